//! Size limits, decided before anything that grows with the scene is allocated.
//!
//! ```text
//! 1. counts    nodes, triangles and unknowns from the generators' parameters and the explicit
//!              lists alone (no allocation): a scene above max_nodes, max_triangles or
//!              max_unknowns is rejected before its mesh is built
//! 2. memory    within those counts the mesh is resolved and the symbolic analysis (AMD
//!              ordering, supernodal, as the solver does it) runs on the node graph (one
//!              column per node, 3 x 3 blocks per entry): the factor's entries, the matrix, the
//!              model and the solver's vectors give the estimated peak memory, checked against
//!              max_memory_gb and against the memory the process can still get (the smaller of
//!              MemAvailable and the address-space limit)
//! ```
//!
//! The defaults fit a 24 GB machine: the Hencky disc at 334 rings (1.0 million unknowns,
//! about 1 GB estimated) passes; a 3000-ring disc (81 million unknowns) is stopped by the
//! counts, a mesh whose factor needs more than 16 GB by the memory estimate.

pub use super::generate::generator_counts;
use super::generate::Mesh;
pub use super::Limits;
use super::{NodeRef, Problem, Scene};
use crate::memory::{self, OutOfMemory};

/// What a scene will need.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Size {
    pub nodes: u64,
    pub triangles: u64,
    /// Upper bound: 3 per node plus 4 per sleeve point (held components are not subtracted).
    pub unknowns: u64,
    /// Sleeve points (slip unknowns): the slip block is dense, m x m.
    pub sleeve_points: u64,
    /// Entries of the LDLT factor (from the symbolic analysis; 0 before it ran).
    pub factor_entries: u64,
    /// Flops of one numeric factorization (from the symbolic analysis; 0 before it ran).
    pub factor_flops: f64,
    /// Estimated peak bytes of model and solver (0 before the symbolic analysis ran).
    pub memory_bytes: u64,
    /// The solver's threads (`solver.threads`; 0 is taken as 1).
    pub threads: u64,
}

/// Counts from the scene's numbers alone: no mesh is built. Saturating, so that absurd
/// division counts cannot overflow.
pub fn count(scene: &Scene) -> Size {
    let g = &scene.geometry;
    let (mut nodes, mut triangles) = (g.nodes.len() as u64, g.triangles.len() as u64);
    for gen in &g.generators {
        let (n, t) = generator_counts(gen);
        nodes = nodes.saturating_add(n);
        triangles = triangles.saturating_add(t);
    }
    let sleeve_points: u64 = scene
        .cables
        .iter()
        .filter(|c| c.sleeve.is_some())
        .map(|c| match &c.nodes {
            NodeRef::Ids(ids) => ids.len() as u64,
            NodeRef::Set(_) => 0, // counted exactly once the mesh exists
        })
        .sum();
    Size {
        nodes,
        triangles,
        unknowns: nodes
            .saturating_mul(3)
            .saturating_add(sleeve_points.saturating_mul(4)),
        sleeve_points,
        factor_entries: 0,
        factor_flops: 0.0,
        memory_bytes: 0,
        threads: 1,
    }
}

/// Problems of the counts against the limits (step 1): one problem listing every count above
/// its limit.
pub fn check_counts(size: &Size, limits: &Limits) -> Vec<Problem> {
    let mut over = Vec::new();
    for (what, n, max, field) in [
        ("nodes", size.nodes, limits.max_nodes, "max_nodes"),
        (
            "triangles",
            size.triangles,
            limits.max_triangles,
            "max_triangles",
        ),
        (
            "unknowns",
            size.unknowns,
            limits.max_unknowns,
            "max_unknowns",
        ),
    ] {
        if n > max {
            over.push(format!("{n} {what} (limit solver.limits.{field} = {max})"));
        }
    }
    if over.is_empty() {
        return Vec::new();
    }
    vec![Problem {
        path: "geometry".into(),
        message: format!(
            "the scene is too large: it would have {}; nothing was built. Coarsen the mesh or raise the limits",
            over.join(", ")
        ),
    }]
}

/// Node-graph edges of the mesh and cables (each pair once, i < j).
fn edges(mesh: &Mesh, cables: &[Vec<usize>]) -> Result<Vec<(u32, u32)>, OutOfMemory> {
    let segments: usize = cables.iter().map(|c| c.len().saturating_sub(1)).sum();
    let mut e: Vec<(u32, u32)> = memory::with_capacity(
        3 * mesh.triangles.len() + segments,
        "the size estimate's node graph",
    )?;
    let mut add = |a: usize, b: usize| {
        if a != b {
            e.push((a.min(b) as u32, a.max(b) as u32));
        }
    };
    for t in &mesh.triangles {
        add(t[0], t[1]);
        add(t[1], t[2]);
        add(t[2], t[0]);
    }
    for c in cables {
        for w in c.windows(2) {
            add(w[0], w[1]);
        }
    }
    e.sort_unstable();
    e.dedup();
    Ok(e)
}

/// The symbolic analysis of the node graph (faer, AMD, supernodal as the solver's): the LDLT
/// factor's entries and the flops of one numeric factorization of the 3-DOF-per-node matrix
/// (9 entries and 27 times the flops per node-level entry and column), and the node graph's
/// edge count. An allocation that fails is an [`OutOfMemory`].
pub fn factor_entries(mesh: &Mesh, cables: &[Vec<usize>]) -> Result<Factor, OutOfMemory> {
    use faer::sparse::linalg::cholesky::{
        factorize_symbolic_cholesky, CholeskySymbolicParams, SymmetricOrdering,
    };
    use faer::sparse::linalg::SupernodalThreshold;
    use faer::sparse::SymbolicSparseColMat;
    use faer::Side;
    let n = mesh.nodes.len();
    if n == 0 {
        return Ok(Factor::default());
    }
    let e = edges(mesh, cables)?;
    let edge_count = e.len() as u64;
    const WHAT: &str = "the size estimate's symbolic analysis";
    // Upper pattern, column j holds rows i <= j (diagonal included), sorted.
    let mut count = memory::filled(n, 1usize, WHAT)?;
    for &(_, j) in &e {
        count[j as usize] += 1;
    }
    let mut col_ptr = memory::with_capacity(n + 1, WHAT)?;
    col_ptr.push(0usize);
    for c in &count {
        col_ptr.push(col_ptr.last().unwrap() + c);
    }
    drop(count);
    let mut row_idx = memory::zeros(*col_ptr.last().unwrap(), WHAT)?;
    let mut next: Vec<usize> = memory::copy(&col_ptr[..n], WHAT)?;
    let mut by_col = e;
    by_col.sort_unstable_by_key(|&(i, j)| (j, i));
    for (i, j) in by_col {
        row_idx[next[j as usize]] = i as usize;
        next[j as usize] += 1;
    }
    for j in 0..n {
        row_idx[next[j]] = j;
    }
    drop(next);
    let pattern = SymbolicSparseColMat::new_checked(n, n, col_ptr, None, row_idx);
    let params = CholeskySymbolicParams {
        supernodal_flop_ratio_threshold: SupernodalThreshold::FORCE_SUPERNODAL,
        ..Default::default()
    };
    let symbolic = factorize_symbolic_cholesky(
        pattern.as_ref(),
        Side::Upper,
        SymmetricOrdering::Amd,
        params,
    )
    .map_err(|_| OutOfMemory {
        what: WHAT,
        bytes: (pattern.compute_nnz() as u64).saturating_mul(8 * 8),
    })?;
    let flops = factor_flops(&symbolic);
    Ok(Factor {
        entries: 9 * symbolic.len_val() as u64,
        flops: 27.0 * flops,
        edges: edge_count,
    })
}

/// What the symbolic analysis tells about the factor.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Factor {
    /// Entries of L (3-DOF-per-node matrix).
    pub entries: u64,
    /// Floating-point operations of one numeric LDLT factorization (multiply-adds counted as
    /// two): Σ over the columns of L of c², c the column's entries below the diagonal.
    pub flops: f64,
    /// Node-graph edges (each pair of nodes sharing an element once).
    pub edges: u64,
}

/// Σ_j c_j² over the columns of the node-level L (c_j its entries below the diagonal), from
/// the supernodal structure: a supernode of w columns and r rows below its diagonal block
/// has columns with w−1−k+r entries below the diagonal, k = 0..w.
pub(crate) fn factor_flops(
    symbolic: &faer::sparse::linalg::cholesky::SymbolicCholesky<usize>,
) -> f64 {
    use faer::sparse::linalg::cholesky::SymbolicCholeskyRaw;
    match symbolic.raw() {
        SymbolicCholeskyRaw::Supernodal(s) => {
            let (begin, end, rows) = (
                s.supernode_begin(),
                s.supernode_end(),
                s.col_ptr_for_row_idx(),
            );
            let mut total = 0.0;
            for k in 0..s.n_supernodes() {
                let w = (end[k] - begin[k]) as f64;
                let r = (rows[k + 1] - rows[k]) as f64;
                for c in 0..(w as usize) {
                    let below = w - 1.0 - c as f64 + r;
                    total += below * below;
                }
            }
            total
        }
        SymbolicCholeskyRaw::Simplicial(s) => {
            let cp = s.col_ptr();
            (0..s.ncols())
                .map(|j| {
                    let c = (cp[j + 1] - cp[j]) as f64 - 1.0;
                    c.max(0.0) * c.max(0.0)
                })
                .sum()
        }
    }
}

/// Estimated peak bytes: factor values and its scratch, the matrix (values, indices, element
/// maps), the model, the mesh, the solver's vectors and, with m sleeve points, the slip
/// block's m solved columns and dense m x m matrix. Generous per-item constants (measured
/// sizes of the structs rounded up). With 2 threads or more on a model that the solver
/// factors in two halves, those too ([`split_bytes`]).
pub fn memory_bytes(size: &Size, matrix_entries: u64) -> u64 {
    let factor = size.factor_entries.saturating_mul(8 + 8);
    let matrix = matrix_entries.saturating_mul(8 + 8);
    // Per triangle: the model's data and evaluation (400), the assembly's copy in visit order
    // (`solver::renumber`, 400; 328 measured) and the element map (81 positions).
    let elements = size.triangles.saturating_mul(400 + 400 + 9 * 9 * 8);
    let nodes = size.nodes.saturating_mul(200);
    let vectors = size.unknowns.saturating_mul(8 * 24);
    let m = size.sleeve_points;
    let slip = m
        .saturating_mul(size.unknowns.saturating_add(m))
        .saturating_mul(8);
    factor
        .saturating_add(matrix)
        .saturating_add(elements)
        .saturating_add(nodes)
        .saturating_add(vectors)
        .saturating_add(slip)
        .saturating_add(split_bytes(size, matrix_entries))
}

/// Most stored entries of the tangent (the solver's `assemble::MAX_ENTRIES`: its position
/// maps hold positions as `u32`; a copy, as for [`SPLIT_MIN_UNKNOWNS`]). Only limits raised
/// far above the defaults (about 130 million entries at 4 million unknowns) reach it.
pub const MAX_MATRIX_ENTRIES: u64 = u32::MAX as u64;

/// Equations from which 2 threads factor the tangent in two halves (the solver's
/// `linear::SPLIT_MIN_EQUATIONS`; the scene keeps its own copy: it imports nothing from the
/// solver). Counted here against the upper bound of the unknowns: generous.
pub const SPLIT_MIN_UNKNOWNS: u64 = 20_000;

/// Address space of the solver's helper thread: its stack (8 MiB) and the malloc arena glibc
/// reserves for a new thread (64 MiB on 64-bit).
pub const THREAD_BYTES: u64 = 72 << 20;

/// The two-domain factorization's own memory (`solver/split.rs`), 0 with 1 thread or below
/// [`SPLIT_MIN_UNKNOWNS`]: the helper thread; each half's copy of its part of the matrix
/// (value, row index and position in the tangent: 24 bytes an entry, both halves together
/// at most every entry once plus the separator block twice: counted as all entries); 15 %
/// more factor entries than the whole (measured 6.3 % on the 300k-DOF disc); and seven dense
/// separator-sized matrices, with a separator of 3 sqrt(unknowns) equations (at most 2500,
/// `split::MAX_SEPARATOR`; measured 1095 on the 300k-DOF disc, where this counts 1643).
pub fn split_bytes(size: &Size, matrix_entries: u64) -> u64 {
    if size.threads < 2 || size.unknowns < SPLIT_MIN_UNKNOWNS {
        return 0;
    }
    let separator = ((3.0 * (size.unknowns as f64).sqrt()) as u64).min(2500);
    THREAD_BYTES
        .saturating_add(matrix_entries.saturating_mul(24))
        .saturating_add(size.factor_entries.saturating_mul(8 * 15) / 100)
        .saturating_add(7 * separator * separator * 8)
}

/// Step 2: the factor's entries from the symbolic analysis, the memory estimate, checked
/// against `max_memory_gb` and (unless `check_available_memory` is off) what the process can
/// get.
pub fn check_memory(
    size: &mut Size,
    mesh: &Mesh,
    cables: &[Vec<usize>],
    limits: &Limits,
) -> Vec<Problem> {
    let factor = match factor_entries(mesh, cables) {
        Ok(f) => f,
        Err(e) => {
            return vec![Problem {
                path: "geometry".into(),
                message: format!(
                    "the size estimate itself could not get its memory ({e}); the scene is too large for this process"
                ),
            }]
        }
    };
    let entries = factor.entries;
    size.factor_entries = entries;
    size.factor_flops = factor.flops;
    let matrix_entries = 9u64.saturating_mul(factor.edges) + 6 * size.nodes;
    size.memory_bytes = memory_bytes(size, matrix_entries);
    let gb = size.memory_bytes as f64 / 1e9;
    let mut out = Vec::new();
    if matrix_entries > MAX_MATRIX_ENTRIES {
        out.push(Problem {
            path: "geometry".into(),
            message: format!(
                "the tangent would have about {matrix_entries} stored entries, more than the {MAX_MATRIX_ENTRIES} the solver's 32-bit position maps address; coarsen the mesh"
            ),
        });
    }
    if gb > limits.max_memory_gb {
        out.push(Problem {
            path: "geometry".into(),
            message: format!(
                "the solve would need about {gb:.1} GB (factor: {entries} entries for {} unknowns), above the limit solver.limits.max_memory_gb = {}; coarsen the mesh or raise the limit",
                size.unknowns, limits.max_memory_gb
            ),
        });
    } else if let Some(avail) = available_bytes().filter(|_| limits.check_available_memory) {
        if size.memory_bytes > avail {
            out.push(Problem {
                path: "geometry".into(),
                message: format!(
                    "the solve would need about {gb:.1} GB, but this process can get only {:.1} GB more (available memory or address-space limit; solver.limits.check_available_memory = false skips this comparison)",
                    avail as f64 / 1e9
                ),
            });
        }
    }
    out
}

/// Bytes this process can still allocate: the smaller of MemAvailable (Linux) and the
/// address-space limit minus what is mapped. None when neither is known.
pub fn available_bytes() -> Option<u64> {
    let meminfo = std::fs::read_to_string("/proc/meminfo").ok().and_then(|t| {
        t.lines()
            .find(|l| l.starts_with("MemAvailable:"))
            .and_then(|l| l.split_whitespace().nth(1))
            .and_then(|kb| kb.parse::<u64>().ok())
            .map(|kb| kb * 1024)
    });
    let rlimit = address_space_left();
    match (meminfo, rlimit) {
        (Some(a), Some(b)) => Some(a.min(b)),
        (a, b) => a.or(b),
    }
}

fn address_space_left() -> Option<u64> {
    let limits = std::fs::read_to_string("/proc/self/limits").ok()?;
    let line = limits
        .lines()
        .find(|l| l.starts_with("Max address space"))?;
    let soft: u64 = line.split_whitespace().nth(3)?.parse().ok()?; // "unlimited" -> None
    let mapped = std::fs::read_to_string("/proc/self/statm")
        .ok()
        .and_then(|t| t.split_whitespace().next()?.parse::<u64>().ok())
        .map(|pages| pages * 4096)
        .unwrap_or(0);
    Some(soft.saturating_sub(mapped))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::generate::resolve;
    use crate::scene::{DiagonalPattern, Generator, Geometry};
    use faer::sparse::linalg::cholesky::{
        factorize_symbolic_cholesky, CholeskySymbolicParams, SymmetricOrdering,
    };
    use faer::sparse::linalg::SupernodalThreshold;
    use faer::sparse::SymbolicSparseColMat;

    /// The factor entries of the full 3-DOF-per-node pattern (every DOF free, 3 x 3 blocks), as
    /// the solver's symbolic analysis counts them: what the node-graph estimate stands for.
    fn dof_factor_entries(mesh: &Mesh) -> u64 {
        let n = mesh.nodes.len();
        let mut cols: Vec<Vec<usize>> = vec![Vec::new(); 3 * n];
        let mut pairs: Vec<(usize, usize)> = edges(mesh, &[])
            .unwrap()
            .into_iter()
            .map(|(i, j)| (i as usize, j as usize))
            .collect();
        pairs.extend((0..n).map(|i| (i, i)));
        for (a, b) in pairs {
            for p in 0..3 {
                for q in 0..3 {
                    let (r, c) = (3 * a + p, 3 * b + q);
                    if r <= c {
                        cols[c].push(r);
                    }
                    if a != b {
                        let (r, c) = (3 * b + q, 3 * a + p);
                        if r <= c {
                            cols[c].push(r);
                        }
                    }
                }
            }
        }
        let mut col_ptr = vec![0usize];
        let mut rows = Vec::new();
        for c in &mut cols {
            c.sort_unstable();
            c.dedup();
            rows.extend_from_slice(c);
            col_ptr.push(rows.len());
        }
        let m = 3 * n;
        let pattern = SymbolicSparseColMat::new_checked(m, m, col_ptr, None, rows);
        let params = CholeskySymbolicParams {
            supernodal_flop_ratio_threshold: SupernodalThreshold::FORCE_SUPERNODAL,
            ..Default::default()
        };
        let s = factorize_symbolic_cholesky(
            pattern.as_ref(),
            faer::Side::Upper,
            SymmetricOrdering::Amd,
            params,
        )
        .unwrap();
        s.len_val() as u64
    }

    /// The node-graph estimate bounds the DOF-level factor from above, within a factor 3
    /// (measured here on discs and rectangles; printed with --nocapture).
    #[test]
    fn the_split_is_counted_with_two_threads_on_large_models_only() {
        let mut size = Size {
            unknowns: 300_000,
            factor_entries: 45_000_000,
            threads: 1,
            ..Size::default()
        };
        assert_eq!(split_bytes(&size, 6_000_000), 0);
        size.threads = 2;
        let bytes = split_bytes(&size, 6_000_000);
        // 72 MiB + 144 MB + 54 MB + 7 x 1643^2 x 8 (151 MB).
        assert_eq!(
            bytes,
            (72 << 20) + 144_000_000 + 54_000_000 + 7 * 1643 * 1643 * 8
        );
        size.unknowns = 10_000;
        assert_eq!(split_bytes(&size, 200_000), 0);
    }

    #[test]
    fn node_graph_estimate_bounds_the_dof_factor() {
        let disc = |rings| Generator::Disc {
            name: "d".into(),
            center: [0.0; 3],
            radius: 1.0,
            rings,
        };
        let rect = |nx, ny| Generator::Rectangle {
            name: "r".into(),
            origin: [0.0; 3],
            size: [1.0, 1.0],
            divisions: [nx, ny],
            pattern: DiagonalPattern::Crossed,
        };
        for g in [disc(10), disc(40), rect(30, 30), rect(2, 400)] {
            let mesh = resolve(&Geometry {
                generators: vec![g],
                ..Default::default()
            });
            let estimate = factor_entries(&mesh, &[]).unwrap().entries;
            let actual = dof_factor_entries(&mesh);
            println!(
                "{} nodes: estimate {estimate}, DOF-level {actual}",
                mesh.nodes.len()
            );
            assert!(
                estimate >= actual && estimate <= 3 * actual,
                "{estimate} vs {actual}"
            );
        }
    }
}
