//! GOAL: under `solver.path: arc_length` prescribed displacements follow the load factor (a
//!       step that moves them, alone or with a force, and a force step with them held are
//!       traced by arc length and give load control's equilibria), and sleeve points (slip
//!       unknowns) are traced by arc length too (issue 10, arc length with sleeves and
//!       prescribed displacements; issue 9, one solver loop).
//! MESH, BOUNDARY CONDITIONS, PARAMETERS: (a) the shipped PrestressedCable (half-span 1 m,
//!       EA 1e5 N, pretension 100 N) with its right end moved in x by a displacement input
//!       `shift`; (b) the shipped SlidingCable (sleeve points 7, 8, 9; μ 0, 0.1, 0.3).
//! LOADING: (a) shift 0 → 0.01 m (one step), then P 0 → 1000 N in five steps with shift held,
//!       then shift and P together (0.02 m, 1200 N), then the shift back to 0; (b) the scene's
//!       ten load rows to P = 200 N, p = 20 N.
//! REFERENCE: (a) the same scene under load control (a different path: both converged to the
//!       residual tolerance 1e-9, so outputs agree to 1e-7 relative, the bound of
//!       tests/verification/arc_length.rs; measured values printed), every step with arc-length
//!       increments. (b) In its own test's header below.
use crate::common;
use common::*;
use velarium::scene::PathMethod;
use velarium::Scene;

const FALLBACK: &str = "arc length does not apply";

fn shifted_cable() -> Scene {
    let mut v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(shipped("PrestressedCable")).unwrap())
            .unwrap();
    v["geometry"]["node_sets"]["left"] = serde_json::json!([0]);
    v["geometry"]["node_sets"]["right"] = serde_json::json!([2]);
    v["supports"] = serde_json::json!([
        {"nodes": "left", "fix": ["x", "y", "z"]},
        {"nodes": "right", "fix": ["y", "z"]}
    ]);
    v["inputs"].as_array_mut().unwrap().push(serde_json::json!(
        {"name": "shift", "load": {"kind": "displacement", "nodes": "right", "component": "x"},
         "start": 0, "min": -0.1, "max": 0.1}
    ));
    Scene::from_json(&v.to_string()).unwrap()
}

fn count(log: &[String], what: &str) -> usize {
    log.iter()
        .filter(|l| l.starts_with("increment") && l.contains(what))
        .count()
}

fn compare(a: &velarium::Engine, b: &velarium::Engine, bound: f64, what: &str) -> f64 {
    let mut worst: f64 = 0.0;
    for ((name, va), (_, vb)) in a.outputs().iter().zip(b.outputs()) {
        if name == "newton_iterations" {
            continue;
        }
        let d = (va - vb).abs() / va.abs().max(1e-12);
        worst = worst.max(d);
        assert!(d < bound, "{what}: {name} {va} vs {vb} ({d:.2e})");
    }
    worst
}

#[test]
fn a_prescribed_displacement_under_arc_length() {
    let load_control = shifted_cable();
    let mut arc = load_control.clone();
    arc.solver.path = PathMethod::ArcLength;
    arc.solver.arc_length = Some(2e-3);
    let mut a = engine(load_control);
    let mut b = engine(arc);
    // (shift m, P N): the shift alone, the force with the shift held, both together.
    let steps = [
        (0.01, 0.0),
        (0.01, 200.0),
        (0.01, 400.0),
        (0.01, 600.0),
        (0.01, 800.0),
        (0.01, 1000.0),
        (0.02, 1200.0),
        (0.0, 1200.0),
    ];
    let mut arcs = 0;
    for (shift, p) in steps {
        for e in [&mut a, &mut b] {
            set(e, "shift", shift);
            set(e, "P", p);
        }
        let ra = solve(&mut a);
        let rb = solve(&mut b);
        assert!(!rb.log[0].starts_with(FALLBACK), "{}", rb.log[0]);
        let by_arc = count(&rb.log, "(arc length,");
        assert!(by_arc > 0, "shift {shift}, P {p}: arc-length increments");
        arcs += by_arc;
        let d = compare(&a, &b, 1e-7, &format!("shift {shift} m, P = {p} N"));
        println!(
            "shift {shift} m, P = {p} N: tension {:.6} N, midspan_uz {:.9} m, load control {} iterations, arc length {} iterations ({by_arc} arc-length increments), worst output difference {d:.1e}",
            get(&a, "tension"),
            get(&a, "midspan_uz"),
            ra.iterations,
            rb.iterations
        );
    }
    println!("arc-length increments {arcs}");
}

/// Outputs of `a` and `b` against each other: the largest of |a − b|/max(|a|, 1) (relative
/// for values above 1 in their SI unit, absolute below: positions in m, slips near 0, forces
/// in N), asserted below `bound`; "slipping"/"sticking" counts must be equal.
fn compare_sleeve(a: &velarium::Engine, b: &velarium::Engine, bound: f64, what: &str) -> f64 {
    let mut worst: f64 = 0.0;
    for ((name, va), (_, vb)) in a.outputs().iter().zip(b.outputs()) {
        if name == "newton_iterations" {
            continue;
        }
        let d = (va - vb).abs() / va.abs().max(1.0);
        worst = worst.max(d);
        assert!(d < bound, "{what}: {name} {va} vs {vb} ({d:.2e})");
    }
    worst
}

/// GOAL: sleeve points (slip unknowns, frictionless and frictional, merged contact groups)
///       under `solver.path: arc_length`: the arc-length row is one more bordered row of the
///       one Newton loop, eliminated with the slip rows (src/solver/arc.rs), so a sleeve scene
///       is traced by arc length and gives load control's equilibria.
/// SETUP: the shipped SlidingCable (seed Fig. 6: cable A-7-8-9-B, EA 1e4 N, pretension
///       100 N, sleeve points 7, 8, 9), at μ = 0 (nodes 7 and 9 run to node 8 and merge in the
///       first row), μ = 0.1 (they stick in row 1, then slip with friction and merge in row
///       2) and μ = 0.3 (they stick: a distinct frictional equilibrium held by the contact
///       forces), each once by load control and once by arc length (RMS arc length 0.01 m, so
///       that every row takes several arc-length increments).
/// LOADING: the scene's ten load rows to P = 200 N, p = 20 N, each from the last.
/// REFERENCE: the same scene under load control (a different iteration path to the same
///       equations). Both converge to the residual tolerance 1e-9, so every output agrees to
///       1e-7 (relative above 1, absolute below; the bound of tests/verification/arc_length.rs). With
///       friction the answer depends on the path only through where points stick, and both
///       runs follow the same quasi-static path; an increment across a stick/slip or merge
///       switch is redone by load control (docs/solver.md). Frictionless, nodes 7 and 9 end on
///       node 8 within 1e-6 of the span (tests/verification/sliding_cable.rs). No step is
///       load-controlled as a whole, and arc-length increments are taken at every μ. Measured:
///       worst output difference 3.5e-9 (μ 0), 3.0e-9 (μ 0.1), 2.4e-9 (μ 0.3); iterations per
///       row, load control / arc length: μ 0 [23, 4, 4, 4, 3 …] / [82, 9, 7, 7, 5 …] (the first
///       row's slide at zero load is one load-controlled increment after a failed corrector),
///       μ 0.1 [5, 154, 4, …] / [12, 138, 7, …], μ 0.3 [5, 4, …] / [12, 8, …] (printed).
#[test]
fn sliding_cable_by_arc_length_matches_load_control() {
    for mu in [0.0, 0.1, 0.3] {
        let load_control = read_scene(&shipped("SlidingCable"));
        let mut arc = load_control.clone();
        arc.solver.path = PathMethod::ArcLength;
        arc.solver.arc_length = Some(0.01);
        let mut a = engine(load_control);
        let mut b = engine(arc);
        for e in [&mut a, &mut b] {
            set(e, "mu", mu);
            solve(e);
        }
        let (mut arcs, mut worst) = (0, 0.0f64);
        let (mut its_a, mut its_b) = (Vec::new(), Vec::new());
        for k in 1..=10 {
            let f = k as f64 / 10.0;
            for e in [&mut a, &mut b] {
                set(e, "P", 200.0 * f);
                set(e, "p", 20.0 * f);
            }
            let ra = solve(&mut a);
            let rb = solve(&mut b);
            assert!(!rb.log[0].starts_with(FALLBACK), "{}", rb.log[0]);
            let by_arc = count(&rb.log, "(arc length,");
            arcs += by_arc;
            its_a.push(ra.iterations);
            its_b.push(rb.iterations);
            let d = compare_sleeve(&a, &b, 1e-7, &format!("μ {mu}, row {k}"));
            worst = worst.max(d);
            println!(
                "μ {mu} row {k}: x7 {:.9} x8 {:.9} x9 {:.9}; load control {} iterations / {} increments, arc length {} iterations / {} increments ({by_arc} by arc length, {} redone by load control across a state switch, {} by load control after a failed corrector), difference {d:.1e}",
                get(&b, "x7"),
                get(&b, "x8"),
                get(&b, "x9"),
                ra.iterations,
                ra.increments,
                rb.iterations,
                rb.increments,
                rb.log.iter().filter(|l| l.contains("redone by load control")).count(),
                count(&rb.log, "corrector failed")
            );
        }
        println!(
            "μ {mu}: worst output difference {worst:.1e}; iterations per row: load control {its_a:?}, arc length {its_b:?}; arc-length increments {arcs}"
        );
        assert!(arcs > 0, "μ {mu}: the run used arc length");
        if mu == 0.0 {
            let (x7, x8, x9) = (get(&b, "x7"), get(&b, "x8"), get(&b, "x9"));
            assert!((x7 - x8).abs() < 4e-6 && (x9 - x8).abs() < 4e-6);
        }
    }
}
