//! Arc-length path following (the normal-plane variant of Riks and Crisfield): the load factor
//! λ of the step becomes one more unknown, held by one more equation on the displacements, so
//! the path goes on through limit points where load control stops.
//!
//! ```text
//! loads      load(λ) = from + λ (to − from);  R(u, λ) = f_int(u) − f_ext(u, load(λ))
//!            q = −∂R/∂λ = R(u, from) − R(u, to)     (R is affine in the loads; follower
//!                                                   pressures make q depend on u)
//! predictor  K v = q at the converged (u_n, λ_n);  t = ±v/|v|,  Δλ = ±Δs/|v|
//!            sign: + at the start of a step (towards the target), then the sign that keeps
//!            t · (u_n − u_{n−1}) > 0 (the path goes on in the direction it came from)
//! corrector  equations R(u, λ) = 0 and h = t · (u − u_n) − Δs = 0 (the plane normal to t at
//!            distance Δs: Riks's fixed normal plane)
//!            [K  −q] [Δu]     [R]      y0 = −K⁻¹R,  y1 = K⁻¹q   (two solves on one LDLT of K)
//!            [tᵀ  0] [Δλ] = − [h]      Δλ = (−h − t·y0)/(t·y1),  Δu = y0 + Δλ y1
//! step size  Δs grows 1.5x after an increment within the target iterations, halves after one
//!            above 3/4 of the limit, is cut by 4 on failure
//! ```
//! The metric is the Euclidean norm of the free displacements divided by √n (n free DOFs), so
//! `Settings::arc_length` is an RMS displacement in metres whatever the mesh.
//!
//! Prescribed displacements that the step moves follow λ like the loads: they are set from
//! load(λ) at every iteration, and q gains −K_fp du_p/dλ (their coupling into the free
//! equations), so a displacement-driven path is followed through a limit point too.
//!
//! Where arc length does not apply the step is load-controlled: a step that moves volume/gas
//! inputs, a model with sleeve points (stick/slip states) or volume unknowns, and every increment across which a membrane's wrinkle state switches
//! (taut/wrinkled/slack) while the load rises: that increment is solved again by load control
//! to the load factor the arc-length point reached (state switches make the path
//! non-smooth, and the normal plane can then cut it at another state's equilibrium). A step
//! ends where the load reaches its target: the last increment is load-controlled to λ = 1
//! exactly. A step whose target lies beyond a limit load therefore fails (the load factor
//! turns back past the limit): the message names the largest load factor reached.
//!
//! # References
//! Riks 1979, Int. J. Solids Struct. 15:529–551 (the normal plane); Crisfield 1991, vol. 1,
//! §9.3–9.4 (arc length, bordered systems by two solves, the sign of the predictor).

use super::assemble::{assemble_with, Membranes, NONE};
use super::newton::Increment;
use super::{push_log, Outcome, Solver, StepReport};
use crate::model::sleeve::Contact;
use crate::model::wrinkling::WrinkleState;
use crate::model::{LoadModel, Model};

/// One converged point of a traced path.
#[derive(Clone, Debug)]
pub struct PathPoint {
    /// Load factor of the step (load = from + λ (to − from)).
    pub lambda: f64,
    /// The equilibrium displacements.
    pub u: Vec<f64>,
    /// Newton iterations of its increment (predictor solve not counted).
    pub iterations: usize,
}

/// Why arc length does not apply to a step (None: it does).
fn not_applicable(model: &Model, from: &[f64], to: &[f64]) -> Option<&'static str> {
    if model.unknown_count() != model.dof_count() {
        return Some("the model has sleeve points or volume unknowns");
    }
    for ((load, a), b) in model.loads.iter().zip(from).zip(to) {
        if a != b && matches!(load, LoadModel::Volume { .. }) {
            return Some("the step moves a prescribed volume");
        }
    }
    if from == to {
        return Some("the loads do not change");
    }
    None
}

fn loads_at(from: &[f64], to: &[f64], lambda: f64) -> Vec<f64> {
    from.iter()
        .zip(to)
        .map(|(a, b)| a + lambda * (b - a))
        .collect()
}

/// du/dλ of the prescribed DOFs at λ (zero elsewhere), None when no prescribed displacement
/// moves in the step.
fn prescribed_rate(
    model: &Model,
    from: &[f64],
    to: &[f64],
    lambda: f64,
    u: &[f64],
) -> Option<Vec<f64>> {
    let moves = model
        .loads
        .iter()
        .zip(from.iter().zip(to))
        .any(|(load, (a, b))| a != b && matches!(load, LoadModel::Displacement(_)));
    if !moves {
        return None;
    }
    let eps = 1e-6;
    let (mut plus, mut minus) = (u.to_vec(), u.to_vec());
    super::path::prescribe(model, &loads_at(from, to, lambda + eps), &mut plus);
    super::path::prescribe(model, &loads_at(from, to, lambda - eps), &mut minus);
    let mut rate = vec![0.0; model.dof_count()];
    for load in &model.loads {
        if let LoadModel::Displacement(p) = load {
            for &d in &p.dofs {
                rate[d] = (plus[d] - minus[d]) / (2.0 * eps);
            }
        }
    }
    Some(rate)
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

impl Solver {
    /// Why a step `from` → `to` under `solver.path: "arc_length"` is load-controlled as a
    /// whole (sleeve points, volume or gas unknowns, moving volumes, unchanged loads); None
    /// when arc length follows it.
    pub fn arc_length_fallback(model: &Model, from: &[f64], to: &[f64]) -> Option<&'static str> {
        not_applicable(model, from, to)
    }

    /// q = R(u, from) − R(u, to) on the equations (−∂R/∂λ).
    fn load_direction(
        &mut self,
        model: &Model,
        from: &[f64],
        to: &[f64],
        lambda: f64,
        u: &[f64],
    ) -> Vec<f64> {
        let mut r0 = vec![0.0; model.dof_count()];
        let mut r1 = vec![0.0; model.dof_count()];
        assemble_with(
            model,
            &self.pattern,
            u,
            from,
            &mut r0,
            None,
            Membranes::default(),
        );
        assemble_with(
            model,
            &self.pattern,
            u,
            to,
            &mut r1,
            None,
            Membranes::default(),
        );
        let mut q = vec![0.0; self.pattern.n];
        for (d, &e) in self.pattern.eq.iter().enumerate() {
            if e != NONE {
                q[e] = r0[d] - r1[d];
            }
        }
        // Prescribed displacements that move with λ: −K_fp du_p/dλ (du_p/dλ by a central
        // difference: exact for translations, to about 1e-10 for rotations), through the held-step
        // coupling of the assembly (the tangent's values are not touched).
        if let Some(rate) = prescribed_rate(model, from, to, lambda, u) {
            let mut coupling = vec![0.0; model.dof_count()];
            let mut r = vec![0.0; model.dof_count()];
            let membranes = Membranes {
                held_step: Some((&rate, &mut coupling)),
                ..Default::default()
            };
            let loads = loads_at(from, to, lambda);
            assemble_with(model, &self.pattern, u, &loads, &mut r, None, membranes);
            for (d, &e) in self.pattern.eq.iter().enumerate() {
                if e != NONE {
                    q[e] -= coupling[d];
                }
            }
        }
        q
    }

    /// Wrinkle states of the membranes at `u` (natural, no freezing).
    fn wrinkle_states(&mut self, model: &Model, loads: &[f64], u: &[f64]) -> Vec<WrinkleState> {
        self.frozen = None;
        let mut r = vec![0.0; model.dof_count()];
        let membranes = Membranes {
            out: Some(&mut self.evaluations),
            ..Default::default()
        };
        assemble_with(model, &self.pattern, u, loads, &mut r, None, membranes);
        self.evaluations.iter().map(|e| e.state).collect()
    }

    /// The unit tangent (on the equations) at the converged point and dλ per unit arc length
    /// (in the √n-scaled metric), with the sign that continues `previous` (or raises the load
    /// when there is none).
    fn arc_tangent(
        &mut self,
        model: &Model,
        from: &[f64],
        to: &[f64],
        lambda: f64,
        u: &[f64],
        previous: Option<&[f64]>,
    ) -> Result<(Vec<f64>, f64), String> {
        self.frozen = None;
        // The artificial prestress (tangent only, where an element lacks tension) keeps the
        // predictor of a stress-free start regular; it does not change the equilibrium.
        self.prestress_factor = 1.0;
        let loads = loads_at(from, to, lambda);
        self.assemble_at(model, &loads, u);
        let mut v = self.load_direction(model, from, to, lambda, u);
        self.linear.factor_solve(&mut v)?;
        let norm = dot(&v, &v).sqrt();
        if !(norm.is_finite() && norm > 0.0) {
            return Err("the tangent predictor is not finite".into());
        }
        let sign = match previous {
            Some(p) if dot(&v, p) < 0.0 => -1.0,
            _ => 1.0,
        };
        let scale = (self.pattern.n as f64).sqrt();
        let t: Vec<f64> = v.iter().map(|x| sign * x / norm).collect();
        Ok((t, sign * scale / norm))
    }

    /// One arc-length increment of length `ds` (RMS metres) from the converged (u_n, λ_n)
    /// along the unit tangent `t` (dλ/ds `dlds`): Ok((u, λ, iterations)).
    #[allow(clippy::too_many_arguments)]
    fn arc_increment(
        &mut self,
        model: &Model,
        from: &[f64],
        to: &[f64],
        change: f64,
        u_n: &[f64],
        lambda_n: f64,
        t: &[f64],
        dlds: f64,
        ds: f64,
        log: &mut Vec<String>,
    ) -> Result<(Vec<f64>, f64, usize), (usize, String)> {
        let scale = (self.pattern.n as f64).sqrt();
        let length = ds * scale;
        let mut u = u_n.to_vec();
        for (d, &e) in self.pattern.eq.iter().enumerate() {
            if e != NONE {
                u[d] += length * t[e];
            }
        }
        let mut lambda = lambda_n + ds * dlds;
        self.frozen = None;
        self.prestress_factor = 1.0;
        for it in 0..=self.settings.max_iterations {
            let loads = loads_at(from, to, lambda);
            // Prescribed displacements follow the load factor.
            super::path::prescribe(model, &loads, &mut u);
            let info = self.assemble_at(model, &loads, &u);
            super::check_inversion(model, &info).map_err(|why| (it, why))?;
            let inc = Increment {
                loads: &loads,
                change,
                moved: true,
            };
            let check = self.check(model, &info, &[], &u, &inc, it);
            if !check.free.is_finite() {
                return Err((it, "the residual is not finite".into()));
            }
            self.prestress_factor = super::newton::prestress_factor(
                check.free / check.scale.max(f64::MIN_POSITIVE),
                self.settings.prestress_fade,
            );
            let mut h = -length;
            for (d, &e) in self.pattern.eq.iter().enumerate() {
                if e != NONE {
                    h += t[e] * (u[d] - u_n[d]);
                }
            }
            if it > 0 && check.strict && h.abs() <= self.settings.tolerance * length {
                push_log(
                    log,
                    format!(
                        "  arc length: converged at λ {lambda:.6}: |R| = {:.3e} (scale {:.3e})",
                        check.free, check.scale
                    ),
                );
                return Ok((u, lambda, it));
            }
            if it == self.settings.max_iterations {
                return Err((
                    it,
                    format!(
                        "arc length: no convergence in {it} iterations (|R| = {:.3e}, scale {:.3e})",
                        check.free, check.scale
                    ),
                ));
            }
            let mut y0 = vec![0.0; self.pattern.n];
            for (d, &e) in self.pattern.eq.iter().enumerate() {
                if e != NONE {
                    y0[e] = -self.residual[d];
                }
            }
            let mut y1 = self.load_direction(model, from, to, lambda, &u);
            // load_direction does not touch the tangent values assembled above.
            self.linear.factor().map_err(|why| (it + 1, why))?;
            self.linear.solve(&mut y0).map_err(|why| (it + 1, why))?;
            self.linear.solve(&mut y1).map_err(|why| (it + 1, why))?;
            let ty1 = dot(t, &y1);
            if !(ty1.is_finite() && ty1 != 0.0) {
                return Err((it + 1, "arc length: the bordered system is singular".into()));
            }
            let dl = (-h - dot(t, &y0)) / ty1;
            let correction = y0
                .iter()
                .zip(&y1)
                .map(|(a, b)| (a + dl * b).abs())
                .fold(0.0f64, f64::max);
            if it > 0
                && check.within_floor
                && correction <= self.settings.tolerance * self.coordinate_size(model, &u)
            {
                push_log(
                    log,
                    format!(
                        "  arc length: converged at λ {lambda:.6} (round-off floor): |R| = {:.3e}",
                        check.free
                    ),
                );
                return Ok((u, lambda, it));
            }
            for (d, &e) in self.pattern.eq.iter().enumerate() {
                if e != NONE {
                    u[d] += y0[e] + dl * y1[e];
                }
            }
            lambda += dl;
            push_log(
                log,
                format!(
                    "  arc length iteration {}: |R| = {:.3e} (scale {:.3e}), λ -> {lambda:.6}",
                    it + 1,
                    check.free,
                    check.scale
                ),
            );
        }
        unreachable!("the loop returns at max_iterations")
    }

    /// One load-controlled increment λ_a → λ_b from the converged `u` (the fallback).
    #[allow(clippy::too_many_arguments)]
    fn load_increment(
        &mut self,
        model: &Model,
        from: &[f64],
        to: &[f64],
        change: f64,
        u: &[f64],
        lambda: f64,
        log: &mut Vec<String>,
    ) -> Result<(Vec<f64>, usize), (usize, String)> {
        let loads = loads_at(from, to, lambda);
        let mut trial = u.to_vec();
        // Moves the prescribed displacements to λ (and predicts the free DOFs) as load
        // control does.
        let predicted = self.predict(model, &loads, &mut trial);
        let mut contact: Vec<Contact> = Vec::new();
        let increment = Increment {
            loads: &loads,
            change,
            moved: true,
        };
        self.newton(model, &increment, &mut trial, &mut contact, log)
            .map(|i| (trial, i + predicted))
            .map_err(|(i, why)| (i + predicted, why))
    }

    /// Trace the path of the step `from` → `to` from the equilibrium `u` (at `from`) by
    /// `count` arc-length increments of fixed length `ds` (RMS metres), without stopping at the
    /// target load and without the load-control fallback: the converged points in order. For
    /// verification and studies of a whole path (a limit point and what lies past it).
    pub fn trace_arc_length(
        &mut self,
        model: &Model,
        from: &[f64],
        to: &[f64],
        u: &[f64],
        ds: f64,
        count: usize,
    ) -> Result<Vec<PathPoint>, String> {
        if let Some(why) = not_applicable(model, from, to) {
            return Err(format!("arc length does not apply: {why}"));
        }
        let change = super::path::load_change(model, from, to);
        let mut log = Vec::new();
        let (mut u_n, mut lambda_n) = (u.to_vec(), 0.0);
        let mut previous: Option<Vec<f64>> = None;
        let mut points = Vec::new();
        for k in 0..count {
            let (t, dlds) =
                self.arc_tangent(model, from, to, lambda_n, &u_n, previous.as_deref())?;
            let (u, lambda, iterations) = self
                .arc_increment(
                    model, from, to, change, &u_n, lambda_n, &t, dlds, ds, &mut log,
                )
                .map_err(|(_, why)| format!("increment {k}: {why}\n{}", log.join("\n")))?;
            previous = Some(self.equation_difference(&u, &u_n));
            points.push(PathPoint {
                lambda,
                u: u.clone(),
                iterations,
            });
            u_n = u;
            lambda_n = lambda;
        }
        Ok(points)
    }

    fn equation_difference(&self, a: &[f64], b: &[f64]) -> Vec<f64> {
        let mut out = vec![0.0; self.pattern.n];
        for (d, &e) in self.pattern.eq.iter().enumerate() {
            if e != NONE {
                out[e] = a[d] - b[d];
            }
        }
        out
    }

    /// Solve one step by arc length (module docs); falls back to
    /// [`Solver::solve_step_with`]'s load control where arc length does not apply.
    pub(super) fn solve_step_arc(
        &mut self,
        model: &Model,
        from: &[f64],
        to: &[f64],
        u: &mut Vec<f64>,
    ) -> Option<StepReport> {
        let mut report = StepReport {
            outcome: Outcome::Failed,
            iterations: 0,
            increments: 0,
            cutbacks: 0,
            reached: 0.0,
            message: String::new(),
            log: Vec::new(),
        };
        if let Some(why) = not_applicable(model, from, to) {
            push_log(
                &mut report.log,
                format!("arc length does not apply ({why}): load control"),
            );
            return None;
        }
        let s = self.settings.clone();
        let change = super::path::load_change(model, from, to);
        let (mut u_n, mut lambda_n, mut lambda_max) = (u.clone(), 0.0f64, 0.0f64);
        let mut previous: Option<Vec<f64>> = None;
        let mut ds = s.arc_length;
        let mut first_dl = s.initial_increment;
        let mut smallest = f64::INFINITY;
        loop {
            if report.increments + report.cutbacks >= s.max_increments {
                report.reached = lambda_max;
                report.message = format!(
                    "no equilibrium found at the step's target by arc length ({} increments used, now at load fraction {lambda_n:.6}; largest load fraction reached {lambda_max:.6})",
                    s.max_increments
                );
                return Some(report);
            }
            if ds <= 0.0 {
                // No size given: the first increment is load-controlled and sets Δs.
                let target = first_dl.min(1.0);
                match self.load_increment(model, from, to, change, &u_n, target, &mut report.log) {
                    Ok((u_new, iters)) => {
                        report.iterations += iters;
                        report.increments += 1;
                        let d = self.equation_difference(&u_new, &u_n);
                        ds = (dot(&d, &d) / self.pattern.n as f64).sqrt();
                        push_log(&mut report.log, format!("increment λ 0 -> {target:.6} (load control): converged in {iters} iterations; arc length {ds:.3e} m"));
                        previous = Some(d);
                        u_n = u_new;
                        lambda_n = target;
                        lambda_max = target;
                        smallest = ds * s.min_increment;
                        if target >= 1.0 {
                            break;
                        }
                        if ds <= 0.0 {
                            // Nothing moved: load control for the rest.
                            ds = f64::NAN;
                        }
                    }
                    Err((iters, why)) => {
                        report.iterations += iters;
                        report.cutbacks += 1;
                        first_dl *= 0.25;
                        if first_dl < s.min_increment {
                            report.message = format!(
                                "no equilibrium found beyond load fraction 0 of the step ({why})"
                            );
                            return Some(report);
                        }
                    }
                }
                continue;
            }
            if ds.is_nan() {
                return None;
            }
            if !smallest.is_finite() {
                smallest = ds * s.min_increment;
            }
            let tangent = self.arc_tangent(model, from, to, lambda_n, &u_n, previous.as_deref());
            let (t, dlds) = match tangent {
                Ok(x) => x,
                Err(why) => {
                    report.message = format!("arc length at load fraction {lambda_n:.6}: {why}");
                    report.reached = lambda_n;
                    return Some(report);
                }
            };
            let predicted = lambda_n + ds * dlds;
            let outcome = if predicted >= 1.0 {
                Err((0, String::from("the predictor passes the target")))
            } else {
                self.arc_increment(
                    model,
                    from,
                    to,
                    change,
                    &u_n,
                    lambda_n,
                    &t,
                    dlds,
                    ds,
                    &mut report.log,
                )
            };
            let mut finish = predicted >= 1.0;
            match outcome {
                Ok((u_new, lambda, iters)) => {
                    report.iterations += iters + 1;
                    if lambda >= 1.0 {
                        finish = true;
                    } else {
                        let before =
                            self.wrinkle_states(model, &loads_at(from, to, lambda_n), &u_n);
                        let after = self.wrinkle_states(model, &loads_at(from, to, lambda), &u_new);
                        let mut accepted = (u_new, lambda, iters, "arc length");
                        if before != after && lambda > lambda_n {
                            let switched =
                                before.iter().zip(&after).filter(|(a, b)| a != b).count();
                            match self.load_increment(
                                model,
                                from,
                                to,
                                change,
                                &u_n,
                                lambda,
                                &mut report.log,
                            ) {
                                Ok((u_lc, it2)) => {
                                    report.iterations += it2;
                                    push_log(&mut report.log, format!("  {switched} wrinkle states switch: increment redone by load control in {it2} iterations"));
                                    accepted = (u_lc, lambda, it2, "load control");
                                }
                                Err((it2, why)) => {
                                    report.iterations += it2;
                                    push_log(&mut report.log, format!("  {switched} wrinkle states switch; load control failed ({why}): the arc-length point is kept"));
                                }
                            }
                        }
                        let (u_new, lambda, iters, how) = accepted;
                        report.increments += 1;
                        push_log(&mut report.log, format!("increment λ {lambda_n:.6} -> {lambda:.6} ({how}, Δs {ds:.3e} m): converged in {iters} iterations"));
                        previous = Some(self.equation_difference(&u_new, &u_n));
                        u_n = u_new;
                        lambda_n = lambda;
                        lambda_max = lambda_max.max(lambda);
                        if lambda < 0.0 && lambda_max > 0.0 {
                            report.reached = lambda_max;
                            report.message = format!("no equilibrium found at the step's target by arc length: the path passed a limit point and its load fell back below the step's start (largest load fraction reached {lambda_max:.6})");
                            return Some(report);
                        }
                        ds *= if iters <= s.target_iterations {
                            1.5
                        } else if 4 * iters > 3 * s.max_iterations {
                            0.5
                        } else {
                            1.0
                        };
                        continue;
                    }
                }
                Err((iters, why)) if !finish => {
                    report.iterations += iters;
                    report.cutbacks += 1;
                    push_log(&mut report.log, format!("increment from λ {lambda_n:.6} (arc length, Δs {ds:.3e} m): {why}; cutting back"));
                    ds *= 0.25;
                    if ds < smallest {
                        report.reached = lambda_n;
                        report.message = format!("no equilibrium found beyond load fraction {lambda_n:.6} of the step by arc length (smallest arc length failed: {why}; largest load fraction reached {lambda_max:.6})");
                        return Some(report);
                    }
                    continue;
                }
                Err(_) => {}
            }
            if finish {
                // The target lies within this increment: reach it exactly by load control.
                match self.load_increment(model, from, to, change, &u_n, 1.0, &mut report.log) {
                    Ok((u_new, iters)) => {
                        report.iterations += iters;
                        report.increments += 1;
                        push_log(&mut report.log, format!("increment λ {lambda_n:.6} -> 1 (load control to the target): converged in {iters} iterations"));
                        u_n = u_new;
                        break;
                    }
                    Err((iters, why)) => {
                        report.iterations += iters;
                        report.cutbacks += 1;
                        push_log(&mut report.log, format!("increment λ {lambda_n:.6} -> 1 (load control to the target): {why}; shorter arc"));
                        ds *= 0.25;
                        if ds < smallest {
                            report.reached = lambda_n;
                            report.message = format!("no equilibrium found beyond load fraction {lambda_n:.6} of the step by arc length ({why})");
                            return Some(report);
                        }
                    }
                }
            }
        }
        *u = u_n;
        report.outcome = Outcome::Converged;
        report.reached = 1.0;
        Some(report)
    }
}
