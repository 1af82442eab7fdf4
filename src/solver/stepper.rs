//! The one stepper: every driver of a step (the CLI's and FMI 2's whole step, FMI 3's step
//! with intermediate updates and early return) goes through it.
//!
//! ```text
//! begin(from, to, u, states)   the step's path: load control (path.rs), or arc length
//!                              (arc.rs) under `Settings::arc_length_path` where it applies
//! advance()                    one increment attempt; the path accepts it (λ moves, Δλ or
//!                              Δs grows) or rejects it (cut back; below the smallest
//!                              increment the step has failed); None once λ = 1 or failed
//! converged()                  the last converged point: what a caller commits, all of the
//!                              step or where it stopped early
//! begin_dynamic(..., h, v, a)  a step of time integration instead (dynamic.rs): each
//!                              advance() one time sub-step, λ the fraction of h reached
//! ```
//! A step is the same sequence of increments whoever drives it, so every driver reaches the
//! same equilibrium in the same iterations.

use super::arc::ArcPath;
use super::core::{Solver, WORK_ITERATION};
use super::dynamic::{DynamicPath, Integration};
use super::path::{Attempt, LoadPath};
use super::report::{Outcome, StepReport};
use crate::model::state::History;
use crate::model::Model;

enum Path {
    Load(LoadPath),
    Arc(ArcPath),
    Dynamic(Box<DynamicPath>),
}

/// One step in progress (module docs).
pub struct Stepper {
    path: Path,
    report: StepReport,
    failed: bool,
    /// The step's loads at λ = 0 and 1.
    from: Vec<f64>,
    to: Vec<f64>,
    /// An arc-length step's start (displacements, stick/slip states), kept for the fallback to
    /// load control as a whole; None under load control (its path holds the start already).
    arc_start: Option<(Vec<f64>, History)>,
    /// Whether the reference configuration was tried before the path's first increment.
    tried_reference: bool,
    /// The history with which the reference last failed the test: with the same history the
    /// same point fails again, so it is not assembled twice.
    refused_with: Option<History>,
}

impl Stepper {
    /// Start the step `from` → `to` from the equilibrium `u` (displacements then slips) with
    /// the history `states` (stick/slip codes of the sleeve points, plastic strains).
    pub fn begin(
        solver: &mut Solver,
        model: &Model,
        from: &[f64],
        to: &[f64],
        u: &[f64],
        states: &History,
    ) -> Stepper {
        let contact = states.clone();
        solver.step_work = 0;
        solver.relax_extra = 0;
        let s = &solver.settings;
        let arc = if s.arc_length_path {
            ArcPath::begin(model, s, from, to, u, contact.clone())
        } else {
            None
        };
        let (path, arc_start) = match arc {
            Some(arc) => (Path::Arc(arc), Some((u.to_vec(), contact))),
            None => (
                Path::Load(LoadPath::begin(model, s, from, to, u, contact)),
                None,
            ),
        };
        Stepper {
            path,
            report: StepReport::failed(),
            failed: false,
            from: from.to_vec(),
            to: to.to_vec(),
            arc_start,
            tried_reference: false,
            refused_with: None,
        }
    }

    /// Newton on the whole step first tries `guess` (displacements, as `u`) as its start,
    /// once, before the first increment (the coarse start, `engine/coarse.rs`); a load-controlled
    /// step only (an arc-length or dynamic step is returned as it is).
    pub fn with_guess(mut self, guess: Vec<f64>) -> Stepper {
        if let Path::Load(p) = &mut self.path {
            p.guess = Some(guess);
        }
        self
    }

    /// A step of time integration (dynamic.rs) of length `duration` (s) from `from` to `to`,
    /// starting from `u`, the velocities and accelerations `motion` (per DOF; empty: at rest)
    /// and the history `states`.
    #[allow(clippy::too_many_arguments)]
    pub fn begin_dynamic(
        solver: &mut Solver,
        model: &Model,
        integration: &Integration,
        duration: f64,
        from: &[f64],
        to: &[f64],
        u: &[f64],
        motion: (&[f64], &[f64]),
        states: &History,
    ) -> Stepper {
        solver.step_work = 0;
        solver.relax_extra = 0;
        let path = DynamicPath::begin(
            solver,
            model,
            integration,
            duration,
            from,
            to,
            u,
            motion,
            states.clone(),
        );
        Stepper {
            path: Path::Dynamic(Box::new(path)),
            report: StepReport::failed(),
            failed: false,
            from: from.to_vec(),
            to: to.to_vec(),
            arc_start: None,
            tried_reference: false,
            refused_with: None,
        }
    }

    /// The velocities and accelerations of the last converged point of a dynamic step (None
    /// under load control or arc length).
    pub fn motion(&self) -> Option<(&[f64], &[f64])> {
        match &self.path {
            Path::Dynamic(p) => Some((&p.velocity, &p.acceleration)),
            _ => None,
        }
    }

    /// How many time sub-steps a dynamic step has converged so far and the length (s) of the
    /// last one (None under load control or arc length).
    pub fn substeps(&self) -> Option<(usize, f64)> {
        match &self.path {
            Path::Dynamic(p) => Some(p.substeps),
            _ => None,
        }
    }

    /// The end points of the converged sub-steps of a dynamic step (None under load control or
    /// arc length, or when there were more than `dynamic::MAX_CHAIN`), taken out.
    pub fn take_points(&mut self) -> Option<Vec<super::dynamic::SubStepPoint>> {
        match &mut self.path {
            Path::Dynamic(p) => p.points.take(),
            _ => None,
        }
    }

    /// A step that cannot start (why in the report): `advance` does nothing.
    pub fn fail(&mut self, message: String) {
        self.failed = true;
        self.report.message = message;
    }

    /// One increment attempt; None once the step is complete or has failed.
    pub fn advance(&mut self, solver: &mut Solver, model: &Model) -> Option<Attempt> {
        if self.failed {
            return None;
        }
        if solver.work_spent() && self.lambda() < 1.0 {
            self.report.work = solver.step_work as f64 / WORK_ITERATION as f64;
            self.report.whole_work =
                (solver.step_work + solver.relax_extra) as f64 / WORK_ITERATION as f64;
            if self.reference_answer(solver, model) {
                return None;
            }
            self.give_up(solver, model);
            let lambda = self.lambda();
            return Some(Attempt::Rejected {
                lambda,
                iterations: 0,
                failed: true,
            });
        }
        // A step to zero inputs first tries the reference (`reference_answer`), once.
        if !self.tried_reference {
            self.tried_reference = true;
            if self.reference_answer(solver, model) {
                return None;
            }
        }
        let attempt = match &mut self.path {
            Path::Load(p) => p.advance(solver, model, &mut self.report),
            Path::Dynamic(p) => p.advance(solver, model, &mut self.report),
            Path::Arc(p) => match p.advance(solver, model, &mut self.report) {
                Ok(a) => a,
                Err(super::arc::LoadControlInstead) => {
                    // The arc-length path cannot start (its first increment moved nothing, or
                    // failed down to the smallest increment): the whole step by load control,
                    // from the start. The report keeps the path's log and iterations, and the
                    // step's work budget what it spent.
                    let (u, contact) = self.arc_start.take().unwrap_or_default();
                    let s = &solver.settings;
                    let load = LoadPath::begin(model, s, &self.from, &self.to, &u, contact);
                    self.path = Path::Load(load);
                    let (log, iterations) =
                        (std::mem::take(&mut self.report.log), self.report.iterations);
                    self.report = StepReport::failed();
                    self.report.log = log;
                    self.report.iterations = iterations;
                    return self.advance(solver, model);
                }
            },
        };
        self.report.work = solver.step_work as f64 / WORK_ITERATION as f64;
        self.report.whole_work =
            (solver.step_work + solver.relax_extra) as f64 / WORK_ITERATION as f64;
        if let Some(Attempt::Rejected { failed: true, .. }) = attempt {
            if self.reference_answer(solver, model) {
                return None;
            }
            self.failed = true;
        }
        attempt
    }

    /// A load-controlled or arc-length step whose every load ends at zero (nothing applied,
    /// nothing prescribed), of a model without sleeves: the reference configuration (no displacement)
    /// is tried as the answer, with the history of the last converged point, before the path's
    /// first increment and again if the path fails. Unloaded, a structure without prestress
    /// whose film and cables go slack (a free-rim cushion let down, a yielded ETFE foil in its
    /// frame) may rest anywhere it stays slack, and the path towards one such rest can spend
    /// its budget on forces that vanish; a taut one (a clamped disc) comes back to it exactly.
    /// The reference is such a rest whenever it meets the convergence test (its strains are
    /// round-off there, so its residual is the round-off floor's), and a form-found scene's
    /// reference is its start. True when it is taken: the step then ends there, converged, and
    /// the report says so.
    fn reference_answer(&mut self, solver: &mut Solver, model: &Model) -> bool {
        if matches!(self.path, Path::Dynamic(_)) {
            return false;
        }
        let (converged, lambda, history) = self.converged();
        let (n, lambda, history) = (converged.len(), lambda, history.clone());
        if !model.slips.is_empty()
            || self.to.iter().any(|&v| v != 0.0)
            || self.refused_with.as_ref() == Some(&history)
        {
            return false;
        }
        history.install(model);
        let mut u = vec![0.0; n];
        super::loads::prescribe(model, &self.to, &mut u);
        let inc = super::rows::Increment {
            loads: &self.to,
            change: 0.0,
            moved: true,
        };
        // One assembly with the tangent (its diagonal sets the round-off floor) and the states
        // the criterion gives there, nothing frozen.
        solver.frozen = None;
        solver.step_work += 2;
        let info = solver.assemble_at(model, &self.to, &u);
        let check = solver.check(model, &info, &[], &u, &inc, 1);
        if !(check.strict || check.within_floor) {
            self.refused_with = Some(history);
            return false;
        }
        let path = if self.tried_reference && lambda == 0.0 && self.report.iterations == 0 {
            String::new()
        } else {
            format!("the path ended at load fraction {lambda:.6}; ")
        };
        let line = format!(
            "{path}every load of the step is zero and the reference configuration (no displacement) meets the convergence test with the history of the last converged point: it is the answer (what is slack may rest anywhere it stays slack; the reference is one such rest)"
        );
        match &mut self.path {
            Path::Load(p) => {
                p.converged = u;
                p.lambda = 1.0;
            }
            Path::Arc(p) => p.take_answer(u),
            // Not tried in a time step (returned above).
            Path::Dynamic(_) => return false,
        }
        self.report.log.push(line.clone());
        self.report.message = line;
        self.failed = false;
        true
    }

    /// The step's budget is spent: the report says so, with the last increment that failed for
    /// a reason of its own, under arc length the largest load fraction reached, and what is
    /// known of the structure at the last converged point under the step's loads
    /// (`mechanism.rs`: a mechanism only once verified), as a failure at the smallest
    /// increment says.
    fn give_up(&mut self, solver: &mut Solver, model: &Model) {
        let budget = solver.settings.max_step_iterations;
        let lambda = self.lambda();
        let spent = "solver.max_step_iterations";
        let bound = if solver.cost_bound_reached() {
            format!(
                ", or {} times its cost with each round of nodal relaxation counted at the element evaluations it made",
                super::core::COST_BOUND
            )
        } else {
            String::new()
        };
        let last = self
            .report
            .log
            .iter()
            .rev()
            .find(|l| {
                (l.starts_with("increment") || l.starts_with("time step"))
                    && l.contains("cutting back")
                    && !l.contains(spent)
            })
            .map_or(String::new(), |l| {
                format!("; the last failed increment: {l}")
            });
        self.failed = true;
        self.report.reached = lambda;
        self.report.message = match &self.path {
            Path::Load(_) => format!(
                "no equilibrium found beyond load fraction {lambda:.6} of the step: its work budget of {budget} Newton iterations ({spent}; a further line-search trial counts as half of one){bound} is spent{last}"
            ),
            Path::Arc(p) => format!(
                "no equilibrium found beyond load fraction {lambda:.6} of the step by arc length: its work budget of {budget} Newton iterations ({spent}; a further line-search trial counts as half of one){bound} is spent{last} (largest load fraction reached {:.6})",
                p.largest_lambda()
            ),
            Path::Dynamic(_) => format!(
                "no dynamic equilibrium found beyond time fraction {lambda:.6} of the step: its work budget of {budget} Newton iterations ({spent}; a further line-search trial counts as half of one){bound} is spent{last}"
            ),
        };
        if let Path::Load(p) = &self.path {
            if let Some(note) = p.continuation_note() {
                self.report
                    .message
                    .push_str(&format!("; the prestress continuation was tried: {note}"));
            }
        }
        if !matches!(self.path, Path::Dynamic(_)) {
            let u = self.converged().0.to_vec();
            let known = solver.diagnose_failure(model, &u, &self.to, lambda);
            self.report.message.push_str(&known);
        }
    }

    /// The load fraction of the last converged point.
    pub fn lambda(&self) -> f64 {
        self.converged().1
    }

    /// Whether the step has failed.
    pub fn has_failed(&self) -> bool {
        self.failed
    }

    /// The last converged point: displacements then slips, load fraction, stick/slip states.
    pub fn converged(&self) -> (&[f64], f64, &History) {
        match &self.path {
            Path::Load(p) => (&p.converged, p.lambda, &p.history),
            Path::Arc(p) => p.converged(),
            Path::Dynamic(p) => (&p.converged, p.lambda(), &p.history),
        }
    }

    /// The loads at the last converged point.
    pub fn applied(&self) -> Vec<f64> {
        let lambda = self.lambda();
        if lambda >= 1.0 {
            return self.to.clone();
        }
        super::loads::loads_at(&self.from, &self.to, lambda)
    }

    /// The report so far (Failed until [`Stepper::finish`] says otherwise).
    pub fn report(&self) -> &StepReport {
        &self.report
    }

    /// End the step at the last converged point: `u` and `states` become it and the report
    /// says Converged with the load fraction reached, unless the step failed (then nothing is
    /// changed and the report says why). The model's plastic store may hold a later history
    /// than `states` after a failed step: the caller installs the one it keeps
    /// (`History::install`).
    pub fn finish(self, u: &mut Vec<f64>, states: &mut History) -> StepReport {
        if self.failed {
            return self.report;
        }
        let (point, lambda, contact) = self.converged();
        u.clear();
        u.extend_from_slice(point);
        states.clone_from(contact);
        let mut report = self.report;
        report.outcome = Outcome::Converged;
        report.reached = lambda;
        report
    }
}

impl Solver {
    /// Apply the load change `from` → `to` starting from the equilibrium `u` (displacements
    /// then slips, `Model::unknown_count`), `states` the history (the stick/slip code of every
    /// sleeve point, `model::sleeve`, and the plastic strains, `model::state`): the whole step through the [`Stepper`]. On convergence `u` and
    /// `states` are the new equilibrium; otherwise both are unchanged. The history (slips,
    /// states) advances only at converged increments.
    pub fn solve_step_with(
        &mut self,
        model: &Model,
        from: &[f64],
        to: &[f64],
        u: &mut Vec<f64>,
        states: &mut History,
    ) -> StepReport {
        let mut stepper = Stepper::begin(self, model, from, to, u, states);
        while stepper.advance(self, model).is_some() {}
        let report = stepper.finish(u, states);
        states.install(model);
        report
    }

    /// [`Solver::solve_step_with`] for a model without sleeves.
    pub fn solve_step(
        &mut self,
        model: &Model,
        from: &[f64],
        to: &[f64],
        u: &mut Vec<f64>,
    ) -> StepReport {
        let mut states = History::start(model);
        self.solve_step_with(model, from, to, u, &mut states)
    }
}
