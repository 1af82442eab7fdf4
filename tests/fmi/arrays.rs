//! Array inputs and outputs, and pressure zones.
//!
//! GOAL: (1) an array variable's elements are the scalars FMI 2 declares as `name[i,j]`
//!       (1-based, row-major), and both equal what the model computes for each element;
//!       (2) a pressure zone loads exactly its triangles: a zone covering the whole disc gives
//!       the plain pressure's equilibrium bit for bit (single zone, and a one-element
//!       zone_pressure array); two half-disc zones at the same pressure give the whole-disc
//!       answer up to the order of summation; the north half alone and the south half alone
//!       give mirror images; (3) support displacements move the supports: the same
//!       translation d of all four corners of the shipped ZonedCushion moves every node by d;
//!       (4) the `zone_force` output is the pressure resultant on a zone: with dead pressures
//!       40 Pa (north) and 25 Pa (south) on the disc its z component is q times the zone's
//!       area (Σ of the triangle areas, computed here from the mesh) and its x, y components
//!       vanish; with follower pressures the two zones' z forces balance the rim reaction.
//! MESH: HenckyDisc at 8 rings (384 triangles); the shipped ZonedCushion (8 x 8 cells).
//! BOUNDARY CONDITIONS: rim clamped (disc); corners prescribed (cushion).
//! PARAMETERS: q = 40 Pa on the disc (qa/Eh = 1e-3); d = (0.01, -0.02, 0.03) m.
//! REFERENCE: exact identities. The same arithmetic: bit-identical. Another summation order
//!            (two halves against the whole): 1e-13 of the largest displacement (measured
//!            2.2e-15). Mirror images and the rigid translation: 5e-13 (measured 1.0e-14 and
//!            5.9e-15; the Newton iterates are not mirrored step by step, so only round-off of
//!            the converged answers separates them). Zone force (4): dead, q A to 1e-13
//!            relative (measured 0), x, y below 1e-12 N (measured 0); follower, the sum
//!            against the rim reaction to 1e-10 of the load (what the Newton tolerance leaves
//!            on the free DOFs; measured 9.4e-12).

use crate::common;
use common::*;
use velarium::scene::generate::resolve;
use velarium::scene::{Load, Scene};
use velarium::variables::{element_index, VarType};
use velarium::Engine;

const Q: f64 = 40.0;

fn disc(rings: usize) -> Scene {
    let mut scene = read_scene(&shipped("HenckyDisc"));
    let velarium::scene::Generator::Disc { rings: r, .. } = &mut scene.geometry.generators[0]
    else {
        panic!("HenckyDisc is a disc")
    };
    *r = rings;
    scene
}

/// Triangle ids of the disc whose centroid satisfies `keep`, as a triangle set `name`.
fn add_zone(scene: &mut Scene, name: &str, keep: impl Fn(f64, f64) -> bool) {
    let mesh = resolve(&scene.geometry);
    let ids = mesh
        .triangles
        .iter()
        .enumerate()
        .filter(|(_, t)| {
            let c = t.iter().fold([0.0; 2], |c, &n| {
                [c[0] + mesh.nodes[n][0] / 3.0, c[1] + mesh.nodes[n][1] / 3.0]
            });
            keep(c[0], c[1])
        })
        .map(|(k, _)| k)
        .collect();
    scene.geometry.triangle_sets.insert(name.into(), ids);
}

/// The displacement of every DOF after solving under pressure `q` on each input of the scene.
fn loaded(scene: Scene, q: f64) -> Vec<f64> {
    let mut e = engine(scene);
    solve(&mut e);
    let inputs: Vec<u32> = e
        .variables()
        .iter()
        .filter(|v| v.causality == velarium::variables::Causality::Input)
        .map(|v| v.value_reference)
        .collect();
    for r in inputs {
        e.set_real(r, q).unwrap();
    }
    solve(&mut e);
    e.state().displacement.clone()
}

fn with_load(mut scene: Scene, load: Load) -> Scene {
    scene.inputs[0].load = load;
    scene
}

fn max_abs(u: &[f64]) -> f64 {
    u.iter().fold(0.0, |m, x| m.max(x.abs()))
}

#[test]
fn a_whole_disc_zone_is_the_plain_pressure_bit_for_bit() {
    let mut scene = disc(8);
    add_zone(&mut scene, "everything", |_, _| true);
    let plain = loaded(scene.clone(), Q);
    let zone = loaded(
        with_load(
            scene.clone(),
            Load::Pressure {
                membrane: "film".into(),
                zone: Some("everything".into()),
                follower: true,
            },
        ),
        Q,
    );
    let array = loaded(
        with_load(
            scene,
            Load::ZonePressure {
                membrane: "film".into(),
                zones: vec!["everything".into()],
                follower: true,
            },
        ),
        Q,
    );
    assert!(max_abs(&plain) > 0.01, "the disc deflects");
    assert_eq!(plain, zone);
    assert_eq!(plain, array);
}

#[test]
fn two_half_zones_add_up_to_the_whole_and_mirror_each_other() {
    let mut scene = disc(8);
    add_zone(&mut scene, "north", |_, y| y > 0.0);
    add_zone(&mut scene, "south", |_, y| y <= 0.0);
    let plain = loaded(scene.clone(), Q);
    let halves = loaded(
        with_load(
            scene.clone(),
            Load::ZonePressure {
                membrane: "film".into(),
                zones: vec!["north".into(), "south".into()],
                follower: true,
            },
        ),
        Q,
    );
    let scale = max_abs(&plain);
    let worst = plain
        .iter()
        .zip(&halves)
        .fold(0.0, |m: f64, (a, b)| m.max((a - b).abs()));
    eprintln!(
        "halves vs whole: {:e} of the largest displacement",
        worst / scale
    );
    assert!(
        worst <= 1e-13 * scale,
        "halves differ from the whole by {worst:e} (scale {scale:e})"
    );

    // North alone against south alone: mirror images under y -> -y, on the north and south
    // halves strictly off the axis (both exclude nothing from the mirror map: every node has a
    // mirror node in the disc mesh).
    let mut strict = disc(8);
    add_zone(&mut strict, "north", |_, y| y > 1e-12);
    add_zone(&mut strict, "south", |_, y| y < -1e-12);
    let half = |zone: &str| {
        loaded(
            with_load(
                strict.clone(),
                Load::Pressure {
                    membrane: "film".into(),
                    zone: Some(zone.into()),
                    follower: true,
                },
            ),
            Q,
        )
    };
    let (north, south) = (half("north"), half("south"));
    let mesh = resolve(&strict.geometry);
    let mirror = |i: usize| {
        let p = mesh.nodes[i];
        mesh.nodes
            .iter()
            .position(|q| (q[0] - p[0]).abs() < 1e-12 && (q[1] + p[1]).abs() < 1e-12)
            .expect("the disc mesh is symmetric about y = 0")
    };
    let scale = max_abs(&north);
    assert!(scale > 1e-3, "half a disc deflects");
    let mut worst: f64 = 0.0;
    for i in 0..mesh.nodes.len() {
        let j = mirror(i);
        let (n, s) = (&north[3 * i..3 * i + 3], &south[3 * j..3 * j + 3]);
        worst = worst
            .max((n[0] - s[0]).abs())
            .max((n[1] + s[1]).abs())
            .max((n[2] - s[2]).abs());
    }
    eprintln!(
        "north vs mirrored south: {:e} of the largest displacement",
        worst / scale
    );
    assert!(
        worst <= 5e-13 * scale,
        "north and south are not mirror images: {worst:e} (scale {scale:e})"
    );
}

#[test]
fn zone_force_is_the_pressure_resultant_on_the_zone() {
    let mut scene = disc(8);
    add_zone(&mut scene, "north", |_, y| y > 0.0);
    add_zone(&mut scene, "south", |_, y| y <= 0.0);
    let output = |name: &str, probe: &str| -> velarium::scene::Output {
        serde_json::from_str(&format!(r#"{{"name": "{name}", "probe": {probe}}}"#)).unwrap()
    };
    for (zone, c) in [
        ("north", "x"),
        ("north", "y"),
        ("north", "z"),
        ("south", "z"),
    ] {
        scene.outputs.push(output(
            &format!("F_{zone}_{c}"),
            &format!(r#"{{"kind": "zone_force", "zone": "{zone}", "component": "{c}"}}"#),
        ));
    }
    let mesh = resolve(&scene.geometry);
    let area = |zone: &str| -> f64 {
        mesh.triangle_sets[zone]
            .iter()
            .map(|&t| {
                let [a, b, c] = mesh.triangles[t].map(|i| nalgebra::Vector3::from(mesh.nodes[i]));
                0.5 * (b - a).cross(&(c - a)).norm()
            })
            .sum()
    };
    let (qn, qs) = (40.0, 25.0);
    for follower in [false, true] {
        let mut e = engine(with_load(
            scene.clone(),
            Load::ZonePressure {
                membrane: "film".into(),
                zones: vec!["north".into(), "south".into()],
                follower,
            },
        ));
        solve(&mut e);
        e.set_real(vr(&e, "pressure[1]"), qn).unwrap();
        e.set_real(vr(&e, "pressure[2]"), qs).unwrap();
        solve(&mut e);
        let (fn_z, fs_z) = (get(&e, "F_north_z"), get(&e, "F_south_z"));
        let rim = get(&e, "rim_reaction_z");
        if follower {
            let err = (fn_z + fs_z + rim).abs() / (fn_z + fs_z);
            eprintln!("follower: zone forces {fn_z:.6} + {fs_z:.6} N, rim {rim:.6} N, {err:e}");
            assert!(err < 1e-10, "{err:e}");
        } else {
            let (en, es) = (rel(fn_z, qn * area("north")), rel(fs_z, qs * area("south")));
            let side = get(&e, "F_north_x").abs().max(get(&e, "F_north_y").abs());
            eprintln!("dead: q A within {en:e}, {es:e}; x, y {side:e} N");
            assert!(
                en < 1e-13 && es < 1e-13 && side < 1e-12,
                "{en:e} {es:e} {side:e}"
            );
        }
    }
}

fn cushion() -> Engine {
    let path = format!(
        "{}/modelDescription/ZonedCushion/scene.json",
        env!("CARGO_MANIFEST_DIR")
    );
    engine(read_scene(&path))
}

#[test]
fn array_variables_and_their_fmi2_scalars_agree() {
    let mut e = cushion();
    solve(&mut e);
    set(&mut e, "wind[1]", 200.0);
    set(&mut e, "wind[2]", 80.0);
    solve(&mut e);
    let shapes: Vec<(&str, Vec<usize>, VarType)> = e
        .arrays()
        .iter()
        .map(|v| (v.name.as_str(), v.dims.clone(), v.var_type))
        .collect();
    assert_eq!(
        shapes,
        vec![
            ("wind", vec![2], VarType::Real),
            ("corners", vec![4, 3], VarType::Real),
            ("u", vec![81, 3], VarType::Real),
            ("corner_x", vec![4, 3], VarType::Real),
            ("edge_tension", vec![8], VarType::Real),
            ("stress", vec![128, 2], VarType::Real),
            ("wrinkle", vec![128], VarType::UInt8),
            ("center_uz", vec![], VarType::Real),
            ("newton_iterations", vec![], VarType::Integer),
        ]
    );
    let model = e.model();
    let u = &e.state().displacement;
    for var in e.arrays() {
        let values = e.values(var);
        assert_eq!(values.len(), var.len());
        for (k, x) in values.iter().enumerate() {
            let name = if var.is_array() {
                format!("{}[{}]", var.name, element_index(&var.dims, k))
            } else {
                var.name.clone()
            };
            // The FMI 2 scalar of that name has the value reference of element k.
            assert_eq!(vr(&e, &name), var.value_reference + k as u32, "{name}");
            assert_eq!(get(&e, &name), *x, "{name}");
        }
    }
    let value = |name: &str| {
        let var = e.arrays().iter().find(|v| v.name == name).unwrap();
        e.values(var).to_vec()
    };
    // Row-major: u[i, c] is node i's displacement component c; positions add the reference.
    assert_eq!(value("u"), u[..3 * 81].to_vec());
    for (k, node) in [0usize, 8, 72, 80].iter().enumerate() {
        for c in 0..3 {
            assert_eq!(
                value("corner_x")[3 * k + c],
                model.reference[*node][c] + u[3 * node + c]
            );
        }
    }
    assert_eq!(value("wind"), vec![200.0, 80.0]);
    let tensions = velarium::results::segment_tensions(model, u, 0);
    assert_eq!(value("edge_tension"), tensions);
    for (t, m) in e.membranes().iter().enumerate() {
        assert_eq!(value("stress")[2 * t], m.cauchy.0);
        assert_eq!(value("stress")[2 * t + 1], m.cauchy.1);
        assert_eq!(
            value("wrinkle")[t],
            velarium::results::state_code(m.state) as f64
        );
    }
    assert!(
        value("wrinkle").iter().any(|s| *s != 0.0),
        "some triangles wrinkle"
    );
}

#[test]
fn support_displacements_translate_the_cushion() {
    let mut e = cushion();
    solve(&mut e);
    let before = e.state().displacement.clone();
    let d = [0.01, -0.02, 0.03];
    for corner in 1..=4 {
        for (c, dc) in d.iter().enumerate() {
            set(&mut e, &format!("corners[{corner},{}]", c + 1), *dc);
        }
    }
    solve(&mut e);
    let after = &e.state().displacement;
    let nodes = e.model().reference.len();
    let mut worst: f64 = 0.0;
    for i in 0..nodes {
        for c in 0..3 {
            worst = worst.max((after[3 * i + c] - before[3 * i + c] - d[c]).abs());
        }
    }
    eprintln!("translation: {:e} of |d|max", worst / 0.03);
    assert!(worst <= 5e-13 * 0.03, "not a rigid translation: {worst:e}");
}

#[test]
fn zones_and_arrays_are_validated() {
    let mut scene = disc(2);
    scene.inputs[0].load = Load::ZonePressure {
        membrane: "film".into(),
        zones: vec!["nowhere".into()],
        follower: true,
    };
    let problems = velarium::scene::validate::validate(&scene);
    assert!(
        problems
            .iter()
            .any(|p| p.path == "inputs[0].load.zones[0]" && p.message.contains("nowhere")),
        "{problems:?}"
    );
    let mut scene = disc(2);
    scene.inputs[0].load = Load::SupportDisplacement {
        nodes: velarium::scene::NodeRef::Set("disc.rim".into()),
    };
    let problems = velarium::scene::validate::validate(&scene);
    assert!(
        problems
            .iter()
            .any(|p| p.path == "inputs[0].load.nodes" && p.message.contains("already fixed")),
        "{problems:?}"
    );
    let mut scene = disc(2);
    scene.inputs[0].name = "p[1]".into();
    scene.inputs[0].load = Load::ZonePressure {
        membrane: "film".into(),
        zones: vec!["disc".into()],
        follower: true,
    };
    let problems = velarium::scene::validate::validate(&scene);
    assert!(
        problems
            .iter()
            .any(|p| p.path == "inputs[0].name" && p.message.contains("no [ ]")),
        "{problems:?}"
    );
    let mut scene = disc(2);
    scene.outputs.push(
        serde_json::from_str(
            r#"{"name": "F", "probe": {"kind": "zone_force", "zone": "nowhere", "component": "z"}}"#,
        )
        .unwrap(),
    );
    let n = scene.outputs.len() - 1;
    let problems = velarium::scene::validate::validate(&scene);
    assert!(
        problems
            .iter()
            .any(|p| p.path == format!("outputs[{n}].probe.zone")
                && p.message.contains("no triangle set is named \"nowhere\"")),
        "{problems:?}"
    );
}
