//! Node renumbering for locality (issue 15 item 2): an internal position for every node, once
//! per model, so that the solver's speed does not depend on how the user's mesher numbered the
//! nodes.
//!
//! ```text
//! rank[node]      internal position of a node (a permutation of 0..nodes)
//! eq[dof]         equation numbers are handed out in rank order (assemble.rs): the tangent's
//!                 pattern, and so the input to faer's AMD ordering, no longer depends on the
//!                 user's numbering, and K's columns are local in space
//! triangle order  triangles are visited by their lowest-ranked node (ties by the highest, then
//!                 the middle one), so one assembly walks the mesh front to back and scatters
//!                 into nearby columns of K
//! ```
//!
//! Nothing user-visible changes: the displacement vector, reactions, element evaluations,
//! outputs, probes, CSV, VTK, FMU arrays, node sets and messages stay in the user's numbering
//! (node `i` is always DOFs 3i..3i+3 of every vector outside the linear solve). Only the
//! equation numbering inside [`super::assemble::Pattern`] and the element visit order change,
//! and with them the order in which floating-point sums are formed (results agree to
//! round-off). Neither depends on the user's numbering, so two numberings of one mesh form the
//! assembly's sums in the same order; nodal relaxation still sweeps in the user's order, so
//! where it runs their Newton paths can differ (docs/performance.md, What is not done).
//!
//! Three orderings (`solver.node_order`; docs/performance.md has the measurements):
//! - **Rings** (the default): breadth first from a central node of each connected part (the
//!   node most balanced between the two ends of a pseudo-diameter), so the levels grow
//!   outward like a generator's rings; a node's new neighbours are taken counterclockwise
//!   around its membrane normal, starting from the direction to the node that reached it, so
//!   each level runs around the front in one sense. faer's AMD, given the equations in this
//!   order, fills the Hencky disc's factor as little as it does in the generator's own ring
//!   order (0.97-1.02x), and 15-30 % less than in a shuffled order.
//! - **Reverse Cuthill-McKee** on the node graph (an edge wherever an element joins two nodes):
//!   breadth first from a pseudo-peripheral node (George & Liu 1979), neighbours by increasing
//!   degree, reversed. About 15 % more fill than the rings on the disc.
//! - **Hilbert curve** on the reference coordinates (3D, 21 bits per axis, Skilling 2004):
//!   nodes close on the curve are close in space. About 25 % more fill than the rings.
//!
//! Every tie (the start node, neighbours at the same angle or degree) is broken by the nodes'
//! Hilbert keys, never by their numbers, so a shuffled numbering of the same mesh gets the same
//! order (nodes at the same point excepted, which then go by number).
//!
//! # References
//! Cuthill & McKee 1969; George & Liu 1979, "An implementation of a pseudoperipheral node
//! finder", ACM TOMS 5(3); Skilling 2004, "Programming the Hilbert curve", AIP Conf. Proc. 707.

use crate::memory::{self, OutOfMemory};
use crate::model::{ElementKind, Model};
use nalgebra::Vector3;

const WHAT: &str = "the node renumbering";
const NONE: usize = usize::MAX;

/// Internal node numbering of the linear solve (the scene's `solver.node_order`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum NodeOrder {
    /// Breadth-first rings outward from a central node, each ring counterclockwise.
    #[default]
    Rings,
    /// Reverse Cuthill-McKee on the node graph.
    Rcm,
    /// A Hilbert curve through the reference coordinates.
    Hilbert,
    /// The model's own numbering.
    Given,
}

/// Internal position of every node of `model` under `order` (`rank[node]`), a permutation.
pub fn node_rank(model: &Model, order: NodeOrder) -> Result<Vec<usize>, OutOfMemory> {
    match order {
        NodeOrder::Rcm | NodeOrder::Rings => node_rank_on(model, order, &node_graph(model)?),
        _ => node_rank_on(model, order, &(Vec::new(), Vec::new())),
    }
}

/// [`node_rank`] with the model's [`node_graph`] built by the caller (the pattern reads it
/// too: built once; unread under `Hilbert` and `Given`).
pub(super) fn node_rank_on(
    model: &Model,
    order: NodeOrder,
    graph: &(Vec<usize>, Vec<usize>),
) -> Result<Vec<usize>, OutOfMemory> {
    node_rank_prepared(model, order, graph, None)
}

/// [`node_rank_on`] with the Cuthill-McKee order's keys, seeds and normals computed
/// elsewhere ([`Prepared`]; None: here).
pub(super) fn node_rank_prepared(
    model: &Model,
    order: NodeOrder,
    graph: &(Vec<usize>, Vec<usize>),
    prepared: Option<Prepared>,
) -> Result<Vec<usize>, OutOfMemory> {
    let n = model.reference.len();
    let sequence = match order {
        NodeOrder::Given => return memory::collect(0..n, WHAT),
        NodeOrder::Rcm => cuthill_mckee(model, false, graph, prepared)?,
        NodeOrder::Rings => cuthill_mckee(model, true, graph, prepared)?,
        NodeOrder::Hilbert => hilbert(model)?,
    };
    let mut rank = memory::filled(n, usize::MAX, WHAT)?;
    for (k, &node) in sequence.iter().enumerate() {
        rank[node] = k;
    }
    debug_assert!(rank.iter().all(|&r| r < n));
    Ok(rank)
}

/// The node graph: every pair of nodes joined by an element of any kind (CSR, sorted, no self
/// loops, no duplicates).
pub(super) fn node_graph(model: &Model) -> Result<(Vec<usize>, Vec<usize>), OutOfMemory> {
    let n = model.reference.len();
    // The triangles' node triples read straight from the model (most of the elements; no
    // per-element dispatch), the other kinds through `element_nodes`.
    let pairs = |nodes: &[usize], f: &mut dyn FnMut(usize, usize)| {
        for a in 0..nodes.len() {
            for b in a + 1..nodes.len() {
                if nodes[a] != nodes[b] {
                    f(nodes[a], nodes[b]);
                }
            }
        }
    };
    let edges = |f: &mut dyn FnMut(usize, usize)| {
        for kind in ElementKind::ALL {
            match kind {
                ElementKind::Membrane => {
                    for t in &model.triangles {
                        pairs(&t.nodes, f);
                    }
                }
                ElementKind::Cable
                | ElementKind::Tie
                | ElementKind::ContactPair
                | ElementKind::ContactPoint => {
                    for e in 0..model.element_count(kind) {
                        pairs(model.element_nodes(kind, e), f);
                    }
                }
            }
        }
    };
    let mut start = memory::zeros::<usize>(n + 1, WHAT)?;
    edges(&mut |a, b| {
        start[a + 1] += 1;
        start[b + 1] += 1;
    });
    for i in 0..n {
        start[i + 1] += start[i];
    }
    let mut adj = memory::lazy_zeros::<usize>(start[n], WHAT)?;
    let mut next = memory::copy(&start[..n], WHAT)?;
    edges(&mut |a, b| {
        adj[next[a]] = b;
        next[a] += 1;
        adj[next[b]] = a;
        next[b] += 1;
    });
    drop(next);
    // Sort and dedup each node's list in place, compacting.
    let mut ptr = memory::with_capacity(n + 1, WHAT)?;
    ptr.push(0);
    let mut kept = 0;
    for i in 0..n {
        adj[start[i]..start[i + 1]].sort_unstable();
        let mut last = usize::MAX;
        for k in start[i]..start[i + 1] {
            let j = adj[k];
            if j != last {
                adj[kept] = j;
                kept += 1;
                last = j;
            }
        }
        ptr.push(kept);
    }
    adj.truncate(kept);
    Ok((ptr, adj))
}

/// What the Cuthill-McKee order reads besides the node graph: every node's Hilbert key, the
/// nodes by key (the components' seeds) and every node's membrane normal. They need only the
/// reference coordinates and the triangles' nodes ([`PrepareInput`]): with two threads they
/// are computed on the solver's helper while the node graph is built (`assemble.rs`).
#[derive(Debug, PartialEq)]
pub(super) struct Prepared {
    keys: Vec<u64>,
    seeds: Vec<usize>,
    normal: Vec<Vector3<f64>>,
}

/// What [`Prepared`] is computed from, copied from the model.
pub(super) struct PrepareInput {
    reference: Vec<Vector3<f64>>,
    triangles: Vec<[usize; 3]>,
}

impl PrepareInput {
    pub(super) fn copy(model: &Model) -> Result<PrepareInput, OutOfMemory> {
        Ok(PrepareInput {
            reference: memory::copy(&model.reference, WHAT)?,
            triangles: memory::collect(model.triangles.iter().map(|t| t.nodes), WHAT)?,
        })
    }

    pub(super) fn prepare(self) -> Result<Prepared, OutOfMemory> {
        prepare(&self.reference, self.triangles.iter().copied())
    }
}

/// [`Prepared`] of the nodes at `reference` and the triangles' nodes `triangles` (the
/// model's, in model order).
fn prepare(
    reference: &[Vector3<f64>],
    triangles: impl Iterator<Item = [usize; 3]>,
) -> Result<Prepared, OutOfMemory> {
    let keys = hilbert_keys_of(reference)?;
    let mut seeds = memory::collect(0..reference.len(), WHAT)?;
    seeds.sort_unstable_by_key(|&i| (keys[i], i));
    let normal = normals_of(reference, triangles)?;
    Ok(Prepared {
        keys,
        seeds,
        normal,
    })
}

/// Unit normal of the membrane at every node (area-weighted over its triangles; zero at a
/// node no triangle touches). Lines have no surface: a node only on cables has no normal,
/// and its neighbours go by degree (as in Cuthill-McKee).
fn normals_of(
    reference: &[Vector3<f64>],
    triangles: impl Iterator<Item = [usize; 3]>,
) -> Result<Vec<Vector3<f64>>, OutOfMemory> {
    let mut normal = memory::filled(reference.len(), Vector3::zeros(), WHAT)?;
    for nodes in triangles {
        let [a, b, c] = nodes.map(|i| reference[i]);
        let w = (b - a).cross(&(c - a));
        for &i in &nodes {
            normal[i] += w;
        }
    }
    for v in &mut normal {
        let l = v.norm();
        *v = if l > 0.0 { *v / l } else { Vector3::zeros() };
    }
    Ok(normal)
}

/// Unit normal of the membrane at every node (area-weighted over its triangles; zero at a
/// node no triangle touches).
#[cfg(test)]
fn node_normals(model: &Model) -> Result<Vec<Vector3<f64>>, OutOfMemory> {
    let mut normal = memory::filled(model.reference.len(), Vector3::zeros(), WHAT)?;
    for kind in ElementKind::ALL {
        match kind {
            ElementKind::Membrane => {
                for t in &model.triangles {
                    let [a, b, c] = t.nodes.map(|i| model.reference[i]);
                    let w = (b - a).cross(&(c - a));
                    for &i in &t.nodes {
                        normal[i] += w;
                    }
                }
            }
            // Lines have no surface: a node only on cables has no normal, and its neighbours
            // go by degree (as in Cuthill-McKee).
            ElementKind::Cable
            | ElementKind::Tie
            | ElementKind::ContactPair
            | ElementKind::ContactPoint => {}
        }
    }
    for v in &mut normal {
        let l = v.norm();
        *v = if l > 0.0 { *v / l } else { Vector3::zeros() };
    }
    Ok(normal)
}

/// Cuthill-McKee order of the node graph, component by component (every node once). Every
/// choice (the start of each component, the order of a node's neighbours) is broken by the
/// nodes' Hilbert keys, never by their numbers, so the order does not depend on the user's
/// numbering (up to nodes at the same point).
///
/// `central`: start each component at a central node (the most balanced between the two ends
/// of a pseudo-diameter) and keep the breadth-first order (levels grow outward, like a
/// generator's rings); otherwise start at a pseudo-peripheral node and reverse (RCM).
fn cuthill_mckee(
    model: &Model,
    central: bool,
    (ptr, adj): &(Vec<usize>, Vec<usize>),
    prepared: Option<Prepared>,
) -> Result<Vec<usize>, OutOfMemory> {
    let n = model.reference.len();
    let Prepared {
        keys,
        seeds,
        normal,
    } = match prepared {
        Some(prepared) => prepared,
        None => prepare(&model.reference, model.triangles.iter().map(|t| t.nodes))?,
    };
    let degree = |i: usize| ptr[i + 1] - ptr[i];
    let mut order = memory::with_capacity(n, WHAT)?;
    let mut placed = memory::filled(n, false, WHAT)?;
    // Scratch of the level-structure searches: the level of each node (usize::MAX: unseen),
    // reset after every search through the list of nodes it reached.
    let mut level = memory::filled(n, usize::MAX, WHAT)?;
    let mut reached: Vec<usize> = memory::with_capacity(n, WHAT)?;
    let mut far_level: Vec<usize> = Vec::new();
    let mut neighbours: Vec<usize> = Vec::new();
    let mut parent = memory::filled(n, NONE, WHAT)?;
    let clear = |level: &mut [usize], reached: &[usize]| {
        for &i in reached {
            level[i] = usize::MAX;
        }
    };
    for &seed in &seeds {
        if placed[seed] {
            continue;
        }
        // Pseudo-peripheral node (George & Liu): from the seed, jump to a lowest-degree node
        // of the deepest level while the depth grows.
        let mut root = seed;
        let mut depth = bfs_levels(root, ptr, adj, &mut level, &mut reached);
        let deepest = |level: &[usize], reached: &[usize], depth: usize| {
            reached
                .iter()
                .copied()
                .filter(|&i| level[i] == depth)
                .min_by_key(|&i| (degree(i), keys[i], i))
                .expect("the deepest level is not empty")
        };
        for _ in 0..16 {
            let far = deepest(&level, &reached, depth);
            clear(&mut level, &reached);
            let d = bfs_levels(far, ptr, adj, &mut level, &mut reached);
            if d <= depth {
                clear(&mut level, &reached);
                depth = bfs_levels(root, ptr, adj, &mut level, &mut reached);
                break;
            }
            root = far;
            depth = d;
        }
        let mut start = root;
        if central {
            // Distances from both ends of the pseudo-diameter; the centre minimises the
            // larger of the two.
            let far = deepest(&level, &reached, depth);
            far_level.clear();
            far_level.extend(reached.iter().map(|&i| level[i]));
            let from_root: Vec<(usize, usize)> =
                memory::collect(reached.iter().copied().zip(far_level.iter().copied()), WHAT)?;
            clear(&mut level, &reached);
            bfs_levels(far, ptr, adj, &mut level, &mut reached);
            start = from_root
                .iter()
                .map(|&(i, l)| (l.max(level[i]), keys[i], i))
                .min()
                .expect("a component has a node")
                .2;
        }
        clear(&mut level, &reached);
        // Cuthill-McKee: breadth first, unplaced neighbours by degree.
        let first = order.len();
        order.push(start);
        placed[start] = true;
        let mut head = first;
        while head < order.len() {
            let i = order[head];
            head += 1;
            neighbours.clear();
            neighbours.extend(
                adj[ptr[i]..ptr[i + 1]]
                    .iter()
                    .copied()
                    .filter(|&j| !placed[j]),
            );
            if central && normal[i] != Vector3::zeros() {
                // Counterclockwise around i's normal, from the direction to i's parent (to its
                // lowest-keyed neighbour at the start): each level continues around the front
                // the way the previous one went.
                let x = &model.reference;
                let nrm = normal[i];
                let towards = match parent[i] {
                    NONE => neighbours
                        .iter()
                        .min_by_key(|&&j| (keys[j], j))
                        .map(|&j| x[j]),
                    p => Some(x[p]),
                };
                let d0 = towards.map_or(Vector3::zeros(), |y| y - x[i]);
                let d0 = d0 - nrm * d0.dot(&nrm);
                let e2 = nrm.cross(&d0);
                let angle = |j: usize| {
                    let d = x[j] - x[i];
                    let a = e2.dot(&d).atan2(d0.dot(&d));
                    if a < 0.0 {
                        a + std::f64::consts::TAU
                    } else {
                        a
                    }
                };
                neighbours.sort_unstable_by(|&a, &b| {
                    angle(a)
                        .total_cmp(&angle(b))
                        .then((keys[a], a).cmp(&(keys[b], b)))
                });
            } else {
                neighbours.sort_unstable_by_key(|&j| (degree(j), keys[j], j));
            }
            for &j in &neighbours {
                placed[j] = true;
                parent[j] = i;
                order.push(j);
            }
        }
        if !central {
            order[first..].reverse();
        }
    }
    Ok(order)
}

/// Breadth-first levels from `root` into `level` (which must be all usize::MAX on the nodes
/// reached); `reached` lists the nodes reached. Returns the deepest level.
fn bfs_levels(
    root: usize,
    ptr: &[usize],
    adj: &[usize],
    level: &mut [usize],
    reached: &mut Vec<usize>,
) -> usize {
    reached.clear();
    reached.push(root);
    level[root] = 0;
    let mut head = 0;
    let mut depth = 0;
    while head < reached.len() {
        let i = reached[head];
        head += 1;
        depth = level[i];
        for &j in &adj[ptr[i]..ptr[i + 1]] {
            if level[j] == usize::MAX {
                level[j] = level[i] + 1;
                reached.push(j);
            }
        }
    }
    depth
}

/// Nodes sorted along a 3D Hilbert curve (ties by node number).
fn hilbert(model: &Model) -> Result<Vec<usize>, OutOfMemory> {
    let keys = hilbert_keys(model)?;
    let mut order = memory::collect(0..keys.len(), WHAT)?;
    order.sort_unstable_by_key(|&i| (keys[i], i));
    Ok(order)
}

/// Every node's position on a 3D Hilbert curve through the bounding cube of the reference
/// coordinates (21 bits per axis).
fn hilbert_keys(model: &Model) -> Result<Vec<u64>, OutOfMemory> {
    hilbert_keys_of(&model.reference)
}

/// [`hilbert_keys`] of the points `x`.
fn hilbert_keys_of(x: &[Vector3<f64>]) -> Result<Vec<u64>, OutOfMemory> {
    const BITS: u32 = 21;
    let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    for p in x {
        for c in 0..3 {
            lo[c] = lo[c].min(p[c]);
            hi[c] = hi[c].max(p[c]);
        }
    }
    let extent = (0..3).map(|c| hi[c] - lo[c]).fold(0.0f64, f64::max);
    let cells = ((1u64 << BITS) - 1) as f64;
    let scale = if extent > 0.0 { cells / extent } else { 0.0 };
    memory::collect(
        x.iter().map(|p| {
            let q = [0, 1, 2].map(|c| ((p[c] - lo[c]) * scale).clamp(0.0, cells) as u32);
            hilbert_key(q, BITS)
        }),
        WHAT,
    )
}

/// Position on the Hilbert curve of the cell with integer coordinates `x` (each below
/// 2^bits): Skilling's axes-to-transpose, then the transpose read as one index.
fn hilbert_key(mut x: [u32; 3], bits: u32) -> u64 {
    let m = 1u32 << (bits - 1);
    let mut q = m;
    while q > 1 {
        let p = q - 1;
        for i in 0..3 {
            if x[i] & q != 0 {
                x[0] ^= p;
            } else {
                let t = (x[0] ^ x[i]) & p;
                x[0] ^= t;
                x[i] ^= t;
            }
        }
        q >>= 1;
    }
    for i in 1..3 {
        x[i] ^= x[i - 1];
    }
    let mut t = 0;
    let mut q = m;
    while q > 1 {
        if x[2] & q != 0 {
            t ^= q - 1;
        }
        q >>= 1;
    }
    for v in &mut x {
        *v ^= t;
    }
    let mut key = 0u64;
    for bit in (0..bits).rev() {
        for v in &x {
            key = (key << 1) | u64::from((v >> bit) & 1);
        }
    }
    key
}

#[cfg(test)]
mod tests {

    /// The Cuthill-McKee inputs computed from the copied coordinates and triangles (on the
    /// solver's helper with two threads) are the model's, and the ranks from them the same,
    /// on shipped scenes (cables, a cushion's two sheets, a sail).
    #[test]
    fn the_prepared_keys_and_normals_are_the_models() {
        for name in ["SleeveCable", "EtfeCushion", "FourPointSail", "HenckyDisc"] {
            let model = crate::model::shipped_model(name);
            let prepared = PrepareInput::copy(&model).unwrap().prepare().unwrap();
            assert_eq!(prepared.keys, hilbert_keys(&model).unwrap(), "{name}");
            assert_eq!(prepared.normal, node_normals(&model).unwrap(), "{name}");
            let graph = node_graph(&model).unwrap();
            for order in [NodeOrder::Rings, NodeOrder::Rcm] {
                let again = PrepareInput::copy(&model).unwrap().prepare().unwrap();
                assert_eq!(
                    node_rank_prepared(&model, order, &graph, Some(again)).unwrap(),
                    node_rank_on(&model, order, &graph).unwrap(),
                    "{name} {order:?}"
                );
            }
        }
    }
    use super::*;

    /// The memory estimate (`scene::limits::memory_bytes`) counts 400 bytes a triangle for the
    /// assembly's copy of the triangles in visit order.
    #[test]
    fn a_triangle_copy_fits_the_memory_estimate() {
        let size = std::mem::size_of::<crate::model::Triangle>();
        println!("size_of::<Triangle>() = {size}");
        assert!(size <= 400, "{size}");
    }

    /// The 2x2x2 Hilbert curve visits the 8 cells once each, every step to a face neighbour.
    #[test]
    fn hilbert_curve_of_order_one_is_a_face_connected_tour() {
        let mut cells: Vec<(u64, [u32; 3])> = (0..8u32)
            .map(|c| [c & 1, (c >> 1) & 1, c >> 2])
            .map(|x| (hilbert_key(x, 1), x))
            .collect();
        cells.sort();
        let keys: Vec<u64> = cells.iter().map(|c| c.0).collect();
        assert_eq!(keys, (0..8).collect::<Vec<u64>>());
        for w in cells.windows(2) {
            let d: u32 = (0..3).map(|c| w[0].1[c].abs_diff(w[1].1[c])).sum();
            assert_eq!(d, 1, "{:?} -> {:?}", w[0].1, w[1].1);
        }
    }

    /// At order 4 (16³ cells) consecutive keys are still face neighbours: the curve is
    /// continuous, which is what makes it local.
    #[test]
    fn hilbert_curve_of_order_four_is_continuous() {
        let bits = 4;
        let side = 1u32 << bits;
        let mut cells = Vec::new();
        for x in 0..side {
            for y in 0..side {
                for z in 0..side {
                    cells.push((hilbert_key([x, y, z], bits), [x, y, z]));
                }
            }
        }
        cells.sort();
        for (k, c) in cells.iter().enumerate() {
            assert_eq!(c.0, k as u64);
        }
        for w in cells.windows(2) {
            let d: u32 = (0..3).map(|c| w[0].1[c].abs_diff(w[1].1[c])).sum();
            assert_eq!(d, 1, "{:?} -> {:?}", w[0].1, w[1].1);
        }
    }
}
