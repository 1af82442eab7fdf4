//! Bad sleeves and sleeve probes are rejected with every problem located by JSON path; the
//! shipped sleeve scenes are valid.

use crate::common;
use velarium::scene::{validate::validate, Scene};

fn problems(text: &str) -> Vec<String> {
    match Scene::from_json(text) {
        Err(p) => vec![p.to_string()],
        Ok(s) => validate(&s).iter().map(|p| p.to_string()).collect(),
    }
}

#[test]
fn shipped_sleeve_scenes_are_valid() {
    for name in ["SlidingCable", "SleeveCable"] {
        let scene = common::read_scene(&common::shipped(name));
        assert_eq!(validate(&scene), vec![], "{name}");
    }
}

#[test]
fn bad_sleeves_and_probes_name_their_paths() {
    let text = r#"{
      "format": 1, "name": "Bad",
      "geometry": {"nodes": [[0,0,0],[1,0,0],[2,0,0],[3,0,0]]},
      "cables": [
        {"name": "c", "nodes": [0, 1, 2, 3], "EA": 1e4, "pretension": 10,
         "sleeve": {"mu": -0.1, "penalty": 0, "nodes": [0, 2, 2]}},
        {"name": "plain", "nodes": [0, 3], "EA": 1e4}
      ],
      "supports": [{"nodes": [0, 3], "fix": ["x", "y", "z"]}],
      "outputs": [
        {"name": "s", "probe": {"kind": "cable_slip", "cable": "c", "node": 3}},
        {"name": "g", "probe": {"kind": "contact_gap", "cable": "plain"}},
        {"name": "l", "probe": {"kind": "cable_length", "cable": "c", "from": 2, "to": 1}},
        {"name": "n", "probe": {"kind": "slip_count", "cable": "nope", "state": "slip"}}
      ]
    }"#;
    let p = problems(text);
    let expect = [
        "cables[0].sleeve.mu: -0.1 is not a friction coefficient >= 0",
        "cables[0].sleeve.penalty: 0 is not a positive penalty stiffness in N/m",
        "cables[0].sleeve.nodes[0]: node 0 is not an interior node of cable \"c\"",
        "cables[0].sleeve.nodes[2]: node 2 is listed twice",
        "outputs[0].probe.node: node 3 is not a sleeve node of cable \"c\"",
        "outputs[1].probe.cable: cable \"plain\" has no sleeve",
        "outputs[2].probe.to: must come after `from` along the cable",
        "outputs[3].probe.cable: no cable is named \"nope\"",
    ];
    for e in expect {
        assert!(
            p.iter().any(|q| q.starts_with(e)),
            "missing {e:?} in {p:#?}"
        );
    }
}

#[test]
fn mu_is_a_tunable_parameter_with_a_checked_range() {
    let mut scene = common::read_scene(&common::shipped("SlidingCable"));
    let mut e = common::engine(scene.clone());
    let vr = common::vr(&e, "mu");
    assert!(
        e.set_real(vr, -0.2).is_err(),
        "a negative friction coefficient is refused"
    );
    assert!(e.set_real(vr, 0.4).is_ok());
    scene.cables[0].sleeve.as_mut().unwrap().mu = f64::NAN;
    assert!(velarium::Engine::try_new(scene).is_err());
}
