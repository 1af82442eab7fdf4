//! The one facade: a scene's model, its committed state and the solver workspace.
//!
//! Everything outside the physics (the FMI adapter, `velarium solve`, tests) drives the solver
//! through this type:
//!
//! ```text
//! Engine::try_new(scene)          validate, form-find if asked, build the model, start values
//! set_real / get_real / get_integer   by value reference (the variable table)
//! solve()                         equilibrium under the current inputs, reached by load
//!                                 increments from the last committed equilibrium; committed
//!                                 only if it converged (otherwise nothing changes)
//! state() / set_state()           the committed state as plain data (FMU get/set state)
//! reset()                         back to the start values and the undeformed configuration
//! ```

use crate::error::Error;
use crate::memory;
use crate::model::membrane::Evaluation;
use crate::model::sleeve::Contact;
use crate::model::wrinkling::WrinkleState;
use crate::model::{Model, ProbeModel};
use crate::results;
use crate::scene::{validate, DebugSettings, Scene};
use crate::solver::{Settings, Solver, StepReport};
use crate::variables::{self, Binding, Causality, VarType, Variability, Variable};
use serde::{Deserialize, Serialize};

pub mod coarse;
pub mod derivatives;
pub mod modes;
pub mod stepping;

/// Everything needed to continue a run: plain data, `Clone + Serialize`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct EngineState {
    /// Displacement of every DOF (3 per node, sleeve points included), then the slip of every
    /// sleeve point (material coordinate change, m), the pressure of every volume input and
    /// the multiplier of every sleeve tie (N, 3 per tie, model/sleeve.rs):
    /// `Model::unknown_count` values.
    pub displacement: Vec<f64>,
    /// Stick/slip state of every sleeve point at the last converged increment (stuck,
    /// slipping toward the cable's end or its start, or merged into the previous sleeve point).
    pub slip_state: Vec<Contact>,
    /// Input values of the committed equilibrium (what the structure carries now).
    pub applied: Vec<f64>,
    /// Input values as last set (applied at the next solve).
    pub inputs: Vec<f64>,
    /// Parameter values, in `scene.parameters` order.
    pub parameters: Vec<f64>,
    /// Newton iterations of the last solve.
    pub last_iterations: u32,
    /// Wrinkle state of every membrane triangle (taut, wrinkled or slack), in model order.
    pub wrinkle: Vec<WrinkleState>,
    /// Tension direction of every membrane triangle: angle (rad) of the major principal strain
    /// direction in the triangle's reference frame (first edge = 0).
    pub tension_angle: Vec<f64>,
    /// Plastic strain of every membrane triangle at the last converged increment (4 per
    /// triangle, `model::state::History`; empty when no membrane group is elastoplastic).
    pub plastic: Vec<f64>,
    /// Velocity and acceleration of every DOF (3 per node) of a scene with time integration
    /// (`dynamics.time_integration`, docs/dynamics.md); empty in a quasi-static scene.
    pub velocity: Vec<f64>,
    pub acceleration: Vec<f64>,
}

impl EngineState {
    /// Bytes of its vectors (what a copy of it allocates).
    pub fn bytes(&self) -> u64 {
        let floats = self.displacement.len()
            + self.applied.len()
            + self.inputs.len()
            + self.parameters.len()
            + self.tension_angle.len()
            + self.plastic.len()
            + self.velocity.len()
            + self.acceleration.len();
        8 * floats as u64
            + (self.slip_state.len() * size_of::<Contact>()
                + self.wrinkle.len() * size_of::<WrinkleState>()) as u64
    }
}

pub struct Engine {
    /// The scene as given (parameter values are applied on top of it when the model is built).
    scene: Scene,
    /// The variable table as FMI 2 sees it: arrays as scalars `name[i]` ([`variables::scalars`]).
    variables: Vec<Variable>,
    /// The variable table with arrays (what FMI 3 declares); same value references.
    arrays: Vec<Variable>,
    model: Model,
    solver: Solver,
    state: EngineState,
    /// Parameters changed since the model was built.
    model_stale: bool,
    /// Outputs of the committed state, in probe order (recomputed whenever the state changes).
    outputs: Vec<f64>,
    /// Evaluation of every membrane triangle in the committed state.
    membranes: Vec<Evaluation>,
    /// The tangent factored at the committed state for derivatives (None: not yet, or the
    /// state or the solver's factorization changed since).
    tangent: Option<crate::solver::sensitivity::Tangent>,
    /// The committed state is an equilibrium a solve of this engine converged to (or ended a
    /// whole step at), with nothing set, restored or reset since: with the inputs equal to the
    /// applied ones and the model not stale, a step has nothing to do ([`Engine::settled`]).
    converged: bool,
    /// Estimated peak bytes of model and solver (`scene::limits::memory_bytes`), from the
    /// validation that admitted the scene.
    memory_estimate: u64,
    /// The length (s) of the next step of a scene with time integration
    /// ([`Engine::set_step_duration`]); 0: the next solve is a static equilibrium.
    duration: f64,
    /// What the committed state is the end of, for its derivatives (`engine/derivatives.rs`).
    last_step: LastStep,
}

impl Engine {
    /// Validate the scene and build its model. Inputs and parameters take their start values;
    /// the state is the undeformed configuration (call [`Engine::solve`] for the equilibrium
    /// under the start values).
    pub fn try_new(scene: Scene) -> Result<Engine, Error> {
        // The size check's factor comes from the solver's own symbolic analysis below
        // (`scene::limits`, "check_factor"), not from a second ordering of the mesh. A scene
        // that asks for form finding keeps the check as `velarium check` runs it: its engine
        // is built from the found scene.
        let (problems, mut size) = if scene.form_finding.is_none() {
            crate::scene::limits::with_factor_from_solver(|| validate::validate_sized(&scene))
        } else {
            validate::validate_sized(&scene)
        };
        if !problems.is_empty() {
            return Err(Error::Scene(problems));
        }
        // A scene that asks for form finding is replaced by the found one before anything
        // else: its geometry is the found shape, its prestress the balancing stress state.
        let scene = if scene.form_finding.is_some() {
            let report = crate::formfind::run(&scene)?;
            let found = report.scene.ok_or_else(|| {
                Error::FormFinding(format!(
                    "after {} iterations: {}",
                    report.iterations, report.message
                ))
            })?;
            let problems = validate::validate(&found);
            if !problems.is_empty() {
                return Err(Error::Scene(problems));
            }
            found
        } else {
            scene
        };
        // The whole build (model, pattern, factor, vectors) at once, before any of it: a
        // shortage is found here, not in the middle (`crate::memory`).
        if !scene.debug.skip_memory_probes {
            memory::probe(size.memory_bytes, "the model and the solver")?;
        }
        // Two threads on a model the solver will split: its threads started now, their
        // helper touching the pages of the triangles' position maps (about 216 MB at the 1M
        // disc) while this thread builds the model (`solver::Started`); the solver takes
        // both (or ends them where it has no pool after all).
        let started = match settings(&scene).threads > 1
            && size.unknowns >= crate::solver::linear::SPLIT_MIN_EQUATIONS as u64
            && size.triangles > 0
        {
            true => crate::solver::Started::begin(size.triangles as usize),
            false => None,
        };
        let arrays = variables::try_table(&scene)?;
        let variables = variables::scalars(&arrays);
        let model = Model::try_build(&scene)?;
        let count = |c: Causality| variables.iter().filter(|v| v.causality == c).count();
        if count(Causality::Input) != model.loads.len()
            || count(Causality::Output) != model.probes.len()
        {
            return Err(Error::State(format!(
                "internal: the variable table has {} input and {} output scalars, the model {} load channels and {} probes",
                count(Causality::Input),
                count(Causality::Output),
                model.loads.len(),
                model.probes.len()
            )));
        }
        let solver = match Solver::try_new_started(&model, settings(&scene), started) {
            Ok(solver) => solver,
            // Short of memory before the size check had the factor: the check's own verdict
            // (located, naming the limit) where it has one.
            Err(e) if size.factor_deferred => {
                drop(model);
                let (problems, _) = validate::validate_sized(&scene);
                return Err(match problems.is_empty() {
                    true => e.into(),
                    false => Error::Scene(problems),
                });
            }
            Err(e) => return Err(e.into()),
        };
        // Two threads: the first outputs' evaluations (one per triangle, 58 MB at the 1M
        // disc) allocated and their pages touched on the solver's helper, idle until that
        // refresh's assembly, while this thread checks the factor's size and sets up the
        // initial state; the refresh writes into them (`refresh_outputs`).
        let evaluations = solver.pool().map(|pool| {
            let triangles = model.triangles.len();
            crate::solver::threads::Pool::launch(pool, 0, move || {
                crate::solver::assemble::unevaluated(triangles)
            })
        });
        let problems = crate::scene::limits::check_factor(
            &mut size,
            solver.factor_nonzeros() as u64,
            solver.factor_flops(),
            &scene.solver.limits,
        );
        if !problems.is_empty() {
            return Err(Error::Scene(problems));
        }
        let state = initial_state(&scene, &variables, &model)?;
        let mut engine = Engine {
            scene,
            variables,
            arrays,
            model,
            solver,
            state,
            model_stale: false,
            outputs: Vec::new(),
            membranes: Vec::new(),
            tangent: None,
            converged: false,
            memory_estimate: size.memory_bytes,
            duration: 0.0,
            last_step: LastStep::Static,
        };
        if let Some(Ok(Ok(evaluations))) = evaluations.map(|e| e.join()) {
            engine.membranes = evaluations;
        }
        engine.refresh_outputs()?;
        Ok(engine)
    }

    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    pub fn model(&self) -> &Model {
        &self.model
    }

    /// The scene's debug switches with the current values of the parameters that target them.
    pub fn debug(&self) -> DebugSettings {
        let mut debug = self.scene.debug.clone();
        for (p, value) in self.scene.parameters.iter().zip(&self.state.parameters) {
            if let Some(field) = p.target.strip_prefix("debug.") {
                debug.set(field, *value);
            }
        }
        debug
    }

    /// The variable table (parameters, inputs, outputs with value references).
    pub fn variables(&self) -> &[Variable] {
        &self.variables
    }

    /// The variable table with arrays (FMI 3); the same value references as
    /// [`Engine::variables`], an array's being that of its first element.
    pub fn arrays(&self) -> &[Variable] {
        &self.arrays
    }

    /// Find a scalar (an array element counts as one) by value reference and FMI 2 type (a
    /// UInt8 is read as an Integer).
    pub fn variable(&self, vr: u32, var_type: VarType) -> Result<&Variable, Error> {
        self.variables
            .iter()
            .find(|v| v.value_reference == vr && v.var_type.fmi2() == var_type.fmi2())
            .ok_or(Error::UnknownValueReference {
                vr,
                kind: type_name(var_type),
            })
    }

    /// Find a variable of the array table (FMI 3) by its value reference and exact type.
    pub fn array_variable(&self, vr: u32, var_type: VarType) -> Result<&Variable, Error> {
        self.arrays
            .iter()
            .find(|v| v.value_reference == vr && v.var_type == var_type)
            .ok_or(Error::UnknownValueReference {
                vr,
                kind: type_name(var_type),
            })
    }

    /// All element values of a variable of the array table (a scalar: one), as f64.
    pub fn values(&self, var: &Variable) -> &[f64] {
        match var.binding {
            Binding::Input(k) => &self.state.inputs[k..k + var.len()],
            Binding::Parameter(i) => std::slice::from_ref(&self.state.parameters[i]),
            Binding::Output(k) => &self.outputs[k..k + var.len()],
        }
    }

    /// Set an input or a parameter. Rejects outputs, unknown references and non-finite values
    /// and values outside [min, max]; the FMI layer adds its own rules of when a set is legal.
    pub fn set_real(&mut self, vr: u32, value: f64) -> Result<(), Error> {
        let var = self.variable(vr, VarType::Real)?.clone();
        if !value.is_finite() {
            return Err(Error::NonFinite {
                vr,
                name: var.name,
                value,
            });
        }
        check_bounds(&var, value)?;
        match var.binding {
            Binding::Input(i) => self.state.inputs[i] = value,
            Binding::Parameter(i) => {
                check_parameter(&self.scene, &var, i, value)?;
                if self.state.parameters[i] != value {
                    self.state.parameters[i] = value;
                    self.model_stale = true;
                }
            }
            Binding::Output(_) => {
                return Err(Error::NotSettable {
                    vr,
                    name: var.name,
                    why: "it is an output".into(),
                })
            }
        }
        Ok(())
    }

    /// Current value of a Real variable (outputs are computed from the committed state).
    pub fn get_real(&self, vr: u32) -> Result<f64, Error> {
        let var = self.variable(vr, VarType::Real)?;
        Ok(match var.binding {
            Binding::Input(i) => self.state.inputs[i],
            Binding::Parameter(i) => self.state.parameters[i],
            Binding::Output(i) => self.outputs[i],
        })
    }

    /// Current value of an Integer variable.
    pub fn get_integer(&self, vr: u32) -> Result<i32, Error> {
        let var = self.variable(vr, VarType::Integer)?;
        match var.binding {
            Binding::Output(i) => Ok(self.outputs[i].round() as i32),
            _ => Err(Error::UnknownValueReference {
                vr,
                kind: "Integer",
            }),
        }
    }

    /// All outputs in table order, as f64 (Integer outputs converted).
    pub fn outputs(&self) -> Vec<(String, f64)> {
        self.variables
            .iter()
            .filter(|v| v.causality == Causality::Output)
            .map(|v| {
                let Binding::Output(i) = v.binding else {
                    unreachable!("outputs bind outputs")
                };
                (v.name.clone(), self.outputs[i])
            })
            .collect()
    }

    /// Reach the equilibrium under the current inputs from the committed one, by load increments
    /// with cut-back. On convergence the new equilibrium is committed; otherwise the committed
    /// state is unchanged and the report says how far the increments got.
    pub fn solve(&mut self) -> StepReport {
        let mut step = self.begin_step();
        while self.advance(&mut step).is_some() {}
        self.end_step(step)
    }

    /// Whether a step to the current inputs has nothing to do: the committed state is an
    /// equilibrium this engine converged to, the inputs are exactly (bit for bit up to the sign
    /// of zero) the ones it carries, and no parameter changed since. Then [`Engine::keep`]
    /// stands for [`Engine::solve`] without running the solver.
    pub fn settled(&self) -> bool {
        // With time integration, a state at rest in equilibrium stays at rest: only then.
        let at_rest = self.state.velocity.iter().all(|v| *v == 0.0)
            && self.state.acceleration.iter().all(|a| *a == 0.0);
        self.converged && !self.model_stale && self.state.inputs == self.state.applied && at_rest
    }

    /// Whether the scene integrates in time (`dynamics.time_integration`, docs/dynamics.md).
    pub fn is_dynamic(&self) -> bool {
        is_dynamic(&self.scene)
    }

    /// The length (s) of the next step of a scene with time integration: from its committed
    /// state, the next [`Engine::solve`] (or [`Engine::begin_step`]) advances time by
    /// `duration`, the loads going linearly from the applied inputs to the set ones. 0 (the
    /// start): the next solve is the static equilibrium under the set inputs, at rest (an
    /// FMU's initialization). Ignored by a quasi-static scene.
    pub fn set_step_duration(&mut self, duration: f64) {
        self.duration = if duration.is_finite() && duration > 0.0 {
            duration
        } else {
            0.0
        };
    }

    /// The step of a [`settled`](Engine::settled) engine: the equilibrium stays as it is (no
    /// assembly, no factorization, no allocation); the step took no Newton iteration, which is
    /// what the `iterations` outputs now show. Returns the converged report of a solve that
    /// found its start already in equilibrium; None when the engine is not settled.
    pub fn keep(&mut self) -> Option<StepReport> {
        if !self.settled() {
            return None;
        }
        self.state.last_iterations = 0;
        // At rest in equilibrium under unchanged inputs, the step's sub-steps would have ended
        // where they started: its derivative is theirs.
        let last_step = LastStep::kept(&self.scene, self.duration);
        if last_step != self.last_step {
            self.tangent = None;
            self.last_step = last_step;
        }
        for (probe, out) in self.model.probes.iter().zip(self.outputs.iter_mut()) {
            if matches!(probe, crate::model::ProbeModel::NewtonIterations) {
                *out = 0.0;
            }
        }
        Some(StepReport::unchanged())
    }

    /// The first non-finite value of the committed state or outputs, named; None if all are
    /// finite.
    fn non_finite(&self) -> Option<String> {
        if let Some(i) = self.state.displacement.iter().position(|x| !x.is_finite()) {
            return Some(format!("displacement[{i}]"));
        }
        self.variables
            .iter()
            .filter(|v| v.causality == Causality::Output)
            .find(|v| matches!(v.binding, Binding::Output(i) if !self.outputs[i].is_finite()))
            .map(|v| format!("output {}", v.name))
    }

    /// Values of a state from outside (an FMU state set or deserialized): every vector as long
    /// as this model's (checked first, so nothing is indexed out of range), finite displacements
    /// within the scene's magnitudes, valid state codes, inputs and parameters finite and within
    /// their declared ranges. The first failed check is named.
    pub fn check_state(&self, state: &EngineState) -> Result<(), Error> {
        let bad = |m: String| Err(Error::State(m));
        // Lengths first: everything below indexes the vectors by the model's counts.
        let s = &self.state;
        for (field, given, want, of) in [
            (
                "velocity",
                state.velocity.len(),
                s.velocity.len(),
                "velocities (3 per node with dynamics.time_integration, else none)",
            ),
            (
                "acceleration",
                state.acceleration.len(),
                s.acceleration.len(),
                "accelerations (3 per node with dynamics.time_integration, else none)",
            ),
            (
                "displacement",
                state.displacement.len(),
                s.displacement.len(),
                "unknowns",
            ),
            (
                "slip_state",
                state.slip_state.len(),
                s.slip_state.len(),
                "sleeve points",
            ),
            (
                "applied",
                state.applied.len(),
                s.applied.len(),
                "input values",
            ),
            ("inputs", state.inputs.len(), s.inputs.len(), "input values"),
            (
                "parameters",
                state.parameters.len(),
                s.parameters.len(),
                "parameters",
            ),
            (
                "wrinkle",
                state.wrinkle.len(),
                s.wrinkle.len(),
                "membrane triangles",
            ),
            (
                "tension_angle",
                state.tension_angle.len(),
                s.tension_angle.len(),
                "membrane triangles",
            ),
            (
                "plastic",
                state.plastic.len(),
                s.plastic.len(),
                "plastic strain values (4 per triangle of an elastoplastic model)",
            ),
        ] {
            if given != want {
                return bad(format!(
                    "{field} has {given} values, this model has {want} {of} (a state of another model?)"
                ));
            }
        }
        let max = crate::scene::validate::MAX_MAGNITUDE;
        if let Some(i) = state
            .displacement
            .iter()
            .position(|x| !(x.is_finite() && x.abs() <= max))
        {
            return bad(format!(
                "displacement[{i}] = {} is not a finite displacement with |u| <= {max:e}",
                state.displacement[i]
            ));
        }
        // Merged only where the point follows another sleeve point, and then its segment
        // must be closed (negative unstretched length, docs/mechanics.md §2.3), both ways.
        let model = &self.model;
        if state.slip_state.len() == model.slips.len()
            && state.displacement.len() == model.unknown_count()
        {
            for (j, &c) in state.slip_state.iter().enumerate() {
                let e = model.slips[j].segments[0];
                let follows = model.segments[e].slip[0].is_some();
                let closed = follows && model.segment_closed(&state.displacement, e);
                if (c == Contact::Merged) != closed {
                    return bad(format!(
                        "slip_state[{j}] = {c:?} does not match the slips: {}",
                        if c == Contact::Merged {
                            "a merged point must follow a touching sleeve point (closed segment)"
                        } else {
                            "the segment before this point is closed, so its state must be Merged"
                        }
                    ));
                }
            }
        }
        if let Some(i) = state
            .plastic
            .iter()
            .position(|x| !(x.is_finite() && x.abs() <= 1e3))
        {
            return bad(format!(
                "plastic[{i}] = {} is not a finite plastic strain with |value| <= 1e3",
                state.plastic[i]
            ));
        }
        for (field, values) in [
            ("velocity", &state.velocity),
            ("acceleration", &state.acceleration),
        ] {
            if let Some(i) = values
                .iter()
                .position(|x| !(x.is_finite() && x.abs() <= max))
            {
                return bad(format!(
                    "{field}[{i}] = {} is not finite with |value| <= {max:e}",
                    values[i]
                ));
            }
        }
        if let Some(i) = state.tension_angle.iter().position(|x| !x.is_finite()) {
            return bad(format!(
                "tension_angle[{i}] = {} is not finite",
                state.tension_angle[i]
            ));
        }
        for var in &self.variables {
            let (field, value) = match var.binding {
                Binding::Input(i) => {
                    if !state.applied[i].is_finite() {
                        return bad(format!(
                            "applied value of input {} = {} is not finite",
                            var.name, state.applied[i]
                        ));
                    }
                    check_bounds(var, state.applied[i])
                        .map_err(|e| Error::State(format!("applied value: {e}")))?;
                    ("input", state.inputs[i])
                }
                Binding::Parameter(i) => ("parameter", state.parameters[i]),
                Binding::Output(_) => continue,
            };
            if !value.is_finite() {
                return bad(format!("{field} {} = {value} is not finite", var.name));
            }
            check_bounds(var, value).map_err(|e| Error::State(format!("{field}: {e}")))?;
            if let Binding::Parameter(i) = var.binding {
                if value != self.state.parameters[i] {
                    check_parameter(&self.scene, var, i, value)
                        .map_err(|e| Error::State(format!("parameter: {e}")))?;
                }
            }
        }
        Ok(())
    }

    /// The committed state.
    pub fn state(&self) -> &EngineState {
        &self.state
    }

    /// Restore a committed state (from [`Engine::state`] of an engine of the same scene).
    pub fn set_state(&mut self, state: EngineState) -> Result<(), Error> {
        self.check_state(&state)?;
        let s = &self.state;
        let params_changed = state.parameters != s.parameters;
        let previous = std::mem::replace(&mut self.state, state);
        if params_changed {
            self.model_stale = true;
            if let Err(e) = self.rebuild() {
                // The model and solver are untouched: back to the previous state.
                self.state = previous;
                self.model_stale = false;
                return Err(e);
            }
        }
        let refreshed = self.refresh_outputs();
        let what = match refreshed {
            Err(e) => Err(e),
            Ok(()) => Ok(self.non_finite()),
        };
        if !matches!(what, Ok(None)) {
            // Leave the engine as it was (a rebuild that fails leaves the model stale: the
            // next solve builds it again; a refresh that failed changed nothing).
            self.state = previous;
            if params_changed {
                self.model_stale = true;
                let _ = self.rebuild();
            }
            let what = what?.unwrap_or_default();
            let _ = self.refresh_outputs();
            return Err(Error::State(format!(
                "the state gives a non-finite {what}; the instance is unchanged"
            )));
        }
        // A restored state is not known to be an equilibrium of this engine: the next step
        // solves. Nor is the step it ended known (its derivative needs that step).
        self.converged = false;
        self.last_step = LastStep::restored(&self.scene);
        Ok(())
    }

    /// Back to the start values and the undeformed configuration.
    /// Memory that cannot be had is an [`Error::Memory`] and leaves the engine as it was.
    pub fn reset(&mut self) -> Result<(), Error> {
        let fresh = initial_state(&self.scene, &self.variables, &self.model)?;
        let previous = std::mem::replace(&mut self.state, fresh);
        if previous.parameters != self.state.parameters || self.model_stale {
            self.model_stale = true;
            if let Err(e) = self.rebuild() {
                self.state = previous;
                return Err(e);
            }
        }
        if let Err(e) = self.refresh_outputs() {
            self.state = previous;
            return Err(e);
        }
        self.converged = false;
        self.last_step = LastStep::Static;
        Ok(())
    }

    /// Evaluation (state, tension angle, stresses) of every membrane triangle in the committed
    /// state, in model order.
    pub fn membranes(&self) -> &[Evaluation] {
        &self.membranes
    }

    /// Free DOFs of the current model (the size of the linear systems).
    pub fn free_dofs(&self) -> usize {
        self.solver.free_dofs()
    }

    /// Residual R = f_int − f_ext of the committed state on every DOF (reactions at held DOFs).
    pub fn residual(&mut self) -> Vec<f64> {
        self.solver
            .residual(&self.model, &self.state.displacement, &self.state.applied)
    }

    /// Estimated peak memory of model and solver in bytes (`scene::limits::memory_bytes`: the
    /// factor from the symbolic analysis, the matrix, the elements, the vectors), the figure
    /// the size limits and the memory probe use. Compare with [`crate::memory::peak_resident`]
    /// (docs/performance.md, memory).
    pub fn memory_estimate(&self) -> u64 {
        self.memory_estimate
    }

    /// Stored entries of the tangent's LDLT factor (after AMD ordering), for the scaling benchmark.
    pub fn factor_nonzeros(&self) -> usize {
        self.solver.factor_nonzeros()
    }

    /// Flops of one numeric factorization of the tangent (Σ c² over the factor's columns, c
    /// the entries below the diagonal; with two threads the halves' and the separator's).
    pub fn factor_flops(&self) -> f64 {
        self.solver.factor_flops()
    }

    /// Equations of the two halves and of their separator when the tangent is factored on two
    /// threads (`solver.threads` >= 2 on a large enough model: docs/performance.md, "Threads");
    /// None when it is factored whole on the solving thread.
    pub fn split_sizes(&self) -> Option<(usize, usize, usize)> {
        self.solver.split_sizes()
    }

    /// Triangles the assembly evaluates on (the solving thread, the helper) when it runs on
    /// two threads (the same gate as [`Engine::split_sizes`]'s pool, with the internal node
    /// numbering); None when it runs on one.
    pub fn assembly_halves(&self) -> Option<(usize, usize)> {
        self.solver.assembly_halves()
    }

    /// Seconds of one assembly and of one numeric factorization + solve at the committed
    /// state (best of `repeats`): the per-iteration floor the benchmark compares against.
    pub fn time_floor(&mut self, repeats: usize) -> (f64, f64) {
        self.tangent = None;
        self.solver.time_floor(
            &self.model,
            &self.state.displacement,
            &self.state.applied,
            repeats,
        )
    }

    /// [`Engine::time_floor`] with the factorization and the solve timed apart: (assembly,
    /// factorization, solve) seconds, each the best of `repeats`.
    pub fn time_floor_parts(&mut self, repeats: usize) -> (f64, f64, f64) {
        self.tangent = None;
        self.solver.time_floor_parts(
            &self.model,
            &self.state.displacement,
            &self.state.applied,
            repeats,
        )
    }

    /// Numeric factorizations of the tangent since the engine was built (the scaling
    /// benchmark's count; `StepReport::iterations` counts Newton iterations).
    pub fn factorizations(&self) -> usize {
        self.solver.factorizations()
    }

    /// Factorizations, inexact-Newton directions, their preconditioner solves and failed
    /// attempts since the engine was built (the scaling benchmark's columns).
    pub fn linear_counts(&self) -> crate::solver::linear::Counts {
        self.solver.linear_counts()
    }

    /// Whether this model's Newton directions may come from conjugate gradients on an earlier
    /// factorization (`solver.inexact_newton`, `auto` decided by the tangent's size).
    pub fn inexact_newton(&self) -> bool {
        self.solver.inexact_newton()
    }

    /// Outputs, membrane evaluations, wrinkle codes and tension angles of the committed state.
    /// Its working memory (element evaluations, residual and load vectors) is probed first
    /// (always, also with `debug.skip_memory_probes`); on failure nothing is changed.
    fn refresh_outputs(&mut self) -> Result<(), Error> {
        let dofs = self.model.dof_count() as u64;
        let triangles = self.model.triangles.len() as u64;
        let evaluation = std::mem::size_of::<Evaluation>() as u64;
        memory::probe(
            (4 * 8 * dofs).saturating_add(triangles.saturating_mul(2 * evaluation + 16)),
            "the outputs",
        )?;
        self.tangent = None;
        let s = &self.state;
        // The assembly reads the committed plastic strains from the model (model/state.rs).
        self.model.plastic.set(&s.plastic);
        // The last committed state's evaluations are overwritten in place: the end of a step
        // touches no fresh pages for them (58 MB at the 1M disc).
        let reused = std::mem::take(&mut self.membranes);
        let committed =
            self.solver
                .evaluate_committed_into(&self.model, &s.displacement, &s.applied, reused);
        self.outputs = results::evaluate(
            &self.model,
            &s.displacement,
            &s.applied,
            s.last_iterations,
            &committed,
            &s.slip_state,
        );
        let membranes = committed.membranes;
        self.state.wrinkle = membranes.iter().map(|e| e.state).collect();
        self.state.tension_angle = membranes.iter().map(|e| e.angle).collect();
        self.membranes = membranes;
        self.motion_outputs();
        self.natural_frequency_outputs()
    }

    /// The outputs of the committed motion: velocities, accelerations and the kinetic energy
    /// (0 in a quasi-static scene).
    fn motion_outputs(&mut self) {
        let s = &self.state;
        for (slot, probe) in self.model.probes.iter().enumerate() {
            let value = match probe {
                ProbeModel::Velocity { dof } => s.velocity.get(*dof).copied().unwrap_or(0.0),
                ProbeModel::Acceleration { dof } => {
                    s.acceleration.get(*dof).copied().unwrap_or(0.0)
                }
                ProbeModel::KineticEnergy => {
                    self.solver
                        .kinetic_energy(&self.model, self.model.mass_kind, &s.velocity)
                }
                _ => continue,
            };
            self.outputs[slot] = value;
        }
    }

    /// Rebuild model and solver workspace from the scene with the current parameter values.
    /// The old ones are dropped first (a rebuild must not need twice the memory); if the
    /// memory for the new ones cannot be had, the error is returned and the model stays stale
    /// (the next solve tries again).
    fn rebuild(&mut self) -> Result<(), Error> {
        self.tangent = None;
        let mut scene = self.scene.clone();
        for (p, value) in scene.parameters.clone().iter().zip(&self.state.parameters) {
            variables::set_parameter_value(&mut scene, &p.target, *value);
        }
        let model = Model::try_build(&scene)?;
        let solver = Solver::try_new(&model, settings(&scene))?;
        self.model = model;
        self.solver = solver;
        self.model_stale = false;
        Ok(())
    }
}

/// What the committed state is the end of, for its derivatives (`engine/derivatives.rs`).
#[derive(Clone, Debug, PartialEq)]
pub enum LastStep {
    /// A static equilibrium: a quasi-static scene's, the initial one of a scene with time
    /// integration, or the start state after a reset.
    Static,
    /// A step of time integration: its number of sub-steps, the length Δt (s) of the last,
    /// whether it reached its end (not after an FMI 3 early return), the end points of its
    /// sub-steps when there were several (None: one, or more than `dynamic::MAX_CHAIN`), and
    /// whether it was a cheap step at rest (every sub-step's end point the committed state).
    Dynamic {
        substeps: usize,
        dt: f64,
        whole: bool,
        points: Option<Vec<crate::solver::dynamic::SubStepPoint>>,
        rest: bool,
    },
    /// A state of a scene with time integration set from outside: the step that ended at it
    /// is not known.
    Restored,
}

impl LastStep {
    /// The last step of a settled engine's cheap step (`Engine::keep`) of length `duration`:
    /// at rest in equilibrium under unchanged inputs, each sub-step would have ended where it
    /// started, in the sub-steps a step of that length takes (`DynamicPath::begin`).
    /// Nothing is copied (the cheap step allocates nothing): the derivative takes the end
    /// points from the committed state.
    pub(crate) fn kept(scene: &crate::scene::Scene, duration: f64) -> LastStep {
        match integration(scene) {
            Some(i) if duration > 0.0 => {
                let pieces = i
                    .max_time_step
                    .map_or(1.0, |m| (duration / m * (1.0 - 1e-9)).ceil().max(1.0));
                LastStep::Dynamic {
                    substeps: pieces as usize,
                    dt: duration / pieces,
                    whole: true,
                    points: None,
                    rest: true,
                }
            }
            _ => LastStep::Static,
        }
    }

    /// After a state is set from outside.
    pub(crate) fn restored(scene: &crate::scene::Scene) -> LastStep {
        match integration(scene) {
            Some(_) => LastStep::Restored,
            None => LastStep::Static,
        }
    }
}

/// The solver's settings from the scene's solver section.
fn settings(scene: &Scene) -> Settings {
    let s = &scene.solver;
    Settings {
        tolerance: s.tolerance,
        max_iterations: s.max_iterations,
        max_step_iterations: s.max_step_iterations,
        initial_increment: s.initial_increment,
        min_increment: s.min_increment,
        target_iterations: s.target_iterations,
        continuation_strain: s.prestress_continuation,
        proximal_start: s.proximal_continuation,
        overshoot_ratio: s.overshoot_continuation,
        line_search: s.line_search,
        arc_length_path: s.path == crate::scene::PathMethod::ArcLength,
        arc_length: s.arc_length.unwrap_or(0.0),
        threads: s.threads,
        node_order: match s.node_order {
            crate::scene::NodeOrder::Rings => crate::solver::renumber::NodeOrder::Rings,
            crate::scene::NodeOrder::Rcm => crate::solver::renumber::NodeOrder::Rcm,
            crate::scene::NodeOrder::Hilbert => crate::solver::renumber::NodeOrder::Hilbert,
            crate::scene::NodeOrder::Given => crate::solver::renumber::NodeOrder::Given,
        },
        inexact_newton: match s.inexact_newton {
            crate::scene::InexactNewton::Auto => crate::solver::InexactNewton::Auto,
            crate::scene::InexactNewton::On => crate::solver::InexactNewton::On,
            crate::scene::InexactNewton::Off => crate::solver::InexactNewton::Off,
        },
        ..Settings::default()
    }
}

/// Whether a scene integrates in time (`dynamics.time_integration`).
fn is_dynamic(scene: &Scene) -> bool {
    scene
        .dynamics
        .as_ref()
        .is_some_and(|d| d.time_integration.is_some())
}

/// The time integration's settings of a scene (None: quasi-static).
pub(crate) fn integration(scene: &Scene) -> Option<crate::solver::Integration> {
    let d = scene.dynamics.as_ref()?;
    let t = d.time_integration.as_ref()?;
    Some(crate::solver::Integration {
        rho_inf: t.rho_inf,
        max_time_step: t.max_time_step,
        mass: d.mass,
        rayleigh_alpha: d.rayleigh_alpha,
        rayleigh_beta: d.rayleigh_beta,
    })
}

fn type_name(t: VarType) -> &'static str {
    match t {
        VarType::Real => "Real",
        VarType::Integer => "Integer",
        VarType::UInt8 => "UInt8",
    }
}

fn initial_state(scene: &Scene, vars: &[Variable], model: &Model) -> Result<EngineState, Error> {
    let motion = if is_dynamic(scene) {
        model.dof_count()
    } else {
        0
    };
    let start = |b: fn(Binding) -> bool| -> Vec<f64> {
        vars.iter()
            .filter(|v| b(v.binding))
            .map(|v| v.start.unwrap_or(0.0))
            .collect()
    };
    let inputs = start(|b| matches!(b, Binding::Input(_)));
    let parameters = start(|b| matches!(b, Binding::Parameter(_)));
    debug_assert_eq!(inputs.len(), model.loads.len());
    const WHAT: &str = "the state";
    Ok(EngineState {
        displacement: memory::zeros(model.unknown_count(), WHAT)?,
        slip_state: memory::zeros(model.slips.len(), WHAT)?,
        applied: vec![0.0; inputs.len()],
        inputs,
        parameters,
        last_iterations: 0,
        wrinkle: memory::zeros(model.triangles.len(), WHAT)?,
        tension_angle: memory::zeros(model.triangles.len(), WHAT)?,
        plastic: memory::zeros(model.plastic_len(), WHAT)?,
        velocity: memory::zeros(motion, WHAT)?,
        acceleration: memory::zeros(motion, WHAT)?,
    })
}

fn check_bounds(var: &Variable, value: f64) -> Result<(), Error> {
    let out = |why: String| Error::OutOfRange {
        vr: var.value_reference,
        name: var.name.clone(),
        value,
        why,
    };
    if let Some(min) = var.min {
        if value < min {
            return Err(out(format!("below min = {min}")));
        }
    }
    if let Some(max) = var.max {
        if value > max {
            return Err(out(format!("above max = {max}")));
        }
    }
    Ok(())
}

/// Physical range of a parameter: the same rules validation applies to the scene field.
fn check_parameter(scene: &Scene, var: &Variable, index: usize, value: f64) -> Result<(), Error> {
    let mut trial = scene.clone();
    variables::set_parameter_value(&mut trial, &scene.parameters[index].target, value);
    let problems = validate::validate(&trial);
    match problems.first() {
        None => Ok(()),
        Some(p) => Err(Error::OutOfRange {
            vr: var.value_reference,
            name: var.name.clone(),
            value,
            why: p.to_string(),
        }),
    }
}

impl Variable {
    /// Parameters with fixed variability may not change after initialization.
    pub fn is_tunable(&self) -> bool {
        self.variability == Variability::Tunable
    }
}
