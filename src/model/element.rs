//! Element kinds: the one list of what the solver assembles, and the interface every element
//! implements.
//!
//! ```text
//! kind        storage            nodes   kernel
//! Membrane    Model::triangles   3       membrane::triangle_with (wrinkling, prestress)
//! Cable       Model::segments    2       cable::segment (tension only; slips, closed links)
//! Tie         Model::ties        2       sleeve::augmented_tie_force, sleeve::tie_stiffness (penalty)
//! ContactPair Model::contact_pairs  2    contact::augmented (two sheets, node to node)
//! ContactPoint Model::contact_points 1   contact::augmented (a node against a rigid surface)
//! ```
//! Loads (pressure on triangles, point forces) and sleeve points (slip unknowns) are not
//! elements: they act on elements or nodes and are handled by their own code.
//!
//! A leaf: the kinds, the trait and [`PerKind`] import nothing of the model. The model
//! registers its storage (`Model::element`, `Model::element_count` in `model/mod.rs`) and
//! implements [`Element`] beside each element's struct (`Triangle`, `Segment` in
//! `model/mod.rs`, `Tie` in `model/sleeve.rs`).
//!
//! Generic code works through [`Element`] and `Model::element` over [`ElementKind::ALL`], so a
//! new kind needs nothing there: the tangent's pattern and position maps
//! (`solver::assemble::Pattern`), nodal relaxation's adjacency (`solver::relax::Adjacency`),
//! the node renumbering's graph (`solver::renumber`), the damping's reference diagonal
//! (`solver::core`) and mechanism detection (`solver::mechanism`).
//!
//! Kind-specific code matches on the kind with no wildcard arm, so adding a variant makes the
//! compiler name every place that must handle it (a place that legitimately does nothing for a
//! kind says so in its arm); the test below checks that no match on `ElementKind` in `src/`
//! has a wildcard arm, so this stays true:
//!
//! ```text
//! model::element       ElementKind::node_count, ElementKind::name (the registration)
//! model                Model::element_count, Model::element (its storage)
//! solver::assemble     visit_order (the order of the sums); the kernels of one assembly on one
//!                      thread (assemble_with) and on two (assemble_two)
//! solver::relax        a node's rows and block (local), a patch's (PatchElements::evaluate)
//! solver::renumber     the membrane normal at a node (node_normals: the rings' sense)
//! solver::sensitivity  the tangent-only parts the true tangent lacks (regularisation_parts)
//! vtk                  the cells of a ParaView file (cells; their data from results)
//! formfind             what form finding prescribes on each kind (check_kinds)
//! ```
//!
//! Mass: [`Element::lumped_mass`] and [`Element::consistent_mass`] default to massless (the
//! tie); the membrane triangle and the cable segment give theirs from the mass they carry
//! (`Triangle::mass`, `Segment::mass`: the group's `density`, the cable's `mass_per_length`).
//! `solver::mass` assembles them into M on the tangent's pattern, which already couples every
//! pair of an element's DOFs.

/// The kinds of element a model may hold.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum ElementKind {
    /// Membrane triangle (constant strain, wrinkling): `Model::triangles`.
    Membrane,
    /// Tension-only cable segment: `Model::segments`.
    Cable,
    /// Penalty tie between a sleeve's cable point and its sleeve node: `Model::ties`.
    Tie,
    /// Unilateral contact of two sheets' partner nodes: `Model::contact_pairs`.
    ContactPair,
    /// Unilateral contact of a node with a rigid surface: `Model::contact_points`.
    ContactPoint,
}

impl ElementKind {
    /// Every kind, in the order an assembly adds them (membranes first: the order of every
    /// floating-point sum measured so far).
    pub const ALL: [ElementKind; 5] = [
        ElementKind::Membrane,
        ElementKind::Cable,
        ElementKind::Tie,
        ElementKind::ContactPair,
        ElementKind::ContactPoint,
    ];

    /// Number of kinds.
    pub const COUNT: usize = ElementKind::ALL.len();

    /// The most nodes an element of any kind has.
    pub const MAX_NODES: usize = {
        let mut most = 0;
        let mut k = 0;
        while k < ElementKind::COUNT {
            let n = ElementKind::ALL[k].node_count();
            if n > most {
                most = n;
            }
            k += 1;
        }
        most
    };

    /// Position of the kind in [`ElementKind::ALL`].
    pub const fn index(self) -> usize {
        self as usize
    }

    /// Nodes of one element of the kind (3 DOFs each: x, y, z).
    pub const fn node_count(self) -> usize {
        match self {
            ElementKind::Membrane => 3,
            ElementKind::Cable => 2,
            ElementKind::Tie => 2,
            ElementKind::ContactPair => 2,
            ElementKind::ContactPoint => 1,
        }
    }

    /// Entries of one element's tangent block, (3 · nodes)².
    pub const fn block_len(self) -> usize {
        let dofs = 3 * self.node_count();
        dofs * dofs
    }

    /// Name in messages.
    pub const fn name(self) -> &'static str {
        match self {
            ElementKind::Membrane => "membrane triangle",
            ElementKind::Cable => "cable segment",
            ElementKind::Tie => "sleeve tie",
            ElementKind::ContactPair => "sheet contact pair",
            ElementKind::ContactPoint => "rigid contact point",
        }
    }
}

/// One value per element kind, indexed by the kind.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PerKind<T>(pub [T; ElementKind::COUNT]);

impl<T> PerKind<T> {
    /// The value of every kind from `f`, in the order of [`ElementKind::ALL`]; the first error
    /// stops it.
    pub fn try_from_fn<E>(mut f: impl FnMut(ElementKind) -> Result<T, E>) -> Result<PerKind<T>, E> {
        let mut values: [Option<T>; ElementKind::COUNT] = std::array::from_fn(|_| None);
        for kind in ElementKind::ALL {
            values[kind.index()] = Some(f(kind)?);
        }
        Ok(PerKind(values.map(|v| v.expect("ALL holds every kind"))))
    }
}

impl<T> std::ops::Index<ElementKind> for PerKind<T> {
    type Output = T;
    fn index(&self, kind: ElementKind) -> &T {
        &self.0[kind.index()]
    }
}

impl<T> std::ops::IndexMut<ElementKind> for PerKind<T> {
    fn index_mut(&mut self, kind: ElementKind) -> &mut T {
        &mut self.0[kind.index()]
    }
}

/// What generic code needs of one element, whatever its kind.
pub trait Element {
    /// Its nodes, in local order: local DOF 3 a + c is component c of node a.
    fn nodes(&self) -> &[usize];

    /// The diagonal stiffness (N/m, the same in x, y and z) its local node `a` would get from
    /// it if it were taut, elastic and unstressed in its reference: the damped system's
    /// reference diagonal D (`solver::core`, `newton.rs`).
    fn reference_stiffness(&self, a: usize) -> f64;

    /// Lumped mass (kg) at local node `a` (a membrane triangle ρ t A/3, a cable segment
    /// ρ_l L/2 per node; massless by default).
    fn lumped_mass(&self, _a: usize) -> f64 {
        0.0
    }

    /// Consistent mass (kg) coupling local nodes `a` and `b`, times the 3x3 identity (a
    /// membrane triangle ρ t A (1 + δ_ab)/12, a cable segment ρ_l L (1 + δ_ab)/6; massless by
    /// default). Its rows sum to [`Element::lumped_mass`].
    fn consistent_mass(&self, _a: usize, _b: usize) -> f64 {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::Model;

    /// A built model with elements of every kind (the shipped sleeve example: a membrane, a
    /// cable, sleeve ties).
    fn model_with_every_kind() -> Model {
        let text = include_str!("../../examples/SleeveDrawstring.json");
        let scene = crate::Scene::from_json(text).expect("the shipped example parses");
        Model::build(&scene)
    }

    /// A cushion on a rigid plane: both contact kinds.
    fn model_with_contacts() -> Model {
        let text = r#"{"format": 1, "name": "C",
            "geometry": {"generators": [{"kind": "cushion", "name": "c", "center": [0, 0, 0],
                "outline": {"shape": "circle", "radius": 1}, "rings": 2, "rise": [0.1, 0.1]}]},
            "membranes": [{"name": "m", "triangles": "c", "thickness": 1e-3,
                "material": {"kind": "svk", "E": 1e9, "nu": 0.3}}],
            "supports": [{"nodes": "c.rim", "fix": ["x", "y", "z"]}],
            "contacts": [{"kind": "sheets", "name": "s", "top": "c.top", "bottom": "c.bottom", "direction": [0, 0, 1]},
                         {"kind": "plane", "name": "p", "nodes": "c.bottom", "point": [0, 0, -0.05], "normal": [0, 0, 1]}]}"#;
        let scene = crate::Scene::from_json(text).expect("the contact scene parses");
        let problems = crate::scene::validate::validate(&scene);
        assert!(problems.is_empty(), "{problems:?}");
        Model::build(&scene)
    }

    /// The registration is complete: `ALL` lists every kind once at its index, and every kind
    /// answers for its count, nodes and reference stiffness on a model that holds it.
    #[test]
    fn every_kind_is_registered_and_answers() {
        assert_eq!(ElementKind::ALL.len(), ElementKind::COUNT);
        for (k, kind) in ElementKind::ALL.into_iter().enumerate() {
            assert_eq!(kind.index(), k, "{kind:?} is not at its index in ALL");
            assert!(kind.node_count() <= ElementKind::MAX_NODES);
            assert_eq!(kind.block_len(), 9 * kind.node_count() * kind.node_count());
        }
        let per = PerKind::try_from_fn(|kind| Ok::<_, ()>(kind.index())).unwrap();
        for kind in ElementKind::ALL {
            assert_eq!(per[kind], kind.index());
        }
        let model = model_with_every_kind();
        let contacts = model_with_contacts();
        let nodes = model.reference.len();
        let mut total = 0;
        for kind in ElementKind::ALL {
            // The contact kinds on a scene of their own (the sleeve example has none).
            let (model, nodes) = match kind {
                ElementKind::Membrane | ElementKind::Cable | ElementKind::Tie => (&model, nodes),
                ElementKind::ContactPair | ElementKind::ContactPoint => {
                    (&contacts, contacts.reference.len())
                }
            };
            let count = model.element_count(kind);
            assert!(count > 0, "the example holds no {}", kind.name());
            for e in 0..count {
                let element = model.element(kind, e);
                let on = model.element_nodes(kind, e);
                assert_eq!(on.len(), kind.node_count(), "{} {e}", kind.name());
                assert_eq!(on, element.nodes());
                for (a, &i) in on.iter().enumerate() {
                    assert!(i < nodes, "{} {e} names node {i} of {nodes}", kind.name());
                    let k = element.reference_stiffness(a);
                    assert!(k > 0.0 && k.is_finite(), "{} {e}: {k}", kind.name());
                    // The consistent rows sum to the lumped mass (mass is conserved).
                    let row: f64 = (0..kind.node_count())
                        .map(|b| element.consistent_mass(a, b))
                        .sum();
                    let lumped = element.lumped_mass(a);
                    assert!(lumped >= 0.0 && (row - lumped).abs() <= 1e-15 * lumped.max(1.0));
                    match kind {
                        ElementKind::Membrane | ElementKind::Cable => {}
                        ElementKind::Tie | ElementKind::ContactPair | ElementKind::ContactPoint => {
                            assert_eq!(lumped, 0.0, "{} is massless", kind.name())
                        }
                    }
                }
            }
            total += count;
        }
        assert_eq!(
            model.elements().count() + contacts.elements().count(),
            total + contacts.element_count(ElementKind::Membrane)
        );
    }

    /// The arms of every `match` in `text` whose arms name `ElementKind::` variants that are
    /// not one or more `ElementKind::Variant` patterns (a wildcard `_`, a binding, a guard):
    /// (line, arm).
    fn loose_arms(text: &str) -> Vec<(usize, String)> {
        let code = strip_comments_and_strings(text);
        let bytes = code.as_bytes();
        let mut out = Vec::new();
        let mut at = 0;
        while let Some(found) = code[at..].find("match ") {
            let start = at + found;
            at = start + 6;
            // A whole word, not the tail of an identifier (`matches!` does not match this).
            if start > 0 && (bytes[start - 1].is_ascii_alphanumeric() || bytes[start - 1] == b'_') {
                continue;
            }
            // The match's block: the first `{` after the scrutinee at nesting depth 0.
            let Some(open) = block_start(&code, at) else {
                continue;
            };
            let arms = arms_of(&code, open);
            if !arms.iter().any(|(_, p)| p.contains("ElementKind::")) {
                continue;
            }
            for (offset, pattern) in arms {
                let plain = pattern
                    .split('|')
                    .map(str::trim)
                    .filter(|p| !p.is_empty())
                    .all(|p| {
                        p.strip_prefix("ElementKind::")
                            .is_some_and(|v| v.chars().all(|c| c.is_ascii_alphanumeric()))
                    });
                if !plain {
                    let line = code[..offset].matches('\n').count() + 1;
                    out.push((line, pattern));
                }
            }
        }
        out
    }

    /// `text` with line and block comments, string and char literals blanked (newlines kept),
    /// so braces in them do not count.
    fn strip_comments_and_strings(text: &str) -> String {
        let chars: Vec<char> = text.chars().collect();
        let mut out = String::with_capacity(text.len());
        let mut i = 0;
        let blank = |c: char| if c == '\n' { '\n' } else { ' ' };
        while i < chars.len() {
            let c = chars[i];
            let next = chars.get(i + 1).copied();
            if c == '/' && next == Some('/') {
                while i < chars.len() && chars[i] != '\n' {
                    out.push(' ');
                    i += 1;
                }
            } else if c == '/' && next == Some('*') {
                while i < chars.len() && !(chars[i] == '*' && chars.get(i + 1) == Some(&'/')) {
                    out.push(blank(chars[i]));
                    i += 1;
                }
                out.push_str("  ");
                i += 2;
            } else if c == 'r' && (next == Some('"') || next == Some('#')) && {
                let mut j = i + 1;
                while chars.get(j) == Some(&'#') {
                    j += 1;
                }
                chars.get(j) == Some(&'"') && (i == 0 || !chars[i - 1].is_alphanumeric())
            } {
                let mut hashes = 0;
                i += 1;
                while chars[i] == '#' {
                    hashes += 1;
                    i += 1;
                }
                i += 1;
                out.push_str(&" ".repeat(hashes + 2));
                loop {
                    if i >= chars.len() {
                        break;
                    }
                    if chars[i] == '"' && (1..=hashes).all(|h| chars.get(i + h) == Some(&'#')) {
                        out.push_str(&" ".repeat(hashes + 1));
                        i += hashes + 1;
                        break;
                    }
                    out.push(blank(chars[i]));
                    i += 1;
                }
            } else if c == '"' {
                out.push(' ');
                i += 1;
                while i < chars.len() && chars[i] != '"' {
                    if chars[i] == '\\' {
                        out.push(' ');
                        i += 1;
                    }
                    if i < chars.len() {
                        out.push(blank(chars[i]));
                        i += 1;
                    }
                }
                out.push(' ');
                i += 1;
            } else if c == '\'' && (next == Some('\\') || chars.get(i + 2) == Some(&'\'')) {
                // A char literal ('{', '\n'); a lifetime ('a) has no closing quote there.
                let end = (i + 1..chars.len())
                    .find(|&j| chars[j] == '\'' && (j > i + 2 || next != Some('\\')))
                    .unwrap_or(chars.len() - 1);
                for _ in i..=end {
                    out.push(' ');
                }
                i = end + 1;
            } else {
                out.push(c);
                i += 1;
            }
        }
        out
    }

    /// Byte offset of the `{` that opens the block of a `match` whose scrutinee starts at
    /// `from`: the first `{` outside parentheses and brackets.
    fn block_start(code: &str, from: usize) -> Option<usize> {
        let mut depth = 0i32;
        for (k, c) in code[from..].char_indices() {
            match c {
                '(' | '[' => depth += 1,
                ')' | ']' => depth -= 1,
                '{' if depth == 0 => return Some(from + k),
                ';' if depth == 0 => return None,
                _ => {}
            }
        }
        None
    }

    /// The arm patterns (text before each top-level `=>`) of the block opening at `open`, with
    /// their byte offsets. A body is a block (to its closing brace) or an expression (to the
    /// next comma outside brackets).
    fn arms_of(code: &str, open: usize) -> Vec<(usize, String)> {
        let b = code.as_bytes();
        let mut arms = Vec::new();
        let mut k = open + 1;
        loop {
            let start = k;
            let mut depth = 0i32;
            let mut arrow = None;
            while k < b.len() {
                match b[k] {
                    b'(' | b'[' | b'{' => depth += 1,
                    b')' | b']' | b'}' if depth == 0 => return arms,
                    b')' | b']' | b'}' => depth -= 1,
                    b'=' if depth == 0 && b.get(k + 1) == Some(&b'>') => {
                        arrow = Some(k);
                        break;
                    }
                    _ => {}
                }
                k += 1;
            }
            let Some(arrow) = arrow else {
                return arms;
            };
            let text = &code[start..arrow];
            let lead = text.len() - text.trim_start().len();
            arms.push((start + lead, text.trim().to_string()));
            k = arrow + 2;
            while k < b.len() && b[k].is_ascii_whitespace() {
                k += 1;
            }
            let block = b.get(k) == Some(&b'{');
            let mut depth = 0i32;
            while k < b.len() {
                match b[k] {
                    b'(' | b'[' | b'{' => depth += 1,
                    b')' | b']' | b'}' if depth == 0 => return arms,
                    b')' | b']' | b'}' => {
                        depth -= 1;
                        if depth == 0 && block {
                            k += 1;
                            while k < b.len() && b[k].is_ascii_whitespace() {
                                k += 1;
                            }
                            if b.get(k) == Some(&b',') {
                                k += 1;
                            }
                            break;
                        }
                    }
                    b',' if depth == 0 => {
                        k += 1;
                        break;
                    }
                    _ => {}
                }
                k += 1;
            }
        }
    }

    fn rust_files(dir: &std::path::Path, out: &mut Vec<std::path::PathBuf>) {
        for entry in std::fs::read_dir(dir).expect("a source directory") {
            let path = entry.expect("a directory entry").path();
            if path.is_dir() {
                rust_files(&path, out);
            } else if path.extension().is_some_and(|e| e == "rs") {
                out.push(path);
            }
        }
    }

    /// The checker finds what it is for, and passes what it should.
    #[test]
    fn the_wildcard_check_can_fail() {
        let loose = "fn f(kind: ElementKind) -> usize {\n    match kind {\n        ElementKind::Membrane => { 3 }\n        // a comment with _ => in it\n        _ => 2,\n    }\n}\n";
        assert_eq!(loose_arms(loose), vec![(5, "_".to_string())]);
        let binding = "match kind { ElementKind::Cable => 1, other => other.index() }";
        assert_eq!(loose_arms(binding), vec![(1, "other".to_string())]);
        let guard = "match kind { ElementKind::Cable if x => 1, ElementKind::Tie => 2 }";
        assert_eq!(loose_arms(guard).len(), 1);
        let exhaustive = "match (kind) {\n    ElementKind::Membrane => f(\"_ => {\", '{'),\n    ElementKind::Cable | ElementKind::Tie => {\n        match x { Some(_) => 1, _ => 2 }\n    }\n}";
        assert!(
            loose_arms(exhaustive).is_empty(),
            "{:?}",
            loose_arms(exhaustive)
        );
        let other = "match x { Some(y) => y, _ => 0 }";
        assert!(loose_arms(other).is_empty());
    }

    /// No `match` on `ElementKind` in `src/` has a wildcard (or binding, or guarded) arm, and
    /// no code tests a kind by comparison, `if let` or `matches!` or imports the variants
    /// bare: adding a kind must make the compiler name every kind-specific place.
    #[test]
    fn no_match_on_element_kind_has_a_wildcard_arm() {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
        let mut files = Vec::new();
        rust_files(&root, &mut files);
        files.sort();
        let mut problems = Vec::new();
        let mut matches = 0;
        for f in &files {
            let text = std::fs::read_to_string(f).expect("a source file");
            // This file's tests hold examples of what is refused.
            let text = match text.find("#[cfg(test)]\nmod tests") {
                Some(k) if f.ends_with("model/element.rs") => &text[..k],
                _ => &text[..],
            };
            let code = strip_comments_and_strings(text);
            matches += code.matches("ElementKind::Membrane =>").count();
            for (line, arm) in loose_arms(text) {
                problems.push(format!("{}:{line}: arm `{arm}`", f.display()));
            }
            for bad in [
                "== ElementKind::",
                "!= ElementKind::",
                "ElementKind::*",
                "let ElementKind::",
            ] {
                if code.contains(bad) {
                    problems.push(format!("{}: `{bad}`", f.display()));
                }
            }
            for (k, _) in code.match_indices("matches!(") {
                let call = &code[k..];
                let call = &call[..call.find(')').unwrap_or(call.len())];
                if call.contains("ElementKind::") {
                    problems.push(format!("{}: `{call})`", f.display()));
                }
            }
        }
        assert!(problems.is_empty(), "{}", problems.join("\n"));
        // The check saw the kind-specific places (the registration alone has four).
        assert!(matches >= 10, "only {matches} matches on ElementKind found");
    }
}
