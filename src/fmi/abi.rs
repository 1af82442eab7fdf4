//! The 34 exported FMI 2.0 functions (common + Co-Simulation), each a short shim:
//! [`with_instance`] (NULL instance -> fmi2Error, panic boundary), pointer arguments turned into
//! `Result`s by the helpers of `ffi.rs`, then one method of [`Instance`].
//!
//! # Safety
//! The contract is the FMI 2.0 standard's: `c` is NULL or an instance from `fmi2Instantiate`
//! not yet freed; an array argument with length `n > 0` is NULL (rejected) or holds `n`
//! elements; strings are NUL-terminated; an `fmi2FMUstate*` is NULL or points to a variable.
//! Within that contract no call crashes or unwinds into the caller. An `fmi2FMUstate` may be
//! anything: it is read only if this instance handed it out and has not freed it (`ffi.rs`), so
//! a foreign or freed state, or a state passed where its address belongs, is an Error.

// The names are the standard's (fmi2GetReal, ...), and every function's `# Safety` is the one
// contract above, stated once.
#![allow(non_snake_case, clippy::missing_safety_doc)]

use super::ffi::{
    free_component, guard, into_component, release_state, slice_in, slice_out, state_mut,
    store_new_state, store_state, text, texts, with_instance, with_states, write_out,
};
use super::fmi2_ffi::{CallbackFunctions, Component, FmuState, Status};
use super::fsm::Func;
use super::instance::{Instance, InstantiateArgs};
use super::logging::Logger;
use std::ffi::{c_char, c_int, c_uint};
use std::ptr::null_mut;

/// `fmi2Boolean`.
pub type Fmi2Boolean = c_int;

#[no_mangle]
pub extern "C" fn fmi2GetTypesPlatform() -> *const c_char {
    c"default".as_ptr()
}

#[no_mangle]
pub extern "C" fn fmi2GetVersion() -> *const c_char {
    c"2.0".as_ptr()
}

#[no_mangle]
pub unsafe extern "C" fn fmi2SetDebugLogging(
    c: Component,
    logging_on: Fmi2Boolean,
    n_categories: usize,
    categories: *const *const c_char,
) -> Status {
    // SAFETY: the FMI contract (module doc): `c` is NULL or a live instance of this FMU;
    // `categories` is NULL or holds `n_categories` pointers, each NULL or NUL-terminated.
    unsafe {
        with_instance(c, "fmi2SetDebugLogging", |i| {
            i.set_debug_logging(
                logging_on != 0,
                texts(categories, n_categories, "categories"),
            )
        })
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2Instantiate(
    instance_name: *const c_char,
    fmu_type: c_int,
    fmu_guid: *const c_char,
    fmu_resource_location: *const c_char,
    functions: *const CallbackFunctions,
    _visible: Fmi2Boolean,
    logging_on: Fmi2Boolean,
) -> Component {
    // SAFETY: the FMI contract (module doc): `instance_name`, `fmu_guid` and
    // `fmu_resource_location` are NULL or NUL-terminated; `functions` is NULL or points to an
    // fmi2CallbackFunctions.
    unsafe {
        guard(null_mut(), || {
            let callbacks = functions.as_ref();
            let (name, guid, location) = (
                text(instance_name),
                text(fmu_guid),
                text(fmu_resource_location),
            );
            let logger = Logger::new(
                callbacks.and_then(|f| f.logger),
                callbacks.map_or(null_mut(), |f| f.component_environment),
                name.as_deref().unwrap_or_default(),
                logging_on != 0,
            );
            let args = InstantiateArgs {
                instance_name: name.as_deref(),
                fmu_type,
                guid: guid.as_deref(),
                resource_location: location.as_deref(),
            };
            Instance::instantiate(&args, logger).map_or(null_mut(), into_component)
        })
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2FreeInstance(c: Component) {
    // SAFETY: the FMI contract (module doc): `c` is NULL or a live instance of this FMU,
    // which the master gives up with this call.
    unsafe {
        with_instance(c, "fmi2FreeInstance", Instance::freeing);
        free_component(c);
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2SetupExperiment(
    c: Component,
    tolerance_defined: Fmi2Boolean,
    tolerance: f64,
    start_time: f64,
    stop_time_defined: Fmi2Boolean,
    stop_time: f64,
) -> Status {
    let tolerance = (tolerance_defined != 0).then_some(tolerance);
    let stop_time = (stop_time_defined != 0).then_some(stop_time);
    // SAFETY: the FMI contract (module doc): `c` is NULL or a live instance of this FMU.
    unsafe {
        with_instance(c, "fmi2SetupExperiment", |i| {
            i.setup_experiment(tolerance, start_time, stop_time)
        })
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2EnterInitializationMode(c: Component) -> Status {
    // SAFETY: the FMI contract (module doc): `c` is NULL or a live instance of this FMU.
    unsafe {
        with_instance(
            c,
            "fmi2EnterInitializationMode",
            Instance::enter_initialization_mode,
        )
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2ExitInitializationMode(c: Component) -> Status {
    // SAFETY: the FMI contract (module doc): `c` is NULL or a live instance of this FMU.
    unsafe {
        with_instance(
            c,
            "fmi2ExitInitializationMode",
            Instance::exit_initialization_mode,
        )
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2Terminate(c: Component) -> Status {
    // SAFETY: the FMI contract (module doc): `c` is NULL or a live instance of this FMU.
    unsafe { with_instance(c, "fmi2Terminate", Instance::terminate) }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2Reset(c: Component) -> Status {
    // SAFETY: the FMI contract (module doc): `c` is NULL or a live instance of this FMU.
    unsafe { with_instance(c, "fmi2Reset", Instance::reset) }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2GetReal(
    c: Component,
    vr: *const c_uint,
    nvr: usize,
    value: *mut f64,
) -> Status {
    // SAFETY: the FMI contract (module doc): `c` is NULL or a live instance of this FMU; `vr` and
    // `value` are NULL or hold `nvr` elements.
    unsafe {
        with_instance(c, "fmi2GetReal", |i| {
            i.get_real(slice_in(vr, nvr, "vr"), slice_out(value, nvr, "value"))
        })
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2GetInteger(
    c: Component,
    vr: *const c_uint,
    nvr: usize,
    value: *mut c_int,
) -> Status {
    // SAFETY: the FMI contract (module doc): `c` is NULL or a live instance of this FMU; `vr` and
    // `value` are NULL or hold `nvr` elements.
    unsafe {
        with_instance(c, "fmi2GetInteger", |i| {
            i.get_integer(slice_in(vr, nvr, "vr"), slice_out(value, nvr, "value"))
        })
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2GetBoolean(
    c: Component,
    vr: *const c_uint,
    nvr: usize,
    _value: *mut Fmi2Boolean,
) -> Status {
    // SAFETY: the FMI contract (module doc): `c` is NULL or a live instance of this FMU; `vr` is
    // NULL or holds `nvr` elements.
    unsafe {
        with_instance(c, "fmi2GetBoolean", |i| {
            i.no_such_variables(Func::GetBoolean, "Boolean", slice_in(vr, nvr, "vr"))
        })
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2GetString(
    c: Component,
    vr: *const c_uint,
    nvr: usize,
    _value: *mut *const c_char,
) -> Status {
    // SAFETY: the FMI contract (module doc): `c` is NULL or a live instance of this FMU; `vr` is
    // NULL or holds `nvr` elements.
    unsafe {
        with_instance(c, "fmi2GetString", |i| {
            i.no_such_variables(Func::GetString, "String", slice_in(vr, nvr, "vr"))
        })
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2SetReal(
    c: Component,
    vr: *const c_uint,
    nvr: usize,
    value: *const f64,
) -> Status {
    // SAFETY: the FMI contract (module doc): `c` is NULL or a live instance of this FMU; `vr` and
    // `value` are NULL or hold `nvr` elements.
    unsafe {
        with_instance(c, "fmi2SetReal", |i| {
            i.set_real(slice_in(vr, nvr, "vr"), slice_in(value, nvr, "value"))
        })
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2SetInteger(
    c: Component,
    vr: *const c_uint,
    nvr: usize,
    value: *const c_int,
) -> Status {
    // SAFETY: the FMI contract (module doc): `c` is NULL or a live instance of this FMU; `vr` and
    // `value` are NULL or hold `nvr` elements.
    unsafe {
        with_instance(c, "fmi2SetInteger", |i| {
            i.set_integer(slice_in(vr, nvr, "vr"), slice_in(value, nvr, "value"))
        })
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2SetBoolean(
    c: Component,
    vr: *const c_uint,
    nvr: usize,
    _value: *const Fmi2Boolean,
) -> Status {
    // SAFETY: the FMI contract (module doc): `c` is NULL or a live instance of this FMU; `vr` is
    // NULL or holds `nvr` elements.
    unsafe {
        with_instance(c, "fmi2SetBoolean", |i| {
            i.no_such_variables(Func::SetBoolean, "Boolean", slice_in(vr, nvr, "vr"))
        })
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2SetString(
    c: Component,
    vr: *const c_uint,
    nvr: usize,
    _value: *const *const c_char,
) -> Status {
    // SAFETY: the FMI contract (module doc): `c` is NULL or a live instance of this FMU; `vr` is
    // NULL or holds `nvr` elements.
    unsafe {
        with_instance(c, "fmi2SetString", |i| {
            i.no_such_variables(Func::SetString, "String", slice_in(vr, nvr, "vr"))
        })
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2GetFMUstate(c: Component, state: *mut FmuState) -> Status {
    // SAFETY: the FMI contract (module doc): `c` is NULL or a live instance of this FMU; `state` is
    // NULL, a state of this instance (rejected) or valid for reads and writes.
    unsafe {
        with_states(c, "fmi2GetFMUstate", |i, h| {
            i.get_fmu_state(|s| store_state(h, state, s))
        })
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2SetFMUstate(c: Component, state: FmuState) -> Status {
    // SAFETY: the FMI contract (module doc): `c` is NULL or a live instance of this FMU; `state` is
    // any pointer (checked against the instance's states, never read unless one).
    unsafe {
        with_states(c, "fmi2SetFMUstate", |i, h| {
            i.set_fmu_state(state_mut(h, state).map(|s| &*s))
        })
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2FreeFMUstate(c: Component, state: *mut FmuState) -> Status {
    // SAFETY: the FMI contract (module doc): `c` is NULL or a live instance of this FMU; `state` is
    // NULL, a state of this instance (rejected) or valid for reads and writes.
    unsafe {
        with_states(c, "fmi2FreeFMUstate", |i, h| {
            i.free_fmu_state(|| release_state(h, state))
        })
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2SerializedFMUstateSize(
    c: Component,
    state: FmuState,
    size: *mut usize,
) -> Status {
    // SAFETY: the FMI contract (module doc): `c` is NULL or a live instance of this FMU; `state` is
    // any pointer (checked against the instance's states); `size` is NULL or valid for a write.
    unsafe {
        with_states(c, "fmi2SerializedFMUstateSize", |i, h| {
            i.serialized_fmu_state_size(state_mut(h, state).map(|s| &*s), |n| {
                write_out(size, n, "size")
            })
        })
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2SerializeFMUstate(
    c: Component,
    state: FmuState,
    bytes: *mut c_char,
    size: usize,
) -> Status {
    // SAFETY: the FMI contract (module doc): `c` is NULL or a live instance of this FMU; `bytes` is
    // NULL or holds `size` elements; `state` is any pointer (checked against the instance's states).
    unsafe {
        with_states(c, "fmi2SerializeFMUstate", |i, h| {
            i.serialize_fmu_state(
                state_mut(h, state).map(|s| &*s),
                slice_out(bytes.cast::<u8>(), size, "serializedState"),
            )
        })
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2DeSerializeFMUstate(
    c: Component,
    bytes: *const c_char,
    size: usize,
    state: *mut FmuState,
) -> Status {
    // SAFETY: the FMI contract (module doc): `c` is NULL or a live instance of this FMU; `bytes` is
    // NULL or holds `size` elements; `state` is NULL, a state of this instance (rejected) or valid for
    // writes.
    unsafe {
        with_states(c, "fmi2DeSerializeFMUstate", |i, h| {
            i.deserialize_fmu_state(slice_in(bytes.cast::<u8>(), size, "serializedState"), |s| {
                store_new_state(h, state, s)
            })
        })
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2GetDirectionalDerivative(
    c: Component,
    unknown: *const c_uint,
    n_unknown: usize,
    known: *const c_uint,
    n_known: usize,
    dv_known: *const f64,
    dv_unknown: *mut f64,
) -> Status {
    // SAFETY: the FMI contract (module doc): `c` is NULL or a live instance of this FMU; `unknown`
    // and `dv_unknown` are NULL or hold `n_unknown` elements; `known` and `dv_known` are NULL or
    // hold `n_known` elements.
    unsafe {
        with_instance(c, "fmi2GetDirectionalDerivative", |i| {
            i.directional_derivative_fmi2(
                slice_in(unknown, n_unknown, "vUnknown_ref"),
                slice_in(known, n_known, "vKnown_ref"),
                slice_in(dv_known, n_known, "dvKnown"),
                slice_out(dv_unknown, n_unknown, "dvUnknown"),
            )
        })
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2SetRealInputDerivatives(
    c: Component,
    _vr: *const c_uint,
    _nvr: usize,
    _order: *const c_int,
    _value: *const f64,
) -> Status {
    // SAFETY: the FMI contract (module doc): `c` is NULL or a live instance of this FMU.
    unsafe {
        with_instance(c, "fmi2SetRealInputDerivatives", |i| {
            i.unsupported(
                Func::SetRealInputDerivatives,
                "canInterpolateInputs is false; inputs are held over each step",
            )
        })
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2GetRealOutputDerivatives(
    c: Component,
    _vr: *const c_uint,
    _nvr: usize,
    _order: *const c_int,
    _value: *mut f64,
) -> Status {
    // SAFETY: the FMI contract (module doc): `c` is NULL or a live instance of this FMU.
    unsafe {
        with_instance(c, "fmi2GetRealOutputDerivatives", |i| {
            i.unsupported(
                Func::GetRealOutputDerivatives,
                "maxOutputDerivativeOrder is 0",
            )
        })
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2DoStep(
    c: Component,
    t: f64,
    h: f64,
    no_set_prior: Fmi2Boolean,
) -> Status {
    // SAFETY: the FMI contract (module doc): `c` is NULL or a live instance of this FMU.
    unsafe { with_instance(c, "fmi2DoStep", |i| i.do_step(t, h, no_set_prior != 0)) }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2CancelStep(c: Component) -> Status {
    // SAFETY: the FMI contract (module doc): `c` is NULL or a live instance of this FMU.
    unsafe {
        with_instance(c, "fmi2CancelStep", |i| {
            i.unsupported(
                Func::CancelStep,
                "fmi2DoStep never runs asynchronously, so there is no step to cancel",
            )
        })
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2GetStatus(c: Component, kind: c_int, _value: *mut Status) -> Status {
    // SAFETY: the FMI contract (module doc): `c` is NULL or a live instance of this FMU.
    unsafe { with_instance(c, "fmi2GetStatus", |i| i.get_status(kind)) }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2GetRealStatus(c: Component, kind: c_int, value: *mut f64) -> Status {
    // SAFETY: the FMI contract (module doc): `c` is NULL or a live instance of this FMU; `value` is
    // NULL or valid for a write.
    unsafe {
        with_instance(c, "fmi2GetRealStatus", |i| {
            i.get_real_status(kind, |v| write_out(value, v, "value"))
        })
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2GetIntegerStatus(
    c: Component,
    kind: c_int,
    _value: *mut c_int,
) -> Status {
    // SAFETY: the FMI contract (module doc): `c` is NULL or a live instance of this FMU.
    unsafe {
        with_instance(c, "fmi2GetIntegerStatus", |i| {
            i.no_such_status(Func::GetIntegerStatus, kind)
        })
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2GetBooleanStatus(
    c: Component,
    kind: c_int,
    value: *mut Fmi2Boolean,
) -> Status {
    // SAFETY: the FMI contract (module doc): `c` is NULL or a live instance of this FMU; `value` is
    // NULL or valid for a write.
    unsafe {
        with_instance(c, "fmi2GetBooleanStatus", |i| {
            i.get_boolean_status(kind, |v| write_out(value, v as Fmi2Boolean, "value"))
        })
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2GetStringStatus(
    c: Component,
    kind: c_int,
    _value: *mut *const c_char,
) -> Status {
    // SAFETY: the FMI contract (module doc): `c` is NULL or a live instance of this FMU.
    unsafe {
        with_instance(c, "fmi2GetStringStatus", |i| {
            i.no_such_status(Func::GetStringStatus, kind)
        })
    }
}
