//! GOAL: the seed paper's observation (§4, Fig. 5a/5b): a flat membrane lifted normal to its
//!       plane is singular at the start; an artificial prestress of 10 or 200 N/m² gets the
//!       iteration going, changes the iteration path, and does not change the equilibrium.
//! MESH: the shipped LiftedMembrane scene (1.0 m x 0.6 m, 20 x 12 cells, crossed diagonals,
//!       edge cables along the long edges).
//! BOUNDARY CONDITIONS: short edges clamped; centre node loaded by the lifting force.
//! PARAMETERS: film E = 200 MPa, ν = 0.3, t = 0.1 mm; cables EA = 2e4 N, pretension 20 N.
//! REFERENCE: seed paper §4 (docs/mechanics.md §0): prestress "influences only the iteration path".
//!            The two equilibria must agree within the solver tolerance: the residual
//!            criterion 1e-9 bounds the displacement difference by about 1e-9 relative times
//!            the condition of the tangent; we require 1e-7 relative on every output.

mod common;
use common::*;

fn lift(prestress: f64, force: f64) -> (Vec<(String, f64)>, usize) {
    let mut scene = read_scene(&shipped("LiftedMembrane"));
    scene.solver.artificial_prestress = Some(prestress);
    let mut e = engine(scene);
    solve(&mut e);
    set(&mut e, "lift_force", force);
    let report = solve(&mut e);
    (e.outputs(), report.iterations)
}

#[test]
fn equilibrium_does_not_depend_on_the_artificial_prestress() {
    let (a, iters_10) = lift(10.0, 50.0);
    let (b, iters_200) = lift(200.0, 50.0);
    for ((name, x), (_, y)) in a.iter().zip(&b) {
        if name == "newton_iterations" {
            continue;
        }
        assert!(
            (x - y).abs() <= 1e-7 * x.abs().max(1e-12),
            "{name}: {x} (10 N/m²) vs {y} (200 N/m²)"
        );
    }
    assert_ne!(
        iters_10, iters_200,
        "the prestress changes the iteration path"
    );
    let lift = a.iter().find(|(n, _)| n == "lift").unwrap().1;
    assert!(lift > 0.01, "the centre is lifted: {lift}");
    println!("iterations: prestress 10 N/m²: {iters_10}, 200 N/m²: {iters_200}");
}

#[test]
fn reaction_balances_the_lifting_force() {
    let (out, _) = lift(200.0, 50.0);
    let r = out.iter().find(|(n, _)| n == "reaction_z").unwrap().1;
    assert!((r + 50.0).abs() < 1e-7 * 50.0, "reaction {r}");
}

#[test]
fn without_prestress_the_flat_start_is_singular_and_reported_not_hidden() {
    // With no artificial prestress the first tangent has no out-of-plane stiffness at all.
    // The solver must end with a clear outcome (converged thanks to regularised pivots, or a
    // failure report) and never panic or return non-finite outputs.
    let mut scene = read_scene(&shipped("LiftedMembrane"));
    scene.solver.artificial_prestress = Some(0.0);
    let mut e = engine(scene);
    solve(&mut e);
    set(&mut e, "lift_force", 50.0);
    let report = e.solve();
    for (name, v) in e.outputs() {
        assert!(v.is_finite(), "{name} = {v}");
    }
    if !report.converged() {
        assert!(!report.message.is_empty());
    }
}
