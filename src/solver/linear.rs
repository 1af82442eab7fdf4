//! Sparse symmetric solve: faer 0.24 supernodal LDLT, symbolic factorization once per pattern,
//! numeric factorization into reused buffers every Newton iteration (docs/performance.md).
//!
//! LDLT does not pivot. Pivots with |d| <= ε·max|K_ii| are replaced by ±δ (dynamic
//! regularization): a slack or unrestrained direction then gets a tiny spring in the tangent
//! only, and Newton's residual check decides whether the step is good. A non-finite solution
//! is reported as a failure, never returned.
//!
//! With groups ([`Ldlt::set_groups`]: the solver gives each node's equations one group) the
//! tangent is factored symmetrically scaled, S K S with S_ee = 2^-k ≈ 1/√(largest diagonal of
//! e's group), so that ε and δ are relative to each node's own stiffness, not to the stiffest
//! member anywhere: a pretensioned stay of EA/L = 1e14 N/m elsewhere in the model no longer
//! replaces the pivots of a flat membrane's nodes by springs of 1e5 N/m. Powers of two make the
//! scaling and its undoing exact; a group with no positive diagonal keeps the largest diagonal
//! of the whole tangent (the unscaled rule).
//!
//! Mixed precision ([`Precision`]; docs/performance.md, "Mixed-precision factor"): from
//! [`SINGLE_MIN_EQUATIONS`] equations the (scaled) tangent is factored in single precision,
//! f32 (faer's numeric LDLT is generic over the scalar; on AVX2 an f32 kernel does twice the
//! flops per instruction, and a substitution reads half the bytes). [`Ldlt::solve`] keeps its
//! contract by iterative refinement against the f64 matrix held here (Carson and Higham 2018,
//! "Accelerating the solution of linear systems by iterative refinement in three precisions",
//! SIAM J. Sci. Comput. 40(2); Higham, "Accuracy and Stability of Numerical Algorithms", ch.
//! 12): x = M⁻¹ b, then r = b − K x in f64 and x += M⁻¹ r until the componentwise backward
//! error is at most [`BACKWARD_ERROR`] (what the f64 factor's solve reaches) or the correction
//! is round-off. When a correction is more than [`MAX_CONTRACTION`] of the last (the tangent
//! too ill-conditioned for f32: κ u₃₂ near 1), or [`MAX_REFINEMENT_STEPS`] do not get there, or
//! the f32 factorization fails, the tangent is factored in f64 from then on and a log line
//! says so ([`Ldlt::take_notes`]). [`Ldlt::pcg`] uses the f32 factor as it is, as its
//! preconditioner (one substitution per application, no refinement). The two-domain split's
//! halves are f32 too; their separator's Schur complement and its dense LDLT stay f64.

use super::dissect::Fill;
use super::factor::{numeric_ldlt, symbolic_ldlt};
use super::split::Split;
use super::threads::{Pool, PRODUCT};
use crate::error::{Breakdown, Error};
use crate::memory::{self, OutOfMemory};
use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::sparse::linalg::cholesky::supernodal::SymbolicSupernodalCholesky;
use faer::sparse::linalg::cholesky::{
    LdltRef, SymbolicCholesky, SymbolicCholeskyRaw, SymmetricOrdering,
};
use faer::sparse::{SparseColMat, SymbolicSparseColMat};
use faer::{Conj, MatMut, Par};
use std::sync::{Arc, Mutex, RwLock};

/// Regularization threshold relative to the largest diagonal entry.
const PIVOT_EPSILON: f64 = 1e-13;
/// Replacement pivot magnitude relative to the largest diagonal entry.
const PIVOT_DELTA: f64 = 1e-9;
/// What [`Breakdown::NonFinite`] names when a solve's result holds NaN or infinity.
const NON_FINITE: &str = "the linear solve's solution";

/// Smallest tangent (equations) factored in single precision under [`Precision::Auto`]
/// (module docs, "Mixed precision"; docs/performance.md, "Mixed-precision factor").
pub const SINGLE_MIN_EQUATIONS: usize = 200_000;

/// Refinement steps a solve with the single-precision factor may take before it falls back
/// to a double-precision factorization.
pub const MAX_REFINEMENT_STEPS: usize = 10;

/// Largest ratio of a refinement step's correction to the last one's (to the solution's, at
/// the first step) for which the single-precision factor is kept: above it the refinement
/// does not contract fast enough and the tangent is factored in double precision.
pub const MAX_CONTRACTION: f64 = 0.5;

/// The componentwise backward error (Oettli-Prager: max_i |b - K x|_i / (|K| |x| + |b|)_i)
/// at which a refined solve stops: 2^-49 = 1.8e-15, 8 ulps of 1 (f64::EPSILON); the
/// double-precision factor's own solve reaches 7e-16 to 1e-15 on the Hencky disc's tangents
/// (docs/performance.md, "Mixed-precision factor").
pub const BACKWARD_ERROR: f64 = 8.0 * f64::EPSILON;

/// A correction at most this many ulps of the solution's largest entry is round-off: the
/// refinement has converged, even where it no longer contracts.
const ROUND_OFF: f64 = 8.0 * f64::EPSILON;

/// Which precision the tangent is factored in (module docs, "Mixed precision").
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Precision {
    /// Single from [`SINGLE_MIN_EQUATIONS`] equations, double below.
    #[default]
    Auto,
    Double,
    Single,
}

/// Smallest tangent (equations) factored in two halves when the solver has 2 threads or more:
/// below it the dense separator block and the hand-over cost more than half a factorization
/// (docs/performance.md, "Threads").
pub const SPLIT_MIN_EQUATIONS: usize = 20_000;

pub struct Ldlt {
    matrix: SparseColMat<usize, f64>,
    /// The whole tangent's symbolic factorization (None when the split was taken straight
    /// from a nested-dissection order: its halves hold their own).
    symbolic: Option<SymbolicCholesky<usize>>,
    l_values: Vec<f64>,
    factor_mem: MemBuffer,
    solve_mem: MemBuffer,
    /// Whether a numeric factorization is held ([`Ldlt::pcg`]'s preconditioner).
    factored: bool,
    /// Numeric factorizations and inexact-Newton solves so far (the scaling benchmark's
    /// counts).
    pub counts: Counts,
    /// Two halves factored side by side on the solver's threads (`split.rs`); None: the
    /// whole tangent on the caller's thread.
    split: Option<Split>,
    /// Group of every equation (module docs); empty: one group.
    groups: Vec<u32>,
    /// S (module docs), one per equation once groups are set (empty: unscaled).
    scale: Vec<f64>,
    /// Largest diagonal of every group (work buffer of the scaling).
    largest: Vec<f64>,
    /// [`Ldlt::solve_block`]'s right-hand sides row by row in the factor's order (work
    /// buffer, grown on first use).
    rows: Vec<f64>,
    /// S in the factor's order ([`Ldlt::solve_block_ordered`]; `ordered_scale[i]` is S of
    /// the equation at position i), for the factorization numbered `ordered_for`.
    ordered_scale: Vec<f64>,
    ordered_for: usize,
    /// The factor is single precision (module docs, "Mixed precision"): the whole tangent's
    /// in `l32` (of the scaled values `v32`), or the split's halves'.
    single: bool,
    v32: Vec<f32>,
    l32: Vec<f32>,
    /// A substitution's vector in f32 (the whole tangent's single-precision solve).
    x32: Vec<f32>,
    /// The refinement's vectors: b, the residual, |K| |x| (allocated at the first refined
    /// solve).
    refine: Vec<f64>,
    /// Log lines of the falls back to double precision, for the solver's log
    /// ([`Ldlt::take_notes`]).
    notes: Vec<String>,
    /// The values were handed out for writing ([`Ldlt::values_mut`]) since the last
    /// factorization: K may no longer be the factored matrix.
    stale: bool,
    /// An empty matrix, in `matrix`'s place while the split's halves borrow its values
    /// ([`Ldlt::factor_split`]) or the two threads' product borrows the matrix.
    spare: Option<SparseColMat<usize, f64>>,
    /// K x on two threads (with the split, [`Product`]); None: on the caller's thread.
    product: Option<Product>,
}

/// K x on two threads ([`Ldlt::multiply`], the refinement's [`Ldlt::residual`]): the caller
/// takes K's columns before `m` and the split's helper those from `m` on (each about half of
/// K's entries), each summing as the one-thread product does; the helper leaves out its
/// columns' rows before `m` (in the upper triangle, the rows of the caller's part: few, where
/// the internal order keeps K banded), which the caller adds after both are done, in column
/// order. Every entry of K x is then the same sum in the same order as on one thread: the
/// same bits ([`product_columns`], [`product_cross`]).
struct Product {
    pool: Arc<Pool>,
    m: usize,
    /// K (lent for one product; None between products), a copy of x, and whether |K| |x|
    /// is wanted too: read by both threads.
    lent: Arc<RwLock<Lent>>,
    /// The helper's rows m..n of K x and of |K| |x|.
    out: Arc<Mutex<[Vec<f64>; 2]>>,
}

#[derive(Default)]
struct Lent {
    matrix: Option<SparseColMat<usize, f64>>,
    x: Vec<f64>,
    abs: bool,
}

/// Below this many stored entries of K (with their row indices and x about 32 MB, the
/// sandbox's L3 cache) a product stays on one thread: K x of the 110-ring disc (1.2 million
/// entries) took 1.4-2.5 ms on one thread and 1.6-1.8 ms on two, the 334-ring disc's (11
/// million) 18 ms against 12 ms (idle, docs/performance.md, "Fourteenth session").
const PRODUCT_MIN_ENTRIES: usize = 1 << 21;

impl Product {
    /// For K's upper CSC pattern with a helper in `pool`: m where the columns before it hold
    /// half of K's entries; None when K is small, or the rows left to the caller (rows before
    /// m in columns from m on) are more than 1/16 of K's entries. The buffers (three vectors
    /// of up to n) are allocated fallibly here, once.
    fn try_new(
        col_ptr: &[usize],
        row_idx: &[usize],
        pool: Arc<Pool>,
    ) -> Result<Option<Product>, OutOfMemory> {
        let n = col_ptr.len() - 1;
        let nnz = row_idx.len();
        if pool.helpers() == 0 || nnz < PRODUCT_MIN_ENTRIES {
            return Ok(None);
        }
        let m = col_ptr.partition_point(|&p| p < nnz / 2).min(n);
        let cross: usize = (m..n)
            .map(|j| row_idx[col_ptr[j]..col_ptr[j + 1]].partition_point(|&i| i < m))
            .sum();
        if m == 0 || m == n || cross > nnz / 16 {
            return Ok(None);
        }
        let what = "the two threads' product";
        let lent = Lent {
            matrix: None,
            x: memory::zeros(n, what)?,
            abs: false,
        };
        let out = [memory::zeros(n - m, what)?, memory::zeros(n - m, what)?];
        let (lent, out) = (Arc::new(RwLock::new(lent)), Arc::new(Mutex::new(out)));
        let (l, o) = (Arc::clone(&lent), Arc::clone(&out));
        pool.set_job_in(
            0,
            PRODUCT,
            Box::new(move || {
                let lent = l.read().unwrap_or_else(|e| e.into_inner());
                let mut out = o.lock().unwrap_or_else(|e| e.into_inner());
                let [y, abs] = &mut *out;
                if let Some(k) = &lent.matrix {
                    let abs = lent.abs.then_some(&mut abs[..]);
                    product_columns(k, &lent.x, m..k.ncols(), m, y, abs);
                }
            }),
        );
        Ok(Some(Product { pool, m, lent, out }))
    }
}

/// Columns `cols` of y = K x (K upper CSC, symmetric), and of |K| |x| into `abs` when given,
/// into vectors that start at row `lo`: column j's entries summed into y[j - lo], and its
/// entries in rows i in [lo, j) added to y[i - lo], column by column; rows before `lo` are left
/// out ([`product_cross`] adds them). With `cols` 0..n and `lo` 0: the whole product.
fn product_columns(
    k: &SparseColMat<usize, f64>,
    x: &[f64],
    cols: std::ops::Range<usize>,
    lo: usize,
    y: &mut [f64],
    mut abs: Option<&mut [f64]>,
) {
    let sym = k.symbolic();
    let (cp, ri) = (sym.col_ptr(), sym.row_idx());
    let v = k.val();
    y.fill(0.0);
    if let Some(a) = abs.as_deref_mut() {
        a.fill(0.0);
    }
    match abs {
        None => {
            for j in cols {
                let (mut acc, xj) = (0.0, x[j]);
                for p in cp[j]..cp[j + 1] {
                    let i = ri[p];
                    acc += v[p] * x[i];
                    if i != j && i >= lo {
                        y[i - lo] += v[p] * xj;
                    }
                }
                y[j - lo] += acc;
            }
        }
        Some(abs) => {
            for j in cols {
                let (mut acc, mut acc_abs, xj) = (0.0, 0.0, x[j]);
                for p in cp[j]..cp[j + 1] {
                    let i = ri[p];
                    acc += v[p] * x[i];
                    acc_abs += (v[p] * x[i]).abs();
                    if i != j && i >= lo {
                        y[i - lo] += v[p] * xj;
                        abs[i - lo] += (v[p] * xj).abs();
                    }
                }
                y[j - lo] += acc;
                abs[j - lo] += acc_abs;
            }
        }
    }
}

/// The entries of columns m..n in rows before m added to y (and |K| |x| to `abs`), column by
/// column: what [`product_columns`] left out of the part from m on.
fn product_cross(
    k: &SparseColMat<usize, f64>,
    x: &[f64],
    m: usize,
    y: &mut [f64],
    mut abs: Option<&mut [f64]>,
) {
    let sym = k.symbolic();
    let (cp, ri) = (sym.col_ptr(), sym.row_idx());
    let v = k.val();
    for j in m..k.ncols() {
        let xj = x[j];
        // Rows are sorted in each column: those before m come first.
        for p in cp[j]..cp[j + 1] {
            let i = ri[p];
            if i >= m {
                break;
            }
            y[i] += v[p] * xj;
            if let Some(a) = abs.as_deref_mut() {
                a[i] += (v[p] * xj).abs();
            }
        }
    }
}

/// Work counters of one [`Ldlt`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Counts {
    /// Numeric factorizations.
    pub factorizations: usize,
    /// Newton directions taken from preconditioned conjugate gradients on an earlier
    /// factorization ([`Ldlt::pcg`]).
    pub inexact: usize,
    /// Preconditioner solves those took, failed attempts included.
    pub pcg_solves: usize,
    /// Attempts that did not converge (a factorization followed).
    pub pcg_failed: usize,
    /// Substitutions (forward and back through the factor), any precision.
    pub substitutions: usize,
    /// Refinement steps of solves with the single-precision factor (one substitution each).
    pub refinements: usize,
    /// Single-precision factors given up for double precision (the refinement did not
    /// contract, or the single-precision factorization failed).
    pub fallbacks: usize,
}

impl Ldlt {
    /// Symbolic analysis of the upper-triangular pattern (AMD ordering, forced supernodal).
    /// Every buffer that grows with the pattern (values, factor, factorization and solve
    /// workspaces) is allocated fallibly: a shortage is an [`OutOfMemory`], never an abort.
    pub fn try_new(
        n: usize,
        col_ptr: Vec<usize>,
        row_idx: Vec<usize>,
    ) -> Result<Ldlt, OutOfMemory> {
        Ldlt::try_with_pool(n, col_ptr, row_idx, None)
    }

    /// [`Ldlt::try_new`], factoring on `pool`'s threads when there are 2 or more, the tangent
    /// is large enough ([`SPLIT_MIN_EQUATIONS`]) and it has a small balanced separator: two
    /// halves side by side (`split.rs`, numbered in the AMD order of the whole). Otherwise (and
    /// with no pool) the whole tangent on the caller's thread.
    pub fn try_with_pool(
        n: usize,
        col_ptr: Vec<usize>,
        row_idx: Vec<usize>,
        pool: Option<Arc<Pool>>,
    ) -> Result<Ldlt, OutOfMemory> {
        Ldlt::try_filled(n, col_ptr, row_idx, pool, None)
    }

    /// [`Ldlt::try_with_pool`] in the elimination order `fill` (`dissect.rs`) in place of
    /// faer's AMD when given. With 2 threads its top separator, when it has one, is the
    /// split's (`split.rs`): the whole tangent's symbolic analysis is then not needed.
    pub fn try_filled(
        n: usize,
        col_ptr: Vec<usize>,
        row_idx: Vec<usize>,
        pool: Option<Arc<Pool>>,
        fill: Option<Fill>,
    ) -> Result<Ldlt, OutOfMemory> {
        let nnz = row_idx.len();
        use crate::phases::start;
        let what = "the symbolic factorization of the tangent";
        let order = match &fill {
            Some(fill) if fill.perm.len() == n => {
                let mut inv = memory::zeros::<usize>(n, what)?;
                for (k, &e) in fill.perm.iter().enumerate() {
                    inv[e] = k;
                }
                Some((memory::copy(&fill.perm, what)?, inv))
            }
            _ => None,
        };
        let pool_split = pool.filter(|_| n >= SPLIT_MIN_EQUATIONS);
        let pool_product = pool_split.clone();
        // With 2 threads and a top separator: the split straight from the order, its halves
        // built on both threads (the pattern shared with the helper meanwhile).
        let mut split = None;
        let (col_ptr, row_idx) = match (&pool_split, &order, fill.as_ref().and_then(|f| f.top)) {
            (Some(pool), Some((_, inv)), Some(top)) => {
                let _phase = start("two halves at the top separator (Split::try_at)");
                let shared = Arc::new((col_ptr, row_idx));
                split = Split::try_at(n, &shared, inv, top, Arc::clone(pool))?;
                // The helper has dropped its reference (`Split::try_at`): no copy is made.
                Arc::unwrap_or_clone(shared)
            }
            _ => (col_ptr, row_idx),
        };
        let sym = SymbolicSparseColMat::new_checked(n, n, col_ptr, None, row_idx);
        let matrix = SparseColMat::new(sym, memory::lazy_zeros(nnz, "the tangent matrix")?);
        let symbolic = if split.is_some() {
            None
        } else {
            let ordering = match &order {
                Some((fwd, inv)) => {
                    SymmetricOrdering::Custom(faer::perm::PermRef::new_checked(fwd, inv, n))
                }
                None => SymmetricOrdering::Amd,
            };
            let _phase = start("symbolic factorization of the whole tangent");
            Some(symbolic_ldlt(&matrix, ordering, what)?)
        };
        if split.is_none() {
            if let (Some(pool), Some(symbolic)) = (pool_split, &symbolic) {
                let sym = matrix.symbolic();
                let rank = symbolic.perm().map(|p| p.arrays().1);
                let _phase = start("two halves by breadth-first levels (Split::try_new)");
                split = Split::try_new(n, sym.col_ptr(), sym.row_idx(), rank, pool)?;
            }
        }
        // With a split its halves hold the factor.
        let whole = match (&split, &symbolic) {
            (None, Some(symbolic)) => symbolic.len_val(),
            _ => 0,
        };
        let _phase = start("factor values and workspaces");
        let l_values = memory::lazy_zeros(whole, "the factor of the tangent")?;
        let buffer = |req: StackReq, what: &'static str| {
            MemBuffer::try_new(req).map_err(|_| OutOfMemory {
                what,
                bytes: req.size_bytes() as u64,
            })
        };
        let factor_mem = buffer(
            match (&split, &symbolic) {
                (None, Some(symbolic)) => symbolic
                    .factorize_numeric_ldlt_scratch::<f64>(Par::Seq, Default::default())
                    .or(symbolic
                        .factorize_numeric_ldlt_scratch::<f32>(Par::Seq, Default::default())),
                _ => StackReq::EMPTY,
            },
            "the factorization workspace",
        )?;
        let solve_mem = buffer(
            match (&split, &symbolic) {
                (None, Some(symbolic)) => symbolic
                    .solve_in_place_scratch::<f64>(1, Par::Seq)
                    .or(symbolic.solve_in_place_scratch::<f32>(1, Par::Seq)),
                _ => StackReq::EMPTY,
            },
            "the solve workspace",
        )?;
        // The product on two threads with the split (whose helper then has the time).
        let product = match (&split, pool_product) {
            (Some(_), Some(pool)) => {
                let sym = matrix.symbolic();
                Product::try_new(sym.col_ptr(), sym.row_idx(), pool)?
            }
            _ => None,
        };
        let mut ldlt = Ldlt {
            matrix,
            symbolic,
            l_values,
            factor_mem,
            solve_mem,
            factored: false,
            counts: Counts::default(),
            split,
            groups: Vec::new(),
            scale: Vec::new(),
            largest: Vec::new(),
            rows: Vec::new(),
            ordered_scale: Vec::new(),
            ordered_for: 0,
            single: false,
            v32: Vec::new(),
            l32: Vec::new(),
            x32: Vec::new(),
            refine: Vec::new(),
            notes: Vec::new(),
            stale: false,
            spare: None,
            product,
        };
        ldlt.set_precision(Precision::Auto)?;
        Ok(ldlt)
    }

    /// Factor in the precision `precision` asks for from the next [`Ldlt::factor`] on (the
    /// single-precision buffers allocated fallibly, or freed). A factor held is dropped.
    pub fn set_precision(&mut self, precision: Precision) -> Result<(), OutOfMemory> {
        let n = self.matrix.ncols();
        let single = match precision {
            Precision::Auto => n >= SINGLE_MIN_EQUATIONS,
            Precision::Double => false,
            Precision::Single => n > 0,
        };
        self.factored = false;
        let what = "the single-precision factor";
        if let Some(split) = self.split.as_mut() {
            split.set_single(single)?;
        } else if single {
            let symbolic = self
                .symbolic
                .as_ref()
                .expect("the whole tangent's symbolic factorization");
            if self.l32.is_empty() {
                self.l32 = memory::lazy_zeros(symbolic.len_val(), what)?;
                self.v32 = memory::lazy_zeros(self.matrix.val().len(), what)?;
                self.x32 = memory::zeros(n, what)?;
            }
        } else {
            self.l32 = Vec::new();
            self.v32 = Vec::new();
            self.x32 = Vec::new();
        }
        self.single = single;
        Ok(())
    }

    /// Whether the tangent is factored in single precision (module docs, "Mixed precision").
    pub fn is_single(&self) -> bool {
        self.single
    }

    /// The log lines of the falls back to double precision since the last call.
    pub fn take_notes(&mut self) -> Vec<String> {
        std::mem::take(&mut self.notes)
    }

    /// (A, B, separator) equations of the two-domain factorization, if it is used.
    pub fn split_sizes(&self) -> Option<(usize, usize, usize)> {
        self.split.as_ref().map(Split::sizes)
    }

    /// Stored entries of the factor L (AMD ordering, supernodal), for the scaling benchmark.
    pub fn factor_nonzeros(&self) -> usize {
        match (&self.split, &self.symbolic) {
            (Some(split), _) => split.factor_nonzeros(),
            (None, Some(symbolic)) => symbolic.len_val(),
            (None, None) => 0,
        }
    }

    /// Flops of one numeric factorization, Σ c² over the factor's columns (c: the column's
    /// entries below the diagonal; the halves' and the separator's with a split).
    pub fn factor_flops(&self) -> f64 {
        match (&self.split, &self.symbolic) {
            (Some(split), _) => split.factor_flops(),
            (None, Some(symbolic)) => super::factor::flops(symbolic),
            (None, None) => 0.0,
        }
    }

    /// Numeric factorizations done since this factorization object was made.
    pub fn factorizations(&self) -> usize {
        self.counts.factorizations
    }

    /// Whether a numeric factorization is held (of the values at some earlier
    /// [`Ldlt::factor`]).
    pub fn has_factor(&self) -> bool {
        self.factored
    }

    /// The matrix values (upper triangle, CSC order) as last filled.
    pub fn values(&self) -> &[f64] {
        self.matrix.val()
    }

    /// The matrix (upper triangle, CSC) as last filled: the sensitivity's products with the
    /// true tangent (`sensitivity.rs`).
    pub fn matrix(&self) -> faer::sparse::SparseColMatRef<'_, usize, f64> {
        self.matrix.as_ref()
    }

    /// The matrix values (upper triangle, CSC order) to fill before [`Ldlt::factor_solve`].
    pub fn values_mut(&mut self) -> &mut [f64] {
        self.stale = true;
        self.matrix.val_mut()
    }

    /// Factor the current values and solve K x = rhs in place. Err with a reason when the
    /// factorization fails or the solution is not finite.
    pub fn factor_solve(&mut self, rhs: &mut [f64]) -> Result<(), Error> {
        if rhs.is_empty() {
            return Ok(());
        }
        self.factor()?;
        self.solve(rhs)
    }

    /// Numeric factorization of the current values (kept for [`Ldlt::solve`]).
    pub fn factor(&mut self) -> Result<(), Error> {
        if self.matrix.ncols() == 0 {
            return Ok(());
        }
        let _phase = crate::phases::start("solve: numeric factorization (Ldlt::factor)");
        let max_diag = self.max_diagonal();
        if !(max_diag.is_finite() && max_diag > 0.0) {
            return Err(Breakdown::Diagonal(max_diag).into());
        }
        self.counts.factorizations += 1;
        self.factored = false;
        if self.split.is_some() {
            let result = self.factor_split(max_diag);
            return self.factored_or_fall_back(result);
        }
        let scaled = self.scale_values(max_diag);
        let unit = if scaled { 1.0 } else { max_diag };
        let reg = (PIVOT_DELTA * unit, PIVOT_EPSILON * unit);
        let result = match self.split.as_mut() {
            Some(split) => split.factor(self.matrix.val(), reg),
            None if self.single => {
                for (s, &v) in self.v32.iter_mut().zip(self.matrix.val()) {
                    *s = v as f32;
                }
                numeric_ldlt(
                    self.symbolic
                        .as_ref()
                        .expect("the whole tangent's symbolic factorization"),
                    &mut self.l32,
                    faer::sparse::SparseColMatRef::new(self.matrix.symbolic(), &self.v32),
                    reg,
                    &mut self.factor_mem,
                    "the tangent",
                )
            }
            None => numeric_ldlt(
                self.symbolic
                    .as_ref()
                    .expect("the whole tangent's symbolic factorization"),
                &mut self.l_values,
                self.matrix.as_ref(),
                reg,
                &mut self.factor_mem,
                "the tangent",
            ),
        };
        if scaled {
            self.unscale_values();
        }
        self.factored_or_fall_back(result)
    }

    /// The end of [`Ldlt::factor`]: the factor is held, or (single precision's failed) the
    /// tangent is factored in double precision.
    fn factored_or_fall_back(&mut self, result: Result<(), Error>) -> Result<(), Error> {
        if let (Err(e), true) = (&result, self.single) {
            // Single precision's factorization failed: double's is the answer either way.
            return self.fall_back(format!("the single-precision factorization failed ({e})"));
        }
        result?;
        self.factored = true;
        self.stale = false;
        Ok(())
    }

    /// [`Ldlt::factor`] with the split (`split.rs`): S computed here, and each half gathers
    /// and scales its values on its own thread ([`Split::factor_shared`]) instead of K being
    /// scaled in place and unscaled on this thread; the same factor bit for bit. K's values
    /// and S are lent to the split for the factorization (moved, not copied).
    fn factor_split(&mut self, max_diag: f64) -> Result<(), Error> {
        let scaled = self.compute_scale(max_diag);
        let unit = if scaled { 1.0 } else { max_diag };
        let reg = (PIVOT_DELTA * unit, PIVOT_EPSILON * unit);
        // K's values taken out of the matrix (an empty matrix in their place, built once: a
        // factorization allocates nothing) and lent to the halves.
        let empty = match self.spare.take() {
            Some(empty) => empty,
            None => SparseColMat::new(
                SymbolicSparseColMat::new_checked(0, 0, vec![0], None, Vec::new()),
                Vec::new(),
            ),
        };
        let (sym, mut values) = std::mem::replace(&mut self.matrix, empty).into_parts();
        let mut unscaled = Vec::new();
        let scale = match scaled {
            true => &mut self.scale,
            false => &mut unscaled,
        };
        let result = match self.split.as_mut() {
            Some(split) => split.factor_shared(&mut values, scale, reg),
            None => Ok(()),
        };
        self.spare = Some(std::mem::replace(
            &mut self.matrix,
            SparseColMat::new(sym, values),
        ));
        result
    }

    /// Give up the single-precision factor: the note logged, the tangent factored in double
    /// precision from here on.
    fn fall_back(&mut self, why: String) -> Result<(), Error> {
        self.counts.fallbacks += 1;
        self.notes.push(format!(
            "linear solve: {why}; the tangent ({} equations) is factored in double precision from here on",
            self.matrix.ncols()
        ));
        self.set_precision(Precision::Double)?;
        self.factor()
    }

    /// The group of every equation (the solver: each node's equations one group), for the
    /// scaled factorization (module docs). Ignored unless it has one entry per equation.
    pub fn set_groups(&mut self, groups: Vec<u32>) -> Result<(), OutOfMemory> {
        let n = self.matrix.ncols();
        if groups.len() != n {
            return Ok(());
        }
        let count = groups.iter().map(|&g| g as usize + 1).max().unwrap_or(0);
        self.largest = memory::zeros(count, "the tangent's scaling")?;
        self.scale = memory::zeros(n, "the tangent's scaling")?;
        self.groups = groups;
        Ok(())
    }

    /// S from the groups' largest diagonals, and the values scaled to S K S. False (nothing
    /// done) without groups.
    fn scale_values(&mut self, max_diag: f64) -> bool {
        if !self.compute_scale(max_diag) {
            return false;
        }
        self.apply_scale(|v, s| v * s);
        true
    }

    /// S from the groups' largest diagonals (module docs) into `scale`; false (nothing done)
    /// without groups.
    fn compute_scale(&mut self, max_diag: f64) -> bool {
        let n = self.matrix.ncols();
        if self.groups.len() != n || self.scale.len() != n {
            return false;
        }
        self.largest.fill(0.0);
        let (sym, v) = self.matrix.parts_mut();
        let cp = sym.col_ptr();
        for (j, &g) in self.groups.iter().enumerate() {
            let g = g as usize;
            self.largest[g] = self.largest[g].max(v[cp[j + 1] - 1].abs());
        }
        for (s, &g) in self.scale.iter_mut().zip(&self.groups) {
            let d = self.largest[g as usize];
            let d = if d > 0.0 && d.is_finite() {
                d
            } else {
                max_diag
            };
            // 2^-round(log2 √d): exact to apply and to undo.
            *s = (-(0.5 * d.log2()).round()).exp2();
        }
        true
    }

    /// The values back from S K S to K (exactly: S is powers of two).
    fn unscale_values(&mut self) {
        self.apply_scale(|v, s| v / s);
    }

    /// v_ij = op(v_ij, S_ii S_jj) over the stored upper triangle.
    fn apply_scale(&mut self, op: impl Fn(f64, f64) -> f64) {
        let (sym, v) = self.matrix.parts_mut();
        let (cp, ri) = (sym.col_ptr(), sym.row_idx());
        for j in 0..sym.ncols() {
            for k in cp[j]..cp[j + 1] {
                v[k] = op(v[k], self.scale[ri[k]] * self.scale[j]);
            }
        }
    }

    /// Solve K x = rhs in place with the last factorization: one forward/back substitution
    /// with a double-precision factor; with a single-precision one, as many more as the
    /// refinement takes to the double-precision answer (module docs, "Mixed precision"), or
    /// a double-precision factorization when it does not contract. After the values were
    /// changed ([`Ldlt::values_mut`]) without a factorization, one substitution with the
    /// factor held, whatever its precision.
    pub fn solve(&mut self, rhs: &mut [f64]) -> Result<(), Error> {
        if rhs.is_empty() {
            return Ok(());
        }
        if !self.single || self.stale {
            // A solve with a factor of values since changed (the chord step of `newton.rs`)
            // has no matrix to refine against: one substitution, as the preconditioner.
            return self.substitute(rhs);
        }
        self.refined(rhs)
    }

    /// [`Ldlt::solve`] with the single-precision factor M: x = M⁻¹ b, then while the
    /// componentwise backward error of x is above [`BACKWARD_ERROR`], r = b − K x (in f64)
    /// and x += M⁻¹ r; each correction must be at most [`MAX_CONTRACTION`] of the one before
    /// (of x at the first), within [`MAX_REFINEMENT_STEPS`] steps, else the tangent is
    /// factored in double precision ([`Ldlt::fall_back`]) and solved with that.
    fn refined(&mut self, rhs: &mut [f64]) -> Result<(), Error> {
        let n = rhs.len();
        if self.refine.len() != 3 * n {
            self.refine = memory::zeros(3 * n, "the refinement's vectors")?;
        }
        let mut work = std::mem::take(&mut self.refine);
        let (b, rest) = work.split_at_mut(n);
        let (r, abs) = rest.split_at_mut(n);
        b.copy_from_slice(rhs);
        let mut result = self.substitute(rhs);
        let mut last = inf_norm(rhs);
        let mut failure = None;
        for step in 0..=MAX_REFINEMENT_STEPS {
            if result.is_err() {
                break;
            }
            let omega = {
                let _phase = crate::phases::start("solve: refinement residual (Ldlt::solve)");
                self.residual(b, rhs, r, abs)
            };
            if omega <= BACKWARD_ERROR {
                failure = None;
                break;
            }
            if step == MAX_REFINEMENT_STEPS {
                failure = Some(format!(
                    "the refinement of the single-precision factor's solve left a backward error of {omega:.2e} after {step} steps"
                ));
                break;
            }
            result = self.substitute(r);
            self.counts.refinements += 1;
            let size = inf_norm(r);
            rhs.iter_mut().zip(r.iter()).for_each(|(x, d)| *x += d);
            let ratio = size / last;
            if size <= ROUND_OFF * inf_norm(rhs) {
                break;
            }
            if !(ratio <= MAX_CONTRACTION) {
                failure = Some(format!(
                    "the refinement of the single-precision factor's solve contracted by {ratio:.2e} > {MAX_CONTRACTION} at step {}",
                    step + 1
                ));
                break;
            }
            last = size;
        }
        if let (Err(e), None) = (&result, &failure) {
            failure = Some(format!("the single-precision factor's solve failed ({e})"));
        }
        let outcome = match failure {
            None => Ok(()),
            Some(why) => {
                rhs.copy_from_slice(b);
                self.fall_back(why).and_then(|()| self.substitute(rhs))
            }
        };
        self.refine = work;
        outcome
    }

    /// r = b − K x and |K| |x| + |b| (in `abs`); returns the componentwise backward error
    /// max_i |r_i| / (|K| |x| + |b|)_i (rows where the denominator is 0 count when r_i ≠ 0).
    fn residual(&mut self, b: &[f64], x: &[f64], r: &mut [f64], abs: &mut [f64]) -> f64 {
        self.product(x, r, Some(abs));
        let mut omega = 0.0f64;
        for i in 0..r.len() {
            r[i] = b[i] - r[i];
            let d = abs[i] + b[i].abs();
            let e = if d > 0.0 {
                r[i].abs() / d
            } else if r[i] == 0.0 {
                0.0
            } else {
                f64::INFINITY
            };
            // NaN (a non-finite x) counts as the largest error.
            omega = if e.is_nan() {
                f64::INFINITY
            } else {
                omega.max(e)
            };
        }
        omega
    }

    /// One forward/back substitution with the last factorization, in place, in the factor's
    /// precision (the preconditioner of [`Ldlt::pcg`]; [`Ldlt::solve`] with a
    /// double-precision factor).
    fn substitute(&mut self, rhs: &mut [f64]) -> Result<(), Error> {
        let n = rhs.len();
        if n == 0 {
            return Ok(());
        }
        self.counts.substitutions += 1;
        let _phase = crate::phases::start("solve: substitution (Ldlt::solve)");
        let scaled = self.scale.len() == n;
        if scaled {
            rhs.iter_mut().zip(&self.scale).for_each(|(x, s)| *x *= s);
        }
        let result = self.solve_scaled(rhs);
        if scaled {
            rhs.iter_mut().zip(&self.scale).for_each(|(x, s)| *x *= s);
        }
        result
    }

    /// Solve with the last factorization for `columns` right-hand sides at once (column
    /// major in `rhs`, each of the equations' length): one pass over the factor for all of
    /// them (the block Lanczos of `modes.rs`); with the two-domain split, one after another.
    pub fn solve_columns(&mut self, rhs: &mut [f64], columns: usize) -> Result<(), Error> {
        if columns == 0 || rhs.is_empty() {
            return Ok(());
        }
        let n = rhs.len() / columns;
        if self.split.is_some() || columns == 1 || self.single {
            for column in rhs.chunks_mut(n) {
                self.solve(column)?;
            }
            return Ok(());
        }
        let scaled = self.scale.len() == n;
        if scaled {
            for column in rhs.chunks_mut(n) {
                column
                    .iter_mut()
                    .zip(&self.scale)
                    .for_each(|(x, s)| *x *= s);
            }
        }
        let symbolic = self
            .symbolic
            .as_ref()
            .expect("the whole tangent's symbolic factorization");
        let req = symbolic.solve_in_place_scratch::<f64>(columns, Par::Seq);
        let mut mem = MemBuffer::try_new(req).map_err(|_| OutOfMemory {
            what: "the solve workspace",
            bytes: req.size_bytes() as u64,
        })?;
        let ldlt = LdltRef::new(symbolic, &self.l_values);
        let rhs_mat = MatMut::from_column_major_slice_mut(rhs, n, columns);
        ldlt.solve_in_place_with_conj(Conj::No, rhs_mat, Par::Seq, MemStack::new(&mut mem));
        if scaled {
            for column in rhs.chunks_mut(n) {
                column
                    .iter_mut()
                    .zip(&self.scale)
                    .for_each(|(x, s)| *x *= s);
            }
        }
        if rhs.iter().all(|x| x.is_finite()) {
            Ok(())
        } else {
            Err(Breakdown::NonFinite(NON_FINITE).into())
        }
    }

    /// faer's supernodal factor when [`Ldlt::solve_block`] substitutes with it (a whole
    /// double-precision factor); None: it calls [`Ldlt::solve_columns`].
    fn block_factor(&self) -> Option<&SymbolicSupernodalCholesky<usize>> {
        supernodal_factor(&self.split, &self.symbolic, self.single)
    }

    /// The order in which [`Ldlt::solve_block_ordered`] takes and returns its vectors: `(fwd,
    /// inv)`, position i holding equation `fwd[i]` and equation e at position `inv[e]` (the
    /// factor's fill-reducing order); None: the equations' own order. As held now: it changes
    /// only with the precision or the split.
    pub fn block_order(&self) -> Option<(&[usize], &[usize])> {
        self.block_factor()?;
        self.symbolic.as_ref()?.perm().map(|p| p.arrays())
    }

    /// [`Ldlt::solve_block`] on vectors held in the order of [`Ldlt::block_order`] (a
    /// Lanczos basis kept in that order: no gather or scatter through the permutation, which
    /// reads the block at random): x ← K⁻¹ b for the `columns` columns of `from` (column-major,
    /// in that order), or of x itself when `from` is None. The result equals
    /// [`Ldlt::solve_block`]'s on the permuted vectors, bit for bit.
    pub fn solve_block_ordered(
        &mut self,
        x: &mut [f64],
        from: Option<&[f64]>,
        columns: usize,
    ) -> Result<(), Error> {
        if columns == 0 || x.is_empty() {
            return Ok(());
        }
        let n = x.len() / columns;
        if self.block_factor().is_none() {
            if let Some(b) = from {
                x.copy_from_slice(&b[..x.len()]);
            }
            return self.solve_block(x, columns);
        }
        // S in the factor's order, gathered once per factorization.
        let scaled = self.scale.len() == n;
        if scaled
            && (self.ordered_for != self.counts.factorizations || self.ordered_scale.len() != n)
        {
            // Its memory reused from factorization to factorization.
            let mut ordered = std::mem::take(&mut self.ordered_scale);
            ordered.clear();
            ordered.try_reserve_exact(n).map_err(|_| OutOfMemory {
                what: "the block solve's scaling",
                bytes: 8 * n as u64,
            })?;
            match self.symbolic.as_ref().and_then(|s| s.perm()) {
                Some(perm) => ordered.extend(perm.arrays().0.iter().map(|&e| self.scale[e])),
                None => ordered.extend_from_slice(&self.scale),
            }
            self.ordered_scale = ordered;
            self.ordered_for = self.counts.factorizations;
        }
        self.substitute_block(x, from, columns, true)
    }

    /// [`Ldlt::solve_columns`] (the same arguments and results, to round-off) by a block
    /// substitution of our own (with a single-precision factor: [`Ldlt::solve`] column by
    /// column): the `columns` right-hand sides are gathered row by row in the
    /// factor's order (an unknown's values side by side), and each supernode of the factor is
    /// read once per sweep for all of them, up to [`BLOCK_ROWS`] at a time (module docs of
    /// [`block_substitution`]). With the two-domain split, or a factor that is not
    /// supernodal, it is [`Ldlt::solve_columns`].
    pub fn solve_block(&mut self, rhs: &mut [f64], columns: usize) -> Result<(), Error> {
        if columns == 0 || rhs.is_empty() {
            return Ok(());
        }
        if self.block_factor().is_none() {
            return self.solve_columns(rhs, columns);
        }
        self.substitute_block(rhs, None, columns, false)
    }

    /// [`Ldlt::solve_block`]'s substitution (a supernodal factor held): x ← K⁻¹ b, b the
    /// columns of `from` or of x; `ordered`: the vectors are in the factor's order and
    /// `ordered_scale` is S in it ([`Ldlt::solve_block_ordered`]).
    fn substitute_block(
        &mut self,
        rhs: &mut [f64],
        from: Option<&[f64]>,
        columns: usize,
        ordered: bool,
    ) -> Result<(), Error> {
        let Some(supernodal) = self.block_factor() else {
            return self.solve_columns(rhs, columns);
        };
        let n = rhs.len() / columns;
        let _phase = crate::phases::start("solve: block substitution (Ldlt::solve_block)");
        let width = columns.min(BLOCK_ROWS);
        // Room for the rows and, after them, one supernode's pattern rows (the backward
        // sweep's gathered values).
        // (The 4-column kernel holds a whole supernode's rows there: its columns and pattern.)
        let longest = (0..supernodal.n_supernodes())
            .map(|s| {
                let size = supernodal.supernode_end()[s] - supernodal.supernode_begin()[s];
                size + supernodal.supernode(s).pattern().len()
            })
            .max()
            .unwrap_or(0);
        let room = (n + longest) * width;
        if self.rows.len() < room {
            self.rows = memory::lazy_zeros(room, "the block solve's workspace")?;
        }
        let supernodal = supernodal_factor(&self.split, &self.symbolic, self.single)
            .expect("the whole tangent's supernodal factorization");
        let symbolic = self
            .symbolic
            .as_ref()
            .expect("the whole tangent's symbolic factorization");
        let (perm, scale) = if ordered {
            (
                None,
                (self.scale.len() == n).then_some(&self.ordered_scale[..]),
            )
        } else {
            (
                symbolic.perm().map(|p| p.arrays()),
                (self.scale.len() == n).then_some(&self.scale[..]),
            )
        };
        let parts = Parts {
            factor: supernodal,
            values: &self.l_values,
            perm,
            scale,
        };
        let mut c0 = 0;
        while c0 < columns {
            let w = (columns - c0).min(BLOCK_ROWS);
            let block = &mut rhs[c0 * n..(c0 + w) * n];
            let from = from.map(|b| &b[c0 * n..(c0 + w) * n]);
            let rows = &mut self.rows[..(n + longest) * w];
            match w {
                1 => block_solve::<1>(&parts, from, block, rows),
                2 => block_solve::<2>(&parts, from, block, rows),
                3 => block_solve::<3>(&parts, from, block, rows),
                4 => block_solve::<4>(&parts, from, block, rows),
                5 => block_solve::<5>(&parts, from, block, rows),
                6 => block_solve::<6>(&parts, from, block, rows),
                7 => block_solve::<7>(&parts, from, block, rows),
                _ => block_solve::<8>(&parts, from, block, rows),
            }
            c0 += w;
        }
        if rhs.iter().all(|x| x.is_finite()) {
            Ok(())
        } else {
            Err(Breakdown::NonFinite(NON_FINITE).into())
        }
    }

    /// Solve with the factor as held (of S K S when scaled).
    fn solve_scaled(&mut self, rhs: &mut [f64]) -> Result<(), Error> {
        let n = rhs.len();
        if let Some(split) = self.split.as_mut() {
            split.solve(rhs)?;
            return if rhs.iter().all(|x| x.is_finite()) {
                Ok(())
            } else {
                Err(Breakdown::NonFinite(NON_FINITE).into())
            };
        }
        let symbolic = self
            .symbolic
            .as_ref()
            .expect("the whole tangent's symbolic factorization");
        if self.single {
            for (s, &v) in self.x32.iter_mut().zip(rhs.iter()) {
                *s = v as f32;
            }
            let ldlt = LdltRef::new(symbolic, &self.l32);
            ldlt.solve_in_place_with_conj(
                Conj::No,
                MatMut::from_column_major_slice_mut(&mut self.x32, n, 1),
                Par::Seq,
                MemStack::new(&mut self.solve_mem),
            );
            for (v, &s) in rhs.iter_mut().zip(&self.x32) {
                *v = s as f64;
            }
            return if rhs.iter().all(|x| x.is_finite()) {
                Ok(())
            } else {
                Err(Breakdown::NonFinite(NON_FINITE).into())
            };
        }
        let ldlt = LdltRef::new(symbolic, &self.l_values);
        let rhs_mat = MatMut::from_column_major_slice_mut(rhs, n, 1);
        ldlt.solve_in_place_with_conj(
            Conj::No,
            rhs_mat,
            Par::Seq,
            MemStack::new(&mut self.solve_mem),
        );
        if rhs.iter().all(|x| x.is_finite()) {
            Ok(())
        } else {
            Err(Breakdown::NonFinite(NON_FINITE).into())
        }
    }

    /// Inexact solve of K x = b with the current values K, preconditioned by the last
    /// factorization (of an earlier tangent; whole or split, whichever [`Ldlt::solve`] uses):
    /// conjugate gradients from x = 0 until the recurred residual ‖b − K x‖₂ ≤
    /// `reduction`·‖b‖₂. Some(preconditioner solves) with x on success; None when it does not
    /// get there within `max_solves` solves, or K or the old factor is not positive definite
    /// along the way, or x is not finite (the caller then factors afresh; x is then scratch).
    /// `work` holds four vectors of length n between calls (allocated
    /// fallibly at the first call and reused, `work.rs`' rule).
    pub fn pcg(
        &mut self,
        b: &[f64],
        x: &mut [f64],
        reduction: f64,
        max_solves: usize,
        work: &mut Vec<f64>,
    ) -> Option<usize> {
        let n = b.len();
        if !self.factored || n == 0 || n != self.matrix.ncols() || x.len() != n {
            return None;
        }
        let _phase = crate::phases::start("solve: inexact Newton (Ldlt::pcg)");
        work.clear();
        // Allocated once, fallibly: short of memory the caller factors instead.
        if work.try_reserve_exact(4 * n).is_err() {
            return None;
        }
        work.resize(4 * n, 0.0);
        let (r, rest) = work.split_at_mut(n);
        let (z, rest) = rest.split_at_mut(n);
        let (p, q) = rest.split_at_mut(n);
        r.copy_from_slice(b);
        x.fill(0.0);
        let target = reduction * dot(r, r).sqrt();
        z.copy_from_slice(r);
        self.counts.pcg_solves += 1;
        self.substitute(z).ok()?;
        p.copy_from_slice(z);
        let mut rz = dot(r, z);
        let mut solves = 1;
        loop {
            if !(rz > 0.0 && rz.is_finite()) {
                return None;
            }
            self.multiply(p, q);
            let pq = dot(p, q);
            if !(pq > 0.0 && pq.is_finite()) {
                return None;
            }
            let alpha = rz / pq;
            for i in 0..n {
                x[i] += alpha * p[i];
                r[i] -= alpha * q[i];
            }
            if dot(r, r).sqrt() <= target {
                return x.iter().all(|v| v.is_finite()).then_some(solves);
            }
            if solves >= max_solves {
                return None;
            }
            self.counts.pcg_solves += 1;
            z.copy_from_slice(r);
            self.substitute(z).ok()?;
            solves += 1;
            let rz_next = dot(r, z);
            let beta = rz_next / rz;
            rz = rz_next;
            for i in 0..n {
                p[i] = z[i] + beta * p[i];
            }
        }
    }

    /// y = K x with the current values (upper triangle stored, symmetric).
    fn multiply(&mut self, x: &[f64], y: &mut [f64]) {
        let _phase = crate::phases::start("solve: K p (pcg)");
        self.product(x, y, None);
    }

    /// y = K x, and |K| |x| into `abs` when given: on two threads where there is a
    /// [`Product`] (the same bits), else on this one.
    fn product(&mut self, x: &[f64], y: &mut [f64], mut abs: Option<&mut [f64]>) {
        let n = self.matrix.ncols();
        let Some(product) = self.product.as_ref().filter(|_| x.len() == n) else {
            product_columns(&self.matrix, x, 0..n, 0, y, abs);
            return;
        };
        let m = product.m;
        let empty = match self.spare.take() {
            Some(empty) => empty,
            None => SparseColMat::new(
                SymbolicSparseColMat::new_checked(0, 0, vec![0], None, Vec::new()),
                Vec::new(),
            ),
        };
        {
            let mut lent = product.lent.write().unwrap_or_else(|e| e.into_inner());
            lent.matrix = Some(std::mem::replace(&mut self.matrix, empty));
            lent.x.copy_from_slice(x);
            lent.abs = abs.is_some();
        }
        product.pool.start_in(0, PRODUCT);
        {
            let lent = product.lent.read().unwrap_or_else(|e| e.into_inner());
            if let Some(k) = &lent.matrix {
                let mine = abs.as_deref_mut().map(|a| &mut a[..m]);
                product_columns(k, x, 0..m, 0, &mut y[..m], mine);
            }
        }
        let waited = product.pool.wait(0);
        let matrix = product
            .lent
            .write()
            .unwrap_or_else(|e| e.into_inner())
            .matrix
            .take();
        if let Some(matrix) = matrix {
            self.spare = Some(std::mem::replace(&mut self.matrix, matrix));
        }
        if waited.is_err() {
            // The helper's part failed: the whole product here.
            product_columns(&self.matrix, x, 0..n, 0, y, abs);
            return;
        }
        {
            let out = product.out.lock().unwrap_or_else(|e| e.into_inner());
            y[m..].copy_from_slice(&out[0]);
            if let Some(a) = abs.as_deref_mut() {
                a[m..].copy_from_slice(&out[1]);
            }
        }
        product_cross(&self.matrix, x, m, y, abs);
    }

    fn max_diagonal(&self) -> f64 {
        let sym = self.matrix.symbolic();
        let (cp, ri) = (sym.col_ptr(), sym.row_idx());
        let v = self.matrix.val();
        let mut m = 0.0f64;
        for j in 0..sym.ncols() {
            // Diagonal is the last entry of an upper-triangular column (rows sorted).
            let last = cp[j + 1] - 1;
            debug_assert_eq!(ri[last], j);
            m = m.max(v[last].abs());
        }
        m
    }
}

fn inf_norm(a: &[f64]) -> f64 {
    a.iter().fold(0.0f64, |m, x| m.max(x.abs()))
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// [`Ldlt::block_factor`] of these fields (borrowing them only).
fn supernodal_factor<'a>(
    split: &Option<Split>,
    symbolic: &'a Option<SymbolicCholesky<usize>>,
    single: bool,
) -> Option<&'a SymbolicSupernodalCholesky<usize>> {
    match (split, symbolic) {
        (None, Some(symbolic)) if !single => match symbolic.raw() {
            SymbolicCholeskyRaw::Supernodal(s) => Some(s),
            SymbolicCholeskyRaw::Simplicial(_) => None,
        },
        _ => None,
    }
}

/// Right-hand sides one block substitution handles at once ([`Ldlt::solve_block`]); more are
/// taken in blocks of this many.
pub const BLOCK_ROWS: usize = 8;

/// What [`block_solve`] reads: faer's supernodal factor (symbolic structure and values), its
/// fill-reducing permutation (forward, inverse) and the symmetric scaling S, if any.
struct Parts<'a> {
    factor: &'a SymbolicSupernodalCholesky<usize>,
    values: &'a [f64],
    perm: Option<(&'a [usize], &'a [usize])>,
    scale: Option<&'a [f64]>,
}

/// K⁻¹ applied to the B columns of `from` (or of `block` itself; column-major, n rows), the
/// result in `block`, with the held factor of P S K S Pᵀ = L D Lᵀ: gathered into `rows` (n × B
/// row by row, row i holding equation P⁻¹(i)'s B values times S; its rows beyond n are
/// [`block_substitution`]'s work space), [`block_substitution`], scattered back times S.
fn block_solve<const B: usize>(
    parts: &Parts,
    from: Option<&[f64]>,
    block: &mut [f64],
    rows: &mut [f64],
) {
    let n = parts.factor.nrows();
    // In the factor's order, 4 columns: transposed in 4 × 4 tiles (the same products).
    let tiles = B == 4 && parts.perm.is_none();
    if !(tiles && rows_from_columns_x4(from.unwrap_or(block), rows, n, parts.scale)) {
        let source: &[f64] = from.unwrap_or(block);
        let (rows, _) = rows.as_chunks_mut::<B>();
        for (i, row) in rows[..n].iter_mut().enumerate() {
            let e = parts.perm.map_or(i, |(fwd, _)| fwd[i]);
            let s = parts.scale.map_or(1.0, |s| s[e]);
            for (c, v) in row.iter_mut().enumerate() {
                *v = source[c * n + e] * s;
            }
        }
    }
    substitute::<B>(parts, rows, n);
    if tiles && columns_from_rows_x4(rows, block, n, parts.scale) {
        return;
    }
    let (rows, _) = rows.as_chunks_mut::<B>();
    for e in 0..n {
        let row = rows[parts.perm.map_or(e, |(_, inv)| inv[e])];
        let s = parts.scale.map_or(1.0, |s| s[e]);
        for (c, v) in row.iter().enumerate() {
            block[c * n + e] = v * s;
        }
    }
}

/// `rows[4 i + c] = columns[c n + i] · scale[i]` (scale 1 when None) for i < n, c < 4: four
/// columns into rows of four, on a processor with AVX2 in 4 × 4 tiles transposed in
/// registers (the same products, so the same bits as the loop it replaces). False, nothing
/// done, without AVX2.
pub(crate) fn rows_from_columns_x4(
    columns: &[f64],
    rows: &mut [f64],
    n: usize,
    scale: Option<&[f64]>,
) -> bool {
    transpose_x4(columns, rows, n, scale, true)
}

/// The inverse of [`rows_from_columns_x4`]: `columns[c n + i] = rows[4 i + c] · scale[i]`.
pub(crate) fn columns_from_rows_x4(
    rows: &[f64],
    columns: &mut [f64],
    n: usize,
    scale: Option<&[f64]>,
) -> bool {
    transpose_x4(rows, columns, n, scale, false)
}

#[cfg(not(target_arch = "x86_64"))]
fn transpose_x4(_: &[f64], _: &mut [f64], _: usize, _: Option<&[f64]>, _: bool) -> bool {
    false
}

#[cfg(target_arch = "x86_64")]
fn transpose_x4(
    from: &[f64],
    to: &mut [f64],
    n: usize,
    scale: Option<&[f64]>,
    into_rows: bool,
) -> bool {
    let Some(simd) = pulp::x86::V3::try_new() else {
        return false;
    };
    pulp::Simd::vectorize(
        simd,
        TransposeX4 {
            simd,
            from: &from[..4 * n],
            to: &mut to[..4 * n],
            n,
            scale,
            into_rows,
        },
    );
    true
}

/// [`transpose_x4`] as a pulp operation (compiled with AVX2).
#[cfg(target_arch = "x86_64")]
struct TransposeX4<'a> {
    simd: pulp::x86::V3,
    from: &'a [f64],
    to: &'a mut [f64],
    n: usize,
    scale: Option<&'a [f64]>,
    into_rows: bool,
}

#[cfg(target_arch = "x86_64")]
impl pulp::WithSimd for TransposeX4<'_> {
    type Output = ();

    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _simd: S) {
        use core::arch::x86_64::__m256d;
        #[inline(always)]
        fn load(v: &[f64], at: usize) -> __m256d {
            let a: [f64; 4] = v[at..at + 4].try_into().expect("four values");
            pulp::cast(a)
        }
        #[inline(always)]
        fn store(v: &mut [f64], at: usize, x: __m256d) {
            let a: [f64; 4] = pulp::cast(x);
            v[at..at + 4].copy_from_slice(&a);
        }
        let Self {
            simd,
            from,
            to,
            n,
            scale,
            into_rows,
        } = self;
        let avx = simd.avx;
        let tiles = n / 4 * 4;
        for i in (0..tiles).step_by(4) {
            // Four vectors of four values: columns (into rows) or rows (into columns).
            let (mut a, mut b, mut c, mut d) = if into_rows {
                (
                    load(from, i),
                    load(from, n + i),
                    load(from, 2 * n + i),
                    load(from, 3 * n + i),
                )
            } else {
                (
                    load(from, 4 * i),
                    load(from, 4 * i + 4),
                    load(from, 4 * i + 8),
                    load(from, 4 * i + 12),
                )
            };
            if into_rows {
                if let Some(s) = scale {
                    let s = load(s, i);
                    a = avx._mm256_mul_pd(a, s);
                    b = avx._mm256_mul_pd(b, s);
                    c = avx._mm256_mul_pd(c, s);
                    d = avx._mm256_mul_pd(d, s);
                }
            }
            // The 4 × 4 transpose.
            let (t0, t1) = (avx._mm256_unpacklo_pd(a, b), avx._mm256_unpackhi_pd(a, b));
            let (t2, t3) = (avx._mm256_unpacklo_pd(c, d), avx._mm256_unpackhi_pd(c, d));
            a = avx._mm256_permute2f128_pd::<0x20>(t0, t2);
            b = avx._mm256_permute2f128_pd::<0x20>(t1, t3);
            c = avx._mm256_permute2f128_pd::<0x31>(t0, t2);
            d = avx._mm256_permute2f128_pd::<0x31>(t1, t3);
            if into_rows {
                store(to, 4 * i, a);
                store(to, 4 * i + 4, b);
                store(to, 4 * i + 8, c);
                store(to, 4 * i + 12, d);
            } else {
                if let Some(s) = scale {
                    let s = load(s, i);
                    a = avx._mm256_mul_pd(a, s);
                    b = avx._mm256_mul_pd(b, s);
                    c = avx._mm256_mul_pd(c, s);
                    d = avx._mm256_mul_pd(d, s);
                }
                store(to, i, a);
                store(to, n + i, b);
                store(to, 2 * n + i, c);
                store(to, 3 * n + i, d);
            }
        }
        for i in tiles..n {
            let s = scale.map_or(1.0, |s| s[i]);
            for c in 0..4 {
                if into_rows {
                    to[4 * i + c] = from[c * n + i] * s;
                } else {
                    to[c * n + i] = from[4 * i + c] * s;
                }
            }
        }
    }
}

/// [`block_substitution`] on `rows` (n rows of B values, then its work space). Four
/// right-hand sides (the Lanczos block of `modes.rs`) on a processor with AVX2 and FMA go
/// through [`substitution_x4`]; otherwise compiled for the widest instruction set the
/// processor has (pulp: AVX2 where present), chosen at run time.
fn substitute<const B: usize>(parts: &Parts, rows: &mut [f64], n: usize) {
    #[cfg(target_arch = "x86_64")]
    if B == 4 {
        if let Some(simd) = pulp::x86::V3::try_new() {
            let whole = rows.len() / 4 * 4;
            let rows: &mut [pulp::f64x4] = pulp::bytemuck::cast_slice_mut(&mut rows[..whole]);
            let (x, work) = rows.split_at_mut(n);
            pulp::Simd::vectorize(
                simd,
                SubstitutionX4 {
                    simd,
                    factor: parts.factor,
                    values: parts.values,
                    x,
                    work,
                },
            );
            return;
        }
    }
    let (rows, _) = rows.as_chunks_mut::<B>();
    let (rows, work) = rows.split_at_mut(n);
    pulp::Arch::new().dispatch(Substitution::<B> {
        factor: parts.factor,
        values: parts.values,
        x: rows,
        work,
    });
}

/// [`substitution_x4`] as a pulp operation (compiled with AVX2 and FMA).
#[cfg(target_arch = "x86_64")]
struct SubstitutionX4<'a> {
    simd: pulp::x86::V3,
    factor: &'a SymbolicSupernodalCholesky<usize>,
    values: &'a [f64],
    x: &'a mut [pulp::f64x4],
    work: &'a mut [pulp::f64x4],
}

#[cfg(target_arch = "x86_64")]
impl pulp::WithSimd for SubstitutionX4<'_> {
    type Output = ();

    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _simd: S) {
        substitution_x4(self.simd, self.factor, self.values, self.x, self.work)
    }
}

/// [`block_substitution`] for 4 right-hand sides, each row of x one AVX register, with the
/// factor read column by column in the order it is stored and at most four columns at a
/// time (so that the processor's prefetching streams it; a walk along a supernode's rows
/// touches a new cache line per value). Per supernode, its rows (its own columns', then its
/// pattern's) are held contiguously in `work` as v; its columns are taken in groups of up
/// to four. Forward: a group's own triangle, then every row below the group gets the
/// group's four updates at once (one load and one store of the row per four of L's values);
/// then D⁻¹ on the supernode's rows, and the pattern rows' sums added to x. Backward (groups
/// from the last): the four columns' sums over the rows below the group (two partial sums
/// each, independent additions; one load of a row per four of L's values), then the group's
/// own triangle upwards. Multiply-adds are fused, so the result differs from
/// [`block_substitution`]'s in the last bits. The factor's values are asked for before they
/// are read ([`prefetch`], a hint that changes no value): while a group's rows are swept,
/// the next group's columns row for row (forward: the columns after it, or the next
/// supernodes; backward: the four columns before it, or the previous supernodes), and a
/// supernode of up to four columns asks for the values [`AHEAD`] beyond its own in the
/// sweep's direction.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn substitution_x4(
    simd: pulp::x86::V3,
    factor: &SymbolicSupernodalCholesky<usize>,
    values: &[f64],
    x: &mut [pulp::f64x4],
    work: &mut [pulp::f64x4],
) {
    let zero = simd.splat_f64x4(0.0);
    let supernodes = factor.n_supernodes();
    let (begin, end, val_ptr) = (
        factor.supernode_begin(),
        factor.supernode_end(),
        factor.col_ptr_for_val(),
    );
    for s in 0..supernodes {
        let (start, stop) = (begin[s], end[s]);
        let size = stop - start;
        let pattern = factor.supernode(s).pattern();
        let m = size + pattern.len();
        let l = &values[val_ptr[s]..val_ptr[s + 1]];
        if size <= 4 {
            prefetch_ahead(simd, l, 0..l.len(), AHEAD as isize);
        }
        match size {
            1 => {
                forward_narrow::<1>(simd, l, start, pattern, x);
                continue;
            }
            2 => {
                forward_narrow::<2>(simd, l, start, pattern, x);
                continue;
            }
            3 => {
                forward_narrow::<3>(simd, l, start, pattern, x);
                continue;
            }
            4 => {
                forward_narrow::<4>(simd, l, start, pattern, x);
                continue;
            }
            _ => {}
        }
        let v = &mut work[..m];
        v[..size].copy_from_slice(&x[start..stop]);
        v[size..].fill(zero);
        let mut j0 = 0;
        while j0 < size {
            let g = (size - j0).min(4);
            // The next group's columns (or the next supernodes) ahead, row for row.
            let ahead = (g * m) as isize;
            match g {
                4 => forward_group::<4>(simd, l, m, j0, v, ahead),
                3 => forward_group::<3>(simd, l, m, j0, v, ahead),
                2 => forward_group::<2>(simd, l, m, j0, v, ahead),
                _ => forward_group::<1>(simd, l, m, j0, v, ahead),
            }
            j0 += g;
        }
        for (j, (t, y)) in x[start..stop].iter_mut().zip(&v[..size]).enumerate() {
            *t = simd.mul_f64x4(*y, simd.splat_f64x4(l[j * m + j].recip()));
        }
        for (y, &row) in v[size..].iter().zip(pattern) {
            x[row] = simd.add_f64x4(x[row], *y);
        }
    }
    for s in (0..supernodes).rev() {
        let (start, stop) = (begin[s], end[s]);
        let size = stop - start;
        let pattern = factor.supernode(s).pattern();
        let m = size + pattern.len();
        let l = &values[val_ptr[s]..val_ptr[s + 1]];
        if size <= 4 {
            prefetch_ahead(simd, l, 0..l.len(), -(AHEAD as isize));
        }
        match size {
            1 => {
                backward_narrow::<1>(simd, l, start, pattern, x);
                continue;
            }
            2 => {
                backward_narrow::<2>(simd, l, start, pattern, x);
                continue;
            }
            3 => {
                backward_narrow::<3>(simd, l, start, pattern, x);
                continue;
            }
            4 => {
                backward_narrow::<4>(simd, l, start, pattern, x);
                continue;
            }
            _ => {}
        }
        let v = &mut work[..m];
        v[..size].copy_from_slice(&x[start..stop]);
        for (y, &row) in v[size..].iter_mut().zip(pattern) {
            *y = x[row];
        }
        let mut j1 = size;
        while j1 > 0 {
            let g = j1.min(4);
            // The previous group's columns (or the previous supernodes) ahead, row for row.
            let ahead = -((4 * m) as isize);
            match g {
                4 => backward_group::<4>(simd, l, m, j1 - 4, v, ahead),
                3 => backward_group::<3>(simd, l, m, j1 - 3, v, ahead),
                2 => backward_group::<2>(simd, l, m, j1 - 2, v, ahead),
                _ => backward_group::<1>(simd, l, m, j1 - 1, v, ahead),
            }
            j1 -= g;
        }
        x[start..stop].copy_from_slice(&v[..size]);
    }
}

/// How far ahead of its reading [`substitution_x4`] asks for the factor's values of the
/// supernodes of up to 4 columns, in values (2 KiB), along the sweep's direction (512 and
/// 1 024 measured the same; docs/dynamics.md, fifteenth session).
const AHEAD: usize = 256;

/// A hint to the processor to bring the cache line at `p` into its first-level cache
/// (PREFETCHT0, pulp's safe wrapper: no memory is read, no value changes, and an address
/// outside any allocation is allowed). The factor's values are read in runs the hardware
/// prefetcher does not foresee: each group of four columns starts four new streams, the
/// backward sweep takes the groups from the last, and a narrow supernode is a few cache
/// lines. With these hints a 4-column solve of the modes benchmark takes about 15 % less time.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn prefetch(simd: pulp::x86::V3, p: *const f64) {
    simd.sse
        ._mm_prefetch::<{ core::arch::x86_64::_MM_HINT_T0 }>(p.cast());
}

/// [`prefetch`] of every cache line of `l[range]` shifted by `ahead` values.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn prefetch_ahead(simd: pulp::x86::V3, l: &[f64], range: std::ops::Range<usize>, ahead: isize) {
    let base = l.as_ptr().wrapping_offset(ahead);
    for k in range.step_by(8) {
        prefetch(simd, base.wrapping_add(k));
    }
}

/// [`substitution_x4`]'s forward step for a supernode of G ≤ 4 columns (`start..start + G`,
/// its values `l`, column-major (G + |pattern|) × G), on x itself: the supernode's own rows
/// are held in registers, each pattern row gets the G updates summed from zero and then
/// added (the operations of [`forward_group`] on the work space, in the same order, so the
/// same bits), then D⁻¹. No copies to and from the work space: most supernodes are this
/// narrow, and the copies were calls of their own.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn forward_narrow<const G: usize>(
    simd: pulp::x86::V3,
    l: &[f64],
    start: usize,
    pattern: &[usize],
    x: &mut [pulp::f64x4],
) {
    let m = G + pattern.len();
    let mut xs: [pulp::f64x4; G] = std::array::from_fn(|a| x[start + a]);
    for a in 0..G {
        let column = &l[a * m..(a + 1) * m];
        for r in a + 1..G {
            xs[r] = simd.negate_mul_add_f64x4(simd.splat_f64x4(column[r]), xs[a], xs[r]);
        }
    }
    let columns: [&[f64]; G] = std::array::from_fn(|a| &l[a * m + G..(a + 1) * m]);
    let zero = simd.splat_f64x4(0.0);
    for (p, &row) in pattern.iter().enumerate() {
        let mut acc = zero;
        for a in 0..G {
            acc = simd.negate_mul_add_f64x4(simd.splat_f64x4(columns[a][p]), xs[a], acc);
        }
        x[row] = simd.add_f64x4(x[row], acc);
    }
    for a in 0..G {
        x[start + a] = simd.mul_f64x4(xs[a], simd.splat_f64x4(l[a * m + a].recip()));
    }
}

/// [`substitution_x4`]'s backward step for a supernode of G ≤ 4 columns, on x itself: the
/// G column sums over the pattern rows (two partial sums each, as [`backward_group`], the
/// same operations in the same order), then the own triangle upwards.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn backward_narrow<const G: usize>(
    simd: pulp::x86::V3,
    l: &[f64],
    start: usize,
    pattern: &[usize],
    x: &mut [pulp::f64x4],
) {
    let m = G + pattern.len();
    let n = pattern.len();
    let zero = simd.splat_f64x4(0.0);
    let columns: [&[f64]; G] = std::array::from_fn(|a| &l[a * m + G..(a + 1) * m]);
    let (mut even, mut odd) = ([zero; G], [zero; G]);
    let pairs = n / 2;
    for p in 0..pairs {
        let (t0, t1) = (x[pattern[2 * p]], x[pattern[2 * p + 1]]);
        for a in 0..G {
            even[a] = simd.mul_add_f64x4(simd.splat_f64x4(columns[a][2 * p]), t0, even[a]);
            odd[a] = simd.mul_add_f64x4(simd.splat_f64x4(columns[a][2 * p + 1]), t1, odd[a]);
        }
    }
    if n % 2 == 1 {
        let t = x[pattern[n - 1]];
        for a in 0..G {
            even[a] = simd.mul_add_f64x4(simd.splat_f64x4(columns[a][n - 1]), t, even[a]);
        }
    }
    let mut xs: [pulp::f64x4; G] = std::array::from_fn(|a| x[start + a]);
    for a in (0..G).rev() {
        let column = &l[a * m..(a + 1) * m];
        let mut sum = simd.add_f64x4(even[a], odd[a]);
        for r in a + 1..G {
            sum = simd.mul_add_f64x4(simd.splat_f64x4(column[r]), xs[r], sum);
        }
        xs[a] = simd.sub_f64x4(xs[a], sum);
    }
    x[start..start + G].copy_from_slice(&xs);
}

/// [`substitution_x4`]'s forward step for the G columns `j0..j0 + G` of a supernode (column
/// j's values at `l[j m..(j + 1) m]`, rows as in `v`).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn forward_group<const G: usize>(
    simd: pulp::x86::V3,
    l: &[f64],
    m: usize,
    j0: usize,
    v: &mut [pulp::f64x4],
    ahead: isize,
) {
    let j1 = j0 + G;
    for a in 0..G {
        let column = &l[(j0 + a) * m..(j0 + a + 1) * m];
        let xa = v[j0 + a];
        for r in j0 + a + 1..j1 {
            v[r] = simd.negate_mul_add_f64x4(simd.splat_f64x4(column[r]), xa, v[r]);
        }
    }
    let (head, below) = v[..m].split_at_mut(j1);
    let n = below.len();
    let xs: [pulp::f64x4; G] = std::array::from_fn(|a| head[j0 + a]);
    let columns: [&[f64]; G] = std::array::from_fn(|a| &l[(j0 + a) * m + j1..][..n]);
    for (r, t) in below.iter_mut().enumerate() {
        if r % 8 == 0 {
            for column in columns {
                prefetch(simd, column.as_ptr().wrapping_add(r).wrapping_offset(ahead));
            }
        }
        let mut acc = *t;
        for a in 0..G {
            acc = simd.negate_mul_add_f64x4(simd.splat_f64x4(columns[a][r]), xs[a], acc);
        }
        *t = acc;
    }
}

/// [`substitution_x4`]'s backward step for the G columns `j0..j0 + G` of a supernode (the
/// rows below them already final in `v`).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn backward_group<const G: usize>(
    simd: pulp::x86::V3,
    l: &[f64],
    m: usize,
    j0: usize,
    v: &mut [pulp::f64x4],
    ahead: isize,
) {
    let j1 = j0 + G;
    let zero = simd.splat_f64x4(0.0);
    let (head, below) = v[..m].split_at_mut(j1);
    let n = below.len();
    let columns: [&[f64]; G] = std::array::from_fn(|a| &l[(j0 + a) * m + j1..][..n]);
    let (mut even, mut odd) = ([zero; G], [zero; G]);
    let pairs = n / 2;
    for p in 0..pairs {
        if p % 4 == 0 {
            for column in columns {
                prefetch(
                    simd,
                    column.as_ptr().wrapping_add(2 * p).wrapping_offset(ahead),
                );
            }
        }
        let (t0, t1) = (below[2 * p], below[2 * p + 1]);
        for a in 0..G {
            even[a] = simd.mul_add_f64x4(simd.splat_f64x4(columns[a][2 * p]), t0, even[a]);
            odd[a] = simd.mul_add_f64x4(simd.splat_f64x4(columns[a][2 * p + 1]), t1, odd[a]);
        }
    }
    if n % 2 == 1 {
        let t = below[n - 1];
        for a in 0..G {
            even[a] = simd.mul_add_f64x4(simd.splat_f64x4(columns[a][n - 1]), t, even[a]);
        }
    }
    for a in (0..G).rev() {
        let column = &l[(j0 + a) * m..(j0 + a + 1) * m];
        let mut sum = simd.add_f64x4(even[a], odd[a]);
        for r in j0 + a + 1..j1 {
            sum = simd.mul_add_f64x4(simd.splat_f64x4(column[r]), head[r], sum);
        }
        head[j0 + a] = simd.sub_f64x4(head[j0 + a], sum);
    }
}

/// x ← L⁻ᵀ D⁻¹ L⁻¹ x for B right-hand sides held row by row (`x[i]`: unknown i's B values),
/// with faer's supernodal LDLT storage: supernode s covers the columns `begin..end`, its
/// values a column-major (size + |pattern|) × size block, the unit lower triangle of the
/// diagonal block (its diagonal holding D) above the rows of its pattern (all beyond `end`).
/// Forward, a supernode's columns first update the diagonal block's rows, then its pattern
/// rows eight at a time (the block's values read column by column, the rows' sums kept in
/// registers); D; backward, each column's sum over the pattern rows, then the diagonal block
/// upwards. Each sweep reads the factor once for all B columns, and every update is one
/// B-wide operation on adjacent values.
/// [`block_substitution`] as a pulp operation: compiled for each instruction set pulp
/// dispatches to.
struct Substitution<'a, const B: usize> {
    factor: &'a SymbolicSupernodalCholesky<usize>,
    values: &'a [f64],
    x: &'a mut [[f64; B]],
    work: &'a mut [[f64; B]],
}

impl<const B: usize> pulp::WithSimd for Substitution<'_, B> {
    type Output = ();

    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _simd: S) {
        block_substitution::<B>(self.factor, self.values, self.x, self.work)
    }
}

#[inline(always)]
fn block_substitution<const B: usize>(
    factor: &SymbolicSupernodalCholesky<usize>,
    values: &[f64],
    x: &mut [[f64; B]],
    work: &mut [[f64; B]],
) {
    const TILE: usize = 8;
    let supernodes = factor.n_supernodes();
    let (begin, end, val_ptr) = (
        factor.supernode_begin(),
        factor.supernode_end(),
        factor.col_ptr_for_val(),
    );
    for s in 0..supernodes {
        let (start, stop) = (begin[s], end[s]);
        let size = stop - start;
        let pattern = factor.supernode(s).pattern();
        let m = size + pattern.len();
        let l = &values[val_ptr[s]..val_ptr[s + 1]];
        let (head, tail) = x.split_at_mut(stop);
        let top = &mut head[start..];
        for j in 0..size {
            let xj = top[j];
            let column = &l[j * m..j * m + size];
            for r in j + 1..size {
                let a = column[r];
                for c in 0..B {
                    top[r][c] += -a * xj[c];
                }
            }
        }
        let mut p0 = 0;
        while p0 + TILE <= pattern.len() {
            let mut acc = [[0.0; B]; TILE];
            for (j, xj) in top.iter().enumerate() {
                let a = &l[j * m + size + p0..j * m + size + p0 + TILE];
                for r in 0..TILE {
                    for c in 0..B {
                        acc[r][c] += a[r] * xj[c];
                    }
                }
            }
            for r in 0..TILE {
                let t = &mut tail[pattern[p0 + r] - stop];
                for c in 0..B {
                    t[c] -= acc[r][c];
                }
            }
            p0 += TILE;
        }
        for (p, &row) in pattern.iter().enumerate().skip(p0) {
            let mut acc = [0.0; B];
            for (j, xj) in top.iter().enumerate() {
                let a = l[j * m + size + p];
                for c in 0..B {
                    acc[c] += a * xj[c];
                }
            }
            let t = &mut tail[row - stop];
            for c in 0..B {
                t[c] -= acc[c];
            }
        }
    }
    for s in 0..supernodes {
        let (start, stop) = (begin[s], end[s]);
        let m = stop - start + factor.supernode(s).pattern().len();
        let l = &values[val_ptr[s]..val_ptr[s + 1]];
        for (j, xj) in x[start..stop].iter_mut().enumerate() {
            let d = l[j * m + j].recip();
            for v in xj.iter_mut() {
                *v *= d;
            }
        }
    }
    for s in (0..supernodes).rev() {
        let (start, stop) = (begin[s], end[s]);
        let size = stop - start;
        let pattern = factor.supernode(s).pattern();
        let m = size + pattern.len();
        let l = &values[val_ptr[s]..val_ptr[s + 1]];
        let (head, tail) = x.split_at_mut(stop);
        let top = &mut head[start..];
        // The pattern rows' values gathered once, read contiguously by every column.
        let gathered = &mut work[..pattern.len()];
        for (g, &row) in gathered.iter_mut().zip(pattern) {
            *g = tail[row - stop];
        }
        let gathered = &*gathered;
        for (j, xj) in top.iter_mut().enumerate() {
            let column = &l[j * m + size..(j + 1) * m];
            let (mut even, mut odd) = ([0.0; B], [0.0; B]);
            let (pairs, last) = gathered.as_chunks::<2>();
            for (t, a) in pairs.iter().zip(column.chunks_exact(2)) {
                for c in 0..B {
                    even[c] += a[0] * t[0][c];
                    odd[c] += a[1] * t[1][c];
                }
            }
            if let Some(t) = last.first() {
                let a = column[pattern.len() - 1];
                for c in 0..B {
                    even[c] += a * t[c];
                }
            }
            for c in 0..B {
                xj[c] -= even[c] + odd[c];
            }
        }
        for j in (0..size).rev() {
            let column = &l[j * m..j * m + size];
            let mut acc = [0.0; B];
            for r in j + 1..size {
                let a = column[r];
                for c in 0..B {
                    acc[c] += a * top[r][c];
                }
            }
            for c in 0..B {
                top[j][c] -= acc[c];
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::solver::threads::Pool;

    use crate::solver::split::tests::grid;

    fn diagonal_scaled(ldlt: &mut Ldlt, cp: &[usize], factor: impl Fn(usize) -> f64) {
        let values = ldlt.values_mut();
        for j in 0..cp.len() - 1 {
            values[cp[j + 1] - 1] *= factor(j);
        }
    }

    /// Preconditioned CG on a perturbed matrix, preconditioned by the factor of the original,
    /// against the direct solve of the perturbed matrix (its own factorization): the same x
    /// to the reduction asked, in a few solves; the counters count them.
    #[test]
    fn pcg_with_an_earlier_factor_matches_the_direct_solve() {
        let (n, cp, ri, v) = grid(40, 30);
        let mut ldlt = Ldlt::try_new(n, cp.clone(), ri).unwrap();
        ldlt.values_mut().copy_from_slice(&v);
        let mut b = vec![0.0; n];
        assert_eq!(ldlt.pcg(&b.clone(), &mut b, 1e-8, 8, &mut Vec::new()), None);
        ldlt.factor().unwrap();
        assert!(ldlt.has_factor());
        // The tangent moves on: diagonal up to 3 % larger, the factor stays the old one.
        diagonal_scaled(&mut ldlt, &cp, |j| {
            1.0 + 0.03 * ((j * 13 % 17) as f64 / 17.0)
        });
        let rhs: Vec<f64> = (0..n)
            .map(|i| ((i * 37) % 101) as f64 / 101.0 - 0.5)
            .collect();
        let mut x = vec![0.0; n];
        let mut work = Vec::new();
        let solves = ldlt
            .pcg(&rhs, &mut x, 1e-10, 20, &mut work)
            .expect("converges");
        // M⁻¹K has its eigenvalues in [1, 1 + 0.03 · 4.2 / 0.1] (the perturbation against
        // K's smallest eigenvalue, above 0.1): κ ≤ 2.26, CG's bound 2 ((√κ − 1)/(√κ + 1))^k
        // reaches 1e-10 by k = 15 (measured 9).
        assert!(solves <= 15, "{solves} solves");
        assert_eq!(ldlt.counts.pcg_solves, solves);
        assert_eq!(ldlt.counts.factorizations, 1);
        // Too few solves allowed: None, and the caller factors.
        let mut y = vec![0.0; n];
        assert_eq!(ldlt.pcg(&rhs, &mut y, 1e-10, 2, &mut work), None);
        let mut direct = rhs.clone();
        ldlt.factor_solve(&mut direct).unwrap();
        let scale = direct.iter().fold(0.0f64, |a, x| a.max(x.abs()));
        let err = x
            .iter()
            .zip(&direct)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        // ‖x − x*‖ ≤ cond(K) · 1e-10 ‖x*‖; the shifted Laplacian's condition number is below
        // 8.4 / 0.1 = 84.
        assert!(err <= 84.0 * 1e-10 * scale, "{err:e} of {scale:e}");
    }

    /// The block substitution against faer's own solve (`solve_columns`) on a 2-D grid's
    /// matrix, 1 to 19 pseudo-random right-hand sides (every block width, and more than
    /// [`BLOCK_ROWS`]), with and without the per-group scaling: the same solution to 1e-12 of
    /// its largest entry (both do the same operations in another order: measured 6.2e-16).
    #[test]
    fn block_substitution_matches_faers_solve() {
        let (n, cp, ri, v) = grid(37, 23);
        for groups in [false, true] {
            let mut ldlt = Ldlt::try_new(n, cp.clone(), ri.clone()).unwrap();
            ldlt.values_mut().copy_from_slice(&v);
            if groups {
                // Three equations per group, the matrix scaled symmetrically by groups so
                // that its diagonal spans 1e-6 .. 1e6 (the scaling then undoes that).
                ldlt.set_groups((0..n as u32).map(|e| e / 3).collect())
                    .unwrap();
                let f = |e: usize| 10f64.powi(((e / 3) % 7) as i32 - 3);
                let values = ldlt.values_mut();
                for j in 0..n {
                    for k in cp[j]..cp[j + 1] {
                        values[k] *= f(ri[k]) * f(j);
                    }
                }
            }
            ldlt.factor().unwrap();
            assert!(ldlt.scale.is_empty() != groups);
            let mut seed = 0x2545_F491_4F6C_DD1Du64;
            let mut worst = 0.0f64;
            for columns in 1..20 {
                let rhs: Vec<f64> = (0..n * columns)
                    .map(|_| {
                        seed ^= seed << 13;
                        seed ^= seed >> 7;
                        seed ^= seed << 17;
                        (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
                    })
                    .collect();
                let (mut ours, mut faers) = (rhs.clone(), rhs);
                ldlt.solve_block(&mut ours, columns).unwrap();
                ldlt.solve_columns(&mut faers, columns).unwrap();
                let largest = faers.iter().fold(0.0f64, |m, x| m.max(x.abs()));
                let err = ours
                    .iter()
                    .zip(&faers)
                    .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
                assert!(
                    largest > 0.0 && err <= 1e-12 * largest,
                    "{columns}: {err:e} of {largest:e}"
                );
                worst = worst.max(err / largest);
            }
            eprintln!("scaled {groups}: {worst:e} of the largest entry");
        }
    }

    /// The block solve on vectors in the factor's order (`solve_block_ordered`, the modal
    /// analysis's Lanczos vectors) is the block solve of the permuted vectors, bit for bit,
    /// with and without the scaling, from another buffer and in place.
    #[test]
    fn ordered_block_solve_is_the_permuted_block_solve() {
        let (n, cp, ri, v) = grid(31, 19);
        for groups in [false, true] {
            let mut ldlt = Ldlt::try_new(n, cp.clone(), ri.clone()).unwrap();
            ldlt.values_mut().copy_from_slice(&v);
            if groups {
                ldlt.set_groups((0..n as u32).map(|e| e / 3).collect())
                    .unwrap();
                let f = |e: usize| 10f64.powi(((e / 3) % 7) as i32 - 3);
                let values = ldlt.values_mut();
                for j in 0..n {
                    for k in cp[j]..cp[j + 1] {
                        values[k] *= f(ri[k]) * f(j);
                    }
                }
            }
            ldlt.factor().unwrap();
            let (fwd, inv) = {
                let (fwd, inv) = ldlt.block_order().expect("a fill-reducing order");
                (fwd.to_vec(), inv.to_vec())
            };
            assert!(fwd.iter().enumerate().any(|(i, &e)| i != e));
            let mut seed = 0x9E37_79B9_7F4A_7C15u64;
            for columns in [1, 3, 4, 5, 8, 11] {
                let rhs: Vec<f64> = (0..n * columns)
                    .map(|_| {
                        seed ^= seed << 13;
                        seed ^= seed >> 7;
                        seed ^= seed << 17;
                        (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
                    })
                    .collect();
                let mut expected = rhs.clone();
                ldlt.solve_block(&mut expected, columns).unwrap();
                let ordered: Vec<f64> = (0..n * columns)
                    .map(|k| rhs[k / n * n + fwd[k % n]])
                    .collect();
                let mut from = vec![f64::NAN; n * columns];
                ldlt.solve_block_ordered(&mut from, Some(&ordered), columns)
                    .unwrap();
                let mut in_place = ordered.clone();
                ldlt.solve_block_ordered(&mut in_place, None, columns)
                    .unwrap();
                for c in 0..columns {
                    for e in 0..n {
                        let want = expected[c * n + e].to_bits();
                        assert_eq!(from[c * n + inv[e]].to_bits(), want, "{columns} {e}");
                        assert_eq!(in_place[c * n + inv[e]].to_bits(), want, "{columns} {e}");
                    }
                }
            }
        }
    }

    /// A tangent that is no longer positive definite stops CG (None), never a wrong x.
    #[test]
    fn pcg_refuses_an_indefinite_tangent() {
        let (n, cp, ri, v) = grid(20, 20);
        let mut ldlt = Ldlt::try_new(n, cp.clone(), ri).unwrap();
        ldlt.values_mut().copy_from_slice(&v);
        ldlt.factor().unwrap();
        // Every diagonal entry negated: K is negative definite.
        diagonal_scaled(&mut ldlt, &cp, |_| -1.0);
        let rhs = vec![1.0; n];
        let mut x = vec![0.0; n];
        assert_eq!(ldlt.pcg(&rhs, &mut x, 1e-8, 8, &mut Vec::new()), None);
    }

    /// The Hencky disc's tangent (`modelDescription/HenckyDisc`, `rings` rings, follower
    /// pressure 40 Pa) at the paraboloid w = w0 (1 − r²/a²), w0 = 0.065404 a (the closed
    /// form's centre deflection, docs/mechanics.md §4a): the film stretched everywhere, as on
    /// the way to the answer. (n, upper CSC, values, each node's equations one group.)
    fn disc_tangent(rings: usize) -> (usize, Vec<usize>, Vec<usize>, Vec<f64>, Vec<u32>) {
        use crate::solver::assemble::{assemble, Pattern, NONE};
        let path = format!(
            "{}/modelDescription/HenckyDisc/scene.json",
            env!("CARGO_MANIFEST_DIR")
        );
        let mut value: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
        value["geometry"]["generators"][0]["rings"] = rings.into();
        let scene = crate::scene::Scene::from_json(&value.to_string()).unwrap();
        let model = crate::model::Model::try_build(&scene).unwrap();
        let pattern = Pattern::try_new(&model).unwrap();
        let a = 0.5;
        let mut u = vec![0.0; model.dof_count()];
        for (i, x) in model.reference.iter().enumerate() {
            let r2 = (x[0] * x[0] + x[1] * x[1]) / (a * a);
            u[3 * i + 2] = 0.065404 * a * (1.0 - r2).max(0.0);
        }
        let mut r = vec![0.0; model.dof_count()];
        let mut k = vec![0.0; pattern.row_idx.len()];
        assemble(&model, &pattern, &u, &[40.0], &mut r, Some(&mut k));
        let mut groups = vec![0u32; pattern.n];
        for (d, &e) in pattern.eq.iter().enumerate() {
            if e != NONE {
                groups[e] = (d / 3) as u32;
            }
        }
        (
            pattern.n,
            pattern.col_ptr.clone(),
            pattern.row_idx.clone(),
            k,
            groups,
        )
    }

    /// The solution of K x = b in `precision`, whole (no pool) or split in two halves (a pool
    /// of 2), with the Ldlt's counts after it.
    fn solved(
        tangent: &(usize, Vec<usize>, Vec<usize>, Vec<f64>, Vec<u32>),
        b: &[f64],
        precision: Precision,
        split: bool,
    ) -> (Vec<f64>, Counts, Ldlt) {
        let (n, cp, ri, v, groups) = tangent;
        let pool = split.then(|| Arc::new(Pool::try_new(2).unwrap()));
        let mut ldlt = Ldlt::try_with_pool(*n, cp.clone(), ri.clone(), pool).unwrap();
        assert_eq!(ldlt.split_sizes().is_some(), split);
        ldlt.set_groups(groups.clone()).unwrap();
        ldlt.set_precision(precision).unwrap();
        ldlt.values_mut().copy_from_slice(v);
        let mut x = b.to_vec();
        ldlt.factor_solve(&mut x).unwrap();
        (x, ldlt.counts, ldlt)
    }

    /// The split's halves gather and scale their own values (`Ldlt::factor_split`,
    /// `Split::factor_shared`): the solve equals, bit for bit, S (S K S)⁻¹ S b with S K S
    /// scaled here by hand (S_ee = 2^-round(log2 √d), d the largest diagonal of e's node,
    /// module docs) and factored by the same split unscaled. S holds powers of two, so the
    /// scaled values are exact either way and only a value scaled by the wrong equation's
    /// S (or not at all) changes the answer. The Hencky disc at 48 rings (20 737 equations),
    /// its nodes' stiffness varied by powers of two.
    #[test]
    fn the_halves_own_scaling_is_the_scaled_tangents_factor() {
        let mut tangent = disc_tangent(48);
        // The disc's nodes are about equally stiff (S nearly the same everywhere): D K D with
        // D a power of two from 1/4 to 4 by node makes neighbours' S differ.
        {
            let (n, cp, ri, v, groups) = &mut tangent;
            let d = |e: usize| (((groups[e] as usize * 7) % 5) as f64 - 2.0).exp2();
            for j in 0..*n {
                for p in cp[j]..cp[j + 1] {
                    v[p] *= d(ri[p]) * d(j);
                }
            }
        }
        let (n, cp, ri, v, groups) = &tangent;
        let b: Vec<f64> = (0..*n)
            .map(|i| ((i * 37) % 101) as f64 / 101.0 - 0.5)
            .collect();
        let (x, _, ldlt) = solved(&tangent, &b, Precision::Double, true);
        assert!(ldlt.split_sizes().is_some());
        // S by hand.
        let count = groups.iter().map(|&g| g as usize + 1).max().unwrap();
        let mut largest = vec![0.0f64; count];
        for (j, &g) in groups.iter().enumerate() {
            largest[g as usize] = largest[g as usize].max(v[cp[j + 1] - 1].abs());
        }
        let s: Vec<f64> = groups
            .iter()
            .map(|&g| (-(0.5 * largest[g as usize].log2()).round()).exp2())
            .collect();
        assert!(largest.iter().all(|&d| d > 0.0));
        let mut sks = v.clone();
        for j in 0..*n {
            for p in cp[j]..cp[j + 1] {
                sks[p] *= s[ri[p]] * s[j];
            }
        }
        let pool = Arc::new(Pool::try_new(2).unwrap());
        let mut plain = Ldlt::try_with_pool(*n, cp.clone(), ri.clone(), Some(pool)).unwrap();
        plain.set_precision(Precision::Double).unwrap();
        plain.values_mut().copy_from_slice(&sks);
        let mut y: Vec<f64> = b.iter().zip(&s).map(|(b, s)| b * s).collect();
        plain.factor_solve(&mut y).unwrap();
        let want: Vec<f64> = y.iter().zip(&s).map(|(y, s)| y * s).collect();
        assert_eq!(x, want);
        // The values are K again, not S K S, after the factorization.
        assert_eq!(ldlt.values(), &v[..]);
    }

    /// K x on two threads ([`Product`]: the caller's columns, the helper's, then the rows the
    /// helper left out) is the one-thread product bit for bit, with and without |K| |x|, and K
    /// is back in place after it; so is the same three-part sum at other columns than the
    /// product's balanced one. The Hencky disc at 167 rings (the 1M disc's first coarser mesh,
    /// 2.7 million stored entries: enough for the product on two threads). The one-thread
    /// product itself is checked against K x summed row by row (TOLERANCE: 1e-12 of |K| |x|,
    /// round-off).
    #[test]
    fn the_two_threads_product_is_the_one_threads() {
        let (n, cp, ri, v, _) = disc_tangent(167);
        let pool = Arc::new(Pool::try_new(2).unwrap());
        let mut ldlt = Ldlt::try_with_pool(n, cp.clone(), ri.clone(), Some(pool)).unwrap();
        let m = ldlt.product.as_ref().expect("a product on two threads").m;
        assert!(m > n / 4 && m < 3 * n / 4, "m {m} of {n}");
        ldlt.values_mut().copy_from_slice(&v);
        let x: Vec<f64> = (0..n)
            .map(|i| ((i * 37) % 101) as f64 / 101.0 - 0.5)
            .collect();
        let (mut y1, mut a1) = (vec![0.0; n], vec![0.0; n]);
        product_columns(&ldlt.matrix, &x, 0..n, 0, &mut y1, Some(&mut a1));
        let (mut y2, mut a2) = (vec![1.0; n], vec![1.0; n]);
        ldlt.product(&x, &mut y2, Some(&mut a2));
        assert_eq!(y1, y2);
        assert_eq!(a1, a2);
        let mut y3 = vec![1.0; n];
        ldlt.multiply(&x, &mut y3);
        assert_eq!(y1, y3);
        assert_eq!(ldlt.values(), &v[..], "K is back");
        for m in [1, n / 3, n - 1] {
            let (mut y, mut a) = (vec![0.0; n], vec![0.0; n]);
            let (mut yb, mut ab) = (vec![0.0; n - m], vec![0.0; n - m]);
            product_columns(&ldlt.matrix, &x, 0..m, 0, &mut y[..m], Some(&mut a[..m]));
            product_columns(&ldlt.matrix, &x, m..n, m, &mut yb, Some(&mut ab));
            y[m..].copy_from_slice(&yb);
            a[m..].copy_from_slice(&ab);
            product_cross(&ldlt.matrix, &x, m, &mut y, Some(&mut a));
            assert_eq!((&y1, &a1), (&y, &a), "at column {m}");
        }
        // K x row by row (the upper triangle and its transpose).
        let mut rows = vec![0.0; n];
        for j in 0..n {
            for p in cp[j]..cp[j + 1] {
                let i = ri[p];
                rows[i] += v[p] * x[j];
                if i != j {
                    rows[j] += v[p] * x[i];
                }
            }
        }
        for i in 0..n {
            assert!((rows[i] - y1[i]).abs() <= 1e-12 * a1[i], "row {i}");
        }
    }

    /// The mixed-precision solve on a real tangent (the Hencky disc, 48 rings: 20 737
    /// equations, enough for the two-domain split), whole and split: the f32 factor with
    /// refinement gives the f64 factor's answer. Reference for "the same": two f64 solves in
    /// different elimination orders (whole, split) differ by their round-off, δ (measured
    /// 7.8e-15 of the largest entry); each refined solve is within 4 δ of the whole f64 solve
    /// (measured 0.40 δ whole, 0.35 δ split), and its componentwise backward error, computed
    /// here, is within [`BACKWARD_ERROR`] (8 ulps: measured 2.4e-16 and 2.5e-16; the f64
    /// solves' 5.2e-16 and 5.6e-16). The f32 factor without refinement (one substitution) is
    /// 1e5 δ or more away (measured 3.6e-6 and 1.7e-6 of the largest entry, 2e8 δ), so the
    /// refinement is what the test checks. The refinement takes 2 or 3 steps (measured 2 and
    /// 2; the 300k and 1M discs' solves take 3, docs/performance.md).
    #[test]
    fn single_precision_with_refinement_gives_the_double_precision_solve() {
        let tangent = disc_tangent(48);
        let n = tangent.0;
        let b: Vec<f64> = (0..n)
            .map(|i| ((i * 37) % 101) as f64 / 101.0 - 0.5)
            .collect();
        let omega = |x: &[f64]| {
            let (_, cp, ri, v, _) = &tangent;
            let (mut kx, mut abs) = (vec![0.0; n], vec![0.0; n]);
            for j in 0..n {
                for k in cp[j]..cp[j + 1] {
                    let i = ri[k];
                    kx[i] += v[k] * x[j];
                    abs[i] += (v[k] * x[j]).abs();
                    if i != j {
                        kx[j] += v[k] * x[i];
                        abs[j] += (v[k] * x[i]).abs();
                    }
                }
            }
            (0..n)
                .map(|i| (b[i] - kx[i]).abs() / (abs[i] + b[i].abs()))
                .fold(0.0f64, f64::max)
        };
        let diff = |x: &[f64], y: &[f64]| {
            x.iter()
                .zip(y)
                .map(|(a, b)| (a - b).abs())
                .fold(0.0f64, f64::max)
        };
        let (whole, counts, _) = solved(&tangent, &b, Precision::Double, false);
        assert_eq!((counts.substitutions, counts.refinements), (1, 0));
        let (split, _, _) = solved(&tangent, &b, Precision::Double, true);
        let largest = whole.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        let delta = diff(&whole, &split);
        assert!(delta > 0.0 && delta <= 1e-10 * largest, "{delta:e}");
        eprintln!(
            "f64: whole against split {:.2e} of the largest entry, backward errors {:.1e} {:.1e}",
            delta / largest,
            omega(&whole),
            omega(&split)
        );
        for with_split in [false, true] {
            let (x, counts, mut ldlt) = solved(&tangent, &b, Precision::Single, with_split);
            assert!(ldlt.is_single());
            assert_eq!(counts.fallbacks, 0);
            assert!(
                (2..=3).contains(&counts.refinements),
                "{} steps",
                counts.refinements
            );
            assert_eq!(counts.substitutions, 1 + counts.refinements);
            let (d, w) = (diff(&x, &whole), omega(&x));
            eprintln!(
                "f32, split {with_split}: {} steps, {:.2} δ from the f64 solve, backward error {w:.1e}",
                counts.refinements,
                d / delta
            );
            assert!(d <= 4.0 * delta, "{:e} δ", d / delta);
            assert!(w <= BACKWARD_ERROR, "{w:e}");
            // One substitution with the f32 factor alone: far from it.
            let mut raw = b.clone();
            ldlt.substitute(&mut raw).unwrap();
            let d = diff(&raw, &whole);
            eprintln!(
                "f32 without refinement: {:.1e} of the largest entry",
                d / largest
            );
            assert!(d >= 1e5 * delta, "{:e} δ", d / delta);
            assert!(ldlt.take_notes().is_empty());
        }
    }

    /// A tangent built to be too ill-conditioned for a single-precision factor: the Laplacian
    /// of a 150 × 150 grid with free edges (singular: constants) shifted by 1e-9, so that its
    /// condition number is 8 / 1e-9 = 8e9, beyond f32's 1/u = 1.7e7 (refinement contracts only
    /// when κ u < 1: Higham, "Accuracy and Stability of Numerical Algorithms", 2nd ed., §12.1).
    /// The refinement does not contract, the solve falls back to a double-precision
    /// factorization with a log line saying so, the answer is the f64 factor's (to 1e-12 of
    /// its largest entry: the same factorization), and the Ldlt stays in double precision.
    #[test]
    fn an_ill_conditioned_tangent_falls_back_to_double_precision() {
        let (nx, ny) = (150, 150);
        let n = nx * ny;
        let (mut cp, mut ri, mut v) = (vec![0], vec![], vec![]);
        for j in 0..n {
            let (x, y) = (j % nx, j / nx);
            let neighbours = [x > 0, x + 1 < nx, y > 0, y + 1 < ny]
                .iter()
                .filter(|&&b| b)
                .count();
            if y > 0 {
                ri.push(j - nx);
                v.push(-1.0);
            }
            if x > 0 {
                ri.push(j - 1);
                v.push(-1.0);
            }
            ri.push(j);
            v.push(neighbours as f64 + 1e-9);
            cp.push(ri.len());
        }
        let b: Vec<f64> = (0..n)
            .map(|i| ((i * 37) % 101) as f64 / 101.0 - 0.5)
            .collect();
        let solve = |precision: Precision, split: bool| {
            let pool = split.then(|| Arc::new(Pool::try_new(2).unwrap()));
            let mut ldlt = Ldlt::try_with_pool(n, cp.clone(), ri.clone(), pool).unwrap();
            assert_eq!(ldlt.split_sizes().is_some(), split);
            ldlt.set_precision(precision).unwrap();
            ldlt.values_mut().copy_from_slice(&v);
            let mut x = b.clone();
            ldlt.factor_solve(&mut x).unwrap();
            (x, ldlt)
        };
        for split in [false, true] {
            let (double, _) = solve(Precision::Double, split);
            let (x, mut ldlt) = solve(Precision::Single, split);
            assert_eq!(ldlt.counts.fallbacks, 1);
            assert_eq!(ldlt.counts.factorizations, 2);
            assert!(!ldlt.is_single());
            let notes = ldlt.take_notes();
            eprintln!("split {split}: {notes:?}");
            assert_eq!(notes.len(), 1);
            assert!(
                notes[0].starts_with(
                    "linear solve: the refinement of the single-precision factor's solve"
                ) && notes[0].ends_with(
                    "the tangent (22500 equations) is factored in double precision from here on"
                ),
                "{}",
                notes[0]
            );
            let largest = double.iter().fold(0.0f64, |m, x| m.max(x.abs()));
            let d = x
                .iter()
                .zip(&double)
                .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
            assert!(d <= 1e-12 * largest, "{d:e} of {largest:e}");
            // The next factorization is double precision: no second fallback.
            let mut y = b.clone();
            ldlt.factor_solve(&mut y).unwrap();
            assert_eq!(
                (ldlt.counts.fallbacks, ldlt.counts.refinements),
                (1, ldlt.counts.refinements)
            );
            assert!(ldlt.take_notes().is_empty());
        }
    }
}
