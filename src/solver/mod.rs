//! The solver: assembly, sparse LDLT, Newton with a slope line search, and load increments with
//! cut-back. It sees the model only; it owns scratch buffers, never committed state.
//!
//! ```text
//! solve_step(from, to, u):  load(λ) = from + λ (to − from),  λ: 0 → 1 in increments Δλ
//!   each increment: Newton from the last converged u; on failure Δλ ← Δλ/4 (down to min);
//!   on success Δλ ← 2 Δλ if N_iter <= N_target, 1.5 Δλ if N_iter <= 3/4 N_max, else Δλ
//! Newton: K Δu = −R on free DOFs; u ← u + α Δu with α from the slope s(α) = Δu·R(u + αΔu)
//!   converged when |R_free|∞ <= tol · max(|f_ext|∞, |reactions|∞) (+ a round-off floor)
//! ```
//! Non-convergence is an outcome ([`StepReport`]), not an error: the caller's state is left as
//! it was.
//!
//! # References
//! Crisfield 1991, *Non-linear Finite Element Analysis of Solids and Structures*, vol. 1, §9.3
//! (line search on the slope); Bonet & Wood 2008, §9.6; MECHANICS.md §5.

pub mod assemble;
pub mod linear;
mod newton;
mod relax;
pub mod sliding;

use crate::model::membrane::Evaluation;
use crate::model::wrinkling::WrinkleState;
use crate::model::Model;
use assemble::Pattern;
use linear::Ldlt;

/// Solver settings (the scene's solver section; defaults are documented there).
#[derive(Clone, Debug, PartialEq)]
pub struct Settings {
    pub tolerance: f64,
    pub max_iterations: usize,
    pub initial_increment: f64,
    pub min_increment: f64,
    pub target_iterations: usize,
    pub line_search: bool,
}

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

/// Smallest signed current/reference area ratio a membrane triangle may reach: below it the
/// triangle has collapsed or turned over (inversion guard of every Newton loop and of nodal
/// relaxation).
pub(super) const MIN_AREA_RATIO: f64 = 1e-6;

/// Err with the reason when an assembly found an inverted or collapsed membrane triangle.
pub(super) fn check_inversion(model: &Model, info: &assemble::AssemblyInfo) -> Result<(), String> {
    if model.triangles.is_empty() || info.min_area_ratio > MIN_AREA_RATIO {
        Ok(())
    } else {
        Err(format!(
            "a membrane element inverted or collapsed (area ratio {:.2e})",
            info.min_area_ratio
        ))
    }
}

/// Increments (converged or cut back) one step may use before it is declared failed: a step
/// that creeps forward by tiny increments is reported, not left to run for minutes.
const MAX_INCREMENTS: usize = 400;

/// Longest solver log kept per step.
const MAX_LOG_LINES: usize = 2000;

pub struct Solver {
    settings: Settings,
    pattern: Pattern,
    linear: Ldlt,
    residual: Vec<f64>,
    trial: Vec<f64>,
    rhs: Vec<f64>,
    /// Per-triangle evaluations of the last assembly.
    evaluations: Vec<Evaluation>,
    /// Wrinkle states frozen against chatter inside the current increment.
    frozen: Option<Vec<WrinkleState>>,
    /// Elements and loads at each node, for nodal relaxation.
    adjacency: relax::Adjacency,
    /// Factor on the artificial prestress in the tangent of the current Newton iteration.
    prestress_factor: f64,
}

impl Solver {
    /// Pattern, position maps and the symbolic factorization, once per model.
    pub fn new(model: &Model, settings: Settings) -> Solver {
        let pattern = Pattern::new(model);
        let linear = Ldlt::new(pattern.n, pattern.col_ptr.clone(), pattern.row_idx.clone());
        let n = model.dof_count();
        let trial_len = model.unknown_count();
        Solver {
            settings,
            linear,
            residual: vec![0.0; n],
            trial: vec![0.0; trial_len],
            rhs: vec![0.0; pattern.n],
            evaluations: Vec::with_capacity(model.triangles.len()),
            frozen: None,
            adjacency: relax::Adjacency::new(model),
            prestress_factor: 1.0,
            pattern,
        }
    }

    /// Number of unknowns (free DOFs).
    pub fn free_dofs(&self) -> usize {
        self.pattern.n
    }

    /// Residual R = f_int − f_ext on all DOFs (reactions at held DOFs) at `u` under `loads`.
    pub fn residual(&mut self, model: &Model, u: &[f64], loads: &[f64]) -> Vec<f64> {
        let mut r = vec![0.0; model.dof_count()];
        assemble::assemble(model, &self.pattern, u, loads, &mut r, None);
        r
    }

    /// Evaluation (state, tension angle, stress, energy) of every membrane triangle at `u`.
    pub fn evaluate_membranes(
        &mut self,
        model: &Model,
        u: &[f64],
        loads: &[f64],
    ) -> Vec<Evaluation> {
        let mut r = vec![0.0; model.dof_count()];
        let mut out = Vec::with_capacity(model.triangles.len());
        let membranes = assemble::Membranes {
            forced: None,
            out: Some(&mut out),
            held_step: None,
            prestress_factor: None,
        };
        assemble::assemble_with(model, &self.pattern, u, loads, &mut r, None, membranes);
        out
    }

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
        let mut report = StepReport {
            outcome: Outcome::Failed,
            iterations: 0,
            increments: 0,
            cutbacks: 0,
            reached: 0.0,
            message: String::new(),
            log: Vec::new(),
        };
        let s = self.settings.clone();
        let mut converged = u.clone();
        let mut converged_states = states.clone();
        let (mut lambda, mut dl) = (0.0, s.initial_increment);
        while lambda < 1.0 {
            if report.increments + report.cutbacks >= MAX_INCREMENTS {
                report.reached = lambda;
                report.message = format!("no equilibrium found beyond load fraction {lambda:.6} of the step ({MAX_INCREMENTS} increments used)");
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
            let result = if model.slips.is_empty() {
                self.newton(model, &loads, &mut trial, &mut report.log)
            } else {
                self.newton_sliding(
                    model,
                    &loads,
                    &mut trial,
                    &mut trial_states,
                    &mut report.log,
                )
            };
            let result = result
                .map(|i| i + predicted)
                .map_err(|(i, why)| (i + predicted, why));
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
                        return report;
                    }
                }
            }
        }
        *u = converged;
        *states = converged_states;
        report.outcome = Outcome::Converged;
        report.reached = 1.0;
        report
    }
}

impl Solver {
    /// Wall time in seconds of one assembly (residual and tangent) and of one numeric
    /// factorization plus solve at `u`: the floor a Newton iteration cannot beat. Best of
    /// `repeats`.
    pub fn time_floor(
        &mut self,
        model: &Model,
        u: &[f64],
        loads: &[f64],
        repeats: usize,
    ) -> (f64, f64) {
        let (mut assembly, mut factor) = (f64::INFINITY, f64::INFINITY);
        for _ in 0..repeats.max(1) {
            let t = std::time::Instant::now();
            assemble::assemble(
                model,
                &self.pattern,
                u,
                loads,
                &mut self.residual,
                Some(self.linear.values_mut()),
            );
            assembly = assembly.min(t.elapsed().as_secs_f64());
            for (d, &e) in self.pattern.eq.iter().enumerate() {
                if e != assemble::NONE {
                    self.rhs[e] = -self.residual[d];
                }
            }
            let t = std::time::Instant::now();
            // A failed factorization still costs its time; the floor is about cost only.
            let _ = self.linear.factor_solve(&mut self.rhs);
            factor = factor.min(t.elapsed().as_secs_f64());
        }
        (assembly, factor)
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

impl Solver {
    /// Start an increment whose prescribed displacements change: one Newton step linearized at
    /// the converged state `u`, with the prescribed change as a load on the free DOFs,
    /// K_ff Δu_f = −(R_f + K_fp Δu_p). Moving only the prescribed DOFs would strain a single
    /// layer of elements and spend the first iterations (and wrinkle-state switches) undoing
    /// it. Returns the factorizations used (0 when nothing is prescribed to move, or 1);
    /// `u` leaves with the prescribed values set in any case.
    fn predict(&mut self, model: &Model, loads: &[f64], u: &mut [f64]) -> usize {
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
        let membranes = assemble::Membranes {
            forced: None,
            out: None,
            held_step: Some((&du, &mut coupling)),
            prestress_factor: None,
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
            if e != assemble::NONE {
                self.rhs[e] = -(self.residual[d] + coupling[d]);
            }
        }
        let solved = self.linear.factor_solve(&mut self.rhs).is_ok();
        u.copy_from_slice(&target);
        if solved {
            for (d, &e) in self.pattern.eq.iter().enumerate() {
                if e != assemble::NONE {
                    u[d] += self.rhs[e];
                }
            }
        }
        1
    }
}

/// Set prescribed DOFs to their load values.
fn prescribe(model: &Model, loads: &[f64], u: &mut [f64]) {
    for (load, &value) in model.loads.iter().zip(loads) {
        if let crate::model::LoadModel::Displacement(dofs) = load {
            for &d in dofs {
                u[d] = value;
            }
        }
    }
}

fn push_log(log: &mut Vec<String>, line: String) {
    if log.len() < MAX_LOG_LINES {
        log.push(line);
    }
}
