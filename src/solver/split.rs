//! Two-domain LDLT on two threads (`solver.threads` >= 2, large models): the tangent's
//! equations are split into two halves A and B and a separator S such that no entry of K
//! couples A with B,
//!
//! ```text
//!     | K_AA   0    K_AS |
//! K = |  0    K_BB  K_BS |
//!     | K_SA  K_SB  K_SS |
//! ```
//!
//! Each half h is its own sparse matrix M_h = [K_hh K_hS; K_Sh K_SS], numbered with faer's AMD
//! ordering of K_hh first and S last, and factored by faer (`Par::Seq`) on its own thread: the
//! solving thread factors A while a helper (`threads.rs`) factors B. The trailing S block of
//! M_h's factor, L_SS D_S L_SS^T, is S_h = K_SS - K_Sh K_hh^-1 K_hS. The Schur complement of
//! both halves, S = K_SS - K_SA K_AA^-1 K_AS - K_SB K_BB^-1 K_BS = S_A + S_B - K_SS, is dense
//! (|S| is one ring of nodes across the mesh) and is factored by faer's dense LDLT.
//!
//! Why: faer 0.24.4 eliminates the supernodes of one factorization one after another and
//! parallelises only the dense kernels inside a supernode (docs/performance.md, "Threads"),
//! which gave 8 % on two threads. The two halves here are independent subtrees of the
//! elimination, so they run side by side.
//!
//! A solve: forward substitution over each half's own columns (both halves at once) gives
//! z_h = L_hh^-1 b_h and, in its S rows, -K_Sh K_hh^-1 b_h; then
//! S x_S = b_S - K_SA K_AA^-1 b_A - K_SB K_BB^-1 b_B (dense); then back substitution over each half's own columns with x_S
//! known gives x_h = K_hh^-1 (b_h - K_hS x_S).
//!
//! The separator is a level set of a breadth-first search from a pseudo-peripheral equation
//! (a level set separates the levels before it from those after it): first the level that
//! balances the equations best with at least 35 % of them on each side, then moved (secant
//! steps, at most 3 more symbolic analyses) until the two halves' factorization flops agree,
//! since the factorization waits for the heavier half; the solving thread takes the lighter.
//! Where there is no admissible level, or it is too large ([`MAX_SEPARATOR`]), the solver keeps
//! the one-thread factorization.
//!
//! Pivots: each half regularizes its tiny pivots like the one-thread factorization
//! (`linear.rs`), and so does the dense LDLT of S. Results agree with one thread to
//! round-off: the elimination order differs.

use super::threads::Pool;
use crate::error::{Breakdown, Error};
use crate::memory::{self, OutOfMemory};
use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::linalg::cholesky::ldlt::factor::LdltRegularization;
use faer::linalg::matmul::triangular::{self, BlockStructure};
use faer::reborrow::{Reborrow, ReborrowMut};
use faer::sparse::linalg::cholesky::{SymbolicCholesky, SymbolicCholeskyRaw, SymmetricOrdering};
use faer::sparse::{SparseColMat, SymbolicSparseColMat};
use faer::{Accum, Conj, MatMut, MatRef, Par};
use std::sync::{Arc, Mutex, MutexGuard, RwLock};

/// K's upper CSC pattern (column pointers, row indices), shared with the helper thread while
/// the halves of [`Split::try_at`] are built.
pub type SharedPattern = Arc<(Vec<usize>, Vec<usize>)>;

/// Largest separator (equations) the dense Schur complement is built for: its buffers take
/// 7 |S|^2 doubles (|S| = 2500: 350 MB) and its LDLT |S|^3 / 3 flops.
pub const MAX_SEPARATOR: usize = 2500;

/// Smallest share of the equations on each side of the separator.
const BALANCE: f64 = 0.35;

#[derive(Clone, Copy, PartialEq, Eq)]
enum Phase {
    Factor,
    Forward,
    Backward,
}

/// K's values (upper CSC) and the scaling S (one entry per equation; empty: none), lent to
/// the halves for a factorization's gathers ([`Split::factor_shared`]).
#[derive(Default)]
struct Source {
    k: Vec<f64>,
    scale: Vec<f64>,
}

/// One half: its own equations (domain in AMD order, then the separator) and its factor.
struct Half {
    /// Global equation of each local one: the domain's `nd`, then the separator's.
    eq: Vec<usize>,
    nd: usize,
    /// Position in K's values (upper CSC) of each stored value of `matrix` (`u32`: K's
    /// entries are counted against `u32` in [`Split::try_new`]).
    map: Vec<u32>,
    matrix: SparseColMat<usize, f64>,
    symbolic: SymbolicCholesky<usize>,
    l_values: Vec<f64>,
    mem: MemBuffer,
    /// L_SS (unit lower, dense) of the factor's separator block, then S_h (lower).
    lss: Dense,
    w: Dense,
    s_block: Dense,
    d: Vec<f64>,
    /// Local right-hand side / solution.
    x: Vec<f64>,
    /// A supernode's rows below its domain columns in a solve (as long as the longest).
    tmp: Vec<f64>,
    /// Factored in single precision (`linear.rs`, "Mixed precision"): the values gathered
    /// into `v32`, the factor in `l32`, a solve's vectors `x32` and `tmp32`; the f64
    /// buffers above are then never written (their pages never touched), and the other way
    /// round.
    single: bool,
    v32: Vec<f32>,
    l32: Vec<f32>,
    x32: Vec<f32>,
    tmp32: Vec<f32>,
    reg: (f64, f64),
    /// Where the helper's half gathers K's values from, scaled, at the start of a
    /// factorization on its own thread ([`Split::factor_shared`]; None: gathered before).
    source: Option<Arc<RwLock<Source>>>,
    /// Whether the next factorization gathers from `source` first.
    gathers: bool,
    phase: Phase,
    status: Result<(), Error>,
}

fn lock(h: &Mutex<Half>) -> MutexGuard<'_, Half> {
    h.lock().unwrap_or_else(|e| e.into_inner())
}

impl Half {
    fn run(&mut self) {
        self.status = match self.phase {
            Phase::Factor => {
                if let (true, Some(source)) = (self.gathers, self.source.clone()) {
                    let source = source.read().unwrap_or_else(|e| e.into_inner());
                    gather_scaled(self, &source.k, &source.scale);
                }
                self.factor()
            }
            Phase::Forward => {
                self.forward();
                Ok(())
            }
            Phase::Backward => {
                self.backward();
                Ok(())
            }
        };
    }

    /// Flops of the half's numeric factorization (sum of column counts squared).
    fn flops(&self) -> f64 {
        let sym = self.supernodal();
        let mut f = 0.0;
        for s in 0..sym.n_supernodes() {
            let b = sym.supernode_begin()[s];
            let e = sym.supernode_end()[s];
            let p = (sym.col_ptr_for_row_idx()[s + 1] - sym.col_ptr_for_row_idx()[s]) as f64;
            for j in b..e {
                let c = (e - j) as f64 + p;
                f += c * c;
            }
        }
        f
    }

    fn supernodal(
        &self,
    ) -> &faer::sparse::linalg::cholesky::supernodal::SymbolicSupernodalCholesky<usize> {
        match self.symbolic.raw() {
            SymbolicCholeskyRaw::Supernodal(s) => s,
            // try_new keeps only supernodal halves.
            SymbolicCholeskyRaw::Simplicial(_) => unreachable!("a supernodal half"),
        }
    }

    fn factor(&mut self) -> Result<(), Error> {
        let phase = crate::phases::start("solve: a half's numeric LDLT");
        if self.single {
            super::factor::numeric_ldlt(
                &self.symbolic,
                &mut self.l32,
                faer::sparse::SparseColMatRef::new(self.matrix.symbolic(), &self.v32),
                self.reg,
                &mut self.mem,
                "a half of the tangent",
            )?;
        } else {
            super::factor::numeric_ldlt(
                &self.symbolic,
                &mut self.l_values,
                self.matrix.as_ref(),
                self.reg,
                &mut self.mem,
                "a half of the tangent",
            )?;
        }
        drop(phase);
        // The factor taken out while `self` is borrowed for the separator's blocks.
        if self.single {
            let l = std::mem::take(&mut self.l32);
            self.separator_block(&l);
            self.l32 = l;
        } else {
            let l = std::mem::take(&mut self.l_values);
            self.separator_block(&l);
            self.l_values = l;
        }
        Ok(())
    }

    /// The separator's block of the factor `values` (this half's, f64 or f32): L_SS and D_S,
    /// then S_h = L_SS D_S L_SS^T in f64.
    fn separator_block<T: Copy + Into<f64> + Default>(&mut self, values: &[T]) {
        let _phase = crate::phases::start("solve: a half's S block (L_SS D_S L_SS^T)");
        // L_SS and D_S of the separator block, then S_h = L_SS D_S L_SS^T.
        let (nd, ns) = (self.nd, self.eq.len() - self.nd);
        let mut lss = std::mem::take(&mut self.lss);
        let mut d = std::mem::take(&mut self.d);
        lss.values.fill(0.0);
        let sym = self.supernodal();
        for s in 0..sym.n_supernodes() {
            let (start, ls, pattern) = supernode(sym, values, s);
            let ncols = ls.ncols();
            if start + ncols <= nd {
                continue;
            }
            for c in nd.saturating_sub(start)..ncols {
                let jl = start + c - nd;
                d[jl] = ls[(c, c)].into();
                lss[(jl, jl)] = 1.0;
                for r in c + 1..ncols {
                    lss[(start + r - nd, jl)] = ls[(r, c)].into();
                }
                for (i, &p) in pattern.iter().enumerate() {
                    lss[(p - nd, jl)] = ls[(ncols + i, c)].into();
                }
            }
        }
        for j in 0..ns {
            for i in j..ns {
                self.w[(i, j)] = lss[(i, j)] * d[j];
            }
        }
        triangular::matmul(
            self.s_block.as_mut(),
            BlockStructure::TriangularLower,
            Accum::Replace,
            self.w.as_ref(),
            BlockStructure::TriangularLower,
            lss.as_ref().transpose(),
            BlockStructure::TriangularUpper,
            1.0,
            Par::Seq,
        );
        self.lss = lss;
        self.d = d;
    }

    /// x := D_hh^-1 L_hh^-1 x over the domain's columns ([`forward`]), in the factor's
    /// precision.
    fn forward(&mut self) {
        let sym = match self.symbolic.raw() {
            SymbolicCholeskyRaw::Supernodal(s) => s,
            SymbolicCholeskyRaw::Simplicial(_) => unreachable!("a supernodal half"),
        };
        if self.single {
            forward(sym, &self.l32, self.nd, &mut self.x32, &mut self.tmp32);
        } else {
            forward(sym, &self.l_values, self.nd, &mut self.x, &mut self.tmp);
        }
    }

    /// x_h := L_hh^-T (x_h - L_Sh^T x_S) ([`backward`]), in the factor's precision.
    fn backward(&mut self) {
        let sym = match self.symbolic.raw() {
            SymbolicCholeskyRaw::Supernodal(s) => s,
            SymbolicCholeskyRaw::Simplicial(_) => unreachable!("a supernodal half"),
        };
        if self.single {
            backward(sym, &self.l32, self.nd, &mut self.x32, &mut self.tmp32);
        } else {
            backward(sym, &self.l_values, self.nd, &mut self.x, &mut self.tmp);
        }
    }

    /// The half's forward result in separator row k (f64 whatever the factor's precision).
    fn separator_value(&self, k: usize) -> f64 {
        if self.single {
            self.x32[self.nd + k] as f64
        } else {
            self.x[self.nd + k]
        }
    }

    /// The separator's solution into the half's vector before [`Half::backward`].
    fn set_separator(&mut self, xs: &[f64]) {
        let nd = self.nd;
        if self.single {
            for (t, &v) in self.x32[nd..].iter_mut().zip(xs) {
                *t = v as f32;
            }
        } else {
            self.x[nd..].copy_from_slice(xs);
        }
    }
}

/// The values of supernode `s` of `sym` in the factor `values`: (first column, its dense
/// block, the rows below it).
fn supernode<'a, T>(
    sym: &'a faer::sparse::linalg::cholesky::supernodal::SymbolicSupernodalCholesky<usize>,
    values: &'a [T],
    s: usize,
) -> (usize, MatRef<'a, T>, &'a [usize]) {
    let start = sym.supernode_begin()[s];
    let end = sym.supernode_end()[s];
    let pattern = &sym.row_idx()[sym.col_ptr_for_row_idx()[s]..sym.col_ptr_for_row_idx()[s + 1]];
    let vals = &values[sym.col_ptr_for_val()[s]..sym.col_ptr_for_val()[s + 1]];
    let ncols = end - start;
    (
        start,
        MatRef::from_column_major_slice(vals, ncols + pattern.len(), ncols),
        pattern,
    )
}

/// x := D_hh^-1 L_hh^-1 x over a half's `nd` domain columns of the factor `l`; the separator
/// rows receive -L_Sh L_hh^-1 x_h (= -K_Sh K_hh^-1 b_h when they start at 0). Supernode by
/// supernode as faer's own solve: a dense triangular solve of its top block, one dense
/// product of the rows below (into `tmp`), then those rows updated.
fn forward<T: faer::traits::RealField + Copy>(
    sym: &faer::sparse::linalg::cholesky::supernodal::SymbolicSupernodalCholesky<usize>,
    l: &[T],
    nd: usize,
    x: &mut [T],
    tmp: &mut [T],
) {
    let one = faer::traits::math_utils::from_f64::<T>(1.0);
    for s in 0..sym.n_supernodes() {
        let (start, ls, pattern) = supernode(sym, l, s);
        if start >= nd {
            break;
        }
        let ncols = ls.ncols();
        let k = ncols.min(nd - start);
        let (top, rest) = x[start..].split_at_mut(k);
        let mut top = MatMut::from_column_major_slice_mut(top, k, 1);
        faer::linalg::triangular_solve::solve_unit_lower_triangular_in_place(
            ls.submatrix(0, 0, k, k),
            top.rb_mut(),
            Par::Seq,
        );
        // Rows below the domain's columns: the supernode's own separator columns
        // (k..ncols), then its pattern.
        let below = ls.nrows() - k;
        let t = MatMut::from_column_major_slice_mut(&mut tmp[..below], below, 1);
        faer::linalg::matmul::matmul(
            t,
            Accum::Replace,
            ls.submatrix(k, 0, below, k),
            top.rb(),
            one,
            Par::Seq,
        );
        let inner = ncols - k;
        for (xi, &t) in rest[..inner].iter_mut().zip(&tmp[..inner]) {
            *xi -= t;
        }
        for (&p, &t) in pattern.iter().zip(&tmp[inner..below]) {
            x[p] -= t;
        }
        for c in 0..k {
            x[start + c] /= ls[(c, c)];
        }
    }
}

/// With the separator's solution in x[nd..]: x_h := L_hh^-T (x_h - L_Sh^T x_S) over the
/// domain's columns of the factor `l`, last to first (dense blocks per supernode, as
/// [`forward`]).
fn backward<T: faer::traits::RealField + Copy>(
    sym: &faer::sparse::linalg::cholesky::supernodal::SymbolicSupernodalCholesky<usize>,
    l: &[T],
    nd: usize,
    x: &mut [T],
    tmp: &mut [T],
) {
    let minus_one = faer::traits::math_utils::from_f64::<T>(-1.0);
    for s in (0..sym.n_supernodes()).rev() {
        let (start, ls, pattern) = supernode(sym, l, s);
        if start >= nd {
            continue;
        }
        let ncols = ls.ncols();
        let k = ncols.min(nd - start);
        let below = ls.nrows() - k;
        let inner = ncols - k;
        tmp[..inner].copy_from_slice(&x[start + k..start + ncols]);
        for (t, &p) in tmp[inner..below].iter_mut().zip(pattern) {
            *t = x[p];
        }
        let mut top = MatMut::from_column_major_slice_mut(&mut x[start..start + k], k, 1);
        faer::linalg::matmul::matmul(
            top.rb_mut(),
            Accum::Add,
            ls.submatrix(k, 0, below, k).transpose(),
            MatRef::from_column_major_slice(&tmp[..below], below, 1),
            minus_one,
            Par::Seq,
        );
        faer::linalg::triangular_solve::solve_unit_upper_triangular_in_place(
            ls.submatrix(0, 0, k, k).transpose(),
            top,
            Par::Seq,
        );
    }
}

/// The two halves, the separator and the dense Schur complement.
pub struct Split {
    pool: Arc<Pool>,
    a: Arc<Mutex<Half>>,
    b: Arc<Mutex<Half>>,
    /// Global equations of the separator.
    s_eq: Vec<usize>,
    /// K_SS's entries: (row, column) in the separator (row >= column) and position in K.
    kss: Vec<(usize, usize, usize)>,
    /// LDLT of S (unit L below the diagonal, D on it).
    schur: Dense,
    schur_mem: MemBuffer,
    xs: Vec<f64>,
    /// K's values and S during a factorization ([`Split::factor_shared`]), read by both
    /// halves' gathers; empty between factorizations.
    source: Arc<RwLock<Source>>,
    /// Factorization flops of the two halves at the level that balances their equations
    /// (read by the unit tests).
    #[cfg(test)]
    counted: [f64; 2],
    /// The same of the halves kept (the solving thread's, the helper's).
    #[cfg(test)]
    flops: [f64; 2],
}

impl Split {
    /// A split of the pattern (upper CSC, n equations) when it has a small balanced
    /// separator (None otherwise: the caller keeps the one-thread factorization). Runs the
    /// symbolic analysis of both halves; every buffer is allocated fallibly.
    pub fn try_new(
        n: usize,
        col_ptr: &[usize],
        row_idx: &[usize],
        rank: Option<&[usize]>,
        pool: Arc<Pool>,
    ) -> Result<Option<Split>, OutOfMemory> {
        // The halves' maps hold K's positions as u32 (as the assembly's do): a larger K
        // stays on one thread.
        if pool.helpers() == 0 || row_idx.len() as u64 > u32::MAX as u64 {
            return Ok(None);
        }
        let Some(levels) = separator_levels(n, col_ptr, row_idx)? else {
            return Ok(None);
        };
        // The two halves (symbolic analysis only) with level `sep` as the separator.
        let pair = |sep: usize| -> Result<Option<(Vec<usize>, Half, Half)>, OutOfMemory> {
            let side = |l: usize| {
                if l < sep {
                    0
                } else if l == sep {
                    2
                } else {
                    1
                }
            };
            let s_eq = select(n, |i| side(levels.level[i]) == 2)?;
            let mut halves = Vec::new();
            for h in 0..2 {
                let domain = select(n, |i| side(levels.level[i]) == h)?;
                match Half::try_new(n, col_ptr, row_idx, &domain, &s_eq, rank)? {
                    Some(half) => halves.push(half),
                    None => return Ok(None),
                }
            }
            let b = halves.pop().expect("two halves");
            let a = halves.pop().expect("two halves");
            Ok(Some((s_eq, a, b)))
        };
        let Some(mut chosen) = pair(levels.sep)? else {
            return Ok(None);
        };
        // Equal equation counts do not make equal work: the factorization waits for the
        // slower half (17 % more flops on one side of the 300k-DOF disc). The separator moves
        // towards the heavier half: the difference of the halves' flops as a function of the
        // equations before the separator, root found by the secant method (the first step
        // takes each side's flops per equation as constant), at most 3 more splits analysed;
        // the split whose larger half has the fewest flops is kept.
        #[cfg(test)]
        let counted = [chosen.1.flops(), chosen.2.flops()];
        let heavier = |c: &(Vec<usize>, Half, Half)| c.1.flops().max(c.2.flops());
        let difference = |c: &(Vec<usize>, Half, Half)| c.1.flops() - c.2.flops();
        let mut tried = vec![levels.sep];
        let mut points = vec![(levels.before(levels.sep) as f64, difference(&chosen))];
        let total = chosen.1.flops() + chosen.2.flops();
        for _ in 0..3 {
            let (x1, d1) = points[points.len() - 1];
            if d1.abs() <= 0.02 * total {
                break;
            }
            let target = if points.len() == 1 {
                let (na, nb) = (chosen.1.nd as f64, chosen.2.nd as f64);
                let (fa, fb) = (chosen.1.flops(), chosen.2.flops());
                x1 - (fa - fb) / (fa / na + fb / nb)
            } else {
                // Secant through the two points that bracket the root, else the last two.
                let (x0, d0) = points
                    .iter()
                    .copied()
                    .filter(|&(_, d)| d.signum() != d1.signum())
                    .min_by(|p, q| (p.0 - x1).abs().total_cmp(&(q.0 - x1).abs()))
                    .unwrap_or(points[points.len() - 2]);
                if d1 == d0 {
                    break;
                }
                x1 - d1 * (x1 - x0) / (d1 - d0)
            };
            let next = (0..levels.size.len())
                .filter(|&l| !tried.contains(&l) && levels.admissible(l))
                .min_by(|&x, &y| {
                    let d = |l: usize| (levels.before(l) as f64 - target).abs();
                    d(x).total_cmp(&d(y))
                });
            let Some(l) = next else { break };
            tried.push(l);
            let Some(other) = pair(l)? else { break };
            points.push((levels.before(l) as f64, difference(&other)));
            if heavier(&other) < heavier(&chosen) {
                chosen = other;
            }
        }
        let (s_eq, a, b) = chosen;
        Split::finish(
            n,
            col_ptr,
            row_idx,
            s_eq,
            (a, b),
            pool,
            #[cfg(test)]
            counted,
        )
    }

    /// A split at the top separator of a nested-dissection order (`dissect.rs`): `rank` the
    /// position of every equation in the order, `top` the equations of the first half, the
    /// second and the separator, in this order; `pattern` K's upper CSC (column pointers, row
    /// indices). None when the separator is too large or the halves too unequal (the caller
    /// then splits as [`Split::try_new`] does).
    ///
    /// The two halves are built side by side: the second (its matrix, symbolic analysis and
    /// buffers) on the pool's helper, which holds a reference to `pattern` only while it runs,
    /// the first on the calling thread. The halves are those a serial build makes.
    pub fn try_at(
        n: usize,
        pattern: &SharedPattern,
        rank: &[usize],
        top: [usize; 3],
        pool: Arc<Pool>,
    ) -> Result<Option<Split>, OutOfMemory> {
        let (col_ptr, row_idx) = (&pattern.0[..], &pattern.1[..]);
        let least = (BALANCE * n as f64) as usize;
        if pool.helpers() == 0
            || row_idx.len() as u64 > u32::MAX as u64
            || top[2] > MAX_SEPARATOR
            || top[0].min(top[1]) < least
            || top.iter().sum::<usize>() != n
        {
            return Ok(None);
        }
        let what = "the two-domain factorization";
        let mut by_position = memory::zeros::<usize>(n, what)?;
        for (g, &r) in rank.iter().enumerate() {
            by_position[r] = g;
        }
        // by_position is in the order: each domain's equations are in it already, and each
        // half's numbering is its domain, then the separator.
        let (first, rest) = by_position.split_at(top[0]);
        let (second, s_eq) = rest.split_at(top[1]);
        let numbering = |domain: &[usize]| -> Result<Vec<usize>, OutOfMemory> {
            let mut eq = memory::with_capacity(domain.len() + s_eq.len(), what)?;
            eq.extend_from_slice(domain);
            eq.extend_from_slice(s_eq);
            Ok(eq)
        };
        let (eq_a, eq_b) = (numbering(first)?, numbering(second)?);
        let s_eq = memory::copy(s_eq, what)?;
        drop(by_position);
        // The second half on the helper: its input is taken (and its reference to the
        // pattern dropped) inside the job, so the caller holds the pattern alone afterwards.
        type Built = Result<Option<Half>, OutOfMemory>;
        let input = Arc::new(Mutex::new(Some((Arc::clone(pattern), eq_b, top[1]))));
        let output: Arc<Mutex<Option<Built>>> = Arc::new(Mutex::new(None));
        let (job_input, job_output) = (Arc::clone(&input), Arc::clone(&output));
        let depth = crate::phases::depth();
        pool.set_job(
            0,
            Box::new(move || {
                let taken = job_input.lock().unwrap_or_else(|e| e.into_inner()).take();
                if let Some((pattern, eq, nd)) = taken {
                    let _phase = crate::phases::start_under("half B (on the helper)", depth);
                    let half = Half::numbered(n, &pattern.0, &pattern.1, eq, nd)
                        .and_then(|h| h.map(Half::allocated).transpose());
                    drop(pattern);
                    *job_output.lock().unwrap_or_else(|e| e.into_inner()) = Some(half);
                }
            }),
        );
        pool.start(0);
        let phase = crate::phases::start("half A");
        let a = Half::numbered(n, col_ptr, row_idx, eq_a, top[0])
            .and_then(|h| h.map(Half::allocated).transpose());
        drop(phase);
        // Always waited for, whatever half A gave: the helper is idle and holds nothing after.
        let waited = pool.wait(0);
        drop(input);
        let b = output.lock().unwrap_or_else(|e| e.into_inner()).take();
        let (Some(a), Ok(()), Some(Some(b))) = (a?, waited, b.transpose()?) else {
            // A coupling between the domains, a simplicial half or a helper that failed:
            // the caller splits another way.
            return Ok(None);
        };
        let _phase = crate::phases::start("halves' buffers, K_SS (Split::finish)");
        #[cfg(test)]
        let counted = [a.flops(), b.flops()];
        Split::finish(
            n,
            col_ptr,
            row_idx,
            s_eq,
            (a, b),
            pool,
            #[cfg(test)]
            counted,
        )
    }

    /// The split of the halves chosen: numeric buffers, K_SS's entries, the helper's job.
    fn finish(
        n: usize,
        col_ptr: &[usize],
        row_idx: &[usize],
        s_eq: Vec<usize>,
        (mut a, mut b): (Half, Half),
        pool: Arc<Pool>,
        #[cfg(test)] counted: [f64; 2],
    ) -> Result<Option<Split>, OutOfMemory> {
        let what = "the two-domain factorization";
        // The solving thread gathers its half's values after starting the helper and forms
        // the separator's Schur complement after both: it takes the lighter half.
        if a.flops() > b.flops() {
            std::mem::swap(&mut a, &mut b);
        }
        if !a.is_allocated() {
            a.allocate()?;
        }
        if !b.is_allocated() {
            b.allocate()?;
        }
        let (a, b) = (Arc::new(Mutex::new(a)), Arc::new(Mutex::new(b)));
        let ns = s_eq.len();
        let mut pos = memory::filled(n, usize::MAX, what)?;
        for (k, &g) in s_eq.iter().enumerate() {
            pos[g] = k;
        }
        let entries: usize = s_eq.iter().map(|&j| col_ptr[j + 1] - col_ptr[j]).sum();
        let mut kss = memory::with_capacity(entries, what)?;
        // The separator's columns in K's order (not a pass over all of K's columns).
        let mut columns = memory::copy(&s_eq, what)?;
        columns.sort_unstable();
        for j in columns {
            let column = col_ptr[j]..col_ptr[j + 1];
            for (p, &i) in column.clone().zip(&row_idx[column]) {
                if pos[i] != usize::MAX {
                    kss.push((pos[i].max(pos[j]), pos[i].min(pos[j]), p));
                }
            }
        }
        let schur_mem = MemBuffer::try_new(
            faer::linalg::cholesky::ldlt::factor::cholesky_in_place_scratch::<f64>(
                ns,
                Par::Seq,
                Default::default(),
            ),
        )
        .map_err(|_| OutOfMemory {
            what,
            bytes: (ns * 8) as u64,
        })?;
        #[cfg(test)]
        let flops = [lock(&a).flops(), lock(&b).flops()];
        let source = Arc::new(RwLock::new(Source::default()));
        lock(&b).source = Some(Arc::clone(&source));
        let job = Arc::clone(&b);
        pool.set_job(0, Box::new(move || lock(&job).run()));
        Ok(Some(Split {
            source,
            pool,
            a,
            b,
            s_eq,
            kss,
            schur: dense(ns, what)?,
            schur_mem,
            xs: memory::zeros(ns, what)?,
            #[cfg(test)]
            counted,
            #[cfg(test)]
            flops,
        }))
    }

    /// Equations in (A, B, S).
    pub fn sizes(&self) -> (usize, usize, usize) {
        (lock(&self.a).nd, lock(&self.b).nd, self.s_eq.len())
    }

    /// Factorization flops (sums of squared column counts) of the halves kept (the solving
    /// thread's, the helper's) and of the halves at the level that balanced their equations.
    #[cfg(test)]
    pub fn flops(&self) -> ([f64; 2], [f64; 2]) {
        (self.flops, self.counted)
    }

    /// Flops of one factorization (Σ c², c a column's entries below the diagonal): both
    /// halves' factors, each with the separator block, and the separator's dense LDLT.
    pub fn factor_flops(&self) -> f64 {
        let ns = self.s_eq.len() as f64;
        super::factor::flops(&lock(&self.a).symbolic)
            + super::factor::flops(&lock(&self.b).symbolic)
            + ns * (ns - 1.0) * (2.0 * ns - 1.0) / 6.0
    }

    /// Factor both halves in single precision, or in double ([`Half::set_single`]); the
    /// separator's Schur complement stays f64 either way. A factor held is then stale.
    pub fn set_single(&mut self, single: bool) -> Result<(), OutOfMemory> {
        lock(&self.a).set_single(single)?;
        lock(&self.b).set_single(single)
    }

    /// Stored entries of both halves' factors.
    pub fn factor_nonzeros(&self) -> usize {
        lock(&self.a).symbolic.len_val() + lock(&self.b).symbolic.len_val()
    }

    /// Factor K (its upper CSC values), regularizing pivots with (delta, epsilon): unscaled
    /// [`Split::factor_shared`] of a copy of `k`.
    pub fn factor(&mut self, k: &[f64], reg: (f64, f64)) -> Result<(), Error> {
        let mut k = memory::copy(k, "a copy of the tangent's values")?;
        self.factor_shared(&mut k, &mut Vec::new(), reg)
    }

    /// [`Split::factor`] of S K S (S diagonal, `scale`, one entry per equation; empty: K
    /// itself), where each half gathers its values from `k` and scales them on its own
    /// thread: K is not scaled in place (and unscaled after) and the helper's half is not
    /// gathered on the solving thread, three passes over K's values that ran on one thread.
    /// The same factor as [`Split::factor`] of the values scaled in place, bit for bit (S K S
    /// takes the same products). `k` and `scale` are lent to the halves (moved, not copied:
    /// nothing is allocated) and are back when this returns.
    pub fn factor_shared(
        &mut self,
        k: &mut Vec<f64>,
        scale: &mut Vec<f64>,
        reg: (f64, f64),
    ) -> Result<(), Error> {
        {
            let mut source = self.source.write().unwrap_or_else(|e| e.into_inner());
            std::mem::swap(&mut source.k, k);
            std::mem::swap(&mut source.scale, scale);
        }
        let result = self.factor_lent(reg);
        let mut source = self.source.write().unwrap_or_else(|e| e.into_inner());
        std::mem::swap(&mut source.k, k);
        std::mem::swap(&mut source.scale, scale);
        result
    }

    /// [`Split::factor_shared`] with K and S in `self.source`.
    fn factor_lent(&mut self, reg: (f64, f64)) -> Result<(), Error> {
        {
            let mut b = lock(&self.b);
            b.gathers = true;
            b.reg = reg;
            b.phase = Phase::Factor;
        }
        self.pool.start(0);
        let mine = {
            let mut a = lock(&self.a);
            {
                let source = self.source.read().unwrap_or_else(|e| e.into_inner());
                gather_scaled(&mut a, &source.k, &source.scale);
            }
            a.reg = reg;
            a.phase = Phase::Factor;
            a.run();
            std::mem::replace(&mut a.status, Ok(()))
        };
        let waited = {
            let _phase = crate::phases::start("solve: factor, wait for the helper's half");
            self.pool.wait(0)
        };
        lock(&self.b).gathers = false;
        waited?;
        mine?;
        let _phase = crate::phases::start("solve: factor, the separator's Schur LDLT");
        let a = lock(&self.a);
        let b = lock(&self.b);
        b.status.clone()?;
        let ns = self.s_eq.len();
        for j in 0..ns {
            for i in j..ns {
                self.schur[(i, j)] = a.s_block[(i, j)] + b.s_block[(i, j)];
            }
        }
        let source = self.source.read().unwrap_or_else(|e| e.into_inner());
        let (k, scale) = (&source.k, &source.scale);
        for &(i, j, p) in &self.kss {
            self.schur[(i, j)] -= match scale.is_empty() {
                true => k[p],
                false => k[p] * (scale[self.s_eq[i]] * scale[self.s_eq[j]]),
            };
        }
        faer::linalg::cholesky::ldlt::factor::cholesky_in_place(
            self.schur.as_mut(),
            LdltRegularization {
                dynamic_regularization_signs: None,
                dynamic_regularization_delta: reg.0,
                dynamic_regularization_epsilon: reg.1,
            },
            Par::Seq,
            MemStack::new(&mut self.schur_mem),
            Default::default(),
        )
        .map_err(|e| Breakdown::Factorization {
            of: "the separator",
            detail: format!("{e:?}"),
        })?;
        Ok(())
    }

    /// Solve K x = rhs in place with the last factorization.
    pub fn solve(&mut self, rhs: &mut [f64]) -> Result<(), Error> {
        let _phase = crate::phases::start("solve: split forward/back substitution");
        let ns = self.s_eq.len();
        {
            let mut b = lock(&self.b);
            load(&mut b, rhs);
            b.phase = Phase::Forward;
        }
        self.pool.start(0);
        {
            let mut a = lock(&self.a);
            load(&mut a, rhs);
            a.forward();
        }
        self.pool.wait(0)?;
        {
            let a = lock(&self.a);
            let b = lock(&self.b);
            for (k, &g) in self.s_eq.iter().enumerate() {
                self.xs[k] = rhs[g] + a.separator_value(k) + b.separator_value(k);
            }
        }
        faer::linalg::cholesky::ldlt::solve::solve_in_place_with_conj(
            self.schur.as_ref(),
            self.schur.as_ref().diagonal(),
            Conj::No,
            MatMut::from_column_major_slice_mut(&mut self.xs, ns, 1),
            Par::Seq,
            MemStack::new(&mut MemBuffer::new(StackReq::EMPTY)),
        );
        {
            let mut b = lock(&self.b);
            b.set_separator(&self.xs);
            b.phase = Phase::Backward;
        }
        self.pool.start(0);
        {
            let mut a = lock(&self.a);
            a.set_separator(&self.xs);
            a.backward();
            store(&a, rhs);
        }
        self.pool.wait(0)?;
        store(&lock(&self.b), rhs);
        for (k, &g) in self.s_eq.iter().enumerate() {
            rhs[g] = self.xs[k];
        }
        Ok(())
    }
}

/// The equations 0..n for which `keep` holds, ascending (allocated fallibly).
fn select(n: usize, keep: impl Fn(usize) -> bool) -> Result<Vec<usize>, OutOfMemory> {
    let count = (0..n).filter(|&i| keep(i)).count();
    let mut v = memory::with_capacity(count, "the two-domain factorization")?;
    v.extend((0..n).filter(|&i| keep(i)));
    Ok(v)
}

/// The half's values from K's (upper CSC) `k`, rounded to f32 when it is factored in single
/// precision.
fn gather(h: &mut Half, k: &[f64]) {
    let Half {
        matrix,
        map,
        single,
        v32,
        ..
    } = h;
    if *single {
        for (v, &p) in v32.iter_mut().zip(map.iter()) {
            *v = k[p as usize] as f32;
        }
    } else {
        for (v, &p) in matrix.val_mut().iter_mut().zip(map.iter()) {
            *v = k[p as usize];
        }
    }
}

/// [`gather`] of S K S (`scale`: S, one entry per equation of K; empty: K itself): each
/// value times S_ii S_jj of its row and column in K, the product `Ldlt`'s in-place scaling
/// takes (exact: S holds powers of two).
fn gather_scaled(h: &mut Half, k: &[f64], scale: &[f64]) {
    let _phase = crate::phases::start("solve: a half's gather of S K S");
    if scale.is_empty() {
        gather(h, k);
        return;
    }
    let Half {
        matrix,
        map,
        single,
        v32,
        eq,
        ..
    } = h;
    let (sym, values) = matrix.parts_mut();
    let (cp, ri) = (sym.col_ptr(), sym.row_idx());
    for j in 0..sym.ncols() {
        let sj = scale[eq[j]];
        for q in cp[j]..cp[j + 1] {
            let v = k[map[q] as usize] * (scale[eq[ri[q]]] * sj);
            if *single {
                v32[q] = v as f32;
            } else {
                values[q] = v;
            }
        }
    }
}

/// The half's right-hand side: its domain's entries, 0 in the separator.
fn load(h: &mut Half, rhs: &[f64]) {
    let nd = h.nd;
    let Half {
        x, x32, eq, single, ..
    } = h;
    if *single {
        for (xi, &g) in x32[..nd].iter_mut().zip(eq.iter()) {
            *xi = rhs[g] as f32;
        }
        x32[nd..].fill(0.0);
    } else {
        for (xi, &g) in x[..nd].iter_mut().zip(eq.iter()) {
            *xi = rhs[g];
        }
        x[nd..].fill(0.0);
    }
}

fn store(h: &Half, rhs: &mut [f64]) {
    if h.single {
        for (xi, &g) in h.x32[..h.nd].iter().zip(h.eq.iter()) {
            rhs[g] = *xi as f64;
        }
    } else {
        for (xi, &g) in h.x[..h.nd].iter().zip(h.eq.iter()) {
            rhs[g] = *xi;
        }
    }
}

/// A dense n x n block, column major, in lazily zeroed memory (`memory::lazy_zeros`): its
/// pages are first touched by the factorization that writes them, on the thread that
/// writes them, and pages it never writes (the upper triangles of the blocks only ever
/// written below the diagonal) are never touched. faer's `Mat::zeros` wrote every page
/// during the set-up instead.
#[derive(Default)]
struct Dense {
    values: Vec<f64>,
    n: usize,
}

impl Dense {
    fn as_ref(&self) -> MatRef<'_, f64> {
        MatRef::from_column_major_slice(&self.values, self.n, self.n)
    }

    fn as_mut(&mut self) -> MatMut<'_, f64> {
        MatMut::from_column_major_slice_mut(&mut self.values, self.n, self.n)
    }
}

impl std::ops::Index<(usize, usize)> for Dense {
    type Output = f64;
    fn index(&self, (i, j): (usize, usize)) -> &f64 {
        debug_assert!(i < self.n && j < self.n);
        &self.values[j * self.n + i]
    }
}

impl std::ops::IndexMut<(usize, usize)> for Dense {
    fn index_mut(&mut self, (i, j): (usize, usize)) -> &mut f64 {
        debug_assert!(i < self.n && j < self.n);
        &mut self.values[j * self.n + i]
    }
}

fn dense(n: usize, what: &'static str) -> Result<Dense, OutOfMemory> {
    Ok(Dense {
        values: memory::lazy_zeros(n.saturating_mul(n), what)?,
        n,
    })
}

impl Half {
    /// The half of `domain` (ascending global equations) and the separator `s_eq`; None when
    /// an entry couples the domain with the other half (not a separator) or faer chose a
    /// simplicial factor.
    fn try_new(
        n: usize,
        col_ptr: &[usize],
        row_idx: &[usize],
        domain: &[usize],
        s_eq: &[usize],
        rank: Option<&[usize]>,
    ) -> Result<Option<Half>, OutOfMemory> {
        let what = "the two-domain factorization";
        let (nd, ns) = (domain.len(), s_eq.len());
        if let Some(rank) = rank {
            let mut eq = memory::with_capacity(nd + ns, what)?;
            eq.extend_from_slice(domain);
            eq.sort_unstable_by_key(|&g| rank[g]);
            eq.extend_from_slice(s_eq);
            return Half::numbered(n, col_ptr, row_idx, eq, nd);
        }
        // Domain-local numbering for AMD: the domain block's upper CSC.
        let mut local = memory::filled(n, usize::MAX, what)?;
        for (k, &g) in domain.iter().enumerate() {
            local[g] = k;
        }
        let mut dcol = memory::with_capacity(nd + 1, what)?;
        let entries: usize = domain.iter().map(|&g| col_ptr[g + 1] - col_ptr[g]).sum();
        let mut drow = memory::with_capacity(entries, what)?;
        dcol.push(0);
        for &g in domain {
            for p in col_ptr[g]..col_ptr[g + 1] {
                if local[row_idx[p]] != usize::MAX {
                    drow.push(local[row_idx[p]]);
                }
            }
            dcol.push(drow.len());
        }
        let mut perm = memory::zeros::<usize>(nd, what)?;
        let mut perm_inv = memory::zeros::<usize>(nd, what)?;
        let sym = SymbolicSparseColMat::new_checked(nd, nd, dcol, None, drow);
        let mut amd_mem = MemBuffer::try_new(faer::sparse::linalg::amd::order_scratch::<usize>(
            nd,
            sym.compute_nnz(),
        ))
        .map_err(|_| OutOfMemory {
            what,
            bytes: (nd as u64) * 64,
        })?;
        faer::sparse::linalg::amd::order(
            &mut perm,
            &mut perm_inv,
            sym.as_ref(),
            Default::default(),
            MemStack::new(&mut amd_mem),
        )
        .map_err(|_| OutOfMemory {
            what,
            bytes: (nd as u64) * 64,
        })?;
        drop(amd_mem);
        // The half's numbering: the domain in AMD order, then the separator.
        let mut eq = memory::with_capacity(nd + ns, what)?;
        eq.extend(perm.iter().map(|&k| domain[k]));
        eq.extend_from_slice(s_eq);
        drop(local);
        Half::numbered(n, col_ptr, row_idx, eq, nd)
    }

    /// The half with equations `eq` (the domain's `nd` first, then the separator).
    fn numbered(
        n: usize,
        col_ptr: &[usize],
        row_idx: &[usize],
        eq: Vec<usize>,
        nd: usize,
    ) -> Result<Option<Half>, OutOfMemory> {
        let what = "the two-domain factorization";
        let phase = crate::phases::start("the half's matrix");
        let ns = eq.len() - nd;
        let mut local = memory::filled(n, usize::MAX, what)?;
        for (k, &g) in eq.iter().enumerate() {
            local[g] = k;
        }
        // Its upper CSC: every entry of K between two of its equations, placed at
        // (min, max) of their local numbers, with its position in K. K is upper: an entry
        // lies in the column of the later of its two equations, so only the half's own
        // columns are read (not all of K's, twice per half).
        let m = nd + ns;
        let mut count = memory::zeros::<usize>(m + 1, what)?;
        for (lj, &j) in eq.iter().enumerate() {
            for &i in &row_idx[col_ptr[j]..col_ptr[j + 1]] {
                let li = local[i];
                if li != usize::MAX {
                    count[li.max(lj) + 1] += 1;
                } else if lj < nd {
                    // An entry between the domain and an equation outside the half: not a
                    // separator. (One in a column outside the half whose row is in this
                    // domain is found by the other half's build, which reads that column.)
                    return Ok(None);
                }
            }
        }
        for j in 0..m {
            count[j + 1] += count[j];
        }
        let nnz = count[m];
        let mut next = memory::copy(&count[..m], what)?;
        // Every entry is written below: fresh pages, no zeroing pass first.
        let mut rows = memory::lazy_zeros::<usize>(nnz, what)?;
        let mut map = memory::lazy_zeros::<u32>(nnz, what)?;
        for (lj, &j) in eq.iter().enumerate() {
            for p in col_ptr[j]..col_ptr[j + 1] {
                let li = local[row_idx[p]];
                if li != usize::MAX {
                    let c = li.max(lj);
                    rows[next[c]] = li.min(lj);
                    map[next[c]] = p as u32;
                    next[c] += 1;
                }
            }
        }
        drop(next);
        drop(local);
        // Each column's rows ascending (one scratch for all: a column holds a few dozen).
        let mut pairs: Vec<(usize, u32)> = Vec::new();
        for c in 0..m {
            let (lo, hi) = (count[c], count[c + 1]);
            pairs.clear();
            pairs.extend(
                rows[lo..hi]
                    .iter()
                    .copied()
                    .zip(map[lo..hi].iter().copied()),
            );
            pairs.sort_unstable();
            for (k, &(r, p)) in pairs.iter().enumerate() {
                rows[lo + k] = r;
                map[lo + k] = p;
            }
        }
        let sym = SymbolicSparseColMat::new_checked(m, m, count, None, rows);
        let matrix = SparseColMat::new(sym, memory::lazy_zeros(nnz, what)?);
        drop(phase);
        let _phase = crate::phases::start("the half's symbolic factorization");
        let symbolic = super::factor::symbolic_ldlt(&matrix, SymmetricOrdering::Identity, what)?;
        if !matches!(symbolic.raw(), SymbolicCholeskyRaw::Supernodal(_)) {
            return Ok(None);
        }
        Ok(Some(Half {
            eq,
            nd,
            map,
            matrix,
            symbolic,
            l_values: Vec::new(),
            mem: MemBuffer::new(StackReq::EMPTY),
            lss: Dense::default(),
            w: Dense::default(),
            s_block: Dense::default(),
            d: Vec::new(),
            x: Vec::new(),
            tmp: Vec::new(),
            single: false,
            v32: Vec::new(),
            l32: Vec::new(),
            x32: Vec::new(),
            tmp32: Vec::new(),
            reg: (0.0, 0.0),
            source: None,
            gathers: false,
            phase: Phase::Factor,
            status: Ok(()),
        }))
    }

    /// The half with its numeric buffers ([`Half::allocate`]).
    fn allocated(mut self) -> Result<Half, OutOfMemory> {
        self.allocate()?;
        Ok(self)
    }

    /// Whether [`Half::allocate`] has run.
    fn is_allocated(&self) -> bool {
        self.x.len() == self.eq.len()
    }

    /// Factor in single precision (`single`: the f32 buffers allocated, fallibly; their pages
    /// are touched by the factorization) or in double (the f32 buffers freed: the f64
    /// factor's pages are then touched by its first factorization instead).
    fn set_single(&mut self, single: bool) -> Result<(), OutOfMemory> {
        let what = "the two-domain factorization's single-precision factor";
        if single && !self.single {
            let (m, nnz) = (self.eq.len(), self.map.len());
            self.v32 = memory::lazy_zeros(nnz, what)?;
            self.l32 = memory::lazy_zeros(self.symbolic.len_val(), what)?;
            self.x32 = memory::zeros(m, what)?;
            self.tmp32 = memory::zeros(self.tmp.len(), what)?;
        } else if !single {
            self.v32 = Vec::new();
            self.l32 = Vec::new();
            self.x32 = Vec::new();
            self.tmp32 = Vec::new();
        }
        self.single = single;
        Ok(())
    }

    /// The numeric buffers (factor values, workspaces, the separator's dense blocks), once
    /// the split is chosen.
    fn allocate(&mut self) -> Result<(), OutOfMemory> {
        let what = "the two-domain factorization";
        let (m, ns) = (self.eq.len(), self.eq.len() - self.nd);
        let symbolic = &self.symbolic;
        self.l_values = memory::lazy_zeros(symbolic.len_val(), what)?;
        let tallest = match symbolic.raw() {
            SymbolicCholeskyRaw::Supernodal(sym) => (0..sym.n_supernodes())
                .map(|s| sym.col_ptr_for_row_idx()[s + 1] - sym.col_ptr_for_row_idx()[s])
                .max()
                .unwrap_or(0),
            SymbolicCholeskyRaw::Simplicial(_) => 0,
        };
        // The f64 factorization's workspace serves the f32 one too (at least as large).
        let req = symbolic.factorize_numeric_ldlt_scratch::<f64>(Par::Seq, Default::default());
        let req32 = symbolic.factorize_numeric_ldlt_scratch::<f32>(Par::Seq, Default::default());
        self.mem = MemBuffer::try_new(req.or(req32)).map_err(|_| OutOfMemory {
            what,
            bytes: (self.map.len() as u64).saturating_mul(8),
        })?;
        self.lss = dense(ns, what)?;
        self.w = dense(ns, what)?;
        self.s_block = dense(ns, what)?;
        self.d = memory::zeros(ns, what)?;
        self.x = memory::zeros(m, what)?;
        // Below the domain columns: the rest of the supernode's columns and its pattern.
        self.tmp = memory::zeros(tallest + ns, what)?;
        Ok(())
    }
}

/// Breadth-first levels from a pseudo-peripheral equation and the level chosen as the
/// separator; None when the graph is not connected or no level is small and balanced.
fn separator_levels(
    n: usize,
    col_ptr: &[usize],
    row_idx: &[usize],
) -> Result<Option<Levels>, OutOfMemory> {
    let what = "the two-domain factorization";
    // Symmetric adjacency (without the diagonal) from the upper pattern.
    let mut ptr = memory::zeros::<usize>(n + 1, what)?;
    for j in 0..n {
        for &i in &row_idx[col_ptr[j]..col_ptr[j + 1]] {
            if i != j {
                ptr[i + 1] += 1;
                ptr[j + 1] += 1;
            }
        }
    }
    for i in 0..n {
        ptr[i + 1] += ptr[i];
    }
    let mut next = memory::copy(&ptr[..n], what)?;
    let mut adj = memory::zeros::<usize>(ptr[n], what)?;
    for j in 0..n {
        for &i in &row_idx[col_ptr[j]..col_ptr[j + 1]] {
            if i != j {
                adj[next[i]] = j;
                next[i] += 1;
                adj[next[j]] = i;
                next[j] += 1;
            }
        }
    }
    drop(next);
    let mut levels = memory::filled(n, usize::MAX, what)?;
    let mut queue = memory::with_capacity(n, what)?;
    let mut bfs = |root: usize, levels: &mut Vec<usize>| -> (usize, usize) {
        levels.fill(usize::MAX);
        queue.clear();
        queue.push(root);
        levels[root] = 0;
        let mut head = 0;
        while head < queue.len() {
            let v = queue[head];
            head += 1;
            for &w in &adj[ptr[v]..ptr[v + 1]] {
                if levels[w] == usize::MAX {
                    levels[w] = levels[v] + 1;
                    queue.push(w);
                }
            }
        }
        let last = *queue.last().expect("root");
        (queue.len(), last)
    };
    let (_, far) = bfs(0, &mut levels);
    let (_, far) = bfs(far, &mut levels);
    let (reached, _) = bfs(far, &mut levels);
    if reached < n {
        return Ok(None);
    }
    let depth = levels.iter().max().copied().unwrap_or(0) + 1;
    let mut size = memory::zeros::<usize>(depth, what)?;
    for &l in levels.iter() {
        size[l] += 1;
    }
    let mut before = 0;
    let mut best: Option<(usize, usize)> = None;
    for (l, &size_l) in size.iter().enumerate().take(depth) {
        let after = n - before - size_l;
        let least = (BALANCE * n as f64) as usize;
        if before >= least && after >= least && best.is_none_or(|(_, m)| before.max(after) < m) {
            best = Some((l, before.max(after)));
        }
        before += size_l;
    }
    Ok(match best {
        Some((l, _)) if size[l] <= MAX_SEPARATOR => Some(Levels {
            sep: l,
            level: levels,
            size,
        }),
        _ => None,
    })
}

/// Breadth-first levels of the equations and the level chosen as the separator.
struct Levels {
    sep: usize,
    /// Level of every equation.
    level: Vec<usize>,
    /// Equations per level.
    size: Vec<usize>,
}

impl Levels {
    /// Equations before level `l` (the first domain's when `l` is the separator).
    fn before(&self, l: usize) -> usize {
        self.size[..l].iter().sum()
    }

    /// Whether level `l` may separate: small enough, and each side at least [`BALANCE`].
    fn admissible(&self, l: usize) -> bool {
        let n = self.level.len();
        let least = (BALANCE * n as f64) as usize;
        let before = self.before(l);
        self.size[l] <= MAX_SEPARATOR && before >= least && n - before - self.size[l] >= least
    }
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;

    /// The 5-point Laplacian of an nx x ny grid plus a shift (SPD), upper CSC (also used by
    /// linear.rs's tests).
    pub(in crate::solver) fn grid(
        nx: usize,
        ny: usize,
    ) -> (usize, Vec<usize>, Vec<usize>, Vec<f64>) {
        let n = nx * ny;
        let (mut cp, mut ri, mut v) = (vec![0], vec![], vec![]);
        for j in 0..n {
            let (x, y) = (j % nx, j / nx);
            if y > 0 {
                ri.push(j - nx);
                v.push(-1.0);
            }
            if x > 0 {
                ri.push(j - 1);
                v.push(-1.0);
            }
            ri.push(j);
            v.push(4.1 + (j % 7) as f64 * 0.01);
            cp.push(ri.len());
        }
        (n, cp, ri, v)
    }

    fn multiply(n: usize, cp: &[usize], ri: &[usize], v: &[f64], x: &[f64]) -> Vec<f64> {
        let mut y = vec![0.0; n];
        for j in 0..n {
            for p in cp[j]..cp[j + 1] {
                let i = ri[p];
                y[i] += v[p] * x[j];
                if i != j {
                    y[j] += v[p] * x[i];
                }
            }
        }
        y
    }

    /// The lazily zeroed dense block reads zero until written, and its (i, j) is faer's
    /// column-major (i, j) of the same values (what the factorization and the solve read
    /// through `as_ref`/`as_mut`).
    #[test]
    fn a_dense_block_is_zero_and_column_major() {
        let mut d = dense(5, "test").unwrap();
        assert!(d.values.iter().all(|&v| v == 0.0));
        d[(3, 1)] = 2.5;
        d.as_mut()[(1, 3)] = -1.0;
        assert_eq!(d.as_ref()[(3, 1)], 2.5);
        assert_eq!(d[(1, 3)], -1.0);
        assert_eq!(d.values[5 + 3], 2.5);
        assert_eq!(d.values[3 * 5 + 1], -1.0);
        assert_eq!(d.values.iter().filter(|&&v| v != 0.0).count(), 2);
    }

    #[test]
    fn the_split_solves_a_grid_laplacian() {
        let (n, cp, ri, v) = grid(60, 40);
        let pool = Arc::new(Pool::try_new(2).unwrap());
        let mut split = Split::try_new(n, &cp, &ri, None, pool)
            .unwrap()
            .expect("a separator");
        let (na, nb, ns) = split.sizes();
        assert_eq!(na + nb + ns, n);
        assert!(ns <= 60, "separator {ns}");
        assert!(na >= n / 3 && nb >= n / 3, "{na} {nb}");
        split.factor(&v, (1e-9, 1e-13)).unwrap();
        let x: Vec<f64> = (0..n)
            .map(|i| ((i * 37) % 101) as f64 / 101.0 - 0.5)
            .collect();
        let mut b = multiply(n, &cp, &ri, &v, &x);
        split.solve(&mut b).unwrap();
        let err = x
            .iter()
            .zip(&b)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        assert!(err < 1e-12, "{err:e}");
        // A second right-hand side with the same factor.
        let mut b = multiply(n, &cp, &ri, &v, &vec![1.0; n]);
        split.solve(&mut b).unwrap();
        let err = b.iter().map(|b| (b - 1.0).abs()).fold(0.0, f64::max);
        assert!(err < 1e-12, "{err:e}");
    }

    /// A strip of a 5-point grid whose width grows from 10 to 70 along its length: the level
    /// that halves the equations leaves the wide end with more flops (its fronts are
    /// longer). The separator moves until the halves' flops agree, the solving thread takes
    /// the lighter, and the split still solves exactly. Measured: 6322 equations, the
    /// count-balanced halves 22.3 % apart in flops, the kept ones 5.4 % (separator 43).
    #[test]
    fn the_separator_balances_the_halves_flops() {
        let length = 160;
        let width = |x: usize| 10 + 60 * x / (length - 1);
        let mut id = vec![vec![usize::MAX; 70]; length];
        let mut n = 0;
        for (x, column) in id.iter_mut().enumerate() {
            for slot in column.iter_mut().take(width(x)) {
                *slot = n;
                n += 1;
            }
        }
        let (mut cp, mut ri, mut v) = (vec![0], vec![], vec![]);
        for x in 0..length {
            for y in 0..width(x) {
                let j = id[x][y];
                let mut column = vec![(j, 4.1 + (j % 7) as f64 * 0.01)];
                if x > 0 && y < width(x - 1) {
                    column.push((id[x - 1][y], -1.0));
                }
                if y > 0 {
                    column.push((id[x][y - 1], -1.0));
                }
                column.sort_by_key(|e| e.0);
                for (i, value) in column {
                    ri.push(i);
                    v.push(value);
                }
                cp.push(ri.len());
            }
        }
        let pool = Arc::new(Pool::try_new(2).unwrap());
        let mut split = Split::try_new(n, &cp, &ri, None, pool)
            .unwrap()
            .expect("a separator");
        let (kept, counted) = split.flops();
        let imbalance = |f: [f64; 2]| f[0].max(f[1]) / f[0].min(f[1]) - 1.0;
        println!(
            "{n} equations, sizes {:?}: flops {kept:?} ({:.3}), count-balanced {counted:?} ({:.3})",
            split.sizes(),
            imbalance(kept),
            imbalance(counted)
        );
        assert!(
            imbalance(counted) > 0.1,
            "the test needs an unbalanced start"
        );
        assert!(imbalance(kept) < 0.1, "{}", imbalance(kept));
        assert!(
            kept[0] <= kept[1],
            "the solving thread takes the lighter half"
        );
        split.factor(&v, (1e-9, 1e-13)).unwrap();
        let x: Vec<f64> = (0..n)
            .map(|i| ((i * 37) % 101) as f64 / 101.0 - 0.5)
            .collect();
        let mut b = multiply(n, &cp, &ri, &v, &x);
        split.solve(&mut b).unwrap();
        let err = x
            .iter()
            .zip(&b)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        assert!(err < 1e-12, "{err:e}");
    }

    #[test]
    fn no_split_without_a_helper_or_without_a_small_separator() {
        let (n, cp, ri, _) = grid(30, 20);
        let one = Arc::new(Pool::try_new(1).unwrap());
        assert!(Split::try_new(n, &cp, &ri, None, one).unwrap().is_none());
        // A dense 5 x 5 block: every level set is too unbalanced.
        let cp: Vec<usize> = (0..=5).map(|j| j * (j + 1) / 2).collect();
        let ri: Vec<usize> = (0..5).flat_map(|j| 0..=j).collect();
        let two = Arc::new(Pool::try_new(2).unwrap());
        assert!(Split::try_new(5, &cp, &ri, None, two).unwrap().is_none());
    }
}
