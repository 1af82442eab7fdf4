//! Speed against error, printed (not asserted): `cargo run --release --example bench`.
//!
//! For the Hencky disc (docs/mechanics.md §4a, follower pressure, qa/(Eh) = 1e-3, reference
//! w0/a = 0.065404) at several mesh sizes: free DOF, relative error of the centre deflection,
//! wall time of the whole solve (flat start to full load, one step), Newton iterations, time
//! per iteration, and that time divided by the floor (one assembly + one numeric LDLT
//! factorization and solve, measured at the solution). One core (faer runs `Par::Seq`).
//!
//! Then the derivatives of the Hencky disc at the same meshes (issue 12): the first
//! directional derivative d(center_uz)/d(pressure) (it factors the tangent at the equilibrium
//! once), then one more seed (a back-substitution with that factorization), and one adjoint
//! seed, against the time of one Newton iteration of the solve and against the floor.
//!
//! Then the wrinkled Lamé annulus (docs/mechanics.md §4b, ρ = 4, τ = 3, reference L/a = 1.80566)
//! at several meshes: DOF, wrinkled radius (midpoint between the outermost wrinkled and the
//! innermost taut centroid beyond it) and its error in units of the radial element size, the
//! largest hoop stress in the wrinkled zone relative to T_in, time and Newton iterations.
//!
//! Then the shipped WrinkledShear film (Wong & Pellegrino's shear test, docs/mechanics.md §4c),
//! sheared 0 → 3 mm in 20 steps at three pretensions (edge separation 1 mm, the scene's start
//! value, 0.5 mm and 0.1 mm): Newton iterations per step (median and largest), steps that
//! needed cut-back, the relative error of the centre triangle's shear stress S12 against the
//! homogeneous tension-field solution at 3 mm, and the wall time of the whole history.

use std::time::Instant;
use velarium::scene::{Generator, Scene};
use velarium::Engine;

const W_FOLLOWER: f64 = 0.065404;

fn main() {
    hencky();
    hencky_derivatives();
    lame();
    sheared_film();
}

fn sheared_film() {
    use velarium::model::wrinkling::Law;
    const H: f64 = 0.128;
    const STEPS: usize = 20;
    println!();
    println!("WrinkledShear: Kapton 380 x 128 mm, 25 µm, sheared 0 → 3 mm in {STEPS} steps");
    println!(
        "{:>14} {:>7} {:>7} {:>8} {:>10} {:>12} {:>9}",
        "separation mm", "median", "max", "cut back", "wrinkled", "S12 error", "time s"
    );
    let path = format!(
        "{}/modelDescription/WrinkledShear/scene.json",
        env!("CARGO_MANIFEST_DIR")
    );
    let text = std::fs::read_to_string(path).expect("the shipped scene");
    for separation in [1e-3, 5e-4, 1e-4] {
        let mut e =
            Engine::try_new(Scene::from_json(&text).expect("valid JSON")).expect("valid scene");
        let (sep, shear) = (
            value_reference(&e, "separation"),
            value_reference(&e, "shear"),
        );
        e.set_real(sep, separation).unwrap();
        let t = Instant::now();
        let mut iterations = Vec::new();
        let (mut cut, mut failed) = (0, 0);
        assert!(e.solve().converged());
        for k in 1..=STEPS {
            e.set_real(shear, 3e-3 * k as f64 / STEPS as f64).unwrap();
            let r = e.solve();
            iterations.push(r.iterations);
            cut += (r.cutbacks > 0) as usize;
            failed += (!r.converged()) as usize;
        }
        let time = t.elapsed().as_secs_f64();
        let (g, s) = (3e-3 / H, separation / H);
        let strain = nalgebra::Vector3::new(0.0, 0.5 * (g * g + (1.0 + s) * (1.0 + s) - 1.0), g);
        let reference = Law::Svk {
            young: 3.5e9,
            nu: 0.3,
        }
        .response(&strain, None)
        .stress[2];
        let centre = 494;
        let stress = e.model().triangles[centre]
            .reference
            .to_global(&e.membranes()[centre].stress)[(0, 1)];
        let mut sorted = iterations.clone();
        sorted.sort_unstable();
        let median = (sorted[STEPS / 2 - 1] + sorted[STEPS / 2]) as f64 / 2.0;
        let wrinkled = e
            .outputs()
            .iter()
            .find(|(n, _)| n == "wrinkled_fraction")
            .unwrap()
            .1;
        println!(
            "{:>14} {:>7} {:>7} {:>8} {:>10.3} {:>12.2e} {:>9.2}{}",
            separation * 1e3,
            median,
            sorted[STEPS - 1],
            cut,
            wrinkled,
            (stress - reference) / reference,
            time,
            if failed > 0 {
                format!("  ({failed} steps failed)")
            } else {
                String::new()
            }
        );
    }
}

fn lame() {
    const L_OVER_A: f64 = 1.80566;
    println!();
    println!("Lamé annulus, a = 1 m, b = 4 m, τ = 3 (T_out = 1 kPa), reference L/a = {L_OVER_A}");
    println!(
        "{:>6} {:>8} {:>8} {:>9} {:>10} {:>11} {:>9} {:>6}",
        "rings", "sectors", "DOF", "L/a", "error/h", "hoop/T_in", "time s", "iters"
    );
    for (rings, sectors) in [(18usize, 48usize), (36, 96), (72, 192)] {
        let text = format!(
            r#"{{"format": 1, "name": "Lame",
            "geometry": {{"generators": [{{"kind": "annulus", "name": "ring", "center": [0,0,0], "inner_radius": 1, "outer_radius": 4, "rings": {rings}, "sectors": {sectors}}}],
                         "node_sets": {{"east": [0], "north": [{north}]}}}},
            "membranes": [{{"name": "film", "triangles": "ring", "thickness": 1e-3, "material": {{"kind": "svk", "E": 1e6, "nu": 0.3}}}}],
            "supports": [{{"nodes": "ring.all", "fix": ["z"]}}, {{"nodes": "east", "fix": ["y"]}}, {{"nodes": "north", "fix": ["x"]}}],
            "inputs": [{{"name": "inner", "load": {{"kind": "radial_edge_load", "nodes": "ring.inner_rim", "center": [0,0,0], "closed": true}}}},
                       {{"name": "outer", "load": {{"kind": "radial_edge_load", "nodes": "ring.outer_rim", "center": [0,0,0], "closed": true}}}}]}}"#,
            north = sectors / 4
        );
        let mut engine =
            Engine::try_new(Scene::from_json(&text).expect("valid JSON")).expect("valid scene");
        let (inner, outer) = (
            value_reference(&engine, "inner"),
            value_reference(&engine, "outer"),
        );
        let t = Instant::now();
        engine.set_real(outer, 1.0).unwrap();
        engine.set_real(inner, -3.0).unwrap();
        let report = engine.solve();
        let time = t.elapsed().as_secs_f64();
        assert!(report.converged(), "{}", report.message);
        let (mut r_wrinkled, mut hoop) = (0.0f64, 0.0f64);
        let mut radii = Vec::new();
        for (m, tri) in engine.membranes().iter().zip(&engine.model().triangles) {
            let c = tri
                .nodes
                .iter()
                .map(|&i| engine.model().reference[i])
                .sum::<nalgebra::Vector3<f64>>()
                / 3.0;
            let r = c.norm();
            radii.push((r, m.state));
            if m.state == velarium::model::wrinkling::WrinkleState::Wrinkled {
                r_wrinkled = r_wrinkled.max(r);
                let et = nalgebra::Vector3::new(-c.y, c.x, 0.0) / r;
                hoop = hoop
                    .max((et.transpose() * tri.reference.to_global(&m.stress) * et)[0].abs() / 3e3);
            }
        }
        let r_taut = radii
            .iter()
            .filter(|(r, s)| {
                *r > r_wrinkled - 1e-12 && *s != velarium::model::wrinkling::WrinkleState::Wrinkled
            })
            .map(|(r, _)| *r)
            .fold(f64::INFINITY, f64::min);
        let l = 0.5 * (r_wrinkled + r_taut.min(4.0));
        let h = 3.0 / rings as f64;
        println!(
            "{rings:>6} {sectors:>8} {:>8} {l:>9.4} {:>10.2} {hoop:>11.1e} {time:>9.3} {:>6}",
            engine.free_dofs(),
            (l - L_OVER_A) / h,
            report.iterations
        );
    }
}

fn hencky() {
    let path = format!(
        "{}/modelDescription/HenckyDisc/scene.json",
        env!("CARGO_MANIFEST_DIR")
    );
    let base = Scene::from_json(&std::fs::read_to_string(&path).expect("shipped scene"))
        .expect("valid scene");
    let rings: Vec<usize> = std::env::args()
        .skip(1)
        .filter_map(|a| a.parse().ok())
        .collect();
    let rings = if rings.is_empty() {
        vec![8, 16, 32, 64]
    } else {
        rings
    };
    println!("Hencky disc, follower pressure, qa/(Eh) = 1e-3, reference w0/a = {W_FOLLOWER}");
    println!(
        "{:>6} {:>8} {:>11} {:>9} {:>6} {:>12} {:>12} {:>8}",
        "rings", "DOF", "error", "time s", "iters", "s/iter", "floor s", "ratio"
    );
    for n in rings {
        let mut scene = base.clone();
        if let Generator::Disc { rings, .. } = &mut scene.geometry.generators[0] {
            *rings = n;
        }
        // From the flat start on this mesh (its Newton iterations against the floor): no
        // coarse start (docs/solver.md), which `examples/coarse_start.rs` measures.
        scene.solver.coarse_start = velarium::scene::CoarseStart::Off;
        let mut engine = Engine::try_new(scene).expect("valid scene");
        let vr = engine
            .variables()
            .iter()
            .find(|v| v.name == "pressure")
            .unwrap()
            .value_reference;
        let out = engine
            .variables()
            .iter()
            .find(|v| v.name == "center_uz")
            .unwrap()
            .value_reference;
        let t = Instant::now();
        engine.set_real(vr, 40.0).unwrap();
        let report = engine.solve();
        let time = t.elapsed().as_secs_f64();
        assert!(report.converged(), "{}", report.message);
        let w = engine.get_real(out).unwrap() / 0.5;
        let error = (w - W_FOLLOWER).abs() / W_FOLLOWER;
        let (assembly, factor) = engine.time_floor(5);
        let per_iter = time / report.iterations.max(1) as f64;
        let floor = assembly + factor;
        println!(
            "{n:>6} {:>8} {error:>11.3e} {time:>9.4} {:>6} {per_iter:>12.3e} {floor:>12.3e} {:>8.2}",
            engine.free_dofs(),
            report.iterations,
            per_iter / floor
        );
    }
}

fn hencky_derivatives() {
    use velarium::engine::derivatives::Known;
    use velarium::variables::Binding;
    let path = format!(
        "{}/modelDescription/HenckyDisc/scene.json",
        env!("CARGO_MANIFEST_DIR")
    );
    let base = Scene::from_json(&std::fs::read_to_string(&path).expect("shipped scene"))
        .expect("valid scene");
    let rings: Vec<usize> = std::env::args()
        .skip(1)
        .filter_map(|a| a.parse().ok())
        .collect();
    let rings = if rings.is_empty() {
        vec![8, 16, 32, 64]
    } else {
        rings
    };
    println!();
    println!("Hencky disc derivatives d(center_uz)/d(pressure) at q = 40 Pa (best of 5 seeds)");
    println!(
        "{:>6} {:>8} {:>12} {:>12} {:>12} {:>12} {:>10} {:>10}",
        "rings", "DOF", "first s", "seed s", "adjoint s", "Newton s/it", "seed/iter", "seed/floor"
    );
    for n in rings {
        let mut scene = base.clone();
        if let Generator::Disc { rings, .. } = &mut scene.geometry.generators[0] {
            *rings = n;
        }
        // From the flat start on this mesh (its Newton iterations against the floor): no
        // coarse start (docs/solver.md), which `examples/coarse_start.rs` measures.
        scene.solver.coarse_start = velarium::scene::CoarseStart::Off;
        let mut engine = Engine::try_new(scene).expect("valid scene");
        let slot = |e: &Engine, name: &str| match e
            .variables()
            .iter()
            .find(|v| v.name == name)
            .unwrap()
            .binding
        {
            Binding::Input(k) | Binding::Output(k) => k,
            Binding::Parameter(_) => unreachable!(),
        };
        let (input, output) = (slot(&engine, "pressure"), slot(&engine, "center_uz"));
        engine
            .set_real(value_reference(&engine, "pressure"), 40.0)
            .unwrap();
        let t = Instant::now();
        let report = engine.solve();
        let per_iter = t.elapsed().as_secs_f64() / report.iterations.max(1) as f64;
        assert!(report.converged(), "{}", report.message);
        let known = [Known::Input(input)];
        let t = Instant::now();
        engine
            .directional_derivative(&known, &[1.0], &[output])
            .expect("derivative");
        let first = t.elapsed().as_secs_f64();
        let best = |f: &mut dyn FnMut()| {
            (0..5)
                .map(|_| {
                    let t = Instant::now();
                    f();
                    t.elapsed().as_secs_f64()
                })
                .fold(f64::INFINITY, f64::min)
        };
        let seed = best(&mut || {
            engine
                .directional_derivative(&known, &[1.0], &[output])
                .unwrap();
        });
        let adjoint = best(&mut || {
            engine
                .adjoint_derivative(&[output], &[1.0], &known)
                .unwrap();
        });
        let (assembly, factor) = engine.time_floor(5);
        println!(
            "{n:>6} {:>8} {first:>12.3e} {seed:>12.3e} {adjoint:>12.3e} {per_iter:>12.3e} {:>10.3} {:>10.3}",
            engine.free_dofs(),
            seed / per_iter,
            seed / (assembly + factor)
        );
    }
}

/// Value reference of a scene variable.
fn value_reference(e: &Engine, name: &str) -> u32 {
    e.variables()
        .iter()
        .find(|v| v.name == name)
        .expect("a variable of the scene")
        .value_reference
}
