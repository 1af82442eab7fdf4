//! Newton iterations of one load increment, with the slope line search.

use super::assemble::{assemble_with, Membranes, NONE};
use super::{push_log, Solver};
use crate::model::wrinkling::WrinkleState;
use crate::model::Model;

/// Iterations with wrinkle-state changes before the states are frozen (chatter guard).
const FREEZE_AFTER: usize = 6;
/// Times frozen states may turn out wrong at convergence before the increment is cut back.
const MAX_UNFREEZE: usize = 3;

/// Smallest current/reference area ratio a membrane triangle may reach (inversion guard).
const MIN_AREA_RATIO: f64 = 1e-6;
/// Line search: accept α when |s(α)| <= LS_RATIO · |s(0)|.
const LS_RATIO: f64 = 0.5;
const LS_MAX_TRIES: usize = 8;
/// Armijo sufficient-decrease fraction.
const ARMIJO: f64 = 1e-4;

impl Solver {
    /// Iterate to equilibrium at fixed `loads`. Ok(iterations) or Err((iterations, reason)).
    pub(super) fn newton(
        &mut self,
        model: &Model,
        loads: &[f64],
        u: &mut [f64],
        log: &mut Vec<String>,
    ) -> Result<usize, (usize, String)> {
        // Round-off level of internal forces (reference geometry is not exact in floating point).
        let floor = 1e-12 * model.force_scale.max(f64::MIN_POSITIVE);
        self.frozen = None;
        let (mut previous, mut freeze_at, mut unfreezes) =
            (Vec::<WrinkleState>::new(), FREEZE_AFTER, 0);
        for it in 0..=self.settings.max_iterations {
            let membranes = Membranes {
                forced: self.frozen.as_deref(),
                out: Some(&mut self.evaluations),
            };
            let info = assemble_with(
                model,
                &self.pattern,
                u,
                loads,
                &mut self.residual,
                Some(self.linear.values_mut()),
                membranes,
            );
            let states: Vec<WrinkleState> = self.evaluations.iter().map(|e| e.state).collect();
            if self.frozen.is_none() && it >= freeze_at && states != previous {
                let changed = states.iter().zip(&previous).filter(|(a, b)| a != b).count();
                push_log(log, format!("  wrinkle states still changing ({changed} elements): frozen until convergence"));
                self.frozen = Some(states.clone());
            }
            previous = states;
            if !model.triangles.is_empty() && !(info.min_area_ratio > MIN_AREA_RATIO) {
                return Err((
                    it,
                    format!(
                        "a membrane element inverted or collapsed (area ratio {:.2e})",
                        info.min_area_ratio
                    ),
                ));
            }
            let (free, held) = self.norms();
            if !free.is_finite() {
                return Err((it, "the residual is not finite".into()));
            }
            let scale = info.external.max(held);
            if free <= self.settings.tolerance * scale + floor {
                if let Some(frozen) = self.frozen.take() {
                    // Re-check at this point with the states the criterion gives. Elements whose
                    // frozen state was wrong but sit on a state border (stress continuous there)
                    // change the residual by almost nothing: the point is an equilibrium of the
                    // true law when the natural residual also meets the tolerance.
                    let (natural, natural_free) = self.natural_states(model, loads, u);
                    if natural != frozen && natural_free > self.settings.tolerance * scale + floor {
                        unfreezes += 1;
                        if unfreezes > MAX_UNFREEZE {
                            return Err((it, "wrinkle states keep changing (chatter)".into()));
                        }
                        push_log(
                            log,
                            "  frozen wrinkle states were wrong at convergence: iterating on"
                                .into(),
                        );
                        freeze_at = it + FREEZE_AFTER;
                        continue;
                    }
                }
                push_log(
                    log,
                    format!("  converged: |R| = {free:.3e} (scale {scale:.3e})"),
                );
                return Ok(it);
            }
            if it == self.settings.max_iterations {
                return Err((
                    it,
                    format!(
                        "no convergence in {it} iterations (|R| = {free:.3e}, scale {scale:.3e})"
                    ),
                ));
            }
            for (d, &e) in self.pattern.eq.iter().enumerate() {
                if e != NONE {
                    self.rhs[e] = -self.residual[d];
                }
            }
            self.linear
                .factor_solve(&mut self.rhs)
                .map_err(|why| (it + 1, why))?;
            let alpha = if self.settings.line_search {
                self.line_search(model, loads, u, info.potential)
            } else {
                1.0
            };
            self.update(u, alpha);
            push_log(
                log,
                format!(
                    "  iteration {}: |R| = {free:.3e} (scale {scale:.3e}), step α = {alpha:.3}",
                    it + 1
                ),
            );
        }
        // Reached only when frozen states were found wrong at the last allowed iteration.
        let n = self.settings.max_iterations;
        Err((
            n,
            format!("no convergence in {n} iterations (wrinkle states changed at the end)"),
        ))
    }

    /// Wrinkle states the mixed criterion gives at `u` (no freezing), and |R|∞ over the free
    /// DOFs with those states.
    fn natural_states(
        &mut self,
        model: &Model,
        loads: &[f64],
        u: &[f64],
    ) -> (Vec<WrinkleState>, f64) {
        let mut r = vec![0.0; u.len()];
        let membranes = Membranes {
            forced: None,
            out: Some(&mut self.evaluations),
        };
        assemble_with(model, &self.pattern, u, loads, &mut r, None, membranes);
        let free = self
            .pattern
            .eq
            .iter()
            .zip(&r)
            .filter(|(&e, _)| e != NONE)
            .fold(0.0f64, |m, (_, v)| m.max(v.abs()));
        (self.evaluations.iter().map(|e| e.state).collect(), free)
    }

    /// |R|∞ over free DOFs and over held DOFs (the reactions).
    fn norms(&self) -> (f64, f64) {
        let (mut free, mut held) = (0.0f64, 0.0f64);
        for (d, &e) in self.pattern.eq.iter().enumerate() {
            let r = self.residual[d].abs();
            if e == NONE {
                held = held.max(r);
            } else if r.is_nan() {
                free = f64::NAN;
            } else {
                free = free.max(r);
            }
        }
        (free, held)
    }

    fn update(&self, u: &mut [f64], alpha: f64) {
        for (d, &e) in self.pattern.eq.iter().enumerate() {
            if e != NONE {
                u[d] += alpha * self.rhs[e];
            }
        }
    }

    /// Slope s(α) = Δu·R(u + αΔu) along the Newton direction (Δu in `rhs`) and the potential
    /// there; (NaN, NaN) if an element inverts.
    fn slope(&mut self, model: &Model, loads: &[f64], u: &[f64], alpha: f64) -> (f64, f64) {
        self.trial.copy_from_slice(u);
        for (d, &e) in self.pattern.eq.iter().enumerate() {
            if e != NONE {
                self.trial[d] += alpha * self.rhs[e];
            }
        }
        let membranes = Membranes {
            forced: self.frozen.as_deref(),
            out: None,
        };
        let info = assemble_with(
            model,
            &self.pattern,
            &self.trial,
            loads,
            &mut self.residual,
            None,
            membranes,
        );
        if !model.triangles.is_empty() && !(info.min_area_ratio > MIN_AREA_RATIO) {
            return (f64::NAN, f64::NAN);
        }
        let s = self.direction_dot_residual();
        (s, info.potential)
    }

    /// Δu·R: the Newton direction (in `rhs`) dotted with the residual on the free DOFs.
    fn direction_dot_residual(&self) -> f64 {
        self.pattern
            .eq
            .iter()
            .enumerate()
            .filter(|(_, &e)| e != NONE)
            .map(|(d, &e)| self.rhs[e] * self.residual[d])
            .sum()
    }

    /// Step length along the Newton direction. With a potential (no follower pressure, whose
    /// work has none): backtracking until the potential decreases by the Armijo fraction of the
    /// slope (the relaxed membrane energy is C¹, so this is robust across state switches).
    /// Otherwise: 1 unless the slope at the full step is worse than half the initial one, then
    /// regula falsi on s(α) between 0 and the last overshooting α.
    fn line_search(&mut self, model: &Model, loads: &[f64], u: &[f64], potential: f64) -> f64 {
        // s0 = Δu·R(u); Newton makes it −Δuᵀ K Δu, negative for a positive definite K.
        let s0 = self.direction_dot_residual();
        if !(s0 < 0.0) {
            return 1.0;
        }
        // The potential resolves changes down to round-off of its own size; below a thousand
        // times that, the slope (computed from forces) is the sharper measure.
        let noise = 1e-13 * potential.abs().max(f64::MIN_POSITIVE);
        if model.is_conservative() && -s0 > 1e3 * noise {
            return self.armijo(model, loads, u, potential, s0);
        }
        let mut alpha = 1.0;
        for _ in 0..LS_MAX_TRIES {
            let (s, _) = self.slope(model, loads, u, alpha);
            if s.is_nan() {
                alpha *= 0.5;
                continue;
            }
            if s.abs() <= LS_RATIO * s0.abs() || s < 0.0 {
                // Close enough to the minimum, or still descending: take it.
                return alpha;
            }
            // Overshoot (s > 0): secant between (0, s0) and (α, s).
            alpha = (alpha * s0 / (s0 - s)).max(0.05 * alpha);
        }
        alpha
    }

    /// Armijo backtracking on the potential Π with quadratic interpolation.
    fn armijo(&mut self, model: &Model, loads: &[f64], u: &[f64], p0: f64, s0: f64) -> f64 {
        let noise = 1e-13 * p0.abs().max(f64::MIN_POSITIVE);
        let mut alpha = 1.0;
        for _ in 0..LS_MAX_TRIES {
            let (_, p) = self.slope(model, loads, u, alpha);
            if p.is_nan() {
                alpha *= 0.25;
                continue;
            }
            let drop = p - p0;
            if drop <= ARMIJO * alpha * s0 + noise {
                return alpha;
            }
            // Minimum of the parabola through Π(0), Π'(0) = s0 and Π(α).
            let a = -s0 * alpha * alpha / (2.0 * (drop - s0 * alpha));
            alpha = a.clamp(0.1 * alpha, 0.5 * alpha);
        }
        alpha
    }
}
