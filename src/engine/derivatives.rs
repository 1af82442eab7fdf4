//! Directional and adjoint derivatives of the outputs with respect to inputs and parameters
//! at the committed equilibrium (FMI's `GetDirectionalDerivative` / `GetAdjointDerivative`).
//!
//! ```text
//! equilibrium   R(z; v, p) = 0 at the committed z (displacements and slips)
//! forward       dz = J⁻¹ g,  g = −∂R/∂v·dv − ∂R/∂p·dp            (solver/sensitivity.rs)
//!               held DOFs of displacement inputs move by dv itself
//! outputs       dy = ∂y/∂z·dz + ∂y/∂v·dv + ∂y/∂p·dp
//!               displacement, position, slip probes: exact (linear in z)
//!               reactions (r = R at the held DOFs): dr = ∂R/∂z·dz + ∂R/∂v·dv exactly, the
//!               held rows of the tangent with the states frozen (input seeds; a parameter
//!               seed takes the difference); moment dM = Σ (dx × r + (x − p) × dr)·a
//!               other continuous probes: central difference of the probe along (dz, dv, dp)
//!               with a step 1e-6 of the model's length scale, wrinkle states held as
//!               committed (a triangle on a wrinkle border must not switch inside the step)
//!               integer probes and area fractions: 0 (their states are frozen)
//! adjoint       w̄ = (∂y/∂(v, p))ᵀ w: one transposed solve Jᵀ λ = (∂y/∂z)ᵀ w when every seeded
//!               output is a displacement, position or slip probe; otherwise one forward solve
//!               per known (the same numbers, another order of work)
//! parameters    ∂R/∂p and ∂y/∂p by central differences over models rebuilt at p ± h,
//!               h = 1e-4 |p| (two model rebuilds: slower than an input seed)
//! ```
//! The tangent is factored once per committed state, at the first derivative asked for, and
//! kept until the state changes (Newton's last factorization is of the iterate before the
//! converged one, with the iteration's damping and prestress, so it is not reused).
//!
//! ```text
//! time step     a scene with dynamics.time_integration: the committed state is the end of
//!               the last step (doStep) from its start state (u_n, v_n, a_n, the history and
//!               the start inputs, all held); the knowns are the inputs set before that step
//!               (the loads at its end, as the one-step lag of a static step). With one
//!               sub-step of length Δt = h the step's equation at its end state is
//!                   R(u_{n+1}; v) + b + K_d (u_{n+1} − u_n) = 0      (solver/dynamic.rs)
//!               b and u_n held, so dz = (J + K_d)⁻¹ g with the same g as in statics:
//!               `factor_tangent` adds K_d. Velocities and accelerations follow Newmark:
//!                   dv_{n+1} = γ/(βΔt) du_{n+1},   da_{n+1} = du_{n+1}/(βΔt²)
//!               Several sub-steps: the chain through them (solver/step_sensitivity.rs), from
//!               the end points the step kept; the adjoint then one chain per known.
//!               Refused (Unsupported, naming why): more than `dynamic::MAX_CHAIN` sub-steps,
//!               sleeves, ties or plastic strains through several sub-steps, a step that
//!               returned early, a state set from outside (the step that ended at it is not
//!               known), parameter seeds (a parameter may enter M and C), energy outputs.
//!               Before the first step (the initial equilibrium is static, at rest) the
//!               derivatives are the static ones.
//! ```

use super::{Engine, LastStep};
use crate::error::Error;
use crate::model::{pressure, LoadModel, Model, ProbeModel};
use crate::results;
use crate::solver::assemble;
use crate::solver::sensitivity::{self, SolveCounts, Tangent};
use crate::variables;

/// What a derivative is taken with respect to: an input element (slot of the flat input
/// vector) or a parameter (index into `scene.parameters`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Known {
    Input(usize),
    Parameter(usize),
}

/// What one seed changes: dz (per unknown, held DOFs included), dv (per input slot), dp (per
/// parameter).
type Seeded = (Vec<f64>, Vec<f64>, Vec<f64>);

/// Step of the central differences of the probes, relative to the model's length scale.
const STEP: f64 = 1e-6;
/// Relative step of the central differences over a parameter: the residual is a difference of
/// internal forces much larger than itself, so round-off (∝ 1/h) dominates below 1e-4
/// (measured on the prestressed cable's pretension: 1e-8 → 1.3e-6, 1e-6 → 3.8e-8, 1e-4 →
/// 7.6e-10 relative error; the truncation error, ∝ h², is still below that at 1e-4).
const PARAMETER_STEP: f64 = 1e-4;

impl Engine {
    /// dy = J_{unknowns, knowns} · seed at the committed equilibrium; `unknowns` are output
    /// slots (elements of the flat output vector).
    pub fn directional_derivative(
        &mut self,
        knowns: &[Known],
        seed: &[f64],
        unknowns: &[usize],
    ) -> Result<Vec<f64>, Error> {
        if self.chained() {
            return self.chain_derivative(knowns, seed, unknowns);
        }
        let (dz, dv, dp) = self.forward(knowns, seed)?;
        self.output_derivative(unknowns, &dz, &dv, &dp, None)
    }

    /// w̄ = J_{unknowns, knowns}ᵀ · seed (seed per unknown, result per known).
    pub fn adjoint_derivative(
        &mut self,
        unknowns: &[usize],
        seed: &[f64],
        knowns: &[Known],
    ) -> Result<Vec<f64>, Error> {
        let linear = unknowns
            .iter()
            .zip(seed)
            .filter(|(_, w)| **w != 0.0)
            .all(|(o, _)| self.probe_gradient(*o).is_some());
        let params = knowns.iter().any(|k| matches!(k, Known::Parameter(_)));
        // Through several sub-steps: one forward chain per known.
        if !linear || params || self.chained() {
            // One forward solve per known.
            let mut out = Vec::with_capacity(knowns.len());
            for k in knowns {
                let column = self.directional_derivative(&[*k], &[1.0], unknowns)?;
                out.push(column.iter().zip(seed).map(|(a, b)| a * b).sum());
            }
            return Ok(out);
        }
        let nu = self.model.unknown_count();
        let mut c = vec![0.0; nu];
        for (o, w) in unknowns.iter().zip(seed) {
            if *w != 0.0 {
                for (i, g) in self.probe_gradient(*o).unwrap_or_default() {
                    c[i] += w * g;
                }
            }
        }
        self.ensure_tangent()?;
        let tangent = self.tangent.take().expect("ensured");
        let result: Result<Vec<f64>, Error> = (|| {
            let lambda = self.solver.tangent_solve_transposed(&tangent, &c)?;
            let mut out = Vec::with_capacity(knowns.len());
            for k in knowns {
                let Known::Input(slot) = *k else {
                    unreachable!("parameters take the forward path")
                };
                let (g, held) = self.load_rhs(&tangent, slot);
                let free: f64 = lambda.iter().zip(&g).map(|(a, b)| a * b).sum();
                let moved: f64 = held.iter().zip(&c).map(|(a, b)| a * b).sum();
                out.push(free + moved);
            }
            Ok(out)
        })();
        self.tangent = Some(tangent);
        result
    }

    /// dz (per unknown, held DOFs included), dv (per input slot), dp (per parameter) of a seed.
    fn forward(&mut self, knowns: &[Known], seed: &[f64]) -> Result<Seeded, Error> {
        let nu = self.model.unknown_count();
        let mut dv = vec![0.0; self.state.inputs.len()];
        let mut dp = vec![0.0; self.state.parameters.len()];
        for (k, s) in knowns.iter().zip(seed) {
            match *k {
                Known::Input(slot) => dv[slot] += s,
                Known::Parameter(i) => dp[i] += s,
            }
        }
        if dp.iter().any(|x| *x != 0.0) && self.is_dynamic() {
            return Err(Error::Unsupported(
                "derivatives with respect to a parameter of a scene with dynamics.time_integration (not implemented: a parameter may enter the mass and the damping of the step)".into(),
            ));
        }
        self.ensure_tangent()?;
        let tangent = self.tangent.take().expect("ensured");
        let result: Result<Vec<f64>, Error> = (|| {
            let mut g = vec![0.0; nu];
            let mut held = vec![0.0; self.model.dof_count()];
            for (slot, &s) in dv.iter().enumerate().filter(|(_, s)| **s != 0.0) {
                let (gk, hk) = self.load_rhs(&tangent, slot);
                for (a, b) in g.iter_mut().zip(&gk) {
                    *a += s * b;
                }
                for (a, b) in held.iter_mut().zip(&hk) {
                    *a += s * b;
                }
            }
            for (i, &s) in dp.iter().enumerate().filter(|(_, s)| **s != 0.0) {
                let gp = self.parameter_rhs(&tangent, i)?;
                for (a, b) in g.iter_mut().zip(&gp) {
                    *a += s * b;
                }
            }
            let mut dz = self.solver.tangent_solve(&tangent, &g)?;
            for (a, b) in dz.iter_mut().zip(&held) {
                *a += b;
            }
            Ok(dz)
        })();
        self.tangent = Some(tangent);
        Ok((result?, dv, dp))
    }

    /// Solve the committed state's sensitivities by the sparse LU of the true tangent alone
    /// (`true`) instead of GMRES preconditioned by Newton's factorization with the LU as its
    /// fallback (`false`, the default; solver/sensitivity.rs): the check of one against the
    /// other. Until the state changes.
    pub fn set_direct_sensitivity(&mut self, direct: bool) -> Result<(), Error> {
        self.ensure_tangent()?;
        if let Some(t) = self.tangent.as_mut() {
            t.set_direct(direct);
        }
        Ok(())
    }

    /// What the sensitivity solves at the committed state did so far (None before the first
    /// derivative at it).
    pub fn sensitivity_counts(&self) -> Option<SolveCounts> {
        self.tangent.as_ref().map(Tangent::counts)
    }

    /// Factor the tangent at the committed state unless it is.
    fn ensure_tangent(&mut self) -> Result<(), Error> {
        if self.tangent.is_some() {
            return Ok(());
        }
        if self.model_stale {
            return Err(Error::State(
                "a parameter changed since the last equilibrium: step first, then ask for derivatives".into(),
            ));
        }
        let inertia = self.step_inertia()?;
        let states: Vec<_> = self.membranes.iter().map(|e| e.state).collect();
        let s = &self.state;
        let tangent = self.solver.factor_tangent(
            &self.model,
            &s.displacement,
            &s.applied,
            &states,
            &s.slip_state,
            &inertia,
        )?;
        self.tangent = Some(tangent);
        Ok(())
    }

    fn load_rhs(&mut self, tangent: &Tangent, slot: usize) -> (Vec<f64>, Vec<f64>) {
        let states: Vec<_> = self.membranes.iter().map(|e| e.state).collect();
        let s = &self.state;
        self.solver.load_rhs(
            &self.model,
            &s.displacement,
            &s.applied,
            tangent,
            &states,
            &s.slip_state,
            slot,
        )
    }

    /// −∂R/∂p_i per unknown (free DOFs and slip rows), by a central difference over models
    /// rebuilt at p ± h.
    fn parameter_rhs(&mut self, tangent: &Tangent, i: usize) -> Result<Vec<f64>, Error> {
        let _ = tangent;
        let (plus, minus, h) = self.parameter_models(i)?;
        let s = &self.state;
        let r = |m: &Model| -> Result<Vec<f64>, Error> {
            m.plastic.set(&s.plastic);
            let pattern = assemble::Pattern::try_new(m)?;
            let mut r = vec![0.0; m.dof_count()];
            assemble::assemble(m, &pattern, &s.displacement, &s.applied, &mut r, None);
            r.extend(sensitivity::slip_residuals(
                m,
                &s.displacement,
                &s.slip_state,
            ));
            Ok(r)
        };
        let (rp, rm) = (r(&plus)?, r(&minus)?);
        Ok(rp
            .iter()
            .zip(&rm)
            .map(|(a, b)| -(a - b) / (2.0 * h))
            .collect())
    }

    /// The models at p_i ± h and h.
    fn parameter_models(&self, i: usize) -> Result<(Model, Model, f64), Error> {
        let p = self.state.parameters[i];
        let h = PARAMETER_STEP * p.abs().max(f64::MIN_POSITIVE.sqrt());
        let build = |value: f64| -> Result<Model, Error> {
            let mut scene = self.scene.clone();
            for (q, v) in scene.parameters.clone().iter().zip(&self.state.parameters) {
                variables::set_parameter_value(&mut scene, &q.target, *v);
            }
            let target = scene.parameters[i].target.clone();
            variables::set_parameter_value(&mut scene, &target, value);
            Model::try_build(&scene)
        };
        Ok((build(p + h)?, build(p - h)?, h))
    }

    /// What the tangent of the committed state gains from the step that ended at it (module
    /// docs): nothing after a static equilibrium, K_d after a step of time integration of one
    /// sub-step; the cases that are not implemented are refused, naming why.
    fn step_inertia(&mut self) -> Result<Vec<f64>, Error> {
        let dt = match &self.last_step {
            LastStep::Static => return Ok(Vec::new()),
            LastStep::Restored => {
                return Err(Error::Unsupported(
                    "derivatives of a scene with dynamics.time_integration at a state set from outside (fmi2SetFMUstate, fmi3SetFMUState, a deserialized state) with no step since: they are those of the last step from its start state, which the state does not hold; take the step from it, then ask".into(),
                ))
            }
            LastStep::Dynamic { whole: false, .. } => {
                return Err(Error::Unsupported(
                    "derivatives of a scene with dynamics.time_integration after a step that returned early (FMI 3 early return): they are given at the end of a whole step".into(),
                ))
            }
            LastStep::Dynamic {
                substeps,
                points: None,
                rest: false,
                ..
            } if *substeps != 1 => {
                return Err(Error::Unsupported(format!(
                    "derivatives of a step of dynamics.time_integration taken in {substeps} sub-steps (dynamics.time_integration.max_time_step shorter than the step, or sub-steps cut back): the end points of at most {} sub-steps are kept for the chain through them",
                    crate::solver::dynamic::MAX_CHAIN
                )))
            }
            // The tangent at the step's end: its last sub-step's (the chain itself runs in
            // `chain_derivative`; this one serves the reactions).
            LastStep::Dynamic { dt, .. } => *dt,
        };
        let Some(integration) = super::integration(&self.scene) else {
            return Ok(Vec::new());
        };
        Ok(self.solver.step_stiffness(&self.model, &integration, dt))
    }

    /// Whether the last step was one of time integration in several sub-steps whose end points
    /// are kept (the derivatives then go through them: `solver/step_sensitivity.rs`).
    fn chained(&self) -> bool {
        match &self.last_step {
            LastStep::Dynamic {
                substeps,
                whole: true,
                points,
                rest,
                ..
            } => *substeps > 1 && (points.is_some() || *rest),
            _ => false,
        }
    }

    /// The directional derivative through the sub-steps of the last step (module docs).
    fn chain_derivative(
        &mut self,
        knowns: &[Known],
        seed: &[f64],
        unknowns: &[usize],
    ) -> Result<Vec<f64>, Error> {
        let mut dv = vec![0.0; self.state.inputs.len()];
        for (k, s) in knowns.iter().zip(seed) {
            match *k {
                Known::Input(slot) => dv[slot] += s,
                Known::Parameter(_) if *s != 0.0 => {
                    return Err(Error::Unsupported(
                        "derivatives with respect to a parameter of a scene with dynamics.time_integration (not implemented: a parameter may enter the mass and the damping of the step)".into(),
                    ))
                }
                Known::Parameter(_) => {}
            }
        }
        let integration = super::integration(&self.scene);
        let points = match (&integration, &self.last_step) {
            (
                Some(_),
                LastStep::Dynamic {
                    points: Some(points),
                    ..
                },
            ) => points.clone(),
            // A cheap step at rest: every sub-step ended at the committed state.
            (
                Some(_),
                LastStep::Dynamic {
                    substeps,
                    dt,
                    rest: true,
                    ..
                },
            ) if *substeps <= crate::solver::dynamic::MAX_CHAIN => (1..=*substeps)
                .map(|k| crate::solver::dynamic::SubStepPoint {
                    u: self.state.displacement.clone(),
                    loads: self.state.applied.clone(),
                    lambda: k as f64 / *substeps as f64,
                    dt: *dt,
                })
                .collect(),
            _ => {
                return Err(Error::Unsupported(format!(
                    "derivatives of a step of dynamics.time_integration in more sub-steps than the {} whose end points are kept",
                    crate::solver::dynamic::MAX_CHAIN
                )))
            }
        };
        let Some(integration) = integration else {
            return Err(Error::Unsupported(
                "internal: a step of time integration in a quasi-static scene".into(),
            ));
        };
        // The chain factors each sub-step's tangent in the solver's one factorization: a
        // tangent factored before (or by) it is stale.
        self.tangent = None;
        let change = self
            .solver
            .step_chain(&self.model, &integration, &points, &dv);
        self.tangent = None;
        let change = change?;
        let dp = vec![0.0; self.state.parameters.len()];
        self.output_derivative(
            unknowns,
            &change.dz,
            &dv,
            &dp,
            Some((&change.velocity, &change.acceleration)),
        )
    }

    /// dv/du and da/du of the end state of the last step (generalized-α's Newmark update,
    /// module docs) when it was a step of time integration of one sub-step; else None.
    fn step_rates(&self) -> Option<(f64, f64)> {
        let LastStep::Dynamic {
            substeps: 1,
            dt,
            whole: true,
            ..
        } = self.last_step
        else {
            return None;
        };
        let integration = super::integration(&self.scene)?;
        let a = crate::solver::dynamic::Alpha::new(integration.rho_inf);
        Some((a.gamma / (a.beta * dt), 1.0 / (a.beta * dt * dt)))
    }

    /// dy of the output slots for the change (dz, dv, dp).
    /// `motion`: the change of the velocities and accelerations (per DOF) where it is not
    /// Newmark's update of dz alone (a step of several sub-steps).
    fn output_derivative(
        &mut self,
        unknowns: &[usize],
        dz: &[f64],
        dv: &[f64],
        dp: &[f64],
        motion: Option<(&[f64], &[f64])>,
    ) -> Result<Vec<f64>, Error> {
        if unknowns.iter().any(|&o| {
            matches!(
                self.model.probes.get(o),
                Some(ProbeModel::KineticEnergy | ProbeModel::StrainEnergy)
            )
        }) {
            return Err(Error::Unsupported(
                "derivatives of an energy output (not implemented)".into(),
            ));
        }
        if self.step_rates().is_none()
            && motion.is_none()
            && unknowns.iter().any(|&o| {
                matches!(
                    self.model.probes.get(o),
                    Some(ProbeModel::Velocity { .. } | ProbeModel::Acceleration { .. })
                )
            })
        {
            return Err(Error::Unsupported(
                "derivatives of a velocity or acceleration output outside a step of time integration (not implemented: a static equilibrium is at rest)".into(),
            ));
        }
        if unknowns.iter().any(|&o| {
            matches!(
                self.model.probes.get(o),
                Some(ProbeModel::NaturalFrequency { .. })
            )
        }) {
            return Err(Error::Unsupported(
                "derivatives of a natural_frequency output (not implemented: the eigenvalue's derivative needs the mode's)".into(),
            ));
        }
        let mut out = vec![0.0; unknowns.len()];
        let mut needs_difference = Vec::new();
        // A parameter may enter a probe itself (EA in a tension): only the kinematic probes
        // then keep their exact gradient.
        let parameters = dp.iter().any(|x| *x != 0.0);
        // The reactions' exact change, formed at the first reaction output asked for.
        let mut reactions: Option<ReactionChange> = None;
        for (k, &o) in unknowns.iter().enumerate() {
            if let Some((velocity, acceleration)) = motion {
                match self.model.probes[o] {
                    ProbeModel::Velocity { dof } => {
                        out[k] = velocity[dof];
                        continue;
                    }
                    ProbeModel::Acceleration { dof } => {
                        out[k] = acceleration[dof];
                        continue;
                    }
                    _ => {}
                }
            }
            let gradient = self
                .probe_gradient(o)
                .filter(|_| !parameters || kinematic(&self.model.probes[o]));
            match gradient {
                Some(gradient) => {
                    out[k] = gradient.iter().map(|&(i, g)| g * dz[i]).sum();
                    continue;
                }
                None if !continuous(&self.model.probes[o]) => continue,
                None => {}
            }
            if is_reaction(&self.model.probes[o]) && !parameters {
                if reactions.is_none() {
                    reactions = Some(self.reaction_change(dz, dv)?);
                }
                if let Some(change) = &reactions {
                    if let Some(d) = change.probe(&self.model, &self.state.displacement, dz, o) {
                        out[k] = d;
                        continue;
                    }
                }
            }
            needs_difference.push(k);
        }
        if needs_difference.is_empty() {
            return Ok(out);
        }
        let scale = dz.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let h = STEP * self.model.length_scale / scale.max(f64::MIN_POSITIVE);
        let h = if scale == 0.0 { STEP } else { h };
        // On the branch of the committed equilibrium: a triangle on a wrinkle border must not
        // switch inside ±h (the difference would average the two sides' slopes). The reactions
        // no longer come this way: on AnnulusTorsion their difference left 3.9e-5 at this step
        // (1.5e-6 at 1e-7, which loses other outputs to round-off through the FMU).
        let held = self.membranes.iter().map(|e| Some(e.state)).collect();
        self.solver.hold_states(Some(held));
        let plus = self.probes_at(h, dz, dv, dp);
        let minus = self.probes_at(-h, dz, dv, dp);
        self.solver.hold_states(None);
        let (plus, minus) = (plus?, minus?);
        for k in needs_difference {
            let o = unknowns[k];
            out[k] = (plus[o] - minus[o]) / (2.0 * h);
        }
        Ok(out)
    }

    /// The held DOFs' reactions r = R(z; v) at the committed equilibrium and their change dr =
    /// ∂R/∂z·dz + ∂R/∂v·dv along a solution (dz with the held DOFs' prescribed motion, dv the
    /// inputs' change), exactly: the rows of the consistent tangent with the states frozen,
    /// minus the change of the external loads.
    fn reaction_change(&mut self, dz: &[f64], dv: &[f64]) -> Result<ReactionChange, Error> {
        self.ensure_tangent()?;
        let tangent = self.tangent.take().expect("ensured");
        let states: Vec<_> = self.membranes.iter().map(|e| e.state).collect();
        let held = states.iter().map(|s| Some(*s)).collect();
        let s = &self.state;
        let mut dr = self.solver.tangent_product(
            &self.model,
            &s.displacement,
            &s.applied,
            &tangent,
            &states,
            dz,
        );
        // −∂f_ext/∂v·dv: a force input's external force per unit value (a prescribed
        // displacement's change is in dz already).
        for (slot, &d) in dv.iter().enumerate().filter(|(_, d)| **d != 0.0) {
            if matches!(self.model.loads[slot], LoadModel::Displacement(_)) {
                continue;
            }
            let (g, _) = self.load_rhs(&tangent, slot);
            for (a, b) in dr.iter_mut().zip(&g) {
                *a -= d * b;
            }
        }
        self.solver.hold_states(Some(held));
        let s = &self.state;
        let r = self
            .solver
            .residual(&self.model, &s.displacement, &s.applied);
        self.solver.hold_states(None);
        let change = ReactionChange { r, dr };
        self.tangent = Some(tangent);
        Ok(change)
    }

    /// Every probe at z + t dz, v + t dv, p + t dp (states as committed).
    fn probes_at(&mut self, t: f64, dz: &[f64], dv: &[f64], dp: &[f64]) -> Result<Vec<f64>, Error> {
        let s = &self.state;
        let u: Vec<f64> = s
            .displacement
            .iter()
            .zip(dz)
            .map(|(a, b)| a + t * b)
            .collect();
        // The contact multipliers after the sensitivity's unknowns: held (model::contact).
        let mut u = u;
        if u.len() < s.displacement.len() {
            u.extend_from_slice(&s.displacement[u.len()..]);
        }
        let v: Vec<f64> = s.applied.iter().zip(dv).map(|(a, b)| a + t * b).collect();
        let model = if dp.iter().any(|x| *x != 0.0) {
            let mut scene = self.scene.clone();
            for (q, (p, d)) in scene
                .parameters
                .clone()
                .iter()
                .zip(s.parameters.iter().zip(dp))
            {
                variables::set_parameter_value(&mut scene, &q.target, p + t * d);
            }
            Some(Model::try_build(&scene)?)
        } else {
            None
        };
        let model = model.as_ref().unwrap_or(&self.model);
        let committed = self.solver.evaluate_committed(model, &u, &v);
        Ok(results::evaluate(
            model,
            &u,
            &v,
            s.last_iterations,
            &committed,
            &s.slip_state,
        ))
    }

    /// ∂y/∂z of an output slot as (unknown, value) pairs, for the probes that do not depend
    /// on the loads directly (displacements, positions, slips, cable lengths and tensions,
    /// contact forces and gaps; a largest-over probe takes the gradient of the one that is
    /// largest); None for the others (reactions and stresses: differences).
    fn probe_gradient(&self, slot: usize) -> Option<Vec<(usize, f64)>> {
        let model = &self.model;
        let u = &self.state.displacement;
        let n3 = model.dof_count();
        Some(match &model.probes[slot] {
            ProbeModel::Displacement { dof } | ProbeModel::Position { dof, .. } => {
                vec![(*dof, 1.0)]
            }
            // The end of a time step: Newmark's update (module docs).
            ProbeModel::Velocity { dof } => vec![(*dof, self.step_rates()?.0)],
            ProbeModel::Acceleration { dof } => vec![(*dof, self.step_rates()?.1)],
            ProbeModel::CableSlip { slip } => vec![(n3 + slip, -1.0)],
            // A closed segment (sleeve points merged into one contact group, length 0) has no
            // direction: its probes go by differences.
            ProbeModel::CableLength { segments }
                if segments.clone().any(|e| closed(model, u, e)) =>
            {
                return None
            }
            ProbeModel::CableTension { cable, .. }
                if model.cables[*cable]
                    .segments
                    .clone()
                    .any(|e| closed(model, u, e)) =>
            {
                return None
            }
            // Contacts: by differences (their multipliers move with the active set).
            ProbeModel::ContactTotal { .. } | ProbeModel::ContactArea(_) => return None,
            ProbeModel::ContactGap { slips }
                if slips
                    .iter()
                    .any(|&j| model.slips[j].segments.iter().any(|&e| closed(model, u, e))) =>
            {
                return None
            }
            ProbeModel::CableLength { segments } => {
                let mut g = Vec::new();
                for e in segments.clone() {
                    length_gradient(model, u, e, 1.0, &mut g);
                }
                g
            }
            ProbeModel::CableTension { cable, segment } => {
                let tensions = results::segment_tensions(model, u, *cable);
                let k = segment.unwrap_or_else(|| argmax(&tensions));
                let e = model.cables[*cable].segments.start + k;
                tension_gradient(model, u, e)
            }
            ProbeModel::ContactForce { slips } => {
                // |λ + k d|: the multiplier is an unknown of the derivative (the ties stay
                // closed, solver/sensitivity.rs).
                let forces: Vec<f64> = slips
                    .iter()
                    .map(|&j| model.tie_force(u, model.slips[j].tie).norm())
                    .collect();
                match slips.get(argmax(&forces)) {
                    Some(&j) => tie_force_gradient(model, u, j),
                    None => Vec::new(),
                }
            }
            ProbeModel::ContactGap { slips } => {
                let ratio = |j: usize| {
                    let [a, b] = model.slips[j].segments;
                    let (la, lb) = (segment_length(model, u, a), segment_length(model, u, b));
                    let (e, l) = if la <= lb { (a, la) } else { (b, lb) };
                    (tie_vector(model, u, j).norm() / l, e, l)
                };
                let ratios: Vec<f64> = slips.iter().map(|&j| ratio(j).0).collect();
                match slips.get(argmax(&ratios)) {
                    Some(&j) => {
                        // d(gap/l) = dgap/l − gap dl/l².
                        let (r, e, l) = ratio(j);
                        let mut g = gap_gradient(model, u, j, 1.0 / l);
                        length_gradient(model, u, e, -r / l, &mut g);
                        g
                    }
                    None => Vec::new(),
                }
            }
            // A volume or gas input's pressure is an unknown of the bordered system.
            ProbeModel::EnclosedPressure(k) => vec![(model.volume_unknown(*k), 1.0)],
            ProbeModel::EnclosedVolume(triangles) => {
                let mut g = Vec::new();
                for &e in triangles {
                    let nodes = model.triangles[e].nodes;
                    let x = nodes.map(|i| model.position(u, i));
                    for (gi, &i) in pressure::enclosed_volume_gradient(&x).iter().zip(&nodes) {
                        for c in 0..3 {
                            g.push((3 * i + c, gi[c]));
                        }
                    }
                }
                g
            }
            _ => return None,
        })
    }
}

/// The reactions at the committed equilibrium (`r`, every DOF's residual; the held DOFs'
/// entries are the reactions) and their change `dr` along a solution.
struct ReactionChange {
    r: Vec<f64>,
    dr: Vec<f64>,
}

impl ReactionChange {
    /// d(probe) of a reaction probe (None: not a reaction probe, or the resultant at zero
    /// where its norm has no derivative).
    fn probe(&self, model: &Model, u: &[f64], dz: &[f64], slot: usize) -> Option<f64> {
        let held = |v: &[f64], i: usize| {
            nalgebra::Vector3::from_fn(|c, _| {
                if model.held[3 * i + c] {
                    v[3 * i + c]
                } else {
                    0.0
                }
            })
        };
        match &model.probes[slot] {
            ProbeModel::Reaction { dofs } => Some(
                dofs.iter()
                    .filter(|&&d| model.held[d])
                    .map(|&d| self.dr[d])
                    .sum(),
            ),
            // M = Σ (x_i − p) × r_i · a: dM = Σ (dx_i × r_i + (x_i − p) × dr_i) · a.
            ProbeModel::ReactionMoment { nodes, point, axis } => Some(
                nodes
                    .iter()
                    .map(|&i| {
                        let arm = model.position(u, i) - point;
                        let dx = nalgebra::Vector3::new(dz[3 * i], dz[3 * i + 1], dz[3 * i + 2]);
                        (dx.cross(&held(&self.r, i)) + arm.cross(&held(&self.dr, i))).dot(axis)
                    })
                    .sum(),
            ),
            // |S|, S = Σ r_i: d|S| = S·dS/|S|.
            ProbeModel::ReactionResultant { nodes } => {
                let sum = |v: &[f64]| {
                    nodes
                        .iter()
                        .map(|&i| held(v, i))
                        .sum::<nalgebra::Vector3<f64>>()
                };
                let (total, change) = (sum(&self.r), sum(&self.dr));
                let norm = total.norm();
                (norm > 0.0).then(|| total.dot(&change) / norm)
            }
            _ => None,
        }
    }
}

fn is_reaction(p: &ProbeModel) -> bool {
    matches!(
        p,
        ProbeModel::Reaction { .. }
            | ProbeModel::ReactionMoment { .. }
            | ProbeModel::ReactionResultant { .. }
    )
}

/// Whether segment `e` is closed: shorter than 1e-6 of the model's length scale (merged sleeve
/// points meet to within about 1e-7 of the span, `solver/order.rs`).
fn closed(model: &Model, u: &[f64], e: usize) -> bool {
    segment_length(model, u, e) < 1e-6 * model.length_scale
}

fn argmax(v: &[f64]) -> usize {
    v.iter()
        .enumerate()
        .fold(
            (0, f64::NEG_INFINITY),
            |m, (i, &x)| if x > m.1 { (i, x) } else { m },
        )
        .0
}

fn segment_vector(model: &Model, u: &[f64], e: usize) -> nalgebra::Vector3<f64> {
    let [a, b] = model.segments[e].nodes;
    model.position(u, b) - model.position(u, a)
}

fn segment_length(model: &Model, u: &[f64], e: usize) -> f64 {
    segment_vector(model, u, e).norm()
}

/// Adds `factor` · ∂l_e/∂z.
fn length_gradient(model: &Model, u: &[f64], e: usize, factor: f64, g: &mut Vec<(usize, f64)>) {
    let d = segment_vector(model, u, e);
    let l = d.norm();
    if l == 0.0 {
        return;
    }
    let [a, b] = model.segments[e].nodes;
    for c in 0..3 {
        g.push((3 * b + c, factor * d[c] / l));
        g.push((3 * a + c, -factor * d[c] / l));
    }
}

/// ∂T_e/∂z: T(L0, l) with L0 = l0 + s_end − s_start.
fn tension_gradient(model: &Model, u: &[f64], e: usize) -> Vec<(usize, f64)> {
    let s = &model.segments[e];
    let (l0, l) = (model.segment_l0(u, e), segment_length(model, u, e));
    let (_, dt_dl) = crate::model::cable::tension(s.law, s.ea, l0, l);
    let dt_dl0 = crate::model::cable::tension_dl0(s.law, s.ea, l0, l);
    let mut g = Vec::new();
    length_gradient(model, u, e, dt_dl, &mut g);
    let n3 = model.dof_count();
    if let Some(j) = s.slip[1] {
        g.push((n3 + j, dt_dl0));
    }
    if let Some(j) = s.slip[0] {
        g.push((n3 + j, -dt_dl0));
    }
    g
}

/// x_c − x_m of the tie of sleeve point `j`.
fn tie_vector(model: &Model, u: &[f64], j: usize) -> nalgebra::Vector3<f64> {
    let [c, m] = model.ties[model.slips[j].tie].nodes;
    model.position(u, c) - model.position(u, m)
}

/// `factor` · ∂|x_c − x_m|/∂z (zero at a closed gap, where the norm has no gradient).
fn gap_gradient(model: &Model, u: &[f64], j: usize, factor: f64) -> Vec<(usize, f64)> {
    let d = tie_vector(model, u, j);
    let gap = d.norm();
    if gap == 0.0 {
        return Vec::new();
    }
    let [c, m] = model.ties[model.slips[j].tie].nodes;
    (0..3)
        .flat_map(|k| {
            [
                (3 * c + k, factor * d[k] / gap),
                (3 * m + k, -factor * d[k] / gap),
            ]
        })
        .collect()
}

/// ∂|λ + k (x_c − x_m)|/∂z of the tie of sleeve point `j`, the multiplier λ among the unknowns
/// (zero where the force vanishes, where the norm has no gradient).
fn tie_force_gradient(model: &Model, u: &[f64], j: usize) -> Vec<(usize, f64)> {
    let t = model.slips[j].tie;
    let f = model.tie_force(u, t);
    let size = f.norm();
    if size == 0.0 {
        return Vec::new();
    }
    let k = model.ties[t].k;
    let [c, m] = model.ties[t].nodes;
    let index = model.multiplier_index(t);
    (0..3)
        .flat_map(|i| {
            [
                (3 * c + i, k * f[i] / size),
                (3 * m + i, -k * f[i] / size),
                (index + i, f[i] / size),
            ]
        })
        .collect()
}

/// Whether a probe is a function of the positions and slips alone (no material constant).
fn kinematic(p: &ProbeModel) -> bool {
    matches!(
        p,
        ProbeModel::Displacement { .. }
            | ProbeModel::Position { .. }
            | ProbeModel::CableSlip { .. }
            | ProbeModel::CableLength { .. }
            | ProbeModel::ContactGap { .. }
            | ProbeModel::EnclosedVolume(_)
            | ProbeModel::EnclosedPressure(_)
    )
}

/// Whether a probe varies continuously with the state (else its derivative is 0: counts,
/// codes and area fractions change only when a frozen state switches).
fn continuous(p: &ProbeModel) -> bool {
    !matches!(
        p,
        ProbeModel::NewtonIterations
            | ProbeModel::SlipCount { .. }
            | ProbeModel::ElementState(_)
            | ProbeModel::WrinkledFraction(_)
            | ProbeModel::SlackFraction(_)
            | ProbeModel::ContactArea(_)
    )
}
