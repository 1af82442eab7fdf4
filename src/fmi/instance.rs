//! One FMU instance in safe Rust: the engine, the calling-sequence state, the experiment, the
//! logger. Every FMI function is a method here; the C shims in `abi.rs` only turn pointers into
//! references, slices and closures.
//!
//! Each method runs through [`Instance::call`]:
//!
//! ```text
//! 1. the function must be legal in the current state   else "fmiX: illegal call in state S"
//! 2. the body runs; Err(crate::Error) is logged as "fmiX: <its text>" (logStatusError)
//!    -> fmi2Error
//! 3. with logCalls enabled: "fmiX(arguments) -> status"
//! ```
//!
//! An illegal call or argument changes nothing. Only an internal failure (a caught panic, an
//! initial equilibrium that does not converge) moves the instance to the Error state.

mod derivatives;
pub(crate) mod fmi3;
mod fmu_state;
mod status;

use super::fmi2_ffi::{Status, FMI2_COSIMULATION};
use super::fsm::{FsmState, Func};
use super::logging::{escape, Category, Logger};
use super::snapshot::Experiment;
use super::uri::file_uri_to_path;
use super::worker::Worker;
use crate::description;
use crate::engine::{Engine, EngineState};
use crate::error::Error;
use crate::scene::Scene;
use crate::solver::StepReport;
use crate::variables::{Causality, VarType};

/// Relative tolerance on communication points: |t - expected| <= TIME_TOLERANCE · max(1, |t|).
pub const TIME_TOLERANCE: f64 = 1e-9;

type Outcome = Result<Status, Error>;

/// The arguments of `fmi2Instantiate` that matter, as Rust values.
pub struct InstantiateArgs<'a> {
    pub instance_name: Option<&'a str>,
    pub fmu_type: i32,
    pub guid: Option<&'a str>,
    pub resource_location: Option<&'a str>,
}

pub struct Instance {
    guid: String,
    logger: Logger,
    engine: Engine,
    fsm: FsmState,
    experiment: Experiment,
    /// The current communication point.
    time: f64,
    last_successful_time: f64,
    wants_to_terminate: bool,
    /// A panic may have left the engine half-updated: rebuild it before it is used again.
    poisoned: bool,
    /// Initialization Mode: the committed state at its start, from which every initial
    /// equilibrium is solved (so the result does not depend on when outputs were read).
    init_base: Option<EngineState>,
    /// Initialization Mode: the initial equilibrium for the current inputs is committed.
    init_solved: bool,
    /// The thread the solves run on (joined when the instance is dropped; see `worker.rs`).
    worker: Worker,
    /// FMI 3: the master's intermediate-update callback (steps then report every load
    /// increment) and whether it allows an early return.
    intermediate: Option<super::fmi3_ffi::IntermediateUpdate>,
    early_return_allowed: bool,
}

impl Instance {
    /// `fmi2Instantiate`: None (after logging why) when an argument, the scene or the GUID is
    /// wrong.
    pub fn instantiate(args: &InstantiateArgs, logger: Logger) -> Option<Instance> {
        // The engine is built on the instance's worker: a scene that asks for form finding
        // factorizes while it is built, and the factorization's thread-locals must not land on
        // the master's thread (worker.rs).
        let worker = Worker::new();
        match worker.run(|| build_engine_guarded(args)) {
            Ok((engine, guid)) => {
                let instance = Instance::new(engine, guid, logger, worker);
                instance.logger.log(
                    Category::Calls,
                    &format!("fmi2Instantiate({}) -> instance", describe(args)),
                );
                instance.log_memory();
                instance.log_warnings();
                Some(instance)
            }
            Err(message) => {
                logger.log(
                    Category::StatusError,
                    &format!("fmi2Instantiate: {message}"),
                );
                None
            }
        }
    }

    fn new(engine: Engine, guid: String, logger: Logger, worker: Worker) -> Instance {
        Instance {
            guid,
            logger,
            engine,
            fsm: FsmState::Instantiated,
            experiment: Experiment::default(),
            time: 0.0,
            last_successful_time: 0.0,
            wants_to_terminate: false,
            poisoned: false,
            init_base: None,
            init_solved: false,
            worker,
            intermediate: None,
            early_return_allowed: false,
        }
    }

    /// The model's memory on the solver category at instantiation: the engine's estimate of
    /// model and solver and the host process's peak resident set so far (docs/performance.md,
    /// memory).
    pub(crate) fn log_memory(&self) {
        if self.logger.enabled(Category::Solver) {
            let line = crate::memory::report(self.engine.memory_estimate());
            self.logger.log(
                Category::Solver,
                &format!(
                    "{line}; {} unknowns, {} factor entries",
                    self.engine.free_dofs(),
                    self.engine.factor_nonzeros()
                ),
            );
        }
    }

    /// The scene's plausibility warnings (`scene::plausibility`: a prestress implying more
    /// than 5 % strain, a modulus far outside its material's usual range, a sleeve penalty
    /// softer than what it ties) on logStatusWarning at instantiation. The instance is built
    /// all the same: they are warnings, not errors.
    pub(crate) fn log_warnings(&self) {
        if self.logger.enabled(Category::StatusWarning) {
            for w in crate::scene::plausibility::warnings(self.engine.scene()) {
                self.logger
                    .log(Category::StatusWarning, &format!("fmi2Instantiate: {w}"));
            }
        }
    }

    pub fn state(&self) -> FsmState {
        self.fsm
    }

    pub fn time(&self) -> f64 {
        self.time
    }

    pub fn guid(&self) -> &str {
        &self.guid
    }

    pub fn engine(&self) -> &Engine {
        &self.engine
    }

    /// Run one FMI function: state check, body, error logging, call trace.
    fn call(
        &mut self,
        func: Func,
        args: String,
        body: impl FnOnce(&mut Self) -> Outcome,
    ) -> Status {
        self.call_as(func.name(), func, args, body)
    }

    /// [`Instance::call`] for a function named `name` that is legal where `func` is (FMI 3
    /// functions without an FMI 2 counterpart of the same name).
    fn call_as(
        &mut self,
        name: &str,
        func: Func,
        args: String,
        body: impl FnOnce(&mut Self) -> Outcome,
    ) -> Status {
        let outcome = if func.allowed_in(self.fsm) {
            body(self)
        } else {
            Err(Error::IllegalCall {
                state: self.fsm.to_string(),
            })
        };
        let status = match outcome {
            Ok(status) => status,
            Err(message) => {
                self.logger
                    .log(Category::StatusError, &format!("{name}: {message}"));
                Status::Error
            }
        };
        if self.logger.enabled(Category::Calls) {
            self.logger.log(
                Category::Calls,
                &format!("{name}({args}) -> {}", status.name()),
            );
        }
        status
    }

    /// The arguments shown in the logCalls trace (only formatted when it is enabled).
    fn args(&self, show: impl FnOnce() -> String) -> String {
        if self.logger.enabled(Category::Calls) {
            show()
        } else {
            String::new()
        }
    }

    /// `fmi2FreeInstance` is about to drop the instance: trace the call.
    pub fn freeing(&mut self) -> Status {
        self.logger.log(Category::Calls, "fmi2FreeInstance()");
        Status::Ok
    }

    /// A panic was caught in `function`: log it and go to the Error state.
    pub fn panicked(&mut self, function: &str, message: &str) {
        self.fsm = FsmState::Error;
        self.poisoned = true;
        self.logger.log(
            Category::StatusError,
            &format!("{function}: internal error ({message}); the instance is now in state Error, fmi2Reset or fmi2SetFMUstate recovers it"),
        );
    }

    /// A function this FMU does not support: log why, return fmi2Error.
    pub fn unsupported(&mut self, func: Func, why: &str) -> Status {
        self.call(func, String::new(), |_| {
            Err(Error::Unsupported(why.to_string()))
        })
    }

    pub fn set_debug_logging(&mut self, on: bool, names: Result<Vec<String>, Error>) -> Status {
        let args = self.args(|| {
            format!(
                "loggingOn={}, categories={:?}",
                on as i32,
                names.as_deref().unwrap_or_default()
            )
        });
        self.call(Func::SetDebugLogging, args, |s| {
            let names = names?;
            let names: Vec<&str> = names.iter().map(String::as_str).collect();
            s.logger.set(on, &names)?;
            Ok(Status::Ok)
        })
    }

    pub fn setup_experiment(
        &mut self,
        tolerance: Option<f64>,
        start_time: f64,
        stop_time: Option<f64>,
    ) -> Status {
        let args = self.args(|| {
            format!(
                "tolerance={}, startTime={start_time}, stopTime={}",
                shown(tolerance),
                shown(stop_time)
            )
        });
        self.call(Func::SetupExperiment, args, |s| {
            s.set_experiment(tolerance, start_time, stop_time)?;
            Ok(Status::Ok)
        })
    }

    /// Check and keep the experiment (fmi2SetupExperiment, the first half of
    /// fmi3EnterInitializationMode).
    fn set_experiment(
        &mut self,
        tolerance: Option<f64>,
        start_time: f64,
        stop_time: Option<f64>,
    ) -> Result<(), Error> {
        check_experiment(tolerance, start_time, stop_time)?;
        self.experiment = Experiment {
            done: true,
            tolerance,
            start_time,
            stop_time,
        };
        Ok(())
    }

    pub fn enter_initialization_mode(&mut self) -> Status {
        self.call(Func::EnterInitializationMode, String::new(), |s| {
            if !s.experiment.done {
                return Err(Error::CallFirst {
                    first: "fmi2SetupExperiment",
                    then: "fmi2EnterInitializationMode",
                });
            }
            s.begin_initialization();
            Ok(Status::Ok)
        })
    }

    /// Into Initialization Mode: initial equilibria are solved from the state now.
    fn begin_initialization(&mut self) {
        self.fsm = FsmState::InitializationMode;
        self.init_base = Some(self.engine.state().clone());
        self.init_solved = false;
    }

    /// Solve the equilibrium under the current inputs and parameters (the start values unless
    /// the master set others), unless outputs read in Initialization Mode already did.
    pub fn exit_initialization_mode(&mut self) -> Status {
        self.call(Func::ExitInitializationMode, String::new(), |s| {
            s.solve_initial()?;
            s.fsm = FsmState::StepComplete;
            s.init_base = None;
            s.time = s.experiment.start_time;
            s.last_successful_time = s.time;
            Ok(Status::Ok)
        })
    }

    /// The initial equilibrium under the current inputs and parameters, always solved from
    /// the state at the start of Initialization Mode. Not converged: the instance goes to
    /// Error (there is no equilibrium to continue from).
    fn solve_initial(&mut self) -> Result<(), Error> {
        if self.init_solved {
            return Ok(());
        }
        if let Some(base) = &self.init_base {
            let current = self.engine.state();
            let start = EngineState {
                inputs: current.inputs.clone(),
                parameters: current.parameters.clone(),
                ..base.clone()
            };
            self.on_worker(|engine| engine.set_state(start))?;
        }
        // The initial equilibrium is static (at rest), also with time integration.
        self.engine.set_step_duration(0.0);
        let report = self.solve()?;
        if !report.converged() {
            self.fsm = FsmState::Error;
            return Err(Error::InitialEquilibrium(reached(&report)));
        }
        self.init_solved = true;
        Ok(())
    }

    /// In Initialization Mode, outputs are the initial equilibrium: solve it before the first
    /// output is read (and again after an input or parameter changed).
    fn prepare_outputs(&mut self, vr: &[u32]) -> Result<(), Error> {
        let reads_output = || {
            let vars = self.engine.variables();
            vr.iter().any(|r| {
                vars.iter()
                    .any(|v| v.value_reference == *r && v.causality == Causality::Output)
            })
        };
        if self.fsm == FsmState::InitializationMode && reads_output() {
            self.solve_initial()?;
        }
        Ok(())
    }

    pub fn terminate(&mut self) -> Status {
        self.call(Func::Terminate, String::new(), |s| {
            s.fsm = FsmState::Terminated;
            Ok(Status::Ok)
        })
    }

    /// Back to Instantiated with the start values; works from every state.
    pub fn reset(&mut self) -> Status {
        self.call(Func::Reset, String::new(), |s| {
            if !s.heal()? {
                s.on_worker(|engine| engine.reset())?;
            }
            s.fsm = FsmState::Instantiated;
            s.experiment = Experiment::default();
            s.time = 0.0;
            s.last_successful_time = 0.0;
            s.wants_to_terminate = false;
            s.init_base = None;
            s.init_solved = false;
            Ok(Status::Ok)
        })
    }

    /// `work` on the engine on the instance's worker thread: everything that may evaluate the
    /// outputs (a restored state, a reset; a `natural_frequency` output factorizes), so that
    /// no thread-local of the linear algebra lands on the master's thread and keeps the
    /// library mapped after FreeInstance (worker.rs).
    pub(super) fn on_worker<T: Send>(&mut self, work: impl FnOnce(&mut Engine) -> T + Send) -> T {
        let engine = &mut self.engine;
        self.worker.run(|| work(engine))
    }

    /// After a panic, rebuild the engine from its scene. Returns whether it did.
    fn heal(&mut self) -> Result<bool, Error> {
        if !self.poisoned {
            return Ok(false);
        }
        let scene = self.engine.scene().clone();
        self.engine = self.worker.run(|| Engine::try_new(scene))?;
        self.poisoned = false;
        Ok(true)
    }

    /// The cheap step (docs/fmu.md, the cost of a step): when the inputs and parameters are
    /// those of the committed equilibrium, the step keeps it on the calling thread, with no
    /// hand-over to the worker (nothing runs that could touch faer's thread-locals or need the
    /// worker's stack). None: a solve is needed.
    fn keep(&mut self) -> Result<Option<StepReport>, Error> {
        if self.poisoned {
            return Err(Error::Poisoned);
        }
        let kept = self.engine.keep();
        if kept.is_some() && self.logger.enabled(Category::Solver) {
            self.logger.log(
                Category::Solver,
                "inputs and parameters unchanged since the last converged step: equilibrium kept, no solve",
            );
        }
        Ok(kept)
    }

    /// `engine.solve()` with its log lines sent to logSolver.
    fn solve(&mut self) -> Result<StepReport, Error> {
        if self.poisoned {
            return Err(Error::Poisoned);
        }
        let engine = &mut self.engine;
        let report = self.worker.run(|| engine.solve());
        if self.logger.enabled(Category::Solver) {
            for line in &report.log {
                self.logger.log(Category::Solver, line);
            }
        }
        Ok(report)
    }

    pub fn get_real(
        &mut self,
        vr: Result<&[u32], Error>,
        values: Result<&mut [f64], Error>,
    ) -> Status {
        let args = self.args(|| format!("vr={:?}", vr.as_deref().unwrap_or_default()));
        self.call(Func::GetReal, args, |s| {
            let vr = vr?;
            s.prepare_outputs(vr)?;
            for (r, v) in vr.iter().zip(values?.iter_mut()) {
                *v = s.engine.get_real(*r)?;
            }
            Ok(Status::Ok)
        })
    }

    pub fn get_integer(
        &mut self,
        vr: Result<&[u32], Error>,
        values: Result<&mut [i32], Error>,
    ) -> Status {
        let args = self.args(|| format!("vr={:?}", vr.as_deref().unwrap_or_default()));
        self.call(Func::GetInteger, args, |s| {
            let vr = vr?;
            s.prepare_outputs(vr)?;
            for (r, v) in vr.iter().zip(values?.iter_mut()) {
                *v = s.engine.get_integer(*r)?;
            }
            Ok(Status::Ok)
        })
    }

    /// Get or set Boolean / String: this FMU has no such variables, so any reference is
    /// unknown.
    pub fn no_such_variables(
        &mut self,
        func: Func,
        kind: &str,
        vr: Result<&[u32], Error>,
    ) -> Status {
        let args = self.args(|| format!("vr={:?}", vr.as_deref().unwrap_or_default()));
        self.call(func, args, |_| match vr?.first() {
            Some(r) => Err(Error::Argument {
                argument: "vr",
                message: format!(
                    "no {kind} variable has value reference {r} (this FMU has no {kind} variables)"
                ),
            }),
            None => Ok(Status::Ok),
        })
    }

    /// Set inputs and parameters. All or nothing: on any rejected value the engine state is
    /// restored to what it was before the call.
    pub fn set_real(&mut self, vr: Result<&[u32], Error>, values: Result<&[f64], Error>) -> Status {
        let args = self.args(|| {
            format!(
                "vr={:?}, value={:?}",
                vr.as_deref().unwrap_or_default(),
                values.as_deref().unwrap_or_default()
            )
        });
        self.call(Func::SetReal, args, |s| {
            let (vr, values) = (vr?, values?);
            for r in vr {
                s.check_settable(*r, VarType::Real)?;
            }
            let backup = s.engine.state().clone();
            for (r, v) in vr.iter().zip(values) {
                if let Err(e) = s.engine.set_real(*r, *v) {
                    let _ = s.on_worker(|engine| engine.set_state(backup));
                    return Err(e);
                }
            }
            s.init_solved &= vr.is_empty();
            Ok(Status::Ok)
        })
    }

    /// There are no Integer inputs or parameters: every reference is an output or unknown.
    pub fn set_integer(
        &mut self,
        vr: Result<&[u32], Error>,
        values: Result<&[i32], Error>,
    ) -> Status {
        let args = self.args(|| {
            format!(
                "vr={:?}, value={:?}",
                vr.as_deref().unwrap_or_default(),
                values.as_deref().unwrap_or_default()
            )
        });
        self.call(Func::SetInteger, args, |s| {
            values?;
            match vr?.first() {
                Some(r) => {
                    s.check_settable(*r, VarType::Integer)?;
                    Err(Error::Argument {
                        argument: "vr",
                        message: format!("value reference {r} cannot be set as an Integer"),
                    })
                }
                None => Ok(Status::Ok),
            }
        })
    }

    /// Whether the variable may be set now (docs/fmu.md, failure policy): outputs never; fixed parameters
    /// before the end of initialization only; inputs and tunable parameters also at
    /// communication points (the state mask already excludes the other states).
    fn check_settable(&self, vr: u32, var_type: VarType) -> Result<(), Error> {
        let var = self.engine.variable(vr, var_type)?;
        let (name, why) = match var.causality {
            Causality::Output => (&var.name, "it is an output"),
            Causality::Parameter if self.fsm == FsmState::StepComplete && !var.is_tunable() => (
                &var.name,
                "it is a fixed parameter, settable only before fmi2ExitInitializationMode",
            ),
            _ => return Ok(()),
        };
        Err(Error::NotSettable {
            vr,
            name: name.clone(),
            why: why.into(),
        })
    }

    /// `fmi2DoStep`: reach the equilibrium under the inputs set before the call. Not converged:
    /// keep the last equilibrium, go to StepFailed and ask the master to stop (Discard).
    pub fn do_step(&mut self, t: f64, h: f64, no_set_prior: bool) -> Status {
        let args = self.args(|| {
            format!(
                "currentCommunicationPoint={t}, communicationStepSize={h}, noSetFMUStatePriorToCurrentPoint={}",
                no_set_prior as i32
            )
        });
        self.call(Func::DoStep, args, |s| {
            let report = s.step(t, h)?;
            if report.converged() {
                return Ok(Status::Ok);
            }
            s.fsm = FsmState::StepFailed;
            s.wants_to_terminate = true;
            s.time = t;
            s.last_successful_time = t;
            s.log_discard(t, h, &report);
            Ok(Status::Discard)
        })
    }

    /// The step from `t` to `t + h` of both versions: check the times, solve (or take the
    /// debug switches' forced outcome); converged: the instance's time moves to `t + h`.
    fn step(&mut self, t: f64, h: f64) -> Result<StepReport, Error> {
        self.check_step(t, h)?;
        // With time integration the step advances time by h (docs/dynamics.md).
        self.engine.set_step_duration(h);
        let report = match self.forced_failure(t + h) {
            Some(report) => report,
            None => match self.keep()? {
                Some(report) => report,
                None => self.solve()?,
            },
        };
        if report.converged() {
            self.time = t + h;
            self.last_successful_time = self.time;
        }
        Ok(report)
    }

    /// The scene's debug switches (test variants only): a step ending after `panic_after_time`
    /// panics here, one ending after `fail_after_time` is reported as not converged, without
    /// touching the engine, exactly as a real non-convergence leaves it.
    fn forced_failure(&self, end: f64) -> Option<StepReport> {
        let debug = self.engine.debug();
        let after = |at: Option<f64>| at.filter(|t| end > t + TIME_TOLERANCE * t.abs().max(1.0));
        if let Some(at) = after(debug.panic_after_time) {
            panic!("debug.panic_after_time = {at}: forced panic in the step to t = {end}");
        }
        after(debug.fail_after_time)
            .map(|at| StepReport::failed_with(format!("forced by debug.fail_after_time = {at}")))
    }

    /// The time rules of a step (docs/fmu.md, "Stepping"):
    /// - t and h finite, h > 0, and t + h finite;
    /// - t is the instance's time within TIME_TOLERANCE · max(1, |t|);
    /// - time must move: t + h > t in floating point (else the loads would change at a time
    ///   that does not);
    /// - the step may end after stopTime by at most TIME_TOLERANCE · max(|stopTime|, h)
    ///   (relative: round-off of summed steps, not a way to step past the end).
    fn check_step(&self, t: f64, h: f64) -> Result<(), Error> {
        let bad = |argument: &'static str, message: String| Error::Argument { argument, message };
        if !(h.is_finite() && h > 0.0) {
            return Err(bad(
                "communicationStepSize",
                format!("communicationStepSize = {h} must be positive and finite"),
            ));
        }
        if !t.is_finite() || (t - self.time).abs() > TIME_TOLERANCE * t.abs().max(1.0) {
            return Err(bad(
                "currentCommunicationPoint",
                format!(
                    "currentCommunicationPoint = {t} does not match the time of the instance: expected {}, got {t}",
                    self.time
                ),
            ));
        }
        let end = t + h;
        if !end.is_finite() {
            return Err(bad(
                "communicationStepSize",
                format!("the step from {t} by {h} ends at a non-finite time ({end})"),
            ));
        }
        if end == t {
            return Err(bad(
                "communicationStepSize",
                format!(
                    "communicationStepSize = {h} is below the resolution of time at {t}: t + h == t in floating point, so time would not move"
                ),
            ));
        }
        match self.experiment.stop_time {
            Some(stop) if end > stop + TIME_TOLERANCE * stop.abs().max(h) => Err(bad(
                "communicationStepSize",
                format!(
                    "the step from {t} to {end} ends after stopTime = {stop} (allowed: {:e} past it, {TIME_TOLERANCE:e} of max(|stopTime|, h))",
                    TIME_TOLERANCE * stop.abs().max(h)
                ),
            )),
            _ => Ok(()),
        }
    }

    /// logStatusDiscard: how far the step got, why it stopped, and the inputs by name and
    /// value reference (`P (#r1#) = 100`).
    fn log_discard(&self, t: f64, h: f64, report: &StepReport) {
        if !self.logger.enabled(Category::StatusDiscard) {
            return;
        }
        let plain = format!(
            "fmi2DoStep: the step from {t} to {} did not converge: {}; the state stays at t = {t}, fmi2Terminated is true. Inputs:",
            t + h,
            reached(report)
        );
        let mut message = escape(&plain);
        for var in self
            .engine
            .variables()
            .iter()
            .filter(|v| v.causality == Causality::Input)
        {
            if let Ok(value) = self.engine.get_real(var.value_reference) {
                // Name and reference: fmpy's command-line logger prints `#r<vr>#` as it is,
                // importers that resolve it show the name twice (FMI 2.0 §2.1.5).
                message.push_str(&format!(
                    " {} (#r{}#) = {value}",
                    escape(&var.name),
                    var.value_reference
                ));
            }
        }
        self.logger.log_formatted(Category::StatusDiscard, &message);
    }
}

/// [`build_engine`] with a panic turned into a message for the logger (Instantiate then returns
/// NULL with a reason instead of NULL alone).
fn build_engine_guarded(args: &InstantiateArgs) -> Result<(Engine, String), Error> {
    std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| build_engine(args))).unwrap_or_else(
        |payload| {
            let what = payload
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| payload.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "unknown panic".into());
            Err(Error::Internal(format!(
                "internal error while building the model ({}); no instance was created",
                crate::scene::read::clip(&what)
            )))
        },
    )
}

/// Check the instantiation arguments, read the scene, build the engine, compare the GUID.
fn build_engine(args: &InstantiateArgs) -> Result<(Engine, String), Error> {
    check_instance_name(args.instance_name)?;
    if args.fmu_type != FMI2_COSIMULATION {
        return Err(Error::Argument {
            argument: "fmuType",
            message: format!(
                "fmuType = {} is not supported: this FMU is Co-Simulation only (fmi2CoSimulation = {FMI2_COSIMULATION})",
                args.fmu_type
            ),
        });
    }
    let given_guid = args.guid.ok_or_else(|| null("fmuGUID"))?;
    let location = args
        .resource_location
        .ok_or_else(|| null("fmuResourceLocation"))?;
    let engine = load_engine(location)?;
    let guid = description::guid(engine.scene(), engine.variables());
    if given_guid != guid {
        return Err(Error::Argument {
            argument: "fmuGUID",
            message: format!(
                "GUID mismatch: the master passed {given_guid}, but this binary and its resources have {guid} (was the FMU repackaged with another modelDescription.xml?)"
            ),
        });
    }
    Ok((engine, guid))
}

/// The instance name of both versions' Instantiate: not NULL, not empty.
fn check_instance_name(name: Option<&str>) -> Result<(), Error> {
    match name {
        None => Err(null("instanceName")),
        Some("") => Err(Error::Argument {
            argument: "instanceName",
            message: "instanceName is empty".into(),
        }),
        Some(_) => Ok(()),
    }
}

/// A NULL (string) argument of Instantiate.
fn null(argument: &str) -> Error {
    Error::NullPointer {
        argument: argument.into(),
        length: None,
    }
}

/// `<resources>/scene.json` -> scene -> engine; every error names the file.
fn load_engine(resource_location: &str) -> Result<Engine, Error> {
    load_engine_from(&file_uri_to_path(resource_location)?)
}

/// `<dir>/scene.json` -> scene -> engine; every error names the file.
fn load_engine_from(dir: &std::path::Path) -> Result<Engine, Error> {
    let path = dir.join("scene.json");
    let shown = path.display().to_string();
    let bytes = std::fs::read(&path).map_err(|e| Error::Read {
        path: shown.clone(),
        reason: e.to_string(),
    })?;
    let in_file = |error: Error| Error::InFile {
        path: shown.clone(),
        error: Box::new(error),
    };
    let scene = Scene::parse(&bytes).map_err(|p| in_file(Error::Scene(p)))?;
    Engine::try_new(scene).map_err(in_file)
}

fn check_experiment(tolerance: Option<f64>, start: f64, stop: Option<f64>) -> Result<(), Error> {
    if !start.is_finite() {
        return Err(Error::Argument {
            argument: "startTime",
            message: format!("startTime = {start} must be finite"),
        });
    }
    if let Some(stop) = stop {
        if !(stop.is_finite() && stop >= start) {
            return Err(Error::Argument {
                argument: "stopTime",
                message: format!(
                    "stopTime = {stop} must be finite and not before startTime = {start}"
                ),
            });
        }
    }
    match tolerance {
        Some(tol) if !(tol.is_finite() && tol > 0.0) => Err(Error::Argument {
            argument: "tolerance",
            message: format!("tolerance = {tol} must be positive and finite"),
        }),
        _ => Ok(()),
    }
}

/// "reached 37.5 % of the load change (why)".
fn reached(report: &StepReport) -> String {
    format!(
        "reached {:.4} % of the load change after {} Newton iterations ({})",
        report.reached * 100.0,
        report.iterations,
        report.message
    )
}

/// An optional number for the call trace.
fn shown(value: Option<f64>) -> String {
    value.map_or("undefined".into(), |v| v.to_string())
}

fn describe(args: &InstantiateArgs) -> String {
    format!(
        "instanceName={:?}, fmuType={}, fmuGUID={:?}, fmuResourceLocation={:?}",
        args.instance_name.unwrap_or_default(),
        args.fmu_type,
        args.guid.unwrap_or_default(),
        args.resource_location.unwrap_or_default()
    )
}

/// A small pretensioned cable for unit tests.
#[cfg(test)]
pub(crate) const TEST_SCENE: &str = r#"{"format": 1, "name": "c",
    "geometry": {"nodes": [[0, 0, 0], [1, 0, 0], [2, 0, 0]]},
    "cables": [{"name": "c", "nodes": [0, 1, 2], "EA": 1e5, "pretension": 100}],
    "supports": [{"nodes": [0, 2], "fix": ["x", "y", "z"]}, {"nodes": [1], "fix": ["y"]}]}"#;

#[cfg(test)]
impl Instance {
    /// An instance of [`TEST_SCENE`] without a logger.
    pub(crate) fn for_tests() -> Instance {
        let engine = Engine::try_new(Scene::from_json(TEST_SCENE).unwrap()).unwrap();
        let guid = description::guid(engine.scene(), engine.variables());
        Instance::new(
            engine,
            guid,
            Logger::new(None, std::ptr::null_mut(), "test", false),
            Worker::new(),
        )
    }
}
