//! Path following of one step: load increments with growth and cut-back, and the tangent
//! predictor for prescribed displacements.
//!
//! ```text
//! solve_step(from, to, u):  load(λ) = from + λ (to − from),  λ: 0 → 1 in increments Δλ
//!   each increment: predictor (prescribed DOFs moved), then Newton from the last converged u;
//!   on failure Δλ ← Δλ/4 (down to min_increment); on success Δλ ← 2 Δλ if N_iter <= N_target,
//!   1.5 Δλ if N_iter <= 3/4 N_max, else Δλ
//!   an increment that fails from or towards an unstressed membrane is first solved again
//!   through the prestress continuation (below), then, where that fails or does not apply,
//!   through the overshoot continuation (overshoot.rs: from an unstressed membrane, the force
//!   loads raised and brought back) and the proximal continuation (proximal.rs), each at most
//!   once per step, and cut back only if those fail too
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
use super::loads::{load_change, loads_at, prescribe};
use super::report::{push_log, StepReport};
use super::rows::Increment;
use super::settings::Settings;
use crate::model::sleeve::Contact;
use crate::model::state::History;
use crate::model::Model;

/// What one increment attempt of a driver did (`stepper.rs`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Attempt {
    /// The increment converged: the load fraction moved to `lambda`.
    Accepted { lambda: f64, iterations: usize },
    /// The increment was cut back (`failed`: below the smallest increment, or out of
    /// increments: the step has failed); the load fraction stays at `lambda`.
    Rejected {
        lambda: f64,
        iterations: usize,
        failed: bool,
    },
}

/// Load control of one step in progress: the last converged point, the next increment, and
/// the continuations' once-per-step records.
pub struct LoadPath {
    from: Vec<f64>,
    to: Vec<f64>,
    /// |Δf_ext|∞ of the whole step (the convergence test's force scale) and whether anything
    /// changed.
    change: f64,
    moved: bool,
    pub(super) lambda: f64,
    dl: f64,
    pub(super) converged: Vec<f64>,
    pub(super) history: History,
    /// The prestress continuation runs at most once per step: where it failed, a smaller
    /// increment from a start as unstressed meets the same difficulty.
    continued: bool,
    /// The proximal continuation (proximal.rs) likewise runs at most once per step.
    proximal_tried: bool,
    /// And so does the overshoot continuation (overshoot.rs).
    overshoot_tried: bool,
    /// Why the continuation failed, for the step's message if the step fails.
    continuation_failed: Option<String>,
    /// A start for Newton on the whole step, tried once before the first increment (the
    /// coarse start, `engine/coarse.rs`).
    pub(super) guess: Option<Vec<f64>>,
}

impl LoadPath {
    /// The step `from` → `to` from the equilibrium `u` with the history `history` (installed
    /// in the model: `state.rs`).
    pub fn begin(
        model: &Model,
        settings: &Settings,
        from: &[f64],
        to: &[f64],
        u: &[f64],
        history: History,
    ) -> LoadPath {
        history.install(model);
        LoadPath {
            from: from.to_vec(),
            to: to.to_vec(),
            change: load_change(model, from, to),
            moved: from != to,
            lambda: 0.0,
            dl: settings.initial_increment,
            converged: u.to_vec(),
            history,
            continued: false,
            proximal_tried: false,
            overshoot_tried: false,
            continuation_failed: None,
            guess: None,
        }
    }

    /// Why the prestress continuation failed, if it ran and failed in this step.
    pub(super) fn continuation_note(&self) -> Option<&str> {
        self.continuation_failed.as_deref()
    }

    /// The loads at load fraction `lambda` of the step.
    pub fn loads(&self, lambda: f64) -> Vec<f64> {
        loads_at(&self.from, &self.to, lambda)
    }

    /// One increment attempt: Newton from the last converged point to λ + Δλ (after a failure,
    /// once per step each, the prestress and the proximal continuation where they apply), then
    /// accept or reject. None once the whole step is applied.
    pub fn advance(
        &mut self,
        solver: &mut Solver,
        model: &Model,
        report: &mut StepReport,
    ) -> Option<Attempt> {
        if self.lambda >= 1.0 {
            return None;
        }
        let s = solver.settings.clone();
        if report.increments + report.cutbacks >= s.max_increments {
            report.reached = self.lambda;
            report.message = format!(
                "no equilibrium found beyond load fraction {:.6} of the step ({} increments used)",
                self.lambda, s.max_increments
            );
            return Some(Attempt::Rejected {
                lambda: self.lambda,
                iterations: 0,
                failed: true,
            });
        }
        if let Some(guess) = self.guess.take() {
            return Some(self.guessed(solver, model, report, guess));
        }
        self.dl = self.dl.min(1.0 - self.lambda);
        let target = if 1.0 - (self.lambda + self.dl) < 1e-12 {
            1.0
        } else {
            self.lambda + self.dl
        };
        let loads = self.loads(target);
        let (result, trial, trial_states) = self.attempt(solver, model, &loads, target, report);
        Some(match result {
            Ok(iters) => self.accept(model, &s, report, target, iters, trial, trial_states),
            Err((iters, why)) => self.reject(solver, model, &s, report, target, iters, why),
        })
    }

    /// Newton on the whole step from `guess` instead of the last converged point (the coarse
    /// start): accepted as the step's one increment when it converges; otherwise nothing
    /// changes (no cut-back, Δλ as it was) and the step goes on from its start.
    fn guessed(
        &mut self,
        solver: &mut Solver,
        model: &Model,
        report: &mut StepReport,
        guess: Vec<f64>,
    ) -> Attempt {
        let loads = self.loads(1.0);
        let increment = Increment {
            loads: &loads,
            change: self.change,
            moved: self.moved,
        };
        let mut trial = guess;
        let mut states = self.history.contact.clone();
        let outcome = solver.newton(
            model,
            &increment,
            &mut trial,
            &mut states,
            None,
            &mut report.log,
        );
        match outcome {
            Ok(iters) => {
                let s = solver.settings.clone();
                self.accept(model, &s, report, 1.0, iters, trial, states)
            }
            Err((iters, why)) => {
                report.iterations += iters;
                push_log(
                    &mut report.log,
                    format!(
                        "from the coarse mesh's answer: {why}; the step goes on from its start"
                    ),
                );
                Attempt::Rejected {
                    lambda: self.lambda,
                    iterations: iters,
                    failed: false,
                }
            }
        }
    }

    /// Newton (and, where they apply, the prestress and proximal continuations) for the increment to
    /// `target`: the outcome with the trial point and its stick/slip states.
    #[allow(clippy::type_complexity)]
    fn attempt(
        &mut self,
        solver: &mut Solver,
        model: &Model,
        loads: &[f64],
        target: f64,
        report: &mut StepReport,
    ) -> (Result<usize, (usize, String)>, Vec<f64>, Vec<Contact>) {
        let mut trial = self.converged.clone();
        let predicted = solver.predict(model, loads, &mut trial);
        let mut trial_states = self.history.contact.clone();
        let increment = Increment {
            loads,
            change: self.change,
            moved: self.moved,
        };
        let mut result = solver
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
        if result.is_err() {
            // The prestress continuation where it applies (from or towards an unstressed
            // membrane), then the overshoot one (overshoot.rs), then the proximal one
            // (proximal.rs; measured orders: docs/solver.md, docs/robustness.md).
            let last_unstressed = solver.unstressed(model, &trial, loads);
            for stage in [0, 1, 2] {
                let Err((iters, why)) = result else { break };
                let again = if stage == 0 {
                    self.prestress_stage(
                        solver,
                        model,
                        &increment,
                        (target, last_unstressed),
                        report,
                        iters,
                        why,
                    )
                } else if stage == 1 {
                    self.overshoot_stage(solver, model, &increment, target, report, iters, why)
                } else {
                    self.proximal_stage(solver, model, &increment, target, report, iters, why)
                };
                result = match again {
                    Ok((outcome, t, states)) => {
                        trial = t;
                        trial_states = states;
                        outcome
                    }
                    Err(unchanged) => Err(unchanged),
                };
            }
        }
        (result, trial, trial_states)
    }

    /// The prestress continuation of a failed increment where it applies (once per step, from
    /// or towards an unstressed membrane): Ok(its outcome, point, states), or Err(the failure
    /// unchanged) where it does not apply.
    #[allow(clippy::too_many_arguments, clippy::type_complexity)]
    fn prestress_stage(
        &mut self,
        solver: &mut Solver,
        model: &Model,
        increment: &Increment,
        (target, last_unstressed): (f64, bool),
        report: &mut StepReport,
        iters: usize,
        why: String,
    ) -> Result<(Result<usize, (usize, String)>, Vec<f64>, Vec<Contact>), (usize, String)> {
        let from = solver.unstressed(model, &self.converged, increment.loads);
        if self.continued || !(from || last_unstressed) {
            return Err((iters, why));
        }
        self.continued = true;
        let whence = if from {
            "from an unstressed membrane"
        } else {
            "towards an unstressed membrane"
        };
        let start = format!(
            "{whence}: prestress continuation from pre-strain {:.1e}",
            solver.settings.continuation_strain
        );
        Ok(self.stage(
            solver,
            model,
            increment,
            (target, report),
            (iters, why),
            ("prestress", start, true),
            |s, u, c, log| s.continuation(model, increment, u, c, log),
        ))
    }

    /// The overshoot continuation (overshoot.rs) of a failed increment where it applies (once
    /// per step, from an unstressed membrane): as [`LoadPath::prestress_stage`].
    #[allow(clippy::too_many_arguments, clippy::type_complexity)]
    fn overshoot_stage(
        &mut self,
        solver: &mut Solver,
        model: &Model,
        increment: &Increment,
        target: f64,
        report: &mut StepReport,
        iters: usize,
        why: String,
    ) -> Result<(Result<usize, (usize, String)>, Vec<f64>, Vec<Contact>), (usize, String)> {
        if self.overshoot_tried || !solver.overshoot_applies(model) || solver.work_spent() {
            return Err((iters, why));
        }
        let Some(f0) = solver.overshoot_factor(model, increment.loads) else {
            return Err((iters, why));
        };
        if !solver.unstressed(model, &self.converged, increment.loads) {
            return Err((iters, why));
        }
        self.overshoot_tried = true;
        let start = format!(
            "from an unstressed membrane: overshoot continuation from {f0:.3} times the load"
        );
        Ok(self.stage(
            solver,
            model,
            increment,
            (target, report),
            (iters, why),
            ("overshoot", start, false),
            |s, u, c, log| s.overshoot(model, increment, f0, u, c, log),
        ))
    }

    /// The proximal continuation (proximal.rs) of a failed increment where it applies (once
    /// per step): as [`LoadPath::prestress_stage`].
    #[allow(clippy::too_many_arguments, clippy::type_complexity)]
    fn proximal_stage(
        &mut self,
        solver: &mut Solver,
        model: &Model,
        increment: &Increment,
        target: f64,
        report: &mut StepReport,
        iters: usize,
        why: String,
    ) -> Result<(Result<usize, (usize, String)>, Vec<f64>, Vec<Contact>), (usize, String)> {
        if self.proximal_tried || !solver.proximal_applies(model) || solver.work_spent() {
            return Err((iters, why));
        }
        self.proximal_tried = true;
        let start = format!(
            "proximal continuation from τ {:.1e}",
            solver.settings.proximal_start
        );
        Ok(self.stage(
            solver,
            model,
            increment,
            (target, report),
            (iters, why),
            ("proximal", start, false),
            |s, u, c, log| s.proximal(model, increment, u, c, log),
        ))
    }

    /// One continuation stage of a failed increment (`name`, started as `start` says): the
    /// failed attempt's iterations counted, the start logged, the increment solved again from
    /// its start by `solve`, and a failure's message saying that this continuation failed too
    /// (kept for the step's message where `noted`: the prestress continuation's).
    #[allow(clippy::too_many_arguments, clippy::type_complexity)]
    fn stage(
        &mut self,
        solver: &mut Solver,
        model: &Model,
        increment: &Increment,
        (target, report): (f64, &mut StepReport),
        (iters, why): (usize, String),
        (name, start, noted): (&str, String, bool),
        solve: impl FnOnce(
            &mut Solver,
            &mut [f64],
            &mut Vec<Contact>,
            &mut Vec<String>,
        ) -> Result<usize, (usize, String)>,
    ) -> (Result<usize, (usize, String)>, Vec<f64>, Vec<Contact>) {
        report.iterations += iters;
        push_log(
            &mut report.log,
            format!(
                "increment λ {:.6} -> {target:.6}: {why}; {start}",
                self.lambda
            ),
        );
        let (outcome, trial, states) = self.again(solver, model, increment, report, solve);
        let lambda = self.lambda;
        let outcome = outcome.map_err(|(i, later)| {
            if noted {
                self.continuation_failed =
                    Some(format!("from load fraction {lambda:.6} it failed {later}"));
            }
            (
                i,
                format!("{why}; the {name} continuation failed too, {later}"),
            )
        });
        (outcome, trial, states)
    }

    /// The increment solved again from its start (the last converged point, its prediction and
    /// stick/slip states) by `solve`, a continuation: the outcome with the prediction's
    /// factorizations counted, the point and its states.
    #[allow(clippy::type_complexity)]
    fn again(
        &self,
        solver: &mut Solver,
        model: &Model,
        increment: &Increment,
        report: &mut StepReport,
        solve: impl FnOnce(
            &mut Solver,
            &mut [f64],
            &mut Vec<Contact>,
            &mut Vec<String>,
        ) -> Result<usize, (usize, String)>,
    ) -> (Result<usize, (usize, String)>, Vec<f64>, Vec<Contact>) {
        let mut trial = self.converged.clone();
        let predicted = solver.predict(model, increment.loads, &mut trial);
        let mut states = self.history.contact.clone();
        let outcome = solve(solver, &mut trial, &mut states, &mut report.log)
            .map(|i| i + predicted)
            .map_err(|(i, why)| (i + predicted, why));
        (outcome, trial, states)
    }

    /// A converged increment: its point becomes the last converged one (the history advanced
    /// to it) and Δλ grows.
    #[allow(clippy::too_many_arguments)]
    fn accept(
        &mut self,
        model: &Model,
        s: &Settings,
        report: &mut StepReport,
        target: f64,
        iters: usize,
        trial: Vec<f64>,
        trial_states: Vec<Contact>,
    ) -> Attempt {
        report.iterations += iters;
        report.increments += 1;
        push_log(
            &mut report.log,
            format!(
                "increment λ {:.6} -> {target:.6}: converged in {iters} iterations",
                self.lambda
            ),
        );
        self.history = self.history.advanced(model, &trial, trial_states);
        self.converged = trial;
        self.lambda = target;
        self.dl *= growth(iters, s.target_iterations, s.max_iterations);
        Attempt::Accepted {
            lambda: target,
            iterations: iters,
        }
    }

    /// A failed increment: Δλ is cut by 4; below the smallest increment the step fails, with
    /// the continuation's note and what is known of the structure there in its message
    /// (`mechanism.rs`: a mechanism only once verified).
    #[allow(clippy::too_many_arguments)]
    fn reject(
        &mut self,
        solver: &mut Solver,
        model: &Model,
        s: &Settings,
        report: &mut StepReport,
        target: f64,
        iters: usize,
        why: String,
    ) -> Attempt {
        let lambda = self.lambda;
        report.iterations += iters;
        report.cutbacks += 1;
        push_log(
            &mut report.log,
            format!("increment λ {lambda:.6} -> {target:.6}: {why}; cutting back"),
        );
        self.dl *= 0.25;
        // A step whose work budget ran out inside this increment ends through the stepper's
        // give-up (stepper.rs), whose message names the last increment that failed for a
        // reason of its own, not this one's "budget spent".
        let failed = self.dl < s.min_increment && !solver.work_spent();
        if failed {
            report.reached = lambda;
            report.message = format!(
                "no equilibrium found beyond load fraction {lambda:.6} of the step (smallest increment {:.1e} failed: {why})",
                s.min_increment
            );
            if let Some(note) = &self.continuation_failed {
                report
                    .message
                    .push_str(&format!("; the prestress continuation was tried: {note}"));
            }
            let loads = self.loads(target);
            let known = solver.diagnose_failure(model, &self.converged, &loads, lambda);
            report.message.push_str(&known);
        }
        Attempt::Rejected {
            lambda,
            iterations: iters,
            failed,
        }
    }
}

impl Solver {
    /// Whether an increment that failed from `u` goes to the prestress continuation: it is on
    /// (`continuation_strain` > 0), the model has membrane triangles and no sleeve point with
    /// friction, and none of the triangles carries more tension at `u` than its artificial
    /// prestress (the singular flat start, where a cut-back meets the same difficulty again).
    /// Friction is excluded because its stick/slip history would take in the pre-strained
    /// problems' slips: the equilibrium would then depend on the continuation, not only the path.
    pub(super) fn unstressed(&mut self, model: &Model, u: &[f64], loads: &[f64]) -> bool {
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
    pub(super) fn continuation(
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
