//! The derivative of a step of time integration taken in several sub-steps: the change of the
//! step's end state with the inputs set before it (the step's end loads), the step's start
//! state held, through every sub-step (docs/dynamics.md, "Derivatives of a time step").
//!
//! ```text
//! sub-step k      R(u_k; v_k) + b_k + K_d,k (u_k − u_{k−1}) = 0          (dynamic.rs)
//!                 v_k = from + λ_k (to − from): dv_k = λ_k dv
//!                 b_k = [M A_k + C G_k + αf R(u_{k−1}; v_{k−1})]/(1 − αf)
//!                 A_k = (1−αm) a⁰ + αm a_{k−1},   G_k = (1−αf) v⁰ + αf v_{k−1}
//!                 a⁰ = −v_{k−1}/(βΔt) − (1−2β)/(2β) a_{k−1},  v⁰ = v_{k−1} + Δt((1−γ) a_{k−1} + γ a⁰)
//! forward         (J_k + K_d,k) du_k = λ_k g_k − db_k + K_d,k du_{k−1}      g_k = −∂R/∂v at u_k
//!                 db_k = [M dA_k + C dG_k + αf dR_{k−1}]/(1 − αf)
//!                 dR_{k−1} = J_{k−1} dz_{k−1} − λ_{k−1} g_{k−1} (force inputs; a prescribed
//!                            displacement's motion is in dz)
//!                 dv_k, da_k by Newmark's update of (du_k − du_{k−1}, dv_{k−1}, da_{k−1})
//!                 (linear in them); du_0 = dv_0 = da_0 = 0, dR_0 = 0: the start is held
//! ```
//! J_k is the true tangent at the sub-step's end (its wrinkle states as the law gives them
//! there), factored with K_d,k for each sub-step in turn: a derivative through S sub-steps costs
//! S factorizations (the solver keeps one factorization at a time). The adjoint of such a step
//! is taken one forward chain per known (the same numbers; `engine/derivatives.rs`).
//! Scenes with sleeves, ties or plastic strains are refused: their history (committed slips,
//! stick/slip states, plastic strains) carries from sub-step to sub-step and its change is not
//! propagated.

use super::assemble::NONE;
use super::core::Solver;
use super::dynamic::{Alpha, Integration, SubStepPoint};
use super::inertia::symmetric_product;
use crate::error::Error;
use crate::model::{LoadModel, Model};

/// The change of a step's end state through its sub-steps.
pub struct ChainChange {
    /// dz at the step's end, per unknown (held DOFs included).
    pub dz: Vec<f64>,
    /// dv and da at the step's end, per DOF.
    pub velocity: Vec<f64>,
    pub acceleration: Vec<f64>,
}

impl Solver {
    /// The forward chain (module docs) for the change `dv` of the step's end inputs (per
    /// input slot), through the sub-steps' end points `points`.
    pub fn step_chain(
        &mut self,
        model: &Model,
        integration: &Integration,
        points: &[SubStepPoint],
        dv: &[f64],
    ) -> Result<ChainChange, Error> {
        if !model.slips.is_empty() || !model.ties.is_empty() || model.plastic_len() > 0 {
            return Err(Error::Unsupported(
                "derivatives through several sub-steps of a scene with sleeves, ties or plastic strains (not implemented: their history carries from sub-step to sub-step)".into(),
            ));
        }
        let n3 = model.dof_count();
        let n = self.pattern.n;
        let eq = self.pattern.eq.clone();
        let alpha = Alpha::new(integration.rho_inf);
        let Alpha {
            am,
            af,
            beta,
            gamma,
        } = alpha;
        let mut du = vec![0.0; n3];
        let mut dvel = vec![0.0; n3];
        let mut dacc = vec![0.0; n3];
        let mut dz = vec![0.0; model.unknown_count()];
        // dR_{k−1} on the equations (0 at the start).
        let mut dr = vec![0.0; n];
        for point in points {
            let dt = point.dt;
            let kd = self.step_stiffness(model, integration, dt);
            let (m, c, col_ptr, row_idx) = {
                let x = self.dynamic_matrices.as_ref().ok_or_else(|| {
                    Error::Unsupported("internal: the time integration's matrices".into())
                })?;
                (
                    x.m.clone(),
                    x.c.clone(),
                    x.col_ptr.clone(),
                    x.row_idx.clone(),
                )
            };
            // −db_k + K_d,k du_{k−1} on the equations.
            let mut da_term = vec![0.0; n];
            let mut dg_term = vec![0.0; n];
            let mut du_prev = vec![0.0; n];
            for (d, &e) in eq.iter().enumerate() {
                if e == NONE {
                    continue;
                }
                let (v, a) = (dvel[d], dacc[d]);
                let a0 = -v / (beta * dt) - (1.0 - 2.0 * beta) / (2.0 * beta) * a;
                let v0 = v + dt * ((1.0 - gamma) * a + gamma * a0);
                da_term[e] = (1.0 - am) * a0 + am * a;
                dg_term[e] = (1.0 - af) * v0 + af * v;
                du_prev[e] = du[d];
            }
            let mut history = vec![0.0; n];
            symmetric_product(&col_ptr, &row_idx, &m, &da_term, &mut history);
            if !c.is_empty() {
                let mut cg = vec![0.0; n];
                symmetric_product(&col_ptr, &row_idx, &c, &dg_term, &mut cg);
                history.iter_mut().zip(&cg).for_each(|(h, x)| *h += x);
            }
            let mut kdu = vec![0.0; n];
            symmetric_product(&col_ptr, &row_idx, &kd, &du_prev, &mut kdu);
            // The tangent at the sub-step's end, its wrinkle states the law's there.
            let wrinkle: Vec<_> = self
                .evaluate_committed(model, &point.u, &point.loads)
                .membranes
                .iter()
                .map(|e| e.state)
                .collect();
            let tangent = self.factor_tangent(model, &point.u, &point.loads, &wrinkle, &[], &kd)?;
            let mut g = vec![0.0; model.unknown_count()];
            let mut held = vec![0.0; n3];
            // −∂R/∂v·dv_k at this end, the force inputs' part kept for dR_k.
            let mut force = vec![0.0; n3];
            for (slot, &s) in dv.iter().enumerate().filter(|(_, s)| **s != 0.0) {
                let (gk, hk) =
                    self.load_rhs(model, &point.u, &point.loads, &tangent, &wrinkle, &[], slot);
                let s = s * point.lambda;
                g.iter_mut().zip(&gk).for_each(|(a, b)| *a += s * b);
                held.iter_mut().zip(&hk).for_each(|(a, b)| *a += s * b);
                if !matches!(model.loads[slot], LoadModel::Displacement(_)) {
                    force
                        .iter_mut()
                        .zip(&gk[..n3])
                        .for_each(|(a, b)| *a += s * b);
                }
            }
            for (d, &e) in eq.iter().enumerate() {
                if e != NONE {
                    g[d] += kdu[e] - (history[e] + af * dr[e]) / (1.0 - af);
                }
            }
            let mut next = self.tangent_solve(&tangent, &g)?;
            for (a, b) in next.iter_mut().zip(&held) {
                *a += b;
            }
            // Newmark's update, linear in the changes, on every DOF (as the step commits).
            for d in 0..n3 {
                (dvel[d], dacc[d]) = alpha.update(dt, next[d] - du[d], dvel[d], dacc[d]);
                du[d] = next[d];
            }
            // dR_k = J_k dz_k − λ_k (force inputs' g) for the next sub-step's b.
            let product =
                self.tangent_product(model, &point.u, &point.loads, &tangent, &wrinkle, &next);
            for (d, &e) in eq.iter().enumerate() {
                if e != NONE {
                    dr[e] = product[d] - force[d];
                }
            }
            dz = next;
        }
        Ok(ChainChange {
            dz,
            velocity: dvel,
            acceleration: dacc,
        })
    }
}
