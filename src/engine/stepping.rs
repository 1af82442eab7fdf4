//! A step driven one load increment at a time, for a caller that reports each increment and
//! may stop after one (FMI 3's intermediate update and early return).
//!
//! ```text
//! begin_step()        the load change applied → inputs, from the committed equilibrium
//! advance(&mut step)  one increment attempt on the solver: λ → λ + Δλ; converged: λ moves and
//!                     Δλ grows as the solver's own path does (×2 at or below the target
//!                     iterations, ×1.5 up to 3/4 of the limit); not: Δλ / 4, and below
//!                     min_increment the step has failed
//! end_step(step)      commit at the λ reached (all of the step, or where the caller stopped);
//!                     a failed step commits nothing
//! ```
//! [`Engine::solve`] lets the solver run all increments in one call; this path runs the same
//! increments one call each, so the convergence test's load scale is the increment's rather
//! than the step's: the equilibria agree to the solver's tolerance, not bit for bit.

use super::Engine;
use crate::solver::{Outcome, StepReport};

/// One step in progress.
pub struct Step {
    from: Vec<f64>,
    to: Vec<f64>,
    lambda: f64,
    increment: f64,
    u: Vec<f64>,
    slip_state: Vec<u8>,
    failed: bool,
    report: StepReport,
}

/// What one increment attempt did.
#[derive(Clone, Debug, PartialEq)]
pub struct Increment {
    /// The load fraction of the step reached (after a cut-back: the one still held).
    pub lambda: f64,
    /// The increment converged (else it was cut back, or the step failed).
    pub converged: bool,
    /// The step has failed (the smallest increment did not converge).
    pub failed: bool,
    pub iterations: usize,
}

impl Step {
    /// The load fraction of the step reached so far.
    pub fn lambda(&self) -> f64 {
        self.lambda
    }
}

impl Engine {
    /// Start a step to the current inputs (see the module docs).
    pub fn begin_step(&mut self) -> Step {
        self.tangent = None;
        let rebuilt = if self.model_stale {
            self.rebuild().map_err(|e| e.to_string())
        } else {
            Ok(())
        };
        let mut step = Step {
            from: self.state.applied.clone(),
            to: self.state.inputs.clone(),
            lambda: 0.0,
            increment: self.scene.solver.initial_increment,
            u: self.state.displacement.clone(),
            slip_state: self.state.slip_state.clone(),
            failed: false,
            report: StepReport::failed(),
        };
        if let Err(message) = rebuilt {
            step.failed = true;
            step.report.message = message;
        }
        step
    }

    /// One increment attempt; None once the step is complete or has failed.
    pub fn advance(&mut self, step: &mut Step) -> Option<Increment> {
        if step.failed || step.lambda >= 1.0 {
            return None;
        }
        self.tangent = None;
        let settings = &self.scene.solver;
        let dl = step.increment.min(1.0 - step.lambda);
        let target = if 1.0 - (step.lambda + dl) < 1e-12 {
            1.0
        } else {
            step.lambda + dl
        };
        let at = |l: f64| -> Vec<f64> {
            step.from
                .iter()
                .zip(&step.to)
                .map(|(a, b)| a + l * (b - a))
                .collect()
        };
        let (a, b) = (at(step.lambda), at(target));
        let mut u = step.u.clone();
        let mut slip_state = step.slip_state.clone();
        // One attempt per call: the solver takes the whole interval as one increment and
        // reports a failure instead of cutting back itself.
        let saved = self.solver.settings_mut().clone();
        {
            let s = self.solver.settings_mut();
            s.initial_increment = 1.0;
            s.max_increments = 1;
        }
        let r = self
            .solver
            .solve_step_with(&self.model, &a, &b, &mut u, &mut slip_state);
        *self.solver.settings_mut() = saved;
        step.report.iterations += r.iterations;
        step.report.log.extend(r.log.iter().cloned());
        if r.converged() {
            step.u = u;
            step.slip_state = slip_state;
            step.lambda = target;
            step.report.increments += 1;
            step.increment *= growth(
                r.iterations,
                settings.target_iterations,
                settings.max_iterations,
            );
            return Some(Increment {
                lambda: target,
                converged: true,
                failed: false,
                iterations: r.iterations,
            });
        }
        step.report.cutbacks += 1;
        step.increment *= 0.25;
        if step.increment < settings.min_increment {
            step.failed = true;
            step.report.reached = step.lambda;
            step.report.message = format!(
                "no equilibrium found beyond load fraction {:.6} of the step (smallest increment {:.1e} failed: {})",
                step.lambda, settings.min_increment, r.message
            );
        }
        Some(Increment {
            lambda: step.lambda,
            converged: false,
            failed: step.failed,
            iterations: r.iterations,
        })
    }

    /// Commit the step at the load fraction it reached (nothing if it failed). The report's
    /// `reached` is that fraction; `outcome` is Converged unless the step failed.
    pub fn end_step(&mut self, step: Step) -> StepReport {
        self.tangent = None;
        let mut report = step.report;
        if step.failed {
            return report;
        }
        let lambda = step.lambda;
        let applied: Vec<f64> = if lambda >= 1.0 {
            step.to.clone()
        } else {
            step.from
                .iter()
                .zip(&step.to)
                .map(|(a, b)| a + lambda * (b - a))
                .collect()
        };
        let previous = self.state.clone();
        self.state.displacement = step.u;
        self.state.slip_state = step.slip_state;
        self.state.applied = applied;
        self.state.last_iterations = report.iterations as u32;
        if let Err(e) = self.refresh_outputs() {
            self.state = previous;
            report.message = e.to_string();
            return report;
        }
        if let Some(what) = self.non_finite() {
            self.state = previous;
            let _ = self.refresh_outputs();
            report.message = format!(
                "the equilibrium found is not finite ({what}); the loads overflow the model's numbers"
            );
            return report;
        }
        report.outcome = Outcome::Converged;
        report.reached = lambda;
        // Short of the end (early return) the inputs are not yet the applied ones, so the
        // engine is settled only after a whole step.
        self.converged = true;
        report
    }
}

/// Increment growth after a converged increment: the rule of the solver's own path
/// (`solver/path.rs`, private there), so both drivers grow alike.
fn growth(iterations: usize, target: usize, max_iterations: usize) -> f64 {
    if iterations <= target {
        2.0
    } else if 4 * iterations <= 3 * max_iterations {
        1.5
    } else {
        1.0
    }
}
