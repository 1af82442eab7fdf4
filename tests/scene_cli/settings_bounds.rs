//! Issue 27, point 9: every numeric solver setting has a documented range that validation
//! enforces (`velarium check`, `solve`, `pack`, `formfind`, the engine and so an FMU's
//! Instantiate), each problem naming the JSON path and the range. The two values from the
//! issue, `solver.max_iterations` 4294967296 (the Newton history then asked for 34 GB: the
//! process aborted, exit 134) and 18446744073709551615 (the loop's bound overflowed: a failing
//! step never ended), exit 1 with the message under the 60 s kill guard of `hostile_input.rs`.
//! The FMI side is in `tests/fmi/fmi_abi.rs` (Instantiate returns NULL and logs why).

use crate::hostile_input::{cable_with, rejected, write, CABLE_LOADS};
use velarium::scene::{validate::validate, Scene};

/// The shipped PrestressedCable with `solver` set to this JSON object.
fn cable_solver(solver: &str) -> Scene {
    let text = cable_with(
        "\"format\": 1,",
        &format!("\"format\": 1, \"solver\": {solver},"),
    );
    Scene::from_json(&text).unwrap_or_else(|p| panic!("{p}"))
}

/// The problems of the cable with `solver`, as `path: message` lines.
fn problems(solver: &str) -> Vec<String> {
    validate(&cable_solver(solver))
        .iter()
        .map(|p| p.to_string())
        .collect()
}

#[test]
fn the_issue_values_of_max_iterations_exit_1_from_check_and_solve() {
    for value in ["4294967296", "18446744073709551615"] {
        let text = cable_with(
            "\"format\": 1,",
            &format!("\"format\": 1, \"solver\": {{\"max_iterations\": {value}}},"),
        );
        let scene = write(&format!("max_iterations_{value}.json"), text.as_bytes());
        let loads = write("cable_loads.csv", CABLE_LOADS.as_bytes());
        let needles = ["solver.max_iterations", value, "1..=10000"];
        rejected(&["check", &scene], &needles);
        rejected(&["solve", &scene, "--loads", &loads], &needles);
    }
    // One past u64: not a whole number serde can hold, a type error on the same path.
    let text = cable_with(
        "\"format\": 1,",
        "\"format\": 1, \"solver\": {\"max_iterations\": 18446744073709551616},",
    );
    let scene = write("max_iterations_2_64.json", text.as_bytes());
    rejected(&["check", &scene], &["solver.max_iterations"]);
}

/// Each setting just outside its range is named with its path and its range; a NaN-like
/// value cannot be written in JSON, so the non-finite cases are set through the struct.
#[test]
fn every_setting_out_of_range_is_named_with_its_range() {
    for (solver, needles) in [
        (
            r#"{"tolerance": 1e-15}"#,
            &["solver.tolerance", "[1e-14, 1e-2]"][..],
        ),
        (
            r#"{"tolerance": 0.02}"#,
            &["solver.tolerance", "[1e-14, 1e-2]"],
        ),
        (
            r#"{"max_iterations": 0}"#,
            &["solver.max_iterations", "1..=10000"],
        ),
        (
            r#"{"max_iterations": 10001}"#,
            &["solver.max_iterations", "1..=10000"],
        ),
        (
            r#"{"target_iterations": 0}"#,
            &["solver.target_iterations", "1..=10000"],
        ),
        (
            r#"{"target_iterations": 10001}"#,
            &["solver.target_iterations", "1..=10000"],
        ),
        (
            r#"{"initial_increment": 1.5}"#,
            &["solver.initial_increment", "[1e-12, 1]"],
        ),
        (
            r#"{"min_increment": 1e-13}"#,
            &["solver.min_increment", "[1e-12, initial_increment = 1]"],
        ),
        (
            r#"{"initial_increment": 0.25, "min_increment": 0.5}"#,
            &["solver.min_increment", "initial_increment = 0.25"],
        ),
        (r#"{"threads": 65}"#, &["solver.threads", "1 to 64"]),
        (
            r#"{"arc_length": 0}"#,
            &["solver.arc_length", "[1e-30, 1e30]"],
        ),
        (
            r#"{"prestress_continuation": 0.2}"#,
            &["solver.prestress_continuation", "0.1"],
        ),
        (
            r#"{"artificial_prestress": -1}"#,
            &["solver.artificial_prestress", ">= 0"],
        ),
        (
            r#"{"limits": {"max_nodes": 0}}"#,
            &["solver.limits.max_nodes", "1..=4294967295"],
        ),
        (
            r#"{"limits": {"max_triangles": 4294967296}}"#,
            &["solver.limits.max_triangles", "1..=4294967295"],
        ),
        (
            r#"{"limits": {"max_unknowns": 18446744073709551615}}"#,
            &["solver.limits.max_unknowns", "1..=4294967295"],
        ),
        (
            r#"{"limits": {"max_memory_gb": 0}}"#,
            &["solver.limits.max_memory_gb", "[0.001, 1e6]"],
        ),
        (
            r#"{"limits": {"max_memory_gb": 1e7}}"#,
            &["solver.limits.max_memory_gb", "[0.001, 1e6]"],
        ),
    ] {
        // One problem: a limit out of its range stops validation before the size checks (so
        // a count limit of 0 is not also reported as a scene too large).
        let p = problems(solver);
        assert_eq!(p.len(), 1, "{solver}: {p:?}");
        for n in needles {
            assert!(p[0].contains(n), "{solver}: {n:?} not in {}", p[0]);
        }
    }
    let mut scene = cable_solver("{}");
    scene.solver.limits.max_memory_gb = f64::NAN;
    scene.solver.tolerance = f64::INFINITY;
    let p: Vec<String> = validate(&scene).iter().map(|p| p.to_string()).collect();
    assert_eq!(p.len(), 2, "{p:?}");
    assert!(
        p.iter().any(|m| m.starts_with("solver.tolerance: inf")),
        "{p:?}"
    );
    assert!(
        p.iter()
            .any(|m| m.starts_with("solver.limits.max_memory_gb: NaN")),
        "{p:?}"
    );
}

/// The ends of every range are accepted, and the scene solves at them.
#[test]
fn the_ends_of_the_ranges_are_accepted() {
    for solver in [
        r#"{"tolerance": 1e-14, "max_iterations": 10000, "target_iterations": 10000}"#,
        r#"{"tolerance": 1e-2, "max_iterations": 1, "target_iterations": 1}"#,
        r#"{"max_iterations": 1, "target_iterations": 6}"#,
        r#"{"initial_increment": 1e-12, "min_increment": 1e-12}"#,
        r#"{"initial_increment": 1, "min_increment": 1}"#,
        r#"{"threads": 64, "prestress_continuation": 0.1, "artificial_prestress": 0}"#,
        r#"{"limits": {"max_nodes": 4294967295, "max_triangles": 1, "max_unknowns": 4294967295, "max_memory_gb": 1e6}}"#,
        r#"{"limits": {"max_memory_gb": 0.001}}"#,
    ] {
        assert_eq!(problems(solver), Vec::<String>::new(), "{solver}");
    }
}

/// A bad setting is named even when the mesh is bad too (the settings are checked first, so
/// the mesh's early return does not hide them).
#[test]
fn a_bad_setting_is_named_beside_a_bad_mesh() {
    let text = r#"{"format": 1, "name": "A",
      "geometry": {"generators": [{"kind": "disc", "name": "d", "center": [0, 0, 0], "radius": -1, "rings": 2}]},
      "solver": {"max_iterations": 4294967296}}"#;
    let p: Vec<String> = validate(&Scene::from_json(text).unwrap())
        .iter()
        .map(|p| p.to_string())
        .collect();
    assert!(
        p.iter().any(|m| m.starts_with("solver.max_iterations")),
        "{p:?}"
    );
    assert!(
        p.iter()
            .any(|m| m.starts_with("geometry.generators[0].radius")),
        "{p:?}"
    );
}

/// The scene layer's bound of `solver.threads` (validation and the schema) is the solver's
/// pool bound, which the scene layer does not import.
#[test]
fn the_thread_bound_is_the_solvers() {
    assert_eq!(
        velarium::scene::validate::MAX_SOLVER_THREADS,
        velarium::solver::threads::MAX_THREADS
    );
}
