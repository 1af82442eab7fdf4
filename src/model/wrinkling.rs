//! Membrane constitutive laws with tension-field wrinkling: taut, wrinkled or slack.
//!
//! ```text
//! E = [E11, E22, 2E12]    Green-Lagrange strain (Voigt, engineering shear), C = I + 2E
//! E1 >= E2, t, m          principal strains and directions (t major, m minor, m ⊥ t)
//! λ1 >= λ2                eigenvalues of C (squared principal stretches), λi = 1 + 2Ei
//! v = [t1², t2², t1 t2],  w = [t1 m1, t2 m2, (t1 m2 + t2 m1)/2]   (Voigt of t⊗t and sym(t⊗m))
//!
//! mixed criterion (Kang & Im 1997): taut ⇔ trial minor principal stress >= 0, otherwise
//!   slack ⇔ E1 <= 0, wrinkled ⇔ E1 > 0
//! SVK      taut: S = D E;  trial S2 >= 0 ⇔ E2 + ν E1 >= 0
//!          wrinkled: S = E·E1 v (uniaxial, modulus E), C_w = E v vᵀ + 2 E E1/(E1 − E2) w wᵀ
//! neo-Hookean (incompressible, plane stress, shear modulus μ):
//!          taut: W = μ/2 (tr C + 1/det C − 3), S = μ (I − C⁻¹/det C),
//!                ℂ = 2μ/det C (C⁻¹⊗C⁻¹ + C⁻¹⊙C⁻¹);  trial S2 > 0 ⇔ λ2 > λ1^(-1/2)
//!          wrinkled (relaxed, natural width λ2 = λ1^(-1/2)): W = μ/2 (λ1 + 2/√λ1 − 3),
//!                S = 2ψ' v, ℂ = 4ψ'' v vᵀ + 8ψ'/(λ1 − λ2) w wᵀ, ψ' = μ/2 (1 − λ1^(-3/2)),
//!                ψ'' = 3μ/4 λ1^(-5/2)
//! slack:   S = 0, W = 0
//! ```
//! The wrinkled tangents include the rotation of the tension direction (the w wᵀ term), so
//! Newton converges quadratically in wrinkled regions; their denominators stay positive inside
//! the wrinkled state (E1 − E2 > (1 + ν) E1 > 0 for SVK, λ1 − λ2 > 0 for neo-Hookean).
//! Wrinkled and slack points add `ε D0` (ε = 1e-6, D0 the small-strain elasticity) to the
//! tangent only: the stress, hence the equilibrium, does not depend on it.
//!
//! The orthotropic (warp/fill) law, whose wrinkle direction must be solved for, lives in
//! `super::orthotropic`; `Law::Orthotropic` dispatches to it.
//!
//! # References
//! docs/mechanics.md §1.2 (SVK tension-field stress and consistent tangent) and §6 (neo-Hookean);
//! Kang & Im 1997, J. Appl. Mech. 64:263-269 (mixed criterion); Pipkin 1986 and Skouras et
//! al. 2014 (relaxed neo-Hookean energy); Stanuszek 2003 (the seed's "cable analogy").

use super::orthotropic::Orthotropic;
pub use super::plane_stress::{principal, Response, WrinkleState, REGULARIZATION, UNSTRAINED};
use nalgebra::{Matrix2, Matrix3, Vector2, Vector3};

/// A membrane material law.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Law {
    Svk {
        young: f64,
        nu: f64,
    },
    NeoHookean {
        mu: f64,
    },
    /// Warp/fill SVK with the generalised tension-field law (`super::orthotropic`).
    Orthotropic(Orthotropic),
}

fn v_w(angle: f64) -> (Vector3<f64>, Vector3<f64>) {
    let (s, c) = angle.sin_cos();
    let t = Vector2::new(c, s);
    let m = Vector2::new(-s, c);
    (
        Vector3::new(t.x * t.x, t.y * t.y, t.x * t.y),
        Vector3::new(t.x * m.x, t.y * m.y, 0.5 * (t.x * m.y + t.y * m.x)),
    )
}

impl Law {
    /// Small-strain plane-stress elasticity (neo-Hookean: E = 3μ, ν = 1/2).
    pub fn small_strain(&self) -> Matrix3<f64> {
        let (e, nu) = match *self {
            Law::Svk { young, nu } => (young, nu),
            Law::NeoHookean { mu } => (3.0 * mu, 0.5),
            Law::Orthotropic(o) => return o.d,
        };
        let c = e / (1.0 - nu * nu);
        Matrix3::new(
            c,
            c * nu,
            0.0,
            c * nu,
            c,
            0.0,
            0.0,
            0.0,
            c * (1.0 - nu) / 2.0,
        )
    }

    /// The state the mixed criterion assigns to a strain. The unstrained state counts as taut
    /// (its trial minor stress is 0, the taut border), so a stress-free sheet starts with its
    /// full elastic tangent; stresses are continuous across every border, so this choice
    /// affects only the tangent at E = 0. Principal strains within [`UNSTRAINED`] of zero are
    /// the round-off of an undeformed element and count as unstrained: otherwise a sheet at
    /// rest would report random wrinkled and slack elements and start from a random tangent.
    pub fn classify(&self, strain: &Vector3<f64>) -> WrinkleState {
        if let Law::Orthotropic(o) = self {
            return o.classify(strain);
        }
        let (e1, e2, _) = principal(strain);
        if e1.abs().max(e2.abs()) <= UNSTRAINED {
            return WrinkleState::Taut;
        }
        let taut = match *self {
            Law::Svk { nu, .. } => e2 + nu * e1 >= 0.0,
            Law::NeoHookean { .. } => {
                let (l1, l2) = (1.0 + 2.0 * e1, 1.0 + 2.0 * e2);
                l2 > 0.0 && l2 * l2 * l1 >= 1.0
            }
            Law::Orthotropic(_) => unreachable!("classified above"),
        };
        if taut {
            WrinkleState::Taut
        } else if e1 <= 0.0 {
            WrinkleState::Slack
        } else {
            WrinkleState::Wrinkled
        }
    }

    /// Response with wrinkling: the state from the mixed criterion, or `forced` (a state frozen
    /// by the solver against chatter).
    pub fn response(&self, strain: &Vector3<f64>, forced: Option<WrinkleState>) -> Response {
        self.response_with(strain, forced, REGULARIZATION)
    }

    /// [`Law::response`] with the tangent-only regularisation `eps` in place of
    /// [`REGULARIZATION`] (the patch Newton of nodal relaxation takes a smaller one,
    /// `solver/relax.rs`). Stress and energy do not depend on it.
    pub fn response_with(
        &self,
        strain: &Vector3<f64>,
        forced: Option<WrinkleState>,
        eps: f64,
    ) -> Response {
        if let Law::Orthotropic(o) = self {
            return o.response_with(strain, forced, eps);
        }
        let state = forced.unwrap_or_else(|| self.classify(strain));
        let (e1, e2, angle) = principal(strain);
        let reg = self.small_strain() * eps;
        let (stress, tangent, energy) = match state {
            WrinkleState::Taut => self.elastic(strain),
            WrinkleState::Slack => (Vector3::zeros(), reg, 0.0),
            WrinkleState::Wrinkled => {
                let (v, w) = v_w(angle);
                match *self {
                    Law::Svk { young, .. } => {
                        let gap = (e1 - e2).max(f64::MIN_POSITIVE);
                        let c = v * v.transpose() * young
                            + w * w.transpose() * (2.0 * young * e1 / gap);
                        (v * (young * e1), c + reg, 0.5 * young * e1 * e1)
                    }
                    Law::NeoHookean { mu } => {
                        let (l1, l2) = (1.0 + 2.0 * e1, 1.0 + 2.0 * e2);
                        let d1 = 0.5 * mu * (1.0 - l1.powf(-1.5));
                        let d2 = 0.75 * mu * l1.powf(-2.5);
                        let gap = (l1 - l2).max(f64::MIN_POSITIVE);
                        let c =
                            v * v.transpose() * (4.0 * d2) + w * w.transpose() * (8.0 * d1 / gap);
                        (
                            v * (2.0 * d1),
                            c + reg,
                            0.5 * mu * (l1 + 2.0 / l1.sqrt() - 3.0),
                        )
                    }
                    Law::Orthotropic(_) => unreachable!("answered above"),
                }
            }
        };
        Response {
            stress,
            tangent,
            energy,
            state,
            angle,
        }
    }

    /// The law without wrinkling (compression allowed): stress, tangent, energy density.
    #[allow(non_snake_case)]
    pub fn elastic(&self, strain: &Vector3<f64>) -> (Vector3<f64>, Matrix3<f64>, f64) {
        match *self {
            Law::Orthotropic(o) => o.elastic(strain),
            Law::Svk { .. } => {
                let D = self.small_strain();
                let S = D * strain;
                (S, D, 0.5 * strain.dot(&S))
            }
            Law::NeoHookean { mu } => {
                let C = Matrix2::new(
                    1.0 + 2.0 * strain[0],
                    strain[2],
                    strain[2],
                    1.0 + 2.0 * strain[1],
                );
                let J = C.determinant();
                let Ci = C.try_inverse().unwrap_or_else(Matrix2::zeros);
                let S = (Matrix2::identity() - Ci / J) * mu;
                let idx = [(0, 0), (1, 1), (0, 1)];
                let mut T = Matrix3::zeros();
                for (p, &(i, j)) in idx.iter().enumerate() {
                    for (q, &(k, l)) in idx.iter().enumerate() {
                        T[(p, q)] = 2.0 * mu / J
                            * (Ci[(i, j)] * Ci[(k, l)]
                                + 0.5 * (Ci[(i, k)] * Ci[(j, l)] + Ci[(i, l)] * Ci[(j, k)]));
                    }
                }
                let W = 0.5 * mu * (C.trace() + 1.0 / J - 3.0);
                (Vector3::new(S[(0, 0)], S[(1, 1)], S[(0, 1)]), T, W)
            }
        }
    }
}
