//! Arc-length path following (the normal-plane variant of Riks and Crisfield): the load factor
//! λ of the step becomes one more unknown, held by one more equation on the displacements, so
//! the path goes on through limit points where load control stops. This module holds the path
//! logic only (predictor, step size, sign, fallbacks); the corrector is the one Newton loop
//! (`newton.rs`) with the arc-length row added to its bordered system.
//!
//! ```text
//! loads      load(λ) = from + λ (to − from);  G(z, λ) = (R, r_slip, h_volume) = 0
//!            q = −∂R/∂λ = R(u, from) − R(u, to)     (R is affine in the loads; follower
//!                                                   pressures make q depend on u)
//!            ∂h_volume/∂λ = −k_V (ΔV_to − ΔV_from)  (a moving volume or gas input)
//! predictor  J dz = −∂G/∂λ at the converged (z_n, λ_n), J the bordered tangent of the loop
//!            (slip and volume rows eliminated by Schur, `slip.rs`); v the displacement part:
//!            t = ±v/|v|,  Δλ = ±Δs/|v|; the volume pressures are predicted along dz, the
//!            slips are not (the loop's stick anchors are the last converged slips)
//!            sign: + at the start of a step (towards the target), then the sign that keeps
//!            t · (u_n − u_{n−1}) > 0 (the path goes on in the direction it came from)
//! corrector  the one Newton loop with one more unknown λ and one more row
//!            h = t · (u − u_n) − Δs = 0 (the plane normal to t at distance Δs: Riks's fixed
//!            normal plane), its column ∂R/∂λ = −q (and ∂h_volume/∂λ in the volume rows),
//!            eliminated with the slip and volume rows on the one LDLT of K; active set,
//!            damping, relaxation and re-check as under load control; the line search's merit
//!            is the residual ‖(R, r)‖ (the loads move with λ inside the step, so no
//!            potential at fixed loads is a merit; the arc row is linear and falls as
//!            (1 − α) h along any step); converged when the load-control test holds and
//!            |h| <= tolerance · Δs
//! step size  Δs grows 1.5x after an increment within the target iterations, halves after one
//!            above 3/4 of the limit, is cut by 4 on failure
//! ```
//! The metric is the Euclidean norm of the free displacements divided by √n (n free DOFs), so
//! `Settings::arc_length` is an RMS displacement in metres whatever the mesh; slips and volume
//! pressures are not in it.
//!
//! Prescribed displacements that the step moves follow λ like the loads: they are set from
//! load(λ) at every iteration and trial point, and q gains −K_fp du_p/dλ (their coupling into
//! the free equations), so a displacement-driven path is followed through a limit point too.
//! (A slip row's own dependence on a prescribed sleeve node moving with λ is left out of the
//! border: the corrector then converges more slowly, not elsewhere.)
//!
//! Fallbacks to load control: a step whose loads do not change is load-controlled as a whole;
//! every increment across which a membrane's wrinkle state (taut/wrinkled/slack) or a sleeve
//! point's stick/slip/merged state switches while the load rises is solved again by load
//! control to the load factor the arc-length point reached (state switches make the path
//! non-smooth, and the normal plane can then cut it at another state's equilibrium); an
//! increment whose corrector fails while the predictor raises the load is tried once by load
//! control to the predictor's λ before Δs is cut (sleeve points on a straight cable slide at
//! zero load, where the normal plane cuts no equilibrium). A step
//! ends where the load reaches its target: the last increment is load-controlled to λ = 1
//! exactly. A step whose target lies beyond a limit load therefore fails (the load factor
//! turns back past the limit): the message names the largest load factor reached.
//!
//! # References
//! Riks 1979, Int. J. Solids Struct. 15:529–551 (the normal plane); Crisfield 1991, vol. 1,
//! §9.3–9.4 (arc length, bordered systems by two solves, the sign of the predictor).

use super::assemble::NONE;
use super::core::Solver;
use super::loads::{load_change, loads_at};
use super::path::Attempt;
use super::report::{push_log, StepReport};
use super::rows::{ArcRow, Increment};
use super::settings::Settings;
use super::slip::slip_rows;
use crate::error::{Breakdown, Error};
use crate::model::sleeve::Contact;
use crate::model::state::History;
use crate::model::Model;

/// A converged load-controlled increment: displacements, stick/slip states, iterations.
type Converged = (Vec<f64>, Vec<Contact>, usize);

/// Arc length cannot start this step (its first increment moved nothing): load control for the
/// whole step instead.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LoadControlInstead;

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

/// The last converged point of a step traced by arc length, with what the next increment needs
/// from the path so far.
struct Committed {
    u: Vec<f64>,
    lambda: f64,
    /// The history there (stick/slip states of the sleeve points, plastic strains).
    history: History,
    /// The step to it on the equations (None before the first increment): the path's sense.
    previous: Option<Vec<f64>>,
    /// The largest load fraction any converged point of the step reached.
    lambda_max: f64,
}

/// Why arc length does not apply to a step (None: it does).
fn not_applicable(_model: &Model, from: &[f64], to: &[f64]) -> Option<&'static str> {
    if from == to {
        return Some("the loads do not change");
    }
    None
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

impl Solver {
    /// Why a step `from` → `to` under `solver.path: "arc_length"` is load-controlled as a
    /// whole (unchanged loads); None when arc length follows it.
    pub fn arc_length_fallback(model: &Model, from: &[f64], to: &[f64]) -> Option<&'static str> {
        not_applicable(model, from, to)
    }

    /// The path's tangent at the converged point: dz/dλ from the bordered tangent (slip and
    /// volume rows included, the stick/slip states `contact`), J dz = −∂G/∂λ. Returns the unit
    /// tangent t of its displacement part (on the equations), dλ per unit arc length (in the
    /// √n-scaled metric) with the sign that continues `previous` (or raises the load when
    /// there is none), and the rates of the slips and volume pressures per unit λ.
    #[allow(clippy::too_many_arguments)]
    fn arc_tangent(
        &mut self,
        model: &Model,
        from: &[f64],
        to: &[f64],
        lambda: f64,
        u: &[f64],
        contact: &[Contact],
        previous: Option<&[f64]>,
    ) -> Result<(Vec<f64>, f64, Vec<f64>), Error> {
        self.frozen = None;
        // The artificial prestress (tangent only, where an element lacks tension) keeps the
        // predictor of a stress-free start regular; it does not change the equilibrium.
        self.prestress_factor = 1.0;
        let loads = loads_at(from, to, lambda);
        self.assemble_at(model, &loads, u);
        let n3 = model.dof_count();
        let mut rows = slip_rows(model, &self.pattern.eq, u, &u[n3..], contact);
        rows.extend(super::volume::rows(model, &self.pattern.eq, u, &loads));
        // Right-hand side −∂G/∂λ: q on the equations, the rows' −∂r/∂λ (the slip rows do not
        // depend on λ; a volume row's target moves with its input).
        for row in rows.iter_mut() {
            row.r = 0.0;
        }
        let rates = super::volume::load_rates(model, from, to);
        for (row, rate) in rows[model.slips.len()..].iter_mut().zip(rates) {
            row.r = rate;
        }
        let q = self.load_direction(model, from, to, lambda, u);
        let minus_q: Vec<f64> = q.iter().map(|v| -v).collect();
        let (v, w) = self.solve_bordered(model, u, &rows, 0.0, None, minus_q)?;
        let norm = dot(&v, &v).sqrt();
        if !(norm.is_finite() && norm > 0.0) {
            return Err(Breakdown::NonFinite("the tangent predictor").into());
        }
        let sign = match previous {
            Some(p) if dot(&v, p) < 0.0 => -1.0,
            _ => 1.0,
        };
        let scale = (self.pattern.n as f64).sqrt();
        let t: Vec<f64> = v.iter().map(|x| sign * x / norm).collect();
        Ok((t, sign * scale / norm, w))
    }

    /// One arc-length increment of length `ds` (RMS metres) from the converged (u_n, λ_n)
    /// along the unit tangent `t` (dλ/ds `dlds`, `w` the slips' and pressures' dz/dλ): the one
    /// Newton loop with the arc-length row. Ok((u, λ, iterations)); `contact` in: the
    /// converged stick/slip states, out: the increment's.
    #[allow(clippy::too_many_arguments)]
    fn arc_increment(
        &mut self,
        model: &Model,
        (from, to, change): (&[f64], &[f64], f64),
        u_n: &[f64],
        lambda_n: f64,
        (t, dlds, w): (&[f64], f64, &[f64]),
        ds: f64,
        contact: &mut Vec<Contact>,
        log: &mut Vec<String>,
    ) -> Result<(Vec<f64>, f64, usize), (usize, String)> {
        let scale = (self.pattern.n as f64).sqrt();
        let length = ds * scale;
        let dl = ds * dlds;
        let mut u = u_n.to_vec();
        for (d, &e) in self.pattern.eq.iter().enumerate() {
            if e != NONE {
                u[d] += length * t[e];
            }
        }
        // The volume pressures are predicted along the tangent; the slips are not (the loop
        // takes the last converged slips as the stick anchors).
        let (n3, m) = (model.dof_count(), model.slips.len());
        for (j, rate) in w.iter().enumerate().skip(m) {
            u[n3 + j] += dl * rate;
        }
        let mut arc = ArcRow {
            from,
            to,
            t,
            u_n,
            length,
            lambda: lambda_n + dl,
        };
        let inc = Increment {
            loads: from,
            change,
            moved: true,
        };
        let iterations = self.newton(model, &inc, &mut u, contact, Some(&mut arc), log)?;
        Ok((u, arc.lambda, iterations))
    }

    /// One load-controlled increment to λ from the last converged point of the path (the
    /// fallback): the new displacements, stick/slip states and iterations.
    fn load_increment(
        &mut self,
        model: &Model,
        (from, to, change): (&[f64], &[f64], f64),
        at: &Committed,
        lambda: f64,
        log: &mut Vec<String>,
    ) -> Result<Converged, (usize, String)> {
        let loads = loads_at(from, to, lambda);
        let mut trial = at.u.clone();
        let mut contact = at.history.contact.clone();
        // Moves the prescribed displacements to λ (and predicts the free DOFs) as load
        // control does.
        let predicted = self.predict(model, &loads, &mut trial);
        let increment = Increment {
            loads: &loads,
            change,
            moved: true,
        };
        self.newton(model, &increment, &mut trial, &mut contact, None, log)
            .map(|i| (trial, contact, i + predicted))
            .map_err(|(i, why)| (i + predicted, why))
    }

    /// Make (u, λ, contact) the path's last converged point (the history advanced to it);
    /// `previous` becomes the step to it.
    fn commit(
        &self,
        model: &Model,
        at: &mut Committed,
        u: Vec<f64>,
        lambda: f64,
        contact: Vec<Contact>,
    ) {
        at.previous = Some(self.equation_difference(&u, &at.u));
        at.history = at.history.advanced(model, &u, contact);
        at.u = u;
        at.lambda = lambda;
        at.lambda_max = at.lambda_max.max(lambda);
    }

    /// Trace the path of the step `from` → `to` from the equilibrium `u` (at `from`) by
    /// `count` arc-length increments of fixed length `ds` (RMS metres), without stopping at the
    /// target load and without the load-control fallback: the converged points in order. For
    /// verification and studies of a whole path (a limit point and what lies past it). Sleeve
    /// points start from their default states, plastic strains from none.
    pub fn trace_arc_length(
        &mut self,
        model: &Model,
        from: &[f64],
        to: &[f64],
        u: &[f64],
        ds: f64,
        count: usize,
    ) -> Result<Vec<PathPoint>, Error> {
        if let Some(why) = not_applicable(model, from, to) {
            return Err(Error::PathStopped(format!(
                "arc length does not apply: {why}"
            )));
        }
        let change = load_change(model, from, to);
        let mut log = Vec::new();
        let (mut u_n, mut lambda_n) = (u.to_vec(), 0.0);
        let mut contact = vec![Contact::default(); model.slips.len()];
        let mut history = History::start(model);
        history.install(model);
        let mut previous: Option<Vec<f64>> = None;
        let mut points = Vec::new();
        for k in 0..count {
            let (t, dlds, w) = self.arc_tangent(
                model,
                from,
                to,
                lambda_n,
                &u_n,
                &contact,
                previous.as_deref(),
            )?;
            let (u, lambda, iterations) = self
                .arc_increment(
                    model,
                    (from, to, change),
                    &u_n,
                    lambda_n,
                    (&t, dlds, &w),
                    ds,
                    &mut contact,
                    &mut log,
                )
                .map_err(|(_, why)| {
                    Error::PathStopped(format!("increment {k}: {why}\n{}", log.join("\n")))
                })?;
            previous = Some(self.equation_difference(&u, &u_n));
            history = history.advanced(model, &u, contact.clone());
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
}

/// Arc length of one step in progress (module docs): the path's last converged point, the
/// arc length Δs and the step's bounds.
pub struct ArcPath {
    from: Vec<f64>,
    to: Vec<f64>,
    change: f64,
    at: Committed,
    /// Δs (RMS metres); 0 before the first, load-controlled, increment sets it; NaN when that
    /// increment moved nothing (load control for the whole step).
    ds: f64,
    /// The first increment's load fraction while Δs is unknown.
    first_dl: f64,
    /// The smallest Δs before the step fails.
    smallest: f64,
    /// The step's target was reached.
    done: bool,
    /// (iterations, increments) of the report when the current attempt began.
    before: (usize, usize),
}

impl ArcPath {
    /// The step `from` → `to` from the equilibrium `u` with the history `history` (installed
    /// in the model: `state.rs`);
    /// None where arc length does not apply (the loads do not change): load control then.
    pub fn begin(
        model: &Model,
        settings: &Settings,
        from: &[f64],
        to: &[f64],
        u: &[f64],
        history: History,
    ) -> Option<ArcPath> {
        if not_applicable(model, from, to).is_some() {
            return None;
        }
        history.install(model);
        Some(ArcPath {
            from: from.to_vec(),
            to: to.to_vec(),
            change: load_change(model, from, to),
            at: Committed {
                u: u.to_vec(),
                lambda: 0.0,
                history,
                previous: None,
                lambda_max: 0.0,
            },
            ds: settings.arc_length,
            first_dl: settings.initial_increment,
            smallest: f64::INFINITY,
            done: false,
            before: (0, 0),
        })
    }

    /// The last converged point: displacements, load fraction and history.
    pub fn converged(&self) -> (&[f64], f64, &History) {
        (&self.at.u, self.at.lambda, &self.at.history)
    }

    /// Take `u` (with the history of the last converged point) as the step's answer at its
    /// target: the reference configuration of a step to zero loads (stepper.rs,
    /// `reference_answer`). The path is done.
    pub fn take_answer(&mut self, u: Vec<f64>) {
        self.at.u = u;
        self.at.lambda = 1.0;
        self.at.lambda_max = self.at.lambda_max.max(1.0);
        self.at.previous = None;
        self.done = true;
    }

    /// The largest load fraction any converged point of the path reached (beyond a limit
    /// point the path comes back below it).
    pub fn largest_lambda(&self) -> f64 {
        self.at.lambda_max
    }

    /// One attempt of the path (an arc-length increment, or the load-controlled increment that
    /// stands for one: the first, where the path tangent is undefined, after a state switch or
    /// a failed corrector, and the last to the target). Ok(None) once the target is reached;
    /// Err(LoadControlInstead) when the step must be load-controlled as a whole instead (the
    /// first increment moved nothing, or failed down to the smallest increment).
    pub fn advance(
        &mut self,
        solver: &mut Solver,
        model: &Model,
        report: &mut StepReport,
    ) -> Result<Option<Attempt>, LoadControlInstead> {
        if self.done {
            return Ok(None);
        }
        self.before = (report.iterations, report.increments);
        let s = solver.settings.clone();
        let (lambda_n, lambda_max) = (self.at.lambda, self.at.lambda_max);
        if report.increments + report.cutbacks >= s.max_increments {
            report.reached = lambda_max;
            report.message = format!(
                "no equilibrium found at the step's target by arc length ({} increments used, now at load fraction {lambda_n:.6}; largest load fraction reached {lambda_max:.6})",
                s.max_increments
            );
            return Ok(Some(self.failed(report)));
        }
        if self.ds <= 0.0 {
            return Ok(Some(self.first_increment(solver, model, &s, report)));
        }
        if self.ds.is_nan() {
            return Err(LoadControlInstead);
        }
        if !self.smallest.is_finite() {
            self.smallest = self.ds * s.min_increment;
        }
        let at = &self.at;
        let tangent = solver.arc_tangent(
            model,
            &self.from,
            &self.to,
            lambda_n,
            &at.u,
            &at.history.contact,
            at.previous.as_deref(),
        );
        let (t, dlds, w) = match tangent {
            Ok(x) => x,
            Err(why) => {
                let why = why.to_string();
                return Ok(Some(self.no_tangent(solver, model, &s, report, why)));
            }
        };
        let predicted = lambda_n + self.ds * dlds;
        let mut contact = self.at.history.contact.clone();
        let outcome = if predicted >= 1.0 {
            Err((0, String::from("the predictor passes the target")))
        } else {
            solver.arc_increment(
                model,
                (&self.from, &self.to, self.change),
                &self.at.u,
                lambda_n,
                (&t, dlds, &w),
                self.ds,
                &mut contact,
                &mut report.log,
            )
        };
        match outcome {
            Ok((u_new, lambda, iters)) if lambda < 1.0 => {
                report.iterations += iters + 1;
                let point = (u_new, lambda, iters, contact);
                Ok(Some(self.corrected(solver, model, &s, report, point)))
            }
            Ok((_, _, iters)) => {
                // The corrector passed the target: reach it exactly by load control.
                report.iterations += iters + 1;
                Ok(Some(self.reach_target(solver, model, report)))
            }
            Err((iters, why)) if predicted < 1.0 => {
                report.iterations += iters;
                Ok(Some(
                    self.corrector_failed(solver, model, report, predicted, why),
                ))
            }
            Err(_) => Ok(Some(self.reach_target(solver, model, report))),
        }
    }

    /// The step fails here (the report says why).
    fn failed(&self, report: &StepReport) -> Attempt {
        Attempt::Rejected {
            lambda: self.at.lambda,
            iterations: report.iterations - self.before.0,
            failed: true,
        }
    }

    /// What the attempt did: accepted when it added a converged increment.
    fn progress(&self, report: &StepReport) -> Attempt {
        let iterations = report.iterations - self.before.0;
        if report.increments > self.before.1 {
            Attempt::Accepted {
                lambda: self.at.lambda,
                iterations,
            }
        } else {
            Attempt::Rejected {
                lambda: self.at.lambda,
                iterations,
                failed: false,
            }
        }
    }

    /// No arc length given: the first increment is load-controlled and sets Δs.
    fn first_increment(
        &mut self,
        solver: &mut Solver,
        model: &Model,
        s: &Settings,
        report: &mut StepReport,
    ) -> Attempt {
        let target = self.first_dl.min(1.0);
        let step = (&self.from[..], &self.to[..], self.change);
        match solver.load_increment(model, step, &self.at, target, &mut report.log) {
            Ok((u_new, contact, iters)) => {
                report.iterations += iters;
                report.increments += 1;
                solver.commit(model, &mut self.at, u_new, target, contact);
                let d = self.at.previous.as_deref().unwrap_or_default();
                self.ds = (dot(d, d) / solver.pattern.n as f64).sqrt();
                let ds = self.ds;
                push_log(&mut report.log, format!("increment λ 0 -> {target:.6} (load control): converged in {iters} iterations; arc length {ds:.3e} m"));
                self.smallest = self.ds * s.min_increment;
                if target >= 1.0 {
                    self.done = true;
                } else if self.ds <= 0.0 {
                    // Nothing moved: load control for the rest.
                    self.ds = f64::NAN;
                }
            }
            Err((iters, why)) => {
                report.iterations += iters;
                report.cutbacks += 1;
                self.first_dl *= 0.25;
                if self.first_dl < s.min_increment {
                    // The path cannot start: its first increment is load-controlled, and load
                    // control alone failed down to the smallest increment. The whole step goes
                    // by load control instead, whose failed increments have the continuations
                    // (prestress, overshoot, proximal: path.rs) this plain increment lacks; from
                    // the step's start no limit point has been passed, so no branch is left.
                    push_log(
                        &mut report.log,
                        format!("arc length: the first (load-controlled) increment failed down to solver.min_increment ({why}); the whole step by load control instead"),
                    );
                    self.ds = f64::NAN;
                }
            }
        }
        self.progress(report)
    }

    /// No path tangent at the last converged point (a singular bordered tangent: sleeve
    /// points free to slide along a straight cable at zero load): the next increment is
    /// load-controlled, from the remaining load down to `min_increment` of it.
    fn no_tangent(
        &mut self,
        solver: &mut Solver,
        model: &Model,
        s: &Settings,
        report: &mut StepReport,
        why: String,
    ) -> Attempt {
        let lambda_n = self.at.lambda;
        let step = (&self.from[..], &self.to[..], self.change);
        let mut fraction = s.initial_increment.min(1.0);
        while fraction >= s.min_increment {
            let target = (lambda_n + fraction * (1.0 - lambda_n)).min(1.0);
            match solver.load_increment(model, step, &self.at, target, &mut report.log) {
                Ok((u_lc, redone, it2)) => {
                    report.iterations += it2;
                    report.increments += 1;
                    push_log(
                        &mut report.log,
                        format!("  arc length: no path tangent at λ {lambda_n:.6} ({why})"),
                    );
                    push_log(&mut report.log, format!("increment λ {lambda_n:.6} -> {target:.6} (load control where the path tangent is not defined): converged in {it2} iterations"));
                    solver.commit(model, &mut self.at, u_lc, target, redone);
                    self.done = self.at.lambda >= 1.0;
                    return self.progress(report);
                }
                Err((it2, _)) => {
                    report.iterations += it2;
                    report.cutbacks += 1;
                    fraction *= 0.25;
                }
            }
        }
        report.message = format!(
            "arc length at load fraction {lambda_n:.6}: {why}; load control from there failed too"
        );
        report.reached = lambda_n;
        self.failed(report)
    }

    /// A converged arc-length point short of the target: redone by load control where a
    /// wrinkle or stick/slip state switched while the load rose, then committed; Δs grows
    /// 1.5x within the target iterations and halves above 3/4 of the limit.
    fn corrected(
        &mut self,
        solver: &mut Solver,
        model: &Model,
        s: &Settings,
        report: &mut StepReport,
        (u_new, lambda, iters, contact): (Vec<f64>, f64, usize, Vec<Contact>),
    ) -> Attempt {
        let (from, to) = (&self.from[..], &self.to[..]);
        let lambda_n = self.at.lambda;
        let ds = self.ds;
        let before = solver.wrinkle_states(model, &loads_at(from, to, lambda_n), &self.at.u);
        let after = solver.wrinkle_states(model, &loads_at(from, to, lambda), &u_new);
        let wrinkles = before.iter().zip(&after).filter(|(a, b)| a != b).count();
        let sleeves = (self.at.history.contact.iter())
            .zip(&contact)
            .filter(|(a, b)| a != b)
            .count();
        let mut accepted = (u_new, lambda, iters, "arc length", contact);
        if (wrinkles > 0 || sleeves > 0) && lambda > lambda_n {
            let what = format!("{wrinkles} wrinkle states and {sleeves} stick/slip states switch");
            let step = (from, to, self.change);
            match solver.load_increment(model, step, &self.at, lambda, &mut report.log) {
                Ok((u_lc, redone, it2)) => {
                    report.iterations += it2;
                    push_log(
                        &mut report.log,
                        format!("  {what}: increment redone by load control in {it2} iterations"),
                    );
                    accepted = (u_lc, lambda, it2, "load control", redone);
                }
                Err((it2, why)) => {
                    report.iterations += it2;
                    push_log(
                        &mut report.log,
                        format!(
                            "  {what}; load control failed ({why}): the arc-length point is kept"
                        ),
                    );
                }
            }
        }
        let (u_new, lambda, iters, how, contact) = accepted;
        report.increments += 1;
        push_log(&mut report.log, format!("increment λ {lambda_n:.6} -> {lambda:.6} ({how}, Δs {ds:.3e} m): converged in {iters} iterations"));
        solver.commit(model, &mut self.at, u_new, lambda, contact);
        if lambda < 0.0 && self.at.lambda_max > 0.0 {
            let lambda_max = self.at.lambda_max;
            report.reached = lambda_max;
            report.message = format!("no equilibrium found at the step's target by arc length: the path passed a limit point and its load fell back below the step's start (largest load fraction reached {lambda_max:.6})");
            return self.failed(report);
        }
        self.ds *= if iters <= s.target_iterations {
            1.5
        } else if 4 * iters > 3 * s.max_iterations {
            0.5
        } else {
            1.0
        };
        self.progress(report)
    }

    /// A corrector that failed short of the target. While the load rises it is retried once by
    /// load control to the predictor's λ (the path can be non-smooth inside the increment: a
    /// state switch, or sleeve points that slide along a straight cable at zero load, where
    /// the normal plane cuts no equilibrium); otherwise Δs is cut by 4.
    fn corrector_failed(
        &mut self,
        solver: &mut Solver,
        model: &Model,
        report: &mut StepReport,
        predicted: f64,
        why: String,
    ) -> Attempt {
        let (lambda_n, lambda_max, ds) = (self.at.lambda, self.at.lambda_max, self.ds);
        if predicted > lambda_n {
            let step = (&self.from[..], &self.to[..], self.change);
            if let Ok((u_lc, redone, it2)) =
                solver.load_increment(model, step, &self.at, predicted, &mut report.log)
            {
                report.iterations += it2;
                report.increments += 1;
                push_log(&mut report.log, format!("  arc length: {why}"));
                push_log(&mut report.log, format!("increment λ {lambda_n:.6} -> {predicted:.6} (load control after the arc-length corrector failed, Δs {ds:.3e} m): converged in {it2} iterations"));
                solver.commit(model, &mut self.at, u_lc, predicted, redone);
                return self.progress(report);
            }
        }
        report.cutbacks += 1;
        push_log(
            &mut report.log,
            format!(
                "increment from λ {lambda_n:.6} (arc length, Δs {ds:.3e} m): {why}; cutting back"
            ),
        );
        self.ds *= 0.25;
        if self.ds < self.smallest {
            report.reached = lambda_n;
            report.message = format!("no equilibrium found beyond load fraction {lambda_n:.6} of the step by arc length (smallest arc length failed: {why}; largest load fraction reached {lambda_max:.6})");
            return self.failed(report);
        }
        self.progress(report)
    }

    /// The target lies within this increment: reach it exactly by load control (a shorter arc
    /// when that fails).
    fn reach_target(
        &mut self,
        solver: &mut Solver,
        model: &Model,
        report: &mut StepReport,
    ) -> Attempt {
        let lambda_n = self.at.lambda;
        let step = (&self.from[..], &self.to[..], self.change);
        match solver.load_increment(model, step, &self.at, 1.0, &mut report.log) {
            Ok((u_new, contact, iters)) => {
                report.iterations += iters;
                report.increments += 1;
                push_log(&mut report.log, format!("increment λ {lambda_n:.6} -> 1 (load control to the target): converged in {iters} iterations"));
                solver.commit(model, &mut self.at, u_new, 1.0, contact);
                self.done = true;
            }
            Err((iters, why)) => {
                report.iterations += iters;
                report.cutbacks += 1;
                push_log(&mut report.log, format!("increment λ {lambda_n:.6} -> 1 (load control to the target): {why}; shorter arc"));
                self.ds *= 0.25;
                if self.ds < self.smallest {
                    report.reached = lambda_n;
                    report.message = format!("no equilibrium found beyond load fraction {lambda_n:.6} of the step by arc length ({why})");
                    return self.failed(report);
                }
            }
        }
        self.progress(report)
    }
}
