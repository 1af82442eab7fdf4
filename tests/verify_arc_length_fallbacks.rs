//! GOAL: under `solver.path: arc_length` the steps the arc-length corrector does not take
//!       (moving prescribed displacements, sleeve points, volume inputs: docs/solver.md, arc
//!       length) are load-controlled as a whole, the step's log says so, and the answers equal
//!       load control; a prescribed displacement that is held while a force rises does not stop
//!       arc length, and its equilibria equal load control's (issue 10, arc length with
//!       sleeves, volume inputs and prescribed displacements).
//! MESH, BOUNDARY CONDITIONS, PARAMETERS: (a) the shipped PrestressedCable (half-span 1 m,
//!       EA 1e5 N, pretension 100 N) with its right end free in x and moved by a displacement
//!       input `shift`; (b) the shipped SlidingCable (frictionless sleeve points 7, 8, 9).
//! LOADING: (a) shift 0 → 0.01 m (one step), then P 0 → 1000 N in five steps with shift held,
//!       then shift and P together (0.02 m, 1200 N); (b) the scene's ten load rows to P = 200 N,
//!       p = 20 N.
//! REFERENCE: the same scenes under load control (a different path for (a)'s force steps: both
//!       converged to the residual tolerance 1e-9, so outputs agree to 1e-7 relative, the bound
//!       of tests/verify_arc_length.rs; measured values printed). The load-controlled fallbacks
//!       run the load-control code itself, so they agree to round-off (asserted 1e-12); what
//!       they check is that the step converges, is logged as a fallback and takes no arc-length
//!       increment.
mod common;
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
    // The shift moves a prescribed displacement: load control, logged.
    set(&mut a, "shift", 0.01);
    set(&mut b, "shift", 0.01);
    solve(&mut a);
    let rb = solve(&mut b);
    assert!(
        rb.log[0].starts_with(FALLBACK) && rb.log[0].contains("prescribed displacement"),
        "{}",
        rb.log[0]
    );
    assert_eq!(count(&rb.log, "(arc length,"), 0);
    let d = compare(&a, &b, 1e-12, "shift 0.01 m");
    println!(
        "shift 0.01 m: tension {:.6} N (load control fallback, difference {d:.1e})",
        get(&b, "tension")
    );
    // The force rises with the shift held: arc length runs.
    let mut arcs = 0;
    for k in 1..=5 {
        let p = 200.0 * k as f64;
        set(&mut a, "P", p);
        set(&mut b, "P", p);
        let ra = solve(&mut a);
        let rb = solve(&mut b);
        assert!(!rb.log[0].starts_with(FALLBACK), "{}", rb.log[0]);
        let by_arc = count(&rb.log, "(arc length,");
        arcs += by_arc;
        let d = compare(&a, &b, 1e-7, &format!("P = {p} N"));
        println!(
            "P = {p} N, shift held: midspan_uz {:.9} m, load control {} iterations, arc length {} iterations ({by_arc} arc-length increments), worst output difference {d:.1e}",
            get(&a, "midspan_uz"),
            ra.iterations,
            rb.iterations
        );
    }
    assert!(arcs > 0, "the force steps used arc length");
    // Both move: load control again.
    set(&mut a, "shift", 0.02);
    set(&mut b, "shift", 0.02);
    set(&mut a, "P", 1200.0);
    set(&mut b, "P", 1200.0);
    solve(&mut a);
    let rb = solve(&mut b);
    assert!(rb.log[0].starts_with(FALLBACK), "{}", rb.log[0]);
    assert_eq!(count(&rb.log, "(arc length,"), 0);
    compare(&a, &b, 1e-12, "shift 0.02 m, P = 1200 N");
}

#[test]
fn a_sleeve_scene_under_arc_length_is_load_controlled() {
    let load_control = read_scene(&shipped("SlidingCable"));
    let mut arc = load_control.clone();
    arc.solver.path = PathMethod::ArcLength;
    let mut a = engine(load_control);
    let mut b = engine(arc);
    solve(&mut a);
    solve(&mut b);
    for k in 1..=10 {
        let f = k as f64 / 10.0;
        for e in [&mut a, &mut b] {
            set(e, "P", 200.0 * f);
            set(e, "p", 20.0 * f);
        }
        solve(&mut a);
        let rb = solve(&mut b);
        assert!(
            rb.log[0].starts_with(FALLBACK) && rb.log[0].contains("sleeve points"),
            "{}",
            rb.log[0]
        );
        assert_eq!(count(&rb.log, "(arc length,"), 0);
        compare(&a, &b, 1e-12, &format!("row {k}"));
    }
    println!(
        "SlidingCable by arc length = load control: x7 {:.9}, x8 {:.9}, x9 {:.9}",
        get(&b, "x7"),
        get(&b, "x8"),
        get(&b, "x9")
    );
}
