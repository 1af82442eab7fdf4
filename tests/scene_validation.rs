//! Bad scenes are rejected with every problem located by JSON path; good ones pass.

mod common;
use velarium::scene::{validate::validate, Scene};

fn problems(text: &str) -> Vec<String> {
    match Scene::from_json(text) {
        Err(p) => vec![p.to_string()],
        Ok(s) => validate(&s).iter().map(|p| p.to_string()).collect(),
    }
}

#[test]
fn shipped_scenes_are_valid() {
    for name in ["PrestressedCable", "HenckyDisc", "LiftedMembrane"] {
        let scene = common::read_scene(&common::shipped(name));
        assert_eq!(validate(&scene), vec![], "{name}");
    }
}

#[test]
fn type_errors_name_their_path() {
    let p = problems(
        r#"{"format": 1, "name": "A", "cables": [{"name": "c", "nodes": [0, 1], "EA": "stiff"}]}"#,
    );
    assert_eq!(p.len(), 1);
    assert!(p[0].starts_with("cables[0].EA"), "{p:?}");
    let p = problems(
        r#"{"format": 1, "name": "A", "membranes": [{"name": "m", "triangles": "t", "thickness": 1, "materail": {}}]}"#,
    );
    assert!(
        p[0].contains("membranes[0]") && p[0].contains("materail"),
        "{p:?}"
    );
}

#[test]
fn every_semantic_problem_is_listed_with_its_path() {
    let text = r#"{
      "format": 2, "name": "9bad",
      "geometry": {"nodes": [[0,0,0],[1,0,0],[2,0,0],[0,1,0]], "triangles": [[0,1,2],[0,1,57]]},
      "membranes": [{"name": "m", "triangles": [0], "thickness": -1, "material": {"kind": "svk", "E": 1e6, "nu": 0.7}}],
      "cables": [{"name": "c", "nodes": [3], "EA": 1e5}],
      "supports": [{"nodes": "nowhere", "fix": ["z"]}],
      "inputs": [{"name": "P", "load": {"kind": "pressure", "membrane": "mm"}, "start": 0}],
      "outputs": [{"name": "P", "probe": {"kind": "displacement", "node": 99, "component": "z"}}]
    }"#;
    let p = problems(text);
    let expect = [
        "format:",
        "name:",
        "geometry.triangles[0]: zero-area triangle 0",
        "geometry.triangles[1][2]: unknown node 57",
        "membranes[0].thickness",
        "membranes[0].material.nu",
        "cables[0].nodes: a cable needs at least two nodes",
        "supports[0].nodes: no node set is named \"nowhere\"",
        "inputs[0].load.membrane: no membrane group is named \"mm\"",
        "outputs[0].probe.node: unknown node 99",
        "outputs[0].name: \"P\" is already used",
    ];
    for e in expect {
        assert!(
            p.iter().any(|m| m.starts_with(e) || m.contains(e)),
            "missing {e:?} in {p:#?}"
        );
    }
}

#[test]
fn engine_refuses_an_invalid_scene() {
    let scene = Scene::from_json(
        r#"{"format": 1, "name": "A", "cables": [{"name": "c", "nodes": [0, 1], "EA": 1}]}"#,
    )
    .unwrap();
    let err = velarium::Engine::try_new(scene)
        .err()
        .expect("unknown nodes must be refused");
    assert!(err.to_string().contains("cables[0].nodes[0]"), "{err}");
}

#[test]
fn the_schema_is_json_and_covers_the_format() {
    let schema: serde_json::Value = serde_json::from_str(&Scene::json_schema()).unwrap();
    let text = schema.to_string();
    for key in [
        "membranes",
        "cables",
        "supports",
        "inputs",
        "outputs",
        "parameters",
        "solver",
        "point_force",
        "reaction",
    ] {
        assert!(text.contains(key), "schema lacks {key}");
    }
}
