//! FMI 2.0 and FMI 3.0 Co-Simulation adapter: the C ABI over [`crate::Engine`]. This module tree
//! is the only place in the crate with `unsafe` code, and that code sits in five files:
//!
//! ```text
//! abi.rs       the 34 exported fmi2* functions; each is a short shim
//! fmi3.rs      the 75 exported fmi3* functions (FMI 3.0 Co-Simulation from the same library);
//!              fmi3_ffi.rs holds the hand-written FMI 3 C types
//! ffi.rs       the one panic boundary and the pointer helpers (NULL instance -> Error,
//!              n == 0 -> empty slice before any array check, NULL array -> Error)
//! worker.rs    each instance's solves run on a pthread of its own, joined when the instance
//!              is freed, so thread-local scratch of the linear algebra never pins the library
//!              after dlclose
//! ```
//!
//! Everything else is safe Rust on an [`Instance`]:
//!
//! ```text
//! instance.rs  lifecycle, variables, stepping; instance/fmu_state.rs (get/set/serialize
//!              FMU states) and instance/status.rs (fmi2Get*Status)
//! fsm.rs       the calling-sequence state machine: one mask of legal states per function
//! logging.rs   log categories, the enabled set, '#' escaping; the C logger is always called
//!              with the format "%s" and the message as its argument
//! snapshot.rs  FMU states: what is saved, and the checked byte format (payload: postcard)
//! uri.rs       percent-encoded file: URIs of the resource location
//! ```
//!
//! # Behaviour in brief
//!
//! - States: Instantiated → InitializationMode → StepComplete ⇄ StepFailed → Terminated, and
//!   Error. An illegal call or argument logs `"<function>: <reason>"` under `logStatusError`
//!   and returns `fmi2Error` without changing anything; only an internal failure (a caught
//!   panic, an initial equilibrium that does not converge) moves the instance to Error, from
//!   which `fmi2Reset`, `fmi2SetFMUstate` and `fmi2FreeInstance` recover or release it.
//! - `fmi2SetupExperiment` is required before `fmi2EnterInitializationMode`.
//! - `fmi2ExitInitializationMode` solves the equilibrium under the current inputs and
//!   parameters; the outputs read right after it are that equilibrium. Outputs read inside
//!   Initialization Mode are the same equilibrium, solved on demand (always from the state at
//!   `fmi2EnterInitializationMode`, so reading early does not change the result).
//! - `fmi2DoStep(t, h)` applies the inputs set before it by load increments from the last
//!   converged equilibrium. If the engine does not converge it keeps that equilibrium, the call
//!   returns `fmi2Discard`, the instance goes to StepFailed, `fmi2Terminated` is true and
//!   `fmi2LastSuccessfulTime` is `t`. A DoStep in StepFailed is an Error; `fmi2SetFMUstate`
//!   with a state saved earlier returns to StepComplete. The Discard is logged under
//!   `logStatusDiscard` whatever the logging settings.
//! - Debug switches (test variants of a scene only, `Scene::debug`): a step ending after
//!   `fail_after_time` is reported as not converged without touching the engine; one ending
//!   after `panic_after_time` panics, so the panic boundary is exercised from outside.
//! - FMU states are boxed plain structs; their serialized form is pointer-free and checked
//!   (see [`Snapshot`], [`STATE_MAGIC`]).
//! - No global mutable state and no thread outlives its instance: all data lives in the
//!   instance; its solves run on its own worker thread, joined by `fmi2FreeInstance` (see
//!   `worker.rs`).

mod abi;
mod ffi;
mod fmi3;
mod fmi3_ffi;
mod fsm;
mod instance;
mod logging;
mod snapshot;
mod uri;
mod worker;

pub use abi::*;
pub use ffi::{CallbackFunctions, Component, FmuState, LoggerFn};
pub use fmi3::*;
pub use fmi3_ffi::{fmi3_names, Fmi3LoggerFn};
pub use fsm::FsmState;
pub use instance::Instance;
pub use logging::Category;
pub use snapshot::{Snapshot, STATE_FORMAT_VERSION, STATE_MAGIC};
pub use uri::file_uri_to_path;

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

/// The log categories to declare in `<LogCategories>`, as (name, description), in order.
/// Every category the binary logs under is listed here, and no other.
pub fn log_categories() -> &'static [(&'static str, &'static str)] {
    logging::CATEGORIES
}

/// `CoSimulation` capability flags, consistent with what the binary does.
pub const CAN_HANDLE_VARIABLE_COMMUNICATION_STEP_SIZE: bool = true;
pub const CAN_GET_AND_SET_FMU_STATE: bool = true;
pub const CAN_SERIALIZE_FMU_STATE: bool = true;
pub const CAN_NOT_USE_MEMORY_MANAGEMENT_FUNCTIONS: bool = true;
pub const CAN_INTERPOLATE_INPUTS: bool = false;
/// `providesDirectionalDerivative` (FMI 2) and `providesDirectionalDerivatives` /
/// `providesAdjointDerivatives` (FMI 3): derivatives at the committed equilibrium.
pub const PROVIDES_DIRECTIONAL_DERIVATIVE: bool = true;
pub const CAN_RUN_ASYNCHRONUOUSLY: bool = false;
pub const CAN_BE_INSTANTIATED_ONLY_ONCE_PER_PROCESS: bool = false;
pub const NEEDS_EXECUTION_TOOL: bool = false;
/// `maxOutputDerivativeOrder`: `fmi2GetRealOutputDerivatives` is not supported.
pub const MAX_OUTPUT_DERIVATIVE_ORDER: u32 = 0;

/// The boolean `CoSimulation` attributes as (XML attribute name, value), in the order the
/// FMI 2.0 schema lists them. The description generator writes them as they are.
pub fn capability_flags() -> &'static [(&'static str, bool)] {
    &[
        ("needsExecutionTool", NEEDS_EXECUTION_TOOL),
        (
            "canHandleVariableCommunicationStepSize",
            CAN_HANDLE_VARIABLE_COMMUNICATION_STEP_SIZE,
        ),
        ("canInterpolateInputs", CAN_INTERPOLATE_INPUTS),
        ("canRunAsynchronuously", CAN_RUN_ASYNCHRONUOUSLY),
        (
            "canBeInstantiatedOnlyOncePerProcess",
            CAN_BE_INSTANTIATED_ONLY_ONCE_PER_PROCESS,
        ),
        (
            "canNotUseMemoryManagementFunctions",
            CAN_NOT_USE_MEMORY_MANAGEMENT_FUNCTIONS,
        ),
        ("canGetAndSetFMUstate", CAN_GET_AND_SET_FMU_STATE),
        ("canSerializeFMUstate", CAN_SERIALIZE_FMU_STATE),
        (
            "providesDirectionalDerivative",
            PROVIDES_DIRECTIONAL_DERIVATIVE,
        ),
    ]
}
