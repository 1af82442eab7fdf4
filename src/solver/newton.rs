//! Newton iterations of one load increment: line search, wrinkle-state freezing against
//! chatter, and nodal relaxation when the global iteration stalls.
//!
//! ```text
//! iterate:  assemble R, K at u (states from the mixed criterion, or frozen)
//!           converged when |R_free|∞ <= tol · max(|f_ext|∞, |reactions|∞) + round-off floor
//!           stalled (after 2 iterations, last step shortened or |R| fell by < 4x):
//!               relax the nodes carrying >= 1/10 of |R|∞ (super::relax); repeat, adding the
//!               nodes that then carry it, while each round lowers |R|∞ by a tenth; reassemble
//!           K Δu = −R;  u ← u + α Δu (α from the line search)
//! ```

use super::assemble::{assemble_with, AssemblyInfo, Membranes, NONE};
use super::relax::relax_nodes;
use super::{push_log, Solver};
use crate::model::wrinkling::WrinkleState;
use crate::model::Model;

/// Iterations with wrinkle-state changes before the states are frozen (chatter guard).
const FREEZE_AFTER: usize = 6;
/// Times frozen states may turn out wrong at convergence before the increment is cut back.
const MAX_UNFREEZE: usize = 3;

/// Line search: accept α when |s(α)| <= LS_RATIO · |s(0)|.
const LS_RATIO: f64 = 0.5;
const LS_MAX_TRIES: usize = 8;
/// Nodes whose residual is at least this share of the largest are relaxed when Newton stalls.
const RELAX_SHARE: f64 = 0.1;
/// Relaxation is for local trouble: not when more than this share of the nodes qualify.
const RELAX_MAX_SHARE: f64 = 0.1;
/// Rounds of relaxation, each over the nodes that then carry the residual, while each round
/// lowers it by at least a tenth.
const RELAX_ROUNDS: usize = 20;
/// Gauss-Seidel sweeps over the nodes to relax.
const RELAX_SWEEPS: usize = 3;

/// The artificial prestress fades with the relative residual below this level: the
/// over-stiff out-of-plane tangent it gives a nearly unstressed membrane (the singular flat
/// state, approached when a flat sheet is unloaded) would otherwise make the last iterations
/// converge only linearly. Tangent only, so the equilibrium does not change.
const PRESTRESS_FADE: f64 = 1e-2;

/// Factor on the artificial prestress for the next tangent: 1 down to a relative residual of
/// PRESTRESS_FADE, proportional to it below.
fn prestress_factor(free: f64, scale: f64) -> f64 {
    if scale > 0.0 && free.is_finite() {
        (free / (PRESTRESS_FADE * scale)).min(1.0)
    } else {
        1.0
    }
}

/// Newton has stalled when, past its first two iterations, the last step was shortened or the
/// residual fell by less than a factor 4 (quadratic convergence falls much faster).
fn stalled(it: usize, free: f64, last_free: f64, last_alpha: f64) -> bool {
    it >= 2 && (last_alpha < 1.0 || free > 0.25 * last_free)
}

/// Non-monotone line search (Grippo, Lampariello & Lucidi 1986): a step must bring the
/// potential below the largest of the last NONMONOTONE_MEMORY iterates' potentials, not
/// necessarily below the current one, so narrow curved valleys do not force tiny steps.
const NONMONOTONE_MEMORY: usize = 5;
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
        self.prestress_factor = 1.0;
        let (mut previous, mut freeze_at, mut unfreezes) =
            (Vec::<WrinkleState>::new(), FREEZE_AFTER, 0);
        let (mut last_free, mut last_alpha) = (f64::INFINITY, 1.0);
        let mut recent = std::collections::VecDeque::with_capacity(NONMONOTONE_MEMORY + 1);
        for it in 0..=self.settings.max_iterations {
            let mut info = self.assemble_at(model, loads, u);
            let states: Vec<WrinkleState> = self.evaluations.iter().map(|e| e.state).collect();
            if self.frozen.is_none() && it >= freeze_at && states != previous {
                let changed = states.iter().zip(&previous).filter(|(a, b)| a != b).count();
                push_log(log, format!("  wrinkle states still changing ({changed} elements): frozen until convergence"));
                self.frozen = Some(states.clone());
            }
            previous = states;
            super::check_inversion(model, &info).map_err(|why| (it, why))?;
            let (mut free, held) = self.norms();
            if !free.is_finite() {
                return Err((it, "the residual is not finite".into()));
            }
            let scale = info.external.max(held);
            let tolerance = self.settings.tolerance * scale + floor;
            self.prestress_factor = prestress_factor(free, scale + floor);
            if free > tolerance && stalled(it, free, last_free, last_alpha) {
                let moved = self.relax(model, loads, u, free, tolerance);
                if moved > 0 {
                    info = self.assemble_at(model, loads, u);
                    let before = free;
                    free = self.norms().0;
                    push_log(
                        log,
                        format!("  stalled: relaxed {moved} nodes, |R| {before:.3e} -> {free:.3e}"),
                    );
                }
            }
            if free <= tolerance {
                if let Some(frozen) = self.frozen.take() {
                    // Re-check at this point with the states the criterion gives. Elements whose
                    // frozen state was wrong but sit on a state border (stress continuous there)
                    // change the residual by almost nothing: the point is an equilibrium of the
                    // true law when the natural residual also meets the tolerance.
                    let (natural, natural_free) = self.natural_states(model, loads, u);
                    if natural != frozen && natural_free > tolerance {
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
            last_free = free;
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
                recent.push_back(info.potential);
                if recent.len() > NONMONOTONE_MEMORY {
                    recent.pop_front();
                }
                let reference = recent.iter().fold(f64::NEG_INFINITY, |m, &p| m.max(p));
                self.line_search(model, loads, u, info.potential, reference)
            } else {
                1.0
            };
            last_alpha = alpha;
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

    /// Residual, tangent and evaluations at `u` (frozen wrinkle states if any).
    pub(super) fn assemble_at(&mut self, model: &Model, loads: &[f64], u: &[f64]) -> AssemblyInfo {
        let membranes = Membranes {
            forced: self.frozen.as_deref(),
            out: Some(&mut self.evaluations),
            held_step: None,
            prestress_factor: Some(self.prestress_factor),
        };
        assemble_with(
            model,
            &self.pattern,
            u,
            loads,
            &mut self.residual,
            Some(self.linear.values_mut()),
            membranes,
        )
    }

    /// Relax, one at a time with all others held, the nodes with a free DOF whose residual is
    /// at least RELAX_SHARE · |R|∞ (`free`), to `target`, when they are few (at most
    /// RELAX_MAX_SHARE of the nodes); returns how many moved.
    fn relax(
        &mut self,
        model: &Model,
        loads: &[f64],
        u: &mut [f64],
        free: f64,
        tolerance: f64,
    ) -> usize {
        let (mut free, mut moved_total) = (free, 0);
        let mut patch = vec![false; model.reference.len()];
        for _ in 0..RELAX_ROUNDS {
            // The patch grows by the nodes that now carry the residual (the neighbours the last
            // round passed it on to) and is relaxed as a whole: block Gauss-Seidel on it.
            for i in 0..model.reference.len() {
                patch[i] |= (0..3).any(|c| {
                    let d = 3 * i + c;
                    self.pattern.eq[d] != NONE && self.residual[d].abs() >= RELAX_SHARE * free
                });
            }
            let nodes: Vec<usize> = (0..patch.len()).filter(|&i| patch[i]).collect();
            if nodes.len() as f64 > RELAX_MAX_SHARE * model.reference.len() as f64 {
                // The residual is spread over the mesh: a global, not a local, difficulty.
                break;
            }
            let forced = self.frozen.as_deref();
            let mut moved = 0;
            for _ in 0..RELAX_SWEEPS {
                moved = moved.max(relax_nodes(
                    model,
                    &self.adjacency,
                    u,
                    loads,
                    &nodes,
                    forced,
                    0.1 * tolerance,
                ));
            }
            if moved == 0 {
                break;
            }
            moved_total += moved;
            let membranes = Membranes {
                forced,
                out: None,
                held_step: None,
                prestress_factor: None,
            };
            assemble_with(
                model,
                &self.pattern,
                u,
                loads,
                &mut self.residual,
                None,
                membranes,
            );
            let before = free;
            free = self.norms().0;
            if free <= tolerance || free > 0.9 * before {
                break;
            }
        }
        moved_total
    }

    /// Wrinkle states the mixed criterion gives at `u` (no freezing), and |R|∞ over the free
    /// DOFs with those states.
    pub(super) fn natural_states(
        &mut self,
        model: &Model,
        loads: &[f64],
        u: &[f64],
    ) -> (Vec<WrinkleState>, f64) {
        let mut r = vec![0.0; model.dof_count()];
        let membranes = Membranes {
            forced: None,
            out: Some(&mut self.evaluations),
            held_step: None,
            prestress_factor: None,
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
    pub(super) fn norms(&self) -> (f64, f64) {
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
            held_step: None,
            prestress_factor: None,
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
        if super::check_inversion(model, &info).is_err() {
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
    fn line_search(
        &mut self,
        model: &Model,
        loads: &[f64],
        u: &[f64],
        potential: f64,
        reference: f64,
    ) -> f64 {
        // s0 = Δu·R(u); Newton makes it −Δuᵀ K Δu, negative for a positive definite K.
        let s0 = self.direction_dot_residual();
        if !(s0 < 0.0) {
            return 1.0;
        }
        // The potential resolves changes down to round-off of its own size; below a thousand
        // times that, the slope (computed from forces) is the sharper measure.
        let noise = 1e-13 * potential.abs().max(f64::MIN_POSITIVE);
        if model.is_conservative() && -s0 > 1e3 * noise {
            return self.armijo(model, loads, u, (potential, reference), s0);
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
    fn armijo(
        &mut self,
        model: &Model,
        loads: &[f64],
        u: &[f64],
        (p0, reference): (f64, f64),
        s0: f64,
    ) -> f64 {
        let noise = 1e-13 * p0.abs().max(f64::MIN_POSITIVE);
        let mut alpha = 1.0;
        for _ in 0..LS_MAX_TRIES {
            let (_, p) = self.slope(model, loads, u, alpha);
            if p.is_nan() {
                alpha *= 0.25;
                continue;
            }
            let drop = p - p0;
            if p - reference <= ARMIJO * alpha * s0 + noise {
                return alpha;
            }
            // Minimum of the parabola through Π(0), Π'(0) = s0 and Π(α).
            let a = -s0 * alpha * alpha / (2.0 * (drop - s0 * alpha));
            alpha = a.clamp(0.1 * alpha, 0.5 * alpha);
        }
        alpha
    }
}
