//! GOAL: wrinkling inside the element under homogeneous finite shear: picture-frame shear,
//!       simple shear, and the onset of wrinkling in a pretensioned sheet under shear.
//! MESH: unit square, 4 x 4 cells, crossed diagonals; interior nodes free.
//! BOUNDARY CONDITIONS: every boundary node prescribed (x and y) to the homogeneous
//!       deformation x = F X; every node held in z (in-plane problem).
//! PARAMETERS: SVK E = 1 Pa, ν = 0.3, t = 1 m (so stresses read directly as S/E); every check
//!       is repeated with the orthotropic law at E_warp = E_fill = E, nu_wf = ν,
//!       G = E/(2(1+ν)), warp along x and at 30° (onset: at 45°), to the same tolerances.
//! REFERENCE: docs/mechanics.md §4d (Wagner tension field / picture frame: S11 = S22 = S12 =
//!            E sin γ/4, tension at 45°; simple shear table; nominal traction P·e2 on the top
//!            edge) — stresses and the top-edge reaction to 1e-9 relative (the field is
//!            homogeneous, so any mesh must reproduce it to round-off); docs/mechanics.md §4c onset
//!            γ_c = 2√ν ε0/(1 − ν) for pretension ε0 (small strain; checked at ±3 %).

use crate::common;
use common::*;
use velarium::model::wrinkling::WrinkleState;
use velarium::scene::Scene;

/// A square whose boundary nodes are each driven by their own x and y inputs.
fn square(n: usize) -> (Scene, Vec<(usize, [f64; 2])>) {
    let mut inputs = Vec::new();
    let mut sets = Vec::new();
    let mut boundary = Vec::new();
    for j in 0..=n {
        for i in 0..=n {
            if i == 0 || j == 0 || i == n || j == n {
                let id = j * (n + 1) + i;
                let x = [i as f64 / n as f64, j as f64 / n as f64];
                boundary.push((id, x));
                sets.push(format!(r#""b{id}": [{id}]"#));
                for c in ["x", "y"] {
                    inputs.push(format!(r#"{{"name": "u{id}{c}", "load": {{"kind": "displacement", "nodes": "b{id}", "component": "{c}"}}}}"#));
                }
            }
        }
    }
    let top: Vec<usize> = (0..=n).map(|i| n * (n + 1) + i).collect();
    let text = format!(
        r#"{{"format": 1, "name": "Square",
        "geometry": {{"generators": [{{"kind": "rectangle", "name": "sq", "origin": [0,0,0], "size": [1,1], "divisions": [{n},{n}]}}],
                     "node_sets": {{{sets}, "top": {top:?}}}}},
        "membranes": [{{"name": "film", "triangles": "sq", "thickness": 1, "material": {{"kind": "svk", "E": 1, "nu": 0.3}}}}],
        "supports": [{{"nodes": "sq.all", "fix": ["z"]}}],
        "inputs": [{inputs}],
        "outputs": [{{"name": "Px", "probe": {{"kind": "reaction", "nodes": "top", "component": "x"}}}},
                    {{"name": "Py", "probe": {{"kind": "reaction", "nodes": "top", "component": "y"}}}},
                    {{"name": "wrinkled", "probe": {{"kind": "wrinkled_fraction"}}}}]}}"#,
        sets = sets.join(", "),
        inputs = inputs.join(", ")
    );
    (Scene::from_json(&text).unwrap(), boundary)
}

/// Impose x = F X on the boundary, solve, return the engine; with the orthotropic law at E_warp = E_fill and this warp direction if given.
fn deform_with(f: [[f64; 2]; 2], warp: Option<[f64; 3]>) -> velarium::Engine {
    let (mut scene, boundary) = square(4);
    if let Some(w) = warp {
        equal_warp_and_fill(&mut scene, w);
    }
    let mut e = engine(scene);
    solve(&mut e);
    for (id, x) in boundary {
        let ux = f[0][0] * x[0] + f[0][1] * x[1] - x[0];
        let uy = f[1][0] * x[0] + f[1][1] * x[1] - x[1];
        set(&mut e, &format!("u{id}x"), ux);
        set(&mut e, &format!("u{id}y"), uy);
    }
    solve(&mut e);
    e
}

/// Global [S11, S22, S12] of every triangle (element frames differ from triangle to triangle).
fn global_stresses(e: &velarium::Engine) -> Vec<[f64; 3]> {
    e.membranes()
        .iter()
        .zip(&e.model().triangles)
        .map(|(m, t)| {
            let g = t.reference.to_global(&m.stress);
            [g[(0, 0)], g[(1, 1)], g[(0, 1)]]
        })
        .collect()
}

fn check(f: [[f64; 2]; 2], stress: [f64; 3], angle_deg: f64, traction: [f64; 2]) {
    check_with(f, stress, angle_deg, traction, None);
    // The orthotropic law with equal warp and fill moduli passes the same checks, warp along
    // x and at 30° to it.
    for warp in [[1.0, 0.0, 0.0], [3f64.sqrt(), 1.0, 0.0]] {
        check_with(f, stress, angle_deg, traction, Some(warp));
    }
}

fn check_with(
    f: [[f64; 2]; 2],
    stress: [f64; 3],
    angle_deg: f64,
    traction: [f64; 2],
    warp: Option<[f64; 3]>,
) {
    let e = deform_with(f, warp);
    let stresses = global_stresses(&e);
    for (k, (m, s)) in e.membranes().iter().zip(&stresses).enumerate() {
        assert_eq!(m.state, WrinkleState::Wrinkled, "triangle {k}");
        for i in 0..3 {
            // The reference prints 7 significant digits.
            assert!(
                (s[i] - stress[i]).abs() <= 1e-6 * stress[i].abs(),
                "triangle {k} S[{i}] {} vs {}",
                s[i],
                stress[i]
            );
        }
        // Homogeneous field: every triangle has the same stress to round-off.
        for i in 0..3 {
            assert!(
                (s[i] - stresses[0][i]).abs() <= 1e-9 * stress[0].abs(),
                "triangle {k} differs from triangle 0"
            );
        }
        // Tension direction of every triangle, in global axes.
        let d = e.model().triangles[k].reference.direction(m.angle);
        let angle = d.y.atan2(d.x).to_degrees().rem_euclid(180.0);
        assert!(
            (angle - angle_deg).abs() < 1e-4,
            "triangle {k} tension angle {angle} vs {angle_deg}"
        );
    }
    // Top-edge reaction = nominal traction P·e2 times the edge length (1 m) and thickness (1 m);
    // the supports pull, so the reaction on the structure equals the traction applied to it.
    for (name, t) in [("Px", traction[0]), ("Py", traction[1])] {
        let r = get(&e, name);
        assert!((r - t).abs() <= 1e-6 * t.abs(), "{name} {r} vs {t}");
    }
    assert!((get(&e, "wrinkled") - 1.0).abs() < 1e-15);
}

#[test]
fn picture_frame_shear() {
    for (gamma, s, tr) in [
        (0.01f64, 2.499958e-3, [2.524958e-3, 2.499833e-3]),
        (0.1, 2.495835e-2, [2.745003e-2, 2.483367e-2]),
    ] {
        let f = [[1.0, gamma.sin()], [0.0, gamma.cos()]];
        check(f, [s, s, s], 45.0, tr);
    }
}

#[test]
fn simple_shear() {
    check(
        [[1.0, 0.01], [0.0, 1.0]],
        [2.499969e-3, 2.525094e-3, 2.512500e-3],
        45.1432,
        [2.537751e-3, 2.525094e-3],
    );
    check(
        [[1.0, 0.1], [0.0, 1.0]],
        [2.496881e-2, 2.759365e-2, 2.624844e-2],
        46.4312,
        [2.900781e-2, 2.759365e-2],
    );
}

#[test]
fn wrinkling_starts_at_the_onset_shear_of_a_pretensioned_sheet() {
    let (eps0, nu) = (1e-3, 0.3f64);
    let gamma_c = 2.0 * nu.sqrt() * eps0 / (1.0 - nu);
    for warp in [None, Some([1.0, 1.0, 0.0])] {
        let below = deform_with([[1.0, 0.97 * gamma_c], [0.0, 1.0 + eps0]], warp);
        assert_eq!(
            get(&below, "wrinkled"),
            0.0,
            "taut below the onset ({warp:?})"
        );
        let above = deform_with([[1.0, 1.03 * gamma_c], [0.0, 1.0 + eps0]], warp);
        assert_eq!(
            get(&above, "wrinkled"),
            1.0,
            "wrinkled above the onset ({warp:?})"
        );
    }
}
