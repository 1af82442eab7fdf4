//! The FMI 3.0 C types this crate needs, written by hand from the standard's
//! `fmi3PlatformTypes.h` / `fmi3FunctionTypes.h` (no bindgen), and the FMI 3 side of logging.
//!
//! ```text
//! C type                        here
//! fmi3Instance                  Component (the same tagged box as an FMI 2 instance)
//! fmi3FMUState                  FmuState (the same tagged box of a Snapshot)
//! fmi3Status                    Status (fmi3OK..fmi3Fatal are 0..4, as fmi2OK..fmi2Fatal)
//! fmi3Boolean, fmi3Clock        bool (C `bool`, one byte; NOT fmi2Boolean's int)
//! fmi3ValueReference            u32
//! fmi3Byte / fmi3Binary         u8 / *const u8
//! fmi3LogMessageCallback        Fmi3LoggerFn: (env, status, category, message), not variadic
//! ```
//!
//! Everything else (the panic boundary, pointer helpers, instance and state boxes) is shared
//! with FMI 2 in `ffi.rs`.

use super::fmi2_ffi::Status;
use std::ffi::{c_char, c_void, CStr};

/// `fmi3LogMessageCallback`.
pub type Fmi3LoggerFn = unsafe extern "C" fn(*mut c_void, Status, *const c_char, *const c_char);

/// `fmi3IntermediateUpdateCallback(instanceEnvironment, intermediateUpdateTime,
/// intermediateVariableSetRequested, intermediateVariableGetAllowed, intermediateStepFinished,
/// canReturnEarly, *earlyReturnRequested, *earlyReturnTime)`.
pub type Fmi3IntermediateUpdateFn =
    unsafe extern "C" fn(*mut c_void, f64, bool, bool, bool, bool, *mut bool, *mut f64);

/// The master's intermediate-update callback and its environment, called on the thread that
/// called `fmi3DoStep`, between two load increments (never while the engine is borrowed: the
/// master may not get or set variables, `intermediateVariableGetAllowed` and
/// `intermediateVariableSetRequested` are false).
#[derive(Clone, Copy)]
pub struct IntermediateUpdate {
    callback: Fmi3IntermediateUpdateFn,
    environment: *mut c_void,
}

// SAFETY: the environment pointer is the master's; it is only passed back to the master's
// callback, which is only called on the thread that called fmi3DoStep (never from the worker,
// which merely holds the instance while it builds or solves).
unsafe impl Send for IntermediateUpdate {}
unsafe impl Sync for IntermediateUpdate {}

impl IntermediateUpdate {
    pub fn new(
        callback: Option<Fmi3IntermediateUpdateFn>,
        environment: *mut c_void,
    ) -> Option<IntermediateUpdate> {
        callback.map(|callback| IntermediateUpdate {
            callback,
            environment,
        })
    }

    /// Report the point `time` (`step_finished`: an internal increment converged there; else
    /// a cut-back). Returns whether the master asked to return early.
    pub fn call(&self, time: f64, step_finished: bool, can_return_early: bool) -> bool {
        let (mut requested, mut at) = (false, time);
        // SAFETY: the callback is the master's, with the environment it gave at instantiation
        // (the FMI 3 contract); the two out-pointers are valid locals.
        unsafe {
            (self.callback)(
                self.environment,
                time,
                false,
                false,
                step_finished,
                can_return_early,
                &mut requested,
                &mut at,
            )
        };
        requested
    }
}

/// `fmi3ClockUpdateCallback` (Scheduled Execution; never called).
pub type Fmi3ClockUpdateFn = unsafe extern "C" fn(*mut c_void);

/// `fmi3LockPreemptionCallback` / `fmi3UnlockPreemptionCallback` (never called).
pub type Fmi3PreemptionFn = unsafe extern "C" fn();

/// `fmi3IntervalQualifier`, `fmi3DependencyKind`: C enums (int).
pub type Fmi3Enum = std::ffi::c_int;

/// Call the master's FMI 3 logger with an already formatted message.
pub(crate) fn call_logger(
    logger: Fmi3LoggerFn,
    environment: *mut c_void,
    status: Status,
    category: &CStr,
    message: &CStr,
) {
    // SAFETY: the master gave this function pointer as an fmi3LogMessageCallback; both
    // strings are NUL-terminated and outlive the call.
    unsafe { logger(environment, status, category.as_ptr(), message.as_ptr()) }
}

/// FMI 2 function names that differ in FMI 3 (longest first where one is a prefix of another).
const RENAMED: &[(&str, &str)] = &[
    ("fmi2Instantiate", "fmi3InstantiateCoSimulation"),
    ("fmi2SetupExperiment", "fmi3EnterInitializationMode"),
    ("fmi2GetReal", "fmi3GetFloat64"),
    ("fmi2SetReal", "fmi3SetFloat64"),
    ("fmi2GetInteger", "fmi3GetInt32"),
    ("fmi2SetInteger", "fmi3SetInt32"),
    ("fmi2GetFMUstate", "fmi3GetFMUState"),
    ("fmi2SetFMUstate", "fmi3SetFMUState"),
    ("fmi2FreeFMUstate", "fmi3FreeFMUState"),
    ("fmi2SerializedFMUstateSize", "fmi3SerializedFMUStateSize"),
    ("fmi2SerializeFMUstate", "fmi3SerializeFMUState"),
    ("fmi2DeSerializeFMUstate", "fmi3DeserializeFMUState"),
    ("fmi2Boolean", "fmi3Boolean"),
];

/// A message of the shared instance code in FMI 3 form: function names of FMI 3 (the shared
/// code names the FMI 2 function it implements, e.g. `fmi2GetReal` for `fmi3GetFloat64`), and
/// `##` back to `#` (FMI 3 messages are plain text, without FMI 2's `#r12#` references).
pub fn fmi3_names(message: &str) -> String {
    if !message.contains("fmi2") && !message.contains("##") {
        return message.to_string();
    }
    let mut out = String::with_capacity(message.len() + 16);
    let mut rest = message;
    while let Some(at) = rest.find("fmi2") {
        out.push_str(&rest[..at]);
        let tail = &rest[at..];
        match RENAMED.iter().find(|(old, _)| tail.starts_with(old)) {
            Some((old, new)) => {
                out.push_str(new);
                rest = &tail[old.len()..];
            }
            None => {
                out.push_str("fmi3");
                rest = &tail[4..];
            }
        }
    }
    out.push_str(rest);
    out.replace("##", "#")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_become_fmi3_names() {
        assert_eq!(
            fmi3_names("fmi2GetReal: illegal call in state Instantiated"),
            "fmi3GetFloat64: illegal call in state Instantiated"
        );
        assert_eq!(
            fmi3_names("fmi2DoStep: x; fmi2Reset or fmi2SetFMUstate recovers it"),
            "fmi3DoStep: x; fmi3Reset or fmi3SetFMUState recovers it"
        );
        assert_eq!(
            fmi3_names("see fmi2SerializedFMUstateSize, load ##2"),
            "see fmi3SerializedFMUStateSize, load #2"
        );
        assert_eq!(fmi3_names("plain 50%"), "plain 50%");
    }
}
