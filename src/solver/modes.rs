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
//! Lanczos  q₁ = A r / |A r|_M (r a fixed pseudo-random vector, so runs repeat bit for bit),
//!          A q_j = β_{j−1} q_{j−1} + α_j q_j + β_j q_{j+1}, every new vector M-orthogonalised
//!          against all earlier ones twice (classical Gram-Schmidt, full reorthogonalisation);
//!          a Ritz pair (θ, Q s) of the tridiagonal T_j has the residual |β_j s_j| (its last
//!          component) and is converged when that is at most TOLERANCE θ
//! deflation a single start vector sees one vector of each eigenspace: a repeated frequency
//!          (the square membrane's f_12 = f_21) would be missed. So once the wanted count has
//!          converged, Lanczos runs again from a new start M-orthogonal to the converged
//!          vectors (which every new vector stays orthogonal to); a lower eigenvalue that run
//!          finds joins the set, until a run finds none below the set's largest
//! ```
//! A Ritz vector φ is M-normalised (φᵀ M φ = 1); f = ω / 2π, reported negative (−√|ω²|/2π)
//! for a negative ω² (an unstable equilibrium: the tangent is not positive definite).
//!
//! # References
//! Ericsson & Ruhe 1980 (the spectral transformation Lanczos method); Parlett 1998, *The
//! Symmetric Eigenvalue Problem*, ch. 13 (Lanczos, full reorthogonalisation); Golub & Van Loan
//! 2013, §10.1.

use super::assemble::{self, Membranes, NONE};
use super::core::Solver;
use super::mass::Mass;
use crate::error::Error;
use crate::memory;
use crate::model::wrinkling::WrinkleState;
use crate::model::Model;

/// The shift's magnitude relative to the largest K_ii/M_ii (a bound of the largest ω²).
const SHIFT: f64 = 1e-8;
/// A Ritz pair is converged when its residual |β_j s_j| is at most this times θ.
const TOLERANCE: f64 = 1e-10;
/// A Lanczos run stops at this many vectors beyond twice the wanted count.
const EXTRA: usize = 40;
/// Deflation runs after the first (each may add one eigenvalue).
const MAX_DEFLATIONS: usize = 8;

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
    /// Solves with the factored K − σM (Lanczos steps of every run).
    pub solves: usize,
    /// Lanczos runs (1 + the deflation runs).
    pub runs: usize,
}

/// The operator of the runs: the factored K − σM and M.
struct Operator<'a> {
    solver: &'a mut Solver,
    mass: &'a Mass,
    solves: usize,
}

impl Operator<'_> {
    fn mass(&self, x: &[f64], y: &mut [f64]) {
        self.solver.mass_product(self.mass, x, y);
    }

    /// y = (K − σM)⁻¹ m (m = M x already formed).
    fn solve(&mut self, m: &[f64], y: &mut [f64]) -> Result<(), Error> {
        y.copy_from_slice(m);
        self.solves += 1;
        self.solver.linear.solve(y)
    }
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// w ← w − Σ (qᵢᵀ M w) qᵢ over `basis`, twice; returns |w|_M after (and leaves M w in `mw`).
fn orthogonalise(op: &Operator, basis: &[&[f64]], w: &mut [f64], mw: &mut [f64]) -> f64 {
    for _ in 0..2 {
        op.mass(w, mw);
        let c: Vec<f64> = basis.iter().map(|q| dot(q, mw)).collect();
        for (q, c) in basis.iter().zip(&c) {
            for (wi, qi) in w.iter_mut().zip(q.iter()) {
                *wi -= c * qi;
            }
        }
    }
    op.mass(w, mw);
    dot(w, mw).max(0.0).sqrt()
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

/// One Lanczos run on `op` in the M-orthogonal complement of `locked`: the converged Ritz
/// pairs (θ descending, M-normalised vectors over the equations), at most `want` of them.
fn lanczos(
    op: &mut Operator,
    n: usize,
    locked: &[Vec<f64>],
    want: usize,
    seed: u64,
) -> Result<Vec<(f64, Vec<f64>)>, Error> {
    let max_dim = (2 * want + EXTRA)
        .min(n.saturating_sub(locked.len()))
        .max(1);
    let what = "the Lanczos vectors";
    let mut mw = memory::zeros(n, what)?;
    let mut w = memory::zeros(n, what)?;
    // q1 = A r in the complement of the locked vectors (A r lies in the range of A: no
    // component along massless directions' infinite frequencies).
    let r = start_vector(n, seed);
    op.mass(&r, &mut mw);
    op.solve(&mw, &mut w)?;
    let locked_refs: Vec<&[f64]> = locked.iter().map(Vec::as_slice).collect();
    let norm = orthogonalise(op, &locked_refs, &mut w, &mut mw);
    if norm == 0.0 || !norm.is_finite() {
        return Ok(Vec::new());
    }
    let mut q: Vec<Vec<f64>> = vec![w.iter().map(|x| x / norm).collect()];
    let mut alpha: Vec<f64> = Vec::new();
    let mut beta: Vec<f64> = Vec::new();
    let mut mq = memory::zeros(n, what)?;
    loop {
        let j = q.len() - 1;
        op.mass(&q[j], &mut mq);
        op.solve(&mq, &mut w)?;
        let a = dot(&mq, &w);
        alpha.push(a);
        let mut basis: Vec<&[f64]> = locked_refs.clone();
        basis.extend(q.iter().map(Vec::as_slice));
        let b = orthogonalise(op, &basis, &mut w, &mut mw);
        beta.push(b);
        let size = alpha.len();
        let (theta, s) = tridiagonal_eigen(&alpha, &beta[..size - 1]);
        // Descending θ: the lowest frequencies first.
        let mut order: Vec<usize> = (0..size).collect();
        order.sort_by(|&x, &y| theta[y].total_cmp(&theta[x]));
        let scale = theta.iter().fold(0.0f64, |m, t| m.max(t.abs()));
        let converged = |k: usize| (b * s[(size - 1, k)]).abs() <= TOLERANCE * scale;
        let done = order.iter().take(want).filter(|&&k| converged(k)).count();
        // An invariant subspace: every Ritz pair is exact.
        let invariant = b <= 1e-14 * scale;
        if invariant || size >= max_dim || (size >= want && done == want) {
            let mut out = Vec::new();
            for &k in order.iter().take(want) {
                if !(converged(k) || invariant) {
                    continue;
                }
                let mut y = memory::zeros(n, what)?;
                for (i, qi) in q.iter().enumerate() {
                    let c = s[(i, k)];
                    for (yv, qv) in y.iter_mut().zip(qi) {
                        *yv += c * qv;
                    }
                }
                op.mass(&y, &mut mw);
                let norm = dot(&y, &mw).max(0.0).sqrt();
                if norm > 0.0 {
                    y.iter_mut().for_each(|v| *v /= norm);
                }
                out.push((theta[k], y));
            }
            return Ok(out);
        }
        q.push(w.iter().map(|x| x / b).collect());
    }
}

/// Eigenvalues and eigenvectors (columns) of the symmetric tridiagonal matrix with diagonal
/// `alpha` and off-diagonal `beta`.
fn tridiagonal_eigen(alpha: &[f64], beta: &[f64]) -> (Vec<f64>, nalgebra::DMatrix<f64>) {
    let m = alpha.len();
    let mut t = nalgebra::DMatrix::zeros(m, m);
    for i in 0..m {
        t[(i, i)] = alpha[i];
        if i + 1 < m {
            t[(i, i + 1)] = beta[i];
            t[(i + 1, i)] = beta[i];
        }
    }
    let e = nalgebra::SymmetricEigen::new(t);
    (e.eigenvalues.iter().copied().collect(), e.eigenvectors)
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
        // The true tangent (as `factor_tangent`): states frozen, no artificial prestress.
        let forced: Vec<Option<WrinkleState>> = wrinkle.iter().copied().map(Some).collect();
        let membranes = Membranes {
            forced: Some(&forced),
            prestress_factor: Some(0.0),
            ..Default::default()
        };
        let mut r = vec![0.0; model.dof_count()];
        assemble::assemble_with(
            model,
            &self.pattern,
            u,
            loads,
            &mut r,
            Some(self.linear.values_mut()),
            membranes,
        );
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
        let mut op = Operator {
            solver: self,
            mass,
            solves: 0,
        };
        let count = count.min(n);
        let mut found = lanczos(&mut op, n, &[], count, 0)?;
        let mut runs = 1;
        // Deflation (module docs): look for eigenvalues the first run's start did not see.
        for seed in 1..=MAX_DEFLATIONS as u64 {
            if found.len() < count || found.len() >= n {
                break;
            }
            let locked: Vec<Vec<f64>> = found.iter().map(|(_, y)| y.clone()).collect();
            let more = lanczos(&mut op, n, &locked, 1, seed)?;
            runs += 1;
            let smallest = found.iter().map(|(t, _)| *t).fold(f64::INFINITY, f64::min);
            match more.into_iter().next() {
                Some((theta, y)) if theta > smallest * (1.0 + 1e-9) => {
                    found.push((theta, y));
                    found.sort_by(|a, b| b.0.total_cmp(&a.0));
                    found.truncate(count);
                }
                _ => break,
            }
        }
        let solves = op.solves;
        let eq = &self.pattern.eq;
        let mut modes = Modes {
            eigenvalues: Vec::new(),
            frequencies: Vec::new(),
            shapes: Vec::new(),
            shift,
            solves,
            runs,
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
