//! Time integration: generalized-α (Chung & Hulbert 1993) in the one Newton loop.
//!
//! A step of a scene with `dynamics.time_integration` advances physical time by its length h,
//! the loads going linearly from the step's start values to its end values over it, in
//! sub-steps Δt (h / ceil(h / max_time_step), cut by 4 on failure and grown back). Each
//! sub-step n → n+1 solves for u_{n+1}
//!
//! ```text
//! M a_{n+1-αm} + C v_{n+1-αf} + (1-αf) R(u_{n+1}, t_{n+1}) + αf R(u_n, t_n) = 0
//! a_{n+1} = (u_{n+1} - u_n - Δt v_n)/(β Δt²) - (1-2β)/(2β) a_n       (Newmark)
//! v_{n+1} = v_n + Δt ((1-γ) a_n + γ a_{n+1})
//! x_{n+1-α} = (1-α) x_{n+1} + α x_n
//! αm = (2ρ∞-1)/(ρ∞+1), αf = ρ∞/(ρ∞+1), γ = 1/2 - αm + αf, β = (1 - αm + αf)²/4
//! ```
//! R = f_int − f_ext the static residual of the System boundary (system.rs). Divided by
//! 1 − αf, the equation is the static one at u_{n+1} plus a force g affine in δ = u_{n+1} − u_n,
//! g = b + K_d δ, with K_d = [(1−αm)/(β Δt²) M + (1−αf) γ/(β Δt) C]/(1−αf) symmetric: so the
//! Newton loop, its line search (the potential gains ½ δᵀK_d δ + bᵀδ), its active set and its
//! convergence test run unchanged on R + g ([`Inertia`], added where the System assembles).
//! The history (stick/slip, plastic strain, wrinkle states) is evaluated at u_{n+1}, as in
//! statics. ρ∞ = 1 is the trapezoidal rule (αm = αf = ½, β = ¼, γ = ½): no numerical
//! dissipation, energy conserved in the linear regime; second order for every ρ∞.
//!
//! M is the scene's mass matrix (`mass.rs`, the air's added mass included), C = α M + β K₀ +
//! C_air: Rayleigh damping with K₀ the tangent of the reference configuration (undeformed,
//! the prestress in, no load) and the air's linear damping along the reference normals
//! (`Solver::air_damping`). Both live
//! on the tangent's pattern over the equations: held DOFs carry no inertia, and a moving
//! support drives its neighbours through their stiffness only (with the lumped mass this is
//! exact; with the consistent mass the coupling M_fp a_p of a support's acceleration is left
//! out). Slips, volume pressures and tie multipliers are massless: their rows hold at t_{n+1}.
//!
//! The state a step starts from is (u_n, v_n, a_n) and the history; R(u_n, t_n) is assembled
//! once at the step's start and carried from sub-step to sub-step.

use super::assemble::{self, Membranes, NONE};
use super::core::Solver;
use super::inertia::{symmetric_product, Carry, Inertia, Matrices};
use super::loads::{load_change, loads_at, prescribe};
use super::path::Attempt;
use super::report::{push_log, StepReport};
use super::rows::Increment;
use crate::model::state::History;
use crate::model::Model;
use crate::scene::MassKind;

/// The time integration's settings (the scene's `dynamics` section).
#[derive(Clone, Debug, PartialEq)]
pub struct Integration {
    /// Spectral radius at infinite frequency, 0 to 1.
    pub rho_inf: f64,
    /// Largest sub-step (s); None: one sub-step per step.
    pub max_time_step: Option<f64>,
    pub mass: MassKind,
    /// Rayleigh damping C = alpha M + beta K₀.
    pub rayleigh_alpha: f64,
    pub rayleigh_beta: f64,
}

/// Generalized-α's parameters of a spectral radius ρ∞ (module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Alpha {
    pub am: f64,
    pub af: f64,
    pub beta: f64,
    pub gamma: f64,
}

impl Alpha {
    pub fn new(rho_inf: f64) -> Alpha {
        let r = rho_inf.clamp(0.0, 1.0);
        let am = (2.0 * r - 1.0) / (r + 1.0);
        let af = r / (r + 1.0);
        let gamma = 0.5 - am + af;
        let beta = 0.25 * (1.0 - am + af).powi(2);
        Alpha {
            am,
            af,
            beta,
            gamma,
        }
    }

    /// a_{n+1} and v_{n+1} of one DOF from its δ = u_{n+1} − u_n (Newmark).
    pub fn update(&self, dt: f64, delta: f64, v: f64, a: f64) -> (f64, f64) {
        let a1 = delta / (self.beta * dt * dt)
            - v / (self.beta * dt)
            - (1.0 - 2.0 * self.beta) / (2.0 * self.beta) * a;
        let v1 = v + dt * ((1.0 - self.gamma) * a + self.gamma * a1);
        (v1, a1)
    }
}

impl Solver {
    /// M and C of the time integration (built at the first dynamic step, then kept in
    /// `self.dynamic_matrices`: both depend on reference quantities only).
    fn dynamic_matrices(&mut self, model: &Model, integration: &Integration) {
        if self.dynamic_matrices.is_some() {
            return;
        }
        let m = self
            .mass(model, integration.mass)
            .map(|m| m.values().to_vec())
            .unwrap_or_default();
        let air = self.air_damping(model, integration.mass);
        let c =
            if integration.rayleigh_alpha > 0.0 || integration.rayleigh_beta > 0.0 || air.is_some()
            {
                let k0 = if integration.rayleigh_beta > 0.0 {
                    self.reference_tangent(model)
                } else {
                    vec![0.0; m.len()]
                };
                let mut c: Vec<f64> = m
                    .iter()
                    .zip(&k0)
                    .map(|(m, k)| integration.rayleigh_alpha * m + integration.rayleigh_beta * k)
                    .collect();
                if let Some(air) = air {
                    c.iter_mut().zip(&air).for_each(|(c, a)| *c += a);
                }
                c
            } else {
                Vec::new()
            };
        let a = self.linear.matrix();
        let symbolic = a.symbolic();
        let matrices = Matrices {
            m,
            c,
            col_ptr: symbolic.col_ptr().to_vec(),
            row_idx: symbolic.row_idx().to_vec(),
            carry: Carry::default(),
        };
        self.dynamic_matrices = Some(matrices);
    }

    /// K₀: the tangent at the reference configuration with no load (wrinkle states from the
    /// law), on the tangent's pattern.
    fn reference_tangent(&mut self, model: &Model) -> Vec<f64> {
        let u = vec![0.0; model.unknown_count()];
        let loads = vec![0.0; model.loads.len()];
        let mut r = vec![0.0; model.dof_count()];
        assemble::assemble_with(
            model,
            &self.pattern,
            &u,
            &loads,
            &mut r,
            Some(self.linear.values_mut()),
            Membranes::default(),
        );
        self.linear.values().to_vec()
    }

    /// The static residual R(u, loads) on the equations (law's wrinkle states). The last time
    /// sub-step's trial point's (`Carry::residual`) where `u` and `loads` are that point's bit
    /// for bit and nothing else enters R (no plastic history, no prestress continuation's
    /// pre-strain; the trial had no frozen states and no sleeves): the same assembly, done
    /// once.
    fn static_residual(&mut self, model: &Model, u: &[f64], loads: &[f64]) -> Vec<f64> {
        let carried = self
            .dynamic_matrices
            .as_mut()
            .and_then(|m| m.carry.residual.take());
        if let Some(t) = carried {
            let same = t.u[..] == u[..] && t.loads[..] == loads[..] && t.r.len() == self.pattern.n;
            if same && self.pre_strain == 0.0 && model.plastic_len() == 0 {
                return t.r;
            }
        }
        let held = self.probe_states.take();
        let r = self.residual(model, u, loads);
        self.probe_states = held;
        let mut out = vec![0.0; self.pattern.n];
        for (d, &e) in self.pattern.eq.iter().enumerate() {
            if e != NONE {
                out[e] = r[d];
            }
        }
        out
    }

    /// ½ vᵀ M v over the free DOFs (`velocity` per DOF, model order) with the mass matrix of
    /// `kind` (built at the first call, then kept).
    pub fn kinetic_energy(&mut self, model: &Model, kind: MassKind, velocity: &[f64]) -> f64 {
        if velocity.iter().all(|v| *v == 0.0) {
            return 0.0;
        }
        if self.kinetic_mass.is_none() {
            self.kinetic_mass = Some(
                self.mass(model, kind)
                    .map(|m| m.values().to_vec())
                    .unwrap_or_default(),
            );
        }
        let m = self.kinetic_mass.as_deref().unwrap_or_default();
        let n = self.pattern.n;
        let mut v = vec![0.0; n];
        for (d, &e) in self.pattern.eq.iter().enumerate() {
            if e != NONE {
                v[e] = velocity.get(d).copied().unwrap_or(0.0);
            }
        }
        if m.len() != self.linear.values().len() {
            return 0.0;
        }
        let mut mv = vec![0.0; n];
        let a = self.linear.matrix();
        let symbolic = a.symbolic();
        symmetric_product(symbolic.col_ptr(), symbolic.row_idx(), m, &v, &mut mv);
        0.5 * v.iter().zip(&mv).map(|(a, b)| a * b).sum::<f64>()
    }

    /// g of the current sub-step into the last assembly's residual (and K_d into the tangent,
    /// the force magnitudes into the convergence test's), when a sub-step is being solved;
    /// returns the potential to add (0 otherwise).
    pub(super) fn add_inertia(&mut self, u: &[f64], tangent: bool, magnitude: bool) -> f64 {
        let Some(inertia) = self.inertia.as_mut() else {
            return 0.0;
        };
        let values = if tangent {
            Some(self.linear.values_mut())
        } else {
            None
        };
        let m = if magnitude {
            Some(&mut self.magnitude[..])
        } else {
            None
        };
        inertia.apply(&self.pattern.eq, u, &mut self.residual, values, m)
    }

    /// K_d = [(1−αm)/(β Δt²) M + (1−αf) γ/(β Δt) C]/(1−αf) of a sub-step of length `dt`
    /// (module docs) on the tangent's pattern (the values over the equations, as
    /// `linear.values()` holds them): the sub-step's equation R + g = 0 changes with its end
    /// state u_{n+1} by J + K_d, J the static tangent. The derivatives of a time step add it to
    /// the true tangent (`engine/derivatives.rs`). Builds M and C if no step has yet.
    pub fn step_stiffness(
        &mut self,
        model: &Model,
        integration: &Integration,
        dt: f64,
    ) -> Vec<f64> {
        self.dynamic_matrices(model, integration);
        let Alpha {
            am,
            af,
            beta,
            gamma,
        } = Alpha::new(integration.rho_inf);
        let cm = (1.0 - am) / (beta * dt * dt) / (1.0 - af);
        let cc = gamma / (beta * dt);
        let Some(matrices) = self.dynamic_matrices.as_ref() else {
            return Vec::new();
        };
        let (m, c) = (&matrices.m, &matrices.c);
        if c.is_empty() {
            m.iter().map(|m| cm * m).collect()
        } else {
            m.iter().zip(c).map(|(m, c)| cm * m + cc * c).collect()
        }
    }
}

/// One step of time integration in progress (module docs): the last converged sub-step's
/// state and the next sub-step.
pub struct DynamicPath {
    from: Vec<f64>,
    to: Vec<f64>,
    change: f64,
    moved: bool,
    /// The step's length h (s), the time reached in it (s) and the next sub-step Δt.
    duration: f64,
    time: f64,
    dt: f64,
    /// The sub-step an unhindered step takes: h / ceil(h / max_time_step).
    nominal: f64,
    alpha: Alpha,
    pub(super) converged: Vec<f64>,
    pub(super) history: History,
    pub(super) velocity: Vec<f64>,
    pub(super) acceleration: Vec<f64>,
    /// R(u_n, t_n) on the equations.
    residual_n: Vec<f64>,
    /// R(u_{n+1}, t_{n+1}) of the last converged attempt. (The inertia force's buffers are
    /// kept in the solver from sub-step to sub-step and step to step: `Carry::inertia`.)
    residual_trial: Vec<f64>,
    /// The sub-steps converged so far and the length Δt (s) of the last one (the derivatives
    /// of a step need them: `Solver::step_stiffness`).
    pub(super) substeps: (usize, f64),
    /// Every converged sub-step's end point, for the derivatives through the sub-steps
    /// (`step_sensitivity.rs`); None once there are more than [`MAX_CHAIN`] (the copies are
    /// not kept for longer steps).
    pub(super) points: Option<Vec<SubStepPoint>>,
}

/// The most sub-steps of one step whose end points are kept for its derivatives.
pub const MAX_CHAIN: usize = 64;

/// The end of one converged time sub-step: its unknowns, its loads, the fraction λ of the
/// step's load change reached there, and its length Δt (s).
#[derive(Clone, Debug, PartialEq)]
pub struct SubStepPoint {
    pub u: Vec<f64>,
    pub loads: Vec<f64>,
    pub lambda: f64,
    pub dt: f64,
}

impl DynamicPath {
    /// The step of length `duration` from `from` to `to`, from (u, v, a) and the history.
    #[allow(clippy::too_many_arguments)]
    pub fn begin(
        solver: &mut Solver,
        model: &Model,
        integration: &Integration,
        duration: f64,
        from: &[f64],
        to: &[f64],
        u: &[f64],
        motion: (&[f64], &[f64]),
        history: History,
    ) -> DynamicPath {
        history.install(model);
        let n3 = model.dof_count();
        let take = |x: &[f64]| {
            if x.len() == n3 {
                x.to_vec()
            } else {
                vec![0.0; n3]
            }
        };
        let pieces = integration
            .max_time_step
            // A step longer than a whole number of sub-steps by round-off only (a master's
            // summed times: 0.020000000000000004 for 0.02) takes that number.
            .map_or(1.0, |m| (duration / m * (1.0 - 1e-9)).ceil().max(1.0));
        let nominal = duration / pieces;
        solver.dynamic_matrices(model, integration);
        let residual_n = solver.static_residual(model, u, from);
        DynamicPath {
            from: from.to_vec(),
            to: to.to_vec(),
            change: load_change(model, from, to),
            moved: from != to,
            duration,
            time: 0.0,
            dt: nominal,
            nominal,
            alpha: Alpha::new(integration.rho_inf),
            converged: u.to_vec(),
            history,
            velocity: take(motion.0),
            acceleration: take(motion.1),
            residual_n,
            residual_trial: Vec::new(),
            substeps: (0, 0.0),
            points: Some(Vec::new()),
        }
    }

    /// The fraction of the step's time reached.
    pub fn lambda(&self) -> f64 {
        if self.time >= self.duration {
            1.0
        } else {
            self.time / self.duration
        }
    }

    /// One sub-step attempt; None once the step's time is reached.
    pub fn advance(
        &mut self,
        solver: &mut Solver,
        model: &Model,
        report: &mut StepReport,
    ) -> Option<Attempt> {
        if self.time >= self.duration {
            return None;
        }
        let s = solver.settings.clone();
        let lambda = self.lambda();
        if report.increments + report.cutbacks >= s.max_increments {
            report.reached = lambda;
            report.message = format!(
                "no dynamic equilibrium found beyond time {:.6e} s of the step ({} sub-steps used)",
                self.time, s.max_increments
            );
            return Some(Attempt::Rejected {
                lambda,
                iterations: 0,
                failed: true,
            });
        }
        let remaining = self.duration - self.time;
        let dt = if self.dt >= remaining * (1.0 - 1e-12) {
            remaining
        } else {
            self.dt
        };
        let end = if dt == remaining {
            1.0
        } else {
            (self.time + dt) / self.duration
        };
        let loads = loads_at(&self.from, &self.to, end);
        let (result, trial, contact) = self.attempt(solver, model, &loads, dt, report);
        Some(match result {
            Ok(iterations) => {
                report.iterations += iterations;
                report.increments += 1;
                push_log(
                    &mut report.log,
                    format!(
                        "time step {:.6e} -> {:.6e} s: converged in {iterations} iterations",
                        self.time,
                        self.time + dt
                    ),
                );
                if let Some(points) = self.points.as_mut() {
                    if points.len() < MAX_CHAIN {
                        points.push(SubStepPoint {
                            u: trial.clone(),
                            loads: loads.clone(),
                            lambda: end.min(1.0),
                            dt,
                        });
                    } else {
                        self.points = None;
                    }
                }
                self.commit(model, dt, trial, contact);
                self.time = if end >= 1.0 {
                    self.duration
                } else {
                    self.time + dt
                };
                if iterations <= s.target_iterations {
                    self.dt = (2.0 * dt).min(self.nominal);
                }
                Attempt::Accepted {
                    lambda: self.lambda(),
                    iterations,
                }
            }
            Err((iterations, why)) => {
                report.iterations += iterations;
                report.cutbacks += 1;
                push_log(
                    &mut report.log,
                    format!(
                        "time step {:.6e} -> {:.6e} s: {why}; cutting back",
                        self.time,
                        self.time + dt
                    ),
                );
                self.dt = 0.25 * dt;
                let failed = self.dt < s.min_increment * self.duration && !solver.work_spent();
                if failed {
                    report.reached = lambda;
                    report.message = format!(
                        "no dynamic equilibrium found beyond time {:.6e} s of the step of {:.6e} s (smallest sub-step {:.1e} of the step failed: {why})",
                        self.time, self.duration, s.min_increment
                    );
                }
                Attempt::Rejected {
                    lambda,
                    iterations,
                    failed,
                }
            }
        })
    }

    /// Newton for the sub-step of length `dt` to `loads`: the outcome, the trial point and its
    /// stick/slip states.
    #[allow(clippy::type_complexity)]
    fn attempt(
        &mut self,
        solver: &mut Solver,
        model: &Model,
        loads: &[f64],
        dt: f64,
        report: &mut StepReport,
    ) -> (
        Result<usize, (usize, String)>,
        Vec<f64>,
        Vec<crate::model::sleeve::Contact>,
    ) {
        let inertia = self.inertia(solver, dt);
        solver.inertia = Some(inertia);
        // The predictor: constant acceleration over the sub-step; then the supports.
        let mut trial = self.converged.clone();
        for ((x, v), a) in trial.iter_mut().zip(&self.velocity).zip(&self.acceleration) {
            *x += dt * v + 0.5 * dt * dt * a;
        }
        prescribe(model, loads, &mut trial);
        let mut contact = self.history.contact.clone();
        let increment = Increment {
            loads,
            change: self.change,
            moved: self.moved,
        };
        let result = solver.newton(
            model,
            &increment,
            &mut trial,
            &mut contact,
            None,
            &mut report.log,
        );
        let inertia = solver.inertia.take();
        if let (Ok(_), Some(inertia)) = (&result, &inertia) {
            // The last assembly was at the converged point (newton.rs ends on an assembled
            // iterate): R + g there, so R(u_{n+1}, t_{n+1}) = (R + g) − g with no assembly more.
            self.residual_trial.clear();
            self.residual_trial.resize(solver.pattern.n, 0.0);
            for (d, &e) in solver.pattern.eq.iter().enumerate() {
                if e != NONE {
                    self.residual_trial[e] = solver.residual[d] - inertia.g[e];
                }
            }
        }
        if let (Some(m), Some(inertia)) = (solver.dynamic_matrices.as_mut(), inertia) {
            m.carry.inertia = Some((dt, inertia));
        }
        (result, trial, contact)
    }

    /// K_d, u_n and b of a sub-step of length `dt` (module docs), in the buffers the solver
    /// keeps (`Carry::inertia`).
    fn inertia(&mut self, solver: &mut Solver, dt: f64) -> Inertia {
        let kept = solver
            .dynamic_matrices
            .as_mut()
            .and_then(|m| m.carry.inertia.take());
        let solver = &*solver;
        let matrices = solver
            .dynamic_matrices
            .as_ref()
            .expect("the time integration's matrices (DynamicPath::begin builds them)");
        let Alpha {
            am,
            af,
            beta,
            gamma,
        } = self.alpha;
        let n = solver.pattern.n;
        let eq = &solver.pattern.eq;
        let (m, c) = (&matrices.m, &matrices.c);
        let (k_dt, mut x) = kept.unwrap_or_else(|| {
            (
                0.0,
                Inertia {
                    u_n: vec![0.0; n],
                    b: vec![0.0; n],
                    delta: vec![0.0; n],
                    g: vec![0.0; n],
                    col_ptr: matrices.col_ptr.clone(),
                    row_idx: matrices.row_idx.clone(),
                    ..Default::default()
                },
            )
        });
        if x.k.len() != m.len() || k_dt != dt || x.u_n.len() != n {
            let cm = (1.0 - am) / (beta * dt * dt) / (1.0 - af);
            let cc = gamma / (beta * dt);
            x.k.clear();
            if c.is_empty() {
                x.k.extend(m.iter().map(|m| cm * m));
            } else {
                x.k.extend(m.iter().zip(c).map(|(m, c)| cm * m + cc * c));
            }
        }
        // At δ = 0: a_{n+1-αm} into delta and v_{n+1-αf} into g (scratch here).
        for (d, &e) in eq.iter().enumerate() {
            if e == NONE {
                continue;
            }
            x.u_n[e] = self.converged[d];
            let (v, a) = (self.velocity[d], self.acceleration[d]);
            let (v1, a1) = self.alpha.update(dt, 0.0, v, a);
            x.delta[e] = (1.0 - am) * a1 + am * a;
            x.g[e] = (1.0 - af) * v1 + af * v;
        }
        symmetric_product(&x.col_ptr, &x.row_idx, m, &x.delta, &mut x.b);
        if !c.is_empty() {
            let mut cv = vec![0.0; n];
            symmetric_product(&x.col_ptr, &x.row_idx, c, &x.g, &mut cv);
            for (b, cv) in x.b.iter_mut().zip(&cv) {
                *b += cv;
            }
        }
        for (b, r) in x.b.iter_mut().zip(&self.residual_n) {
            *b = (*b + af * r) / (1.0 - af);
        }
        x
    }

    /// A converged sub-step: velocities and accelerations by Newmark, the history advanced,
    /// R(u_{n+1}, t_{n+1}) for the next.
    fn commit(
        &mut self,
        model: &Model,
        dt: f64,
        trial: Vec<f64>,
        contact: Vec<crate::model::sleeve::Contact>,
    ) {
        let motion = self.velocity.iter_mut().zip(self.acceleration.iter_mut());
        for ((v, a), (x1, x0)) in motion.zip(trial.iter().zip(&self.converged)) {
            (*v, *a) = self.alpha.update(dt, x1 - x0, *v, *a);
        }
        self.history = self.history.advanced(model, &trial, contact);
        std::mem::swap(&mut self.residual_n, &mut self.residual_trial);
        self.converged = trial;
        self.substeps = (self.substeps.0 + 1, dt);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::solver::Settings;

    /// A 1 m x 0.7 m sheet, 4 x 3 cells, its reference normals tilted out of the z axis (so
    /// that the air's n nᵀ couples x, y and z), clamped on one edge, with Rayleigh damping, a point mass and air
    /// (added mass and damping) on its group.
    fn model(kind: &str) -> Model {
        let text = serde_json::json!({
            "format": 1, "name": "Inertia",
            "geometry": {"generators": [{"kind": "rectangle", "name": "s",
                "origin": [0, 0, 0], "size": [1.0, 0.7], "divisions": [4, 3]}]},
            "membranes": [{"name": "m", "triangles": "s", "thickness": 0.001, "density": 1000.0,
                           "material": {"kind": "svk", "E": 1e9, "nu": 0.3},
                           "prestress": {"kind": "isotropic", "n": 1000.0}}],
            "supports": [{"nodes": "s.edge_left", "fix": ["x", "y", "z"]}],
            "dynamics": {"mass": kind, "rayleigh_alpha": 3.0, "rayleigh_beta": 1e-4,
                         "point_masses": [{"nodes": "s.corner_tr", "mass": 0.2}],
                         "air": [{"membrane": "m", "added_mass": 0.7, "damping": 5.0}],
                         "time_integration": {"rho_inf": 0.8}}
        });
        let scene = crate::Scene::from_json(&text.to_string()).unwrap();
        let mut model = Model::build(&scene);
        // Tilted normals (as on a plane z = 0.3 x + 0.2 y), so that n nᵀ couples x, y and z.
        let normal = nalgebra::Vector3::new(-0.3, -0.2, 1.0).normalize();
        for t in &mut model.triangles {
            t.reference.normal = normal;
        }
        model
    }

    /// A time sub-step's iterations take a trial point's assembly as their equations
    /// (`line_search.rs`, "A time sub-step's trial point") and the next step its static
    /// residual (`Carry::residual`): both must be exactly what the iteration's own assembly
    /// (`assemble_at`) and the next step's (`Solver::residual`) give, or a run would depend on
    /// whether they were shared, and a state restored through the FMI would not continue as
    /// the uninterrupted run does. Reference: the same assemblies done afresh at the converged
    /// point. Tolerance: none, bit for bit (R, the force magnitudes of the convergence test,
    /// the triangles' evaluations).
    #[test]
    fn shared_trial_assemblies_are_the_iterations_own_bit_for_bit() {
        let text = serde_json::json!({
            "format": 1, "name": "Shared",
            "geometry": {"generators": [{"kind": "rectangle", "name": "s",
                "origin": [0, 0, 0], "size": [1.0, 0.7], "divisions": [8, 6]}]},
            "membranes": [{"name": "m", "triangles": "s", "thickness": 0.001, "density": 1000.0,
                           "material": {"kind": "svk", "E": 1e9, "nu": 0.3},
                           "prestress": {"kind": "isotropic", "n": 1000.0}}],
            "supports": [{"nodes": "s.boundary", "fix": ["x", "y", "z"]}],
            "inputs": [{"name": "p", "load": {"kind": "pressure", "membrane": "m"}, "start": 0}],
            "dynamics": {"time_integration": {"rho_inf": 0.9}}
        });
        let scene = crate::Scene::from_json(&text.to_string()).unwrap();
        let model = Model::build(&scene);
        let mut solver = Solver::try_new(&model, Settings::default()).unwrap();
        let integration = Integration {
            rho_inf: 0.9,
            max_time_step: None,
            mass: model.mass_kind,
            rayleigh_alpha: 0.0,
            rayleigh_beta: 0.0,
        };
        let mut u = vec![0.0; model.unknown_count()];
        let (mut v, mut a) = (Vec::new(), Vec::new());
        let mut from = vec![0.0];
        // Three steps of 2 ms (f11 of this sheet is about 28 Hz) to 50, 80 and 20 Pa.
        for p in [50.0, 80.0, 20.0] {
            let to = vec![p];
            let mut path = DynamicPath::begin(
                &mut solver,
                &model,
                &integration,
                0.002,
                &from,
                &to,
                &u,
                (&v, &a),
                History::start(&model),
            );
            let mut report = StepReport::failed();
            while let Some(attempt) = path.advance(&mut solver, &model, &mut report) {
                assert!(
                    matches!(attempt, Attempt::Accepted { .. }),
                    "{:?}",
                    report.log
                );
            }
            u.clone_from(&path.converged);
            (v, a) = (path.velocity.clone(), path.acceleration.clone());
            from = to;
            // The last iterate was a shared trial point: the residual carried for the next
            // step is there, at that point.
            let carried = solver
                .dynamic_matrices
                .as_ref()
                .unwrap()
                .carry
                .residual
                .clone();
            let carried = carried.expect("a trial point's residual carried");
            assert!(
                carried.u == u && carried.loads == from,
                "carried at the converged point"
            );
            // R + g, the magnitudes and the evaluations the Newton loop ended on, against the
            // iteration's own assembly done afresh (with the sub-step's inertia force again).
            let (r, magnitude, evaluations) = (
                solver.residual.clone(),
                solver.magnitude.clone(),
                solver.evaluations.clone(),
            );
            let (dt, inertia) = solver
                .dynamic_matrices
                .as_mut()
                .unwrap()
                .carry
                .inertia
                .take()
                .unwrap();
            solver.inertia = Some(inertia);
            solver.assemble_at(&model, &carried.loads, &u);
            assert!(solver.residual == r, "R + g");
            assert!(solver.magnitude == magnitude, "force magnitudes");
            assert!(
                solver
                    .evaluations
                    .iter()
                    .zip(&evaluations)
                    .all(|(x, y)| format!("{x:?}") == format!("{y:?}")),
                "evaluations"
            );
            let inertia = solver.inertia.take().unwrap();
            solver.dynamic_matrices.as_mut().unwrap().carry.inertia = Some((dt, inertia));
            // The static residual carried to the next step, against Solver::residual.
            let fresh = solver.residual(&model, &u, &from);
            let eq = &solver.pattern.eq;
            let fresh: Vec<f64> = (0..solver.pattern.n)
                .map(|e| fresh[eq.iter().position(|&x| x == e).unwrap()])
                .collect();
            assert!(carried.r == fresh, "carried static residual");
        }
        assert!(u.iter().any(|x| *x != 0.0), "the sheet moved");
    }

    /// The inertia force g(u) = b + K_d (u − u_n) of a sub-step, with the added mass in M and
    /// the air's damping in C: its tangent as the Newton loop assembles it (`Inertia::apply`
    /// into the tangent's values) against central differences of g itself, entry by entry,
    /// for both mass matrices; and K_d against its definition from M and C with the air's
    /// matrices built independently here (per triangle ∫ N_a N_b n nᵀ, dense).
    #[test]
    fn inertia_tangent_with_air_matches_finite_differences() {
        for kind in ["consistent", "lumped"] {
            let model = model(kind);
            let mut solver = Solver::try_new(&model, Settings::default()).unwrap();
            let integration = Integration {
                rho_inf: 0.8,
                max_time_step: None,
                mass: model.mass_kind,
                rayleigh_alpha: 3.0,
                rayleigh_beta: 1e-4,
            };
            let n3 = model.dof_count();
            let u0 = vec![0.0; model.unknown_count()];
            let mut rng = 0x1234_5678_u64;
            let mut random = || {
                rng ^= rng << 13;
                rng ^= rng >> 7;
                rng ^= rng << 17;
                (rng >> 11) as f64 / (1u64 << 53) as f64 - 0.5
            };
            let v: Vec<f64> = (0..n3).map(|_| random()).collect();
            let a: Vec<f64> = (0..n3).map(|_| random()).collect();
            let loads = vec![0.0; model.loads.len()];
            let mut path = DynamicPath::begin(
                &mut solver,
                &model,
                &integration,
                0.01,
                &loads,
                &loads,
                &u0,
                (&v, &a),
                History::start(&model),
            );
            let dt = 0.004;
            let mut inertia = path.inertia(&mut solver, dt);
            let eq = solver.pattern.eq.clone();
            let n = solver.pattern.n;
            let u: Vec<f64> = (0..u0.len()).map(|_| 1e-3 * random()).collect();
            let g = |inertia: &mut Inertia, u: &[f64]| {
                let mut r = vec![0.0; n3];
                inertia.apply(&eq, u, &mut r, None, None);
                r
            };
            // The assembled K_d (upper triangle on the pattern) as a dense matrix.
            let mut values = vec![0.0; solver.linear.values().len()];
            g(&mut inertia, &u);
            let mut r = vec![0.0; n3];
            inertia.apply(&eq, &u, &mut r, Some(&mut values), None);
            let (col_ptr, row_idx) = (inertia.col_ptr.clone(), inertia.row_idx.clone());
            let mut kd = vec![0.0; n * n];
            for j in 0..n {
                for p in col_ptr[j]..col_ptr[j + 1] {
                    let i = row_idx[p];
                    kd[i * n + j] = values[p];
                    kd[j * n + i] = values[p];
                }
            }
            let h = 1e-6;
            let mut worst = 0.0f64;
            let scale = kd.iter().fold(0.0f64, |m, x| m.max(x.abs()));
            for (d, &j) in eq.iter().enumerate() {
                if j == NONE {
                    continue;
                }
                let (mut up, mut down) = (u.clone(), u.clone());
                up[d] += h;
                down[d] -= h;
                let (gu, gd) = (g(&mut inertia, &up), g(&mut inertia, &down));
                for (d2, &i) in eq.iter().enumerate() {
                    if i != NONE {
                        let fd = (gu[d2] - gd[d2]) / (2.0 * h);
                        worst = worst.max((fd - kd[i * n + j]).abs());
                    }
                }
            }
            println!(
                "{kind}: |K_d - FD| max {:.2e} of max |K_d| {scale:.3e}",
                worst
            );
            // g is affine in u: the differences are exact up to round-off, ε |g| / h (measured
            // 0.8e-13 and 1.6e-13 of the largest entry).
            assert!(worst <= 1e-12 * scale, "{kind}: {worst} of {scale}");

            // K_d from its definition, with M_air and C_air built here, dense.
            let alpha = Alpha::new(0.8);
            let cm = (1.0 - alpha.am) / (alpha.beta * dt * dt) / (1.0 - alpha.af);
            let cc = alpha.gamma / (alpha.beta * dt);
            let structural = {
                let mut scene_model = model.clone();
                scene_model.air.clear();
                solver
                    .mass(&scene_model, model.mass_kind)
                    .unwrap()
                    .values()
                    .to_vec()
            };
            let k0 = solver.reference_tangent(&model);
            let mut expected = vec![0.0; n * n];
            for j in 0..n {
                for p in col_ptr[j]..col_ptr[j + 1] {
                    let i = row_idx[p];
                    let x = (cm + cc * 3.0) * structural[p] + cc * 1e-4 * k0[p];
                    expected[i * n + j] = x;
                    expected[j * n + i] = x;
                }
            }
            for (t, tri) in model.triangles.iter().enumerate() {
                let [ma, c] = model.air[t];
                assert!(ma > 0.0 && c > 0.0);
                let normal = tri.reference.normal;
                for a in 0..3 {
                    for b in 0..3 {
                        let w = match (kind, a == b) {
                            ("consistent", true) => 2.0 / 12.0,
                            ("consistent", false) => 1.0 / 12.0,
                            (_, true) => 1.0 / 3.0,
                            (_, false) => 0.0,
                        };
                        for i in 0..3 {
                            for k in 0..3 {
                                let (ei, ek) = (eq[3 * tri.nodes[a] + i], eq[3 * tri.nodes[b] + k]);
                                if ei == NONE || ek == NONE {
                                    continue;
                                }
                                let nn = normal[i] * normal[k] * w;
                                // Rayleigh α multiplies the whole M (the added mass in it).
                                expected[ei * n + ek] += (cm + cc * 3.0) * ma * nn + cc * c * nn;
                            }
                        }
                    }
                }
            }
            let off = kd
                .iter()
                .zip(&expected)
                .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
            println!("{kind}: |K_d - definition| max {off:.2e}");
            // Round-off of the sums (measured 4e-16 and 5e-16 of the largest entry).
            assert!(off <= 1e-14 * scale, "{kind}: {off} of {scale}");
        }
    }
}
