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
//!          with BLOCK right-hand sides: one pass over the factor), every column
//!          M-orthogonalised against the last two blocks, then against all earlier vectors
//!          (classical Gram-Schmidt, full reorthogonalisation), and within the new block, W = Q_{j+1} B_j. The coefficients
//!          form H = Qᵀ M A Q (block tridiagonal up to round-off); a Ritz pair (θ, Q s) of H
//!          has the residual |B_j s_j| (s_j: its last block of components) in the M norm and
//!          is converged when that is at most TOLERANCE θ_max
//! multiple a single start vector sees one vector of each eigenspace; a block of BLOCK sees up
//!          to BLOCK (the square membrane's f_12 = f_21, a straight cable's frequencies in two
//!          planes, a disc's pairs): a frequency repeated more often than BLOCK times may be
//!          reported fewer times
//! A Ritz vector φ is M-normalised (φᵀ M φ = 1); f = ω / 2π, reported negative (−√|ω²|/2π)
//! for a negative ω² (an unstable equilibrium: the tangent is not positive definite).
//!
//! # References
//! Ericsson & Ruhe 1980 (the spectral transformation Lanczos method); Parlett 1998, *The
//! Symmetric Eigenvalue Problem*, ch. 13 (Lanczos, full reorthogonalisation); Golub & Van Loan
//! 2013, §10.1.

use super::assemble::NONE;
use super::core::Solver;
use super::mass::Mass;
use crate::error::Error;
use crate::memory;
use crate::model::wrinkling::WrinkleState;
use crate::model::Model;

/// The shift's magnitude relative to the largest K_ii/M_ii (a bound of the largest ω²).
const SHIFT: f64 = 1e-8;
/// A Ritz pair is converged when its residual is at most this times the largest θ (the
/// eigenvalue is then within about its square, relative).
const TOLERANCE: f64 = 1e-6;
/// Vectors per Lanczos block (the largest multiplicity seen: module docs).
const BLOCK: usize = 4;
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
    /// Seconds of the assembly and factorization of K − σM, of the solves, and of the rest of
    /// the Lanczos iteration (orthogonalisation, M products, Ritz pairs).
    pub seconds: [f64; 3],
}

/// The operator of the Lanczos iteration: the factored K − σM and M.
struct Operator<'a> {
    solver: &'a mut Solver,
    mass: &'a Mass,
    solves: usize,
    solve_seconds: f64,
}

impl Operator<'_> {
    fn mass(&self, x: &[f64], y: &mut [f64]) {
        self.solver.mass_product(self.mass, x, y);
    }

    /// Y = (K − σM)⁻¹ Mx for the columns `mx` (M x already formed), in one pass.
    fn solve_block(&mut self, mx: &[&[f64]]) -> Result<Vec<Vec<f64>>, Error> {
        let n = mx.first().map_or(0, |c| c.len());
        let mut buffer = memory::zeros(n * mx.len(), "the Lanczos vectors")?;
        for (chunk, c) in buffer.chunks_mut(n.max(1)).zip(mx) {
            chunk.copy_from_slice(c);
        }
        self.solves += mx.len();
        let t = std::time::Instant::now();
        let result = self.solver.linear.solve_columns(&mut buffer, mx.len());
        self.solve_seconds += t.elapsed().as_secs_f64();
        result?;
        Ok(buffer.chunks(n.max(1)).map(<[f64]>::to_vec).collect())
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

/// Block Lanczos on `op` (module docs): the converged Ritz pairs (θ descending, M-normalised
/// vectors over the equations), at most `want` of them.
fn block_lanczos(op: &mut Operator, n: usize, want: usize) -> Result<Vec<(f64, Vec<f64>)>, Error> {
    let max_dim = (2 * want + EXTRA).min(n).max(1);
    let block = BLOCK.min(n);
    let what = "the Lanczos vectors";
    let mut mw = memory::zeros(n, what)?;
    // The Lanczos vectors, their M products and H's columns (h[k][i] = (M qᵢ)ᵀ A q_k).
    let mut q: Vec<Vec<f64>> = Vec::new();
    let mut mq: Vec<Vec<f64>> = Vec::new();
    let mut h: Vec<Vec<f64>> = Vec::new();
    // The first block: A R, M-orthonormalised (A R lies in the range of A: no component along
    // the massless directions' infinite frequencies).
    let mut mr = Vec::with_capacity(block);
    for seed in 0..block as u64 {
        let r = start_vector(n, seed);
        let mut m = memory::zeros(n, what)?;
        op.mass(&r, &mut m);
        mr.push(m);
    }
    let first = op.solve_block(&mr.iter().map(Vec::as_slice).collect::<Vec<_>>())?;
    let mut scale = 0.0f64;
    for mut w in first {
        let size = m_orthogonalise(op, &q, &mq, 0, &mut w, &mut mw).0;
        if size > 1e-10 * scale && size.is_finite() {
            scale = scale.max(size);
            q.push(w.iter().map(|x| x / size).collect());
            mq.push(mw.iter().map(|x| x / size).collect());
        }
    }
    let (mut previous, mut start) = (0, 0);
    loop {
        let end = q.len();
        if start == end {
            // No new direction: an invariant subspace, every Ritz pair exact.
            return ritz_pairs(&q, &h, end, want, None);
        }
        let columns: Vec<&[f64]> = mq[start..end].iter().map(Vec::as_slice).collect();
        let ws = op.solve_block(&columns)?;
        for (k, mut w) in (start..end).zip(ws) {
            let (size, c) = m_orthogonalise(op, &q, &mq, previous, &mut w, &mut mw);
            let mut column = c;
            scale = scale.max(column.get(k).copied().unwrap_or(0.0).abs());
            if size > 1e-10 * scale && size.is_finite() && q.len() < n {
                column.push(size);
                q.push(w.iter().map(|x| x / size).collect());
                mq.push(mw.iter().map(|x| x / size).collect());
            }
            h.push(column);
        }
        // Residual of a Ritz pair: the coefficients on the new block's vectors (B_j s_j).
        let (theta, s) = projected_eigen(&h, end);
        let mut order: Vec<usize> = (0..end).collect();
        order.sort_by(|&x, &y| theta[y].total_cmp(&theta[x]));
        let largest = theta.iter().fold(0.0f64, |m, t| m.max(t.abs()));
        let residual = |k: usize| -> f64 {
            (end..q.len())
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
        let invariant = q.len() == end;
        if (end >= want && done) || invariant || q.len() >= max_dim {
            let keep: Vec<usize> = order
                .iter()
                .take(wanted)
                .copied()
                .filter(|&k| invariant || residual(k) <= TOLERANCE * largest)
                .collect();
            return ritz_pairs(&q, &h, end, want, Some(&keep));
        }
        previous = start;
        start = end;
    }
}

/// w ← w − Σ ((M qᵢ)ᵀ w) qᵢ over the vectors from `local` on (the three-term recurrence's
/// part: the last two blocks), then over every vector so far (the full reorthogonalisation);
/// then M w into `mw`. Returns (|w|_M, the coefficients of both passes summed: A q's column of
/// H).
fn m_orthogonalise(
    op: &Operator,
    q: &[Vec<f64>],
    mq: &[Vec<f64>],
    local: usize,
    w: &mut [f64],
    mw: &mut [f64],
) -> (f64, Vec<f64>) {
    let mut total = vec![0.0; q.len()];
    for from in [local.min(q.len()), 0] {
        let c: Vec<f64> = mq[from..].iter().map(|m| dot(m, w)).collect();
        for ((qi, c), t) in q[from..].iter().zip(&c).zip(&mut total[from..]) {
            *t += c;
            for (wi, qv) in w.iter_mut().zip(qi) {
                *wi -= c * qv;
            }
        }
    }
    op.mass(w, mw);
    (dot(w, mw).max(0.0).sqrt(), total)
}

/// Eigenpairs of the leading `m` × `m` block of H (columns `h`, symmetrised).
fn projected_eigen(h: &[Vec<f64>], m: usize) -> (Vec<f64>, nalgebra::DMatrix<f64>) {
    let at = |i: usize, k: usize| h[k].get(i).copied().unwrap_or(0.0);
    let t = nalgebra::DMatrix::from_fn(m, m, |i, k| 0.5 * (at(i, k) + at(k, i)));
    let e = nalgebra::SymmetricEigen::new(t);
    (e.eigenvalues.iter().copied().collect(), e.eigenvectors)
}

/// The Ritz pairs (θ, Q s) of the leading `m` vectors: those of `keep` (indices into the
/// eigenpairs of H), or the largest `want`.
fn ritz_pairs(
    q: &[Vec<f64>],
    h: &[Vec<f64>],
    m: usize,
    want: usize,
    keep: Option<&[usize]>,
) -> Result<Vec<(f64, Vec<f64>)>, Error> {
    let m = m.min(h.len());
    if m == 0 {
        return Ok(Vec::new());
    }
    let (theta, s) = projected_eigen(h, m);
    let chosen: Vec<usize> = match keep {
        Some(k) => k.to_vec(),
        None => {
            let mut order: Vec<usize> = (0..m).collect();
            order.sort_by(|&x, &y| theta[y].total_cmp(&theta[x]));
            order.truncate(want);
            order
        }
    };
    let n = q.first().map_or(0, Vec::len);
    let mut out = Vec::with_capacity(chosen.len());
    for k in chosen {
        let mut y = memory::zeros(n, "the mode shapes")?;
        for (i, qi) in q.iter().take(m).enumerate() {
            let c = s[(i, k)];
            for (yv, qv) in y.iter_mut().zip(qi) {
                *yv += c * qv;
            }
        }
        out.push((theta[k], y));
    }
    Ok(out)
}

impl Solver {
    /// The lowest `count` natural frequencies and modes at the converged state `u` under
    /// `loads`, wrinkle states `wrinkle` (module docs). Errors: a model without mass, a scene
    /// with sleeves or volume inputs (their unknowns are not in this eigenproblem), a failed
    /// factorization of K − σM. Leaves K − σM in the solver's factorization: the next Newton
    /// iteration assembles and factors its own.
    pub fn modes(
        &mut self,
        model: &Model,
        mass: &Mass,
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
        self.linear.factor()?;
        let factored = started.elapsed().as_secs_f64();
        let mut op = Operator {
            solver: self,
            mass,
            solves: 0,
            solve_seconds: 0.0,
        };
        let count = count.min(n);
        let found = block_lanczos(&mut op, n, count)?;
        let solves = op.solves;
        let lanczos_seconds = started.elapsed().as_secs_f64() - factored;
        let seconds = [
            factored,
            op.solve_seconds,
            lanczos_seconds - op.solve_seconds,
        ];
        let eq = &self.pattern.eq;
        let mut modes = Modes {
            eigenvalues: Vec::new(),
            frequencies: Vec::new(),
            shapes: Vec::new(),
            shift,
            solves,
            seconds,
        };
        for (theta, y) in found {
            let lambda = shift + 1.0 / theta;
            modes.eigenvalues.push(lambda);
            let f = lambda.abs().sqrt() / (2.0 * std::f64::consts::PI);
            modes.frequencies.push(if lambda < 0.0 { -f } else { f });
            let mut shape = vec![0.0; model.dof_count()];
            for (d, &e) in eq.iter().enumerate() {
                if e != NONE {
                    shape[d] = y[e];
                }
            }
            modes.shapes.push(shape);
        }
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
