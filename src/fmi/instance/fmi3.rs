//! The FMI 3.0 Co-Simulation side of an instance. The same [`Instance`] serves both versions:
//! same engine, worker, state machine, FMU states, logging; what differs lives here.
//!
//! ```text
//! FMI 3                                 here                      FMI 2 counterpart
//! fmi3InstantiateCoSimulation           instantiate_fmi3          fmi2Instantiate (native
//!                                                                 resource path, token)
//! fmi3EnterInitializationMode(tol, t0,  enter_initialization_     fmi2SetupExperiment +
//!   t1)                                   mode_fmi3               fmi2EnterInitializationMode
//! fmi3GetFloat64 / SetFloat64           get_float64 / set_float64 fmi2GetReal / SetReal (+ nValues
//!                                                                 check, `time` at vr 0)
//! fmi3GetInt32 / SetInt32               get_int32 / set_int32     fmi2GetInteger / SetInteger
//! fmi3DoStep(..., out flags)            do_step_fmi3              fmi2DoStep, but a step that
//!                                                                 does not converge leaves the
//!                                                                 state as it was (Discard)
//! other types (Float32, Int8, UInt8..., no_such_variables_fmi3    "no <Type> variable has
//!   Boolean, String, Binary)                                      value reference r"
//! ME, SE, clock, event-mode functions   unsupported_fmi3          Error with the reason
//! ```
//!
//! Messages of the shared methods name the FMI 2 function they implement; the FMI 3 logger
//! (`fmi3_ffi::fmi3_names`) prints the FMI 3 names.

use super::{check_instance_name, load_engine_from, null, reached, shown, Instance};
use crate::description3;
use crate::description3::TIME_VALUE_REFERENCE;
use crate::engine::Engine;
use crate::error::Error;
use crate::fmi::fmi2_ffi::Status;
use crate::fmi::fmi3_ffi::IntermediateUpdate;
use crate::fmi::fsm::Func;
use crate::fmi::logging::{Category, Logger};
use crate::fmi::worker::Worker;
use crate::variables::{Causality, VarType, Variable};

/// The arguments of `fmi3InstantiateCoSimulation` that matter, as Rust values.
pub struct Instantiate3Args<'a> {
    pub instance_name: Option<&'a str>,
    pub instantiation_token: Option<&'a str>,
    pub resource_path: Option<&'a str>,
    pub event_mode_used: bool,
    pub early_return_allowed: bool,
    pub intermediate_update: Option<IntermediateUpdate>,
}

/// The out-arguments of `fmi3DoStep`.
pub struct DoStepOut<'a> {
    pub event_handling_needed: &'a mut bool,
    pub terminate_simulation: &'a mut bool,
    pub early_return: &'a mut bool,
    pub last_successful_time: &'a mut f64,
}

/// A function legal in every state (for bodies that only report that they are unsupported).
const ANY_STATE: Func = Func::CancelStep;

impl Instance {
    /// `fmi3InstantiateCoSimulation`: None (after logging why) when an argument, the scene or
    /// the token is wrong, or when the master wants event mode (`hasEventMode="false"`).
    pub fn instantiate_fmi3(args: &Instantiate3Args, logger: Logger) -> Option<Instance> {
        // Built on the instance's worker, as in fmi2Instantiate (form finding factorizes).
        let worker = Worker::new();
        match worker.run(|| build_fmi3(args)) {
            Ok((engine, token)) => {
                let mut instance = Instance::new(engine, token, logger, worker);
                instance.intermediate = args.intermediate_update;
                instance.early_return_allowed = args.early_return_allowed;
                instance.logger.log(
                    Category::Calls,
                    &format!(
                        "fmi3InstantiateCoSimulation(instanceName={:?}, instantiationToken={:?}, resourcePath={:?}, eventModeUsed={}, earlyReturnAllowed={}) -> instance",
                        args.instance_name.unwrap_or_default(),
                        args.instantiation_token.unwrap_or_default(),
                        args.resource_path.unwrap_or_default(),
                        args.event_mode_used,
                        args.early_return_allowed
                    ),
                );
                instance.log_memory();
                instance.log_warnings();
                Some(instance)
            }
            Err(message) => {
                logger.log(
                    Category::StatusError,
                    &format!("fmi3InstantiateCoSimulation: {message}"),
                );
                None
            }
        }
    }

    /// `fmi3EnterInitializationMode`: the experiment (FMI 2's SetupExperiment) and the entry
    /// into Initialization Mode in one call.
    pub fn enter_initialization_mode_fmi3(
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
        self.call_as(
            "fmi3EnterInitializationMode",
            Func::EnterInitializationMode,
            args,
            |s| {
                s.set_experiment(tolerance, start_time, stop_time)?;
                s.begin_initialization();
                s.time = start_time;
                Ok(Status::Ok)
            },
        )
    }

    /// The variables of the array table that `vr` name, all of type `var_type` (value
    /// reference 0 is `time`, a Float64 scalar), and their total element count, which must be
    /// `n_values`.
    fn resolve_fmi3(
        &self,
        vr: &[u32],
        var_type: VarType,
        n_values: usize,
    ) -> Result<Vec<Option<Variable>>, Error> {
        let mut vars = Vec::with_capacity(vr.len());
        let mut total = 0;
        for &r in vr {
            if r == TIME_VALUE_REFERENCE && var_type == VarType::Real {
                vars.push(None);
                total += 1;
                continue;
            }
            let var = self.engine.array_variable(r, var_type)?;
            total += var.len();
            vars.push(Some(var.clone()));
        }
        if total != n_values {
            return Err(Error::Argument {
                argument: "nValues",
                message: format!(
                    "nValues = {n_values}, expected {total}: the sum of the element counts of the {} variables",
                    vr.len()
                ),
            });
        }
        Ok(vars)
    }

    /// Getters of FMI 3: every element of every variable in order (arrays row-major), `time`
    /// at value reference 0; `nValues` must be the total element count.
    fn get_fmi3<T>(
        &mut self,
        name: &'static str,
        var_type: VarType,
        vr: Result<&[u32], Error>,
        values: Result<&mut [T], Error>,
        n_values: usize,
        convert: fn(f64) -> T,
    ) -> Status {
        let args = self.args(|| format!("vr={:?}", vr.as_deref().unwrap_or_default()));
        let func = match var_type {
            VarType::Real => Func::GetReal,
            _ => Func::GetInteger,
        };
        self.call_as(name, func, args, |s| {
            let vr = vr?;
            let vars = s.resolve_fmi3(vr, var_type, n_values)?;
            let values = values?;
            s.prepare_outputs(vr)?;
            let mut at = 0;
            for var in &vars {
                match var {
                    None => {
                        values[at] = convert(s.time);
                        at += 1;
                    }
                    Some(var) => {
                        for x in s.engine.values(var) {
                            values[at] = convert(*x);
                            at += 1;
                        }
                    }
                }
            }
            Ok(Status::Ok)
        })
    }

    /// `fmi3GetFloat64`.
    pub fn get_float64(
        &mut self,
        vr: Result<&[u32], Error>,
        values: Result<&mut [f64], Error>,
        n_values: usize,
    ) -> Status {
        self.get_fmi3("fmi3GetFloat64", VarType::Real, vr, values, n_values, |x| x)
    }

    /// `fmi3GetInt32`.
    pub fn get_int32(
        &mut self,
        vr: Result<&[u32], Error>,
        values: Result<&mut [i32], Error>,
        n_values: usize,
    ) -> Status {
        self.get_fmi3(
            "fmi3GetInt32",
            VarType::Integer,
            vr,
            values,
            n_values,
            |x| x.round() as i32,
        )
    }

    /// `fmi3GetUInt8` (wrinkle states).
    pub fn get_uint8(
        &mut self,
        vr: Result<&[u32], Error>,
        values: Result<&mut [u8], Error>,
        n_values: usize,
    ) -> Status {
        self.get_fmi3("fmi3GetUInt8", VarType::UInt8, vr, values, n_values, |x| {
            x.round() as u8
        })
    }

    /// `fmi3SetFloat64`: the FMI 2 rules of `fmi2SetReal` (all or nothing) on every element,
    /// after the checks FMI 3 adds (`nValues`, `time` is not settable).
    pub fn set_float64(
        &mut self,
        vr: Result<&[u32], Error>,
        values: Result<&[f64], Error>,
        n_values: usize,
    ) -> Status {
        let elements = match &vr {
            Ok(vr) if vr.contains(&TIME_VALUE_REFERENCE) => Err(Error::NotSettable {
                vr: TIME_VALUE_REFERENCE,
                name: description3::TIME_NAME.into(),
                why: "it is the independent variable (set by fmi3EnterInitializationMode and fmi3DoStep)".into(),
            }),
            Ok(vr) => self
                .resolve_fmi3(vr, VarType::Real, n_values)
                .map(|vars| {
                    vars.iter()
                        .flatten()
                        .flat_map(|v| v.references())
                        .collect::<Vec<u32>>()
                }),
            Err(e) => Err(e.clone()),
        };
        match elements {
            Err(message) => self.call_as("fmi3SetFloat64", Func::SetReal, String::new(), |_| {
                Err(message)
            }),
            Ok(elements) => self.set_real(Ok(&elements), values),
        }
    }

    /// `fmi3SetInt32` / `fmi3SetUInt8`: there are no integer inputs or parameters, so every
    /// reference is an output or unknown (FMI 2's `fmi2SetInteger` rules).
    pub fn set_integer_fmi3(
        &mut self,
        name: &'static str,
        var_type: VarType,
        vr: Result<&[u32], Error>,
        n_values: usize,
    ) -> Status {
        let args = self.args(|| format!("vr={:?}", vr.as_deref().unwrap_or_default()));
        self.call_as(name, Func::SetInteger, args, |s| {
            let vr = vr?;
            let vars = s.resolve_fmi3(vr, var_type, n_values)?;
            match vars.iter().flatten().next() {
                Some(v) => Err(Error::NotSettable {
                    vr: v.value_reference,
                    name: v.name.clone(),
                    why: "it is an output".into(),
                }),
                None => Ok(Status::Ok),
            }
        })
    }

    /// Get or set a variable type this FMU has no variables of: any reference is unknown;
    /// an empty call is OK. `getter` selects the state mask of a getter or a setter.
    pub fn no_such_variables_fmi3(
        &mut self,
        name: &'static str,
        kind: &str,
        getter: bool,
        vr: Result<&[u32], Error>,
    ) -> Status {
        let legal = if getter { Func::GetReal } else { Func::SetReal };
        let args = self.args(|| format!("vr={:?}", vr.as_deref().unwrap_or_default()));
        self.call_as(name, legal, args, |_| match vr?.first() {
            Some(r) => Err(Error::Argument {
                argument: "valueReferences",
                message: format!(
                    "no {kind} variable has value reference {r} (this FMU has Float64, Int32 and UInt8 variables only)"
                ),
            }),
            None => Ok(Status::Ok),
        })
    }

    /// An FMI 3 function this FMU does not support: log why, return fmi3Error.
    pub fn unsupported_fmi3(&mut self, name: &'static str, why: &str) -> Status {
        self.call_as(name, ANY_STATE, String::new(), |_| {
            Err(Error::Unsupported(why.to_string()))
        })
    }

    /// `fmi3DoStep`: reach the equilibrium under the inputs set before the call. Not
    /// converged: the instance stays exactly as it was before the call (same equilibrium,
    /// time, state-machine state) and the call returns fmi3Discard with
    /// `lastSuccessfulTime = currentCommunicationPoint`; the master may change inputs and try
    /// again, restore a state, or terminate. `eventHandlingNeeded` and `terminateSimulation` are
    /// false (no event mode); `earlyReturn` is true only when the master asked for it through
    /// its intermediate-update callback and allowed it at instantiation (`step_reported`).
    pub fn do_step_fmi3(
        &mut self,
        t: f64,
        h: f64,
        no_set_prior: bool,
        out: Result<DoStepOut<'_>, Error>,
    ) -> Status {
        let args = self.args(|| {
            format!(
                "currentCommunicationPoint={t}, communicationStepSize={h}, noSetFMUStatePriorToCurrentPoint={no_set_prior}"
            )
        });
        self.call_as("fmi3DoStep", Func::DoStep, args, |s| {
            let out = out?;
            *out.event_handling_needed = false;
            *out.terminate_simulation = false;
            *out.early_return = false;
            *out.last_successful_time = s.time;
            let (report, early) = match s.intermediate {
                Some(callback) => s.step_reported(t, h, callback)?,
                None => (s.step(t, h)?, false),
            };
            if report.converged() {
                *out.last_successful_time = s.time;
                *out.early_return = early;
                return Ok(Status::Ok);
            }
            *out.last_successful_time = t;
            s.log_discard_fmi3(t, h, &report);
            Ok(Status::Discard)
        })
    }

    /// [`Instance::step`] one load increment at a time, each reported to the master's
    /// intermediate-update callback at its pseudo-time t + λ h (λ the load fraction of the step
    /// reached; `intermediateStepFinished` true for a converged increment, false for a
    /// cut-back). When early return is allowed and the master asks for it after a converged
    /// increment short of the end, the step stops there: the equilibrium at λ is committed and
    /// the instance's time is t + λ h (the next DoStep starts there and applies the rest).
    /// Returns the report and whether the step returned early.
    fn step_reported(
        &mut self,
        t: f64,
        h: f64,
        callback: IntermediateUpdate,
    ) -> Result<(crate::solver::StepReport, bool), Error> {
        self.check_step(t, h)?;
        self.engine.set_step_duration(h);
        if let Some(report) = self.forced_failure(t + h) {
            return Ok((report, false));
        }
        if self.poisoned {
            return Err(Error::Poisoned);
        }
        if let Some(report) = self.keep()? {
            // What a solve does here: one increment over the whole step, converged at once.
            callback.call(t + h, true, false);
            self.time = t + h;
            self.last_successful_time = self.time;
            return Ok((report, false));
        }
        let engine = &mut self.engine;
        let mut step = self.worker.run(|| engine.begin_step());
        let mut early = false;
        loop {
            let engine = &mut self.engine;
            let Some(increment) = self.worker.run(|| engine.advance(&mut step)) else {
                break;
            };
            let can_return_early =
                self.early_return_allowed && increment.converged && increment.lambda < 1.0;
            let requested = callback.call(
                t + increment.lambda * h,
                increment.converged,
                can_return_early,
            );
            if requested && can_return_early {
                early = true;
                break;
            }
        }
        let engine = &mut self.engine;
        let report = self.worker.run(|| engine.end_step(step));
        if self.logger.enabled(Category::Solver) {
            for line in &report.log {
                self.logger.log(Category::Solver, line);
            }
        }
        if report.converged() {
            self.time = if early { t + report.reached * h } else { t + h };
            self.last_successful_time = self.time;
        }
        Ok((report, early))
    }

    /// logStatusDiscard for FMI 3: how far the step got, why, and the inputs by name.
    fn log_discard_fmi3(&self, t: f64, h: f64, report: &crate::solver::StepReport) {
        if !self.logger.enabled(Category::StatusDiscard) {
            return;
        }
        let inputs: Vec<String> = self
            .engine
            .variables()
            .iter()
            .filter(|v| v.causality == Causality::Input)
            .filter_map(|v| {
                let value = self.engine.get_real(v.value_reference).ok()?;
                Some(format!("{} = {value}", v.name))
            })
            .collect();
        self.logger.log(
            Category::StatusDiscard,
            &format!(
                "fmi3DoStep: the step from {t} to {} did not converge: {}; the FMU state is unchanged (t = {t}, the last equilibrium); inputs: {}",
                t + h,
                reached(report),
                if inputs.is_empty() { "none".to_string() } else { inputs.join(", ") }
            ),
        );
    }
}

/// Check the instantiation arguments, read the scene from the resource path, compare the
/// token.
fn build_fmi3(args: &Instantiate3Args) -> Result<(Engine, String), Error> {
    check_instance_name(args.instance_name)?;
    if args.event_mode_used {
        return Err(Error::Argument {
            argument: "eventModeUsed",
            message:
                "eventModeUsed = true, but this FMU has no event mode (hasEventMode=\"false\")"
                    .into(),
        });
    }
    let given = args
        .instantiation_token
        .ok_or_else(|| null("instantiationToken"))?;
    let path = args.resource_path.ok_or_else(|| Error::Argument {
        argument: "resourcePath",
        message: "resourcePath is NULL; this FMU reads its scene from resources/scene.json".into(),
    })?;
    let engine = load_engine_from(std::path::Path::new(path))?;
    let token = description3::instantiation_token(engine.scene(), engine.arrays());
    if given != token {
        return Err(Error::Argument {
            argument: "instantiationToken",
            message: format!(
                "instantiationToken mismatch: the importer passed {given}, but this binary and its resources have {token} (was the FMU repackaged with another modelDescription.xml?)"
            ),
        });
    }
    Ok((engine, token))
}
