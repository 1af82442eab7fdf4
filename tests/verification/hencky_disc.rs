//! GOAL: a flat clamped circular membrane under uniform pressure (the singular flat start)
//!       reaches the exact-kinematics Hencky deflection, for dead and follower pressure, and
//!       the error falls as the mesh is refined.
//! MESH: disc generator, `rings` rings of near-equilateral CST triangles (ring k has 6k nodes).
//! BOUNDARY CONDITIONS: rim clamped (x, y, z).
//! PARAMETERS: a = 0.5 m, h = 0.1 mm, E = 200 MPa, ν = 0.3, q = 40 Pa, so qa/(Eh) = 1e-3; also
//!       the orthotropic law at E_warp = E_fill = E, nu_wf = ν, G = E/(2(1+ν)).
//! REFERENCE: docs/mechanics.md §4a, exact-kinematics table (axisymmetric SVK membrane with finite
//!            rotations, shooting): w0/a = 0.065338 (dead: load per reference area along z)
//!            and 0.065404 (follower). The CST discretisation error is O(h²): measured
//!            6.21e-3, 1.74e-3, 4.79e-4 at 5, 10, 20 rings (follower; ratios 3.6 per halving of
//!            h) and 4.77e-4 at 20 rings (dead). Tolerance 1e-3 at 20 rings (about 2x the
//!            measured error, which the solver tolerance 1e-9 does not move), and each halving
//!            of h must cut the error by more than 3 (the O(h²) rate, 4, less round-off of
//!            the reference's 5 digits).

use crate::common;
use common::*;

const A: f64 = 0.5;
const Q: f64 = 40.0;
const W_DEAD: f64 = 0.065338;
const W_FOLLOWER: f64 = 0.065404;

fn deflection(rings: usize, follower: bool) -> f64 {
    deflection_with(rings, follower, None)
}

/// [`deflection`], with the orthotropic law at E_warp = E_fill and this warp if given.
fn deflection_with(rings: usize, follower: bool, warp: Option<[f64; 3]>) -> f64 {
    let mut scene = read_scene(&shipped("HenckyDisc"));
    if let Some(w) = warp {
        equal_warp_and_fill(&mut scene, w);
    }
    let velarium::scene::Generator::Disc { rings: r, .. } = &mut scene.geometry.generators[0]
    else {
        panic!("HenckyDisc is a disc")
    };
    *r = rings;
    let velarium::scene::Load::Pressure { follower: f, .. } = &mut scene.inputs[0].load else {
        panic!("HenckyDisc is loaded by pressure")
    };
    *f = follower;
    let mut e = engine(scene);
    solve(&mut e);
    set(&mut e, "pressure", Q);
    solve(&mut e);
    get(&e, "center_uz") / A
}

#[test]
fn follower_pressure_within_1e3_and_converging_as_h_squared() {
    let errors: Vec<f64> = [5, 10, 20]
        .iter()
        .map(|&n| rel(deflection(n, true), W_FOLLOWER))
        .collect();
    println!("follower errors at 5, 10, 20 rings: {errors:?}");
    assert!(errors[2] < 1e-3, "20 rings: error {:.3e}", errors[2]);
    assert!(
        errors[0] > 3.0 * errors[1] && errors[1] > 3.0 * errors[2],
        "error must fall as h² with refinement: {errors:?}"
    );
}

/// The orthotropic law with E_warp = E_fill = E, nu_wf = ν, G = E/(2(1+ν)) (warp along x and
/// along (1, 2, 0)) gives the same deflection at 20 rings, follower pressure: within 1e-3 of
/// Hencky and within 2e-14 of the SVK answer (measured 8.5e-16 and 2.1e-16: the laws agree to
/// round-off and the disc's taut Newton path is the same).
#[test]
fn equal_warp_and_fill_reproduces_hencky() {
    let iso = deflection(20, true);
    for warp in [[1.0, 0.0, 0.0], [1.0, 2.0, 0.0]] {
        let w = deflection_with(20, true, Some(warp));
        println!("warp {warp:?}: w0/a {w}, vs SVK {:e}", rel(w, iso));
        assert!(rel(w, W_FOLLOWER) < 1e-3, "w0/a = {w} vs {W_FOLLOWER}");
        assert!(rel(w, iso) < 2e-14, "w0/a = {w} vs SVK {iso}");
    }
}

#[test]
fn dead_pressure_within_1e3() {
    let w = deflection(20, false);
    println!("dead 20 rings: error {:e}", rel(w, W_DEAD));
    assert!(rel(w, W_DEAD) < 1e-3, "w0/a = {w} vs {W_DEAD}");
}

/// Vertical equilibrium: the rim reaction carries the whole load, q times the projected area
/// of the deformed disc for follower pressure (= π a² since the rim does not move).
#[test]
fn rim_reaction_balances_the_pressure() {
    let mut e = engine(read_scene(&shipped("HenckyDisc")));
    solve(&mut e);
    set(&mut e, "pressure", Q);
    solve(&mut e);
    // Projected area of the 96-gon rim (16 rings), not of the circle.
    let n = 96.0;
    let area = 0.5 * n * A * A * (2.0 * std::f64::consts::PI / n).sin();
    let r = get(&e, "rim_reaction_z");
    assert!(
        rel(-r, Q * area) < 1e-8,
        "reaction {r} vs load {}",
        Q * area
    );
}

/// Unloading back towards the singular flat state: from q = 40 Pa to q = 0.04 Pa in one step,
/// qa/(Eh) = 1e-6, where the deflection is the small-rotation Hencky value
/// w0/a = 0.65343 (qa/Eh)^(1/3) (docs/mechanics.md §4a, ν = 0.3, table row 1e-4: the coefficient no
/// longer depends on the load). Measured 7.5e-4 at the shipped 16 rings (the O(h²) mesh error,
/// the same as at qa/Eh = 1e-3 on this mesh); tolerance 2e-3.
/// The step must also go through without internal cut-back: near the flat state the membrane
/// stress is tiny, and the artificial prestress (fading with the residual) must not make the
/// last iterations crawl.
#[test]
fn unloading_towards_the_flat_state_follows_hencky() {
    let mut e = engine(read_scene(&shipped("HenckyDisc")));
    solve(&mut e);
    set(&mut e, "pressure", Q);
    solve(&mut e);
    set(&mut e, "pressure", Q * 1e-3);
    let report = solve(&mut e);
    assert_eq!(report.increments, 1, "{}", report.log.join("\n"));
    let expected = 0.65343 * (1e-6f64).cbrt();
    let w = get(&e, "center_uz") / A;
    println!("unloaded: w0/a {w} vs {expected}: {:e}", rel(w, expected));
    assert!(rel(w, expected) < 2e-3, "w0/a = {w} vs {expected}");
}
