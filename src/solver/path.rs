//! Path following of one step: load increments with growth and cut-back, and the tangent
//! predictor for prescribed displacements.
//!
//! ```text
//! solve_step(from, to, u):  load(λ) = from + λ (to − from),  λ: 0 → 1 in increments Δλ
//!   each increment: predictor (prescribed DOFs moved), then Newton from the last converged u;
//!   on failure Δλ ← Δλ/4 (down to min_increment); on success Δλ ← 2 Δλ if N_iter <= N_target,
//!   1.5 Δλ if N_iter <= 3/4 N_max, else Δλ
//!   an increment that fails from an unstressed membrane is first solved again through the
//!   prestress continuation (below, at most once per step), and cut back only if that fails
//!   too
//! ```
//!
//! # The prestress continuation
//! A flat, stress-free membrane loaded normal to its plane has no stiffness out of its plane:
//! the artificial prestress (tangent only) starts the iteration, but from flat the problem
//! is self-similar in the load (a pure membrane's deflection grows as q^(1/3)), so a smaller
//! increment is as hard as the whole one and cutting back does not help. On fine meshes the
//! wrinkled regions then form and dissolve across many elements at once, and the first
//! increment can stall (the 4 m square with edge cables at 1M DOF: |R| between 0.35 and 7.6 N
//! from its 15th iteration to its 50th, force scale 7.5e3 N). The continuation solves instead a sequence of
//! problems in which every triangle carries an isotropic pre-strain h (the law sees
//! E + E0 + h (1, 1, 0): a real, energy-consistent prestress, wrinkling acting on the total
//! stress), h = h0, h0/4, h0/16, ... while h >= h0/1000, then h = 0, each Newton solve
//! starting from the last one's equilibrium. With h0 the membrane is taut almost everywhere
//! and the wrinkled regions grow stage by stage as the pre-strain is withdrawn; the last
//! problem is the scene's own, solved by the same Newton iteration and convergence test, so
//! the equilibrium is the one a direct solve would find. Only the path changes. If any stage
//! fails the increment is cut back as before. Not with friction in a sleeve: the stick/slip
//! history would take in the pre-strained problems' slips, and the answer would then depend on
//! the continuation. (A homotopy in the sense of Allgower & Georg
//! 2003, *Introduction to Numerical Continuation Methods*, ch. 1, followed in a few discrete
//! stages; the seed paper's artificial prestress, here in the residual and withdrawn.)

use super::assemble::{self, Membranes, NONE};
use super::core::Solver;
use super::loads::{external_forces, load_change, prescribe};
use super::report::{push_log, Outcome, StepReport};
use super::rows::Increment;
use crate::model::sleeve::Contact;
use crate::model::Model;

impl Solver {
    /// Apply the load change `from` → `to` starting from the equilibrium `u`. On convergence
    /// `u` is the new equilibrium; otherwise `u` is unchanged.
    pub fn solve_step(
        &mut self,
        model: &Model,
        from: &[f64],
        to: &[f64],
        u: &mut Vec<f64>,
    ) -> StepReport {
        let mut states = vec![0; model.slips.len()];
        self.solve_step_with(model, from, to, u, &mut states)
    }

    /// [`Solver::solve_step`] for a model with sleeves: `u` holds displacements then slips
    /// (`Model::unknown_count`), `states` the stick/slip code of every sleeve point
    /// (`model::sleeve`). The history (slips, states) advances only at converged increments;
    /// on failure both are unchanged.
    pub fn solve_step_with(
        &mut self,
        model: &Model,
        from: &[f64],
        to: &[f64],
        u: &mut Vec<f64>,
        states: &mut Vec<u8>,
    ) -> StepReport {
        if self.settings.arc_length_path {
            if let Some(report) = self.solve_step_arc(model, from, to, u, states) {
                return report;
            }
        }
        let mut report = StepReport::failed();
        let s = self.settings.clone();
        let step_change = load_change(model, from, to);
        let moved = from != to;
        let mut converged = u.clone();
        let mut converged_states: Vec<Contact> = states
            .iter()
            .map(|&c| Contact::from_code(c).unwrap_or_default())
            .collect();
        let (mut lambda, mut dl) = (0.0, s.initial_increment);
        // The prestress continuation runs at most once per step: where it failed, a smaller
        // increment from a start as unstressed meets the same difficulty.
        let mut continued = false;
        // Why the continuation failed, for the step's message if the step fails.
        let mut continuation_failed: Option<String> = None;
        while lambda < 1.0 {
            if report.increments + report.cutbacks >= s.max_increments {
                report.reached = lambda;
                report.message = format!(
                    "no equilibrium found beyond load fraction {lambda:.6} of the step ({} increments used)",
                    s.max_increments
                );
                return report;
            }
            dl = dl.min(1.0 - lambda);
            let target = if 1.0 - (lambda + dl) < 1e-12 {
                1.0
            } else {
                lambda + dl
            };
            let loads: Vec<f64> = from
                .iter()
                .zip(to)
                .map(|(a, b)| a + target * (b - a))
                .collect();
            let mut trial = converged.clone();
            let predicted = self.predict(model, &loads, &mut trial);
            let mut trial_states = converged_states.clone();
            let increment = Increment {
                loads: &loads,
                change: step_change,
                moved,
            };
            let result = self
                .newton(
                    model,
                    &increment,
                    &mut trial,
                    &mut trial_states,
                    None,
                    &mut report.log,
                )
                .map(|i| i + predicted)
                .map_err(|(i, why)| (i + predicted, why));
            let result = match result {
                Err((iters, why)) if !continued && self.unstressed(model, &converged, &loads) => {
                    continued = true;
                    report.iterations += iters;
                    push_log(
                        &mut report.log,
                        format!("increment λ {lambda:.6} -> {target:.6}: {why}; from an unstressed membrane: prestress continuation from pre-strain {:.1e}", s.continuation_strain),
                    );
                    trial = converged.clone();
                    let predicted = self.predict(model, &loads, &mut trial);
                    trial_states = converged_states.clone();
                    self.continuation(
                        model,
                        &increment,
                        &mut trial,
                        &mut trial_states,
                        &mut report.log,
                    )
                    .map(|i| i + predicted)
                    .map_err(|(i, later)| {
                        continuation_failed =
                            Some(format!("from load fraction {lambda:.6} it failed {later}"));
                        (
                            i + predicted,
                            format!("{why}; the prestress continuation failed too, {later}"),
                        )
                    })
                }
                other => other,
            };
            match result {
                Ok(iters) => {
                    report.iterations += iters;
                    report.increments += 1;
                    push_log(&mut report.log, format!("increment λ {lambda:.6} -> {target:.6}: converged in {iters} iterations"));
                    converged = trial;
                    converged_states = trial_states;
                    lambda = target;
                    dl *= growth(iters, s.target_iterations, s.max_iterations);
                }
                Err((iters, why)) => {
                    report.iterations += iters;
                    report.cutbacks += 1;
                    push_log(
                        &mut report.log,
                        format!("increment λ {lambda:.6} -> {target:.6}: {why}; cutting back"),
                    );
                    dl *= 0.25;
                    if dl < s.min_increment {
                        report.reached = lambda;
                        report.message = format!(
                            "no equilibrium found beyond load fraction {lambda:.6} of the step (smallest increment {:.1e} failed: {why})",
                            s.min_increment
                        );
                        let reached: Vec<f64> = from
                            .iter()
                            .zip(to)
                            .map(|(a, b)| a + target * (b - a))
                            .collect();
                        if let Some(note) = &continuation_failed {
                            report.message.push_str(&format!(
                                "; the prestress continuation was tried: {note}"
                            ));
                        }
                        let f_ext = external_forces(model, &reached);
                        if let Some(why) = super::mechanism::diagnose(model, &f_ext) {
                            report.message.push_str(&format!("; {why}"));
                        }
                        return report;
                    }
                }
            }
        }
        *u = converged;
        *states = converged_states.iter().map(|c| c.code()).collect();
        report.outcome = Outcome::Converged;
        report.reached = 1.0;
        report
    }

    /// Whether an increment that failed from `u` goes to the prestress continuation: it is on
    /// (`continuation_strain` > 0), the model has membrane triangles and no sleeve point with
    /// friction, and none of the triangles carries more tension at `u` than its artificial
    /// prestress (the singular flat start, where a cut-back meets the same difficulty again).
    /// Friction is excluded because its stick/slip history would take in the pre-strained
    /// problems' slips: the equilibrium would then depend on the continuation, not only the path.
    fn unstressed(&mut self, model: &Model, u: &[f64], loads: &[f64]) -> bool {
        if self.settings.continuation_strain <= 0.0
            || model.triangles.is_empty()
            || model.slips.iter().any(|p| p.mu > 0.0)
        {
            return false;
        }
        let held = self.probe_states.take();
        let evaluations = self.evaluate_membranes(model, u, loads);
        self.probe_states = held;
        evaluations
            .iter()
            .zip(&model.triangles)
            .all(|(e, t)| e.cauchy.0 <= t.prestress)
    }

    /// The prestress continuation (module docs) of one increment from `u` (its start, the
    /// prescribed displacements set): Newton at pre-strain h0, h0/4, ... (while >= h0/1000),
    /// then 0, each from the last equilibrium. Returns the iterations of every stage, or where
    /// it failed; the pre-strain is 0 again on return.
    fn continuation(
        &mut self,
        model: &Model,
        increment: &Increment,
        u: &mut [f64],
        states: &mut Vec<Contact>,
        log: &mut Vec<String>,
    ) -> Result<usize, (usize, String)> {
        let start = self.settings.continuation_strain;
        let (mut h, mut total) = (start, 0);
        let outcome = loop {
            self.pre_strain = h;
            match self.newton(model, increment, u, states, None, log) {
                Ok(n) => {
                    total += n;
                    push_log(
                        log,
                        format!("  prestress continuation: pre-strain {h:.2e} converged in {n} iterations"),
                    );
                }
                Err((n, why)) => {
                    break Err((total + n, format!("at pre-strain {h:.2e}: {why}")));
                }
            }
            if h == 0.0 {
                break Ok(total);
            }
            h = if h / 4.0 >= 1e-3 * start {
                h / 4.0
            } else {
                0.0
            };
        };
        self.pre_strain = 0.0;
        outcome
    }

    /// Start an increment whose prescribed displacements change: one Newton step linearized at
    /// the converged state `u`, with the prescribed change as a load on the free DOFs,
    /// K_ff Δu_f = −(R_f + K_fp Δu_p). Moving only the prescribed DOFs would strain a single
    /// layer of elements and spend the first iterations (and wrinkle-state switches) undoing
    /// it. Returns the factorizations used (0 when nothing is prescribed to move, or 1);
    /// `u` leaves with the prescribed values set in any case.
    pub(super) fn predict(&mut self, model: &Model, loads: &[f64], u: &mut [f64]) -> usize {
        let mut du = vec![0.0; u.len()];
        let mut target = u.to_vec();
        prescribe(model, loads, &mut target);
        let mut moved = false;
        for (d, (a, b)) in u.iter().zip(&target).enumerate() {
            if a != b {
                du[d] = b - a;
                moved = true;
            }
        }
        if !moved {
            return 0;
        }
        let mut coupling = vec![0.0; u.len()];
        let membranes = Membranes {
            held_step: Some((&du, &mut coupling)),
            ..Default::default()
        };
        assemble::assemble_with(
            model,
            &self.pattern,
            u,
            loads,
            &mut self.residual,
            Some(self.linear.values_mut()),
            membranes,
        );
        for (d, &e) in self.pattern.eq.iter().enumerate() {
            if e != NONE {
                self.rhs[e] = -(self.residual[d] + coupling[d]);
            }
        }
        let solved = self.linear.factor_solve(&mut self.rhs).is_ok();
        u.copy_from_slice(&target);
        if solved {
            for (d, &e) in self.pattern.eq.iter().enumerate() {
                if e != NONE {
                    u[d] += self.rhs[e];
                }
            }
        }
        1
    }
}

/// Increment growth after a converged increment. A state switch (wrinkled/slack/taut) costs a
/// few Newton iterations whatever the increment size, so iteration counts above the target do
/// not mean the increment is too large: grow 2x up to the target, 1.5x up to three quarters of
/// the iteration limit, keep it otherwise. Failures cut it by 4.
fn growth(iterations: usize, target: usize, max_iterations: usize) -> f64 {
    if iterations <= target {
        2.0
    } else if 4 * iterations <= 3 * max_iterations {
        1.5
    } else {
        1.0
    }
}
