//! Issue 27, point 8: plausibility warnings (`velarium::scene::plausibility`). Each warning
//! fires on a scene made wrong on purpose, names the JSON path and its numbers, and leaves the
//! scene valid (`velarium check` exits 0 and prints it after the summary); no warning fires on
//! any shipped scene (every `modelDescription/*/scene.json` and `examples/*.json`, and the
//! scene the FourPointSail's form finding hands its analysis), the check that keeps the
//! thresholds honest. Thresholds: strain 5 %, modulus 100x outside the usual range of its
//! material kind, a sleeve penalty below the stiffness of what it ties (the module docs give
//! the numbers and their sources). The margins of the shipped scenes are printed.

use crate::common;
use crate::hostile_input::{rejected, write};
use std::process::Command;
use velarium::scene::plausibility::{measures, warnings, Check};
use velarium::scene::validate::validate;
use velarium::Scene;

const VELARIUM: &str = env!("CARGO_BIN_EXE_velarium");

fn scene_text(path: &str) -> String {
    std::fs::read_to_string(path).unwrap()
}

/// Every shipped scene file: the FMUs' scenes and the examples.
fn shipped_files() -> Vec<String> {
    let root = env!("CARGO_MANIFEST_DIR");
    let mut files = Vec::new();
    for dir in ["modelDescription", "examples"] {
        for entry in std::fs::read_dir(format!("{root}/{dir}")).unwrap() {
            let path = entry.unwrap().path();
            let file = if path.is_dir() {
                path.join("scene.json")
            } else {
                path
            };
            if file.extension().is_some_and(|e| e == "json") && file.exists() {
                files.push(file.display().to_string());
            }
        }
    }
    files.sort();
    files
}

/// The scene with `from` replaced by `to` in its text (once; `from` must be there).
fn edited(name: &str, from: &str, to: &str) -> Scene {
    let text = scene_text(&common::shipped(name));
    assert!(text.contains(from), "{name}: {from}");
    let scene = Scene::from_json(&text.replacen(from, to, 1)).unwrap();
    assert_eq!(validate(&scene), vec![], "the edited scene is still valid");
    scene
}

fn lines(scene: &Scene) -> Vec<String> {
    warnings(scene).iter().map(|w| w.to_string()).collect()
}

#[test]
fn no_shipped_scene_warns_and_their_margins_are_printed() {
    let files = shipped_files();
    assert!(files.len() >= 11, "{files:?}");
    let mut scenes: Vec<(String, Scene)> = files
        .iter()
        .map(|f| (f.clone(), common::read_scene(f)))
        .collect();
    // What an FMU of the FourPointSail checks: the found scene (a `field` prestress and
    // per-segment pretensions), not the one that asks for form finding.
    let sail = common::engine(common::read_scene(&common::shipped("FourPointSail")));
    scenes.push(("FourPointSail, found".into(), sail.scene().clone()));
    for (name, scene) in &scenes {
        assert_eq!(validate(scene), vec![], "{name}");
        assert_eq!(lines(scene), Vec::<String>::new(), "{name}");
        let all = measures(scene);
        let mut margins = Vec::new();
        for check in [Check::Prestrain, Check::Modulus, Check::Penalty] {
            if let Some(m) = all
                .iter()
                .filter(|m| m.check == check)
                .max_by(|a, b| a.ratio.total_cmp(&b.ratio))
            {
                assert!(m.ratio <= 1.0, "{name}: {m:?}");
                margins.push(format!("{check:?} {:.3} at {}", m.ratio, m.path));
            }
        }
        println!(
            "{name}: largest ratio to the threshold: {}",
            margins.join("; ")
        );
    }
}

#[test]
fn each_warning_fires_on_a_scene_made_wrong_and_names_its_numbers() {
    // E = 600 Pa on the Hencky disc (1e6 / 600 = 1667x below a sheet's usual range).
    let w = lines(&edited("HenckyDisc", "\"E\": 2e8", "\"E\": 600"));
    assert_eq!(w.len(), 1, "{w:?}");
    assert!(
        w[0].starts_with("membranes[0].material.E: 6e2 Pa is 1667x below the usual range"),
        "{w:?}"
    );
    // A neo-Hookean mu of 1e10 Pa (333x above a rubber's usual shear modulus, 3e7).
    let w = lines(&edited("SleeveCable", "\"mu\": 300000.0", "\"mu\": 1e10"));
    assert!(
        w.iter()
            .any(|l| l.starts_with("membranes[0].material.mu: 1e10 Pa is 333x above")),
        "{w:?}"
    );
    // The FourPointSail's prestress given in N/mm-like numbers: 2e5 N/m on E t = 6e5 N/m,
    // strain (1 − 0.3) 2e5 / 6e5 = 23.3 %.
    let w = lines(&edited("FourPointSail", "\"n\": 2000", "\"n\": 200000"));
    assert_eq!(w.len(), 1, "{w:?}");
    assert!(
        w[0].starts_with("membranes[0].prestress: an isotropic prestress of 2e5 N/m")
            && w[0].contains("strain of 23.3 %"),
        "{w:?}"
    );
    // A cable pretension of 6 % of EA (the PrestressedCable: EA 1e5 N).
    let w = lines(&edited(
        "PrestressedCable",
        "\"pretension\": 100",
        "\"pretension\": 6000",
    ));
    assert_eq!(w.len(), 1, "{w:?}");
    assert!(
        w[0].starts_with(
            "cables[0].pretension: a tension of 6e3 N on EA = 1e5 N implies a strain of 6.00 %"
        ),
        "{w:?}"
    );
    // An unstretched length 10 % short of the cable's 2 m.
    let mut cable = common::read_scene(&common::shipped("PrestressedCable"));
    cable.cables[0].pretension = None;
    cable.cables[0].unstretched_length = Some(1.818);
    cable
        .parameters
        .retain(|p| !p.target.ends_with("pretension"));
    assert_eq!(validate(&cable), vec![]);
    let w = lines(&cable);
    assert!(
        w.len() == 1
            && w[0].starts_with(
                "cables[0].unstretched_length: 1.818e0 m against the cable's length 2e0 m"
            ),
        "{w:?}"
    );
    // A sleeve penalty of 1 N/m on the SleeveCable (EA/l_min = 200 / 0.01 = 2e4 N/m, E t of the
    // rubber 3 · 3e5 · 5e-4 = 450 N/m): softer than the cable; the default is 100x the stiffer.
    let w = lines(&edited(
        "SleeveCable",
        "\"mu\": 0.3",
        "\"mu\": 0.3, \"penalty\": 1.0",
    ));
    assert!(
        w.len() == 1
            && w[0].starts_with("cables[0].sleeve.penalty: 1e0 N/m is softer than the members it ties (EA/l_min = 2e4 N/m"),
        "{w:?}"
    );
    // At the stiffness of the cable itself it no longer warns.
    let w = lines(&edited(
        "SleeveCable",
        "\"mu\": 0.3",
        "\"mu\": 0.3, \"penalty\": 2.1e4",
    ));
    assert_eq!(w, Vec::<String>::new());
}

/// Orthotropic fabric (E_warp 1e9, E_fill 5e8 Pa, nu_wf 0.3, t = 1 mm) with a warp/fill
/// prestress: ε_fill = n_f/(E_f t) − ν_wf n_w/(E_w t); 30 kN/m fill and 10 kN/m warp give
/// 6.0 % − 0.3 % = 5.7 %, a warning; 20 kN/m fill 3.7 %, none. A `field` prestress on the same
/// fabric takes the larger principal force over the softer modulus: 3e4 N/m, 6 %.
#[test]
fn orthotropic_and_field_prestress_strains_follow_the_compliance() {
    let group = |prestress: &str| {
        format!(
            r#"{{"format": 1, "name": "Fabric",
  "geometry": {{"generators": [{{"kind": "rectangle", "name": "sq", "origin": [0, 0, 0], "size": [1, 1], "divisions": [1, 1]}}]}},
  "membranes": [{{"name": "f", "triangles": "sq", "thickness": 1e-3,
     "material": {{"kind": "orthotropic", "E_warp": 1e9, "E_fill": 5e8, "nu_wf": 0.3, "G": 2e7, "warp": [1, 0, 0]}},
     "prestress": {prestress}}}],
  "supports": [{{"nodes": "sq.all", "fix": ["x", "y", "z"]}}]}}"#
        )
    };
    let strain_of = |prestress: &str| {
        let scene = Scene::from_json(&group(prestress)).unwrap();
        assert_eq!(validate(&scene), vec![]);
        let m = measures(&scene);
        let p = m.iter().find(|m| m.check == Check::Prestrain).unwrap();
        (p.ratio * 0.05, lines(&scene))
    };
    let (e, w) = strain_of(
        r#"{"kind": "warp_fill", "warp": 1e4, "fill": 3e4, "warp_direction": [1, 0, 0]}"#,
    );
    assert!((e - 0.057).abs() < 1e-12, "{e}");
    assert!(w.len() == 1 && w[0].contains("strain of 5.70 %"), "{w:?}");
    let (e, w) = strain_of(
        r#"{"kind": "warp_fill", "warp": 1e4, "fill": 2e4, "warp_direction": [1, 0, 0]}"#,
    );
    assert!((e - 0.037).abs() < 1e-12 && w.is_empty(), "{e} {w:?}");
    let (e, w) =
        strain_of(r#"{"kind": "field", "n": [[1e4, 3e4, 0, 0, 0, 0], [1e4, 2e4, 0, 0, 0, 0]]}"#);
    assert!((e - 0.06).abs() < 1e-12, "{e}");
    assert!(
        w.len() == 1 && w[0].contains("the prestress field (triangle 0 of the group)"),
        "{w:?}"
    );
}

/// `velarium check` prints each warning as `warning: path: message` after the summary and the
/// cost line, and exits 0 (the scene is valid); a scene that also has a problem exits 1 with
/// the problem (warnings are only computed for valid scenes).
#[test]
fn check_prints_warnings_after_the_summary_and_exits_0() {
    let text = scene_text(&common::shipped("HenckyDisc")).replacen("\"E\": 2e8", "\"E\": 600", 1);
    let file = write("hencky_600pa.json", text.as_bytes());
    let out = Command::new(VELARIUM)
        .args(["check", &file])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(0));
    let stdout = String::from_utf8_lossy(&out.stdout);
    let lines: Vec<&str> = stdout.lines().collect();
    assert_eq!(lines.len(), 3, "{stdout}");
    assert!(lines[0].starts_with("ok: HenckyDisc") && lines[1].starts_with("cost: "));
    assert!(
        lines[2].starts_with("warning: membranes[0].material.E: 6e2 Pa is 1667x below"),
        "{stdout}"
    );
    let broken = text.replacen("\"thickness\": 1e-4", "\"thickness\": -1", 1);
    let file = write("hencky_600pa_broken.json", broken.as_bytes());
    let t = rejected(&["check", &file], &["membranes[0].thickness"]);
    assert!(!t.contains("warning:"), "{t}");
}

/// `velarium check` says when the coarse start applies (docs/solver.md "The coarse start"):
/// the shipped Hencky disc (2163 free DOF, below `auto`'s 10 000) gets no such line; the same
/// disc at 64 rings written out as an explicit mesh (36 291 free DOF) gets one naming the two
/// ways a coarser mesh is made; with `coarse_start: off` it does not.
#[test]
fn check_names_the_coarse_start_of_a_large_explicit_mesh() {
    let mut scene: Scene = Scene::from_json(&scene_text(&common::shipped("HenckyDisc"))).unwrap();
    let lines = |scene: &Scene, name: &str| {
        let file = write(name, serde_json::to_string(scene).unwrap().as_bytes());
        let out = Command::new(VELARIUM)
            .args(["check", &file])
            .output()
            .unwrap();
        assert_eq!(out.status.code(), Some(0));
        String::from_utf8_lossy(&out.stdout)
            .lines()
            .filter(|l| l.starts_with("coarse start:"))
            .map(String::from)
            .collect::<Vec<_>>()
    };
    assert!(lines(&scene, "hencky_16.json").is_empty());
    if let velarium::scene::Generator::Disc { rings, .. } = &mut scene.geometry.generators[0] {
        *rings = 64;
    }
    scene.geometry =
        velarium::scene::generate::written_out(&scene.geometry).expect("the mesh written out");
    let found = lines(&scene, "hencky_64_explicit.json");
    assert!(
        found.len() == 1 && found[0].contains("an explicit one with edges collapsed"),
        "{found:?}"
    );
    scene.solver.coarse_start = velarium::scene::CoarseStart::Off;
    assert!(lines(&scene, "hencky_64_explicit_off.json").is_empty());
}
