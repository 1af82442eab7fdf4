//! The 75 exported FMI 3.0 functions (`fmi3Functions.h`), in the same shared library as the
//! FMI 2 ones. Each is a short shim like those of `abi.rs`: [`with_instance`] (NULL instance
//! -> fmi3Error, panic boundary), pointers turned into `Result`s by the helpers of `ffi.rs`,
//! then one method of [`Instance`] (FMI 3 specifics in `instance/fmi3.rs`).
//!
//! What is supported (Co-Simulation, no event mode, no clocks):
//!
//! ```text
//! fmi3InstantiateCoSimulation, FreeInstance, EnterInitializationMode, ExitInitializationMode,
//! Terminate, Reset, SetDebugLogging, GetVersion        as FMI 2 (one call for the experiment)
//! fmi3Get/SetFloat64, fmi3Get/SetInt32, fmi3GetUInt8  the variables, arrays row-major (nValues =
//!                                                     their element count; time = vr 0)
//! fmi3GetDirectionalDerivative, GetAdjointDerivative  at the current equilibrium
//! fmi3DoStep                                          Discard leaves the state unchanged
//! fmi3Get/Set/FreeFMUState, SerializedFMUStateSize, SerializeFMUState, DeserializeFMUState
//! ```
//!
//! Every other function is exported (importers such as fmpy resolve all 75 at load time) and
//! answers fmi3Error with a logged reason: the other variable types have no variables (an
//! empty call is OK, any value reference is unknown); Model Exchange and Scheduled Execution
//! instantiation return NULL; event mode, clocks, configuration mode, variable
//! dependencies and the Model Exchange functions are not supported.
//!
//! # Safety
//! The contract is the FMI 3.0 standard's: `instance` is NULL or an instance from
//! `fmi3InstantiateCoSimulation` not yet freed; an array argument with length `n > 0` is NULL
//! (rejected) or holds `n` elements; strings are NUL-terminated; an `fmi3FMUState*` is NULL or
//! points to a variable. Within that contract no call crashes or unwinds into the caller. An
//! `fmi3FMUState` may be anything: it is read only if this instance handed it out and has not
//! freed it (`ffi.rs`), so a foreign or freed state, or a state passed where its address
//! belongs, is an Error.

// The names are the standard's (fmi3GetFloat64, ...), and every function's `# Safety` is the one
// contract above, stated once.
#![allow(non_snake_case, clippy::missing_safety_doc)]

use super::ffi::{
    free_component, guard, into_component, release_state, slice_in, slice_out, state_mut,
    store_new_state, store_state, text, texts, with_instance, with_states, write_out,
};
use super::fmi2_ffi::{Component, FmuState, Status};
use super::fmi3_ffi::{
    Fmi3ClockUpdateFn, Fmi3Enum, Fmi3IntermediateUpdateFn, Fmi3LoggerFn, Fmi3PreemptionFn,
    IntermediateUpdate,
};
use super::instance::fmi3::{DoStepOut, Instantiate3Args};
use super::instance::Instance;
use super::logging::{Callback, Category, Logger};
use crate::error::Error;
use crate::variables::VarType;
use std::ffi::{c_char, c_void};
use std::ptr::null_mut;

const NO_EVENT_MODE: &str =
    "this FMU has no event mode (hasEventMode=\"false\"); after fmi3ExitInitializationMode it is in Step Mode";
const NO_CLOCKS: &str = "this FMU has no clocks";
const CO_SIMULATION_ONLY: &str = "this is a Model Exchange function; the FMU is Co-Simulation only";
const NO_DEPENDENCIES: &str =
    "providesPerElementDependencies is false; the modelDescription's ModelStructure lists the dependencies";
const NO_CONFIGURATION: &str = "this FMU has no structural parameters to configure";

/// The shim of a function this FMU does not support.
///
/// # Safety
/// `instance` is NULL or a live instance of this FMU.
unsafe fn unsupported(instance: Component, name: &'static str, why: &str) -> Status {
    // SAFETY: as this function requires: `instance` is NULL or a live instance of this FMU.
    unsafe { with_instance(instance, name, |i| i.unsupported_fmi3(name, why)) }
}

/// Instantiation of an interface type this FMU does not provide: log, return NULL.
///
/// # Safety
/// `instance_name` is NULL or NUL-terminated.
unsafe fn refuse_instantiation(
    function: &str,
    instance_name: *const c_char,
    environment: *mut c_void,
    log_message: Option<Fmi3LoggerFn>,
) -> Component {
    // SAFETY: as this function requires: `instance_name` is NULL or NUL-terminated.
    unsafe {
        guard(null_mut(), || {
            let name = text(instance_name);
            let logger = Logger::with_callback(
                log_message.map(Callback::Fmi3),
                environment,
                name.as_deref().unwrap_or_default(),
                false,
            );
            logger.log(
                Category::StatusError,
                &format!(
                    "{function}: this FMU supports Co-Simulation only (fmi3InstantiateCoSimulation)"
                ),
            );
            null_mut()
        })
    }
}

// ---------------------------------------------------------------------------------------------
// Inquire version numbers, set debug logging

#[no_mangle]
pub extern "C" fn fmi3GetVersion() -> *const c_char {
    c"3.0".as_ptr()
}

#[no_mangle]
pub unsafe extern "C" fn fmi3SetDebugLogging(
    instance: Component,
    logging_on: bool,
    n_categories: usize,
    categories: *const *const c_char,
) -> Status {
    // SAFETY: the FMI contract (module doc): `instance` is NULL or a live instance of this FMU;
    // `categories` is NULL or holds `n_categories` pointers, each NULL or NUL-terminated.
    unsafe {
        with_instance(instance, "fmi3SetDebugLogging", |i| {
            i.set_debug_logging(logging_on, texts(categories, n_categories, "categories"))
        })
    }
}

// ---------------------------------------------------------------------------------------------
// Creation and destruction of instances

#[no_mangle]
pub unsafe extern "C" fn fmi3InstantiateModelExchange(
    instance_name: *const c_char,
    _instantiation_token: *const c_char,
    _resource_path: *const c_char,
    _visible: bool,
    _logging_on: bool,
    instance_environment: *mut c_void,
    log_message: Option<Fmi3LoggerFn>,
) -> Component {
    // SAFETY: the FMI contract (module doc): `instance_name` is NULL or NUL-terminated.
    unsafe {
        refuse_instantiation(
            "fmi3InstantiateModelExchange",
            instance_name,
            instance_environment,
            log_message,
        )
    }
}

#[no_mangle]
#[allow(clippy::too_many_arguments)] // the signature is fmi3Functions.h's
pub unsafe extern "C" fn fmi3InstantiateCoSimulation(
    instance_name: *const c_char,
    instantiation_token: *const c_char,
    resource_path: *const c_char,
    _visible: bool,
    logging_on: bool,
    event_mode_used: bool,
    early_return_allowed: bool,
    _required_intermediate_variables: *const u32,
    _n_required_intermediate_variables: usize,
    instance_environment: *mut c_void,
    log_message: Option<Fmi3LoggerFn>,
    intermediate_update: Option<Fmi3IntermediateUpdateFn>,
) -> Component {
    // SAFETY: the FMI contract (module doc): `instance_name`, `instantiation_token` and
    // `resource_path` are NULL or NUL-terminated.
    unsafe {
        guard(null_mut(), || {
            let (name, token, path) = (
                text(instance_name),
                text(instantiation_token),
                text(resource_path),
            );
            let logger = Logger::with_callback(
                log_message.map(Callback::Fmi3),
                instance_environment,
                name.as_deref().unwrap_or_default(),
                logging_on,
            );
            let args = Instantiate3Args {
                instance_name: name.as_deref(),
                instantiation_token: token.as_deref(),
                resource_path: path.as_deref(),
                event_mode_used,
                early_return_allowed,
                intermediate_update: IntermediateUpdate::new(
                    intermediate_update,
                    instance_environment,
                ),
            };
            Instance::instantiate_fmi3(&args, logger).map_or(null_mut(), into_component)
        })
    }
}

#[no_mangle]
#[allow(clippy::too_many_arguments)] // the signature is fmi3Functions.h's
pub unsafe extern "C" fn fmi3InstantiateScheduledExecution(
    instance_name: *const c_char,
    _instantiation_token: *const c_char,
    _resource_path: *const c_char,
    _visible: bool,
    _logging_on: bool,
    instance_environment: *mut c_void,
    log_message: Option<Fmi3LoggerFn>,
    _clock_update: Option<Fmi3ClockUpdateFn>,
    _lock_preemption: Option<Fmi3PreemptionFn>,
    _unlock_preemption: Option<Fmi3PreemptionFn>,
) -> Component {
    // SAFETY: the FMI contract (module doc): `instance_name` is NULL or NUL-terminated.
    unsafe {
        refuse_instantiation(
            "fmi3InstantiateScheduledExecution",
            instance_name,
            instance_environment,
            log_message,
        )
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi3FreeInstance(instance: Component) {
    // SAFETY: the FMI contract (module doc): `instance` is NULL or a live instance of this FMU,
    // which the master gives up with this call.
    unsafe {
        with_instance(instance, "fmi3FreeInstance", Instance::freeing);
        free_component(instance);
    }
}

// ---------------------------------------------------------------------------------------------
// Initialization, event mode, termination, reset

#[no_mangle]
pub unsafe extern "C" fn fmi3EnterInitializationMode(
    instance: Component,
    tolerance_defined: bool,
    tolerance: f64,
    start_time: f64,
    stop_time_defined: bool,
    stop_time: f64,
) -> Status {
    let tolerance = tolerance_defined.then_some(tolerance);
    let stop_time = stop_time_defined.then_some(stop_time);
    // SAFETY: the FMI contract (module doc): `instance` is NULL or a live instance of this FMU.
    unsafe {
        with_instance(instance, "fmi3EnterInitializationMode", |i| {
            i.enter_initialization_mode_fmi3(tolerance, start_time, stop_time)
        })
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi3ExitInitializationMode(instance: Component) -> Status {
    // SAFETY: the FMI contract (module doc): `instance` is NULL or a live instance of this FMU.
    unsafe {
        with_instance(
            instance,
            "fmi3ExitInitializationMode",
            Instance::exit_initialization_mode,
        )
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi3EnterEventMode(instance: Component) -> Status {
    // SAFETY: the FMI contract (module doc): `instance` is NULL or a live instance of this FMU.
    unsafe { unsupported(instance, "fmi3EnterEventMode", NO_EVENT_MODE) }
}

#[no_mangle]
pub unsafe extern "C" fn fmi3Terminate(instance: Component) -> Status {
    // SAFETY: the FMI contract (module doc): `instance` is NULL or a live instance of this FMU.
    unsafe { with_instance(instance, "fmi3Terminate", Instance::terminate) }
}

#[no_mangle]
pub unsafe extern "C" fn fmi3Reset(instance: Component) -> Status {
    // SAFETY: the FMI contract (module doc): `instance` is NULL or a live instance of this FMU.
    unsafe { with_instance(instance, "fmi3Reset", Instance::reset) }
}

// ---------------------------------------------------------------------------------------------
// Getting and setting variable values: the types this FMU has

#[no_mangle]
pub unsafe extern "C" fn fmi3GetFloat64(
    instance: Component,
    vr: *const u32,
    n_vr: usize,
    values: *mut f64,
    n_values: usize,
) -> Status {
    // SAFETY: the FMI contract (module doc): `instance` is NULL or a live instance of this FMU;
    // `vr` is NULL or holds `n_vr` elements; `values` is NULL or holds `n_values` elements.
    unsafe {
        with_instance(instance, "fmi3GetFloat64", |i| {
            i.get_float64(
                slice_in(vr, n_vr, "valueReferences"),
                slice_out(values, n_values, "values"),
                n_values,
            )
        })
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi3SetFloat64(
    instance: Component,
    vr: *const u32,
    n_vr: usize,
    values: *const f64,
    n_values: usize,
) -> Status {
    // SAFETY: the FMI contract (module doc): `instance` is NULL or a live instance of this FMU;
    // `vr` is NULL or holds `n_vr` elements; `values` is NULL or holds `n_values` elements.
    unsafe {
        with_instance(instance, "fmi3SetFloat64", |i| {
            i.set_float64(
                slice_in(vr, n_vr, "valueReferences"),
                slice_in(values, n_values, "values"),
                n_values,
            )
        })
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi3GetInt32(
    instance: Component,
    vr: *const u32,
    n_vr: usize,
    values: *mut i32,
    n_values: usize,
) -> Status {
    // SAFETY: the FMI contract (module doc): `instance` is NULL or a live instance of this FMU;
    // `vr` is NULL or holds `n_vr` elements; `values` is NULL or holds `n_values` elements.
    unsafe {
        with_instance(instance, "fmi3GetInt32", |i| {
            i.get_int32(
                slice_in(vr, n_vr, "valueReferences"),
                slice_out(values, n_values, "values"),
                n_values,
            )
        })
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi3SetInt32(
    instance: Component,
    vr: *const u32,
    n_vr: usize,
    _values: *const i32,
    n_values: usize,
) -> Status {
    // SAFETY: the FMI contract (module doc): `instance` is NULL or a live instance of this FMU;
    // `vr` is NULL or holds `n_vr` elements.
    unsafe {
        with_instance(instance, "fmi3SetInt32", |i| {
            i.set_integer_fmi3(
                "fmi3SetInt32",
                VarType::Integer,
                slice_in(vr, n_vr, "valueReferences"),
                n_values,
            )
        })
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi3GetUInt8(
    instance: Component,
    vr: *const u32,
    n_vr: usize,
    values: *mut u8,
    n_values: usize,
) -> Status {
    // SAFETY: the FMI contract (module doc): `instance` is NULL or a live instance of this FMU;
    // `vr` is NULL or holds `n_vr` elements; `values` is NULL or holds `n_values` elements.
    unsafe {
        with_instance(instance, "fmi3GetUInt8", |i| {
            i.get_uint8(
                slice_in(vr, n_vr, "valueReferences"),
                slice_out(values, n_values, "values"),
                n_values,
            )
        })
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi3SetUInt8(
    instance: Component,
    vr: *const u32,
    n_vr: usize,
    _values: *const u8,
    n_values: usize,
) -> Status {
    // SAFETY: the FMI contract (module doc): `instance` is NULL or a live instance of this FMU;
    // `vr` is NULL or holds `n_vr` elements.
    unsafe {
        with_instance(instance, "fmi3SetUInt8", |i| {
            i.set_integer_fmi3(
                "fmi3SetUInt8",
                VarType::UInt8,
                slice_in(vr, n_vr, "valueReferences"),
                n_values,
            )
        })
    }
}

// ---------------------------------------------------------------------------------------------
// Getting and setting variable values: types without variables

/// The getter and setter of a type this FMU has no variables of: any value reference is
/// unknown (fmi3Error with the reference), an empty call is OK.
macro_rules! no_variables {
    ($get:ident, $set:ident, $kind:literal, $value:ty) => {
        #[no_mangle]
        pub unsafe extern "C" fn $get(
            instance: Component,
            vr: *const u32,
            n_vr: usize,
            _values: *mut $value,
            _n_values: usize,
        ) -> Status {
            // SAFETY: the FMI contract (module doc): `instance` is NULL or a live instance of this
            // FMU; `vr` is NULL or holds `n_vr` elements.
            unsafe { no_such_variables(instance, stringify!($get), $kind, true, vr, n_vr) }
        }

        #[no_mangle]
        pub unsafe extern "C" fn $set(
            instance: Component,
            vr: *const u32,
            n_vr: usize,
            _values: *const $value,
            _n_values: usize,
        ) -> Status {
            // SAFETY: the FMI contract (module doc): `instance` is NULL or a live instance of this
            // FMU; `vr` is NULL or holds `n_vr` elements.
            unsafe { no_such_variables(instance, stringify!($set), $kind, false, vr, n_vr) }
        }
    };
}

/// The shim of a getter or setter of a type without variables.
///
/// # Safety
/// `instance` is NULL or a live instance of this FMU; `vr` is NULL or holds `n_vr` elements.
unsafe fn no_such_variables(
    instance: Component,
    name: &'static str,
    kind: &'static str,
    getter: bool,
    vr: *const u32,
    n_vr: usize,
) -> Status {
    // SAFETY: as this function requires: `instance` is NULL or a live instance of this FMU; `vr` is
    // NULL or holds `n_vr` elements.
    unsafe {
        with_instance(instance, name, |i| {
            i.no_such_variables_fmi3(name, kind, getter, slice_in(vr, n_vr, "valueReferences"))
        })
    }
}

no_variables!(fmi3GetFloat32, fmi3SetFloat32, "Float32", f32);
no_variables!(fmi3GetInt8, fmi3SetInt8, "Int8", i8);
no_variables!(fmi3GetInt16, fmi3SetInt16, "Int16", i16);
no_variables!(fmi3GetUInt16, fmi3SetUInt16, "UInt16", u16);
no_variables!(fmi3GetUInt32, fmi3SetUInt32, "UInt32", u32);
no_variables!(fmi3GetInt64, fmi3SetInt64, "Int64", i64);
no_variables!(fmi3GetUInt64, fmi3SetUInt64, "UInt64", u64);
no_variables!(fmi3GetBoolean, fmi3SetBoolean, "Boolean", bool);
no_variables!(fmi3GetString, fmi3SetString, "String", *const c_char);

#[no_mangle]
pub unsafe extern "C" fn fmi3GetBinary(
    instance: Component,
    vr: *const u32,
    n_vr: usize,
    _value_sizes: *mut usize,
    _values: *mut *const u8,
    _n_values: usize,
) -> Status {
    // SAFETY: the FMI contract (module doc): `instance` is NULL or a live instance of this FMU;
    // `vr` is NULL or holds `n_vr` elements.
    unsafe { no_such_variables(instance, "fmi3GetBinary", "Binary", true, vr, n_vr) }
}

#[no_mangle]
pub unsafe extern "C" fn fmi3SetBinary(
    instance: Component,
    vr: *const u32,
    n_vr: usize,
    _value_sizes: *const usize,
    _values: *const *const u8,
    _n_values: usize,
) -> Status {
    // SAFETY: the FMI contract (module doc): `instance` is NULL or a live instance of this FMU;
    // `vr` is NULL or holds `n_vr` elements.
    unsafe { no_such_variables(instance, "fmi3SetBinary", "Binary", false, vr, n_vr) }
}

#[no_mangle]
pub unsafe extern "C" fn fmi3GetClock(
    instance: Component,
    vr: *const u32,
    n_vr: usize,
    _values: *mut bool,
) -> Status {
    // SAFETY: the FMI contract (module doc): `instance` is NULL or a live instance of this FMU;
    // `vr` is NULL or holds `n_vr` elements.
    unsafe { no_such_variables(instance, "fmi3GetClock", "Clock", true, vr, n_vr) }
}

#[no_mangle]
pub unsafe extern "C" fn fmi3SetClock(
    instance: Component,
    vr: *const u32,
    n_vr: usize,
    _values: *const bool,
) -> Status {
    // SAFETY: the FMI contract (module doc): `instance` is NULL or a live instance of this FMU;
    // `vr` is NULL or holds `n_vr` elements.
    unsafe { no_such_variables(instance, "fmi3SetClock", "Clock", false, vr, n_vr) }
}

// ---------------------------------------------------------------------------------------------
// Variable dependencies

#[no_mangle]
pub unsafe extern "C" fn fmi3GetNumberOfVariableDependencies(
    instance: Component,
    _vr: u32,
    _n_dependencies: *mut usize,
) -> Status {
    // SAFETY: the FMI contract (module doc): `instance` is NULL or a live instance of this FMU.
    unsafe {
        unsupported(
            instance,
            "fmi3GetNumberOfVariableDependencies",
            NO_DEPENDENCIES,
        )
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi3GetVariableDependencies(
    instance: Component,
    _dependent: u32,
    _element_indices_of_dependent: *mut usize,
    _independents: *mut u32,
    _element_indices_of_independents: *mut usize,
    _dependency_kinds: *mut Fmi3Enum,
    _n_dependencies: usize,
) -> Status {
    // SAFETY: the FMI contract (module doc): `instance` is NULL or a live instance of this FMU.
    unsafe { unsupported(instance, "fmi3GetVariableDependencies", NO_DEPENDENCIES) }
}

// ---------------------------------------------------------------------------------------------
// FMU state

#[no_mangle]
pub unsafe extern "C" fn fmi3GetFMUState(instance: Component, state: *mut FmuState) -> Status {
    // SAFETY: the FMI contract (module doc): `instance` is NULL or a live instance of this FMU;
    // `state` is NULL, a state of this instance (rejected) or valid for reads and writes.
    unsafe {
        with_states(instance, "fmi3GetFMUState", |i, h| {
            i.get_fmu_state(|s| store_state(h, state, s))
        })
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi3SetFMUState(instance: Component, state: FmuState) -> Status {
    // SAFETY: the FMI contract (module doc): `instance` is NULL or a live instance of this FMU;
    // `state` is any pointer (checked against the instance's states).
    unsafe {
        with_states(instance, "fmi3SetFMUState", |i, h| {
            i.set_fmu_state(state_mut(h, state).map(|s| &*s))
        })
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi3FreeFMUState(instance: Component, state: *mut FmuState) -> Status {
    // SAFETY: the FMI contract (module doc): `instance` is NULL or a live instance of this FMU;
    // `state` is NULL, a state of this instance (rejected) or valid for reads and writes.
    unsafe {
        with_states(instance, "fmi3FreeFMUState", |i, h| {
            i.free_fmu_state(|| release_state(h, state))
        })
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi3SerializedFMUStateSize(
    instance: Component,
    state: FmuState,
    size: *mut usize,
) -> Status {
    // SAFETY: the FMI contract (module doc): `instance` is NULL or a live instance of this FMU;
    // `state` is any pointer (checked against the instance's states); `size` is NULL or valid for a write.
    unsafe {
        with_states(instance, "fmi3SerializedFMUStateSize", |i, h| {
            i.serialized_fmu_state_size(state_mut(h, state).map(|s| &*s), |n| {
                write_out(size, n, "size")
            })
        })
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi3SerializeFMUState(
    instance: Component,
    state: FmuState,
    bytes: *mut u8,
    size: usize,
) -> Status {
    // SAFETY: the FMI contract (module doc): `instance` is NULL or a live instance of this FMU;
    // `bytes` is NULL or holds `size` elements; `state` is any pointer (checked against the instance's states).
    unsafe {
        with_states(instance, "fmi3SerializeFMUState", |i, h| {
            i.serialize_fmu_state(
                state_mut(h, state).map(|s| &*s),
                slice_out(bytes, size, "serializedState"),
            )
        })
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi3DeserializeFMUState(
    instance: Component,
    bytes: *const u8,
    size: usize,
    state: *mut FmuState,
) -> Status {
    // SAFETY: the FMI contract (module doc): `instance` is NULL or a live instance of this FMU;
    // `bytes` is NULL or holds `size` elements; `state` is NULL, a state of this instance (rejected) or valid for
    // writes.
    unsafe {
        with_states(instance, "fmi3DeserializeFMUState", |i, h| {
            i.deserialize_fmu_state(slice_in(bytes, size, "serializedState"), |s| {
                store_new_state(h, state, s)
            })
        })
    }
}

// ---------------------------------------------------------------------------------------------
// Partial derivatives

#[no_mangle]
#[allow(clippy::too_many_arguments)] // the signature is fmi3Functions.h's
pub unsafe extern "C" fn fmi3GetDirectionalDerivative(
    instance: Component,
    unknowns: *const u32,
    n_unknowns: usize,
    knowns: *const u32,
    n_knowns: usize,
    seed: *const f64,
    n_seed: usize,
    sensitivity: *mut f64,
    n_sensitivity: usize,
) -> Status {
    // SAFETY: the FMI contract (module doc): `instance` is NULL or a live instance of this FMU;
    // `unknowns` is NULL or holds `n_unknowns` elements; `knowns` is NULL or holds `n_knowns`
    // elements; `seed` is NULL or holds `n_seed` elements; `sensitivity` is NULL or holds
    // `n_sensitivity` elements.
    unsafe {
        with_instance(instance, "fmi3GetDirectionalDerivative", |i| {
            i.derivative_fmi3(
                false,
                slice_in(unknowns, n_unknowns, "unknowns"),
                slice_in(knowns, n_knowns, "knowns"),
                slice_in(seed, n_seed, "seed"),
                slice_out(sensitivity, n_sensitivity, "sensitivity"),
            )
        })
    }
}

#[no_mangle]
#[allow(clippy::too_many_arguments)] // the signature is fmi3Functions.h's
pub unsafe extern "C" fn fmi3GetAdjointDerivative(
    instance: Component,
    unknowns: *const u32,
    n_unknowns: usize,
    knowns: *const u32,
    n_knowns: usize,
    seed: *const f64,
    n_seed: usize,
    sensitivity: *mut f64,
    n_sensitivity: usize,
) -> Status {
    // SAFETY: the FMI contract (module doc): `instance` is NULL or a live instance of this FMU;
    // `unknowns` is NULL or holds `n_unknowns` elements; `knowns` is NULL or holds `n_knowns`
    // elements; `seed` is NULL or holds `n_seed` elements; `sensitivity` is NULL or holds
    // `n_sensitivity` elements.
    unsafe {
        with_instance(instance, "fmi3GetAdjointDerivative", |i| {
            i.derivative_fmi3(
                true,
                slice_in(unknowns, n_unknowns, "unknowns"),
                slice_in(knowns, n_knowns, "knowns"),
                slice_in(seed, n_seed, "seed"),
                slice_out(sensitivity, n_sensitivity, "sensitivity"),
            )
        })
    }
}

// ---------------------------------------------------------------------------------------------
// Configuration mode, clocks, discrete states

#[no_mangle]
pub unsafe extern "C" fn fmi3EnterConfigurationMode(instance: Component) -> Status {
    // SAFETY: the FMI contract (module doc): `instance` is NULL or a live instance of this FMU.
    unsafe { unsupported(instance, "fmi3EnterConfigurationMode", NO_CONFIGURATION) }
}

#[no_mangle]
pub unsafe extern "C" fn fmi3ExitConfigurationMode(instance: Component) -> Status {
    // SAFETY: the FMI contract (module doc): `instance` is NULL or a live instance of this FMU.
    unsafe { unsupported(instance, "fmi3ExitConfigurationMode", NO_CONFIGURATION) }
}

#[no_mangle]
pub unsafe extern "C" fn fmi3GetIntervalDecimal(
    instance: Component,
    _vr: *const u32,
    _n_vr: usize,
    _intervals: *mut f64,
    _qualifiers: *mut Fmi3Enum,
) -> Status {
    // SAFETY: the FMI contract (module doc): `instance` is NULL or a live instance of this FMU.
    unsafe { unsupported(instance, "fmi3GetIntervalDecimal", NO_CLOCKS) }
}

#[no_mangle]
pub unsafe extern "C" fn fmi3GetIntervalFraction(
    instance: Component,
    _vr: *const u32,
    _n_vr: usize,
    _counters: *mut u64,
    _resolutions: *mut u64,
    _qualifiers: *mut Fmi3Enum,
) -> Status {
    // SAFETY: the FMI contract (module doc): `instance` is NULL or a live instance of this FMU.
    unsafe { unsupported(instance, "fmi3GetIntervalFraction", NO_CLOCKS) }
}

#[no_mangle]
pub unsafe extern "C" fn fmi3GetShiftDecimal(
    instance: Component,
    _vr: *const u32,
    _n_vr: usize,
    _shifts: *mut f64,
) -> Status {
    // SAFETY: the FMI contract (module doc): `instance` is NULL or a live instance of this FMU.
    unsafe { unsupported(instance, "fmi3GetShiftDecimal", NO_CLOCKS) }
}

#[no_mangle]
pub unsafe extern "C" fn fmi3GetShiftFraction(
    instance: Component,
    _vr: *const u32,
    _n_vr: usize,
    _counters: *mut u64,
    _resolutions: *mut u64,
) -> Status {
    // SAFETY: the FMI contract (module doc): `instance` is NULL or a live instance of this FMU.
    unsafe { unsupported(instance, "fmi3GetShiftFraction", NO_CLOCKS) }
}

#[no_mangle]
pub unsafe extern "C" fn fmi3SetIntervalDecimal(
    instance: Component,
    _vr: *const u32,
    _n_vr: usize,
    _intervals: *const f64,
) -> Status {
    // SAFETY: the FMI contract (module doc): `instance` is NULL or a live instance of this FMU.
    unsafe { unsupported(instance, "fmi3SetIntervalDecimal", NO_CLOCKS) }
}

#[no_mangle]
pub unsafe extern "C" fn fmi3SetIntervalFraction(
    instance: Component,
    _vr: *const u32,
    _n_vr: usize,
    _counters: *const u64,
    _resolutions: *const u64,
) -> Status {
    // SAFETY: the FMI contract (module doc): `instance` is NULL or a live instance of this FMU.
    unsafe { unsupported(instance, "fmi3SetIntervalFraction", NO_CLOCKS) }
}

#[no_mangle]
pub unsafe extern "C" fn fmi3SetShiftDecimal(
    instance: Component,
    _vr: *const u32,
    _n_vr: usize,
    _shifts: *const f64,
) -> Status {
    // SAFETY: the FMI contract (module doc): `instance` is NULL or a live instance of this FMU.
    unsafe { unsupported(instance, "fmi3SetShiftDecimal", NO_CLOCKS) }
}

#[no_mangle]
pub unsafe extern "C" fn fmi3SetShiftFraction(
    instance: Component,
    _vr: *const u32,
    _n_vr: usize,
    _counters: *const u64,
    _resolutions: *const u64,
) -> Status {
    // SAFETY: the FMI contract (module doc): `instance` is NULL or a live instance of this FMU.
    unsafe { unsupported(instance, "fmi3SetShiftFraction", NO_CLOCKS) }
}

#[no_mangle]
pub unsafe extern "C" fn fmi3EvaluateDiscreteStates(instance: Component) -> Status {
    // SAFETY: the FMI contract (module doc): `instance` is NULL or a live instance of this FMU.
    unsafe { unsupported(instance, "fmi3EvaluateDiscreteStates", NO_EVENT_MODE) }
}

#[no_mangle]
pub unsafe extern "C" fn fmi3UpdateDiscreteStates(
    instance: Component,
    _discrete_states_need_update: *mut bool,
    _terminate_simulation: *mut bool,
    _nominals_changed: *mut bool,
    _values_changed: *mut bool,
    _next_event_time_defined: *mut bool,
    _next_event_time: *mut f64,
) -> Status {
    // SAFETY: the FMI contract (module doc): `instance` is NULL or a live instance of this FMU.
    unsafe { unsupported(instance, "fmi3UpdateDiscreteStates", NO_EVENT_MODE) }
}

// ---------------------------------------------------------------------------------------------
// Model Exchange

#[no_mangle]
pub unsafe extern "C" fn fmi3EnterContinuousTimeMode(instance: Component) -> Status {
    // SAFETY: the FMI contract (module doc): `instance` is NULL or a live instance of this FMU.
    unsafe { unsupported(instance, "fmi3EnterContinuousTimeMode", CO_SIMULATION_ONLY) }
}

#[no_mangle]
pub unsafe extern "C" fn fmi3CompletedIntegratorStep(
    instance: Component,
    _no_set_prior: bool,
    _enter_event_mode: *mut bool,
    _terminate_simulation: *mut bool,
) -> Status {
    // SAFETY: the FMI contract (module doc): `instance` is NULL or a live instance of this FMU.
    unsafe { unsupported(instance, "fmi3CompletedIntegratorStep", CO_SIMULATION_ONLY) }
}

#[no_mangle]
pub unsafe extern "C" fn fmi3SetTime(instance: Component, _time: f64) -> Status {
    // SAFETY: the FMI contract (module doc): `instance` is NULL or a live instance of this FMU.
    unsafe { unsupported(instance, "fmi3SetTime", CO_SIMULATION_ONLY) }
}

#[no_mangle]
pub unsafe extern "C" fn fmi3SetContinuousStates(
    instance: Component,
    _states: *const f64,
    _n: usize,
) -> Status {
    // SAFETY: the FMI contract (module doc): `instance` is NULL or a live instance of this FMU.
    unsafe { unsupported(instance, "fmi3SetContinuousStates", CO_SIMULATION_ONLY) }
}

#[no_mangle]
pub unsafe extern "C" fn fmi3GetContinuousStateDerivatives(
    instance: Component,
    _derivatives: *mut f64,
    _n: usize,
) -> Status {
    // SAFETY: the FMI contract (module doc): `instance` is NULL or a live instance of this FMU.
    unsafe {
        unsupported(
            instance,
            "fmi3GetContinuousStateDerivatives",
            CO_SIMULATION_ONLY,
        )
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi3GetEventIndicators(
    instance: Component,
    _indicators: *mut f64,
    _n: usize,
) -> Status {
    // SAFETY: the FMI contract (module doc): `instance` is NULL or a live instance of this FMU.
    unsafe { unsupported(instance, "fmi3GetEventIndicators", CO_SIMULATION_ONLY) }
}

#[no_mangle]
pub unsafe extern "C" fn fmi3GetContinuousStates(
    instance: Component,
    _states: *mut f64,
    _n: usize,
) -> Status {
    // SAFETY: the FMI contract (module doc): `instance` is NULL or a live instance of this FMU.
    unsafe { unsupported(instance, "fmi3GetContinuousStates", CO_SIMULATION_ONLY) }
}

#[no_mangle]
pub unsafe extern "C" fn fmi3GetNominalsOfContinuousStates(
    instance: Component,
    _nominals: *mut f64,
    _n: usize,
) -> Status {
    // SAFETY: the FMI contract (module doc): `instance` is NULL or a live instance of this FMU.
    unsafe {
        unsupported(
            instance,
            "fmi3GetNominalsOfContinuousStates",
            CO_SIMULATION_ONLY,
        )
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi3GetNumberOfEventIndicators(
    instance: Component,
    _n: *mut usize,
) -> Status {
    // SAFETY: the FMI contract (module doc): `instance` is NULL or a live instance of this FMU.
    unsafe {
        unsupported(
            instance,
            "fmi3GetNumberOfEventIndicators",
            CO_SIMULATION_ONLY,
        )
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi3GetNumberOfContinuousStates(
    instance: Component,
    _n: *mut usize,
) -> Status {
    // SAFETY: the FMI contract (module doc): `instance` is NULL or a live instance of this FMU.
    unsafe {
        unsupported(
            instance,
            "fmi3GetNumberOfContinuousStates",
            CO_SIMULATION_ONLY,
        )
    }
}

// ---------------------------------------------------------------------------------------------
// Co-Simulation

#[no_mangle]
pub unsafe extern "C" fn fmi3EnterStepMode(instance: Component) -> Status {
    // SAFETY: the FMI contract (module doc): `instance` is NULL or a live instance of this FMU.
    unsafe { unsupported(instance, "fmi3EnterStepMode", NO_EVENT_MODE) }
}

#[no_mangle]
pub unsafe extern "C" fn fmi3GetOutputDerivatives(
    instance: Component,
    _vr: *const u32,
    _n_vr: usize,
    _orders: *const i32,
    _values: *mut f64,
    _n_values: usize,
) -> Status {
    // SAFETY: the FMI contract (module doc): `instance` is NULL or a live instance of this FMU.
    unsafe {
        unsupported(
            instance,
            "fmi3GetOutputDerivatives",
            "maxOutputDerivativeOrder is 0",
        )
    }
}

#[no_mangle]
#[allow(clippy::too_many_arguments)] // the signature is fmi3Functions.h's
pub unsafe extern "C" fn fmi3DoStep(
    instance: Component,
    current_communication_point: f64,
    communication_step_size: f64,
    no_set_fmu_state_prior_to_current_point: bool,
    event_handling_needed: *mut bool,
    terminate_simulation: *mut bool,
    early_return: *mut bool,
    last_successful_time: *mut f64,
) -> Status {
    // SAFETY: the FMI contract (module doc): `instance` is NULL or a live instance of this FMU;
    // `event_handling_needed`, `terminate_simulation`, `early_return` and `last_successful_time`
    // are NULL or valid for a write.
    unsafe {
        with_instance(instance, "fmi3DoStep", |i| {
            let out = match (
                event_handling_needed.as_mut(),
                terminate_simulation.as_mut(),
                early_return.as_mut(),
                last_successful_time.as_mut(),
            ) {
                (Some(e), Some(t), Some(r), Some(l)) => Ok(DoStepOut {
                    event_handling_needed: e,
                    terminate_simulation: t,
                    early_return: r,
                    last_successful_time: l,
                }),
                (e, t, r, _) => {
                    let first = [
                        (e.is_none(), "eventHandlingNeeded"),
                        (t.is_none(), "terminateSimulation"),
                        (r.is_none(), "earlyReturn"),
                    ]
                    .into_iter()
                    .find(|(missing, _)| *missing)
                    .map_or("lastSuccessfulTime", |(_, name)| name);
                    Err(Error::NullPointer {
                        argument: format!("{first} (an out-argument)"),
                        length: None,
                    })
                }
            };
            i.do_step_fmi3(
                current_communication_point,
                communication_step_size,
                no_set_fmu_state_prior_to_current_point,
                out,
            )
        })
    }
}

// ---------------------------------------------------------------------------------------------
// Scheduled Execution

#[no_mangle]
pub unsafe extern "C" fn fmi3ActivateModelPartition(
    instance: Component,
    _clock_reference: u32,
    _activation_time: f64,
) -> Status {
    // SAFETY: the FMI contract (module doc): `instance` is NULL or a live instance of this FMU.
    unsafe {
        unsupported(
            instance,
            "fmi3ActivateModelPartition",
            "this is a Scheduled Execution function; the FMU is Co-Simulation only",
        )
    }
}
