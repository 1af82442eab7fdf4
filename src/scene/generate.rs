//! Mesh generators: the explicit geometry plus every generator, resolved into one node list,
//! one triangle list and named sets.
//!
//! ```text
//! rectangle  (nx+1)(ny+1) nodes, 2 nx ny triangles, node (i, j) = j (nx+1) + i
//! disc       1 + 3 n (n+1) nodes: centre, ring k (1..=n) has 6k nodes at radius k a/n;
//!            6 n² triangles, nearly equilateral
//! annulus    (rings+1) · sectors nodes, 2 rings · sectors triangles, radii graded geometrically
//! cushion    2 + m rings² nodes, 2 m rings² triangles (m corners of the outline): `cushion.rs`
//! ```
//! Triangles are counter-clockwise seen from +z, so their normals point to +z (a cushion's
//! bottom sheet the other way: outward).

use super::{DiagonalPattern, Generator, Geometry, OneNode};
use crate::memory::{self, OutOfMemory};
use std::collections::BTreeMap;
use std::f64::consts::PI;

/// The resolved mesh of a scene.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Mesh {
    pub nodes: Vec<[f64; 3]>,
    pub triangles: Vec<[usize; 3]>,
    pub node_sets: BTreeMap<String, Vec<usize>>,
    pub triangle_sets: BTreeMap<String, Vec<usize>>,
}

/// Nodes and triangles one generator makes (saturating).
pub fn generator_counts(gen: &Generator) -> (u64, u64) {
    match gen {
        Generator::Rectangle { divisions, .. } => {
            let [nx, ny] = divisions.map(|d| d as u64);
            (
                (nx.saturating_add(1)).saturating_mul(ny.saturating_add(1)),
                2u64.saturating_mul(nx).saturating_mul(ny),
            )
        }
        Generator::Disc { rings, .. } => {
            let n = *rings as u64;
            (
                1u64.saturating_add(3u64.saturating_mul(n).saturating_mul(n.saturating_add(1))),
                6u64.saturating_mul(n).saturating_mul(n),
            )
        }
        Generator::Annulus { rings, sectors, .. } => {
            let (r, s) = (*rings as u64, *sectors as u64);
            (
                r.saturating_add(1).saturating_mul(s),
                2u64.saturating_mul(r).saturating_mul(s),
            )
        }
        Generator::Cushion { outline, rings, .. } => {
            super::cushion::counts(outline.sides(), *rings)
        }
    }
}

/// Resolve explicit geometry and generators, for tools and tests: [`try_resolve`], panicking
/// if the memory cannot be had (the library itself always calls [`try_resolve`]).
pub fn resolve(geometry: &Geometry) -> Mesh {
    try_resolve(geometry).unwrap_or_else(|e| panic!("{e}"))
}

/// Resolve explicit geometry and generators. Generators never fail: sizes are checked by
/// validation before (a zero division count simply yields no triangles here). The node and
/// triangle lists are reserved exactly from the generators' counts and the named sets (about
/// one index per node and per triangle) are probed first, so that a shortage of memory is an
/// [`OutOfMemory`], never an abort.
pub fn try_resolve(geometry: &Geometry) -> Result<Mesh, OutOfMemory> {
    let _phase = crate::phases::start("mesh generation (try_resolve)");
    let (mut n, mut t) = (geometry.nodes.len() as u64, geometry.triangles.len() as u64);
    for g in &geometry.generators {
        let (gn, gt) = generator_counts(g);
        n = n.saturating_add(gn);
        t = t.saturating_add(gt);
    }
    let too_many = |what| OutOfMemory {
        what,
        bytes: u64::MAX,
    };
    let n = usize::try_from(n).map_err(|_| too_many("the mesh's nodes"))?;
    let t = usize::try_from(t).map_err(|_| too_many("the mesh's triangles"))?;
    // The sets (every generator's "all" and triangle set, its edges: at most the nodes again)
    // are built while the nodes and triangles are held, so the probe asks for all of it at
    // once: 24 bytes per node and per triangle, 8 per set entry.
    let sets = (n as u64).saturating_mul(2).saturating_add(t as u64);
    memory::probe(
        (n as u64)
            .saturating_add(t as u64)
            .saturating_mul(24)
            .saturating_add(sets.saturating_mul(8)),
        "the mesh with its node and triangle sets",
    )?;
    let mut nodes = memory::with_capacity(n, "the mesh's nodes")?;
    nodes.extend_from_slice(&geometry.nodes);
    let mut triangles = memory::with_capacity(t, "the mesh's triangles")?;
    // Explicit triangles come first; their nodes are resolved once every set exists.
    triangles.resize(geometry.triangles.len(), [usize::MAX; 3]);
    let mut mesh = Mesh {
        nodes,
        triangles,
        node_sets: geometry.node_sets.clone(),
        triangle_sets: geometry.triangle_sets.clone(),
    };
    for g in &geometry.generators {
        match g {
            Generator::Rectangle {
                name,
                origin,
                size,
                divisions,
                pattern,
            } => rectangle(&mut mesh, name, *origin, *size, *divisions, *pattern),
            Generator::Disc {
                name,
                center,
                radius,
                rings,
            } => disc(&mut mesh, name, *center, *radius, *rings),
            Generator::Annulus {
                name,
                center,
                inner_radius,
                outer_radius,
                rings,
                sectors,
                grading,
            } => annulus(
                &mut mesh,
                name,
                *center,
                [*inner_radius, *outer_radius],
                [*rings, *sectors],
                *grading,
            ),
            Generator::Cushion {
                name,
                center,
                outline,
                rings,
                rise,
            } => super::cushion::cushion(
                super::cushion::Target {
                    nodes: &mut mesh.nodes,
                    triangles: &mut mesh.triangles,
                    node_sets: &mut mesh.node_sets,
                    triangle_sets: &mut mesh.triangle_sets,
                },
                name,
                *center,
                outline,
                *rings,
                *rise,
            ),
        }
    }
    for (k, t) in geometry.triangles.iter().enumerate() {
        mesh.triangles[k] = [0, 1, 2].map(|c| node_id(&mesh, &t[c]));
    }
    Ok(mesh)
}

/// The geometry with every generator's mesh written out as explicit nodes, triangles and sets
/// (what a user's own mesher gives): the same nodes, triangles and sets with the same ids, and
/// no generators. The coarse start makes an explicit mesh's coarser meshes by edge
/// collapses, a generated one's by halving its divisions (`scene::coarsen`).
pub fn written_out(geometry: &Geometry) -> Result<Geometry, OutOfMemory> {
    let mesh = try_resolve(geometry)?;
    Ok(Geometry {
        nodes: mesh.nodes,
        triangles: mesh.triangles.iter().map(|t| t.map(OneNode::Id)).collect(),
        node_sets: mesh.node_sets,
        triangle_sets: mesh.triangle_sets,
        generators: Vec::new(),
    })
}

/// The global id of a triangle corner: an id, or the one node of a set (usize::MAX when the
/// set does not exist or has not exactly one node; validation reports it).
pub fn node_id(mesh: &Mesh, r: &OneNode) -> usize {
    match r {
        OneNode::Id(id) => *id,
        OneNode::Set(name) => match mesh.node_sets.get(name).map(Vec::as_slice) {
            Some([id]) => *id,
            _ => usize::MAX,
        },
    }
}

impl Mesh {
    /// Append a triangle, swapping two nodes if it is clockwise seen from +z.
    fn push_ccw(&mut self, t: [usize; 3]) {
        let [a, b, c] = t.map(|i| self.nodes[i]);
        let cross = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
        self.triangles
            .push(if cross < 0.0 { [t[0], t[2], t[1]] } else { t });
    }

    fn add_sets(&mut self, name: &str, sets: Vec<(&str, Vec<usize>)>, tris: Vec<usize>) {
        for (k, v) in sets {
            self.node_sets.insert(format!("{name}.{k}"), v);
        }
        self.triangle_sets.insert(name.to_string(), tris);
    }
}

fn rectangle(
    mesh: &mut Mesh,
    name: &str,
    origin: [f64; 3],
    size: [f64; 2],
    divisions: [usize; 2],
    pattern: DiagonalPattern,
) {
    let [nx, ny] = divisions;
    let base = mesh.nodes.len();
    let id = |i: usize, j: usize| base + j * (nx + 1) + i;
    for j in 0..=ny {
        for i in 0..=nx {
            let x = origin[0] + size[0] * i as f64 / nx.max(1) as f64;
            let y = origin[1] + size[1] * j as f64 / ny.max(1) as f64;
            mesh.nodes.push([x, y, origin[2]]);
        }
    }
    let t0 = mesh.triangles.len();
    for j in 0..ny {
        for i in 0..nx {
            let (a, b, c, d) = (id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1));
            let right = match pattern {
                DiagonalPattern::Right => true,
                DiagonalPattern::Left => false,
                DiagonalPattern::Crossed => (i + j) % 2 == 0,
            };
            if right {
                mesh.push_ccw([a, b, c]);
                mesh.push_ccw([a, c, d]);
            } else {
                mesh.push_ccw([a, b, d]);
                mesh.push_ccw([b, c, d]);
            }
        }
    }
    let bottom: Vec<usize> = (0..=nx).map(|i| id(i, 0)).collect();
    let top: Vec<usize> = (0..=nx).map(|i| id(i, ny)).collect();
    let left: Vec<usize> = (0..=ny).map(|j| id(0, j)).collect();
    let right: Vec<usize> = (0..=ny).map(|j| id(nx, j)).collect();
    let mut boundary: Vec<usize> = bottom
        .iter()
        .chain(&top)
        .chain(&left)
        .chain(&right)
        .copied()
        .collect();
    boundary.sort_unstable();
    boundary.dedup();
    let sets = vec![
        ("all", (base..mesh.nodes.len()).collect()),
        ("edge_bottom", bottom),
        ("edge_top", top),
        ("edge_left", left),
        ("edge_right", right),
        ("corner_bl", vec![id(0, 0)]),
        ("corner_br", vec![id(nx, 0)]),
        ("corner_tl", vec![id(0, ny)]),
        ("corner_tr", vec![id(nx, ny)]),
        ("center", vec![id(nx / 2, ny / 2)]),
        ("boundary", boundary),
    ];
    let tris = (t0..mesh.triangles.len()).collect();
    mesh.add_sets(name, sets, tris);
}

fn disc(mesh: &mut Mesh, name: &str, center: [f64; 3], radius: f64, rings: usize) {
    let base = mesh.nodes.len();
    mesh.nodes.push(center);
    // First node id of ring k (k >= 1): 1 + 3k(k-1).
    let ring_start = |k: usize| base + 1 + 3 * k * (k - 1);
    let node = |k: usize, m: usize| {
        if k == 0 {
            base
        } else {
            ring_start(k) + m % (6 * k)
        }
    };
    for k in 1..=rings {
        let r = radius * k as f64 / rings as f64;
        for m in 0..6 * k {
            let phi = 2.0 * PI * m as f64 / (6 * k) as f64;
            mesh.nodes.push([
                center[0] + r * phi.cos(),
                center[1] + r * phi.sin(),
                center[2],
            ]);
        }
    }
    let t0 = mesh.triangles.len();
    for k in 1..=rings {
        // Six sectors; in each, ring k has k+1 nodes (shared ends) and ring k-1 has k.
        for s in 0..6 {
            for i in 0..k {
                let outer_a = node(k, s * k + i);
                let outer_b = node(k, s * k + i + 1);
                let inner_a = node(k - 1, s * (k - 1) + i);
                mesh.push_ccw([inner_a, outer_a, outer_b]);
                if i + 1 < k {
                    let inner_b = node(k - 1, s * (k - 1) + i + 1);
                    mesh.push_ccw([inner_a, outer_b, inner_b]);
                }
            }
        }
    }
    let rim: Vec<usize> = if rings == 0 {
        vec![]
    } else {
        (0..6 * rings).map(|m| node(rings, m)).collect()
    };
    let sets = vec![
        ("all", (base..mesh.nodes.len()).collect()),
        ("center", vec![base]),
        ("rim", rim.clone()),
        ("boundary", rim),
    ];
    let tris = (t0..mesh.triangles.len()).collect();
    mesh.add_sets(name, sets, tris);
}

fn annulus(
    mesh: &mut Mesh,
    name: &str,
    center: [f64; 3],
    radii: [f64; 2],
    counts: [usize; 2],
    grading: f64,
) {
    let ([a, b], [rings, sectors]) = (radii, counts);
    let base = mesh.nodes.len();
    let node = |k: usize, m: usize| base + k * sectors + m % sectors;
    // Radial cell sizes h, h g, h g², ... summing to b - a.
    let weights: Vec<f64> = (0..rings).map(|k| grading.powi(k as i32)).collect();
    let total: f64 = weights.iter().sum();
    let mut r = a;
    for k in 0..=rings {
        if k > 0 {
            r += (b - a) * weights[k - 1] / total;
        }
        for m in 0..sectors {
            let phi = 2.0 * PI * (m as f64 + 0.5 * (k % 2) as f64) / sectors as f64;
            mesh.nodes.push([
                center[0] + r * phi.cos(),
                center[1] + r * phi.sin(),
                center[2],
            ]);
        }
    }
    let t0 = mesh.triangles.len();
    for k in 0..rings {
        for m in 0..sectors {
            let (p, q) = (node(k, m), node(k, m + 1));
            if k % 2 == 0 {
                let (s, t) = (node(k + 1, m), node(k + 1, m + 1));
                mesh.push_ccw([p, q, s]);
                mesh.push_ccw([q, t, s]);
            } else {
                let (s, t) = (node(k + 1, m + 1), node(k + 1, m + 2));
                mesh.push_ccw([p, q, s]);
                mesh.push_ccw([q, t, s]);
            }
        }
    }
    let inner: Vec<usize> = (0..sectors).map(|m| node(0, m)).collect();
    let outer: Vec<usize> = (0..sectors).map(|m| node(rings, m)).collect();
    let boundary = inner.iter().chain(&outer).copied().collect();
    let sets = vec![
        ("all", (base..mesh.nodes.len()).collect()),
        ("inner_rim", inner),
        ("outer_rim", outer),
        ("boundary", boundary),
    ];
    let tris = (t0..mesh.triangles.len()).collect();
    mesh.add_sets(name, sets, tris);
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A mesh written out (explicit nodes and a disc generator after them, and a rectangle)
    /// resolves to the same nodes, triangles and sets, ids included, with no generators.
    #[test]
    fn a_mesh_written_out_resolves_to_itself() {
        let geometry: Geometry = serde_json::from_value(serde_json::json!({
            "nodes": [[9.0, 9.0, 1.0]],
            "triangles": [[0, "d.center", "r.corner_tr"]],
            "node_sets": {"extra": [0]},
            "generators": [
                {"kind": "disc", "name": "d", "center": [0, 0, 0], "radius": 1, "rings": 3},
                {"kind": "rectangle", "name": "r", "origin": [2, 0, 0], "size": [1, 2], "divisions": [2, 3]}]
        }))
        .expect("geometry");
        let (mesh, out) = (
            resolve(&geometry),
            written_out(&geometry).expect("written out"),
        );
        assert!(out.generators.is_empty());
        let again = resolve(&out);
        assert_eq!(again.nodes, mesh.nodes);
        assert_eq!(again.triangles, mesh.triangles);
        assert_eq!(again.node_sets, mesh.node_sets);
        assert_eq!(again.triangle_sets, mesh.triangle_sets);
        assert_eq!(
            mesh.triangles[0],
            [
                0,
                mesh.node_sets["d.center"][0],
                mesh.node_sets["r.corner_tr"][0]
            ]
        );
    }

    fn area(m: &Mesh) -> f64 {
        m.triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| m.nodes[i]);
                0.5 * ((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]))
            })
            .sum()
    }

    fn geometry(g: Generator) -> Geometry {
        Geometry {
            generators: vec![g],
            ..Default::default()
        }
    }

    #[test]
    fn rectangle_counts_area_and_orientation() {
        for pattern in [
            DiagonalPattern::Right,
            DiagonalPattern::Left,
            DiagonalPattern::Crossed,
        ] {
            let m = resolve(&geometry(Generator::Rectangle {
                name: "r".into(),
                origin: [1.0, 2.0, 0.5],
                size: [2.0, 1.0],
                divisions: [4, 3],
                pattern,
            }));
            assert_eq!(m.nodes.len(), 20);
            assert_eq!(m.triangles.len(), 24);
            assert!((area(&m) - 2.0).abs() < 1e-12);
            assert_eq!(m.node_sets["r.edge_left"].len(), 4);
            assert_eq!(m.node_sets["r.boundary"].len(), 14);
        }
    }

    #[test]
    fn disc_counts_and_area_converge() {
        let m = resolve(&geometry(Generator::Disc {
            name: "d".into(),
            center: [0.0; 3],
            radius: 1.0,
            rings: 8,
        }));
        assert_eq!(m.nodes.len(), 1 + 3 * 8 * 9);
        assert_eq!(m.triangles.len(), 6 * 64);
        // Inscribed polygon with 48 sides: area = 24 sin(2π/48).
        let exact = 0.5 * 48.0 * (2.0 * PI / 48.0).sin();
        assert!((area(&m) - exact).abs() < 1e-12, "{}", area(&m));
        assert_eq!(m.node_sets["d.rim"].len(), 48);
    }

    #[test]
    fn annulus_area_positive_everywhere() {
        let m = resolve(&geometry(Generator::Annulus {
            name: "a".into(),
            center: [0.0; 3],
            inner_radius: 0.25,
            outer_radius: 1.0,
            rings: 6,
            sectors: 40,
            grading: 1.2,
        }));
        assert_eq!(m.nodes.len(), 7 * 40);
        assert_eq!(m.triangles.len(), 2 * 6 * 40);
        assert!(area(&m) > 0.9 * PI * (1.0 - 0.0625));
        let signed = |t: &[usize; 3]| {
            let [a, b, c] = t.map(|i| m.nodes[i]);
            (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
        };
        assert!(m.triangles.iter().all(|t| signed(t) > 0.0));
    }
}
