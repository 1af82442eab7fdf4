//! The FMI 2.0 C types this crate needs, written by hand from the standard's
//! `fmi2TypesPlatform.h` / `fmi2FunctionTypes.h` (no bindgen), and the FMI 2 side of logging.
//!
//! ```text
//! C type                        here
//! fmi2Component                 Component (a tagged box of an Instance, see ffi.rs)
//! fmi2FMUstate                  FmuState (a tagged box of a Snapshot)
//! fmi2Status                    Status
//! fmi2Type, fmi2StatusKind      the FMI2_* constants
//! fmi2CallbackFunctions         CallbackFunctions (only the logger and its environment used)
//! fmi2CallbackLogger            LoggerFn: variadic, always called with the format "%s"
//! ```
//!
//! A leaf: it imports nothing of the crate, so the logger, the instance and the shims can all
//! use these types without importing one another.

use std::ffi::{c_char, c_int, c_void, CStr};

/// `fmi2Component`.
pub type Component = *mut c_void;
/// `fmi2FMUstate`.
pub type FmuState = *mut c_void;

/// `fmi2CallbackLogger`: `void logger(env, instanceName, status, category, message, ...)`.
pub type LoggerFn =
    unsafe extern "C" fn(*mut c_void, *const c_char, Status, *const c_char, *const c_char, ...);

/// `fmi2CallbackFunctions`. Only the logger and the environment are used
/// (`canNotUseMemoryManagementFunctions = true`).
#[repr(C)]
pub struct CallbackFunctions {
    pub logger: Option<LoggerFn>,
    pub allocate_memory: Option<unsafe extern "C" fn(usize, usize) -> *mut c_void>,
    pub free_memory: Option<unsafe extern "C" fn(*mut c_void)>,
    pub step_finished: Option<unsafe extern "C" fn(*mut c_void, c_int)>,
    pub component_environment: *mut c_void,
}

/// `fmi2Status`.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Status {
    Ok = 0,
    Warning = 1,
    Discard = 2,
    Error = 3,
    Fatal = 4,
    Pending = 5,
}

impl Status {
    /// The name FMI uses in messages (`fmi2OK`, ...).
    pub fn name(self) -> &'static str {
        match self {
            Status::Ok => "fmi2OK",
            Status::Warning => "fmi2Warning",
            Status::Discard => "fmi2Discard",
            Status::Error => "fmi2Error",
            Status::Fatal => "fmi2Fatal",
            Status::Pending => "fmi2Pending",
        }
    }
}

/// `fmi2Type` value of a co-simulation instance (the only type this FMU supports).
pub const FMI2_COSIMULATION: i32 = 1;
/// `fmi2Type` value of a model-exchange instance (rejected).
pub const FMI2_MODEL_EXCHANGE: i32 = 0;

/// `fmi2StatusKind` values.
pub const FMI2_DO_STEP_STATUS: i32 = 0;
pub const FMI2_PENDING_STATUS: i32 = 1;
pub const FMI2_LAST_SUCCESSFUL_TIME: i32 = 2;
pub const FMI2_TERMINATED: i32 = 3;

/// Call the master's variadic logger as `logger(env, name, status, category, "%s", message)`.
pub(crate) fn call_logger(
    logger: LoggerFn,
    environment: *mut c_void,
    instance_name: &CStr,
    status: Status,
    category: &CStr,
    message: &CStr,
) {
    // SAFETY: the master gave this function pointer for exactly this call signature; every
    // string is NUL-terminated and outlives the call; "%s" consumes exactly one char* argument.
    unsafe {
        logger(
            environment,
            instance_name.as_ptr(),
            status,
            category.as_ptr(),
            c"%s".as_ptr(),
            message.as_ptr(),
        )
    }
}
