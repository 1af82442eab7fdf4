//! GOAL: the SleeveDrawstring scene (examples/SleeveDrawstring.json, not yet shipped) (second reading of seed Fig. 1: 2P on the two cable
//!       ends, P each in +x, the cable in a sleeve along the free right edge from B to A)
//!       gathers its sleeved edge: A moves down and B up by the same amount, the cable length in
//!       the sleeve L_c shrinks below its unloaded 0.080 m, the sheet wrinkles and the cable
//!       slips; and (ignored, an open solver defect) it solves Table 1's load path.
//! MESH: the scene's 8 x 8 rubber sheet with a 9-point sleeve on the right edge.
//! BOUNDARY CONDITIONS: as shipped (left edge clamped, everything in the sheet's plane, 0.15 N
//!       along the sleeve on each cable end, 2P shared by the two ends).
//! PARAMETERS: the scene's start values (mu_rubber 3e5 Pa, mu_friction 0.3);
//!       2P = 0, 0.05, 0.10, 0.15 N (the range the current solver reaches: 2P = 0.20 N fails,
//!       docs/mechanics.md §7), and Table 1's 0, 1, 2, 4, 5 N for the ignored test.
//! REFERENCE: mirror symmetry of the scene about y = 40 mm (geometry, supports, loads):
//!       A_dy = -B_dy to 1e-6 relative (measured below 1e-9); L_c = 0.080 m unloaded (the
//!       sleeve's length). Tie gap below 1e-3 of the segment length (docs/mechanics.md §2.3).

use crate::common;
use common::*;

const SCENE: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/examples/SleeveDrawstring.json"
);

#[test]
fn drawstring_gathers_the_sleeved_edge_symmetrically() {
    let mut e = engine(read_scene(SCENE));
    let mut prev_lc = f64::INFINITY;
    let mut prev_ady = f64::INFINITY;
    for (k, p) in [0.0, 0.05, 0.10, 0.15].into_iter().enumerate() {
        set(&mut e, "force_2P", p);
        let report = solve(&mut e);
        let (a_dy, b_dy, lc) = (get(&e, "A_dy"), get(&e, "B_dy"), get(&e, "L_c"));
        println!(
            "2P {p}: A_dx {:.6e} A_dy {a_dy:.9e} B_dy {b_dy:.9e} L_c {lc:.6} slipping {} wrinkled {:.3} gap {:.1e} iterations {}",
            get(&e, "A_dx"),
            get(&e, "slipping"),
            get(&e, "wrinkled_fraction"),
            get(&e, "contact_gap"),
            report.iterations
        );
        if k == 0 {
            assert_eq!(lc, 0.080, "unloaded L_c");
            continue;
        }
        assert!(
            (a_dy + b_dy).abs() <= 1e-6 * b_dy.abs(),
            "mirror symmetry: A_dy {a_dy:e} = -B_dy {b_dy:e}"
        );
        assert!(a_dy < prev_ady && a_dy < 0.0, "A moves down as 2P grows");
        assert!(lc < prev_lc && lc < 0.080, "the sleeved edge is gathered");
        assert!(get(&e, "A_dx") > 0.0, "A is pulled out in +x");
        assert!(get(&e, "wrinkled_fraction") > 0.5, "the sheet wrinkles");
        assert!(get(&e, "slipping") >= 1.0, "the cable slips");
        assert!(get(&e, "contact_gap") < 1e-3);
        prev_lc = lc;
        prev_ady = a_dy;
    }
}

/// Open defect (reported, docs/mechanics.md §7): with the current solver the step 2P = 0 -> 1 N
/// stops at load fraction 0.19 (2P = 0.19 N): "no convergence in 40 iterations" or "a membrane
/// element inverted or collapsed" in the gathered edge. Run with `--ignored` to see it.
#[test]
#[ignore = "SleeveDrawstring does not converge beyond 2P = 0.19 N with the current solver (docs/mechanics.md §7)"]
fn drawstring_solves_table1_load_path() {
    let mut e = engine(read_scene(SCENE));
    for p in [0.0, 1.0, 2.0, 4.0, 5.0] {
        set(&mut e, "force_2P", p);
        solve(&mut e);
        println!(
            "2P {p}: A_dx {:.4e} A_dy {:.4e} B_dy {:.4e} L_c {:.5}",
            get(&e, "A_dx"),
            get(&e, "A_dy"),
            get(&e, "B_dy"),
            get(&e, "L_c")
        );
    }
}

/// GOAL: can displacement control (the cable ends' x displacement prescribed instead of the
///       force 2P) trace the drawstring reading further than force control (which stops near
///       2P = 0.19-0.20 N)? Measured answer: no; 2P still rises with the shift (no force limit
///       point is passed) and the path stops at an end shift of 17.3 mm, 2P = 0.195 N, where
///       a corner triangle of the gathered edge collapses (area ratio below 1e-6; L_c down
///       from 80 to 58.5 mm, A_dy = -B_dy = -10.75 mm). Arc length does not apply (sleeve
///       points: docs/solver.md).
/// MESH, BOUNDARY CONDITIONS, PARAMETERS: the scene as above, its input force_2P replaced by a
///       displacement input `end_shift` (x of both cable ends); 2P read as the x reaction at
///       the ends. Shifts 0.5, 1.25, 2.5, 5, 7.5, 10, 12.5, 15 mm, then 20 mm.
/// REFERENCE: mirror symmetry (A_dy = -B_dy to 1e-6 relative) and 2P increasing with the
///       shift at every converged row; the 15 mm row reaches 2P > 0.17 N (measured 0.179 N;
///       path-dependent by friction: finer steps gave 0.182 N at 15.4 mm, the largest 0.1948
///       N at 17.32 mm); the 20 mm step fails (by the rule a converged answer is never wrong
///       silently). With penalty ties and the budget counted in Newton iterations (500) it
///       failed naming a collapsed element at load fraction 0.461 of the step (17.31 mm); with
///       the ties closed by their multipliers (extra Newton iterations for the multiplier
///       updates) and the budget counted as work (line-search trials and relaxation rounds
///       included, 1000) the budget is spent at MEASURED, before the corner collapses: the
///       failure names the spent budget.
#[test]
fn drawstring_under_displacement_control_stops_at_a_collapsed_corner() {
    let text = std::fs::read_to_string(format!(
        "{}/examples/SleeveDrawstring.json",
        env!("CARGO_MANIFEST_DIR")
    ))
    .unwrap();
    let mut v: serde_json::Value = serde_json::from_str(&text).unwrap();
    v["inputs"][0] = serde_json::json!({"name": "end_shift",
        "load": {"kind": "displacement", "nodes": "cable_ends", "component": "x"},
        "start": 0, "min": 0, "max": 0.05});
    v["outputs"]
        .as_array_mut()
        .unwrap()
        .push(serde_json::json!({"name": "force_2P",
            "probe": {"kind": "reaction", "nodes": "cable_ends", "component": "x"}}));
    let mut e = engine(velarium::Scene::from_json(&v.to_string()).unwrap());
    solve(&mut e);
    let mut last = 0.0;
    for shift in [0.5, 1.25, 2.5, 5.0, 7.5, 10.0, 12.5, 15.0] {
        set(&mut e, "end_shift", shift * 1e-3);
        let r = solve(&mut e);
        let (p, a, b) = (get(&e, "force_2P"), get(&e, "A_dy"), get(&e, "B_dy"));
        println!(
            "end shift {shift} mm: 2P {p:.4} N, A_dx {:.2} mm, A_dy {:.2} mm, B_dy {:.2} mm, L_c {:.2} mm, slipping/sticking {}/{}, wrinkled {:.2}, {} iterations",
            1e3 * get(&e, "A_dx"),
            1e3 * a,
            1e3 * b,
            1e3 * get(&e, "L_c"),
            get(&e, "slipping"),
            get(&e, "sticking"),
            get(&e, "wrinkled_fraction"),
            r.iterations
        );
        assert!(p > last, "2P rises with the shift: {p} after {last}");
        assert!((a + b).abs() <= 1e-6 * a.abs(), "symmetry: {a} vs {b}");
        last = p;
    }
    assert!(last > 0.17, "2P at 15 mm: {last}");
    set(&mut e, "end_shift", 0.02);
    let r = e.solve();
    println!("end shift 20 mm: {}", r.message);
    assert!(
        !r.converged() && r.message.contains("solver.max_step_iterations"),
        "{}",
        r.message
    );
}
