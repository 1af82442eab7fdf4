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

mod common;
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
