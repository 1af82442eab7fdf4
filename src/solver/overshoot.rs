//! The overshoot continuation of an increment that failed from an unstressed membrane: the
//! force loads first raised by a factor F₀, then brought back to the scene's.
//!
//! A flat, stress-free membrane loaded across its plane (a cushion or an airbag inflated from
//! flat, a sheet under its first pressure) deflects by a motion that is nearly inextensional
//! when the load is small against the membrane's stiffness: with q the load per area, a the
//! span and E t the membrane stiffness, the strains grow as (q a / E t)^(2/3) while the shape
//! changes at once. Newton then has to find a large change of shape on a tangent whose
//! stiffness along it is tiny against E t, and its wrinkle and slack states switch across
//! the whole sheet from one iteration to the next. For an elastic structure the load scale is
//! what sets this ratio: f_int(u; E) = g f_ext(u) is the problem of the material E/g under the
//! scene's load. So the increment is solved instead through a sequence of problems with the
//! force loads (point forces, pressures, snow) multiplied by g_k:
//!
//! ```text
//! g_0 = F₀,  g_{k+1} = max(1, g_k / r),  each problem's Newton starting from the last one's
//! equilibrium; r = 4, squared (at most 64) after a problem solved in at most 6 iterations,
//! its square root after one that failed (retried from the last equilibrium; below r = 1.1
//! the continuation has failed)
//! ```
//!
//! The last problem (g = 1) is the scene's own, solved by the same Newton iteration and
//! convergence test, so the equilibrium is one that a direct solve accepts; only the path
//! changes. The first problem starts from the unstressed membrane and is solved through the
//! prestress continuation (path.rs) where that is on. F₀ brings the nominal ratio Σ|f| / (√A · E t) (Σ|f| the total applied force, A the
//! membranes' reference area, E t their area-weighted stiffness) to `overshoot_ratio` (the
//! setting `solver.overshoot_continuation`, default 3e-2): strains of a few
//! per cent, where the same Newton iteration converges from flat in tens of iterations on the
//! robustness corpus's cushions (measured: docs/robustness.md). F₀ is at most `MAX_FACTOR`,
//! and where it would be below 2 the continuation does not apply. A first problem that fails
//! is tried again from the start at 4 times its factor, at most twice.
//!
//! - **Where.** Only from an unstressed membrane (the singular flat start; path.rs decides),
//!   only on structures whose equilibrium does not depend on the load path: no elastoplastic
//!   group, no sleeve point (friction carries history; a sliding cable's slips are unknowns the
//!   scaling does not reach), no volume, gas or water input (their pressure is not a load the
//!   scaling can raise) and not in a time sub-step. A snapping structure could be carried over
//!   to another branch by a raised load; a membrane starting flat and unstressed has no
//!   branch to keep before it takes load.
//! - **Cost.** Every problem's iterations count towards the step's work budget.
//!
//! A homotopy in the load parameter in the sense of Allgower & Georg 2003, *Introduction to
//! Numerical Continuation Methods*, ch. 1: for a structure without prestress, the material
//! stiffness continued from E/F₀ to E, written as the equivalent load factor.

use super::core::Solver;
use super::report::push_log;
use super::rows::Increment;
use crate::model::pressure::SurfaceLaw;
use crate::model::sleeve::Contact;
use crate::model::{LoadModel, Model};

/// The largest first factor.
const MAX_FACTOR: f64 = 1e4;
/// The factor's first ratio from problem to problem, its largest, and its smallest.
const RATIO: f64 = 4.0;
const MAX_RATIO: f64 = 64.0;
const MIN_RATIO: f64 = 1.1;
/// A problem solved in at most this many iterations squares the ratio.
const EASY: usize = 6;
/// The most first problems tried from the start.
const FIRST_TRIES: usize = 3;

/// The force loads of `loads` multiplied by `g` (point forces, pressures, snow); every other
/// input (prescribed displacements, volumes, water levels) as it is.
pub(super) fn scaled(model: &Model, loads: &[f64], g: f64) -> Vec<f64> {
    model
        .loads
        .iter()
        .zip(loads)
        .map(|(load, &v)| match load {
            LoadModel::PointForce(_)
            | LoadModel::Pressure { .. }
            | LoadModel::Surface {
                law: SurfaceLaw::Snow,
                ..
            } => g * v,
            _ => v,
        })
        .collect()
}

impl Solver {
    /// Whether the overshoot continuation may run on `model` (module docs, "Where").
    pub(super) fn overshoot_applies(&self, model: &Model) -> bool {
        self.settings.overshoot_ratio > 0.0
            && self.inertia.is_none()
            && model.slips.is_empty()
            && model.plastic_len() == 0
            && !model.triangles.is_empty()
            && !model.loads.iter().any(|l| {
                matches!(
                    l,
                    LoadModel::Volume { .. }
                        | LoadModel::Water { .. }
                        | LoadModel::Surface {
                            law: SurfaceLaw::Ponding { .. },
                            ..
                        }
                )
            })
    }

    /// The first factor F₀ for the loads `loads` (module docs), None where it would be below 2
    /// (the load is already large against the membranes' stiffness) or cannot be estimated.
    pub(super) fn overshoot_factor(&self, model: &Model, loads: &[f64]) -> Option<f64> {
        let force: f64 = super::loads::external_forces(model, loads)
            .iter()
            .map(|f| f.abs())
            .sum();
        let (mut area, mut stiffness) = (0.0, 0.0);
        for t in &model.triangles {
            area += t.reference.area;
            stiffness += t.material.modulus() * t.material.thickness * t.reference.area;
        }
        if !(force > 0.0 && area > 0.0 && stiffness > 0.0) {
            return None;
        }
        let ratio = force / (area.sqrt() * stiffness / area);
        let f0 = (self.settings.overshoot_ratio / ratio).min(MAX_FACTOR);
        (f0.is_finite() && f0 >= 2.0).then_some(f0)
    }

    /// The overshoot continuation (module docs) of one increment from `u` (its start, the
    /// prescribed displacements set) with the first factor `f0`. Returns the iterations of
    /// every problem, or where it failed.
    pub(super) fn overshoot(
        &mut self,
        model: &Model,
        increment: &Increment,
        f0: f64,
        u: &mut [f64],
        states: &mut Vec<Contact>,
        log: &mut Vec<String>,
    ) -> Result<usize, (usize, String)> {
        let mut total = 0;
        let mut last = u.to_vec();
        let mut last_states = states.clone();
        // The factor of the last solved problem (None before the first) and the next one's.
        let mut solved: Option<f64> = None;
        let (mut g, mut ratio, mut tries) = (f0, RATIO, 0);
        loop {
            if self.work_spent() {
                return Err((
                    total,
                    format!("at {g:.3} times the load: the step's work budget is spent"),
                ));
            }
            let loads = scaled(model, increment.loads, g);
            let problem = Increment {
                loads: &loads,
                change: increment.change * g,
                moved: increment.moved,
            };
            u.copy_from_slice(&last);
            states.clone_from(&last_states);
            // The first problem starts from the unstressed membrane: through the prestress
            // continuation (path.rs) where it is on, as a direct solve of that load would.
            let outcome = if solved.is_none() && self.settings.continuation_strain > 0.0 {
                self.continuation(model, &problem, u, states, log)
            } else {
                self.newton(model, &problem, u, states, None, log)
            };
            match outcome {
                Ok(i) => {
                    total += i;
                    push_log(
                        log,
                        format!("  overshoot continuation: {g:.3} times the load solved in {i} iterations"),
                    );
                    if g == 1.0 {
                        return Ok(total);
                    }
                    last.copy_from_slice(u);
                    last_states.clone_from(states);
                    solved = Some(g);
                    if i <= EASY {
                        ratio = (ratio * ratio).min(MAX_RATIO);
                    }
                    g = (g / ratio).max(1.0);
                }
                Err((i, why)) => {
                    total += i;
                    push_log(
                        log,
                        format!("  overshoot continuation: {g:.3} times the load failed after {i} iterations: {why}"),
                    );
                    let Some(from) = solved else {
                        // The first problem from the start: a larger factor (the larger the
                        // load against the stiffness, the sooner the sheet is taut), at most
                        // `FIRST_TRIES` times.
                        tries += 1;
                        if tries == FIRST_TRIES || g * RATIO > MAX_FACTOR {
                            return Err((total, format!("at {g:.3} times the load: {why}")));
                        }
                        g *= RATIO;
                        continue;
                    };
                    ratio = ratio.sqrt();
                    if ratio < MIN_RATIO {
                        return Err((
                            total,
                            format!("from {from:.3} towards {g:.3} times the load: {why}"),
                        ));
                    }
                    g = (from / ratio).max(1.0);
                }
            }
        }
    }
}
