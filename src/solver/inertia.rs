//! The inertia force of a time sub-step on the System's equations (`dynamic.rs` builds it,
//! system.rs and line_search.rs add it where they assemble), and the symmetric product with a
//! matrix on the tangent's pattern that it and the mass matrix (`mass.rs`) share. A leaf:
//! plain data the solver's workspace (core.rs) holds.

use super::assemble::NONE;

/// y = A x for a symmetric A stored as its upper triangle in CSC (`col_ptr`, `row_idx`,
/// `values`), over the equations.
pub fn symmetric_product(
    col_ptr: &[usize],
    row_idx: &[usize],
    values: &[f64],
    x: &[f64],
    y: &mut [f64],
) {
    y.fill(0.0);
    for j in 0..x.len() {
        let xj = x[j];
        let mut sum = 0.0;
        for p in col_ptr[j]..col_ptr[j + 1] {
            let i = row_idx[p];
            let a = values[p];
            if i == j {
                sum += a * xj;
            } else {
                y[i] += a * xj;
                sum += a * x[i];
            }
        }
        y[j] += sum;
    }
}

/// M and C on the tangent's pattern (values over the equations), built once per solver, and
/// what the time integration carries from one step to the next in the solver ([`Carry`]).
#[derive(Clone, Debug)]
pub struct Matrices {
    pub m: Vec<f64>,
    /// Empty when the scene has no Rayleigh damping.
    pub c: Vec<f64>,
    /// The tangent's pattern over the equations (column pointers, row indices).
    pub col_ptr: Vec<usize>,
    pub row_idx: Vec<usize>,
    pub(super) carry: Carry,
}

/// What a time step leaves for the next (`dynamic.rs`): work that a step would otherwise
/// redo, never a value the next step could not compute itself bit for bit (a state restored
/// through the FMI continues as the uninterrupted run does).
#[derive(Clone, Debug, Default)]
pub struct Carry {
    /// The inertia force's buffers of the last sub-step and its Δt: K_d is rebuilt only when
    /// Δt changes, and no buffer is allocated again.
    pub(super) inertia: Option<(f64, Inertia)>,
    /// The static residual R (on the equations, before the inertia force) of the last trial
    /// point of a time sub-step's line search (`line_search.rs`), with that point and its
    /// loads: the next step's R(u_n, t_n) where it starts from that very point under those
    /// very loads (`Solver::static_residual`).
    pub(super) residual: Option<TrialResidual>,
}

/// R at a trial point (see [`Carry::residual`]).
#[derive(Clone, Debug, Default)]
pub struct TrialResidual {
    pub(super) u: Vec<f64>,
    pub(super) loads: Vec<f64>,
    pub(super) r: Vec<f64>,
}

/// The inertia and history force of one sub-step, g = b + K_d δ (module docs), on the
/// equations.
#[derive(Clone, Debug, Default)]
pub struct Inertia {
    /// K_d's values on the tangent's pattern.
    pub(super) k: Vec<f64>,
    /// u_n and b per equation.
    pub(super) u_n: Vec<f64>,
    pub(super) b: Vec<f64>,
    /// Scratch: δ and g per equation.
    pub(super) delta: Vec<f64>,
    pub(super) g: Vec<f64>,
    /// The tangent's pattern (column pointers and row indices over the equations).
    pub(super) col_ptr: Vec<usize>,
    pub(super) row_idx: Vec<usize>,
}

impl Inertia {
    /// g at `u` (per DOF, model order) into the solver's residual on the free DOFs (its
    /// magnitude into `magnitude`, when given), K_d into `values` when given; returns the
    /// potential ½ δᵀK_d δ + bᵀδ.
    pub(super) fn apply(
        &mut self,
        eq: &[usize],
        u: &[f64],
        residual: &mut [f64],
        values: Option<&mut [f64]>,
        magnitude: Option<&mut [f64]>,
    ) -> f64 {
        for (d, &e) in eq.iter().enumerate() {
            if e != NONE {
                self.delta[e] = u[d] - self.u_n[e];
            }
        }
        symmetric_product(
            &self.col_ptr,
            &self.row_idx,
            &self.k,
            &self.delta,
            &mut self.g,
        );
        let mut potential = 0.0;
        for e in 0..self.g.len() {
            potential += self.delta[e] * (0.5 * self.g[e] + self.b[e]);
            self.g[e] += self.b[e];
        }
        for (d, &e) in eq.iter().enumerate() {
            if e != NONE {
                residual[d] += self.g[e];
            }
        }
        if let Some(m) = magnitude {
            for (d, &e) in eq.iter().enumerate() {
                if e != NONE {
                    m[d] += self.g[e].abs();
                }
            }
        }
        if let Some(values) = values {
            for (v, k) in values.iter_mut().zip(&self.k) {
                *v += k;
            }
        }
        potential
    }
}
