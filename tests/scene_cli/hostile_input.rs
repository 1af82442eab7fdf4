//! Issue 11, every listed example as a regression test: hostile scenes, load tables and states
//! are rejected with a located message (exit 1 from the command line, Err from the engine),
//! never a panic (exit 101), an abort (exit 134) or a non-finite answer. The FMI side of the
//! same examples is in `tests/fmi/fmi_abi.rs` (time rules, Instantiate, state values) and in the harness
//! fuzzers (`harness/test_fuzz.py`).
//!
//! Each command runs under a 60 s kill guard (a hang is a failure, not a wait); the times are
//! printed, never asserted.

use crate::common;
use std::path::PathBuf;
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};
use velarium::scene::{validate::validate, Scene};

const VELARIUM: &str = env!("CARGO_BIN_EXE_velarium");

fn dir() -> PathBuf {
    let d = std::env::temp_dir().join(format!("velarium-hostile-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

pub(crate) fn write(name: &str, bytes: &[u8]) -> String {
    let p = dir().join(name);
    std::fs::write(&p, bytes).unwrap();
    p.display().to_string()
}

/// Run the command with a kill guard; print the time it took.
fn run(args: &[&str]) -> Output {
    let start = Instant::now();
    let mut child = Command::new(VELARIUM)
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    loop {
        if child.try_wait().unwrap().is_some() {
            break;
        }
        if start.elapsed() > Duration::from_secs(60) {
            child.kill().unwrap();
            panic!("velarium {args:?} did not finish in 60 s");
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    let out = child.wait_with_output().unwrap();
    println!(
        "velarium {:?}: {:.3} s",
        args[0],
        start.elapsed().as_secs_f64()
    );
    out
}

fn text(out: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    )
}

/// Exit 1 (not 101 or a signal) with every needle in the output.
pub(crate) fn rejected(args: &[&str], needles: &[&str]) -> String {
    let out = run(args);
    let t = text(&out);
    assert_eq!(out.status.code(), Some(1), "{args:?}: {t}");
    for n in needles {
        assert!(t.contains(n), "{args:?}: {n:?} not in {t}");
    }
    t
}

fn shipped_text(name: &str) -> String {
    std::fs::read_to_string(common::shipped(name)).unwrap()
}

fn hencky(rings: &str) -> String {
    shipped_text("HenckyDisc").replace("\"rings\": 16", &format!("\"rings\": {rings}"))
}

pub(crate) const CABLE_LOADS: &str = "time,P\n0,0\n1,100\n";

/// The shipped PrestressedCable with a replacement applied to its text.
pub(crate) fn cable_with(from: &str, to: &str) -> String {
    let t = shipped_text("PrestressedCable");
    assert!(t.contains(from), "{from}");
    t.replacen(from, to, 1)
}

// 1. Size limits decided before allocating.

#[test]
fn a_huge_disc_is_rejected_by_its_counts_in_check_solve_and_pack() {
    for rings in ["100000", "3000"] {
        let scene = write(&format!("disc{rings}.json"), hencky(rings).as_bytes());
        let t = rejected(
            &["check", &scene],
            &["geometry.generators[0].rings", "too large", "max_nodes"],
        );
        assert!(t.lines().all(|l| l.len() < 700), "{t}");
        let loads = write("p.csv", b"time,pressure\n0,0\n1,10\n");
        rejected(&["solve", &scene, "--loads", &loads], &["max_nodes"]);
        rejected(
            &["pack", &scene, "--out", &dir().display().to_string()],
            &["max_nodes"],
        );
    }
}

#[test]
fn the_default_limits_let_a_million_unknowns_through_and_stop_what_would_not_fit() {
    // 334 rings: 335,671 nodes, 1,001,001 unknowns (the issue's 1M-DOF Hencky disc).
    let scene: Scene = serde_json::from_str(&hencky("334")).unwrap();
    let (problems, size) = velarium::scene::validate::validate_sized(&scene);
    assert_eq!(problems, vec![]);
    assert_eq!(size.unknowns, 3 * 335_671);
    println!(
        "334 rings: factor {} entries, estimated {:.2} GB",
        size.factor_entries,
        size.memory_bytes as f64 / 1e9
    );
    assert!(size.memory_bytes > 0 && (size.memory_bytes as f64) < 16e9);
    // The same disc with a memory limit of 0.5 GB: stopped by the estimate, located.
    let mut small = scene.clone();
    small.solver.limits.max_memory_gb = 0.5;
    let p = validate(&small);
    assert_eq!(p.len(), 1, "{p:?}");
    assert!(p[0].to_string().contains("max_memory_gb = 0.5"), "{}", p[0]);
}

#[test]
fn a_long_strip_passes_with_its_estimate_and_a_lower_limit_stops_it() {
    // divisions [1, 100000]: 200,002 nodes, within the defaults; check says how big it is.
    let t = shipped_text("LiftedMembrane");
    let v: serde_json::Value = serde_json::from_str(&t).unwrap();
    let gen = &v["geometry"]["generators"][0];
    assert_eq!(gen["kind"], "rectangle", "LiftedMembrane's first generator");
    let mut v2 = v.clone();
    v2["geometry"]["generators"][0]["divisions"] = serde_json::json!([1, 100000]);
    let scene = write("strip.json", v2.to_string().as_bytes());
    let out = run(&["check", &scene]);
    let t = text(&out);
    if out.status.code() == Some(0) {
        assert!(
            t.contains("600006 unknowns") || t.contains("estimated solve memory"),
            "{t}"
        );
    } else {
        // Other scene rules (supports, probes) may object; never a size panic or abort.
        assert_eq!(out.status.code(), Some(1), "{t}");
    }
    v2["solver"]["limits"] = serde_json::json!({"max_unknowns": 100000});
    let scene = write("strip_limited.json", v2.to_string().as_bytes());
    rejected(
        &["check", &scene],
        &[
            "geometry.generators[0].divisions",
            "600006 unknowns",
            "max_unknowns = 100000",
        ],
    );
}

// 2. Everything generated is validated like everything given.

#[test]
fn generated_triangles_of_zero_area_are_located_errors_not_panics() {
    let rect = r#"{"format": 1, "name": "R",
      "geometry": {"generators": [{"kind": "rectangle", "name": "r", "origin": [1e17, 0, 0], "size": [1, 1], "divisions": [4, 4]}]},
      "membranes": [{"name": "m", "triangles": "r", "thickness": 1e-3, "material": {"kind": "svk", "E": 1e6, "nu": 0.3}}],
      "supports": [{"nodes": "r.boundary", "fix": ["x", "y", "z"]}]}"#;
    let small = hencky("16").replace("\"radius\": 0.5", "\"radius\": 1e-150");
    let far = hencky("16").replace("\"center\": [0, 0, 0]", "\"center\": [0, 1e19, 0]");
    let loads = write("p2.csv", b"time,pressure\n0,0\n1,10\n");
    for (name, scene, needle) in [
        (
            "rect_far.json",
            rect.to_string(),
            "zero area in floating point",
        ),
        ("disc_small.json", small, "radius"),
        ("disc_far.json", far, "zero area in floating point"),
    ] {
        let path = write(name, scene.as_bytes());
        rejected(&["check", &path], &["geometry.generators[0]", needle]);
        rejected(
            &["pack", &path, "--out", &dir().display().to_string()],
            &["geometry.generators[0]"],
        );
        if name != "rect_far.json" {
            rejected(
                &["solve", &path, "--loads", &loads],
                &["geometry.generators[0]"],
            );
        }
    }
}

#[test]
fn overflowing_coordinates_and_moduli_are_rejected_with_the_field() {
    let p = problems(&cable_with("[2, 0, 0]", "[2, 1e308, 0]"));
    assert!(
        p.iter().any(|m| m.starts_with("geometry.nodes[2]")),
        "{p:?}"
    );
    let p = problems(&cable_with("\"EA\": 1e5", "\"EA\": 1e308"));
    assert!(p.iter().any(|m| m.starts_with("cables[0].EA")), "{p:?}");
    // Finite but too stiff for the pretension to survive round-off.
    let p = problems(&cable_with("\"EA\": 1e5", "\"EA\": 1e25"));
    assert!(
        p.iter()
            .any(|m| m.starts_with("cables[0].EA") && m.contains("pretension would be lost")),
        "{p:?}"
    );
}

fn problems(text: &str) -> Vec<String> {
    match Scene::parse(text.as_bytes()) {
        Err(p) => p.iter().map(|p| p.to_string()).collect(),
        Ok(s) => validate(&s).iter().map(|p| p.to_string()).collect(),
    }
}

#[test]
fn duplicate_keys_anywhere_are_rejected_naming_both_places() {
    let text = r#"{"format": 1, "name": "A",
  "geometry": {"nodes": [[0, 0, 0], [1, 0, 0]],
               "node_sets": {"midspan": [1], "midspan": [0]}},
  "cables": [{"name": "c", "nodes": [0, 1], "EA": 1e5, "EA": 2e5}]}"#;
    let p = problems(text);
    assert_eq!(p.len(), 2, "{p:?}");
    assert!(
        p[0].starts_with("geometry.node_sets.midspan: the key \"midspan\" is given twice")
            && p[0].contains("line 3, column 30 and line 3, column 46"),
        "{p:?}"
    );
    assert!(p[1].starts_with("cables[0].EA"), "{p:?}");
}

// 3. (state values: engine level here, FMI level in tests/fmi/fmi_abi.rs)

#[test]
fn set_state_checks_values_and_leaves_the_engine_as_it_was() {
    let mut e = common::engine(common::read_scene(&common::shipped("HenckyDisc")));
    common::set(&mut e, "pressure", 40.0);
    assert!(e.solve().converged());
    let good = e.state().clone();
    let outputs = e.outputs();
    type Edit = fn(&mut velarium::engine::EngineState);
    // Wrinkle and stick/slip states are typed: a code that is none of them cannot reach the
    // engine (src/fmi/snapshot.rs checks the codes of a serialized state).
    let cases: [(&str, Edit); 4] = [
        ("displacement[4]", |s| s.displacement[4] = f64::NAN),
        ("displacement[4]", |s| s.displacement[4] = f64::INFINITY),
        ("displacement[4]", |s| s.displacement[4] = 1e308),
        ("parameter E", |s| s.parameters[0] = f64::NAN),
    ];
    for (needle, edit) in cases {
        let mut bad = good.clone();
        edit(&mut bad);
        let err = e.set_state(bad).unwrap_err().to_string();
        assert!(err.contains(needle), "{needle}: {err}");
        assert_eq!(e.state(), &good);
        assert_eq!(e.outputs(), outputs);
    }
    let mut bad = good.clone();
    bad.parameters[1] = -1.0; // thickness
    let err = e.set_state(bad).unwrap_err().to_string();
    assert!(err.contains("thickness"), "{err}");
}

#[test]
fn a_merged_state_where_no_segment_is_closed_is_rejected() {
    let mut e = common::engine(common::read_scene(&common::shipped("SleeveCable")));
    let good = e.state().clone();
    assert!(!good.slip_state.is_empty());
    let mut bad = good.clone();
    bad.slip_state[0] = velarium::model::sleeve::Contact::Merged;
    let err = e.set_state(bad).unwrap_err().to_string();
    assert!(
        err.contains("slip_state[0] = Merged does not match the slips"),
        "{err}"
    );
    assert_eq!(e.state(), &good);
}

// 4. Messages in the scene's words.

/// Words that must never reach a user: Rust and serde vocabulary.
const SERDE_WORDS: &[&str] = &[
    "usize",
    "u32",
    "f64",
    "untagged",
    "internally tagged",
    "NodeRef",
    "OneNode",
    "TriangleRef",
    "enum ",
    "struct ",
    "sequence",
];

fn assert_scene_words(messages: &[String]) {
    for m in messages {
        for w in SERDE_WORDS {
            assert!(!m.contains(w), "{w:?} in {m}");
        }
    }
}

#[test]
fn type_errors_speak_the_scene_and_name_the_field() {
    let text = r#"{"format": 1, "name": "A",
  "geometry": {"generators": [{"kind": "disc", "name": "d", "center": [0, 0, 0], "radius": 1, "rings": 1.6e-11}]},
  "outputs": [{"name": "a", "probe": {"kind": "displacement", "node": [1, 2], "component": "z"}},
              {"name": "b", "probe": "displacement"},
              {"name": "c", "probe": {"kind": "reaction", "nodes": 2.5, "component": "z"}}],
  "cables": [{"name": "c", "nodes": [0, 1], "EA": "stiff", "colour": "red"}]}"#;
    let p = problems(text);
    assert_scene_words(&p);
    for e in [
        "geometry.generators[0].rings: invalid type: floating point `1.6e-11`, expected a whole number >= 0",
        "outputs[0].probe.node: must be a node index or the name of a one-node set",
        "outputs[1].probe: must be an object with a \"kind\" field",
        "outputs[2].probe.nodes: must be a list of node indices or a node-set name",
        "cables[0].EA: invalid type: string \"stiff\", expected a number",
        "cables[0].colour: unknown field `colour`",
    ] {
        assert!(p.iter().any(|m| m.starts_with(e)), "missing {e:?} in {p:#?}");
    }
}

#[test]
fn check_lists_unknown_fields_and_semantic_problems_in_one_run() {
    let text = shipped_text("PrestressedCable")
        .replacen("\"EA\": 1e5", "\"EA\": -1, \"colour\": 1", 1)
        .replacen("\"format\": 1,", "\"format\": 1, \"autor\": \"x\",", 1);
    let path = write("two_typos.json", text.as_bytes());
    let t = rejected(
        &["check", &path],
        &["cables[0].colour", "autor", "cables[0].EA: -1"],
    );
    assert!(t.contains("3 problems"), "{t}");
}

#[test]
fn a_bom_is_accepted_in_scenes_and_load_tables_and_comments_after_hash() {
    let mut scene = b"\xEF\xBB\xBF".to_vec();
    scene.extend(shipped_text("PrestressedCable").bytes());
    let path = write("bom.json", &scene);
    assert_eq!(run(&["check", &path]).status.code(), Some(0));
    let loads = write(
        "bom.csv",
        "\u{feff}time,P # header comment\n0,0 # start\n1,50 # half\n".as_bytes(),
    );
    let out = run(&["solve", &path, "--loads", &loads]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out));
    assert_eq!(String::from_utf8_lossy(&out.stdout).lines().count(), 3);
}

#[test]
fn invalid_utf8_names_the_byte_offset() {
    let mut scene = shipped_text("PrestressedCable").into_bytes();
    let at = 40;
    scene.insert(at, 0xFF);
    let path = write("latin1.json", &scene);
    rejected(&["check", &path], &[&format!("byte offset {at}")]);
    let good = write("good.json", shipped_text("PrestressedCable").as_bytes());
    let loads = write("latin1.csv", b"time,P\n0,0\n1,5\xE9\n");
    rejected(
        &["solve", &good, "--loads", &loads],
        &["byte offset 14 (line 3)"],
    );
}

#[test]
fn a_huge_name_is_not_echoed_whole() {
    let long = "x".repeat(100_000);
    let text = shipped_text("PrestressedCable").replacen(
        "\"name\": \"PrestressedCable\"",
        &format!("\"name\": \"9{long}\""),
        1,
    );
    let path = write("long.json", text.as_bytes());
    let t = rejected(&["check", &path], &["name:", "characters"]);
    assert!(t.len() < 1000, "{} bytes", t.len());
    let loads = write("long.csv", format!("time,{long}\n0,1\n").as_bytes());
    let good = write("good2.json", shipped_text("PrestressedCable").as_bytes());
    let t = rejected(&["solve", &good, "--loads", &loads], &["not an input"]);
    assert!(t.len() < 1500, "{} bytes", t.len());
    let _ = CABLE_LOADS;
}

// Issue 14 item 5: explicit triangles on generated nodes.

#[test]
fn explicit_triangles_may_use_generated_nodes_by_id_or_set_name() {
    // A 1 x 1 rectangle (nodes 1..=4 after one explicit node 0) and an explicit triangle from
    // its top-right corner to the explicit node above it.
    let text = r#"{"format": 1, "name": "T",
  "geometry": {"nodes": [[1, 2, 0]],
               "triangles": [[3, "r.corner_tr", 0]],
               "generators": [{"kind": "rectangle", "name": "r", "origin": [0, 0, 0], "size": [1, 1], "divisions": [1, 1]}],
               "triangle_sets": {"cap": [0]}},
  "membranes": [{"name": "m", "triangles": "r", "thickness": 1e-3, "material": {"kind": "svk", "E": 1e6, "nu": 0.3}},
                {"name": "c", "triangles": "cap", "thickness": 1e-3, "material": {"kind": "svk", "E": 1e6, "nu": 0.3}}],
  "supports": [{"nodes": [0, 1, 2, 3, 4], "fix": ["x", "y", "z"]}]}"#;
    let scene = Scene::parse(text.as_bytes()).unwrap();
    assert_eq!(validate(&scene), vec![]);
    let mesh = velarium::scene::generate::resolve(&scene.geometry);
    // Global numbering: explicit node 0, then the rectangle's (i, j) at 1 + 2 j + i.
    assert_eq!(mesh.triangles[0], [3, 4, 0]);
    assert_eq!(mesh.nodes[4], [1.0, 1.0, 0.0]);
    let bad = text
        .replace("\"r.corner_tr\"", "\"r.edge_top\"")
        .replace("[3,", "[9,");
    let p = problems(&bad);
    assert!(
        p.iter()
            .any(|m| m.starts_with("geometry.triangles[0][0]: unknown node 9")),
        "{p:?}"
    );
    assert!(
        p.iter()
            .any(|m| m.starts_with("geometry.triangles[0][1]") && m.contains("2 nodes")),
        "{p:?}"
    );
}
