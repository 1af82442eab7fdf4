//! The proximal continuation of a failed increment: implicit pseudo-time towards equilibrium.
//!
//! An increment Newton could not solve is solved again from its start through a sequence of
//! problems, each of which ties every point to the last one by a spring,
//!
//! ```text
//! R(u_{k+1}) + τ_k D (u_{k+1} − u_k) = 0
//! ```
//!
//! with D the diagonal stiffness the structure would have with every element taut and
//! unstressed (the damping's, newton.rs). Each problem is a backward-Euler step of the
//! overdamped motion D u̇ = −R with the pseudo-time step 1/τ_k, solved by the one Newton loop
//! (the spring enters where a time sub-step's inertia force does, inertia.rs), so wrinkle,
//! slack and contact states change inside each problem and the path follows the motion
//! towards a stable equilibrium. With a potential Π each problem minimises
//! Π(u) + ½ τ_k |u − u_k|²_D, the proximal-point step (Rockafellar 1976): Π falls from
//! problem to problem, and τ → 0 leaves the scene's own problem.
//!
//! - **The schedule.** τ_0 = `proximal_start` (1e-3). After a solved problem τ falls by 16,
//!   4 or 2 as it took at most 4, at most 10 or more Newton iterations. A problem that fails
//!   is solved again from u_k with τ ×4.
//! - **Inexact problems.** A problem with a spring is solved once its residual is 1e-2 of its
//!   force scale (an inexact proximal step: only the last problem must be exact). Measured on
//!   the robustness corpus against exact problems: docs/robustness.md.
//! - **No artificial prestress inside.** The spring is the tangent's regularisation there;
//!   the artificial prestress (out-of-plane stiffness of an unstressed membrane) made each
//!   problem converge only linearly, since it does not fade while the residual is large.
//! - **The end.** Below τ = 1e-9 the spring is dropped and the scene's own problem is solved
//!   from the last point with the full convergence test: the equilibrium is the scene's, only
//!   the path differs. If that fails, pseudo-time goes on from τ = 1.6e-8, at most
//!   `MAX_FINAL` times; at most `MAX_PROBLEMS` problems; the step's work budget bounds all.
//!   Where no problem with a spring moved the point (each solved in 0 iterations: the start
//!   is already within `ACCEPT` of equilibrium, so the trouble is in the last digits, which a
//!   spring does not help with), the scene's own problem would be the failed one again from
//!   the same point: the continuation ends there (measured: the sheared film WrinkledShear
//!   stalling at its local tolerance spent 150 iterations on such repeats).
//! - **Where.** Not with elastoplastic groups: their answer depends on the load path, and a
//!   cut-back is the remedy that follows it more closely (measured: an ETFE strip yielding from
//!   flat, which the cut-backs solve, spent its budget in the continuation). Not with sleeve
//!   points (their slips carry no spring, so the problems are not regularised in them;
//!   measured: rings and drawstrings lost rows) and not in a time sub-step (which has its own
//!   inertia).
//! - **Volume and gas inputs.** Their rows stay constraints of every problem: each minimises
//!   Π(u) + ½ τ_k |u − u_k|²_D with the enclosed volume (or the gas law) held, the pressure
//!   its multiplier. The pressure needs no spring: with K + τD positive definite the bordered
//!   matrix is regular wherever ∂V/∂u ≠ 0, a flat cushion included (its first problem inflates
//!   it along D⁻¹ ∂V/∂u, its normals). Measured (sixteenth session) on the corpus's
//!   `cushion-volume` family over nine seeds: 80-95.7 % right without, 85.7-100 % with, none
//!   wrong; the failures left are free-rim bags partly inflated, slack at zero pressure
//!   (docs/robustness.md). Until then volume inputs were left out: the shipped gas cushion
//!   spent its budget in it then, and is elastoplastic (left out for that) now. After the prestress continuation where that applies (path.rs): measured,
//!   docs/robustness.md.
//!
//! # References
//! Rockafellar 1976, SIAM J. Control Optim. 14:877–898 (the proximal point algorithm);
//! Kelley & Keyes 1998, SIAM J. Numer. Anal. 35:508–523 (pseudo-transient continuation);
//! Solodov & Svaiter 1999, Set-Valued Anal. 7:323–345 (inexact proximal steps).

use super::assemble::NONE;
use super::core::Solver;
use super::inertia::Inertia;
use super::report::push_log;
use super::rows::Increment;
use crate::model::sleeve::Contact;
use crate::model::Model;

/// τ below which the spring is dropped (relative to D).
const TAU_END: f64 = 1e-9;
/// Relative residual at which a problem with a spring is solved.
pub(super) const ACCEPT: f64 = 1e-2;
/// Most problems of one continuation.
const MAX_PROBLEMS: usize = 60;
/// Most failures of the scene's own problem at the end.
const MAX_FINAL: usize = 3;

impl Solver {
    /// Whether the proximal continuation applies (module docs).
    pub(super) fn proximal_applies(&self, model: &Model) -> bool {
        self.settings.proximal_start > 0.0
            && self.inertia.is_none()
            && model.slips.is_empty()
            && model.plastic_len() == 0
    }

    /// The proximal continuation (module docs) of one increment from `u` (its start, the
    /// prescribed displacements set). Returns the iterations of every problem, or why it failed.
    pub(super) fn proximal(
        &mut self,
        model: &Model,
        increment: &Increment,
        u: &mut [f64],
        states: &mut Vec<Contact>,
        log: &mut Vec<String>,
    ) -> Result<usize, (usize, String)> {
        let n = self.pattern.n;
        let symbolic = self.linear.matrix().symbolic();
        let (col_ptr, row_idx) = (symbolic.col_ptr().to_vec(), symbolic.row_idx().to_vec());
        let nnz = row_idx.len();
        let mut tau = self.settings.proximal_start;
        let (mut total, mut problems, mut finals) = (0, 0, 0);
        // Whether a problem with a spring moved the point since the start or the last failure
        // of the scene's own problem: if none did, that problem would be the one that failed,
        // from the same point.
        let mut moved = false;
        let mut last = u.to_vec();
        let mut last_states = states.clone();
        let outcome = loop {
            if self.work_spent() {
                break Err((
                    total,
                    format!("after {problems} proximal problems (τ = {tau:.1e}): the step's work budget is spent"),
                ));
            }
            if problems == MAX_PROBLEMS {
                break Err((
                    total,
                    format!("not solved in {MAX_PROBLEMS} proximal problems"),
                ));
            }
            let spring = tau >= TAU_END;
            if !spring && !moved {
                break Err((
                    total,
                    format!("after {problems} proximal problems the point had not moved: the increment's start is within {ACCEPT:.0e} of the scale from equilibrium, which a spring does not bring closer"),
                ));
            }
            self.inertia = spring.then(|| {
                let mut k = vec![0.0; nnz];
                for (e, &p) in self.diagonal_positions.iter().enumerate().take(n) {
                    k[p] = tau * self.reference_diagonal[e];
                }
                let mut u_n = vec![0.0; n];
                for (d, &e) in self.pattern.eq.iter().enumerate() {
                    if e != NONE {
                        u_n[e] = last[d];
                    }
                }
                Inertia {
                    k,
                    u_n,
                    b: vec![0.0; n],
                    delta: vec![0.0; n],
                    g: vec![0.0; n],
                    col_ptr: col_ptr.clone(),
                    row_idx: row_idx.clone(),
                }
            });
            u.copy_from_slice(&last);
            states.clone_from(&last_states);
            self.proximal = spring;
            let result = self.newton(model, increment, u, states, None, log);
            self.proximal = false;
            self.inertia = None;
            problems += 1;
            match result {
                Ok(i) => {
                    total += i;
                    push_log(
                        log,
                        format!("  proximal continuation: τ = {tau:.2e} solved in {i} iterations"),
                    );
                    if !spring {
                        break Ok(total);
                    }
                    moved |= i > 0;
                    last.copy_from_slice(u);
                    last_states.clone_from(states);
                    tau /= match i {
                        0..=4 => 16.0,
                        5..=10 => 4.0,
                        _ => 2.0,
                    };
                }
                Err((i, why)) => {
                    total += i;
                    push_log(
                        log,
                        format!("  proximal continuation: τ = {tau:.2e} failed after {i} iterations: {why}"),
                    );
                    if !spring {
                        finals += 1;
                        if finals == MAX_FINAL {
                            break Err((
                                total,
                                format!("the scene's own problem at the end: {why}"),
                            ));
                        }
                        tau = 16.0 * TAU_END;
                        moved = false;
                    } else {
                        tau *= 4.0;
                        if tau > self.settings.damping_max {
                            break Err((total, format!("at τ = {tau:.1e}: {why}")));
                        }
                    }
                }
            }
        };
        self.inertia = None;
        outcome
    }
}
