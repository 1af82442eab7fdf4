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
//!            the condition of the tangent; measured 1.1e-10 of the largest displacement over
//!            the whole field, required 1e-9, and the same wrinkle state in every triangle.

use crate::common;
use common::*;

/// The lifted equilibrium with `prestress` N/m² of artificial prestress: outputs, the whole
/// displacement field, the wrinkle state of every triangle, Newton iterations and the outcome.
struct Lifted {
    outputs: Vec<(String, f64)>,
    displacement: Vec<f64>,
    wrinkle: Vec<velarium::model::wrinkling::WrinkleState>,
    iterations: usize,
    converged: bool,
    message: String,
}

fn lift_state(prestress: f64, force: f64) -> Lifted {
    let mut scene = read_scene(&shipped("LiftedMembrane"));
    scene.solver.artificial_prestress = Some(prestress);
    let mut e = engine(scene);
    solve(&mut e);
    set(&mut e, "lift_force", force);
    let report = e.solve();
    Lifted {
        outputs: e.outputs(),
        displacement: e.state().displacement.clone(),
        wrinkle: e.state().wrinkle.clone(),
        iterations: report.iterations,
        converged: report.converged(),
        message: report.message,
    }
}

/// Largest displacement difference relative to the largest displacement.
fn field_difference(a: &[f64], b: &[f64]) -> f64 {
    let scale = a.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    a.iter()
        .zip(b)
        .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()))
        / scale
}

fn lift(prestress: f64, force: f64) -> (Vec<(String, f64)>, usize) {
    let l = lift_state(prestress, force);
    assert!(l.converged, "prestress {prestress}: {}", l.message);
    (l.outputs, l.iterations)
}

#[test]
fn equilibrium_does_not_depend_on_the_artificial_prestress() {
    let a = lift_state(10.0, 50.0);
    let b = lift_state(200.0, 50.0);
    assert!(a.converged && b.converged, "{} / {}", a.message, b.message);
    // The whole field, not a few outputs (one of which, the reaction, equals the load at any
    // equilibrium): every displacement component within 1e-9 of the largest displacement
    // (measured 1.1e-10: both points meet the residual tolerance 1e-9 of the forces).
    let d = field_difference(&a.displacement, &b.displacement);
    assert!(
        d < 1e-9,
        "displacement fields differ by {d:e} of the largest displacement"
    );
    assert_eq!(a.wrinkle, b.wrinkle, "wrinkle state of every triangle");
    assert_ne!(
        a.iterations, b.iterations,
        "the prestress changes the iteration path"
    );
    let lift = a.outputs.iter().find(|(n, _)| n == "lift").unwrap().1;
    assert!(lift > 0.01, "the centre is lifted: {lift}");
    println!(
        "iterations: prestress 10 N/m²: {}, 200 N/m²: {}; field difference {d:.1e}",
        a.iterations, b.iterations
    );
}

#[test]
fn reaction_balances_the_lifting_force() {
    let (out, _) = lift(200.0, 50.0);
    let r = out.iter().find(|(n, _)| n == "reaction_z").unwrap().1;
    assert!((r + 50.0).abs() < 1e-7 * 50.0, "reaction {r}");
}

#[test]
fn without_prestress_the_flat_start_reaches_the_same_equilibrium() {
    // With no artificial prestress the first tangent has no out-of-plane stiffness at all:
    // the LDLT regularises the zero pivots and the damped Newton (src/solver/newton.rs) takes
    // the iteration off the flat state. The equilibrium exists and is the one the prestressed
    // runs find: the same displacement field within 1e-9 (measured 7.6e-11) and the same
    // wrinkle states.
    let none = lift_state(0.0, 50.0);
    assert!(none.converged, "{}", none.message);
    let reference = lift_state(200.0, 50.0);
    let d = field_difference(&reference.displacement, &none.displacement);
    assert!(d < 1e-9, "displacement fields differ by {d:e}");
    assert_eq!(none.wrinkle, reference.wrinkle);
    println!(
        "no prestress: {} iterations, field difference {d:.1e}",
        none.iterations
    );
}
