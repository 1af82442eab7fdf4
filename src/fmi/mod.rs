//! FMI 2.0 and FMI 3.0 Co-Simulation adapter: the C ABI over [`crate::Engine`]. This module tree
//! is the only place in the crate with `unsafe` code, and that code sits in six files:
//!
//! ```text
//! abi.rs       the 34 exported fmi2* functions; each is a short shim
//! fmi3.rs      the 75 exported fmi3* functions (FMI 3.0 Co-Simulation from the same library)
//! fmi2_ffi.rs  the hand-written FMI 2 C types (Status, Component, the callbacks) and the
//!              call of the master's logger; fmi3_ffi.rs the same for FMI 3
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
//! - FMU states are boxed plain structs, read only if the instance handed them out and has
//!   not freed them (a foreign pointer is an Error, never dereferenced; `ffi.rs`); their
//!   serialized form is pointer-free and checked (see [`Snapshot`], [`STATE_MAGIC`]).
//! - No global mutable state and no thread outlives its instance: all data lives in the
//!   instance; its solves run on its own worker thread, joined by `fmi2FreeInstance` (see
//!   `worker.rs`).

mod abi;
mod ffi;
mod fmi2_ffi;
mod fmi3;
mod fmi3_ffi;
mod fsm;
mod instance;
mod logging;
mod snapshot;
mod uri;
mod worker;

pub use abi::*;
pub use fmi2_ffi::{
    CallbackFunctions, Component, FmuState, LoggerFn, Status, FMI2_COSIMULATION,
    FMI2_DO_STEP_STATUS, FMI2_LAST_SUCCESSFUL_TIME, FMI2_MODEL_EXCHANGE, FMI2_PENDING_STATUS,
    FMI2_TERMINATED,
};
pub use fmi3::*;
pub use fmi3_ffi::{fmi3_names, Fmi3LoggerFn};
pub use fsm::FsmState;
pub use instance::Instance;
pub use logging::Category;
pub use snapshot::{Snapshot, STATE_FORMAT_VERSION, STATE_MAGIC};
pub use uri::file_uri_to_path;

// What the FMU declares about itself is defined with the description, which this adapter
// implements (the adapter imports the description, never the reverse); the same items here.
pub use crate::description::{
    capability_flags, CAN_BE_INSTANTIATED_ONLY_ONCE_PER_PROCESS, CAN_GET_AND_SET_FMU_STATE,
    CAN_HANDLE_VARIABLE_COMMUNICATION_STEP_SIZE, CAN_INTERPOLATE_INPUTS,
    CAN_NOT_USE_MEMORY_MANAGEMENT_FUNCTIONS, CAN_RUN_ASYNCHRONUOUSLY, CAN_SERIALIZE_FMU_STATE,
    MAX_OUTPUT_DERIVATIVE_ORDER, NEEDS_EXECUTION_TOOL, PROVIDES_DIRECTIONAL_DERIVATIVE,
};
pub use crate::description3::{capability_flags_fmi3, TIME_VALUE_REFERENCE};

/// The log categories to declare in `<LogCategories>`, as (name, description), in order.
/// Every category the binary logs under is listed here, and no other.
pub fn log_categories() -> &'static [(&'static str, &'static str)] {
    crate::description::LOG_CATEGORIES
}
