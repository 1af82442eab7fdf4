//! The one Newton loop of a load increment, for every scene (with or without sleeves). It
//! iterates on the System boundary (system.rs: the equations at a load factor) in phases, each
//! a function of its own:
//!
//! ```text
//! equations   assemble R, K at u (wrinkle states from the mixed criterion, or frozen),
//!             stick/slip states by the return map (or frozen)        active_set.rs
//!             the slip and volume rows, the convergence test          system.rs
//!             stalled (after 2 iterations, last step shortened or |R| fell by < 4x):
//!               relax the nodes carrying the residual                 relaxation.rs
//!             under arc length, the bordered row and column           system.rs
//! verdict     converged when every free DOF d and slip row j meets |R_d| <= tol · F, or meets
//!               |R_d| <= tol · F + ρ_d and the Newton correction is within tol · X,
//!             and no stick/slip state changed, no touching sleeve points part, and the
//!             re-check of frozen states accepts
//! ties        converged with a sleeve tie open by more than GAP_TOLERANCE of its segment: the
//!               ties' multipliers are updated and the increment solved again (slip.rs,
//!               close_ties; at most MAX_UZAWA_ROUNDS times, then the increment fails)
//! budget      max_iterations from the last release of frozen states (more while the
//!             residual still falls steadily near the solution)
//! direction   (K + τ D) Δ = −R, slips eliminated by Schur              slip.rs
//! step        u ← u + α Δ, α from the line search                     line_search.rs
//!             τ: 0 while Newton steps work; τ0 when the tangent is singular, the line search
//!             fails or cuts α below 1e-5 (the step was far too long: a mechanism), or the
//!             slips would take α below 1/4 to keep every sleeved segment (a sliding
//!             mechanism), ×4 on every further such step; ÷8 after every full step (0 below
//!             τ_min)
//! ```
//! The convergence test is documented with its code (system.rs).
//!
//! # Globalisation
//! Slack cables, slack or wrinkled membrane and frictionless sleeves leave directions with no
//! stiffness (mechanisms before the structure is stressed) or almost none. Full Newton steps
//! there are huge and the line search cannot save them. The damped system (K + τD) Δ = −R,
//! D the diagonal of the structure's stiffness if every element were taut (`reference
//! diagonal`), is a Levenberg–Marquardt / pseudo-transient step: it moves a mechanism by
//! R/(τD), grows that move by 8x per accepted step and shrinks it by 4x per rejected one.
//! τ = 0 at convergence (quadratic convergence kept) and R is the true residual, so the
//! equilibrium is unchanged.
//!
//! # References
//! Kelley & Keyes 1998, SIAM J. Numer. Anal. 35:508–523 (pseudo-transient continuation);
//! Nocedal & Wright 2006, §10.3 (Levenberg–Marquardt); Higham 2002, §7.2 (componentwise
//! residual bounds); Crisfield 1991, vol. 1, §9.

use super::active_set::{ActiveSet, Recheck};
use super::assemble::{AssemblyInfo, NONE};
use super::core::{check_inversion, Solver, WORK_ITERATION};
use super::line_search::{Direction, Merit, Trial};
use super::report::push_log;
use super::rows::{ArcRow, Border, Increment, Row};
use super::slip::{slip_rows_into, step_limit, Ties};
use super::system::Check;
use crate::model::sleeve::Contact;
use crate::model::Model;

/// Factor on the artificial prestress for the next tangent: 1 down to a relative residual of
/// `fade` (`Settings::prestress_fade`), proportional to it below.
pub(super) fn prestress_factor(relative: f64, fade: f64) -> f64 {
    if relative.is_finite() {
        (relative / fade).min(1.0)
    } else {
        1.0
    }
}

/// Newton has stalled when, past its first two iterations, the last step was shortened or the
/// residual fell by less than a factor 4 (quadratic convergence falls much faster).
fn stalled(it: usize, free: f64, last_free: f64, last_alpha: f64) -> bool {
    it >= 2 && (last_alpha < 1.0 || free > 0.25 * last_free)
}

/// Iterations compared by [`progressing`].
const PROGRESS_WINDOW: usize = 10;

/// Whether the relative residual (|R|/F per iteration in `history`) still falls steadily: the
/// smallest of the last `PROGRESS_WINDOW` is below half the smallest of the window before.
/// Linear convergence that keeps this pace (a root where the tangent is singular, such as a
/// flat membrane unloaded to exactly zero: w³ ∝ q, each Newton step goes a third of the way;
/// or a free-rim cushion drawing its rim in from flat, where a smaller increment is as far
/// from its equilibrium as the whole one) is allowed past `max_iterations`; stagnation and
/// chatter are not (they are cut back as before). Until 2026-11-28 only a residual already
/// below 1e-4 of the force scale could continue: measured on the robustness corpus, dropping
/// that condition took the quarter cushions from 25 % to 33 % right and changed no other
/// family's shares (docs/robustness.md).
fn progressing(history: &[f64]) -> bool {
    let n = history.len();
    if n < 2 * PROGRESS_WINDOW {
        return false;
    }
    let least = |w: &[f64]| w.iter().copied().fold(f64::INFINITY, f64::min);
    let recent = least(&history[n - PROGRESS_WINDOW..]);
    let before = least(&history[n - 2 * PROGRESS_WINDOW..n - PROGRESS_WINDOW]);
    recent < 0.5 * before
}

/// What the Newton loop of one increment carries from one iteration to the next.
struct Iteration {
    /// The stick anchors: the last converged slips, except where points met in this
    /// increment (a merged frictional group sticks from where it met, order.rs).
    committed: Vec<f64>,
    active: ActiveSet,
    damping: f64,
    /// The last non-zero damping: where the undamped tangent turns out singular again, the
    /// damping resumes from it rather than from the start value.
    last_damping: f64,
    last_free: f64,
    last_alpha: f64,
    /// Relative residual of the last iterate (the converged one after a re-check).
    last_relative: f64,
    /// Partings of touching sleeve points so far.
    reopened: usize,
    /// The non-monotone line search's memory, and whether it holds potentials (true) or
    /// residual norms: a sleeve point that sticks or merges switches the merit, and the memory
    /// starts afresh.
    recent: std::collections::VecDeque<f64>,
    recent_potential: Option<bool>,
    /// Relative residuals since `budget_from` (the progress test).
    history: Vec<f64>,
    /// The iteration from which `max_iterations` counts: 0, or the last release of frozen
    /// states.
    budget_from: usize,
    /// The loads of the iterate (the load factor's under arc length).
    loads: Vec<f64>,
    /// The slip and volume rows of the iterate.
    rows: Vec<Row>,
    /// A time sub-step's trial point shared with the next iteration (line_search.rs).
    shared: super::line_search::Shared,
}

/// The equations of an iterate after assembly: the convergence test, and under arc length the
/// bordered rows and the load factor's column.
struct Assembled {
    info: AssemblyInfo,
    check: Check,
    /// Stick/slip states that changed in this iteration.
    changed: usize,
    /// Whether the arc-length row is met (true without arc length).
    arc_met: bool,
    bordered: Option<Border>,
}

/// What the convergence phase decided.
enum Verdict {
    /// Converged: return the iterations.
    Done(usize),
    /// Start the next iteration at once (points parted, frozen states released).
    Again,
    /// Not converged: take a Newton step (with the direction already computed, if any).
    Step(Option<(Vec<f64>, Vec<f64>)>),
}

type Failure = (usize, String);

impl Solver {
    /// Iterate to equilibrium at fixed loads. `u` holds displacements then slips, `contact` the
    /// stick/slip states (in: last converged, out: this increment's). Ok(iterations) or
    /// Err((iterations, reason)); on Err `u` and `contact` are scratch.
    /// With `arc`, the loads are those of the load factor `arc.lambda`, an unknown held by the
    /// arc-length row (`step.loads` is not read; prescribed displacements follow λ).
    /// Each iteration: assemble (and update the active set), check, decide convergence, then a
    /// direction and a line search (module docs).
    pub(super) fn newton(
        &mut self,
        model: &Model,
        step: &Increment,
        u: &mut [f64],
        contact: &mut Vec<Contact>,
        mut arc: Option<&mut ArcRow>,
        log: &mut Vec<String>,
    ) -> Result<usize, Failure> {
        let n3 = model.dof_count();
        let memory = self.settings.nonmonotone_memory;
        let max = self.settings.max_iterations;
        let hard_max = max.max(self.settings.max_iterations_progressing);
        self.frozen = None;
        self.prestress_factor = if self.proximal { 0.0 } else { 1.0 };
        // Allocated once per increment, reused by every iteration (`work.rs`).
        let mut state = Iteration {
            committed: u[n3..].to_vec(),
            active: ActiveSet::new(contact.clone(), &self.settings),
            damping: 0.0,
            last_damping: 0.0,
            last_free: f64::INFINITY,
            last_alpha: 1.0,
            last_relative: f64::INFINITY,
            reopened: 0,
            recent: std::collections::VecDeque::with_capacity(memory + 1),
            recent_potential: None,
            // Bounded whatever the settings say (a library caller can set any number; the
            // scene's validation allows at most 10000): the history grows past it if needed.
            history: Vec::with_capacity(hard_max.min(10_000) + 1),
            budget_from: 0,
            loads: Vec::with_capacity(step.loads.len()),
            rows: Vec::new(),
            shared: Default::default(),
        };
        // Multiplier updates of the sleeve ties so far (slip.rs, `close_ties`).
        let mut rounds = 0;
        for it in 0..=hard_max {
            if self.work_spent() {
                return Err((
                    it,
                    format!(
                        "the step's work budget of {} Newton iterations (solver.max_step_iterations) is spent",
                        self.settings.max_step_iterations
                    ),
                ));
            }
            self.step_work += WORK_ITERATION;
            let mut eqs = self.equations(model, step, &mut state, u, arc.as_deref(), it, log)?;
            match self.verdict(model, step, &mut state, u, &eqs, arc.as_deref(), it, log)? {
                Verdict::Done(it) => match self.close_ties(model, u, &mut rounds, log) {
                    Ties::Closed => {
                        *contact = std::mem::take(&mut state.active.contact);
                        return Ok(it);
                    }
                    Ties::Updated(change) => {
                        self.after_tie_update(&mut state, it);
                        if state.damping == 0.0 {
                            // The residual took the multipliers' change and the tangent is
                            // the assembled one: the step from here at once.
                            eqs.info.potential += change;
                            self.budget(model, u, &mut state, &eqs.check, it, hard_max)?;
                            let d =
                                self.newton_direction(model, &mut state, u, &eqs, None, it, log)?;
                            self.newton_step(
                                model,
                                &mut state,
                                u,
                                &eqs,
                                arc.as_deref_mut(),
                                d,
                                it,
                                log,
                            );
                        }
                    }
                    Ties::Open(why) => return Err((it, why)),
                },
                Verdict::Again => continue,
                Verdict::Step(pending) => {
                    self.budget(model, u, &mut state, &eqs.check, it, hard_max)?;
                    let (dx, ds) =
                        self.newton_direction(model, &mut state, u, &eqs, pending, it, log)?;
                    self.newton_step(
                        model,
                        &mut state,
                        u,
                        &eqs,
                        arc.as_deref_mut(),
                        (dx, ds),
                        it,
                        log,
                    );
                }
            }
        }
        // Reached only when frozen states were found wrong at the last allowed iteration.
        Err((
            hard_max,
            format!("no convergence in {hard_max} iterations (states changed at the end)"),
        ))
    }

    /// Phase 1, the equations at the iterate: the loads (and under arc length the prescribed
    /// displacements of λ), residual and tangent with the wrinkle states (law or frozen), the
    /// stick/slip states by the return map, the slip and volume rows, the convergence test,
    /// nodal relaxation when stalled, and the arc-length border.
    #[allow(clippy::too_many_arguments)]
    fn equations(
        &mut self,
        model: &Model,
        step: &Increment,
        st: &mut Iteration,
        u: &mut [f64],
        arc: Option<&ArcRow>,
        it: usize,
        log: &mut Vec<String>,
    ) -> Result<Assembled, Failure> {
        match arc {
            Some(a) => {
                st.loads = super::loads::loads_at(a.from, a.to, a.lambda);
                super::loads::prescribe(model, &st.loads, u);
            }
            None => {
                st.loads.clear();
                st.loads.extend_from_slice(step.loads);
            }
        }
        let loads = std::mem::take(&mut st.loads);
        let inc = &Increment {
            loads: &loads,
            change: step.change,
            moved: step.moved,
        };
        self.frozen.clone_from(&st.active.wrinkle_frozen);
        let info = self.assemble_or_share(model, inc.loads, u, &mut st.shared);
        st.active
            .observe_wrinkles(it, self.evaluations.iter().map(|e| e.state), log);
        self.frozen.clone_from(&st.active.wrinkle_frozen);
        if let Err(why) = check_inversion(model, &info) {
            st.loads = loads;
            return Err((it, why.to_string()));
        }
        // The return map runs only once the iterate is near equilibrium (`contact_settle`):
        // the cone test at a far iterate (a linear step that overshoots the kinks) flips
        // sticking points to slip and sends Newton wandering (active_set.rs).
        let settled = st.last_relative <= self.settings.contact_settle;
        let changed = st
            .active
            .update_contact(it, model, u, &mut st.committed, settled, log);
        slip_rows_into(
            model,
            &self.pattern.eq,
            u,
            &st.committed,
            &st.active.contact,
            &mut st.rows,
        );
        st.rows
            .extend(super::volume::rows(model, &self.pattern.eq, u, inc.loads));
        let check = self.check(model, &info, &st.rows, u, inc, it);
        st.loads = loads;
        if !(check.free.is_finite() && check.slip.is_finite()) {
            return Err((it, "the residual is not finite".into()));
        }
        let check = self.stalled_relaxation(model, step, st, u, check, it, log);
        let (arc_met, bordered) = match arc {
            Some(a) => {
                let (met, border) = self.arc_border(model, a, &st.rows, u);
                (met, Some(border))
            }
            None => (true, None),
        };
        Ok(Assembled {
            info,
            check,
            changed,
            arc_met,
            bordered,
        })
    }

    /// The relative residual of the iterate sets the artificial prestress of the next
    /// tangent; a stalled iteration relaxes the nodes carrying the residual (relax.rs) and is
    /// checked again.
    #[allow(clippy::too_many_arguments)]
    fn stalled_relaxation(
        &mut self,
        model: &Model,
        step: &Increment,
        st: &mut Iteration,
        u: &mut [f64],
        mut check: Check,
        it: usize,
        log: &mut Vec<String>,
    ) -> Check {
        let tolerance = self.settings.tolerance * check.scale;
        // Also for the iterations that restart at this point (a re-check, a parting).
        st.last_relative = check.free.max(check.slip) / check.scale.max(f64::MIN_POSITIVE);
        self.prestress_factor = if self.proximal {
            0.0
        } else {
            prestress_factor(
                check.free.max(check.slip) / check.scale.max(f64::MIN_POSITIVE),
                self.settings.prestress_fade,
            )
        };
        // Not in a time sub-step: relaxation moves nodes to their static equilibrium, which
        // the inertia force does not hold (dynamic.rs). Also within the round-off floor when
        // not within the tolerance: such a point is converged only once the Newton correction
        // is small, and a stalled one needs the relaxation to get there (docs/solver.md).
        if self.inertia.is_none()
            && !check.strict
            && stalled(it, check.free, st.last_free, st.last_alpha)
        {
            let (moved, patch_iterations) = self.relax(model, &st.loads, u, check.free, tolerance);
            if moved > 0 {
                let info = self.assemble_at(model, &st.loads, u);
                let before = check.free;
                let inc = Increment {
                    loads: &st.loads,
                    change: step.change,
                    moved: step.moved,
                };
                check = self.check(model, &info, &st.rows, u, &inc, it);
                push_log(
                    log,
                    format!(
                        "  stalled: relaxed {moved} nodes ({patch_iterations} patch Newton iterations), |R| {before:.3e} -> {:.3e}",
                        check.free
                    ),
                );
            }
        }
        check
    }

    /// Phase 2, convergence: the test (within the round-off floor, the Newton correction
    /// decides), then touching sleeve points that would pull apart, then the re-check of
    /// frozen states.
    #[allow(clippy::too_many_arguments)]
    fn verdict(
        &mut self,
        model: &Model,
        step: &Increment,
        st: &mut Iteration,
        u: &mut [f64],
        eqs: &Assembled,
        arc: Option<&ArcRow>,
        it: usize,
        log: &mut Vec<String>,
    ) -> Result<Verdict, Failure> {
        let check = &eqs.check;
        let tolerance = self.settings.tolerance * check.scale;
        // An inexact proximal problem (proximal.rs): solved once its residual is small against
        // its own scale; the scene's own problem at the end gets the full test.
        if self.proximal
            && eqs.arc_met
            && check.free.max(check.slip) <= super::proximal::ACCEPT * check.scale
        {
            return Ok(Verdict::Done(it));
        }
        // Within the round-off floor but not the tolerance: converged only when the Newton
        // correction from here is within the tolerance of the coordinates, tol · X at every
        // unknown (a floor reached at every DOF could still leave a net force on a soft part
        // held by stiff members; that part's correction is then large and real).
        let mut pending = None;
        let mut converged = check.strict && eqs.arc_met;
        if !converged && check.within_floor && eqs.arc_met && eqs.changed == 0 {
            let bordered = eqs.bordered.as_ref();
            if let Ok((dx, ds)) =
                self.direction_sharing(model, u, &st.rows, bordered, st.damping, &mut st.shared)
            {
                let limit = self.settings.tolerance * self.coordinate_size(model, u);
                // The load factor's correction is not a coordinate (the arc row, met, holds
                // the path's position).
                converged = dx
                    .iter()
                    .chain(&ds[..st.rows.len()])
                    .all(|v| v.abs() <= limit);
                pending = Some((dx, ds));
            }
        }
        if !(converged && eqs.changed == 0) {
            return Ok(Verdict::Step(pending));
        }
        if !st.active.contact.is_empty() {
            // Touching sleeve points whose contact force would pull part here (order.rs).
            let parted = super::order::open_gaps(
                model,
                u,
                &mut st.active.contact,
                tolerance,
                self.settings.reopen_gap,
                (
                    self.settings.roundoff_factor * f64::EPSILON,
                    self.coordinate_size(model, u),
                ),
            );
            if parted > 0 {
                st.reopened += 1;
                if st.reopened > self.settings.max_unfreeze {
                    return Err((it, "touching sleeve points keep parting (chatter)".into()));
                }
                push_log(log, format!("  {parted} touching sleeve points part"));
                st.last_free = f64::INFINITY;
                return Ok(Verdict::Again);
            }
        }
        let inc = Increment {
            loads: &st.loads,
            change: step.change,
            moved: step.moved,
        };
        let rows = &st.rows;
        let verdict = st.active.recheck(
            it,
            model,
            u,
            &st.committed,
            tolerance,
            || self.natural_states_converged(model, rows, u, &inc, it),
            log,
        );
        match verdict {
            Recheck::Chatter(why) => Err((it, why.to_string())),
            Recheck::Accept => {
                self.log_converged(check, arc, log);
                Ok(Verdict::Done(it))
            }
            Recheck::IterateOn => {
                // The frozen states' equilibrium is the start of a new solve of the law's own
                // problem: its iterations get the whole budget again, and the progress test
                // compares residuals of that problem only (the frozen one's, far smaller,
                // would make a steady descent from the jump look like stagnation). `hard_max`
                // still bounds the increment.
                st.last_free = f64::INFINITY;
                st.budget_from = it;
                st.history.clear();
                Ok(Verdict::Again)
            }
        }
    }

    /// After the sleeve ties' multipliers moved (slip.rs, `close_ties`), the increment is
    /// solved again from the converged iterate: a new solve's budget and progress record (as
    /// after a release of frozen states), and a fresh line-search memory (the potential has
    /// changed with the multipliers). `hard_max` still bounds the increment.
    fn after_tie_update(&self, st: &mut Iteration, it: usize) {
        st.last_free = f64::INFINITY;
        st.budget_from = it;
        st.history.clear();
        st.recent.clear();
        st.recent_potential = None;
    }

    /// The converged iterate's log line.
    fn log_converged(&self, check: &Check, arc: Option<&ArcRow>, log: &mut Vec<String>) {
        push_log(
            log,
            format!(
                "  converged: |R| = {:.3e} (scale {:.3e}, largest residual {:.2} of its local tolerance and floor){}{}",
                check.free,
                check.scale,
                check.worst,
                slip_note(check),
                arc.map_or(String::new(), |a| format!(" at λ {:.6}", a.lambda)),
            ),
        );
    }

    /// Phase 3, the iteration budget: `max_iterations` from the last release of frozen
    /// states, continued (up to `max_iterations_progressing`) while the residual still falls
    /// steadily near the solution.
    fn budget(
        &self,
        model: &Model,
        u: &[f64],
        st: &mut Iteration,
        check: &Check,
        it: usize,
        hard_max: usize,
    ) -> Result<(), Failure> {
        st.last_free = check.free;
        st.history
            .push(check.free.max(check.slip) / check.scale.max(f64::MIN_POSITIVE));
        if it - st.budget_from >= self.settings.max_iterations
            && !(it < hard_max && progressing(&st.history))
        {
            return Err((
                it,
                format!(
                    "no convergence in {it} iterations (|R| = {:.3e}, |r_slip| = {:.3e}, scale {:.3e}; the largest residual is {:.1e} times its local tolerance and floor{}){}",
                    check.free,
                    check.slip,
                    check.scale,
                    check.worst,
                    why_not_within(check),
                    if folded_within(check) {
                        self.where_folded(model, u)
                    } else {
                        self.where_stuck(model)
                    }
                ),
            ));
        }
        Ok(())
    }

    /// Phase 4, the direction: (K + τD) Δ = −R with the rows eliminated (slip.rs); a tangent
    /// with no stiffness at all (every cable slack, nothing stressed) switches the damping
    /// on, and the damped system is definite.
    #[allow(clippy::too_many_arguments)]
    fn newton_direction(
        &mut self,
        model: &Model,
        st: &mut Iteration,
        u: &[f64],
        eqs: &Assembled,
        pending: Option<(Vec<f64>, Vec<f64>)>,
        it: usize,
        log: &mut Vec<String>,
    ) -> Result<(Vec<f64>, Vec<f64>), Failure> {
        let bordered = eqs.bordered.as_ref();
        if pending.is_none() && self.chord_applies(st, it) {
            if let Some(d) = self.chord_direction() {
                return Ok(d);
            }
        }
        let direction = match pending {
            Some(d) => Ok(d),
            None => {
                self.direction_sharing(model, u, &st.rows, bordered, st.damping, &mut st.shared)
            }
        };
        // A single-precision factor given up for double (linear.rs, "Mixed precision").
        for line in self.linear.take_notes() {
            push_log(log, format!("  {line}"));
        }
        match direction {
            Ok(d) => Ok(d),
            Err(why) if st.damping == 0.0 && self.settings.damping_start > 0.0 => {
                push_log(log, format!("  {why}: damping switched on"));
                st.damping = if st.last_damping > 0.0 {
                    st.last_damping
                } else {
                    self.settings.damping_start
                };
                self.direction_sharing(model, u, &st.rows, bordered, st.damping, &mut st.shared)
                    .map_err(|why| (it + 1, why.to_string()))
            }
            Err(why) => Err((it + 1, why.to_string())),
        }
    }

    /// In a time sub-step (dynamic.rs), once Newton is in its quadratic basin (the last step
    /// cut the relative residual by 100 or more), the next direction comes from the last
    /// factorization (a chord step): the tangent K + K_d changes little within the sub-step,
    /// K_d (the inertia's) being constant. Not with slip or volume rows or damping.
    fn chord_applies(&self, st: &Iteration, it: usize) -> bool {
        let h = &st.history;
        self.inertia.is_some()
            && it >= 1
            && st.rows.is_empty()
            && st.damping == 0.0
            && self.linear.has_factor()
            && h.len() >= 2
            && h[h.len() - 1] <= 1e-2 * h[h.len() - 2]
    }

    /// −K⁻¹R with the last factorization (None if the solve fails).
    fn chord_direction(&mut self) -> Option<(Vec<f64>, Vec<f64>)> {
        let mut dx = vec![0.0; self.pattern.n];
        for (d, &e) in self.pattern.eq.iter().enumerate() {
            if e != NONE {
                dx[e] = -self.residual[d];
            }
        }
        self.linear.solve(&mut dx).ok()?;
        dx.iter().all(|v| v.is_finite()).then_some((dx, Vec::new()))
    }

    /// The line search's merit for this direction. Frictionless sliding points are
    /// conservative: a slip row r = f_t = c (T_b − T_a) vanishes where the potential is
    /// stationary in that slip (∂Π/∂s = T_b (1 + ε_b/2) − T_a (1 + ε_a/2), c the cosine of the
    /// half kink), so the potential is the merit, as without sleeves, with Δs·r for the slips'
    /// part of the slope. Friction, stuck or merged points and volume rows need the residual.
    /// Under arc length the loads move with λ inside the step: no potential at fixed loads is
    /// the merit, the residual of the equilibrium and constraint rows is (the bordered Newton
    /// direction is a descent direction of ‖(R, r)‖; the arc row is linear, so it falls as
    /// (1 − α) h along any step and needs no share in the merit).
    fn merit(
        &self,
        model: &Model,
        st: &mut Iteration,
        info: &AssemblyInfo,
        ds: &[f64],
        arc: bool,
    ) -> Merit {
        let memory = self.settings.nonmonotone_memory;
        let rows = &st.rows;
        let sliding_freely = rows.len() == model.slips.len()
            && model
                .slips
                .iter()
                .zip(&st.active.contact)
                .all(|(p, c)| p.mu == 0.0 && matches!(c, Contact::Forward | Contact::Backward));
        let residual_merit =
            arc || (!rows.is_empty() && (!sliding_freely || !model.is_conservative()));
        if st.recent_potential.replace(!residual_merit) == Some(residual_merit) {
            st.recent.clear();
        }
        if residual_merit {
            let norm = self.residual_norm(rows.iter().map(|r| &r.r));
            Merit::Residual {
                reference: remember(&mut st.recent, memory, norm),
            }
        } else if model.is_conservative() {
            Merit::Potential {
                value: info.potential,
                reference: remember(&mut st.recent, memory, info.potential),
                slip_slope: rows.iter().zip(ds).map(|(r, d)| r.r * d).sum(),
            }
        } else {
            Merit::Slope
        }
    }

    /// Phase 5, the step: the line search along the direction, u ← u + α Δ (and λ under arc
    /// length), and the damping for the next iteration.
    #[allow(clippy::too_many_arguments)]
    fn newton_step(
        &mut self,
        model: &Model,
        st: &mut Iteration,
        u: &mut [f64],
        eqs: &Assembled,
        mut arc: Option<&mut ArcRow>,
        (dx, mut ds): (Vec<f64>, Vec<f64>),
        it: usize,
        log: &mut Vec<String>,
    ) {
        let n3 = model.dof_count();
        let dlambda = if arc.is_some() { ds.pop() } else { None };
        // Touching sleeve points the full step would carry past each other (frictionless pairs,
        // order::predicted_closures) merge now, all of them, and the direction is taken again
        // with the merged groups: a semismooth Newton step on the ordering's Kuhn-Tucker
        // conditions. Only while the fraction to the boundary would shorten the step (the
        // prediction is about closing gaps), and not after a pair parted in this increment
        // (a parting and a prediction disagree only where the contact force is about zero, and
        // re-merging there chattered: measured on unloaded rings).
        if !ds.is_empty()
            && st.reopened == 0
            && step_limit(model, u, &ds, self.settings.keep_length) < 1.0
            && st
                .active
                .close_predicted(model, u, &mut st.committed, &ds, log)
                > 0
        {
            // The active set changed: the next iteration's direction sees the merged groups.
            st.last_alpha = 1.0;
            self.work.recycle(dx, ds);
            return;
        }
        let merit = self.merit(model, st, &eqs.info, &ds, arc.is_some());
        let (alpha, ok) = self.line_search(
            model,
            u,
            &Direction { dx: &dx, ds: &ds },
            &Trial {
                loads: &st.loads,
                committed: &st.committed,
                contact: &st.active.contact,
                arc: arc
                    .as_deref()
                    .zip(dlambda)
                    .map(|(a, dl)| (a.from, a.to, a.lambda, dl)),
            },
            merit,
            &mut st.shared,
        );
        // A slip step that would shorten a sleeved segment by far more than its length is a
        // sliding mechanism's step, like a line search cut to nothing.
        let capped = !ds.is_empty()
            && step_limit(model, u, &ds, self.settings.keep_length)
                < self.settings.damping_slip_cap;
        let trouble = !ok || alpha < self.settings.damping_trigger || capped;
        st.last_alpha = alpha;
        for (d, &e) in self.pattern.eq.iter().enumerate() {
            if e != NONE {
                u[d] += alpha * dx[e];
            }
        }
        for (j, v) in ds.iter().enumerate() {
            u[n3 + j] += alpha * v;
        }
        if let (Some(a), Some(dl)) = (arc.as_deref_mut(), dlambda) {
            a.lambda += alpha * dl;
        }
        st.damping = self.next_damping(st, trouble, alpha);
        let check = &eqs.check;
        push_log(
            log,
            format!(
                "  iteration {}: |R| = {:.3e} (scale {:.3e}){}, step α = {alpha:.3}, damping τ = {:.1e}{}",
                it + 1,
                check.free,
                check.scale,
                slip_note(check),
                st.damping,
                arc.as_deref().map_or(String::new(), |a| format!(", λ -> {:.6}", a.lambda)),
            ),
        );
        self.work.recycle(dx, ds);
    }

    /// τ for the next iteration: on (or ×4) after trouble, ÷8 after a full step (0 below
    /// τ_min), kept otherwise (module docs, globalisation).
    fn next_damping(&self, st: &mut Iteration, trouble: bool, alpha: f64) -> f64 {
        let s = &self.settings;
        let damping = st.damping;
        if damping > 0.0 {
            st.last_damping = damping;
        }
        if trouble {
            if damping == 0.0 {
                s.damping_start
            } else {
                (4.0 * damping).min(s.damping_max)
            }
        } else if alpha >= 1.0 {
            let next = damping / 8.0;
            if next < s.damping_min {
                0.0
            } else {
                next
            }
        } else {
            damping
        }
    }
}

/// ", |r_slip| = …" when the model has slip rows (their largest residual is then not 0).
fn slip_note(check: &Check) -> String {
    if check.slip > 0.0 {
        format!(", |r_slip| = {:.3e}", check.slip)
    } else {
        String::new()
    }
}

/// Push `value` into the non-monotone memory and return the largest remembered value.
fn remember(recent: &mut std::collections::VecDeque<f64>, memory: usize, value: f64) -> f64 {
    recent.push_back(value);
    if recent.len() > memory {
        recent.pop_front();
    }
    recent.iter().fold(f64::NEG_INFINITY, |m, &p| m.max(p))
}

/// Every residual within its tolerance and floor, and a membrane triangle turned over or
/// collapsed: the iterate is refused for the fold alone.
fn folded_within(check: &Check) -> bool {
    check.worst <= 1.0 && check.min_area_ratio <= super::settings::MIN_AREA_RATIO
}

/// Why the last iterate of a failed increment is not an answer although every residual is
/// within its tolerance and floor (`check.worst` <= 1): a membrane triangle turned over, or
/// (within the round-off floor only) a Newton correction from there larger than the
/// tolerance of the coordinates or a stick/slip state still changing. Empty where a residual
/// is above its tolerance: the message's numbers already say why.
fn why_not_within(check: &Check) -> String {
    if !(check.worst <= 1.0) {
        String::new()
    } else if folded_within(check) {
        format!(
            ", but a membrane triangle is turned over or collapsed (area ratio {:.1e}), which an answer may not have",
            check.min_area_ratio
        )
    } else if !check.strict {
        String::from(", within the round-off floor only, where an iterate is accepted once its Newton correction is within the tolerance of the coordinates and no stick/slip state changes; neither happened (a direction with almost no stiffness, or a state still switching)")
    } else {
        String::new()
    }
}

#[cfg(test)]
mod tests {
    use super::{why_not_within, Check};

    fn check(worst: f64, strict: bool, min_area_ratio: f64) -> Check {
        Check {
            strict,
            within_floor: worst <= 1.0,
            free: 1e-8,
            slip: 0.0,
            scale: 1e4,
            worst,
            min_area_ratio,
        }
    }

    /// A failed increment whose residuals all met their tolerance says why it is not an
    /// answer: the 16x16 quarter circle of the robustness corpus failed its overshoot
    /// problems with "the largest residual is 4.0e-3 times its local tolerance" and no reason
    /// (a rim triangle turned over by 3.5e-2 of its area).
    #[test]
    fn a_failure_within_tolerance_names_what_stopped_it() {
        let folded = why_not_within(&check(4e-3, true, -3.5e-2));
        assert!(
            folded.contains("turned over or collapsed (area ratio -3.5e-2)"),
            "{folded}"
        );
        let soft = why_not_within(&check(0.5, false, 0.9));
        assert!(soft.contains("Newton correction"), "{soft}");
        // Above the tolerance the numbers say it: nothing added.
        assert_eq!(why_not_within(&check(2.0, false, -0.5)), "");
        assert_eq!(why_not_within(&check(f64::NAN, false, 0.9)), "");
    }
}
