//! Inexact Newton (issue 15 item 1: `solver.inexact_newton`, `Ldlt::pcg`, `slip.rs`).
//!
//! GOAL: (1) forcing inexact Newton on (`"on"`: in the quadratic regime the direction by
//!       conjugate gradients on the current tangent, preconditioned by the last
//!       factorization) reaches the same equilibria as exact Newton (`"off"`) in the same
//!       number of Newton iterations, with fewer factorizations on a plain system (Hencky
//!       disc, wrinkled shear, and the load-controlled increments of an arc-length path, which
//!       the path takes across wrinkle switches: LiftedMembrane); (2) systems bordered by slip
//!       rows (SlidingCable) or a volume row (balloon) keep the exact path: no inexact
//!       direction is taken and the answers are bit for bit those of `"off"`;
//!       (3) with 2 threads on a tangent of more than 20 000 equations the preconditioner is the
//!       two-domain factorization (split.rs) and the answer is again the exact one; (4) `"auto"`
//!       (the default) is off below 100 000 equations and on from there; (5) a bad value is
//!       named in the error.
//! MESH, BOUNDARY CONDITIONS, PARAMETERS: the shipped scenes as they are (HenckyDisc at its 32
//!       rings, WrinkledShear, SlidingCable, LiftedMembrane with `solver.path: arc_length`),
//!       the octahedral balloon of tests/verification/volume_control.rs at 6 divisions per edge, and the
//!       HenckyDisc at 50 rings (22 053 equations) with `solver.threads: 2`; HenckyDisc at 106
//!       rings (100 809 equations) for the `auto` threshold (built, not solved).
//! LOADING: HenckyDisc pressure 40 Pa (flat start); WrinkledShear shear 0.75, 1.5 mm
//!       (wrinkled); SlidingCable p = 10 N, P = 100 N, p = 20 N, P = 200 N; balloon stretch 1.2
//!       (volume input); LiftedMembrane lift 10, 20 N.
//! REFERENCE: the exact-Newton solve of the same scene (`"off"`), itself verified against
//!       closed forms in tests/verification/hencky_disc.rs, wrinkled_shear.rs and friends. Both
//!       runs stop on the same true-residual test (relative 1e-9); the inexact directions
//!       solve K Δx = −R to ‖K Δx + R‖ ≤ η ‖R‖ with η ≤ 1e-6, and the last iterations of
//!       both runs are quadratic, so both land far below the test and differ by round-off of
//!       the last correction. Tolerance: every output relative to the larger of its size and
//!       1e-3 SI (a slip of 1e-10 m is round-off of a 1 m cable), and every displacement
//!       relative to the largest, per case (measured worst, printed per case): the 32-ring
//!       disc 1e-12 (2.7e-14), the 50-ring disc with 2 threads 1e-12 (2.8e-14), the
//!       arc-length path 1e-11 (7.9e-13), WrinkledShear 1e-13 (1.3e-15).
//!       Bordered systems: 0 (bit for bit). Iteration counts: equal.
use crate::common;
use common::*;
use serde_json::json;
use velarium::scene::{Generator, InexactNewton, PathMethod};
use velarium::solver::linear::Counts;
use velarium::{Engine, Scene};

/// Tolerances per case (header): plain membrane, arc-length path, wrinkled film.
const MEMBRANE: f64 = 1e-12;
const ARC: f64 = 1e-11;
const WRINKLED: f64 = 1e-13;
/// Outputs are compared relative to the larger of their magnitude and this (SI units).
const OUTPUT_FLOOR: f64 = 1e-3;

fn build(scene: &Scene, inexact: InexactNewton) -> Engine {
    let mut scene = scene.clone();
    scene.solver.inexact_newton = inexact;
    engine(scene)
}

/// What one comparison found.
struct Compared {
    worst: f64,
    exact: Counts,
    inexact: Counts,
}

/// Solve `scene` through `steps` (input, value) with inexact Newton forced off and on; after
/// every step the outputs and displacements must agree within `tolerance` and the Newton
/// iterations must be equal.
fn compare(name: &str, scene: &Scene, steps: &[(&str, f64)], tolerance: f64) -> Compared {
    let mut exact = build(scene, InexactNewton::Off);
    let mut inexact = build(scene, InexactNewton::On);
    assert!(!exact.inexact_newton() && inexact.inexact_newton());
    let mut worst = 0.0f64;
    for &(input, value) in steps {
        set(&mut exact, input, value);
        set(&mut inexact, input, value);
        let a = solve(&mut exact);
        let b = solve(&mut inexact);
        assert_eq!(
            a.iterations, b.iterations,
            "{name}: Newton iterations at {input} = {value}"
        );
        for ((out, x), (_, y)) in exact.outputs().iter().zip(inexact.outputs()) {
            let d = (x - y).abs() / x.abs().max(OUTPUT_FLOOR);
            assert!(
                d <= tolerance,
                "{name}: {out} at {input} = {value}: {x} vs {y} ({d:.2e})"
            );
            worst = worst.max(d);
        }
        let d = field_difference(&exact.state().displacement, &inexact.state().displacement);
        assert!(
            d <= tolerance,
            "{name}: displacements at {input} = {value} differ by {d:.2e}"
        );
        worst = worst.max(d);
    }
    let c = Compared {
        worst,
        exact: exact.linear_counts(),
        inexact: inexact.linear_counts(),
    };
    println!(
        "{name}: inexact against exact Newton: worst difference {:.2e}; exact {:?}; inexact {:?}",
        c.worst, c.exact, c.inexact
    );
    c
}

#[test]
fn hencky_disc_same_answers_fewer_factorizations() {
    let scene = read_scene(&shipped("HenckyDisc"));
    let c = compare("HenckyDisc", &scene, &[("pressure", 40.0)], MEMBRANE);
    assert_eq!(c.exact.inexact, 0, "{:?}", c.exact);
    assert!(c.inexact.inexact >= 1, "{:?}", c.inexact);
    assert!(
        c.inexact.factorizations < c.exact.factorizations,
        "{:?} vs {:?}",
        c.inexact,
        c.exact
    );
}

#[test]
fn wrinkled_shear_same_answers() {
    let scene = read_scene(&shipped("WrinkledShear"));
    let c = compare(
        "WrinkledShear",
        &scene,
        &[("shear", 0.75e-3), ("shear", 1.5e-3)],
        WRINKLED,
    );
    assert!(c.inexact.inexact >= 1, "{:?}", c.inexact);
}

#[test]
fn sliding_cable_keeps_the_exact_path() {
    let scene = read_scene(&shipped("SlidingCable"));
    let c = compare(
        "SlidingCable",
        &scene,
        &[("p", 10.0), ("P", 100.0), ("p", 20.0), ("P", 200.0)],
        0.0,
    );
    assert_eq!(c.inexact, c.exact);
}

#[test]
fn arc_length_path_same_answers() {
    let mut scene = read_scene(&shipped("LiftedMembrane"));
    scene.solver.path = PathMethod::ArcLength;
    scene.solver.arc_length = Some(2e-4);
    let c = compare(
        "LiftedMembrane (arc length)",
        &scene,
        &[("lift_force", 10.0), ("lift_force", 20.0)],
        ARC,
    );
    assert_eq!(c.exact.inexact, 0, "{:?}", c.exact);
}

#[test]
fn volume_controlled_balloon_keeps_the_exact_path() {
    let scene = balloon_scene(
        6,
        1e-3,
        1e5,
        json!({"kind": "volume", "membrane": "rubber"}),
    );
    let v0 = engine(scene.clone()).outputs()[1].1;
    let c = compare(
        "balloon (volume)",
        &scene,
        &[("dV", (1.2f64.powi(3) - 1.0) * v0)],
        0.0,
    );
    assert_eq!(c.inexact, c.exact);
}

fn disc(rings: usize) -> Scene {
    let mut scene = read_scene(&shipped("HenckyDisc"));
    if let Generator::Disc { rings: r, .. } = &mut scene.geometry.generators[0] {
        *r = rings;
    }
    scene
}

#[test]
fn two_threads_the_split_factorization_preconditions() {
    let mut scene = disc(50);
    scene.solver.threads = 2;
    let probe = build(&scene, InexactNewton::On);
    let (a, b, s) = probe
        .split_sizes()
        .expect("2 threads on 22 053 equations factor in two halves");
    println!(
        "50 rings, 2 threads: {} equations, halves {a} + {b}, separator {s}",
        probe.free_dofs()
    );
    assert!(probe.free_dofs() >= 20_000);
    let c = compare(
        "HenckyDisc 50 rings, 2 threads",
        &scene,
        &[("pressure", 40.0)],
        MEMBRANE,
    );
    assert!(c.inexact.inexact >= 1, "{:?}", c.inexact);
    assert!(
        c.inexact.factorizations < c.exact.factorizations,
        "{:?} vs {:?}",
        c.inexact,
        c.exact
    );
}

#[test]
fn auto_is_off_below_100k_equations_and_on_from_there() {
    assert_eq!(
        velarium::scene::SolverSettings::default().inexact_newton,
        InexactNewton::Auto
    );
    let small = build(&disc(32), InexactNewton::Auto);
    assert!(!small.inexact_newton(), "{} equations", small.free_dofs());
    let large = build(&disc(106), InexactNewton::Auto);
    println!("106 rings: {} equations", large.free_dofs());
    assert!(large.free_dofs() >= velarium::solver::INEXACT_MIN_EQUATIONS);
    assert!(large.inexact_newton(), "{} equations", large.free_dofs());
    assert!(!build(&disc(106), InexactNewton::Off).inexact_newton());
}

#[test]
fn bad_value_is_named() {
    let mut v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(shipped("HenckyDisc")).unwrap()).unwrap();
    v["solver"] = json!({"inexact_newton": "sometimes"});
    let err = Scene::from_json(&v.to_string())
        .expect_err("an unknown value is refused")
        .to_string();
    println!("{err}");
    assert!(err.contains("inexact_newton"), "{err}");
    assert!(err.contains("sometimes"), "{err}");
}
