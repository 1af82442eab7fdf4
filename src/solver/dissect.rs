//! Geometric nested dissection: a fill-reducing elimination order of the node graph from the
//! nodes' reference coordinates (a membrane mesh always has them), for the sparse LDLT
//! (`linear.rs`) in place of faer's AMD on large meshes (docs/performance.md, "Nested
//! dissection").
//!
//! ```text
//! part P          a set of nodes (the whole graph at first)
//! cut             for each of DIRECTIONS directions d in the plane of P's two longest bounding
//!                 box sides: c = the median of d·x over P; left = d·x < c, right = the rest
//! separator S     for every edge of P from left to right not covered yet, the endpoint
//!                 nearer the cut line: a vertex cover of the cut edges, one layer thick (on a
//!                 mesh with a row of nodes along the cut, exactly that row)
//! choice          the direction with the smallest S
//! order           dissect(left \ S), dissect(right \ S), then S; a part of LEAF nodes or fewer
//!                 (or one the cut cannot divide) is ordered by faer's AMD on its own subgraph
//! ```
//!
//! The top level's three sets are also the two-thread factorization's halves and separator
//! (`split.rs`): no edge joins the two halves.
//!
//! Everything depends on the coordinates and the graph only, not on the node numbers, up to
//! ties (equal projections go by the order of the part's list, itself derived from the
//! caller's node list).
//!
//! # References
//! George 1973, "Nested dissection of a regular finite element mesh", SIAM J. Numer. Anal.
//! 10(2); Miller, Teng, Thurston & Vavasis 1998 (geometric separators).

use crate::memory::{self, OutOfMemory};
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::sparse::SymbolicSparseColMat;

const WHAT: &str = "the nested-dissection ordering";

/// Smallest tangent (equations) ordered by nested dissection; below it faer's AMD on the
/// equations. Measured on the Hencky disc (docs/performance.md, "Nested dissection"): at 100k
/// equations the dissection's factor needs 3.5 % more flops than AMD's, at 300k 4 % fewer,
/// at 1M the same (0.2 % fewer), and on two threads at 1M its top separator gives a split
/// with 8 % fewer flops than the breadth-first one and no whole-tangent symbolic analysis.
/// With a helper thread (two threads, from `linear::SPLIT_MIN_EQUATIONS`) at any size
/// (`assemble.rs`, `Pattern::try_ordered_on`): it runs on the helper, and its top separator
/// spares the serial whole-tangent analysis and breadth-first split search (docs/performance.md,
/// "Twelfth session").
pub const MIN_EQUATIONS: usize = 200_000;

/// Largest part ordered by AMD instead of being cut again.
pub const LEAF: usize = 64;

/// Cut directions tried per part (evenly over half a turn).
const DIRECTIONS: usize = 6;

/// An elimination order of a graph's nodes.
pub struct Dissection {
    /// The nodes in elimination order.
    pub order: Vec<usize>,
    /// Nodes in the first half, the second half and the top separator (in this order at the
    /// start, middle and end of `order`); None when the graph was not cut at the top.
    pub top: Option<[usize; 3]>,
}

struct Work<'a> {
    x: &'a [[f64; 3]],
    ptr: &'a [usize],
    adj: &'a [usize],
    /// Part id of every node (0: in no open part).
    part: Vec<u32>,
    /// Separator membership, by stamp.
    mark: Vec<u32>,
    stamp: u32,
    /// The median of the last cut.
    median: f64,
    next_part: u32,
    proj: Vec<f64>,
    keys: Vec<f64>,
    /// Local number of a leaf's node (usize::MAX elsewhere).
    local: Vec<usize>,
    out: Vec<usize>,
}

/// The nested-dissection order of `nodes` (each in the graph `ptr`/`adj`, CSR over all nodes,
/// no self loops; edges to nodes outside `nodes` are ignored) by coordinates `x`.
pub fn dissect(
    x: &[[f64; 3]],
    ptr: &[usize],
    adj: &[usize],
    nodes: Vec<usize>,
) -> Result<Dissection, OutOfMemory> {
    let n = x.len();
    let count = nodes.len();
    let mut work = Work {
        x,
        ptr,
        adj,
        part: memory::zeros(n, WHAT)?,
        mark: memory::zeros(n, WHAT)?,
        stamp: 0,
        median: 0.0,
        next_part: 0,
        proj: memory::zeros(n, WHAT)?,
        keys: memory::with_capacity(count, WHAT)?,
        local: memory::filled(n, usize::MAX, WHAT)?,
        out: memory::with_capacity(count, WHAT)?,
    };
    let top = work.part_of(nodes, true)?;
    debug_assert_eq!(work.out.len(), count);
    Ok(Dissection {
        order: work.out,
        top,
    })
}

impl Work<'_> {
    /// Order `nodes` (appended to `out`); at the top, the sizes of the three sets.
    fn part_of(&mut self, nodes: Vec<usize>, top: bool) -> Result<Option<[usize; 3]>, OutOfMemory> {
        if nodes.len() <= LEAF {
            self.leaf(&nodes)?;
            return Ok(None);
        }
        self.next_part += 1;
        let id = self.next_part;
        for &v in &nodes {
            self.part[v] = id;
        }
        // The two longest sides of the part's bounding box.
        let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
        for &v in &nodes {
            for c in 0..3 {
                lo[c] = lo[c].min(self.x[v][c]);
                hi[c] = hi[c].max(self.x[v][c]);
            }
        }
        let mut axes = [0, 1, 2];
        axes.sort_by(|&a, &b| (hi[b] - lo[b]).total_cmp(&(hi[a] - lo[a])));
        let direction = |k: usize| {
            let t = std::f64::consts::PI * k as f64 / DIRECTIONS as f64;
            let mut d = [0.0; 3];
            d[axes[0]] = t.cos();
            d[axes[1]] = t.sin();
            d
        };
        let mut best: Option<(usize, usize)> = None;
        for k in 0..DIRECTIONS {
            let size = self.cut(&nodes, id, direction(k));
            if best.is_none_or(|(_, s)| size < s) {
                best = Some((k, size));
            }
        }
        let k = best.expect("a direction").0;
        self.cut(&nodes, id, direction(k));
        let c = self.median;
        let stamp = self.stamp;
        let mut left = memory::with_capacity(nodes.len() / 2 + 1, WHAT)?;
        let mut right = memory::with_capacity(nodes.len() / 2 + 1, WHAT)?;
        let mut sep = Vec::new();
        for &v in &nodes {
            self.part[v] = 0;
            if self.mark[v] == stamp {
                sep.push(v);
            } else if self.proj[v] < c {
                left.push(v);
            } else {
                right.push(v);
            }
        }
        if left.is_empty() || right.is_empty() {
            // All nodes on one side of every cut (coincident coordinates): AMD.
            self.leaf(&nodes)?;
            return Ok(None);
        }
        drop(nodes);
        let sizes = [left.len(), right.len(), sep.len()];
        self.part_of(left, false)?;
        self.part_of(right, false)?;
        self.out.extend_from_slice(&sep);
        Ok(top.then_some(sizes))
    }

    /// The separator of the cut of part `id` along `d` at the median: marked with a new
    /// stamp; returns its size. Leaves the projections in `proj` and the median in
    /// `self.median`.
    fn cut(&mut self, nodes: &[usize], id: u32, d: [f64; 3]) -> usize {
        self.keys.clear();
        for &v in nodes {
            let p = d[0] * self.x[v][0] + d[1] * self.x[v][1] + d[2] * self.x[v][2];
            self.proj[v] = p;
            self.keys.push(p);
        }
        let mid = self.keys.len() / 2;
        let (_, &mut c, _) = self.keys.select_nth_unstable_by(mid, f64::total_cmp);
        self.median = c;
        self.stamp += 1;
        let stamp = self.stamp;
        let mut size = 0;
        for &u in nodes {
            let pu = self.proj[u];
            if pu >= c {
                continue;
            }
            for &v in &self.adj[self.ptr[u]..self.ptr[u + 1]] {
                if self.part[v] != id || self.proj[v] < c {
                    continue;
                }
                if self.mark[u] == stamp {
                    break;
                }
                if self.mark[v] == stamp {
                    continue;
                }
                // The endpoint nearer the cut line (the right one on a tie).
                let w = if self.proj[v] - c <= c - pu { v } else { u };
                self.mark[w] = stamp;
                size += 1;
            }
        }
        size
    }

    /// faer's AMD on the subgraph of `nodes`, appended to `out`.
    fn leaf(&mut self, nodes: &[usize]) -> Result<(), OutOfMemory> {
        let m = nodes.len();
        if m <= 2 {
            self.out.extend_from_slice(nodes);
            return Ok(());
        }
        let mut sorted = memory::copy(nodes, WHAT)?;
        sorted.sort_unstable();
        for (k, &v) in sorted.iter().enumerate() {
            self.local[v] = k;
        }
        let mut col_ptr = memory::with_capacity(m + 1, WHAT)?;
        let mut rows = Vec::new();
        col_ptr.push(0usize);
        for &v in &sorted {
            let before = rows.len();
            rows.extend(
                self.adj[self.ptr[v]..self.ptr[v + 1]]
                    .iter()
                    .map(|&w| self.local[w])
                    .filter(|&l| l != usize::MAX),
            );
            rows.push(self.local[v]);
            rows[before..].sort_unstable();
            col_ptr.push(rows.len());
        }
        for &v in &sorted {
            self.local[v] = usize::MAX;
        }
        let nnz = rows.len();
        let pattern = SymbolicSparseColMat::new_checked(m, m, col_ptr, None, rows);
        let mut perm = vec![0usize; m];
        let mut inv = vec![0usize; m];
        let mut mem = MemBuffer::try_new(faer::sparse::linalg::amd::order_scratch::<usize>(m, nnz))
            .map_err(|_| OutOfMemory {
                what: WHAT,
                bytes: (nnz as u64) * 16,
            })?;
        match faer::sparse::linalg::amd::order(
            &mut perm,
            &mut inv,
            pattern.as_ref(),
            Default::default(),
            MemStack::new(&mut mem),
        ) {
            Ok(_) => self.out.extend(perm.iter().map(|&k| sorted[k])),
            Err(_) => self.out.extend_from_slice(&sorted),
        }
        Ok(())
    }
}

/// A fill-reducing order of a tangent's equations, handed to the factorization in place of
/// faer's AMD (`linear.rs`).
pub struct Fill {
    /// The equations in elimination order.
    pub perm: Vec<usize>,
    /// Equations of the first half, the second half and the top separator (in this order in
    /// `perm`): the two-thread factorization's split (`split.rs`).
    pub top: Option<[usize; 3]>,
}

/// The equation order of nodes numbered internally 0..nodes (`x`, `ptr`/`adj` in that
/// numbering), `equations(r)` the equations of internal node r, ascending.
pub fn fill(
    x: &[[f64; 3]],
    ptr: &[usize],
    adj: &[usize],
    equations: impl Fn(usize) -> std::ops::Range<usize>,
    n: usize,
) -> Result<Fill, OutOfMemory> {
    let mut active = memory::with_capacity(x.len(), WHAT)?;
    active.extend((0..x.len()).filter(|&r| !equations(r).is_empty()));
    let d = dissect(x, ptr, adj, active)?;
    let mut perm = memory::with_capacity(n, WHAT)?;
    let mut bounds = [0usize; 3];
    let mut at = 0;
    for (k, &r) in d.order.iter().enumerate() {
        if let Some(top) = d.top {
            if k == top[0] || k == top[0] + top[1] {
                bounds[at] = perm.len();
                at += 1;
            }
        }
        perm.extend(equations(r));
    }
    let top = d
        .top
        .map(|_| [bounds[0], bounds[1] - bounds[0], perm.len() - bounds[1]]);
    Ok(Fill { perm, top })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A triangulated nx x ny grid: coordinates and the CSR node graph.
    fn grid(nx: usize, ny: usize) -> (Vec<[f64; 3]>, Vec<usize>, Vec<usize>) {
        let id = |i: usize, j: usize| j * nx + i;
        let mut x = Vec::new();
        let mut lists = vec![Vec::new(); nx * ny];
        for j in 0..ny {
            for i in 0..nx {
                x.push([i as f64, j as f64 + 0.1 * i as f64, 0.0]);
                let mut link = |a: usize, b: usize| {
                    lists[a].push(b);
                    lists[b].push(a);
                };
                if i + 1 < nx {
                    link(id(i, j), id(i + 1, j));
                }
                if j + 1 < ny {
                    link(id(i, j), id(i, j + 1));
                }
                if i + 1 < nx && j + 1 < ny {
                    link(id(i, j), id(i + 1, j + 1));
                }
            }
        }
        let mut ptr = vec![0];
        let mut adj = Vec::new();
        for mut l in lists {
            l.sort_unstable();
            adj.extend(l);
            ptr.push(adj.len());
        }
        (x, ptr, adj)
    }

    /// Every node once; the top separator leaves no edge between the two halves; every
    /// separator is ordered after the part it cuts (checked at the top).
    #[test]
    fn dissection_is_a_permutation_with_a_true_top_separator() {
        let (x, ptr, adj) = grid(60, 45);
        let n = x.len();
        let d = dissect(&x, &ptr, &adj, (0..n).collect()).unwrap();
        let mut seen = vec![false; n];
        for &v in &d.order {
            assert!(!seen[v]);
            seen[v] = true;
        }
        assert!(seen.iter().all(|&s| s));
        let [a, b, s] = d.top.expect("a cut at the top");
        assert_eq!(a + b + s, n);
        assert!(a.min(b) >= n * 2 / 5, "{a} {b}");
        // A straight cut through a grid: about one row or column of nodes.
        assert!(s <= 2 * 45, "{s}");
        let mut side = vec![0u8; n];
        for (k, &v) in d.order.iter().enumerate() {
            side[v] = if k < a {
                1
            } else if k < a + b {
                2
            } else {
                0
            };
        }
        for v in 0..n {
            for &w in &adj[ptr[v]..ptr[v + 1]] {
                assert!(side[v] * side[w] != 2, "edge {v}-{w} joins the halves");
            }
        }
    }

    /// The equation order expands each node's equations in node order and counts the top
    /// sets in equations; nodes without equations are left out.
    #[test]
    fn fill_expands_nodes_to_equations() {
        let (x, ptr, adj) = grid(30, 30);
        // Node r has 3 equations, except every 7th with none (held).
        let count = |r: usize| if r.is_multiple_of(7) { 0 } else { 3 };
        let mut first = vec![0];
        for r in 0..x.len() {
            first.push(first[r] + count(r));
        }
        let n = *first.last().unwrap();
        let f = fill(&x, &ptr, &adj, |r| first[r]..first[r + 1], n).unwrap();
        let mut sorted = f.perm.clone();
        sorted.sort_unstable();
        assert_eq!(sorted, (0..n).collect::<Vec<_>>());
        let top = f.top.expect("a cut at the top");
        assert_eq!(top.iter().sum::<usize>(), n);
        assert!(top.iter().all(|t| t.is_multiple_of(3)));
    }
}
