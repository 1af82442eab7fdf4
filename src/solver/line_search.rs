//! The one line search: backtracking along the Newton direction with the merit the problem
//! has.
//!
//! ```text
//! Potential   every load has a potential and every sleeve point (if any) slides without
//!             friction: non-monotone Armijo on Π (Grippo, Lampariello & Lucidi 1986),
//!             Π(α) <= max(last 5 Π) + c α (Δu·R + Δs·r), quadratic interpolation between
//!             tries, α from the same fraction-to-boundary limit as below
//! Slope       follower pressure (no potential), no slip unknowns: s(α) = Δu·R(u + αΔu); full
//!             step unless it overshoots the minimum, then regula falsi inside the bracket
//!             (largest α with s < 0, smallest with s > 0) until |s| <= ½|s(0)|
//! Residual    friction, stuck or merged sleeve points, volume unknowns, arc length (the
//!             loads move with λ inside the step, so no potential at fixed loads applies; the
//!             trial point takes the loads of λ + αΔλ): non-monotone Armijo
//!             on ‖(R_x, r)‖₂,
//!             ‖R(α)‖ <= (1 − c α) max(last 5 ‖R‖), halving; α starts at the largest step that
//!             keeps every sleeved segment's unstretched length above a tenth of its value
//! ```
//! Every trial point whose membrane triangles invert is rejected (α shrinks). With a potential,
//! a direction along which Π rises (an indefinite or wrongly regularised tangent) is not taken
//! at all. The search returns the step length and whether its condition was met (the
//! globalisation reads that).
//!
//!
//! # A time sub-step's trial point, shared with the next iteration
//! In a time sub-step (dynamic.rs: no slip or volume rows, no arc length, no frozen wrinkle
//! states) a trial point assembles what the next iteration's equations need besides the
//! tangent: R (with the inertia force), the force magnitudes and the triangles' evaluations.
//! When the step taken ends on the last trial point (bit for bit: the full step, nearly
//! always), the next iteration takes them as its equations and assembles nothing
//! ([`Solver::assemble_or_share`]); its tangent is assembled only if a factorization needs it
//! ([`Solver::direction_sharing`]): a chord step (newton.rs, `chord_applies`) and a converged
//! iterate do not. Each time step of the 32-ring Hencky disc thus assembles the tangent once
//! instead of three times (examples/dynamic_cost.rs). The residual, the magnitudes, the
//! evaluations and the tangent are those the iteration would have assembled itself; only the
//! round-off floor of the convergence test (system.rs) reads the diagonal of the last tangent
//! assembled, an earlier iterate's of the same sub-step, where the iterate's own is not
//! assembled. Statics (and the proximal continuation's springs) are untouched.
//!
//! # References
//! Crisfield 1991, vol. 1, §9.3 (line search on the slope); Nocedal & Wright 2006, §3.1 and
//! §3.5 (Armijo, interpolation); Grippo, Lampariello & Lucidi 1986, SIAM J. Numer. Anal.
//! 23:707–716 (non-monotone).

use super::assemble::{assemble_with, AssemblyInfo, Membranes, NONE};
use super::core::Solver;
use super::slip::{slip_rows_into, step_limit};
use super::slope::{bracket_slope, SLOPE_RATIO};
use crate::model::sleeve::Contact;
use crate::model::Model;

/// The merit function of the current iteration and its reference value.
#[derive(Clone, Copy, Debug)]
pub(super) enum Merit {
    /// Π at the current point and the largest Π of the recent iterates.
    Potential {
        value: f64,
        reference: f64,
        /// Δs·r: the slips' part of the slope (0 without sleeve points).
        slip_slope: f64,
    },
    Slope,
    /// ‖R‖₂ reference (the largest of the recent iterates).
    Residual {
        reference: f64,
    },
}

/// The Newton direction: displacement part on equations, slip part per sleeve point.
pub(super) struct Direction<'a> {
    pub dx: &'a [f64],
    pub ds: &'a [f64],
}

/// Where the trial point's residual is taken.
pub(super) struct Trial<'a> {
    pub loads: &'a [f64],
    pub committed: &'a [f64],
    pub contact: &'a [Contact],
    /// Under arc length (`arc.rs`): the step's loads (from, to), the load factor λ and its
    /// Newton correction Δλ; the trial point's loads and prescribed displacements are those
    /// of λ + α Δλ.
    pub arc: Option<(&'a [f64], &'a [f64], f64, f64)>,
}

/// What a time sub-step's Newton loop shares between a trial point and the next iteration
/// (module docs); newton.rs holds one per solve.
#[derive(Debug, Default)]
pub(super) struct Shared {
    /// The last trial point's assembly (R, magnitudes and evaluations in the solver's
    /// buffers, the point in `Solver::trial`), when it assembled all the equations but K.
    kept: Option<AssemblyInfo>,
    /// The iterate took a trial point's equations: its tangent is not assembled yet. The
    /// loads and the artificial prestress's factor it is to be assembled with.
    stale: Option<(Vec<f64>, f64)>,
}

impl Solver {
    /// Whether trial points share their assembly with the next iteration (module docs): in a
    /// time sub-step without slip or volume rows and without frozen wrinkle states.
    fn shares_trials(&self, model: &Model) -> bool {
        self.inertia.is_some()
            && !self.proximal
            && self.frozen.is_none()
            && model.slips.is_empty()
            && model.volumes == 0
    }

    /// The equations at `u` (newton.rs's assembly of an iterate): the last trial point's, when
    /// `u` is that point and they were kept, with the tangent left for
    /// [`Solver::direction_sharing`]; else R and K assembled (`assemble_at`).
    pub(super) fn assemble_or_share(
        &mut self,
        model: &Model,
        loads: &[f64],
        u: &[f64],
        shared: &mut Shared,
    ) -> AssemblyInfo {
        shared.stale = None;
        if let Some(info) = shared.kept.take() {
            if self.shares_trials(model) && self.trial[..] == u[..] {
                shared.stale = Some((loads.to_vec(), self.prestress_factor));
                self.measure_load_scale(model);
                return info;
            }
        }
        self.assemble_at(model, loads, u)
    }

    /// The Newton direction (`direction_of`), after assembling the iterate's tangent if it
    /// took a trial point's equations: with the loads and prestress factor of then, no frozen
    /// states (as the trial point had), so R, the magnitudes and the evaluations come out as
    /// they were.
    pub(super) fn direction_sharing(
        &mut self,
        model: &Model,
        u: &[f64],
        rows: &[super::rows::Row],
        bordered: Option<&super::rows::Border>,
        damping: f64,
        shared: &mut Shared,
    ) -> Result<(Vec<f64>, Vec<f64>), crate::error::Error> {
        if let Some((loads, factor)) = shared.stale.take() {
            let frozen = self.frozen.take();
            let now = std::mem::replace(&mut self.prestress_factor, factor);
            self.assemble_at(model, &loads, u);
            (self.frozen, self.prestress_factor) = (frozen, now);
        }
        self.direction_of(model, u, rows, bordered, damping)
    }

    /// Step length along `dir` from `u`, and whether the merit's condition was met. In a time
    /// sub-step the trial points' assemblies are kept in `shared` (module docs).
    pub(super) fn line_search(
        &mut self,
        model: &Model,
        u: &[f64],
        dir: &Direction,
        at: &Trial,
        merit: Merit,
        shared: &mut Shared,
    ) -> (f64, bool) {
        shared.kept = None;
        if !self.settings.line_search {
            return (
                step_limit(model, u, dir.ds, self.settings.keep_length),
                true,
            );
        }
        // Every trial after the first (an assembly without the tangent) counts half an
        // iteration in the step's work budget (core.rs, step_work).
        self.trials = 0;
        let outcome = self.search(model, u, dir, at, merit, shared);
        self.step_work += self.trials.saturating_sub(1);
        outcome
    }

    /// The line search proper (`line_search`), trials counted in `self.trials`.
    fn search(
        &mut self,
        model: &Model,
        u: &[f64],
        dir: &Direction,
        at: &Trial,
        merit: Merit,
        shared: &mut Shared,
    ) -> (f64, bool) {
        // s0 = Δu·R(u); Newton makes it −Δuᵀ K Δu, negative for a positive definite K.
        let s0 = self.direction_dot_residual(dir.dx);
        match merit {
            Merit::Potential {
                value,
                reference,
                slip_slope,
            } => {
                let s0 = s0 + slip_slope;
                // The potential resolves changes down to round-off of its own size; below a
                // thousand times that, the slope (computed from forces) is the sharper measure.
                let noise = 1e-13 * value.abs().max(f64::MIN_POSITIVE);
                if s0 > 1e3 * noise {
                    // Not a descent direction: the tangent is indefinite along it (a zero
                    // pivot regularised with the wrong sign). Take no step; the damping that
                    // the failed search switches on makes the next tangent definite.
                    return (0.0, false);
                }
                if s0 < 0.0 && -s0 > 1e3 * noise {
                    self.armijo_potential(model, u, dir, at, (value, reference, s0), shared)
                } else {
                    self.slope_search(model, u, dir, at, s0, shared)
                }
            }
            Merit::Slope => self.slope_search(model, u, dir, at, s0, shared),
            Merit::Residual { reference } => {
                self.armijo_residual(model, u, dir, at, reference, shared)
            }
        }
    }

    /// Residual at u + α dir into `self.residual` and the slip and volume rows' residuals into
    /// `self.work.trial_slip`; returns (potential, inverted). In a time sub-step also the force
    /// magnitudes and evaluations, the assembly kept in `shared` (module docs).
    fn trial_point(
        &mut self,
        model: &Model,
        u: &[f64],
        dir: &Direction,
        at: &Trial,
        alpha: f64,
        shared: &mut Shared,
    ) -> (f64, bool) {
        self.trials += 1;
        self.trial.copy_from_slice(u);
        for (d, &e) in self.pattern.eq.iter().enumerate() {
            if e != NONE {
                self.trial[d] += alpha * dir.dx[e];
            }
        }
        let n3 = model.dof_count();
        for (j, d) in dir.ds.iter().enumerate() {
            self.trial[n3 + j] += alpha * d;
        }
        let moved;
        let loads = match at.arc {
            Some((from, to, lambda, dl)) => {
                moved = super::loads::loads_at(from, to, lambda + alpha * dl);
                super::loads::prescribe(model, &moved, &mut self.trial);
                &moved[..]
            }
            None => at.loads,
        };
        let share = at.arc.is_none() && self.shares_trials(model);
        let mut info = assemble_with(
            model,
            &self.pattern,
            &self.trial,
            loads,
            &mut self.residual,
            None,
            Membranes {
                forced: self.frozen.as_deref(),
                pre_strain: self.pre_strain,
                scratch: Some(&mut self.work.scratch),
                out: share.then_some(&mut self.evaluations),
                magnitude: share.then_some(&mut self.magnitude[..]),
                ..Default::default()
            },
        );
        if share && self.pre_strain == 0.0 {
            self.carry_trial_residual(loads);
        }
        let trial = std::mem::take(&mut self.trial);
        let inertia = self.add_inertia(&trial, false, share);
        self.trial = trial;
        // As `assemble_only` (system.rs) adds it, for the kept copy.
        info.potential += inertia;
        shared.kept = share.then_some(info);
        let inverted = super::core::check_inversion(model, &info).is_err();
        let work = &mut self.work;
        work.trial_slip.clear();
        if !model.slips.is_empty() {
            slip_rows_into(
                model,
                &self.pattern.eq,
                &self.trial,
                at.committed,
                at.contact,
                &mut work.trial_rows,
            );
            work.trial_slip.extend(work.trial_rows.iter().map(|r| r.r));
        }
        work.trial_slip.extend(
            super::volume::rows(model, &self.pattern.eq, &self.trial, loads)
                .iter()
                .map(|r| r.r),
        );
        (info.potential, inverted)
    }

    /// The static residual just assembled at the trial point, kept for the next time step
    /// (`inertia::Carry::residual`, `Solver::static_residual`), in the kept buffers.
    fn carry_trial_residual(&mut self, loads: &[f64]) {
        let Some(matrices) = self.dynamic_matrices.as_mut() else {
            return;
        };
        let kept = matrices.carry.residual.get_or_insert_with(Default::default);
        kept.u.clear();
        kept.u.extend_from_slice(&self.trial);
        kept.loads.clear();
        kept.loads.extend_from_slice(loads);
        kept.r.clear();
        kept.r.resize(self.pattern.n, 0.0);
        for (d, &e) in self.pattern.eq.iter().enumerate() {
            if e != NONE {
                kept.r[e] = self.residual[d];
            }
        }
    }

    /// Δu·R: the displacement direction dotted with the residual on the free DOFs.
    pub(super) fn direction_dot_residual(&self, dx: &[f64]) -> f64 {
        self.pattern
            .eq
            .iter()
            .enumerate()
            .filter(|(_, &e)| e != NONE)
            .map(|(d, &e)| dx[e] * self.residual[d])
            .sum()
    }

    /// ‖(R_free, r)‖₂ of the last assembly and the given slip residuals.
    pub(super) fn residual_norm<'a>(&self, slip: impl IntoIterator<Item = &'a f64>) -> f64 {
        let free: f64 = self
            .pattern
            .eq
            .iter()
            .zip(&self.residual)
            .filter(|(&e, _)| e != NONE)
            .map(|(_, r)| r * r)
            .sum();
        (free + slip.into_iter().map(|r| r * r).sum::<f64>()).sqrt()
    }

    /// Armijo backtracking on the potential Π with quadratic interpolation; (p0, reference, s0)
    /// are Π(0), the largest recent Π and the slope Π′(0).
    fn armijo_potential(
        &mut self,
        model: &Model,
        u: &[f64],
        dir: &Direction,
        at: &Trial,
        (p0, reference, s0): (f64, f64, f64),
        shared: &mut Shared,
    ) -> (f64, bool) {
        let noise = 1e-13 * p0.abs().max(f64::MIN_POSITIVE);
        let mut alpha = step_limit(model, u, dir.ds, self.settings.keep_length);
        for _ in 0..self.settings.line_search_tries {
            let (p, inverted) = self.trial_point(model, u, dir, at, alpha, shared);
            if inverted || !p.is_finite() {
                alpha *= 0.25;
                continue;
            }
            if p - reference <= self.settings.armijo * alpha * s0 + noise {
                return (alpha, true);
            }
            // Minimum of the parabola through Π(0), Π'(0) = s0 and Π(α).
            let a = -s0 * alpha * alpha / (2.0 * (p - p0 - s0 * alpha));
            alpha = a.clamp(0.1 * alpha, 0.5 * alpha);
        }
        (alpha, false)
    }

    /// Full step unless the slope s(α) = Δu·R(u + αΔu) at it is positive and larger than half
    /// the initial one; then regula falsi inside the bracket of the line's minimum (the largest
    /// α with s < 0, the smallest with s > 0 or an inverted trial) until |s| <= ½|s(0)|, or
    /// the bracket's lower end when the tries run out.
    fn slope_search(
        &mut self,
        model: &Model,
        u: &[f64],
        dir: &Direction,
        at: &Trial,
        s0: f64,
        shared: &mut Shared,
    ) -> (f64, bool) {
        let tries = self.settings.line_search_tries;
        bracket_slope(s0, tries, SLOPE_RATIO, |alpha| {
            let (_, inverted) = self.trial_point(model, u, dir, at, alpha, shared);
            let s = self.direction_dot_residual(dir.dx);
            (!inverted && s.is_finite()).then_some(s)
        })
    }

    /// Non-monotone Armijo on the residual norm, halving from the fraction-to-boundary limit.
    fn armijo_residual(
        &mut self,
        model: &Model,
        u: &[f64],
        dir: &Direction,
        at: &Trial,
        reference: f64,
        shared: &mut Shared,
    ) -> (f64, bool) {
        let mut alpha = step_limit(model, u, dir.ds, self.settings.keep_length);
        for _ in 0..self.settings.line_search_tries {
            let (_, inverted) = self.trial_point(model, u, dir, at, alpha, shared);
            let norm = self.residual_norm(&self.work.trial_slip);
            let armijo = self.settings.armijo;
            if !inverted && norm.is_finite() && norm <= (1.0 - armijo * alpha) * reference {
                return (alpha, true);
            }
            alpha *= 0.5;
        }
        (alpha, false)
    }
}
