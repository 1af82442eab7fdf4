//! The architecture of src/, checked on the source (docs/architecture.md):
//! - no import cycle among src files: file A imports file B when it names B through
//!   `crate::...`, `super::...` (an item defined in the parent's file counts as the parent file,
//!   `super::sibling::X` as the sibling), `self::child::...`, or a child module's relative path
//!   (`child::Item` in the file that declares `mod child;`, re-exports included); a bare
//!   `mod child;` declaration is not an import;
//! - the layering that src/lib.rs states: each top-level module imports only modules above it,
//!   with no exception;
//! - unsafe code only in the FMI layer.
//!
//! The checker is a small text scanner (comments and `#[cfg(test)]` modules are skipped); its
//! own tests below run it on made-up sources with a known cycle and a known layer violation.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// The top-level modules in the order src/lib.rs states (each imports only those before it).
/// `error` and `format` are leaves used across the layers: they import only what is listed
/// before them.
const LAYERS: &[&str] = &[
    "format",
    "phases",
    "memory",
    "scene",
    "error",
    "variables",
    "model",
    "solver",
    "formfind",
    "results",
    "engine",
    "description",
    "description3",
    "fmi",
    "vtu",
    "pack",
    "history",
    "vtk",
];

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    if dir.is_file() {
        if dir.extension().is_some_and(|e| e == "rs") {
            out.push(dir.to_path_buf());
        }
        return;
    }
    for entry in std::fs::read_dir(dir).unwrap() {
        rust_files(&entry.unwrap().path(), out);
    }
}

/// The module path of a source file relative to src/ (`solver/newton.rs` -> [solver, newton];
/// `solver/mod.rs` -> [solver]; `lib.rs` and `main.rs` -> []).
fn module_of(rel: &str) -> Vec<String> {
    let mut parts: Vec<String> = rel
        .trim_end_matches(".rs")
        .split('/')
        .map(String::from)
        .collect();
    if matches!(
        parts.last().map(String::as_str),
        Some("mod" | "lib" | "main")
    ) {
        parts.pop();
    }
    parts
}

/// The source without comments, string literals and `#[cfg(test)]` items.
fn code_of(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    let mut skip_depth: Option<usize> = None;
    let mut depth = 0usize;
    let mut pending_test = false;
    for line in text.lines() {
        let trimmed = line.trim_start();
        if trimmed.starts_with("//") {
            continue;
        }
        // Strip string literals and trailing comments (good enough for `use` lines and paths).
        let mut clean = String::new();
        let mut in_str = false;
        let mut prev = ' ';
        let chars: Vec<char> = line.chars().collect();
        let mut i = 0;
        while i < chars.len() {
            let c = chars[i];
            if !in_str && c == '/' && chars.get(i + 1) == Some(&'/') {
                break;
            }
            if c == '"' && prev != '\\' && !(prev == '\'' && chars.get(i + 1) == Some(&'\'')) {
                in_str = !in_str;
            } else if !in_str {
                clean.push(c);
            }
            prev = c;
            i += 1;
        }
        if trimmed.starts_with("#[cfg(test)]") {
            pending_test = true;
            continue;
        }
        let opens = clean.matches('{').count();
        let closes = clean.matches('}').count();
        if pending_test && skip_depth.is_none() && (opens > 0 || clean.trim_end().ends_with(';')) {
            pending_test = false;
            if opens > closes {
                skip_depth = Some(depth);
            }
            depth = depth + opens - closes.min(depth + opens);
            continue;
        }
        depth = (depth + opens).saturating_sub(closes);
        if let Some(d) = skip_depth {
            if depth <= d {
                skip_depth = None;
            }
            continue;
        }
        out.push_str(&clean);
        out.push('\n');
    }
    out
}

/// Every path expression `a::b::c` (and the paths inside `use x::{...}` groups, expanded).
fn paths_in(code: &str) -> Vec<Vec<String>> {
    fn expand(prefix: &[String], group: &str, out: &mut Vec<Vec<String>>) {
        // split a group at top-level commas
        let mut depth = 0;
        let mut start = 0;
        let bytes: Vec<char> = group.chars().collect();
        let mut items = Vec::new();
        for (i, &c) in bytes.iter().enumerate() {
            match c {
                '{' => depth += 1,
                '}' => depth -= 1,
                ',' if depth == 0 => {
                    items.push(bytes[start..i].iter().collect::<String>());
                    start = i + 1;
                }
                _ => {}
            }
        }
        items.push(bytes[start..].iter().collect::<String>());
        for item in items {
            let item = item.trim();
            if item.is_empty() {
                continue;
            }
            if let Some(open) = item.find('{') {
                let head: Vec<String> = item[..open]
                    .trim_end_matches("::")
                    .split("::")
                    .filter(|s| !s.trim().is_empty())
                    .map(|s| s.trim().to_string())
                    .collect();
                let inner = &item[open + 1..item.rfind('}').unwrap_or(item.len())];
                let mut p = prefix.to_vec();
                p.extend(head);
                expand(&p, inner, out);
            } else {
                let item = item.split(" as ").next().unwrap().trim();
                let mut p = prefix.to_vec();
                p.extend(item.split("::").map(|s| s.trim().to_string()));
                out.push(p);
            }
        }
    }
    let mut out = Vec::new();
    // `use` declarations with groups.
    for stmt in code.split(';') {
        let s = stmt.trim();
        let s = s.rsplit('\n').next().unwrap_or(s).trim();
        let body = s
            .strip_prefix("pub use ")
            .or_else(|| s.strip_prefix("pub(crate) use "))
            .or_else(|| s.strip_prefix("pub(super) use "))
            .or_else(|| s.strip_prefix("use "));
        if let Some(body) = body {
            if body.contains('{') {
                expand(&[], body, &mut out);
            }
        }
    }
    // Plain paths anywhere.
    let chars: Vec<char> = code.chars().collect();
    let is_ident = |c: char| c.is_alphanumeric() || c == '_';
    let mut i = 0;
    while i < chars.len() {
        if is_ident(chars[i]) && (i == 0 || !(is_ident(chars[i - 1]) || chars[i - 1] == ':')) {
            let mut segs = Vec::new();
            let mut j = i;
            loop {
                let s = j;
                while j < chars.len() && is_ident(chars[j]) {
                    j += 1;
                }
                segs.push(chars[s..j].iter().collect::<String>());
                if j + 2 < chars.len()
                    && chars[j] == ':'
                    && chars[j + 1] == ':'
                    && is_ident(chars[j + 2])
                {
                    j += 2;
                } else {
                    break;
                }
            }
            if segs.len() > 1 {
                out.push(segs);
            }
            i = j.max(i + 1);
        } else {
            i += 1;
        }
    }
    out
}

/// File-level import graph: module path -> the module paths of the files it imports.
fn graph(files: &BTreeMap<Vec<String>, String>) -> BTreeMap<Vec<String>, BTreeSet<Vec<String>>> {
    let resolve = |segs: &[String]| -> Option<Vec<String>> {
        (1..=segs.len())
            .rev()
            .map(|k| segs[..k].to_vec())
            .find(|p| files.contains_key(p))
    };
    let mut edges = BTreeMap::new();
    for (me, text) in files {
        let code = code_of(text);
        let kids: BTreeSet<String> = code
            .lines()
            .filter_map(|l| {
                let l = l.trim();
                let l = l
                    .strip_prefix("pub ")
                    .or_else(|| l.strip_prefix("pub(crate) "))
                    .unwrap_or(l);
                l.strip_prefix("mod ")
                    .and_then(|r| r.strip_suffix(';'))
                    .map(|s| s.trim().to_string())
            })
            .collect();
        let mut out = BTreeSet::new();
        for p in paths_in(&code) {
            let full: Vec<String> = match p[0].as_str() {
                "crate" => p[1..].to_vec(),
                "self" => me.iter().cloned().chain(p[1..].iter().cloned()).collect(),
                "super" => {
                    let mut base = me.clone();
                    let mut rest = &p[..];
                    while rest.first().map(String::as_str) == Some("super") {
                        base.pop();
                        rest = &rest[1..];
                    }
                    base.into_iter().chain(rest.iter().cloned()).collect()
                }
                k if kids.contains(k) => me.iter().cloned().chain(p.iter().cloned()).collect(),
                _ => continue,
            };
            if let Some(target) = resolve(&full) {
                if &target != me {
                    out.insert(target);
                }
            }
        }
        edges.insert(me.clone(), out);
    }
    edges
}

/// Strongly connected components with more than one file (Tarjan's algorithm).
fn cycles(edges: &BTreeMap<Vec<String>, BTreeSet<Vec<String>>>) -> Vec<Vec<String>> {
    struct Tarjan<'a> {
        nodes: Vec<&'a Vec<String>>,
        index_of: BTreeMap<&'a Vec<String>, usize>,
        edges: &'a BTreeMap<Vec<String>, BTreeSet<Vec<String>>>,
        index: Vec<usize>,
        low: Vec<usize>,
        on_stack: Vec<bool>,
        stack: Vec<usize>,
        next: usize,
        found: Vec<Vec<String>>,
    }
    impl Tarjan<'_> {
        fn visit(&mut self, v: usize) {
            self.index[v] = self.next;
            self.low[v] = self.next;
            self.next += 1;
            self.stack.push(v);
            self.on_stack[v] = true;
            let targets: Vec<usize> = self.edges[self.nodes[v]]
                .iter()
                .filter_map(|w| self.index_of.get(w).copied())
                .collect();
            for w in targets {
                if self.index[w] == usize::MAX {
                    self.visit(w);
                    self.low[v] = self.low[v].min(self.low[w]);
                } else if self.on_stack[w] {
                    self.low[v] = self.low[v].min(self.index[w]);
                }
            }
            if self.low[v] == self.index[v] {
                let mut component = Vec::new();
                loop {
                    let w = self.stack.pop().unwrap();
                    self.on_stack[w] = false;
                    component.push(self.nodes[w].join("::"));
                    if w == v {
                        break;
                    }
                }
                if component.len() > 1 {
                    component.sort();
                    self.found.push(component);
                }
            }
        }
    }
    let nodes: Vec<&Vec<String>> = edges.keys().collect();
    let n = nodes.len();
    let mut t = Tarjan {
        index_of: nodes.iter().enumerate().map(|(i, m)| (*m, i)).collect(),
        nodes,
        edges,
        index: vec![usize::MAX; n],
        low: vec![0; n],
        on_stack: vec![false; n],
        stack: Vec::new(),
        next: 0,
        found: Vec::new(),
    };
    for v in 0..n {
        if t.index[v] == usize::MAX {
            t.visit(v);
        }
    }
    t.found
}

fn sources(root: &Path) -> BTreeMap<Vec<String>, String> {
    let mut files = Vec::new();
    rust_files(&root.join("src"), &mut files);
    files
        .iter()
        .filter(|f| !f.ends_with("main.rs"))
        .map(|f| {
            let rel = f
                .strip_prefix(root.join("src"))
                .unwrap()
                .to_string_lossy()
                .replace('\\', "/");
            (module_of(&rel), std::fs::read_to_string(f).unwrap())
        })
        .collect()
}

#[test]
fn no_import_cycle_among_src_files() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let files = sources(root);
    assert!(files.len() > 50, "found only {} source files", files.len());
    let found = cycles(&graph(&files));
    assert!(
        found.is_empty(),
        "import cycles among src files (each line one strongly connected set):\n{}",
        found
            .iter()
            .map(|c| c.join(", "))
            .collect::<Vec<_>>()
            .join("\n")
    );
}

#[test]
fn modules_import_only_what_is_above_them() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let files = sources(root);
    let edges = graph(&files);
    let rank = |m: &Vec<String>| {
        m.first()
            .and_then(|top| LAYERS.iter().position(|l| l == top))
    };
    let mut violations = Vec::new();
    let mut unranked = BTreeSet::new();
    for (from, tos) in &edges {
        let Some(a) = rank(from) else {
            if !from.is_empty() {
                unranked.insert(from[0].clone());
            }
            continue;
        };
        for to in tos {
            match rank(to) {
                Some(b) if b > a => {
                    violations.push(format!("{} imports {}", from.join("::"), to.join("::")))
                }
                None if !to.is_empty() => {
                    unranked.insert(to[0].clone());
                }
                _ => {}
            }
        }
    }
    assert!(
        unranked.is_empty(),
        "top-level modules missing from LAYERS: {unranked:?}"
    );
    assert!(
        violations.is_empty(),
        "imports against the layering of src/lib.rs:\n{}",
        violations.join("\n")
    );
}

#[test]
fn the_layers_are_the_ones_lib_rs_states() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let lib = std::fs::read_to_string(root.join("src/lib.rs")).unwrap();
    let declared: BTreeSet<String> = lib
        .lines()
        .filter_map(|l| {
            l.strip_prefix("pub mod ")
                .and_then(|r| r.strip_suffix(';'))
                .map(String::from)
        })
        .collect();
    let listed: BTreeSet<String> = LAYERS.iter().map(|s| s.to_string()).collect();
    assert_eq!(
        declared, listed,
        "src/lib.rs's modules and this test's LAYERS differ"
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

/// The checker itself, on made-up files: a cycle through a parent's re-export and a sibling,
/// a child that imports only its sibling (no cycle), a test module's imports ignored.
#[test]
fn the_checker_finds_a_known_cycle_and_nothing_else() {
    let file = |m: &str, t: &str| {
        (
            m.split("::")
                .filter(|s| !s.is_empty())
                .map(String::from)
                .collect::<Vec<_>>(),
            t.to_string(),
        )
    };
    let clean: BTreeMap<_, _> = [
        file("a", "mod b;\nmod c;\npub use b::Thing;\n"),
        file("a::b", "use super::c::Other;\npub struct Thing;\n"),
        file(
            "a::c",
            "pub struct Other;\n#[cfg(test)]\nmod tests {\n    use super::super::b::Thing;\n}\n",
        ),
    ]
    .into_iter()
    .collect();
    assert!(cycles(&graph(&clean)).is_empty(), "{:?}", graph(&clean));
    let cyclic: BTreeMap<_, _> = [
        file("a", "mod b;\nmod c;\npub use b::Thing;\npub struct Root;\n"),
        file("a::b", "use super::Root;\npub struct Thing;\n"),
        file("a::c", "use crate::a::{b::Thing, c};\n"),
    ]
    .into_iter()
    .collect();
    assert_eq!(
        cycles(&graph(&cyclic)),
        vec![vec!["a".to_string(), "a::b".to_string()]]
    );
}
