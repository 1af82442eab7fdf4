//! Path following and outcomes: non-convergence is reported and leaves the committed state
//! untouched; the elastic equilibrium does not depend on how the load is split into steps;
//! Newton converges quadratically near the solution; an increment that moves prescribed
//! displacements starts from the tangent predictor.

use crate::common;
use common::*;

#[test]
fn a_failed_step_is_an_outcome_and_commits_nothing() {
    let mut scene = read_scene(&shipped("PrestressedCable"));
    // One Newton iteration per increment and no room to cut back: the step must fail.
    scene.solver.max_iterations = 1;
    scene.solver.min_increment = 0.5;
    let mut e = engine(scene);
    solve(&mut e);
    set(&mut e, "P", 1000.0);
    let before = e.state().clone();
    let outputs = e.outputs();
    let report = e.solve();
    assert!(!report.converged());
    assert!(
        report.message.contains("no equilibrium found"),
        "{}",
        report.message
    );
    assert!(report.cutbacks >= 1);
    assert_eq!(
        e.state(),
        &before,
        "a failed step must not change the committed state"
    );
    assert_eq!(e.outputs(), outputs);
}

#[test]
fn equilibrium_is_independent_of_the_load_steps() {
    let run = |steps: usize| {
        let mut e = engine(read_scene(&shipped("HenckyDisc")));
        solve(&mut e);
        for k in 1..=steps {
            set(&mut e, "pressure", 40.0 * k as f64 / steps as f64);
            solve(&mut e);
        }
        get(&e, "center_uz")
    };
    let (one, ten) = (run(1), run(10));
    // Both are equilibria within the residual tolerance 1e-9; the displacement difference is
    // bounded by it times the tangent's condition, here far below 1e-7.
    assert!(rel(one, ten) < 1e-7, "{one} vs {ten}");
}

#[test]
fn newton_converges_quadratically_near_the_solution() {
    let mut e = engine(read_scene(&shipped("HenckyDisc")));
    solve(&mut e);
    set(&mut e, "pressure", 40.0);
    let report = solve(&mut e);
    // (|R|, scale) of every iteration and of the converged iterate, as the log prints them.
    let field = |l: &str, key: &str| -> Option<f64> {
        l.split(key).nth(1)?.split([' ', ')']).next()?.parse().ok()
    };
    let relative: Vec<f64> = report
        .log
        .iter()
        .filter_map(|l| Some(field(l, "|R| = ")? / field(l, "(scale ")?))
        .collect();
    // Quadratic: r_{k+1} <= C r_k² in residuals relative to the force scale, with C = 100 (the
    // disc's measured constants are 0.1-14 along the path, with the line search on the slope
    // before and after it bracketed the minimum); linear convergence at a rate ρ fails it once
    // r_k < ρ/100, which any linear sequence reaches before its residual drops below 1e-10 (a
    // rate of 0.1 fails at 1e-3). Measured only on pairs whose second residual is
    // above 1e-10 of the scale: below that the residual is round-off (the floor of the
    // convergence test is 16 ε of the element forces, 1e-12 to 1e-11 of the scale here), and a
    // residual at the floor falls no further whatever the rate.
    let pairs: Vec<(f64, f64)> = relative
        .windows(2)
        .map(|w| (w[0], w[1]))
        .filter(|&(a, b)| a < 1e-2 && b > 1e-10)
        .collect();
    assert!(
        !pairs.is_empty(),
        "no iterate in the quadratic range: {relative:?}"
    );
    for (a, b) in pairs {
        assert!(
            b <= 100.0 * a * a,
            "convergence rate not quadratic: {a:.3e} -> {b:.3e} in {relative:?}"
        );
    }
}

#[test]
fn prescribed_displacements_start_from_the_tangent_predictor() {
    // A plain elastic sheet (no wrinkling), bottom edge clamped, top edge pulled up by 1e-7 of
    // its width. The predictor step K_ff Δu_f = −K_fp Δu_p is the linear solution, whose
    // residual is the nonlinearity: of the order of the strain, 1e-7 of the force scale. So
    // the step takes the predictor's factorization and exactly one Newton iteration (quadratic
    // convergence: 1e-7 -> 1e-14 relative, below the tolerance 1e-9). Moving only the top edge
    // would leave one row of strained elements: a first residual of the order of the reaction
    // itself.
    let text = r#"{"format": 1, "name": "Pull",
        "geometry": {"generators": [{"kind": "rectangle", "name": "s", "origin": [0,0,0], "size": [1,1], "divisions": [4,4]}]},
        "membranes": [{"name": "m", "triangles": "s", "thickness": 1e-3, "wrinkling": false, "material": {"kind": "svk", "E": 1e9, "nu": 0.3}}],
        "supports": [{"nodes": "s.edge_bottom", "fix": ["x", "y", "z"]}, {"nodes": "s.all", "fix": ["z"]}],
        "inputs": [{"name": "pull", "load": {"kind": "displacement", "nodes": "s.edge_top", "component": "y"}}],
        "outputs": [{"name": "force", "probe": {"kind": "reaction", "nodes": "s.edge_top", "component": "y"}}]}"#;
    let mut e = engine(velarium::Scene::from_json(text).unwrap());
    solve(&mut e);
    set(&mut e, "pull", 1e-7);
    let report = solve(&mut e);
    let log = report.log.join("\n");
    assert_eq!(report.iterations, 2, "{log}");
    // The first logged residual (after the predictor) relative to its force scale.
    let first = report
        .log
        .iter()
        .find(|l| l.contains("iteration 1:"))
        .expect("one iteration");
    let number = |key: &str| -> f64 {
        first
            .split(key)
            .nth(1)
            .unwrap()
            .split([' ', ')', ','])
            .next()
            .unwrap()
            .parse()
            .unwrap()
    };
    let relative = number("|R| = ") / number("(scale ");
    assert!(
        relative < 1e-6,
        "residual after the predictor {relative:e} of the scale:\n{log}"
    );
    assert!(get(&e, "force") > 0.0);
}
