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
//! An engine (`Engine::try_new`) runs step 2 without its own symbolic analysis
//! ([`with_factor_from_solver`]): the solver orders and analyses the tangent anyway, and the
//! factor's entries it reports then give the estimate ([`check_factor`]) before the first
//! numeric factorization touches the factor's pages. `velarium check` (and every other
//! validation) keeps the node-level analysis above.
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
    /// Stored entries of the tangent (upper triangle: 9 per node-graph edge and 6 per node;
    /// 0 before step 2 ran).
    pub matrix_entries: u64,
    /// Step 2 ran without the factor ([`with_factor_from_solver`]): `factor_entries`,
    /// `factor_flops` are 0 and `memory_bytes` counts everything but the factor until
    /// [`check_factor`] fills them in from the solver's own symbolic analysis.
    pub factor_deferred: bool,
}

thread_local! {
    /// Whether [`check_memory`] leaves the factor to the solver ([`with_factor_from_solver`]).
    static FROM_SOLVER: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

/// Runs `f` (a validation) with step 2's symbolic analysis left to the solver: on this thread
/// [`check_memory`] then counts the tangent's entries (no ordering, no symbolic analysis),
/// checks them, and marks the size `factor_deferred`; the caller must call [`check_factor`]
/// with the solver's factor before factoring (`Engine::try_new` does).
pub fn with_factor_from_solver<T>(f: impl FnOnce() -> T) -> T {
    struct Restore(bool);
    impl Drop for Restore {
        fn drop(&mut self) {
            FROM_SOLVER.with(|c| c.set(self.0));
        }
    }
    let _restore = Restore(FROM_SOLVER.with(|c| c.replace(true)));
    f()
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
        matrix_entries: 0,
        factor_deferred: false,
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

/// Node-graph edges of the mesh and cables (each pair once), counted without sorting them
/// all: each edge is listed at its lower node (a counting sort), and each node's short list
/// is deduplicated on its own. What [`edges`]`.len()` gives, in time linear in the triangles.
fn edge_count(mesh: &Mesh, cables: &[Vec<usize>]) -> Result<u64, OutOfMemory> {
    const WHAT: &str = "the size estimate's edge count";
    let n = mesh.nodes.len();
    let pairs = || {
        let tris = mesh
            .triangles
            .iter()
            .flat_map(|t| [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])]);
        let segs = cables
            .iter()
            .flat_map(|c| c.windows(2).map(|w| (w[0], w[1])));
        tris.chain(segs)
            .filter(|(a, b)| a != b)
            .map(|(a, b)| (a.min(b), a.max(b)))
    };
    let mut start = memory::filled(n + 1, 0usize, WHAT)?;
    for (a, _) in pairs() {
        start[a + 1] += 1;
    }
    for i in 0..n {
        start[i + 1] += start[i];
    }
    let mut next = memory::copy(&start[..n], WHAT)?;
    let mut upper = memory::zeros::<u32>(start[n], WHAT)?;
    for (a, b) in pairs() {
        upper[next[a]] = b as u32;
        next[a] += 1;
    }
    let mut count = 0u64;
    for i in 0..n {
        let list = &mut upper[start[i]..start[i + 1]];
        if !list.is_empty() {
            list.sort_unstable();
            count += 1 + list.windows(2).filter(|w| w[0] != w[1]).count() as u64;
        }
    }
    Ok(count)
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
    if FROM_SOLVER.with(|c| c.get()) {
        let edges = match edge_count(mesh, cables) {
            Ok(e) => e,
            Err(e) => return estimate_failed(e),
        };
        size.factor_entries = 0;
        size.factor_flops = 0.0;
        size.factor_deferred = true;
        size.matrix_entries = 9u64.saturating_mul(edges) + 6 * size.nodes;
        size.memory_bytes = memory_bytes(size, size.matrix_entries);
        return matrix_problems(size.matrix_entries).into_iter().collect();
    }
    let factor = match factor_entries(mesh, cables) {
        Ok(f) => f,
        Err(e) => return estimate_failed(e),
    };
    let entries = factor.entries;
    size.factor_entries = entries;
    size.factor_flops = factor.flops;
    let matrix_entries = 9u64.saturating_mul(factor.edges) + 6 * size.nodes;
    size.matrix_entries = matrix_entries;
    size.memory_bytes = memory_bytes(size, matrix_entries);
    let mut out: Vec<Problem> = matrix_problems(matrix_entries).into_iter().collect();
    out.extend(memory_problems(size, limits, available_bytes));
    out
}

/// The located problem of a size estimate that could not get its own memory.
fn estimate_failed(e: OutOfMemory) -> Vec<Problem> {
    vec![Problem {
        path: "geometry".into(),
        message: format!(
            "the size estimate itself could not get its memory ({e}); the scene is too large for this process"
        ),
    }]
}

/// A tangent too large for the solver's 32-bit position maps.
fn matrix_problems(matrix_entries: u64) -> Option<Problem> {
    (matrix_entries > MAX_MATRIX_ENTRIES).then(|| Problem {
        path: "geometry".into(),
        message: format!(
            "the tangent would have about {matrix_entries} stored entries, more than the {MAX_MATRIX_ENTRIES} the solver's 32-bit position maps address; coarsen the mesh"
        ),
    })
}

/// Step 2 deferred to the solver ([`with_factor_from_solver`]): the factor's entries and
/// flops as the solver's symbolic analysis gives them (`Solver::factor_nonzeros`, with two
/// threads both halves'), the memory estimate from them, checked against `max_memory_gb` and
/// (unless `check_available_memory` is off) against the memory still available: by then the
/// model, the pattern and the maps are resident, so only what is not yet touched (the factor's
/// values and the split's buffers) is compared with MemAvailable. Nothing to do on a size
/// whose step 2 was not deferred.
pub fn check_factor(size: &mut Size, entries: u64, flops: f64, limits: &Limits) -> Vec<Problem> {
    if !size.factor_deferred {
        return Vec::new();
    }
    size.factor_deferred = false;
    size.factor_entries = entries;
    size.factor_flops = flops;
    let without = size.memory_bytes;
    size.memory_bytes = memory_bytes(size, size.matrix_entries);
    let untouched = size.memory_bytes.saturating_sub(without);
    memory_problems(size, limits, || {
        available_physical().map(|a| a.saturating_add(size.memory_bytes - untouched))
    })
}

/// The estimate against `max_memory_gb` and, unless `check_available_memory` is off, against
/// `available()`.
fn memory_problems(
    size: &Size,
    limits: &Limits,
    available: impl FnOnce() -> Option<u64>,
) -> Vec<Problem> {
    let entries = size.factor_entries;
    let gb = size.memory_bytes as f64 / 1e9;
    let mut out = Vec::new();
    if gb > limits.max_memory_gb {
        out.push(Problem {
            path: "geometry".into(),
            message: format!(
                "the solve would need about {gb:.1} GB (factor: {entries} entries for {} unknowns), above the limit solver.limits.max_memory_gb = {}; coarsen the mesh or raise the limit",
                size.unknowns, limits.max_memory_gb
            ),
        });
    } else if let Some(avail) = limits.check_available_memory.then(available).flatten() {
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

/// MemAvailable (Linux), None where it is not known.
fn available_physical() -> Option<u64> {
    std::fs::read_to_string("/proc/meminfo").ok().and_then(|t| {
        t.lines()
            .find(|l| l.starts_with("MemAvailable:"))
            .and_then(|l| l.split_whitespace().nth(1))
            .and_then(|kb| kb.parse::<u64>().ok())
            .map(|kb| kb * 1024)
    })
}

/// Bytes this process can still allocate: the smaller of MemAvailable (Linux) and the
/// address-space limit minus what is mapped. None when neither is known.
pub fn available_bytes() -> Option<u64> {
    let meminfo = available_physical();
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

    #[test]
    fn the_edge_count_is_the_sorted_edge_lists_length() {
        let disc = Generator::Disc {
            name: "d".into(),
            center: [0.0; 3],
            radius: 1.0,
            rings: 12,
        };
        let rect = Generator::Rectangle {
            name: "r".into(),
            origin: [0.0; 3],
            size: [1.0, 1.0],
            divisions: [7, 3],
            pattern: DiagonalPattern::Crossed,
        };
        for g in [disc, rect] {
            let mesh = resolve(&Geometry {
                generators: vec![g],
                ..Default::default()
            });
            // A cable along mesh edges (no new pairs), one across (new ones), a repeated node.
            let n = mesh.nodes.len();
            let cables = [mesh.triangles[0].to_vec(), vec![0, n - 1, n - 1, n / 2]];
            for c in [&cables[..0], &cables[..]] {
                let sorted = edges(&mesh, c).unwrap().len() as u64;
                assert_eq!(edge_count(&mesh, c).unwrap(), sorted);
                assert!(sorted > 0);
            }
        }
    }

    /// An engine takes the factor's size from its solver: its validation runs no symbolic
    /// analysis, and the limit is still applied, with the same located message.
    #[test]
    fn an_engine_checks_the_memory_limit_with_the_solvers_factor() {
        let path = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/modelDescription/HenckyDisc/scene.json"
        );
        let mut scene: crate::scene::Scene =
            serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
        let Generator::Disc { rings, .. } = &mut scene.geometry.generators[0] else {
            panic!("the shipped Hencky disc is generated")
        };
        *rings = 40;
        let (problems, full) = crate::scene::validate::validate_sized(&scene);
        assert!(problems.is_empty(), "{problems:?}");
        assert!(full.factor_entries > 0 && !full.factor_deferred);
        let (problems, deferred) =
            with_factor_from_solver(|| crate::scene::validate::validate_sized(&scene));
        assert!(problems.is_empty(), "{problems:?}");
        assert!(deferred.factor_deferred && deferred.factor_entries == 0);
        assert_eq!(deferred.matrix_entries, full.matrix_entries);
        assert!(deferred.memory_bytes < full.memory_bytes);
        // The flag is this call's only.
        let (_, again) = crate::scene::validate::validate_sized(&scene);
        assert_eq!(again, full);

        let engine = crate::Engine::try_new(scene.clone()).unwrap();
        let factor_bytes = 16 * engine.factor_nonzeros() as u64;
        assert!(factor_bytes > 0);
        // The solver's DOF-level factor is below the node-level upper bound (at most 3x:
        // node_graph_estimate_bounds_the_dof_factor) and is in the engine's estimate.
        assert!(
            engine.memory_estimate() >= deferred.memory_bytes + factor_bytes
                && engine.memory_estimate() <= full.memory_bytes,
            "{} vs {} + {factor_bytes} and {}",
            engine.memory_estimate(),
            deferred.memory_bytes,
            full.memory_bytes
        );
        scene.solver.limits.max_memory_gb = 0.001;
        match crate::Engine::try_new(scene) {
            Err(crate::Error::Scene(p)) => {
                assert_eq!(p.len(), 1, "{p:?}");
                assert!(
                    p[0].to_string().contains("max_memory_gb = 0.001"),
                    "{}",
                    p[0]
                );
            }
            Err(e) => panic!("{e}"),
            Ok(_) => panic!("a 40-ring disc passed a 1 MB limit"),
        }
    }
}

/// Cost model of one Newton iteration on the reference machine (one core of the 2-core CI
/// kind; docs/solver.md, cost), fitted to `examples/bench.rs`-style floors: a 150-ring disc
/// (201,153 unknowns, 11.2 GFlop, 32.5 M factor entries: factorization and solve 0.75 s,
/// assembly of 135,000 elements 0.058 s) and a [1, 100000] strip (599,994 unknowns, 0.60 GFlop,
/// 32.4 M entries: 0.22 s, 200,000 elements 0.117 s).
const FACTOR_FLOPS_PER_SECOND: f64 = 20e9;
const FACTOR_SECONDS_PER_ENTRY: f64 = 6e-9;
const ELEMENT_SECONDS: f64 = 0.6e-6;
/// Element evaluations per Newton iteration: the assembly of residual and tangent and the line
/// search's first trial point.
const ASSEMBLIES_PER_ITERATION: f64 = 2.0;

/// What `velarium check` announces a step costs on the reference machine.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cost {
    /// One Newton iteration at least: one factorization, its solve, two assemblies [s].
    pub iteration: f64,
    /// A step that converges in one increment of up to `solver.max_iterations` [s].
    pub converging: f64,
    /// A step that does not converge: its work budget of `solver.max_step_iterations`
    /// iterations' worth of work, in which every further line-search trial and re-check counts
    /// as half an iteration and a round of nodal relaxation as one [s].
    pub failing: f64,
}

/// The cost model applied to a scene's size (`factor_flops`, `factor_entries` from the
/// symbolic analysis) and its solver settings.
pub fn cost(solver: &super::SolverSettings, size: &Size, triangles: u64) -> Cost {
    let factor = size.factor_flops / FACTOR_FLOPS_PER_SECOND
        + size.factor_entries as f64 * FACTOR_SECONDS_PER_ENTRY;
    let iteration = factor + ASSEMBLIES_PER_ITERATION * triangles as f64 * ELEMENT_SECONDS;
    Cost {
        iteration,
        converging: iteration * solver.max_iterations as f64,
        failing: iteration * solver.max_step_iterations as f64,
    }
}
