//! The committed `modelDescription/<Name>/modelDescription.xml` of every shipped scene equals the
//! one generated from its `scene.json` now: a change to the scene, the variable table or the
//! generator that changes the description (and so the GUID) must come with the regenerated file.

use std::path::{Path, PathBuf};
use velarium::description::model_description;
use velarium::{Engine, Scene};

fn shipped() -> Vec<PathBuf> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("modelDescription");
    let mut dirs: Vec<PathBuf> = match std::fs::read_dir(&root) {
        Ok(entries) => entries
            .map(|e| e.unwrap().path())
            .filter(|p| p.is_dir())
            .collect(),
        Err(_) => Vec::new(),
    };
    dirs.sort();
    dirs
}

#[test]
fn committed_model_descriptions_are_current() {
    let dirs = shipped();
    if dirs.is_empty() {
        eprintln!("skipped: no modelDescription/<Name>/ directories yet");
        return;
    }
    let mut stale = Vec::new();
    for dir in &dirs {
        let name = dir.file_name().unwrap().to_string_lossy().into_owned();
        let scene_path = dir.join("scene.json");
        let text = std::fs::read_to_string(&scene_path)
            .unwrap_or_else(|e| panic!("{}: {e}", scene_path.display()));
        let scene =
            Scene::from_json(&text).unwrap_or_else(|p| panic!("{}: {p}", scene_path.display()));
        assert_eq!(
            scene.name,
            name,
            "{}: the scene's name must be its directory's",
            scene_path.display()
        );
        let engine =
            Engine::try_new(scene).unwrap_or_else(|e| panic!("{}: {e}", scene_path.display()));
        let generated = model_description(engine.scene(), engine.variables());
        let committed_path = dir.join("modelDescription.xml");
        let regenerate = format!(
            "regenerate it with\n  cargo run --release -- describe modelDescription/{name}/scene.json \
             > modelDescription/{name}/modelDescription.xml"
        );
        match std::fs::read_to_string(&committed_path) {
            Err(e) => stale.push(format!("{}: {e}; {regenerate}", committed_path.display())),
            Ok(committed) if committed != generated => {
                let line = first_difference(&committed, &generated);
                stale.push(format!(
                    "modelDescription/{name}/modelDescription.xml is stale (first difference at line {line}); {regenerate}"
                ));
            }
            Ok(_) => {}
        }
    }
    assert!(stale.is_empty(), "{}", stale.join("\n"));
}

/// 1-based line of the first difference between two texts.
fn first_difference(a: &str, b: &str) -> usize {
    let common = a.lines().zip(b.lines()).take_while(|(x, y)| x == y).count();
    common + 1
}
