//! What a step did: its outcome, counts, message and log.

/// How a step ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Outcome {
    /// The whole load change was applied and the equilibrium committed.
    Converged,
    /// The smallest increment failed; nothing was committed.
    Failed,
}

/// What one step did.
#[derive(Clone, Debug, PartialEq)]
pub struct StepReport {
    pub outcome: Outcome,
    /// Newton iterations (factorizations), failed increments included.
    pub iterations: usize,
    /// The work the step spent, in Newton iterations' worth (`solver.max_step_iterations`
    /// bounds it: an iteration one, a further line-search trial or re-check one half, a round
    /// of nodal relaxation one).
    pub work: f64,
    /// The step's whole work in Newton iterations' worth: `work` plus what its rounds of nodal
    /// relaxation cost beyond one iteration each, counted by the element evaluations they made
    /// (an assembly's worth one half). At most 20 times `solver.max_step_iterations` (checked
    /// between rounds, so one round may pass it).
    pub whole_work: f64,
    /// Converged increments.
    pub increments: usize,
    /// Increments that were cut back.
    pub cutbacks: usize,
    /// Fraction of the load change reached by converged increments (1 when converged).
    pub reached: f64,
    /// Why the step failed (empty when converged).
    pub message: String,
    /// One line per increment and per Newton iteration (capped), for the FMU's logSolver.
    pub log: Vec<String>,
}

impl StepReport {
    pub fn converged(&self) -> bool {
        self.outcome == Outcome::Converged
    }
}

impl StepReport {
    /// A step that has not converged yet (the start of every driver's report).
    pub fn failed() -> StepReport {
        StepReport {
            outcome: Outcome::Failed,
            iterations: 0,
            work: 0.0,
            whole_work: 0.0,
            increments: 0,
            cutbacks: 0,
            reached: 0.0,
            message: String::new(),
            log: Vec::new(),
        }
    }

    /// A step that failed before it started, with its reason: nothing was changed.
    pub fn failed_with(message: String) -> StepReport {
        StepReport {
            message,
            ..StepReport::failed()
        }
    }

    /// A step that had nothing to do (the loads were already applied).
    pub fn unchanged() -> StepReport {
        StepReport {
            outcome: Outcome::Converged,
            reached: 1.0,
            ..StepReport::failed()
        }
    }
}

/// Longest solver log kept per step.
pub const MAX_LOG_LINES: usize = 2000;

/// Append a line to a step's log, up to [`MAX_LOG_LINES`].
pub fn push_log(log: &mut Vec<String>, line: String) {
    if log.len() < MAX_LOG_LINES {
        log.push(line);
    }
}
