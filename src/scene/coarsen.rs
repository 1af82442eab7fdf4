//! A coarser copy of a scene with an explicit mesh, for the coarse start (`engine::coarse`),
//! by half-edge collapses (Hoppe 1996, "Progressive meshes", SIGGRAPH; the link condition of
//! Dey, Edelsbrunner, Guha & Nekhayev 1999 keeps the surface's topology).
//!
//! ```text
//! collapse   a node goes onto a neighbour: its triangles take the neighbour instead and the
//!            ones on the edge between them vanish. Nodes keep their places and ids, so the
//!            coarse mesh's nodes are some of this mesh's and every reference to a node holds
//! may go     a node that nothing but triangles and supports names (not a cable's, a load's,
//!            a contact's), inside a sheet or on a straight run (turning by less than 20°) of
//!            a feature line: a free edge, a crease whose triangles turn by more than 30°
//!            (a flat cushion's rim, where the sheets face opposite ways), a border between
//!            membrane groups. A line node goes along its line. The neighbour must be held in
//!            every component the node is held in, so no support is lost on the way
//! keeps      the link condition (the two nodes' common neighbours are the third nodes of the
//!            triangles on their edge: no fold, no duplicate triangle), each moved triangle's
//!            facing (its normal turns by less than 45°) and shape (quality 4√3 A / Σ l² at
//!            least 0.2); of the neighbours that pass, the one that leaves the best shape
//! passes     each pass collapses nodes whose neighbourhoods do not touch (a node, its target
//!            and its neighbours are locked for the pass), until a quarter of the sheets'
//!            nodes is left (as halving a generator's divisions leaves) or a pass removes
//!            less than 1 %; at least half must go, or there is no coarser mesh
//! scene      the same scene with the surviving triangles (renumbered in the membranes, the
//!            triangle sets and a per-triangle prestress field); every node is kept, and one
//!            that no triangle uses any more is held in x, y and z; no outputs
//! ```
//! Not for scenes with generators (those halve their divisions), form finding, or triangle
//! ids named anywhere but the membranes, the triangle sets and the outputs.

use super::generate::{try_resolve, Mesh};
use super::shape::{node_ids, triangle_ids};
use super::{Component, NodeRef, OneNode, Prestress, Scene, Support, TriangleRef};
use std::collections::{BTreeSet, HashMap};

/// Fewer nodes in the sheets than this: no coarser mesh (a 9 x 9 grid; its coarse copy has
/// about 25 nodes, as a generator at its smallest halved divisions).
const MIN_NODES: usize = 81;
/// The share of the sheets' nodes a coarse mesh keeps at most.
const KEEP: f64 = 0.25;
/// A line node goes only where its line turns by less than 20° (cosine).
const STRAIGHT: f64 = 0.939_692_620_785_908_4;
/// Two triangles on an edge that turn by more than 30° make it a feature line (cosine).
const CREASE: f64 = 0.866_025_403_784_438_6;
/// A moved triangle's normal turns by less than 45° (cosine).
const FACING: f64 = std::f64::consts::FRAC_1_SQRT_2;
/// The least shape quality of a moved triangle (1 = equilateral, a right isosceles 0.87).
const MIN_QUALITY: f64 = 0.2;

/// The coarser scene (module docs); None where there is none.
pub fn coarser_explicit(scene: &Scene) -> Option<Scene> {
    let g = &scene.geometry;
    if !g.generators.is_empty() || g.triangles.is_empty() || scene.form_finding.is_some() {
        return None;
    }
    let mesh = try_resolve(g).ok()?;
    let n = mesh.nodes.len();
    if mesh.triangles.iter().flatten().any(|&i| i >= n) {
        return None;
    }
    // Each triangle's membrane group, and each group's triangles in its own order.
    let mut group = vec![usize::MAX; mesh.triangles.len()];
    let mut order = Vec::with_capacity(scene.membranes.len());
    for (k, m) in scene.membranes.iter().enumerate() {
        let ids = triangle_ids(&mesh, &m.triangles);
        for &t in &ids {
            if t >= group.len() || group[t] != usize::MAX {
                return None;
            }
            group[t] = k;
        }
        order.push(ids);
    }
    if group.contains(&usize::MAX) {
        return None;
    }
    let mut held = vec![0u8; n];
    for s in &scene.supports {
        let bits = s.fix.iter().fold(0u8, |b, c| b | 1 << c.index());
        for i in node_ids(&mesh, &s.nodes) {
            *held.get_mut(i)? |= bits;
        }
    }
    let pinned = named_nodes(scene, &mesh)?;
    let mut sheet = Collapse::new(&mesh.nodes, mesh.triangles.clone(), group, held, pinned);
    let before = sheet.live_nodes();
    if before < MIN_NODES {
        return None;
    }
    let target = (KEEP * before as f64).ceil() as usize;
    for _ in 0..30 {
        let removed = sheet.pass(before - target.min(before));
        if sheet.live_nodes() <= target || removed * 100 < before {
            break;
        }
    }
    if 2 * sheet.live_nodes() > before {
        return None;
    }
    sheet.scene(scene, &mesh, &order)
}

/// Nodes named anywhere but in the geometry, the supports, the membranes and the outputs
/// (ids under a node key, and every node of a node set whose name appears as a text); None
/// where a triangle id is named outside the membranes, the triangle sets and the outputs.
fn named_nodes(scene: &Scene, mesh: &Mesh) -> Option<Vec<bool>> {
    use serde_json::Value;
    let mut value = serde_json::to_value(scene).ok()?;
    let object = value.as_object_mut()?;
    for key in ["geometry", "supports", "membranes", "outputs"] {
        object.remove(key);
    }
    let mut pinned = vec![false; mesh.nodes.len()];
    fn walk(v: &Value, key: Option<&str>, mesh: &Mesh, pinned: &mut [bool]) -> bool {
        match v {
            Value::Number(x) => match key {
                Some("nodes" | "node" | "top" | "bottom" | "from" | "to") => {
                    match x.as_u64().and_then(|i| usize::try_from(i).ok()) {
                        Some(i) if i < pinned.len() => {
                            pinned[i] = true;
                            true
                        }
                        _ => false,
                    }
                }
                Some("triangles" | "triangle") => false,
                _ => true,
            },
            Value::String(s) => {
                for &i in mesh.node_sets.get(s).into_iter().flatten() {
                    if let Some(p) = pinned.get_mut(i) {
                        *p = true;
                    }
                }
                true
            }
            Value::Array(a) => a.iter().all(|x| walk(x, key, mesh, pinned)),
            Value::Object(o) => o.iter().all(|(k, x)| {
                let key = match k.as_str() {
                    "nodes" | "node" | "top" | "bottom" | "from" | "to" | "triangles"
                    | "triangle" => Some(k.as_str()),
                    _ => None,
                };
                walk(x, key, mesh, pinned)
            }),
            _ => true,
        }
    }
    walk(&value, None, mesh, &mut pinned).then_some(pinned)
}

/// The mesh being coarsened.
struct Collapse<'a> {
    x: &'a [[f64; 3]],
    triangles: Vec<[usize; 3]>,
    alive: Vec<bool>,
    group: Vec<usize>,
    held: Vec<u8>,
    pinned: Vec<bool>,
    /// Each node's live triangles.
    incident: Vec<Vec<usize>>,
    /// Nodes that had triangles and lost them all.
    removed: Vec<bool>,
}

impl<'a> Collapse<'a> {
    fn new(
        x: &'a [[f64; 3]],
        triangles: Vec<[usize; 3]>,
        group: Vec<usize>,
        held: Vec<u8>,
        pinned: Vec<bool>,
    ) -> Self {
        let mut incident = vec![Vec::new(); x.len()];
        for (t, tri) in triangles.iter().enumerate() {
            for &i in tri {
                incident[i].push(t);
            }
        }
        Collapse {
            x,
            alive: vec![true; triangles.len()],
            triangles,
            group,
            held,
            pinned,
            incident,
            removed: vec![false; x.len()],
        }
    }

    fn live_nodes(&self) -> usize {
        self.incident.iter().filter(|t| !t.is_empty()).count()
    }

    fn normal(&self, t: [usize; 3]) -> [f64; 3] {
        let [a, b, c] = t.map(|i| self.x[i]);
        cross(sub(b, a), sub(c, a))
    }

    /// 4√3 A / (a² + b² + c²): 1 for an equilateral triangle, 0 for a degenerate one.
    fn quality(&self, t: [usize; 3]) -> f64 {
        let [a, b, c] = t.map(|i| self.x[i]);
        let squares =
            dot(sub(b, a), sub(b, a)) + dot(sub(c, b), sub(c, b)) + dot(sub(a, c), sub(a, c));
        let area = 0.5 * norm(self.normal(t));
        if squares > 0.0 {
            4.0 * 3f64.sqrt() * area / squares
        } else {
            0.0
        }
    }

    fn neighbours(&self, v: usize) -> BTreeSet<usize> {
        self.incident[v]
            .iter()
            .flat_map(|&t| self.triangles[t])
            .filter(|&i| i != v)
            .collect()
    }

    /// Every edge's live triangles.
    fn edges(&self) -> HashMap<(usize, usize), Vec<usize>> {
        let mut edges: HashMap<(usize, usize), Vec<usize>> = HashMap::new();
        for (t, tri) in self.triangles.iter().enumerate() {
            if !self.alive[t] {
                continue;
            }
            for k in 0..3 {
                let (a, b) = (tri[k], tri[(k + 1) % 3]);
                edges.entry((a.min(b), a.max(b))).or_default().push(t);
            }
        }
        edges
    }

    fn is_feature(&self, on: &[usize]) -> bool {
        match on {
            [s, t] => {
                let (m, n) = (
                    self.normal(self.triangles[*s]),
                    self.normal(self.triangles[*t]),
                );
                self.group[*s] != self.group[*t] || dot(m, n) < CREASE * norm(m) * norm(n)
            }
            _ => true,
        }
    }

    /// One pass (module docs), removing at most `most` nodes; how many it removed.
    fn pass(&mut self, most: usize) -> usize {
        let mut lines: Vec<Vec<usize>> = vec![Vec::new(); self.x.len()];
        for ((a, b), on) in self.edges() {
            if self.is_feature(&on) {
                lines[a].push(b);
                lines[b].push(a);
            }
        }
        let mut locked = vec![false; self.x.len()];
        let mut removed = 0;
        for v in 0..self.x.len() {
            if removed >= most {
                break;
            }
            if locked[v] || self.pinned[v] || self.incident[v].is_empty() {
                continue;
            }
            let candidates: Vec<usize> = match lines[v].as_slice() {
                [] => self.neighbours(v).into_iter().collect(),
                &[p, q] => {
                    let (a, b) = (sub(self.x[v], self.x[p]), sub(self.x[q], self.x[v]));
                    if dot(a, b) < STRAIGHT * norm(a) * norm(b) {
                        continue;
                    }
                    vec![p, q]
                }
                _ => continue,
            };
            let best = candidates
                .into_iter()
                .filter(|&u| !locked[u] && self.held[v] & !self.held[u] == 0)
                .filter_map(|u| self.shape_after(v, u).map(|q| (q, u)))
                .max_by(|a, b| a.0.total_cmp(&b.0));
            if let Some((_, u)) = best {
                for w in self.neighbours(v) {
                    locked[w] = true;
                }
                locked[v] = true;
                self.collapse(v, u);
                removed += 1;
            }
        }
        removed
    }

    /// The least quality of `v`'s triangles moved onto `u`, if the collapse keeps the link
    /// condition, every facing and the least quality (module docs).
    fn shape_after(&self, v: usize, u: usize) -> Option<f64> {
        let on_edge: BTreeSet<usize> = self.incident[v]
            .iter()
            .map(|&t| self.triangles[t])
            .filter(|t| t.contains(&u))
            .flat_map(|t| t.into_iter().filter(|&i| i != u && i != v))
            .collect();
        let (nv, nu) = (self.neighbours(v), self.neighbours(u));
        if nv.intersection(&nu).copied().collect::<BTreeSet<_>>() != on_edge
            || on_edge.is_empty()
            || on_edge.iter().any(|&w| self.incident[w].len() < 2)
        {
            // Not the link condition, or a third node would lose its last triangle.
            return None;
        }
        let mut least = f64::INFINITY;
        for &t in &self.incident[v] {
            let old = self.triangles[t];
            if old.contains(&u) {
                continue;
            }
            let new = old.map(|i| if i == v { u } else { i });
            let (m, n) = (self.normal(old), self.normal(new));
            if dot(m, n) < FACING * norm(m) * norm(n) {
                return None;
            }
            least = least.min(self.quality(new));
        }
        (least >= MIN_QUALITY).then_some(least)
    }

    fn collapse(&mut self, v: usize, u: usize) {
        for t in std::mem::take(&mut self.incident[v]) {
            if self.triangles[t].contains(&u) {
                self.alive[t] = false;
                for i in self.triangles[t] {
                    self.incident[i].retain(|&s| s != t);
                }
            } else {
                for i in &mut self.triangles[t] {
                    if *i == v {
                        *i = u;
                    }
                }
                self.incident[u].push(t);
            }
        }
        self.removed[v] = true;
    }

    /// The coarse scene (module docs); None where a membrane group lost every triangle.
    fn scene(&self, scene: &Scene, mesh: &Mesh, order: &[Vec<usize>]) -> Option<Scene> {
        let mut id = vec![usize::MAX; self.triangles.len()];
        let mut triangles = Vec::new();
        for (t, tri) in self.triangles.iter().enumerate() {
            if self.alive[t] {
                id[t] = triangles.len();
                triangles.push(tri.map(OneNode::Id));
            }
        }
        let mut out = scene.clone();
        out.geometry.triangles = triangles;
        for set in out.geometry.triangle_sets.values_mut() {
            *set = set
                .iter()
                .filter_map(|&t| id.get(t).copied())
                .filter(|&t| t != usize::MAX)
                .collect();
        }
        for (m, ids) in out.membranes.iter_mut().zip(order) {
            let kept: Vec<usize> = ids
                .iter()
                .map(|&t| id[t])
                .filter(|&t| t != usize::MAX)
                .collect();
            if kept.is_empty() {
                return None;
            }
            if let Some(Prestress::Field { n }) = &mut m.prestress {
                if n.len() != ids.len() {
                    return None;
                }
                *n = n
                    .iter()
                    .zip(ids)
                    .filter(|(_, &t)| id[t] != usize::MAX)
                    .map(|(s, _)| *s)
                    .collect();
            }
            m.triangles = TriangleRef::Ids(kept);
        }
        let gone: Vec<usize> = (0..mesh.nodes.len()).filter(|&i| self.removed[i]).collect();
        if !gone.is_empty() {
            out.supports.push(Support {
                nodes: NodeRef::Ids(gone),
                fix: vec![Component::X, Component::Y, Component::Z],
            });
        }
        out.outputs.clear();
        Some(out)
    }
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn norm(a: [f64; 3]) -> f64 {
    dot(a, a).sqrt()
}

#[cfg(test)]
mod tests {
    use super::coarser_explicit;
    use crate::scene::generate::{resolve, Mesh};
    use crate::scene::validate::validate;
    use crate::Scene;
    use serde_json::json;

    /// Quality, area and normal's z of each triangle of a mesh.
    fn shapes(mesh: &Mesh) -> Vec<(f64, f64, f64)> {
        mesh.triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| mesh.nodes[i]);
                let n = super::cross(super::sub(b, a), super::sub(c, a));
                let s: f64 = [(a, b), (b, c), (c, a)]
                    .iter()
                    .map(|&(p, q)| super::dot(super::sub(q, p), super::sub(q, p)))
                    .sum();
                let area = 0.5 * super::norm(n);
                (4.0 * 3f64.sqrt() * area / s, area, n[2])
            })
            .collect()
    }

    fn used(mesh: &Mesh) -> std::collections::BTreeSet<usize> {
        mesh.triangles.iter().flatten().copied().collect()
    }

    /// A flat 4 m x 3 m sheet, 24 x 18 cells written out explicitly, held in x, y, z on its
    /// left edge, a point force on one inside node, a per-triangle prestress field whose xx
    /// entry is the triangle's id. REQUIRED: at most a third of the nodes left (a quarter
    /// aimed at); the outline kept exactly (the area, 12 m², to round-off, 1e-12 relative: a
    /// collapse along a straight edge or inside moves no boundary); every triangle still
    /// counter-clockwise and of quality at least 0.2; the four corners, every held node's
    /// partner and the loaded node kept; the prestress field filtered with its triangles (its
    /// ids still rising); every node no triangle uses held in x, y, z; the scene valid.
    #[test]
    fn a_flat_sheet_keeps_its_outline_supports_and_named_nodes() {
        let (nx, ny) = (24, 18);
        let gen = json!({"generators": [{"kind": "rectangle", "name": "g", "origin": [0, 0, 0], "size": [4, 3], "divisions": [nx, ny]}]});
        let mesh = resolve(&serde_json::from_value(gen).unwrap());
        let loaded = mesh.node_sets["g.center"][0];
        let field: Vec<[f64; 6]> = (0..mesh.triangles.len())
            .map(|t| [t as f64, 1.0, 0.0, 0.0, 0.0, 0.0])
            .collect();
        let text = json!({
            "format": 1, "name": "T",
            "geometry": {"nodes": mesh.nodes, "triangles": mesh.triangles,
                         "node_sets": {"left": mesh.node_sets["g.edge_left"], "c": [loaded]}},
            "membranes": [{"name": "m", "triangles": (0..mesh.triangles.len()).collect::<Vec<_>>(), "thickness": 1e-3,
                           "material": {"kind": "svk", "E": 1e9, "nu": 0.3},
                           "prestress": {"kind": "field", "n": field}}],
            "supports": [{"nodes": "left", "fix": ["x", "y", "z"]}],
            "inputs": [{"name": "F", "load": {"kind": "point_force", "nodes": "c", "direction": [0, 0, 1]}}],
            "outputs": [{"name": "s", "probe": {"kind": "element_state", "triangle": 5}}]
        });
        let scene = Scene::from_json(&text.to_string()).expect("valid scene");
        let coarse = coarser_explicit(&scene).expect("a coarser mesh");
        assert!(validate(&coarse).is_empty(), "{:?}", validate(&coarse));
        let cmesh = resolve(&coarse.geometry);
        let kept = used(&cmesh);
        let nodes = (nx + 1) * (ny + 1);
        println!(
            "{} of {nodes} nodes, {} triangles",
            kept.len(),
            cmesh.triangles.len()
        );
        assert!(3 * kept.len() <= nodes, "{} of {nodes}", kept.len());
        let s = shapes(&cmesh);
        let area: f64 = s.iter().map(|x| x.1).sum();
        assert!((area - 12.0).abs() < 1e-12 * 12.0, "area {area}");
        assert!(s.iter().all(|&(q, _, z)| q >= 0.2 && z > 0.0));
        for c in ["g.corner_bl", "g.corner_br", "g.corner_tl", "g.corner_tr"] {
            assert!(kept.contains(&mesh.node_sets[c][0]), "{c}");
        }
        assert!(kept.contains(&loaded));
        // Every boundary edge of the coarse mesh lies on the outline, and on the left edge
        // it joins held nodes.
        let mut count = std::collections::HashMap::new();
        for t in &cmesh.triangles {
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                *count.entry((a.min(b), a.max(b))).or_insert(0) += 1;
            }
        }
        let left: std::collections::BTreeSet<usize> =
            mesh.node_sets["g.edge_left"].iter().copied().collect();
        for (&(a, b), &k) in &count {
            if k == 1 {
                let (p, q) = (cmesh.nodes[a], cmesh.nodes[b]);
                let on = |i: usize, v: f64| (p[i] - v).abs() < 1e-12 && (q[i] - v).abs() < 1e-12;
                assert!(
                    on(0, 0.0) || on(0, 4.0) || on(1, 0.0) || on(1, 3.0),
                    "{p:?} {q:?}"
                );
                if on(0, 0.0) {
                    assert!(left.contains(&a) && left.contains(&b));
                }
            }
        }
        let m = &coarse.membranes[0];
        let ids = match &m.triangles {
            crate::scene::TriangleRef::Ids(ids) => ids.clone(),
            other => panic!("{other:?}"),
        };
        assert_eq!(ids.len(), cmesh.triangles.len());
        match &m.prestress {
            Some(crate::scene::Prestress::Field { n }) => {
                assert_eq!(n.len(), ids.len());
                assert!(n.windows(2).all(|w| w[0][0] < w[1][0]));
            }
            other => panic!("{other:?}"),
        }
        let held = crate::scene::shape::node_ids(&cmesh, &coarse.supports[1].nodes);
        assert_eq!(coarse.supports[1].fix.len(), 3);
        assert_eq!(held.len() + kept.len(), nodes);
        assert!(held.iter().all(|i| !kept.contains(i)));
        assert!(coarse.outputs.is_empty());
    }

    /// The flat two-sheet quarter cushion of the robustness corpus (16 x 16 cells, sheets
    /// sharing the rim x = a or y = a, symmetry planes x = 0 and y = 0): the two sheets lie on
    /// top of each other and face opposite ways. REQUIRED: each coarse triangle faces the way
    /// its sheet does and belongs to one sheet (no triangle joins a top node inside to a
    /// bottom one; one with all three nodes on the rim counts to the sheet it faces); each sheet keeps its area a² exactly (1e-12 relative); the rim's three
    /// corners (on the axes and at (a, a)) and the centre nodes of both sheets (on both
    /// symmetry planes) kept; at most a third of the nodes left.
    #[test]
    fn a_flat_quarter_cushion_keeps_its_two_sheets_apart() {
        let (n, a) = (16usize, 0.7);
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
        let top_count = (n + 1) * (n + 1);
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
        let text = json!({
            "format": 1, "name": "Q",
            "geometry": {"nodes": nodes, "triangles": triangles,
                         "node_sets": {"rim": zfix, "xfix": xfix, "yfix": yfix}},
            "membranes": [{"name": "sheets", "triangles": (0..triangles.len()).collect::<Vec<_>>(),
                           "thickness": 1e-4, "material": {"kind": "svk", "E": 3e9, "nu": 0.3}}],
            "supports": [{"nodes": "rim", "fix": ["z"]}, {"nodes": "xfix", "fix": ["x"]},
                         {"nodes": "yfix", "fix": ["y"]}],
            "inputs": [{"name": "p", "load": {"kind": "pressure", "membrane": "sheets"}}]
        });
        let scene = Scene::from_json(&text.to_string()).expect("valid scene");
        let coarse = coarser_explicit(&scene).expect("a coarser mesh");
        assert!(validate(&coarse).is_empty(), "{:?}", validate(&coarse));
        let cmesh = resolve(&coarse.geometry);
        let kept = used(&cmesh);
        println!("{} of {} nodes", kept.len(), nodes.len());
        assert!(3 * kept.len() <= nodes.len());
        let is_rim = |k: usize| k < top_count && rim(k % (n + 1), k / (n + 1));
        let mut area = [0.0, 0.0];
        for (t, s) in cmesh.triangles.iter().zip(shapes(&cmesh)) {
            let top = t.iter().any(|&k| k < top_count && !is_rim(k));
            let bot = t.iter().any(|&k| k >= top_count);
            assert!(!(top && bot), "{t:?} joins the sheets");
            // A triangle with all three nodes on the rim (across a corner) belongs to the
            // sheet it faces.
            assert!(!top || s.2 > 0.0, "{t:?} turned over");
            assert!(!bot || s.2 < 0.0, "{t:?} turned over");
            area[(s.2 < 0.0) as usize] += s.1;
        }
        for s in area {
            assert!((s - a * a).abs() < 1e-12 * a * a, "{area:?}");
        }
        for k in [id(0, n), id(n, 0), id(n, n), id(0, 0), bottom[id(0, 0)]] {
            assert!(kept.contains(&k), "node {k}");
        }
    }

    /// Where there is no coarser explicit mesh: a generated mesh (it halves its divisions
    /// instead), form finding, fewer than 81 nodes in the sheets, a triangle named by id
    /// outside the membranes, the sets and the outputs.
    #[test]
    fn no_coarser_explicit_mesh_where_it_does_not_apply() {
        let sheet = |n: usize| {
            let g = json!({"generators": [{"kind": "rectangle", "name": "g", "origin": [0, 0, 0], "size": [1, 1], "divisions": [n, n]}]});
            resolve(&serde_json::from_value(g).unwrap())
        };
        let scene = |mesh: &Mesh, extra: serde_json::Value| {
            let mut v = json!({
                "format": 1, "name": "T",
                "geometry": {"nodes": mesh.nodes, "triangles": mesh.triangles,
                             "node_sets": {"edge": mesh.node_sets["g.boundary"]}},
                "membranes": [{"name": "m", "triangles": (0..mesh.triangles.len()).collect::<Vec<_>>(), "thickness": 1e-3,
                               "material": {"kind": "svk", "E": 1e9, "nu": 0.3}}],
                "supports": [{"nodes": "edge", "fix": ["x", "y", "z"]}]
            });
            for (k, x) in extra.as_object().unwrap() {
                v[k] = x.clone();
            }
            Scene::from_json(&v.to_string()).expect("valid scene")
        };
        assert!(
            coarser_explicit(&scene(&sheet(8), json!({}))).is_some(),
            "81 nodes"
        );
        assert!(
            coarser_explicit(&scene(&sheet(7), json!({}))).is_none(),
            "64 nodes"
        );
        let generated = Scene::from_json(
            &json!({"format": 1, "name": "G",
                "geometry": {"generators": [{"kind": "rectangle", "name": "g", "origin": [0, 0, 0], "size": [1, 1], "divisions": [16, 16]}]},
                "membranes": [{"name": "m", "triangles": "g", "thickness": 1e-3, "material": {"kind": "svk", "E": 1e9, "nu": 0.3}}],
                "supports": [{"nodes": "g.boundary", "fix": ["x", "y", "z"]}]})
            .to_string(),
        )
        .expect("valid scene");
        assert!(coarser_explicit(&generated).is_none());
        let mut found = scene(&sheet(16), json!({}));
        found.form_finding = Some(serde_json::from_value(json!({})).expect("form finding"));
        assert!(coarser_explicit(&found).is_none());
    }
}
