//! The one-way data flow of STYLE.md, checked on the source: a module imports only modules
//! above it (scene -> variables -> model -> solver -> results -> engine -> fmi/description/...).

use std::path::Path;

/// (module path prefix, modules it must not import)
const RULES: &[(&str, &[&str])] = &[
    (
        "src/scene",
        &[
            "variables",
            "model",
            "solver",
            "results",
            "engine",
            "fmi",
            "description",
            "pack",
            "history",
        ],
    ),
    (
        "src/model",
        &[
            "solver",
            "results",
            "engine",
            "fmi",
            "description",
            "pack",
            "history",
            "variables",
        ],
    ),
    (
        "src/solver",
        &[
            "scene",
            "results",
            "engine",
            "fmi",
            "description",
            "pack",
            "history",
            "variables",
        ],
    ),
    (
        "src/formfind.rs",
        &["results", "engine", "fmi", "description", "pack", "history"],
    ),
    (
        "src/results.rs",
        &["engine", "fmi", "scene", "description", "pack", "history"],
    ),
    ("src/engine.rs", &["fmi", "description", "pack", "history"]),
];

fn rust_files(dir: &Path, out: &mut Vec<std::path::PathBuf>) {
    if dir.is_file() {
        out.push(dir.to_path_buf());
        return;
    }
    for entry in std::fs::read_dir(dir).unwrap() {
        rust_files(&entry.unwrap().path(), out);
    }
}

#[test]
fn modules_import_only_what_is_above_them() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut violations = Vec::new();
    for (prefix, forbidden) in RULES {
        let mut files = Vec::new();
        rust_files(&root.join(prefix), &mut files);
        assert!(!files.is_empty(), "{prefix} has no source");
        for f in files {
            let text = std::fs::read_to_string(&f).unwrap();
            for line in text
                .lines()
                .filter(|l| l.contains("crate::") && !l.trim_start().starts_with("//"))
            {
                for m in *forbidden {
                    if line.contains(&format!("crate::{m}")) {
                        violations.push(format!("{}: {}", f.display(), line.trim()));
                    }
                }
            }
        }
    }
    assert!(
        violations.is_empty(),
        "imports against the data flow:\n{}",
        violations.join("\n")
    );
}

#[test]
fn unsafe_code_lives_only_in_the_fmi_layer() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut files = Vec::new();
    rust_files(&root.join("src"), &mut files);
    for f in files {
        if f.starts_with(root.join("src/fmi")) {
            continue;
        }
        let text = std::fs::read_to_string(&f).unwrap();
        assert!(
            !text.contains("unsafe "),
            "{} uses unsafe outside src/fmi",
            f.display()
        );
    }
}
