//! GOAL: issue 27, "Honest diagnostics": a failed step names a mechanism only once it is
//!       verified (src/solver/mechanism.rs): a part with a rigid-body motion that no support
//!       stops, or a finite motion that keeps every element's lengths, on which the loads do
//!       work. Structures that fail for other reasons (a singular tangent at a flat or straight
//!       start, a spent budget, a cushion that does not converge) never get the word
//!       "mechanism" in their message; where the tangent at the last converged point is
//!       near-singular the message says so and what was checked.
//! MESH, BOUNDARY CONDITIONS, PARAMETERS: per test below (every scene is built here). Where a
//!       structure has an equilibrium the default solver finds, the step is made to fail by a
//!       small budget (`max_iterations` 3, `min_increment` 0.5: one increment, then one cut
//!       back; the proximal continuation off), so that the message of a failure from that start is what is checked.
//! REFERENCE: kinematics by hand, per test: which motions keep every element length (a
//!       parallelogram of cables between two held nodes swings; a node on a straight cable
//!       between two held nodes moves sideways only to first order, its cables lengthen at
//!       second order; a flat membrane pushed out of its plane stretches at second order; a
//!       sheet held only in z slides in its plane as a rigid body; a pretensioned cable and a
//!       quarter cushion whose supports stop every rigid motion have no motion that keeps their
//!       lengths and the loads push along). No tolerance: the assertions are on the message's
//!       words and the node ids it names.

use crate::common;
use common::*;
use serde_json::json;
use velarium::{Engine, Scene};

fn scene_of(value: serde_json::Value) -> Scene {
    Scene::from_json(&value.to_string()).unwrap_or_else(|p| panic!("{p}"))
}

/// The solver section that makes a step fail after one increment and one cut-back (the
/// proximal and overshoot continuations off: they solve these structures even with 3
/// iterations per problem).
fn short() -> serde_json::Value {
    json!({"max_iterations": 3, "min_increment": 0.5, "proximal_continuation": 0.0,
           "overshoot_continuation": 0.0})
}

/// Solve with input `name` at `value` from the scene's start: the step's report must be a
/// failure; its message.
fn failure(scene: Scene, name: &str, value: f64) -> String {
    let mut e = Engine::try_new(scene).unwrap_or_else(|err| panic!("{err}"));
    set(&mut e, name, value);
    let report = e.solve();
    println!("converged {}: {}", report.converged(), report.message);
    assert!(!report.converged(), "the step must fail");
    report.message
}

/// The numbers a text holds (node ids among them).
fn numbers(text: &str) -> Vec<&str> {
    text.split(|c: char| !c.is_ascii_digit())
        .filter(|s| !s.is_empty())
        .collect()
}

/// The part of a failure's message after the Newton iteration's own reason: what is known
/// of the structure (starts at "the structure is a mechanism" or "the tangent at").
fn diagnosis(message: &str) -> &str {
    let at = ["; the structure is a mechanism", "; the tangent at"]
        .iter()
        .filter_map(|w| message.find(w))
        .min()
        .unwrap_or_else(|| panic!("no diagnosis in: {message}"));
    &message[at + 2..]
}

fn no_mechanism_claim(message: &str) {
    assert!(
        !message.to_lowercase().contains("mechanism"),
        "no mechanism may be claimed: {message}"
    );
}

/// Cables A–N1–N2–B on a unit square (A = 0 and B = 3 held in x, y and z; N1 = 1 at (0, 1),
/// N2 = 2 at (1, 1)), no pretension, a point force in x at N1; `brace` adds a cable A–N2.
fn parallelogram(brace: bool, solver: serde_json::Value) -> Scene {
    let mut cables = vec![json!({"name": "c", "nodes": [0, 1, 2, 3], "EA": 1e4})];
    if brace {
        cables.push(json!({"name": "brace", "nodes": [0, 2], "EA": 1e4}));
    }
    scene_of(json!({
        "format": 1, "name": "Parallelogram",
        "geometry": {"nodes": [[0.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 1.0, 0.0], [1.0, 0.0, 0.0]],
                     "node_sets": {"ends": [0, 3], "hinge": [1]}},
        "cables": cables,
        "supports": [{"nodes": "ends", "fix": ["x", "y", "z"]}],
        "inputs": [{"name": "F", "load": {"kind": "point_force", "nodes": "hinge", "direction": [1.0, 0.0, 0.0]}}],
        "solver": solver
    }))
}

/// A straight cable A–N–B (A = 0 at the origin, N = 1 at 1 m, B = 2 at 2 m, A and B held in x,
/// y and z), EA 1e4 N and `pretension`, a point force in y at N.
fn straight(pretension: f64, solver: serde_json::Value) -> Scene {
    scene_of(json!({
        "format": 1, "name": "Straight",
        "geometry": {"nodes": [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]],
                     "node_sets": {"ends": [0, 2], "middle": [1]}},
        "cables": [{"name": "c", "nodes": [0, 1, 2], "EA": 1e4, "pretension": pretension}],
        "supports": [{"nodes": "ends", "fix": ["x", "y", "z"]}],
        "inputs": [{"name": "F", "load": {"kind": "point_force", "nodes": "middle", "direction": [0.0, 1.0, 0.0]}}],
        "solver": solver
    }))
}

/// A flat 1 m square membrane (4 x 4 cells, 0.1 mm, SVK E 1 GPa, ν 0.3, no prestress), its
/// boundary held in x, y and z, under a follower pressure p; `supports` replaces the supports.
fn flat(supports: serde_json::Value, solver: serde_json::Value) -> Scene {
    scene_of(json!({
        "format": 1, "name": "Flat",
        "geometry": {"generators": [{"kind": "rectangle", "name": "sheet", "origin": [0.0, 0.0, 0.0],
                                     "size": [1.0, 1.0], "divisions": [4, 4]}]},
        "membranes": [{"name": "film", "triangles": "sheet", "thickness": 1e-4,
                       "material": {"kind": "svk", "E": 1e9, "nu": 0.3}}],
        "supports": supports,
        "inputs": [{"name": "p", "load": {"kind": "pressure", "membrane": "film"}},
                   {"name": "F", "load": {"kind": "point_force", "nodes": "sheet.corner_tr", "direction": [1.0, 0.0, 0.0]}}],
        "solver": solver
    }))
}

/// The square two-sheet quarter cushion of the robustness corpus (examples/robustness/corpus.rs,
/// family cushion-quarter): `n` x `n` cells on a square of side `a`, two sheets sharing the
/// outer rim (x = a or y = a), the rim held in z and free in its plane, the symmetry planes
/// x = 0 (x held) and y = 0 (y held) on both sheets, SVK E t = `et` N/m, ν 0.3, inflated from
/// flat by a follower pressure p.
fn quarter_cushion(n: usize, a: f64, et: f64) -> Scene {
    let id = |i: usize, j: usize| j * (n + 1) + i;
    let rim = |i: usize, j: usize| i == n || j == n;
    let mut nodes: Vec<[f64; 3]> = Vec::new();
    for j in 0..=n {
        for i in 0..=n {
            nodes.push([a * i as f64 / n as f64, a * j as f64 / n as f64, 0.0]);
        }
    }
    let mut bottom = vec![0usize; nodes.len()];
    for j in 0..=n {
        for i in 0..=n {
            let k = id(i, j);
            bottom[k] = if rim(i, j) {
                k
            } else {
                nodes.push(nodes[k]);
                nodes.len() - 1
            };
        }
    }
    let mut triangles: Vec<[usize; 3]> = Vec::new();
    for j in 0..n {
        for i in 0..n {
            let (p, q, r, s) = (id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1));
            if (i + j) % 2 == 0 {
                triangles.extend([[p, q, r], [p, r, s]]);
            } else {
                triangles.extend([[p, q, s], [q, r, s]]);
            }
        }
    }
    for k in 0..triangles.len() {
        let t = triangles[k];
        triangles.push([bottom[t[0]], bottom[t[2]], bottom[t[1]]]);
    }
    let (mut xfix, mut yfix, mut zfix) = (Vec::new(), Vec::new(), Vec::new());
    for j in 0..=n {
        for i in 0..=n {
            let k = id(i, j);
            if rim(i, j) {
                zfix.push(k);
            }
            if i == 0 {
                xfix.extend([k, bottom[k]]);
            }
            if j == 0 {
                yfix.extend([k, bottom[k]]);
            }
        }
    }
    for v in [&mut xfix, &mut yfix] {
        v.sort_unstable();
        v.dedup();
    }
    let young = 3e9;
    scene_of(json!({
        "format": 1, "name": "QuarterCushion",
        "geometry": {"nodes": nodes, "triangles": triangles,
                     "node_sets": {"rim": zfix, "xfix": xfix, "yfix": yfix}},
        "membranes": [{"name": "sheets", "triangles": (0..triangles.len()).collect::<Vec<_>>(),
                       "thickness": et / young, "material": {"kind": "svk", "E": young, "nu": 0.3}}],
        "supports": [{"nodes": "rim", "fix": ["z"]}, {"nodes": "xfix", "fix": ["x"]},
                     {"nodes": "yfix", "fix": ["y"]}],
        "inputs": [{"name": "p", "load": {"kind": "pressure", "membrane": "sheets"}}]
    }))
}

/// A sheet held only in z, pushed in x at a corner: it slides in its plane as a rigid body
/// (x, y and the rotation about z free, and the force does work on x). REQUIRED: the message
/// says the structure is a mechanism, a part with 3 rigid-body motions, and names its 25
/// nodes (the first 12 ids and the count).
#[test]
fn a_sheet_on_sliders_pushed_in_its_plane_is_named() {
    let message = failure(
        flat(json!([{"nodes": "sheet.all", "fix": ["z"]}]), json!({})),
        "F",
        1.0,
    );
    let known = diagnosis(&message);
    assert!(
        known.starts_with("the structure is a mechanism: nodes 0, 1, 2,")
            && known.contains("(25 nodes) form a part with 3 rigid-body motions"),
        "{message}"
    );
}

/// The cable parallelogram pushed in x at N1 with no pretension swings: N1 and N2 move on
/// circles about A and B and no cable changes length; nothing stops it and the force does
/// work on it (its rigid rotation about the line AB is free too, but the force does no work on
/// that one, so it is not the part named). The default solver finds the swung equilibrium; with
/// the short budget the step fails from the start. REQUIRED: the message names the finite
/// mechanism with nodes 1 and 2 and no others.
#[test]
fn a_swinging_cable_parallelogram_is_named_a_finite_mechanism() {
    let message = failure(parallelogram(false, short()), "F", 1.0);
    let known = diagnosis(&message);
    assert!(
        known
            .starts_with("the structure is a mechanism: nodes 1, 2 can move along a finite motion"),
        "{message}"
    );
    let named = &known[..known.find("can move").unwrap()];
    assert_eq!(numbers(named), ["1", "2"], "{message}");
}

/// The parallelogram braced by a cable A–N2: a rigid triangle A–N1–N2 and a cable N2–B. In the
/// plane nothing moves without changing a length at first order; out of it N1 and N2 can (the
/// rigid rotation about AB among those motions), but the force in x does no work on any of
/// them. REQUIRED: with the short budget the step fails and the message claims no mechanism.
#[test]
fn a_braced_parallelogram_is_not_called_a_mechanism() {
    let message = failure(parallelogram(true, short()), "F", 1.0);
    no_mechanism_claim(&message);
}

/// A node on a straight, unstressed cable between two held nodes, pushed sideways: the sideways
/// motion keeps the two lengths to first order only (they grow as δ²/2 per metre), so the cable
/// sags to an equilibrium (the default solver finds it). With the short budget the step fails
/// from the straight start. REQUIRED: the message says the tangent there is near-singular at
/// node 1, that the motion does not extend to a finite one, and claims no mechanism.
#[test]
fn a_node_pushed_sideways_on_a_straight_cable_is_not_called_a_mechanism() {
    let message = failure(straight(0.0, short()), "F", 1.0);
    no_mechanism_claim(&message);
    let known = diagnosis(&message);
    assert!(
        known.starts_with(
            "the tangent at the last converged point (load fraction 0.000000) is near-singular: the out-of-balance load drives a motion largest at node 1,"
        ) && known.contains("does not extend to a finite one"),
        "{message}"
    );
}

/// The same cable pretensioned to 10 N: the tension gives the sideways motion a stiffness of
/// T/l = 10 N/m per cable against EA/l = 1e4 N/m along it (1e-3 of the elastic stiffness), far
/// from singular. A budget of 1 iteration per increment (`max_iterations` 1, `min_increment`
/// 0.5) makes the step under 100 N fail. REQUIRED: the message says nothing of a near-singular
/// tangent and claims no mechanism.
#[test]
fn a_pretensioned_cable_short_of_iterations_is_not_called_singular() {
    let message = failure(
        straight(10.0, json!({"max_iterations": 1, "min_increment": 0.5})),
        "F",
        100.0,
    );
    no_mechanism_claim(&message);
    assert!(!message.contains("near-singular"), "{message}");
}

/// A stiff structure whose step runs out of its budget (`max_step_iterations` 2): the
/// pretensioned cable under a large sideways force. REQUIRED: the message says the budget is
/// spent and claims no mechanism.
#[test]
fn a_spent_step_budget_is_not_called_a_mechanism() {
    let message = failure(straight(10.0, json!({"max_step_iterations": 2})), "F", 1e4);
    assert!(message.contains("solver.max_step_iterations"), "{message}");
    no_mechanism_claim(&message);
}

/// A flat, stress-free membrane clamped on its boundary under pressure, with the artificial
/// prestress and the prestress continuation off: its tangent has no out-of-plane stiffness at
/// the flat start (its out-of-plane motion stretches it at second order only). With the short
/// budget the step fails there. REQUIRED: the message says the tangent is near-singular, names
/// interior nodes only (the boundary is held), says the motion does not extend to a finite one,
/// and claims no mechanism.
#[test]
fn a_flat_unprestressed_membrane_under_pressure_is_not_called_a_mechanism() {
    let mut solver = short();
    solver["artificial_prestress"] = json!(0.0);
    solver["prestress_continuation"] = json!(0.0);
    let message = failure(
        flat(
            json!([{"nodes": "sheet.boundary", "fix": ["x", "y", "z"]}]),
            solver,
        ),
        "p",
        100.0,
    );
    no_mechanism_claim(&message);
    let known = diagnosis(&message);
    assert!(
        known.contains("is near-singular") && known.contains("does not extend to a finite one"),
        "{message}"
    );
    // Interior nodes of the 5 x 5 grid: ids 6-8, 11-13, 16-18.
    let interior = ["6", "7", "8", "11", "12", "13", "16", "17", "18"];
    let from = known.find("largest at node").unwrap();
    let to = known.find(", which").or(known.find(", whose")).unwrap();
    let named = &known[from..to];
    let named = &named[..named.find(" (of").unwrap_or(named.len())];
    let ids = numbers(named);
    assert!(
        !ids.is_empty() && ids.iter().all(|i| interior.contains(i)),
        "{ids:?}: {message}"
    );
}

/// The quarter cushion of the report (8 x 8 cells, a = 0.70 m, E t = 1.505e8 N/m, p = 4167 Pa,
/// the corpus member that failed at 8 x 8 before the proximal continuation): every rigid motion
/// is stopped (x by the plane x = 0, y by y = 0, z and the tilts by the rim, the turn about z
/// by both planes), so no failure of it may claim a mechanism. With the proximal and overshoot
/// continuations off (`solver.proximal_continuation` and `solver.overshoot_continuation` 0)
/// the step fails as it did. REQUIRED: the message claims no mechanism.
#[test]
fn the_quarter_cushion_is_not_called_a_mechanism() {
    let mut scene = quarter_cushion(8, 0.70, 1.505e8);
    scene.solver.proximal_continuation = 0.0;
    scene.solver.overshoot_continuation = 0.0;
    let message = failure(scene, "p", 4167.0);
    no_mechanism_claim(&message);
}
