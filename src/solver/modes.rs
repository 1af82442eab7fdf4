//! Natural frequencies and mode shapes about a converged equilibrium: the lowest eigenpairs
//! of K φ = ω² M φ by shift-invert Lanczos.
//!
//! ```text
//! K        the true tangent at the equilibrium (as the sensitivities take it): material and
//!          geometric stiffness of the converged stresses, wrinkle and slack states frozen as
//!          converged, no artificial prestress, no damping, the wrinkled triangles'
//!          tangent-only regularisation taken out again; the follower pressure's symmetric
//!          part (its skew part is left out: the problem is kept symmetric); held DOFs removed
//! M        the mass matrix (`mass.rs`), consistent or lumped as the scene's `dynamics` says
//! shift    σ = −SHIFT · max_i(K_ii / M_ii) below the spectrum of a stable equilibrium, so
//!          that K − σM is positive definite (a mechanism, ω = 0, still factors); one
//!          factorization of K − σM with the solver's LDLT (`linear.rs`)
//! operator A = (K − σM)⁻¹ M, self-adjoint in the M inner product; its largest eigenvalues
//!          θ = 1/(ω² − σ) are the lowest frequencies
//! Lanczos  block Lanczos, BLOCK vectors at a time: Q₁ = A R M-orthonormalised (R fixed
//!          pseudo-random vectors, so runs repeat bit for bit), then W = A Q_j (one solve
//!          with BLOCK right-hand sides, `Ldlt::solve_block`: held row by row, one pass over
//!          the factor per sweep for all of them), the block
//!          M-orthogonalised twice against the last two blocks (classical Gram-Schmidt, each
//!          pass two dense products, so a pass reads those blocks once, not once per
//!          vector), against the earlier vectors only when an estimate of the loss of
//!          orthogonality passes √ε (partial reorthogonalisation, `Partial`: Simon 1984,
//!          Grimes, Lewis & Simon 1994; the basis stays semi-orthogonal, which keeps the
//!          Ritz values to round-off and admits no spurious copies), then within itself,
//!          W = Q_{j+1} B_j (Cholesky QR twice: the Gram matrix (M W)ᵀ W and W B⁻¹ as matrix
//!          products; column by column when the block is nearly dependent). Q is held as an
//!          n × k matrix, M Q for the last two blocks only. The recurrence's coefficients
//!          form H = Qᵀ M A Q (block tridiagonal); a Ritz pair (θ, Q s) of H
//!          has the residual |B_j s_j| (s_j: its last block of components) in the M norm and
//!          is converged when that is at most TOLERANCE θ_max
//! order    every Lanczos vector is held in the factor's fill-reducing order
//!          (`Ldlt::block_order`): the solves take and return them without a permutation
//!          (`Ldlt::solve_block_ordered`: no gather and scatter at random through it), M is
//!          compressed as P M Pᵀ, the start vectors are permuted once and the Ritz vectors
//!          back once (the same Krylov space, its sums in another order: the same
//!          frequencies to round-off)
//! multiple a single start vector sees one vector of each eigenspace; a block of BLOCK sees up
//!          to BLOCK (the square membrane's f_12 = f_21, a straight cable's frequencies in two
//!          planes, a disc's pairs): a frequency repeated more often than BLOCK times may be
//!          reported fewer times
//! M x      over M's nonzero entries only (the tangent's pattern also holds M's zeros: a
//!          membrane's M couples x with x only), one pass over M per block, the block held
//!          row by row meanwhile (a block of BLOCK columns)
//! A Ritz vector φ is M-normalised (φᵀ M φ = 1); f = ω / 2π, reported negative (−√|ω²|/2π)
//! for a negative ω² (an unstable equilibrium: the tangent is not positive definite).
//!
//! # References
//! Ericsson & Ruhe 1980 (the spectral transformation Lanczos method); Parlett 1998, *The
//! Symmetric Eigenvalue Problem*, ch. 13 (Lanczos, reorthogonalisation); Golub & Van Loan
//! 2013, §10.1; Simon 1984, "The Lanczos algorithm with partial reorthogonalization", Math.
//! Comp. 42, 115-142; Grimes, Lewis & Simon 1994, "A shifted block Lanczos algorithm for
//! solving sparse symmetric generalized eigenproblems", SIAM J. Matrix Anal. Appl. 15(1),
//! 228-272.

use super::assemble::NONE;
use super::core::Solver;
use super::mass::Mass;
use super::work::ModesWork as Work;
use crate::error::Error;
use crate::memory;
use crate::model::wrinkling::WrinkleState;
use crate::model::Model;
use faer::linalg::matmul::matmul;
use faer::{Accum, MatMut, MatRef, Par};

/// The shift's magnitude relative to the largest K_ii/M_ii (a bound of the largest ω²).
const SHIFT: f64 = 1e-8;
/// A Ritz pair is converged when its residual is at most this times the largest θ (the
/// eigenvalue is then within about its square, relative).
const TOLERANCE: f64 = 1e-6;
/// Vectors per Lanczos block (the largest multiplicity seen: module docs).
const BLOCK: usize = 4;
/// The most columns one pass of the blocked M product handles.
const BLOCK_MAX: usize = 16;
/// A run stops at this many vectors beyond twice the wanted count.
const EXTRA: usize = 40;

/// The lowest natural frequencies and modes.
#[derive(Clone, Debug)]
pub struct Modes {
    /// ω² (1/s²), ascending.
    pub eigenvalues: Vec<f64>,
    /// f = ω/2π (Hz); negative for a negative ω².
    pub frequencies: Vec<f64>,
    /// M-normalised mode shapes per DOF (held DOFs 0), in the order of the frequencies.
    pub shapes: Vec<Vec<f64>>,
    /// The shift σ (1/s²).
    pub shift: f64,
    /// Solves with the factored K − σM (right-hand sides, BLOCK per pass over the factor).
    pub solves: usize,
    /// Passes over the factor (solves with a block of right-hand sides).
    pub passes: usize,
    /// Blocks orthogonalised against the whole Lanczos basis (partial reorthogonalisation:
    /// the others against the last two blocks only).
    pub reorthogonalisations: usize,
    /// Where the time went ([`Seconds`]).
    pub seconds: Seconds,
}

/// Wall seconds of the parts of one modal analysis.
#[derive(Clone, Copy, Debug, Default)]
pub struct Seconds {
    /// Assembly of the true tangent, the shift and the numeric factorization of K − σM.
    pub factorization: f64,
    /// Solves with the factor (every pass of BLOCK right-hand sides).
    pub solves: f64,
    /// M products (one pass over M per block).
    pub mass_products: f64,
    /// M-orthogonalisation of each new block against the earlier vectors and within itself.
    pub orthogonalisation: f64,
    /// The projected eigenproblems, the convergence tests and the Ritz vectors (shapes).
    pub ritz: f64,
    /// CPU seconds of the calling thread (`phases::thread_cpu`, NaN off Linux): the numeric
    /// factorization of K − σM alone, and the whole analysis. With one solver thread their
    /// ratio is the analysis's cost in factorizations, whatever else the machine runs.
    pub factor_cpu: f64,
    pub total_cpu: f64,
    /// CPU seconds of the calling thread in the solves and in the orthogonalisation (as
    /// `factor_cpu`: less disturbed by the machine's load than their wall times).
    pub solves_cpu: f64,
    pub orthogonalisation_cpu: f64,
}

impl Seconds {
    /// The total.
    pub fn total(&self) -> f64 {
        self.factorization + self.solves + self.mass_products + self.orthogonalisation + self.ritz
    }
}

/// `v` emptied and with room for `n` values (fallibly; kept memory is reused as it is).
fn reserved<T>(mut v: Vec<T>, n: usize, what: &'static str) -> Result<Vec<T>, Error> {
    v.clear();
    v.try_reserve_exact(n).map_err(|_| memory::OutOfMemory {
        what,
        bytes: (n * std::mem::size_of::<T>()) as u64,
    })?;
    Ok(v)
}

/// `v` as `n` zeros: its kept memory reused, or fresh memory when it must grow
/// (`memory::lazy_zeros`: pages the system zeroes at their first write, no pass over them
/// here; a first analysis's buffers are all fresh).
fn zeroed<T: Copy + Default>(mut v: Vec<T>, n: usize, what: &'static str) -> Result<Vec<T>, Error> {
    if v.capacity() < n {
        return Ok(memory::lazy_zeros(n, what)?);
    }
    v.clear();
    v.resize(n, T::default());
    Ok(v)
}

/// `v` as `n` values, its kept contents left as they are: for buffers that are written before
/// they are read (fresh memory when it must grow, as [`zeroed`]).
fn sized<T: Copy + Default>(mut v: Vec<T>, n: usize, what: &'static str) -> Result<Vec<T>, Error> {
    if v.capacity() < n {
        return Ok(memory::lazy_zeros(n, what)?);
    }
    v.truncate(n);
    v.resize(n, T::default());
    Ok(v)
}

/// The operator of the Lanczos iteration: the factored K − σM and M.
struct Operator<'a> {
    solver: &'a mut Solver,
    passes: usize,
    reorthogonalisations: usize,
    /// M's nonzero entries only (upper triangle, CSC, in the operator's order): the
    /// tangent's pattern holds M's zeros too (a consistent or lumped M couples x with x only,
    /// so two thirds of a membrane's entries are zero), which a product need not read.
    mass: (Vec<usize>, Vec<usize>, Vec<f64>),
    solves: usize,
    seconds: Seconds,
    /// X and Y row by row ([`symmetric_product_rows`]'s work buffer, 2 n BLOCK values).
    rows: Vec<f64>,
}

impl<'a> Operator<'a> {
    /// The operator, its buffers taken from `work` ([`Operator::give_back`] returns them).
    /// M's values on the tangent's pattern are not needed once M is compressed: when `work`
    /// has no row buffer yet (a first analysis), their memory becomes it (it is larger: the
    /// pattern's entries against 2 n BLOCK), so that buffer costs no fresh pages.
    fn new(
        solver: &'a mut Solver,
        mass: Mass,
        seconds: Seconds,
        work: &mut Work,
    ) -> Result<Operator<'a>, Error> {
        let t = std::time::Instant::now();
        let n = solver.linear.matrix().ncols();
        let compressed = {
            let a = solver.linear.matrix();
            let s = a.symbolic();
            let (col_ptr, row_idx) = (s.col_ptr(), s.row_idx());
            let values = mass.values();
            let what = "the mass matrix's nonzeros";
            let (ptr, rows, vals) = std::mem::take(&mut work.mass);
            match solver.linear.block_order() {
                None => {
                    let nonzero = values.iter().filter(|v| **v != 0.0).count();
                    let mut ptr = reserved(ptr, col_ptr.len(), what)?;
                    let mut rows = reserved(rows, nonzero, what)?;
                    let mut vals = reserved(vals, nonzero, what)?;
                    ptr.push(0);
                    for j in 0..col_ptr.len() - 1 {
                        for p in col_ptr[j]..col_ptr[j + 1] {
                            if values[p] != 0.0 {
                                rows.push(row_idx[p]);
                                vals.push(values[p]);
                            }
                        }
                        ptr.push(rows.len());
                    }
                    (ptr, rows, vals)
                }
                // The upper triangle of P M Pᵀ (entry (i, j) of M at (inv i, inv j), taken
                // to the upper triangle): counted per column, then placed.
                Some((_, inv)) => {
                    let mut ptr = zeroed(ptr, n + 1, what)?;
                    let mut nonzero = 0;
                    for j in 0..n {
                        let b = inv[j];
                        for p in col_ptr[j]..col_ptr[j + 1] {
                            if values[p] != 0.0 {
                                ptr[b.max(inv[row_idx[p]]) + 1] += 1;
                                nonzero += 1;
                            }
                        }
                    }
                    for c in 0..n {
                        ptr[c + 1] += ptr[c];
                    }
                    let mut rows = sized(rows, nonzero, what)?;
                    let mut vals = sized(vals, nonzero, what)?;
                    // ptr[c] runs from the start of column c to its end.
                    for j in 0..n {
                        let b = inv[j];
                        for p in col_ptr[j]..col_ptr[j + 1] {
                            if values[p] != 0.0 {
                                let a = inv[row_idx[p]];
                                let c = a.max(b);
                                let at = ptr[c];
                                rows[at] = a.min(b);
                                vals[at] = values[p];
                                ptr[c] += 1;
                            }
                        }
                    }
                    for c in (1..=n).rev() {
                        ptr[c] = ptr[c - 1];
                    }
                    ptr[0] = 0;
                    (ptr, rows, vals)
                }
            }
        };
        let rows = {
            let kept = std::mem::take(&mut work.rows);
            let spare = mass.into_values();
            let need = 2 * BLOCK * n;
            let buffer = if kept.capacity() < need && spare.capacity() >= need {
                spare
            } else {
                kept
            };
            sized(buffer, need, "the mass products' work buffer")?
        };
        let mut op = Operator {
            solver,
            mass: compressed,
            passes: 0,
            reorthogonalisations: 0,
            solves: 0,
            seconds,
            rows,
        };
        op.seconds.mass_products += t.elapsed().as_secs_f64();
        Ok(op)
    }

    /// The buffers taken from `work` by [`Operator::new`], handed back.
    fn give_back(&mut self, work: &mut Work) {
        work.mass = std::mem::take(&mut self.mass);
        work.rows = std::mem::take(&mut self.rows);
    }

    /// Y = M X for the `columns` columns of X (column-major, n rows), in one pass over M.
    fn mass(&mut self, x: &[f64], y: &mut [f64], columns: usize) {
        let t = std::time::Instant::now();
        let (col_ptr, row_idx, values) = &self.mass;
        if columns == BLOCK {
            symmetric_product_rows::<BLOCK>(col_ptr, row_idx, values, x, y, &mut self.rows);
        } else {
            symmetric_product_columns(col_ptr, row_idx, values, x, y, columns);
        }
        self.seconds.mass_products += t.elapsed().as_secs_f64();
    }

    /// X ← (K − σM)⁻¹ B for the `columns` columns of B (`from`, or X itself; M x already
    /// formed), in one pass, the vectors in the operator's order.
    fn solve(&mut self, x: &mut [f64], from: Option<&[f64]>, columns: usize) -> Result<(), Error> {
        self.solves += columns;
        self.passes += 1;
        let (t, cpu) = (std::time::Instant::now(), crate::phases::thread_cpu());
        let result = self.solver.linear.solve_block_ordered(x, from, columns);
        self.seconds.solves += t.elapsed().as_secs_f64();
        self.seconds.solves_cpu += crate::phases::thread_cpu() - cpu;
        result
    }
}

/// Y = A X for a symmetric A stored as its upper triangle in CSC and the `columns` columns of
/// X and Y (column-major, `col_ptr.len() − 1` rows): one pass over A for all of them.
fn symmetric_product_columns(
    col_ptr: &[usize],
    row_idx: &[usize],
    values: &[f64],
    x: &[f64],
    y: &mut [f64],
    columns: usize,
) {
    let n = col_ptr.len() - 1;
    y[..n * columns].fill(0.0);
    let mut sum = [0.0; BLOCK_MAX];
    for c0 in (0..columns).step_by(BLOCK_MAX) {
        let width = BLOCK_MAX.min(columns - c0);
        for j in 0..n {
            let sum = &mut sum[..width];
            sum.fill(0.0);
            for p in col_ptr[j]..col_ptr[j + 1] {
                let i = row_idx[p];
                let a = values[p];
                if i == j {
                    for (c, s) in sum.iter_mut().enumerate() {
                        *s += a * x[(c0 + c) * n + j];
                    }
                } else {
                    for (c, s) in sum.iter_mut().enumerate() {
                        let col = (c0 + c) * n;
                        y[col + i] += a * x[col + j];
                        *s += a * x[col + i];
                    }
                }
            }
            for (c, s) in sum.iter().enumerate() {
                y[(c0 + c) * n + j] += s;
            }
        }
    }
}

/// [`symmetric_product_columns`] for B columns, the same sums in the same order (the same
/// result bit for bit), with X and Y held row by row in `rows` meanwhile (an unknown's B
/// values side by side): each of A's entries then updates B adjacent values, where the
/// column-major layout touches B places n apart. With 4 columns on a processor with AVX2,
/// each row is one register ([`ProductX4`], the same operations).
fn symmetric_product_rows<const B: usize>(
    col_ptr: &[usize],
    row_idx: &[usize],
    values: &[f64],
    x: &[f64],
    y: &mut [f64],
    rows: &mut [f64],
) {
    let n = col_ptr.len() - 1;
    let (xr, yr) = rows[..2 * B * n].split_at_mut(B * n);
    #[cfg(target_arch = "x86_64")]
    if B == 4 {
        if let Some(simd) = pulp::x86::V3::try_new() {
            // X into rows and Y back in 4 × 4 tiles (`linear.rs`; the same values). (Both
            // find AVX2, as `simd` did.)
            let tiled = super::linear::rows_from_columns_x4(x, xr, n, None);
            debug_assert!(tiled);
            yr.fill(0.0);
            let xr: &[pulp::f64x4] = pulp::bytemuck::cast_slice(&xr[..4 * n]);
            let yr: &mut [pulp::f64x4] = pulp::bytemuck::cast_slice_mut(&mut yr[..4 * n]);
            pulp::Simd::vectorize(
                simd,
                ProductX4 {
                    simd,
                    col_ptr,
                    row_idx,
                    values,
                    x: xr,
                    y: yr,
                },
            );
            let tiled = super::linear::columns_from_rows_x4(&rows[4 * n..8 * n], y, n, None);
            debug_assert!(tiled);
            return;
        }
    }
    let (xr, _) = xr.as_chunks_mut::<B>();
    let (yr, _) = yr.as_chunks_mut::<B>();
    for (j, row) in xr.iter_mut().enumerate() {
        for (c, v) in row.iter_mut().enumerate() {
            *v = x[c * n + j];
        }
    }
    yr.fill([0.0; B]);
    for j in 0..n {
        let xj = xr[j];
        let mut sum = [0.0; B];
        for p in col_ptr[j]..col_ptr[j + 1] {
            let (i, a) = (row_idx[p], values[p]);
            if i == j {
                for c in 0..B {
                    sum[c] += a * xj[c];
                }
            } else {
                let xi = xr[i];
                let yi = &mut yr[i];
                for c in 0..B {
                    yi[c] += a * xj[c];
                    sum[c] += a * xi[c];
                }
            }
        }
        for c in 0..B {
            yr[j][c] += sum[c];
        }
    }
    for (j, row) in yr.iter().enumerate() {
        for (c, v) in row.iter().enumerate() {
            y[c * n + j] = *v;
        }
    }
}

/// [`symmetric_product_rows`]'s sums for 4 columns, each row one register (compiled with
/// AVX2): the same products and additions in the same order (separate multiply and add, no
/// fused operation), so the same result bit for bit.
#[cfg(target_arch = "x86_64")]
struct ProductX4<'a> {
    simd: pulp::x86::V3,
    col_ptr: &'a [usize],
    row_idx: &'a [usize],
    values: &'a [f64],
    x: &'a [pulp::f64x4],
    y: &'a mut [pulp::f64x4],
}

#[cfg(target_arch = "x86_64")]
impl pulp::WithSimd for ProductX4<'_> {
    type Output = ();

    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _simd: S) {
        let Self {
            simd,
            col_ptr,
            row_idx,
            values,
            x,
            y,
        } = self;
        for j in 0..col_ptr.len() - 1 {
            let xj = x[j];
            let mut sum = simd.splat_f64x4(0.0);
            for p in col_ptr[j]..col_ptr[j + 1] {
                let (i, a) = (row_idx[p], simd.splat_f64x4(values[p]));
                if i == j {
                    sum = simd.add_f64x4(sum, simd.mul_f64x4(a, xj));
                } else {
                    y[i] = simd.add_f64x4(y[i], simd.mul_f64x4(a, xj));
                    sum = simd.add_f64x4(sum, simd.mul_f64x4(a, x[i]));
                }
            }
            y[j] = simd.add_f64x4(y[j], sum);
        }
    }
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// A fixed pseudo-random vector (xorshift), the same every run for `seed`.
fn start_vector(n: usize, seed: u64) -> Vec<f64> {
    let mut s = 0x9E37_79B9_7F4A_7C15u64 ^ seed.wrapping_mul(0xBF58_476D_1CE4_E5B9);
    (0..n)
        .map(|_| {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        })
        .collect()
}

/// Blocks of M Q held: the last two (the three-term recurrence's). The open block takes the
/// slot of the older one, written only once the block has been orthogonalised against both
/// (its Cholesky QR, or its columns one by one, come after the Gram-Schmidt passes).
const RING: usize = 2;

/// The Lanczos basis: Q as a column-major n × k matrix (one allocation, grown by blocks), so
/// that the orthogonalisation and the Ritz vectors are matrix products that read Q once per
/// block rather than once per vector; M Q of the last [`RING`] blocks only (block b in slot
/// b mod RING, `width` vectors each): the reorthogonalisation against the whole basis takes
/// its coefficients as Qᵀ (M W).
struct Basis {
    n: usize,
    /// Vectors held (the first `count` columns of `q`; memory beyond them is kept from
    /// earlier analyses and written before it is read).
    count: usize,
    q: Vec<f64>,
    mq: Vec<f64>,
    /// Vectors per block at most (a slot of `mq`).
    width: usize,
    /// The first vector of every block; the last block is the open one.
    starts: Vec<usize>,
    /// [`cholesky_qr_block`]'s work space (2 n p values, allocated on first use; in an
    /// analysis, the M product's row buffer lent to it).
    work: Vec<f64>,
}

impl Basis {
    /// An empty basis of blocks of at most `width` vectors of `n` values (`q`, `mq`, `work`:
    /// memory to reuse).
    fn new(
        n: usize,
        width: usize,
        q: Vec<f64>,
        mq: Vec<f64>,
        work: Vec<f64>,
    ) -> Result<Basis, Error> {
        // A slot is written before it is read: kept memory of the right size is reused as it is.
        let size = RING * width * n;
        let mq = if mq.len() == size {
            mq
        } else {
            zeroed(mq, size, "the Lanczos vectors")?
        };
        Ok(Basis {
            n,
            count: 0,
            q,
            mq,
            width,
            starts: Vec::new(),
            work,
        })
    }

    fn len(&self) -> usize {
        self.count
    }

    /// Room in `q` for `vectors` vectors (grown with zeros; never shrunk, so that a later
    /// analysis writes into the memory an earlier one touched, without clearing it first;
    /// [`block_lanczos`] gives it room for the whole basis at once).
    fn room(&mut self, vectors: usize) -> Result<(), Error> {
        let size = vectors * self.n;
        if self.q.len() < size {
            self.q
                .try_reserve(size - self.q.len())
                .map_err(|_| memory::OutOfMemory {
                    what: "the Lanczos vectors",
                    bytes: 8 * size as u64,
                })?;
            self.q.resize(size, 0.0);
        }
        Ok(())
    }

    fn q(&self, k: usize) -> &[f64] {
        &self.q[k * self.n..(k + 1) * self.n]
    }

    /// Where vector `k`'s M q starts in `mq` (its block among the last [`RING`]).
    fn mq_at(&self, k: usize) -> usize {
        let b = self.starts.partition_point(|&s| s <= k) - 1;
        // (The open block is the last of `starts`: the two before it are still held.)
        debug_assert!(b + RING + 1 >= self.starts.len() && k - self.starts[b] < self.width);
        ((b % RING) * self.width + k - self.starts[b]) * self.n
    }

    fn mq(&self, k: usize) -> &[f64] {
        let at = self.mq_at(k);
        &self.mq[at..at + self.n]
    }

    /// M Q of the vectors `from..to` of one block.
    fn mq_block(&self, from: usize, to: usize) -> &[f64] {
        let at = self.mq_at(from);
        &self.mq[at..at + (to - from) * self.n]
    }

    /// Open a new block (the vectors pushed next).
    fn begin_block(&mut self) {
        self.starts.push(self.len());
    }

    fn push(&mut self, w: &[f64], mw: &[f64], size: f64) -> Result<(), Error> {
        let k = self.len();
        self.room(k + 1)?;
        for (y, x) in self.q[k * self.n..(k + 1) * self.n].iter_mut().zip(w) {
            *y = x / size;
        }
        self.count = k + 1;
        let at = self.mq_at(k);
        for (y, x) in self.mq[at..at + self.n].iter_mut().zip(mw) {
            *y = x / size;
        }
        Ok(())
    }
}

/// Orthonormalise the `columns` columns of W (M W in `mw`) in the M inner product. For a
/// Lanczos block (`recurrence` = (the start of the block W is the image of, the start of the
/// block before it)): against the last two blocks (the three-term recurrence) twice
/// (classical Gram-Schmidt, each pass two matrix products that read those blocks' Q and M Q
/// once for the whole block); then M W; then, when `partial` says the block would lose
/// orthogonality to the earlier vectors beyond √ε (or always, without an estimate), against
/// every vector of `basis` before the last two blocks (the reorthogonalisation, its
/// coefficients Qᵀ (M W); the last two blocks had their two passes) and M W afresh; then
/// within the block: as matrix
/// products ([`cholesky_qr_block`]) when the block is well conditioned, otherwise one column
/// after the other against the block's earlier accepted columns (twice). Accepted columns (M
/// norm above 1e-10 `scale`) join `basis`. Returns per column its coefficients on the basis
/// (the column of H: the last two blocks', the block's accepted ones', then its own M norm if
/// accepted; the reorthogonalisation's coefficients are left out of H, as
/// partial reorthogonalisation's analysis takes it: Simon 1984).
#[allow(clippy::too_many_arguments)]
fn orthonormalise_block(
    op: &mut Operator,
    basis: &mut Basis,
    w: &mut [f64],
    mw: &mut [f64],
    columns: usize,
    scale: &mut f64,
    recurrence: Option<(usize, usize)>,
    h: &[Vec<f64>],
    partial: &mut Partial,
) -> Result<Vec<Vec<f64>>, Error> {
    let (diagonal_of, local) = match recurrence {
        Some((start, previous)) => (Some(start), previous),
        None => (None, 0),
    };
    let n = basis.n;
    let old = basis.len();
    let local = local.min(old);
    basis.begin_block();
    let (t, cpu) = (std::time::Instant::now(), crate::phases::thread_cpu());
    let mut total = vec![0.0; old * columns];
    let mut c = vec![0.0; old * columns];
    // The three-term recurrence's part (the last two blocks, from `local`), twice.
    for _ in 0..2 {
        gram_schmidt_pass(basis, w, None, columns, local, old, &mut c, &mut total);
    }
    op.seconds.orthogonalisation += t.elapsed().as_secs_f64();
    op.seconds.orthogonalisation_cpu += crate::phases::thread_cpu() - cpu;
    op.mass(w, mw, columns);
    let (t, cpu) = (std::time::Instant::now(), crate::phases::thread_cpu());
    let mut first = gram_cholesky(w, mw, n, columns);
    // (At the second block, `local` is 0: the two passes were against every vector.)
    let full = match (diagonal_of, &first) {
        (Some(start), Some(r1)) => {
            partial.exceeds(h, &total, old, start, columns, r1, *scale) && local > 0
        }
        (Some(_), None) => {
            partial.give_up();
            local > 0
        }
        (None, _) => false,
    };
    if full {
        // The reorthogonalisation against the vectors before the last two blocks (those
        // were orthogonalised against twice above; what this pass subtracts adds to W's
        // components along them only its product with the basis's semi-orthogonality, √ε
        // times √ε), then M W afresh. Its coefficients stay out of H (Simon 1984).
        let mut extra = vec![0.0; old * columns];
        gram_schmidt_pass(basis, w, Some(mw), columns, 0, local, &mut c, &mut extra);
        op.seconds.orthogonalisation += t.elapsed().as_secs_f64();
        op.seconds.orthogonalisation_cpu += crate::phases::thread_cpu() - cpu;
        op.mass(w, mw, columns);
        op.reorthogonalisations += 1;
        first = None;
    }
    let (t, cpu) = (std::time::Instant::now(), crate::phases::thread_cpu());
    // The M product's row buffer (2 n BLOCK values) is free meanwhile: it is the Cholesky
    // QR's work space (2 n p values), so the solver keeps no buffer of its own for that.
    std::mem::swap(&mut basis.work, &mut op.rows);
    let blocked = cholesky_qr_block(
        basis,
        w,
        mw,
        columns,
        &total,
        old,
        scale,
        diagonal_of,
        first,
    );
    std::mem::swap(&mut basis.work, &mut op.rows);
    let blocked = blocked?;
    if let Some(out) = blocked {
        if diagonal_of.is_some() {
            partial.accepted(columns, full);
        } else {
            partial.start(columns);
        }
        op.seconds.orthogonalisation += t.elapsed().as_secs_f64();
        op.seconds.orthogonalisation_cpu += crate::phases::thread_cpu() - cpu;
        return Ok(out);
    }
    // A nearly dependent block: the estimate no longer applies (full reorthogonalisation of
    // every later block).
    partial.give_up();
    let mut out = Vec::with_capacity(columns);
    let mut accepted = 0;
    for c in 0..columns {
        let mut column = total[c * old..(c + 1) * old].to_vec();
        let mut within = vec![0.0; accepted];
        let (wc, mwc) = (&mut w[c * n..(c + 1) * n], &mut mw[c * n..(c + 1) * n]);
        for _ in 0..2 {
            for (slot, coefficient_sum) in within.iter_mut().enumerate() {
                let (qk, mqk) = (basis.q(old + slot), basis.mq(old + slot));
                let coefficient = dot(mqk, wc);
                *coefficient_sum += coefficient;
                for (x, y) in wc.iter_mut().zip(qk) {
                    *x -= coefficient * y;
                }
                for (x, y) in mwc.iter_mut().zip(mqk) {
                    *x -= coefficient * y;
                }
            }
        }
        column.extend_from_slice(&within);
        if let Some(start) = diagonal_of {
            *scale = scale.max(column.get(start + c).copied().unwrap_or(0.0).abs());
        }
        let size = dot(wc, mwc).max(0.0).sqrt();
        if size > 1e-10 * *scale && size.is_finite() && basis.len() < n {
            if diagonal_of.is_none() {
                *scale = scale.max(size);
            }
            column.push(size);
            basis.push(wc, mwc, size)?;
            accepted += 1;
        }
        out.push(column);
    }
    op.seconds.orthogonalisation += t.elapsed().as_secs_f64();
    op.seconds.orthogonalisation_cpu += crate::phases::thread_cpu() - cpu;
    Ok(out)
}

/// One classical Gram-Schmidt pass of the `columns` columns of W against the basis vectors
/// `from..to`: C = (M Q)ᵀ W, or Qᵀ (M W) when M W is given (`mw`: the vectors' M Q may no
/// longer be held), then W ← W − Q C (two matrix products), C added to `total` (old ×
/// columns, column-major, old the basis's length; `c` a work space as large).
#[allow(clippy::too_many_arguments)]
fn gram_schmidt_pass(
    basis: &Basis,
    w: &mut [f64],
    mw: Option<&[f64]>,
    columns: usize,
    from: usize,
    to: usize,
    c: &mut [f64],
    total: &mut [f64],
) {
    let (n, old) = (basis.n, basis.len());
    let k = to - from;
    if k == 0 {
        return;
    }
    let q = MatRef::from_column_major_slice(&basis.q[from * n..to * n], n, k);
    let wm = MatRef::from_column_major_slice(w, n, columns);
    match mw {
        Some(mw) => {
            let mwm = MatRef::from_column_major_slice(mw, n, columns);
            let cm = MatMut::from_column_major_slice_mut(&mut c[..k * columns], k, columns);
            product(cm, Accum::Replace, q.transpose(), mwm, 1.0);
        }
        None => {
            // Block by block (M Q is held per block).
            let mut part = vec![0.0; basis.width * columns];
            let mut s = from;
            while s < to {
                let b = basis.starts.partition_point(|&x| x <= s) - 1;
                let e = basis.starts.get(b + 1).copied().unwrap_or(to).min(to);
                let rows = e - s;
                let mq = MatRef::from_column_major_slice(basis.mq_block(s, e), n, rows);
                let pm =
                    MatMut::from_column_major_slice_mut(&mut part[..rows * columns], rows, columns);
                product(pm, Accum::Replace, mq.transpose(), wm, 1.0);
                for col in 0..columns {
                    for i in 0..rows {
                        c[col * k + s - from + i] = part[col * rows + i];
                    }
                }
                s = e;
            }
        }
    }
    let cm = MatRef::from_column_major_slice(&c[..k * columns], k, columns);
    let wm = MatMut::from_column_major_slice_mut(w, n, columns);
    product(wm, Accum::Add, q, cm, -1.0);
    for col in 0..columns {
        for i in 0..k {
            total[col * old + from + i] += c[col * k + i];
        }
    }
}

/// Partial reorthogonalisation's estimate of the loss of orthogonality (Simon 1984, "The
/// Lanczos algorithm with partial reorthogonalization", Math. Comp. 42; in the block form of
/// Grimes, Lewis & Simon 1994, SIAM J. Matrix Anal. Appl. 15(1)). With the blocks Q_k of p
/// vectors and A Q_j = Q_{j−1} B_{j−1}ᵀ + Q_j A_j + Q_{j+1} B_j + F_j (A_j, B_j the blocks of
/// H, F_j the rounding), E_{k,j} = Q_kᵀ M Q_j follows, since M A is symmetric,
///
/// ```text
/// E_{k,j+1} B_j = B_{k−1} E_{k−1,j} + A_k E_{k,j} + B_kᵀ E_{k+1,j} − E_{k,j−1} B_{j−1}ᵀ − E_{k,j} A_j + G
/// ```
///
/// with G the rounding's part. The estimate runs this recurrence on p × p matrices for every
/// block k before the last two (those are orthogonalised against at every step), with G
/// replaced by NOISE θ_max in every entry, signed to add to the entry's magnitude (Simon's
/// rule), and the last two blocks' entries set to NOISE θ_max ‖B_j⁻¹‖. When its largest entry
/// passes √ε the block is orthogonalised against every earlier block (those before the last
/// two: [`orthonormalise_block`]), and so is the next
/// one (Q_j itself is no better); both then restart at the noise level. Blocks narrower than
/// p (a nearly dependent block) end the estimate: every later block is reorthogonalised.
struct Partial {
    p: usize,
    /// E_{k,j} for the last block j (k = 0..=j, p × p column-major each) and E_{k,j−1}.
    current: Vec<f64>,
    previous: Vec<f64>,
    /// The next block is reorthogonalised whatever the estimate.
    force: bool,
    /// The block being orthogonalised was forced (it is the second of a pair).
    forced: bool,
    /// No estimate: every block is reorthogonalised.
    off: bool,
    /// The estimate for the block being orthogonalised ([`Partial::exceeds`]).
    next: Vec<f64>,
}

/// The rounding's part of the recurrence per step, relative to θ_max ([`Partial`]): ε, as
/// Simon takes it. On the modes benchmark the estimate then stays 60-250 times above the loss
/// of orthogonality measured with the full products (Qᵀ M W, every block, reorthogonalising
/// none), and it passes √ε one block before the measured loss does.
const NOISE: f64 = f64::EPSILON;
/// Reorthogonalise when the estimate passes this (√ε).
const SEMI: f64 = 1.4901161193847656e-8;

impl Partial {
    fn new(p: usize) -> Partial {
        Partial {
            p,
            current: Vec::new(),
            previous: Vec::new(),
            force: false,
            forced: false,
            off: false,
            next: Vec::new(),
        }
    }

    /// The first block (block 0) accepted whole.
    fn start(&mut self, columns: usize) {
        self.off |= columns != self.p;
        self.previous.clear();
        self.current = identity(self.p);
    }

    fn give_up(&mut self) {
        self.off = true;
    }

    /// Whether the block W of the image of block j = `start`/p (A_j in `total`, the first
    /// Cholesky factor `r1` of its Gram matrix ≈ B_j) must be orthogonalised against every
    /// earlier vector. Keeps the estimate E_{·,j+1} for [`Partial::accepted`].
    #[allow(clippy::too_many_arguments)]
    fn exceeds(
        &mut self,
        h: &[Vec<f64>],
        total: &[f64],
        old: usize,
        start: usize,
        columns: usize,
        r1: &[f64],
        theta: f64,
    ) -> bool {
        let p = self.p;
        if self.off
            || columns != p
            || !old.is_multiple_of(p)
            || !start.is_multiple_of(p)
            || start + p != old
        {
            self.off = true;
            return true;
        }
        let j = start / p;
        if self.current.len() != (j + 1) * p * p || self.previous.len() != j * p * p {
            self.off = true;
            return true;
        }
        let pp = p * p;
        // H's blocks: A_k (symmetrised), B_k (rows block k+1, columns block k).
        let a = |k: usize| -> Vec<f64> {
            let mut m = vec![0.0; pp];
            for c in 0..p {
                for i in 0..p {
                    let x = if k == j {
                        0.5 * (total[c * old + k * p + i] + total[i * old + k * p + c])
                    } else {
                        let at = |r: usize, col: usize| h[col].get(r).copied().unwrap_or(0.0);
                        0.5 * (at(k * p + i, k * p + c) + at(k * p + c, k * p + i))
                    };
                    m[i + c * p] = x;
                }
            }
            m
        };
        let b = |k: usize| -> Vec<f64> {
            let mut m = vec![0.0; pp];
            for c in 0..p {
                for i in 0..p {
                    m[i + c * p] = h[k * p + c].get((k + 1) * p + i).copied().unwrap_or(0.0);
                }
            }
            m
        };
        let inverse = upper_inverse(r1, p);
        let inverse_norm = norm(&inverse, p);
        let noise = NOISE * theta;
        let a_j = a(j);
        let b_jm1t = if j >= 1 {
            transpose(&b(j - 1), p)
        } else {
            vec![0.0; pp]
        };
        let mut next = vec![0.0; (j + 2) * pp];
        let mut largest = 0.0f64;
        fn e(row: &[f64], k: usize, pp: usize) -> &[f64] {
            &row[k * pp..(k + 1) * pp]
        }
        for k in 0..j.saturating_sub(1) {
            let mut x = vec![0.0; pp];
            if k >= 1 {
                add_product(&mut x, &b(k - 1), e(&self.current, k - 1, pp), p, 1.0);
            }
            add_product(&mut x, &a(k), e(&self.current, k, pp), p, 1.0);
            add_product(
                &mut x,
                &transpose(&b(k), p),
                e(&self.current, k + 1, pp),
                p,
                1.0,
            );
            add_product(&mut x, e(&self.previous, k, pp), &b_jm1t, p, -1.0);
            add_product(&mut x, e(&self.current, k, pp), &a_j, p, -1.0);
            for v in x.iter_mut() {
                *v += noise.copysign(*v);
            }
            let mut y = vec![0.0; pp];
            add_product(&mut y, &x, &inverse, p, 1.0);
            largest = y.iter().fold(largest, |m, v| m.max(v.abs()));
            next[k * pp..(k + 1) * pp].copy_from_slice(&y);
        }
        for k in j.saturating_sub(1)..=j {
            next[k * pp..(k + 1) * pp].fill(noise * inverse_norm);
        }
        next[(j + 1) * pp..].copy_from_slice(&identity(p));
        self.next = next;
        self.forced = std::mem::take(&mut self.force);
        self.forced || largest > SEMI
    }

    /// The block was accepted whole (`full`: after the reorthogonalisation).
    fn accepted(&mut self, columns: usize, full: bool) {
        let p = self.p;
        if self.off || columns != p || self.next.is_empty() {
            self.off = true;
            return;
        }
        let mut next = std::mem::take(&mut self.next);
        if full {
            // Both this block and, next time, the following one are clean: the noise level.
            let j = next.len() / (p * p) - 2;
            let level = next[j * p * p];
            next[..j * p * p].fill(level);
            self.force = !self.forced;
        }
        self.previous = std::mem::replace(&mut self.current, next);
    }
}

fn identity(p: usize) -> Vec<f64> {
    let mut m = vec![0.0; p * p];
    for i in 0..p {
        m[i + i * p] = 1.0;
    }
    m
}

fn transpose(m: &[f64], p: usize) -> Vec<f64> {
    let mut t = vec![0.0; p * p];
    for c in 0..p {
        for i in 0..p {
            t[c + i * p] = m[i + c * p];
        }
    }
    t
}

/// The ∞-norm of a p × p matrix (column-major).
fn norm(m: &[f64], p: usize) -> f64 {
    (0..p)
        .map(|i| (0..p).map(|c| m[i + c * p].abs()).sum::<f64>())
        .fold(0.0, f64::max)
}

/// Y += s X Z (p × p, column-major).
fn add_product(y: &mut [f64], x: &[f64], z: &[f64], p: usize, s: f64) {
    for c in 0..p {
        for k in 0..p {
            let zk = s * z[k + c * p];
            for i in 0..p {
                y[i + c * p] += x[i + k * p] * zk;
            }
        }
    }
}

/// The within-block step of [`orthonormalise_block`] as matrix products (CholQR2): twice, the
/// Gram matrix G = (M W)ᵀ W (one product that reads W and M W once), its Cholesky factor
/// G = Rᵀ R, then W ← W R⁻¹ and M W ← M W R⁻¹ (one matrix product each). The block is
/// then W = Q R with R = R₂ R₁: column c's coefficients on the block's earlier vectors are
/// R[0..c, c] and its M norm R[c, c], as the column-by-column code gives them. A Cholesky
/// factorization loses orthogonality in proportion to κ(W)², so the first factor must have
/// its diagonal within 1e-5 of its largest (κ below about 1e5: the second pass restores
/// orthogonality to round-off) and every column must be accepted as the column-by-column
/// code would accept it; otherwise None, W and M W untouched, and that code runs (a nearly
/// dependent block, an invariant subspace, a basis as large as n).
#[allow(clippy::too_many_arguments)]
fn cholesky_qr_block(
    basis: &mut Basis,
    w: &[f64],
    mw: &[f64],
    columns: usize,
    total: &[f64],
    old: usize,
    scale: &mut f64,
    diagonal_of: Option<usize>,
    first: Option<Vec<f64>>,
) -> Result<Option<Vec<Vec<f64>>>, Error> {
    let n = basis.n;
    let p = columns;
    if p == 0 || p > BLOCK_MAX || p > basis.width || basis.len() + p > n {
        return Ok(None);
    }
    // The scale the column-by-column code would reach over this block (an upper bound of it).
    let mut new_scale = *scale;
    if let Some(start) = diagonal_of {
        for c in 0..p {
            let d = total.get(c * old + start + c).copied().unwrap_or(0.0);
            new_scale = new_scale.max(d.abs());
        }
    }
    // The first round's W R₁⁻¹ and M W R₁⁻¹ (in `basis.work`, kept from block to block).
    let mut work = std::mem::take(&mut basis.work);
    if work.len() < 2 * n * p {
        work = memory::zeros(2 * n * p, "the Lanczos block's work space")?;
    }
    let result = cholesky_qr_rounds(
        basis,
        w,
        mw,
        &mut work,
        p,
        &mut new_scale,
        diagonal_of,
        first,
    );
    basis.work = work;
    let Some(r_total) = result? else {
        return Ok(None);
    };
    *scale = new_scale;
    Ok(Some(
        (0..p)
            .map(|c| {
                let mut column = total[c * old..(c + 1) * old].to_vec();
                column.extend((0..=c).map(|i| r_total[i + c * p]));
                column
            })
            .collect(),
    ))
}

/// [`cholesky_qr_block`]'s two rounds: R = R₂ R₁ (column-major, p × p), the block's vectors
/// appended to `basis`; None (nothing appended) when a factor is refused.
#[allow(clippy::too_many_arguments)]
fn cholesky_qr_rounds(
    basis: &mut Basis,
    w: &[f64],
    mw: &[f64],
    work: &mut [f64],
    p: usize,
    scale: &mut f64,
    diagonal_of: Option<usize>,
    first: Option<Vec<f64>>,
) -> Result<Option<Vec<f64>>, Error> {
    let n = basis.n;
    let (tw, tmw) = work[..2 * n * p].split_at_mut(n * p);
    let r1 = match first.or_else(|| gram_cholesky(w, mw, n, p)) {
        Some(r) => r,
        None => return Ok(None),
    };
    let (low, high) = (0..p)
        .map(|j| r1[j + j * p])
        .fold((f64::INFINITY, 0.0f64), |(l, h), d| (l.min(d), h.max(d)));
    if diagonal_of.is_none() {
        *scale = scale.max(high);
    }
    if !(low > 1e-5 * high && low > 1e-10 * *scale) {
        return Ok(None);
    }
    let inverse = upper_inverse(&r1, p);
    for (into, from) in [(&mut *tw, w), (&mut *tmw, mw)] {
        times_inverse(into, from, &inverse, n, p);
    }
    let Some(r2) = gram_cholesky(tw, tmw, n, p) else {
        return Ok(None);
    };
    let inverse = upper_inverse(&r2, p);
    let old = basis.len();
    basis.room(old + p)?;
    times_inverse(&mut basis.q[old * n..], tw, &inverse, n, p);
    basis.count = old + p;
    let at = basis.mq_at(old);
    times_inverse(&mut basis.mq[at..], tmw, &inverse, n, p);
    // R₂ R₁.
    let mut r = vec![0.0; p * p];
    for j in 0..p {
        for i in 0..=j {
            r[i + j * p] = (i..=j).map(|k| r2[i + k * p] * r1[k + j * p]).sum();
        }
    }
    Ok(Some(r))
}

/// The upper Cholesky factor R of G = (M X)ᵀ X (symmetrised; column-major, p × p), or None
/// when a pivot is not positive and finite.
fn gram_cholesky(x: &[f64], mx: &[f64], n: usize, p: usize) -> Option<Vec<f64>> {
    let mut g = vec![0.0; p * p];
    product(
        MatMut::from_column_major_slice_mut(&mut g, p, p),
        Accum::Replace,
        MatRef::from_column_major_slice(&mx[..n * p], n, p).transpose(),
        MatRef::from_column_major_slice(&x[..n * p], n, p),
        1.0,
    );
    let mut r = vec![0.0; p * p];
    for j in 0..p {
        for i in 0..=j {
            let gij = 0.5 * (g[i + j * p] + g[j + i * p]);
            let sum = gij - (0..i).map(|k| r[k + i * p] * r[k + j * p]).sum::<f64>();
            if i == j {
                if !(sum > 0.0 && sum.is_finite()) {
                    return None;
                }
                r[j + j * p] = sum.sqrt();
            } else {
                r[i + j * p] = sum / r[i + i * p];
            }
        }
    }
    Some(r)
}

/// The inverse of an upper triangular p × p matrix (column-major, nonzero diagonal).
fn upper_inverse(r: &[f64], p: usize) -> Vec<f64> {
    let mut inverse = vec![0.0; p * p];
    for j in 0..p {
        inverse[j + j * p] = 1.0 / r[j + j * p];
        for i in (0..j).rev() {
            let sum: f64 = (i + 1..=j).map(|k| r[i + k * p] * inverse[k + j * p]).sum();
            inverse[i + j * p] = -sum / r[i + i * p];
        }
    }
    inverse
}

/// C ← α A B, or C + α A B with `Accum::Add` (faer's product on one thread), then the vector
/// registers' upper halves cleared ([`clear_upper_halves`]).
fn product(c: MatMut<f64>, accumulate: Accum, a: MatRef<f64>, b: MatRef<f64>, alpha: f64) {
    matmul(c, accumulate, a, b, alpha, Par::Seq);
    clear_upper_halves();
}

/// VZEROUPPER. faer's products run AVX-512 kernels written in assembly (private-gemm-x86)
/// that return with the vector registers' upper halves in use. Code compiled without AVX that
/// runs after that (nalgebra's eigensolver here, the element routines of the next assembly)
/// then ran about twice as slow on the development machine: the true tangent's assembly took
/// 45 ms instead of 23 ms in every analysis after the first (docs/dynamics.md, thirteenth
/// session).
fn clear_upper_halves() {
    #[cfg(target_arch = "x86_64")]
    if let Some(simd) = pulp::x86::V3::try_new() {
        simd.avx._mm256_zeroupper();
    }
}

/// Y = X R⁻¹ (n × p, column-major) as one matrix product.
fn times_inverse(y: &mut [f64], x: &[f64], inverse: &[f64], n: usize, p: usize) {
    product(
        MatMut::from_column_major_slice_mut(&mut y[..n * p], n, p),
        Accum::Replace,
        MatRef::from_column_major_slice(&x[..n * p], n, p),
        MatRef::from_column_major_slice(inverse, p, p),
        1.0,
    );
}

/// Block Lanczos on `op` (module docs): the converged Ritz pairs, at most `want` of them: θ
/// descending and the M-normalised vectors (n values each, one after the other, in the
/// operator's order).
/// The basis and the block's vectors live in `work` (kept between analyses).
fn block_lanczos(op: &mut Operator, n: usize, want: usize, work: &mut Work) -> Result<Ritz, Error> {
    let max_dim = (2 * want + EXTRA).min(n).max(1);
    let block = BLOCK.min(n);
    let what = "the Lanczos vectors";
    // The kept basis memory as it is (written before it is read), or fresh memory for the
    // whole basis at once (its pages zeroed by the system as the blocks are first written).
    let mut q = std::mem::take(&mut work.q);
    if q.len() < n * (max_dim + block) {
        q = memory::lazy_zeros(n * (max_dim + block), what)?;
    }
    let mut basis = Basis::new(
        n,
        block,
        q,
        std::mem::take(&mut work.mq),
        std::mem::take(&mut work.qr),
    )?;
    let mut vectors = sized(std::mem::take(&mut work.block), 2 * n * block, what)?;
    let result = lanczos_iterate(op, n, want, max_dim, &mut basis, &mut vectors);
    work.q = basis.q;
    work.mq = basis.mq;
    work.qr = basis.work;
    work.block = vectors;
    result
}

/// [`block_lanczos`]'s iteration, with the basis (empty) and the block's vectors (W and M W,
/// n × BLOCK each; M W first holds the start block R) given.
fn lanczos_iterate(
    op: &mut Operator,
    n: usize,
    want: usize,
    max_dim: usize,
    basis: &mut Basis,
    vectors: &mut [f64],
) -> Result<Ritz, Error> {
    let block = BLOCK.min(n);
    let (w, mw) = vectors.split_at_mut(n * block);
    // H's columns (h[k][i] = (M qᵢ)ᵀ A q_k).
    let mut h: Vec<Vec<f64>> = Vec::new();
    // The first block: A R, M-orthonormalised (A R lies in the range of A: no component along
    // the massless directions' infinite frequencies). R is held in M W's place until M W is
    // formed, in the operator's order.
    let order = op.solver.linear.block_order().map(|(fwd, _)| fwd);
    for seed in 0..block {
        let v = start_vector(n, seed as u64);
        let r = &mut mw[seed * n..(seed + 1) * n];
        match order {
            Some(fwd) => r.iter_mut().zip(fwd).for_each(|(x, &e)| *x = v[e]),
            None => r.copy_from_slice(&v),
        }
    }
    op.mass(mw, w, block);
    op.solve(w, None, block)?;
    let mut scale = 0.0f64;
    let mut partial = Partial::new(block);
    orthonormalise_block(op, basis, w, mw, block, &mut scale, None, &h, &mut partial)?;
    let (mut previous, mut start) = (0, 0);
    loop {
        let end = basis.len();
        if start == end {
            // No new direction: an invariant subspace, every Ritz pair exact.
            return ritz_pairs(op, &h, end, want, None);
        }
        let columns = end - start;
        op.solve(
            &mut w[..n * columns],
            Some(basis.mq_block(start, end)),
            columns,
        )?;
        let new = orthonormalise_block(
            op,
            basis,
            &mut w[..n * columns],
            &mut mw[..n * columns],
            columns,
            &mut scale,
            Some((start, previous)),
            &h,
            &mut partial,
        )?;
        h.extend(new);
        let t = std::time::Instant::now();
        // Residual of a Ritz pair: the coefficients on the new block's vectors (B_j s_j).
        let (theta, s) = projected_eigen(&h, end);
        let mut order: Vec<usize> = (0..end).collect();
        order.sort_by(|&x, &y| theta[y].total_cmp(&theta[x]));
        let largest = theta.iter().fold(0.0f64, |m, t| m.max(t.abs()));
        let total = basis.len();
        let residual = |k: usize| -> f64 {
            (end..total)
                .map(|i| {
                    (start..end)
                        .map(|c| h[c].get(i).copied().unwrap_or(0.0) * s[(c, k)])
                        .sum::<f64>()
                })
                .map(|v| v * v)
                .sum::<f64>()
                .sqrt()
        };
        let wanted = want.min(end);
        let done = order
            .iter()
            .take(wanted)
            .all(|&k| residual(k) <= TOLERANCE * largest);
        let invariant = total == end;
        op.seconds.ritz += t.elapsed().as_secs_f64();
        if (end >= want && done) || invariant || total >= max_dim {
            let keep: Vec<usize> = order
                .iter()
                .take(wanted)
                .copied()
                .filter(|&k| invariant || residual(k) <= TOLERANCE * largest)
                .collect();
            return ritz_pairs(op, &h, end, want, Some((&keep, (theta, s))));
        }
        previous = start;
        start = end;
    }
}

/// Converged Ritz pairs: θ descending, and their coefficients S on the basis's first m vectors
/// (m × count, column-major), and m: the M-normalised vectors are Q S ([`mode_shapes`]).
type Ritz = (Vec<f64>, Vec<f64>, usize);

/// Eigenvalues θ and eigenvectors (columns) of a block of H.
type Eigen = (Vec<f64>, nalgebra::DMatrix<f64>);

/// Eigenpairs of the leading `m` × `m` block of H (columns `h`, symmetrised).
fn projected_eigen(h: &[Vec<f64>], m: usize) -> Eigen {
    let at = |i: usize, k: usize| h[k].get(i).copied().unwrap_or(0.0);
    let t = nalgebra::DMatrix::from_fn(m, m, |i, k| 0.5 * (at(i, k) + at(k, i)));
    let e = nalgebra::SymmetricEigen::new(t);
    (e.eigenvalues.iter().copied().collect(), e.eigenvectors)
}

/// The Ritz pairs (θ, Q s) of the leading `m` vectors: `known`, the eigenpairs of H's
/// leading m × m block as the convergence test has them and those of them to keep (indices),
/// or, when None, the largest `want` of H's eigenpairs; the vectors' coefficients S (the
/// vectors Q S are formed straight into the mode shapes: [`mode_shapes`]).
fn ritz_pairs(
    op: &mut Operator,
    h: &[Vec<f64>],
    m: usize,
    want: usize,
    known: Option<(&[usize], Eigen)>,
) -> Result<Ritz, Error> {
    let t = std::time::Instant::now();
    let m = m.min(h.len());
    if m == 0 {
        return Ok((Vec::new(), Vec::new(), 0));
    }
    let (chosen, (theta, s)) = match known {
        Some((keep, eigen)) => (keep.to_vec(), eigen),
        None => {
            let (theta, s) = projected_eigen(h, m);
            let mut order: Vec<usize> = (0..m).collect();
            order.sort_by(|&x, &y| theta[y].total_cmp(&theta[x]));
            order.truncate(want);
            (order, (theta, s))
        }
    };
    let count = chosen.len();
    let mut coefficients = vec![0.0; m * count];
    for (j, &k) in chosen.iter().enumerate() {
        for i in 0..m {
            coefficients[j * m + i] = s[(i, k)];
        }
    }
    let thetas = chosen.iter().map(|&k| theta[k]).collect();
    op.seconds.ritz += t.elapsed().as_secs_f64();
    Ok((thetas, coefficients, m))
}

/// Rows of Q per product of [`mode_shapes`] (the block of Q S, rows × count, stays in cache).
const SHAPE_ROWS: usize = 1024;

/// The mode shapes per DOF (`dofs` values each, held DOFs 0): the Ritz vectors Q S (`q` the
/// basis, n × m, in the operator's order; `s` m × count) formed SHAPE_ROWS rows at a time
/// and each row put at its DOF (`position`: the DOF of each position of the operator's
/// order), so that no n × count matrix of them is written and read back.
fn mode_shapes(
    q: &[f64],
    n: usize,
    m: usize,
    s: &[f64],
    count: usize,
    position: &[usize],
    dofs: usize,
) -> Vec<Vec<f64>> {
    let mut shapes: Vec<Vec<f64>> = (0..count).map(|_| vec![0.0; dofs]).collect();
    if count == 0 || m == 0 {
        return shapes;
    }
    let q = MatRef::from_column_major_slice(&q[..n * m], n, m);
    let s = MatRef::from_column_major_slice(&s[..m * count], m, count);
    let mut y = vec![0.0; SHAPE_ROWS * count];
    for start in (0..n).step_by(SHAPE_ROWS) {
        let rows = SHAPE_ROWS.min(n - start);
        product(
            MatMut::from_column_major_slice_mut(&mut y[..rows * count], rows, count),
            Accum::Replace,
            q.subrows(start, rows),
            s,
            1.0,
        );
        let at = &position[start..start + rows];
        for (shape, column) in shapes.iter_mut().zip(y.chunks(rows)) {
            for (&d, &v) in at.iter().zip(column) {
                shape[d] = v;
            }
        }
    }
    shapes
}

impl Solver {
    /// The lowest `count` natural frequencies and modes at the converged state `u` under
    /// `loads`, wrinkle states `wrinkle` (module docs). Errors: a model without mass, a scene
    /// with sleeves or volume inputs (their unknowns are not in this eigenproblem), a failed
    /// factorization of K − σM. Leaves K − σM in the solver's factorization: the next Newton
    /// iteration assembles and factors its own. Keeps its large buffers (the Lanczos basis,
    /// [`Work`]) in the solver for the next analysis.
    pub fn modes(
        &mut self,
        model: &Model,
        mass: Mass,
        u: &[f64],
        loads: &[f64],
        wrinkle: &[WrinkleState],
        count: usize,
    ) -> Result<Modes, Error> {
        if model.volumes > 0 || !model.slips.is_empty() {
            return Err(Error::Unsupported(
                "natural frequencies of scenes with sleeves or volume inputs (their slip and pressure unknowns are not in the eigenproblem yet)".into(),
            ));
        }
        if mass.is_zero() {
            return Err(Error::Unsupported(
                "natural frequencies of a massless scene: give a membrane group a `density` (kg/m3), a cable a `mass_per_length` (kg/m) or the `dynamics` section `point_masses`".into(),
            ));
        }
        let n = self.pattern.n;
        let started = std::time::Instant::now();
        let cpu_started = crate::phases::thread_cpu();
        // (Whatever ran before, a faer product of the statics say, may have left the vector
        // registers' upper halves in use; the element routines are compiled without AVX.)
        clear_upper_halves();
        // The true tangent (as `factor_tangent`): states frozen, no artificial prestress.
        self.assemble_true_tangent(model, u, loads, wrinkle);
        self.remove_regularisation(model, u, wrinkle);
        // The shift: below ω² = 0 by SHIFT of the largest K_ii/M_ii.
        let mut largest = 0.0f64;
        {
            let k = self.linear.values();
            for &p in &self.diagonal_positions {
                let (kii, mii) = (k[p], mass.values()[p]);
                if mii > 0.0 && kii.is_finite() {
                    largest = largest.max(kii / mii);
                }
            }
        }
        let shift = -SHIFT * largest.max(f64::MIN_POSITIVE);
        mass.add_to(-shift, self.linear.values_mut());
        let cpu_factor = crate::phases::thread_cpu();
        let factorization = self.linear.factor();
        // (Its dense kernels leave the vector registers' upper halves in use.)
        clear_upper_halves();
        factorization?;
        let factor_cpu = crate::phases::thread_cpu() - cpu_factor;
        let factored = started.elapsed().as_secs_f64();
        let mut work = std::mem::take(&mut self.modes_work);
        let seconds = Seconds {
            factorization: factored,
            factor_cpu,
            ..Seconds::default()
        };
        let count = count.min(n);
        let run = move |solver: &mut Solver, work: &mut Work| {
            let mut op = Operator::new(solver, mass, seconds, work)?;
            let found = block_lanczos(&mut op, n, count, work);
            op.give_back(work);
            let counts = (op.solves, op.passes, op.reorthogonalisations);
            Ok::<_, Error>((found?, counts, op.seconds))
        };
        let result = run(self, &mut work);
        self.modes_work = work;
        let (found, (solves, passes, reorthogonalisations), seconds) = result?;
        let eq = &self.pattern.eq;
        let mut modes = Modes {
            eigenvalues: Vec::new(),
            frequencies: Vec::new(),
            shapes: Vec::new(),
            shift,
            solves,
            passes,
            reorthogonalisations,
            seconds,
        };
        let (thetas, coefficients, m) = found;
        for &theta in &thetas {
            let lambda = shift + 1.0 / theta;
            modes.eigenvalues.push(lambda);
            let f = lambda.abs().sqrt() / (2.0 * std::f64::consts::PI);
            modes.frequencies.push(if lambda < 0.0 { -f } else { f });
        }
        // The vectors are in the operator's order: equation e at position inv[e].
        let t = std::time::Instant::now();
        let inv = self.linear.block_order().map(|(_, inv)| inv);
        // The DOF at each position, in the compressed M's column pointers (n + 1 values,
        // rebuilt by the next analysis's compression): no fresh memory for it.
        let mut position = std::mem::take(&mut self.modes_work.mass.0);
        if position.len() < n {
            position = memory::filled(n, 0usize, "the mode shapes")?;
        }
        for (d, &e) in eq.iter().enumerate() {
            if e != NONE {
                position[inv.map_or(e, |inv| inv[e])] = d;
            }
        }
        modes.shapes = mode_shapes(
            &self.modes_work.q,
            n,
            m,
            &coefficients,
            thetas.len(),
            &position[..n],
            model.dof_count(),
        );
        self.modes_work.mass.0 = position;
        modes.seconds.ritz += t.elapsed().as_secs_f64();
        modes.seconds.total_cpu = crate::phases::thread_cpu() - cpu_started;
        Ok(modes)
    }

    /// Subtract the wrinkled and slack triangles' tangent-only regularisation
    /// (`sensitivity::regularisation_parts`) from the assembled tangent.
    fn remove_regularisation(&mut self, model: &Model, u: &[f64], wrinkle: &[WrinkleState]) {
        let parts = super::sensitivity::regularisation_parts(model, u, wrinkle);
        if parts.is_empty() {
            return;
        }
        let eq = self.pattern.eq.clone();
        let (col_ptr, row_idx) = {
            let s = self.linear.matrix();
            let s = s.symbolic();
            (s.col_ptr().to_vec(), s.row_idx().to_vec())
        };
        let values = self.linear.values_mut();
        for (nodes, k) in parts {
            for a in 0..9 {
                for b in 0..9 {
                    let (i, j) = (eq[3 * nodes[a / 3] + a % 3], eq[3 * nodes[b / 3] + b % 3]);
                    if i == NONE || j == NONE || i > j {
                        continue;
                    }
                    let column = &row_idx[col_ptr[j]..col_ptr[j + 1]];
                    if let Some(p) = column.iter().position(|&r| r == i) {
                        values[col_ptr[j] + p] -= k[(a, b)];
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The row-by-row M product against the column-major one on a 2-D grid's matrix (upper
    /// triangle, CSC) with 4 pseudo-random columns: the same sums in the same order, so the
    /// same result bit for bit.
    #[test]
    fn mass_product_by_rows_is_the_column_product() {
        let (n, cp, ri, v) = crate::solver::split::tests::grid(29, 17);
        let x: Vec<f64> = (0..BLOCK as u64)
            .flat_map(|seed| start_vector(n, seed))
            .collect();
        let (mut by_columns, mut by_rows) = (vec![0.0; BLOCK * n], vec![1.0; BLOCK * n]);
        symmetric_product_columns(&cp, &ri, &v, &x, &mut by_columns, BLOCK);
        let mut rows = vec![0.0; 2 * BLOCK * n];
        symmetric_product_rows::<BLOCK>(&cp, &ri, &v, &x, &mut by_rows, &mut rows);
        assert!(by_columns.iter().any(|y| *y != 0.0));
        assert_eq!(by_rows, by_columns);
    }

    /// The within-block step as matrix products (`cholesky_qr_block`) against modified
    /// Gram-Schmidt column by column in the M inner product (written out here), M a 2-D
    /// grid's matrix (upper triangle, CSC), W 4 pseudo-random columns with a graded scale
    /// (1, 1e-1, 1e-2, 1e-3), M-orthogonal to 4 earlier basis vectors: the same coefficients R to 1e-12
    /// of their largest (measured 4.2e-16), Q R = W and Qᵀ M Q = I to 1e-12 (measured 8.7e-18
    /// and 4.4e-16). A block with two equal columns is refused (None), the basis unchanged.
    #[test]
    fn block_cholesky_qr_matches_gram_schmidt() {
        let (n, cp, ri, v) = crate::solver::split::tests::grid(29, 17);
        let m = |x: &[f64], columns: usize| {
            let mut y = vec![0.0; x.len()];
            symmetric_product_columns(&cp, &ri, &v, x, &mut y, columns);
            y
        };
        let mut basis = Basis::new(n, 4, Vec::new(), Vec::new(), Vec::new()).unwrap();
        basis.begin_block();
        for seed in 10..14u64 {
            let mut x = start_vector(n, seed);
            for k in 0..basis.len() {
                let c = dot(basis.mq(k), &x);
                let qk = basis.q(k).to_vec();
                x.iter_mut().zip(&qk).for_each(|(a, b)| *a -= c * b);
            }
            let mx = m(&x, 1);
            let size = dot(&x, &mx).sqrt();
            basis.push(&x, &mx, size).unwrap();
        }
        let p = 4;
        let w: Vec<f64> = (0..p as u64)
            .flat_map(|seed| {
                start_vector(n, seed)
                    .into_iter()
                    .map(move |x| x * 10f64.powi(-(seed as i32)))
            })
            .collect();
        // W M-orthogonal to the earlier vectors, as the caller's Gram-Schmidt leaves it.
        let mut w = w;
        for column in w.chunks_mut(n) {
            for _ in 0..2 {
                for k in 0..basis.len() {
                    let c = dot(basis.mq(k), column);
                    column
                        .iter_mut()
                        .zip(basis.q(k))
                        .for_each(|(a, b)| *a -= c * b);
                }
            }
        }
        let mw = m(&w, p);
        // Reference: modified Gram-Schmidt against the block's earlier columns, twice.
        let mut reference = vec![0.0; p * p];
        let mut q = w.clone();
        for c in 0..p {
            let mut x = q[c * n..(c + 1) * n].to_vec();
            for _ in 0..2 {
                for i in 0..c {
                    let qi = &q[i * n..(i + 1) * n];
                    let coefficient = dot(&m(qi, 1), &x);
                    reference[i + c * p] += coefficient;
                    x.iter_mut()
                        .zip(qi)
                        .for_each(|(a, b)| *a -= coefficient * b);
                }
            }
            let size = dot(&x, &m(&x, 1)).sqrt();
            reference[c + c * p] = size;
            q[c * n..(c + 1) * n]
                .iter_mut()
                .zip(&x)
                .for_each(|(a, b)| *a = b / size);
        }
        let old = basis.len();
        let total = vec![0.0; old * p];
        let mut scale = 1.0;
        basis.begin_block();
        let out = cholesky_qr_block(
            &mut basis,
            &w,
            &mw,
            p,
            &total,
            old,
            &mut scale,
            Some(0),
            None,
        )
        .unwrap()
        .expect("a well-conditioned block");
        assert_eq!(basis.len(), old + p);
        let largest = reference.iter().fold(0.0f64, |a, x| a.max(x.abs()));
        let mut worst = [0.0f64; 3];
        for c in 0..p {
            assert_eq!(out[c].len(), old + c + 1);
            for i in 0..=c {
                worst[0] = worst[0].max((out[c][old + i] - reference[i + c * p]).abs() / largest);
            }
            // Q R against W.
            for e in 0..n {
                let qr: f64 = (0..=c).map(|i| basis.q(old + i)[e] * out[c][old + i]).sum();
                worst[1] = worst[1].max((qr - w[c * n + e]).abs() / largest);
            }
            for i in 0..old + p {
                let g = dot(basis.mq(i), basis.q(old + c));
                let expected = if i == old + c { 1.0 } else { 0.0 };
                worst[2] = worst[2].max((g - expected).abs());
            }
            // M Q as held equals M applied to Q.
            let mq = m(basis.q(old + c), 1);
            let err = mq
                .iter()
                .zip(basis.mq(old + c))
                .fold(0.0f64, |a, (x, y)| a.max((x - y).abs()));
            assert!(
                err <= 1e-12 * mq.iter().fold(0.0f64, |a, x| a.max(x.abs())),
                "{err:e}"
            );
        }
        eprintln!(
            "R {:e}, Q R - W {:e}, Q^T M Q - I {:e}",
            worst[0], worst[1], worst[2]
        );
        assert!(worst.iter().all(|e| *e <= 1e-12), "{worst:?}");
        // Two equal columns: refused, nothing appended.
        let mut twice = w[..2 * n].to_vec();
        twice.extend_from_slice(&w[..n]);
        let mtwice = m(&twice, 3);
        let before = basis.len();
        let total = vec![0.0; before * 3];
        basis.begin_block();
        let refused = cholesky_qr_block(
            &mut basis,
            &twice,
            &mtwice,
            3,
            &total,
            before,
            &mut scale,
            Some(0),
            None,
        )
        .unwrap();
        assert!(refused.is_none());
        assert_eq!(basis.len(), before);
    }

    /// The modes benchmark's membrane (examples/modes.rs) at `nx` x `ny` cells: 1 m x 0.7 m,
    /// 1 mm, SVK E 1 GPa, ν 0.3, 1000 kg/m³, isotropic prestress 1 kN/m, the boundary clamped;
    /// with one-thread solver settings.
    fn clamped_membrane(nx: usize, ny: usize) -> (Model, super::super::Settings) {
        clamped_rectangle(0.7, nx, ny)
    }

    /// [`clamped_membrane`] with the side `height` in place of 0.7 m.
    fn clamped_rectangle(height: f64, nx: usize, ny: usize) -> (Model, super::super::Settings) {
        let text = serde_json::json!({
            "format": 1, "name": "ClampedMembrane",
            "geometry": {"generators": [{"kind": "rectangle", "name": "s", "origin": [0, 0, 0],
                                         "size": [1.0, height], "divisions": [nx, ny]}]},
            "membranes": [{"name": "m", "triangles": "s", "thickness": 0.001, "density": 1000.0,
                           "material": {"kind": "svk", "E": 1e9, "nu": 0.3},
                           "prestress": {"kind": "isotropic", "n": 1000.0}}],
            "supports": [{"nodes": "s.boundary", "fix": ["x", "y", "z"]}],
            "solver": {"threads": 1}
        })
        .to_string();
        let scene = crate::scene::Scene::from_json(&text).unwrap();
        let settings = super::super::Settings {
            threads: 1,
            ..Default::default()
        };
        (Model::try_build(&scene).unwrap(), settings)
    }

    /// The work space kept in the solver between analyses changes nothing: on a 24 x 17
    /// clamped prestressed membrane, analyses of 6, then 10, then 6 modes on one solver (the
    /// kept basis first grown, then reused larger than needed) give the same frequencies and
    /// shapes, bit for bit, as each count on a fresh solver; the third analysis writes into the
    /// second's basis memory.
    #[test]
    fn kept_work_space_gives_the_fresh_solvers_modes() {
        let (model, settings) = clamped_membrane(24, 17);
        let u = vec![0.0; model.dof_count()];
        let states = vec![WrinkleState::Taut; model.triangles.len()];
        let analyse = |solver: &mut Solver, count: usize| {
            let mass = solver.mass(&model, model.mass_kind).unwrap();
            let modes = solver.modes(&model, mass, &u, &[], &states, count).unwrap();
            (modes.frequencies, modes.shapes)
        };
        let mut kept = Solver::try_new(&model, settings.clone()).unwrap();
        assert_eq!(kept.modes_work.q.capacity(), 0);
        let mut capacity = 0;
        let mut memory = Vec::new();
        for count in [6, 10, 6] {
            let ours = analyse(&mut kept, count);
            let mut fresh = Solver::try_new(&model, settings.clone()).unwrap();
            let theirs = analyse(&mut fresh, count);
            assert_eq!(ours.0.len(), count);
            assert!(ours.0[0] > 20.0, "{:?}", ours.0);
            assert_eq!(ours, theirs, "{count} modes");
            capacity = capacity.max(kept.modes_work.q.capacity());
            assert_eq!(kept.modes_work.q.capacity(), capacity);
            memory.push(kept.modes_work.q.as_ptr());
        }
        assert!(capacity > 0);
        // The third analysis wrote into the second's basis memory.
        assert_eq!(memory[1], memory[2]);
    }

    /// The dense n × n matrix of a symmetric matrix held as its upper triangle (CSC).
    fn dense(
        a: faer::sparse::SparseColMatRef<'_, usize, f64>,
        values: &[f64],
    ) -> nalgebra::DMatrix<f64> {
        let n = a.ncols();
        let s = a.symbolic();
        let mut d = nalgebra::DMatrix::zeros(n, n);
        for j in 0..n {
            let range = s.col_ptr()[j]..s.col_ptr()[j + 1];
            for (&i, &v) in s.row_idx()[range.clone()].iter().zip(&values[range]) {
                d[(i, j)] = v;
                d[(j, i)] = v;
            }
        }
        d
    }

    /// Partial reorthogonalisation loses no mode and adds none, on clustered frequencies: a
    /// clamped square membrane (1 m × 1 m, 16 × 16 cells, 675 equations; the closed form's
    /// f_mn = f_nm are double, the computed pairs agree to 5e-13), its 13 lowest modes (five
    /// double). Reference:
    /// the dense generalised eigenproblem K φ = λ M φ (nalgebra: Cholesky of M, then the
    /// symmetric eigenvalues of L⁻¹ K L⁻ᵀ), and the Sturm count, the number of negative
    /// eigenvalues of the dense K − λ' M (Sylvester's law of inertia) at λ' just above the
    /// highest returned eigenvalue. Asserted: the run reorthogonalised some blocks and not all
    /// (the estimate was used); every eigenvalue equals the dense one of the same rank to 1e-10
    /// relative; the Sturm count at λ' = λ₁₃ (1 + 1e-7) is 13 (no eigenvalue missed below it,
    /// none reported twice); the spectrum holds clusters (pairs within 1e-2 relative); the
    /// shapes are M-orthonormal, |Φᵀ M Φ − I| ≤ 1e-10 entrywise. Measured: 15 passes, 4
    /// reorthogonalised; eigenvalues 4.3e-11 (the same with every block reorthogonalised:
    /// the convergence tolerance's and the dense reference's level); Φᵀ M Φ − I 3.5e-12
    /// (5.6e-15 with every block reorthogonalised).
    #[test]
    fn partial_reorthogonalisation_keeps_clustered_modes() {
        let (model, settings) = clamped_rectangle(1.0, 16, 16);
        let mut solver = Solver::try_new(&model, settings).unwrap();
        let n = solver.pattern.n;
        assert_eq!(n, 675);
        let mass = solver.mass(&model, model.mass_kind).unwrap();
        let u = vec![0.0; model.dof_count()];
        let states = vec![WrinkleState::Taut; model.triangles.len()];
        let count = 13;
        let modes = solver
            .modes(&model, mass.clone(), &u, &[], &states, count)
            .unwrap();
        assert_eq!(modes.eigenvalues.len(), count);
        eprintln!(
            "{} passes, {} blocks reorthogonalised against the whole basis",
            modes.passes, modes.reorthogonalisations
        );
        assert!(modes.reorthogonalisations >= 1, "{modes:?}");
        assert!(modes.reorthogonalisations + 2 < modes.passes, "{modes:?}");
        // K = (K − σM) + σM from the values the analysis left in the solver.
        let a = solver.linear.matrix();
        let k_values: Vec<f64> = solver
            .linear
            .values()
            .iter()
            .zip(mass.values())
            .map(|(k, m)| k + modes.shift * m)
            .collect();
        let (k, m) = (dense(a, &k_values), dense(a, mass.values()));
        let l = nalgebra::Cholesky::new(m.clone())
            .expect("M positive definite")
            .l();
        let li = l.clone().try_inverse().unwrap();
        let c = &li * &k * li.transpose();
        let c = 0.5 * (&c + c.transpose());
        let mut exact: Vec<f64> = nalgebra::SymmetricEigen::new(c)
            .eigenvalues
            .iter()
            .copied()
            .collect();
        exact.sort_by(f64::total_cmp);
        let mut worst = 0.0f64;
        for (lambda, e) in modes.eigenvalues.iter().zip(&exact) {
            worst = worst.max((lambda - e).abs() / e);
        }
        eprintln!("eigenvalues against the dense ones: {worst:e} relative");
        assert!(
            worst <= 1e-10,
            "{worst:e}: {:?} against {:?}",
            modes.eigenvalues,
            &exact[..count]
        );
        let pairs = modes
            .eigenvalues
            .windows(2)
            .filter(|w| (w[1] - w[0]) / w[1] < 1e-2)
            .count();
        assert!(pairs >= 3, "{:?}", modes.eigenvalues);
        // The Sturm count just above the highest returned eigenvalue.
        let top = modes.eigenvalues[count - 1] * (1.0 + 1e-7);
        let shifted = &k - top * &m;
        let negative = nalgebra::SymmetricEigen::new(shifted)
            .eigenvalues
            .iter()
            .filter(|v| **v < 0.0)
            .count();
        assert_eq!(
            negative, count,
            "Sturm count at {top}: {:?}",
            modes.eigenvalues
        );
        // Φᵀ M Φ = I over the equations.
        let eq = &solver.pattern.eq;
        let phi = nalgebra::DMatrix::from_fn(n, count, |i, c| {
            let d = eq.iter().position(|&e| e == i).unwrap();
            modes.shapes[c][d]
        });
        let g = phi.transpose() * &m * &phi;
        let off = (g - nalgebra::DMatrix::<f64>::identity(count, count)).amax();
        eprintln!("shapes: |Phi^T M Phi - I| = {off:e}");
        assert!(off <= 1e-10, "{off:e}");
    }

    /// `Ldlt::solve_block` against faer's solve (`Ldlt::solve_columns`) on the modes
    /// benchmark's matrix (examples/modes.rs: the clamped prestressed 1 m x 0.7 m membrane,
    /// 230 x 161 cells, 109 920 equations), K − σM as `Solver::modes` leaves it factored, with
    /// 1, 3, 4 and 8 pseudo-random right-hand sides: the same solution to 1e-12 of its largest
    /// entry (measured 1.5e-15).
    #[test]
    fn block_solve_matches_faer_on_the_benchmark_matrix() {
        let (model, settings) = clamped_membrane(230, 161);
        let mut solver = Solver::try_new(&model, settings).unwrap();
        let n = solver.pattern.n;
        assert_eq!(n, 109_920);
        let mass = solver.mass(&model, model.mass_kind).unwrap();
        // The flat, uniformly prestressed membrane is in equilibrium at u = 0 (no inputs).
        let u = vec![0.0; model.dof_count()];
        let states = vec![WrinkleState::Taut; model.triangles.len()];
        let modes = solver.modes(&model, mass, &u, &[], &states, 1).unwrap();
        assert!(
            (modes.frequencies[0] - 27.5726).abs() < 1e-3,
            "{:?}",
            modes.frequencies
        );
        let mut worst = 0.0f64;
        for columns in [1, 3, 4, 8] {
            let rhs: Vec<f64> = (0..columns as u64)
                .flat_map(|seed| start_vector(n, 100 + seed))
                .collect();
            let (mut ours, mut faers) = (rhs.clone(), rhs);
            solver.linear.solve_block(&mut ours, columns).unwrap();
            solver.linear.solve_columns(&mut faers, columns).unwrap();
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
        eprintln!("block solve against faer's: {worst:e} of the largest entry");
    }
}
