//! The one panic boundary and the one set of pointer helpers of the C ABI.
//!
//! Every exported function goes through [`with_instance`] (or [`guard`] where there is no
//! instance yet), which
//!
//! ```text
//! 1. rejects a NULL (or foreign) instance pointer with fmi2Error,
//! 2. runs the safe body inside catch_unwind: a panic is logged, the instance goes to the
//!    Error state and the call returns fmi2Error (a panic never unwinds into the master),
//! ```
//!
//! and arrays become slices only through [`slice_in`] / [`slice_out`]: `n == 0` gives an empty
//! slice whatever the pointer, a NULL pointer with `n > 0` is an error naming the argument.
//! Instances are `Box`es handed out as raw pointers, tagged with a magic word so that a wrong
//! kind of pointer is rejected instead of misread.
//!
//! FMU states are `Box`es too, and each instance keeps the addresses of the states it handed
//! out and has not freed ([`StateHandles`]). A state pointer is dereferenced only after it is
//! found there: a pointer this instance did not hand out (another instance's state, a freed
//! one, a forged one, or the state itself where the address of a state variable belongs, as
//! the Reference-FMUs' `fmusim --final-fmu-state-file` passes it to `fmi2FreeFMUstate`) is
//! never read and the call returns Error with a message naming the argument. The states an
//! instance still holds are freed with it (`fmi2FreeInstance`).

use super::fmi2_ffi::{Component, FmuState, Status};
use super::instance::Instance;
use super::snapshot::Snapshot;
use crate::error::Error;
use std::any::Any;
use std::collections::HashSet;
use std::ffi::{c_char, c_void, CStr};
use std::panic::{catch_unwind, AssertUnwindSafe};

const INSTANCE_TAG: u64 = 0x5645_4c41_5249_4e53; // "VELARINS"

/// What an instance pointer points to (the tag first, so it can be read alone).
#[repr(C)]
pub(crate) struct InstanceBox {
    tag: u64,
    /// The FMU states this instance handed out and has not freed.
    states: StateHandles,
    instance: Instance,
}

/// The addresses of the live FMU states one instance handed out: the only state pointers it
/// ever dereferences.
#[derive(Default)]
pub(crate) struct StateHandles {
    live: HashSet<usize>,
}

impl StateHandles {
    /// Box a snapshot as a new FMU state of this instance.
    fn hand_out(&mut self, snapshot: Snapshot) -> FmuState {
        let s = Box::into_raw(Box::new(snapshot));
        self.live.insert(s as usize);
        s as FmuState
    }

    /// Whether `s` is a live state of this instance (compares the address only).
    fn owns(&self, s: FmuState) -> bool {
        self.live.contains(&(s as usize))
    }

    /// The snapshot behind a state of this instance, or an error naming the problem; a pointer
    /// that is not one is never read.
    fn get<'a>(&self, s: FmuState) -> Result<&'a mut Snapshot, Error> {
        if s.is_null() {
            return Err(null("FMUstate", None));
        }
        if !self.owns(s) {
            return Err(foreign_state(s));
        }
        // SAFETY: `s` is in `live`: it came from `hand_out` (a leaked `Box<Snapshot>`) and has
        // not been freed (freeing removes it). FMI calls on one instance do not overlap, so no
        // other reference to it is in use.
        Ok(unsafe { &mut *(s as *mut Snapshot) })
    }

    /// Free a state of this instance; a pointer that is not one is an error and is not read.
    fn free(&mut self, s: FmuState) -> Result<(), Error> {
        if !self.live.remove(&(s as usize)) {
            return Err(foreign_state(s));
        }
        // SAFETY: `s` was in `live` (just removed): a `Box<Snapshot>` leaked by `hand_out`,
        // dropped exactly once here.
        guard((), || drop(unsafe { Box::from_raw(s as *mut Snapshot) }));
        Ok(())
    }

    /// Check an `FMUstate*` argument: NULL gives None; the address of a state of this instance
    /// (a state passed where the address of a state variable belongs) is an error, and the
    /// pointer is not read.
    ///
    /// # Safety
    /// A `slot` that is not a state of this instance is NULL or valid for reads and writes.
    unsafe fn slot<'a>(&self, slot: *mut FmuState) -> Result<Option<&'a mut FmuState>, Error> {
        if self.owns(slot.cast()) {
            return Err(Error::Argument {
                argument: "FMUstate",
                message: format!(
                    "the FMU state argument {slot:p} is an FMU state itself, where the address \
                     of an FMU state variable belongs (pass &state); nothing was read, written \
                     or freed"
                ),
            });
        }
        // SAFETY: `slot` is not a state of this instance, so it is NULL or valid for reads and
        // writes (the caller's precondition).
        Ok(unsafe { slot.as_mut() })
    }
}

impl Drop for StateHandles {
    fn drop(&mut self) {
        for s in std::mem::take(&mut self.live) {
            // SAFETY: every address in `live` is a `Box<Snapshot>` leaked by `hand_out` and not
            // yet freed; each is dropped exactly once here.
            guard((), || drop(unsafe { Box::from_raw(s as *mut Snapshot) }));
        }
    }
}

/// A state pointer this instance did not hand out (or has freed).
fn foreign_state(s: FmuState) -> Error {
    Error::Argument {
        argument: "FMUstate",
        message: format!(
            "the FMU state {s:p} is not a live FMU state of this instance (never handed out \
             by it, or already freed); it was not read"
        ),
    }
}

/// Run `body`, turning a panic into `fallback`.
pub(crate) fn guard<T>(fallback: T, body: impl FnOnce() -> T) -> T {
    catch_unwind(AssertUnwindSafe(body)).unwrap_or(fallback)
}

/// The panic boundary of every function that takes an instance.
///
/// # Safety
/// `c` is NULL or a pointer returned by [`into_component`] and not yet freed.
pub(crate) unsafe fn with_instance(
    c: Component,
    function: &'static str,
    body: impl FnOnce(&mut Instance) -> Status,
) -> Status {
    // SAFETY: as this function's.
    unsafe { with_states(c, function, |i, _| body(i)) }
}

/// [`with_instance`] with the instance's FMU states beside it (the state functions).
///
/// # Safety
/// As [`with_instance`].
pub(crate) unsafe fn with_states(
    c: Component,
    function: &'static str,
    body: impl FnOnce(&mut Instance, &mut StateHandles) -> Status,
) -> Status {
    // SAFETY: a non-NULL `c` came from `into_component` (the caller's precondition): its tag
    // word is readable.
    if unsafe { !has_tag(c, INSTANCE_TAG) } {
        return Status::Error;
    }
    // SAFETY: `c` came from `into_component` and is not yet freed (the caller's precondition),
    // so it is a live `InstanceBox`; FMI calls on one instance do not overlap.
    let boxed = unsafe { &mut *(c as *mut InstanceBox) };
    let (instance, states) = (&mut boxed.instance, &mut boxed.states);
    match catch_unwind(AssertUnwindSafe(|| body(&mut *instance, states))) {
        Ok(status) => status,
        Err(payload) => {
            let message = panic_message(payload.as_ref());
            guard((), || instance.panicked(function, &message));
            Status::Error
        }
    }
}

/// Whether `p` is non-NULL and starts with `tag` (reads only the tag word).
///
/// # Safety
/// A non-NULL `p` points to at least 8 readable, aligned bytes.
unsafe fn has_tag(p: *mut c_void, tag: u64) -> bool {
    // SAFETY: `p` is not NULL, and a non-NULL `p` points to 8 readable, aligned bytes (the
    // caller's precondition).
    !p.is_null() && unsafe { (p as *const u64).read() } == tag
}

fn panic_message(payload: &(dyn Any + Send)) -> String {
    if let Some(s) = payload.downcast_ref::<&str>() {
        (*s).to_string()
    } else if let Some(s) = payload.downcast_ref::<String>() {
        s.clone()
    } else {
        "unknown panic payload".to_string()
    }
}

/// Hand an instance to the master.
pub(crate) fn into_component(instance: Instance) -> Component {
    Box::into_raw(Box::new(InstanceBox {
        tag: INSTANCE_TAG,
        states: StateHandles::default(),
        instance,
    })) as Component
}

/// Take an instance back and drop it with the FMU states it still holds. NULL or a foreign
/// pointer: nothing happens.
///
/// # Safety
/// `c` is NULL or a pointer returned by [`into_component`] and not yet freed.
pub(crate) unsafe fn free_component(c: Component) {
    // SAFETY: a non-NULL `c` came from `into_component` (the caller's precondition): its tag
    // word is readable.
    if unsafe { has_tag(c, INSTANCE_TAG) } {
        let boxed = c as *mut InstanceBox;
        // SAFETY: the tag matched and `c` is not yet freed (the caller's precondition), so
        // `boxed` is the box `into_component` leaked, dropped exactly once here.
        unsafe {
            (*boxed).tag = 0;
            guard((), || drop(Box::from_raw(boxed)));
        }
    }
}

/// The snapshot behind an FMU state of this instance, or an error naming the problem.
pub(crate) fn state_mut<'a>(states: &StateHandles, s: FmuState) -> Result<&'a mut Snapshot, Error> {
    states.get(s)
}

/// `fmi2GetFMUstate`: a NULL `*slot` gets a new state, a non-NULL one is overwritten in place
/// (the handle stays the same).
///
/// # Safety
/// `slot` is NULL, a state of this instance (rejected) or valid for reads and writes.
pub(crate) unsafe fn store_state(
    states: &mut StateHandles,
    slot: *mut FmuState,
    snapshot: Snapshot,
) -> Result<(), Error> {
    // SAFETY: the caller's precondition.
    let slot = unsafe { states.slot(slot) }?.ok_or_else(|| null("FMUstate", None))?;
    if slot.is_null() {
        *slot = states.hand_out(snapshot);
    } else {
        *states.get(*slot)? = snapshot;
    }
    Ok(())
}

/// `fmi2DeSerializeFMUstate`: always a new state (whatever `*slot` held before).
///
/// # Safety
/// `slot` is NULL, a state of this instance (rejected) or valid for writes.
pub(crate) unsafe fn store_new_state(
    states: &mut StateHandles,
    slot: *mut FmuState,
    snapshot: Snapshot,
) -> Result<(), Error> {
    // SAFETY: the caller's precondition.
    let slot = unsafe { states.slot(slot) }?.ok_or_else(|| null("FMUstate", None))?;
    *slot = states.hand_out(snapshot);
    Ok(())
}

/// `fmi2FreeFMUstate`: free `*slot` and set it to NULL; a NULL `slot` or `*slot` is a no-op. A
/// `*slot` that is not a live state of this instance is an error (and is neither read nor
/// freed).
///
/// # Safety
/// `slot` is NULL, a state of this instance (rejected) or valid for reads and writes.
pub(crate) unsafe fn release_state(
    states: &mut StateHandles,
    slot: *mut FmuState,
) -> Result<(), Error> {
    // SAFETY: the caller's precondition.
    let Some(slot) = unsafe { states.slot(slot) }? else {
        return Ok(());
    };
    if !slot.is_null() {
        states.free(*slot)?;
        *slot = std::ptr::null_mut();
    }
    Ok(())
}

/// An input array of `n` elements. `n == 0`: empty, whatever the pointer.
///
/// # Safety
/// A non-NULL `ptr` points to `n` readable, initialized elements.
pub(crate) unsafe fn slice_in<'a, T>(
    ptr: *const T,
    n: usize,
    name: &str,
) -> Result<&'a [T], Error> {
    if n == 0 {
        Ok(&[])
    } else if ptr.is_null() {
        Err(null(name, Some(n)))
    } else {
        // SAFETY: `ptr` is not NULL, so it points to `n` readable, initialized elements (the
        // caller's precondition).
        Ok(unsafe { std::slice::from_raw_parts(ptr, n) })
    }
}

/// An output array of `n` elements. `n == 0`: empty, whatever the pointer.
///
/// # Safety
/// A non-NULL `ptr` points to `n` writable elements.
pub(crate) unsafe fn slice_out<'a, T>(
    ptr: *mut T,
    n: usize,
    name: &str,
) -> Result<&'a mut [T], Error> {
    if n == 0 {
        Ok(&mut [])
    } else if ptr.is_null() {
        Err(null(name, Some(n)))
    } else {
        // SAFETY: `ptr` is not NULL, so it points to `n` writable elements (the caller's
        // precondition).
        Ok(unsafe { std::slice::from_raw_parts_mut(ptr, n) })
    }
}

/// A C string argument as UTF-8 text. NULL -> None; invalid UTF-8 is replaced.
///
/// # Safety
/// A non-NULL `ptr` points to a NUL-terminated string.
pub(crate) unsafe fn text<'a>(ptr: *const c_char) -> Option<std::borrow::Cow<'a, str>> {
    // SAFETY: `ptr` is not NULL, so it is NUL-terminated (the caller's precondition).
    (!ptr.is_null()).then(|| unsafe { CStr::from_ptr(ptr) }.to_string_lossy())
}

/// An array of C strings (`fmi2String[]`) as text; any NULL entry is an error.
///
/// # Safety
/// As [`slice_in`], and every entry as [`text`].
pub(crate) unsafe fn texts(
    ptr: *const *const c_char,
    n: usize,
    name: &str,
) -> Result<Vec<String>, Error> {
    // SAFETY: `ptr` is NULL or holds `n` pointers, each NULL or NUL-terminated (the caller's
    // precondition).
    unsafe { slice_in(ptr, n, name) }?
        .iter()
        .enumerate()
        .map(|(i, p)| {
            // SAFETY: as above, `*p` is NULL or NUL-terminated.
            unsafe { text(*p) }
                .map(|s| s.into_owned())
                .ok_or_else(|| null(&format!("{name}[{i}]"), None))
        })
        .collect()
}

/// Write through an out-pointer; NULL is an error naming it.
///
/// # Safety
/// A non-NULL `ptr` is valid for a write of `T`.
pub(crate) unsafe fn write_out<T>(ptr: *mut T, value: T, name: &str) -> Result<(), Error> {
    // SAFETY: `ptr` is NULL or valid for a write of `T` (the caller's precondition).
    match unsafe { ptr.as_mut() } {
        Some(p) => {
            *p = value;
            Ok(())
        }
        None => Err(null(name, None)),
    }
}

/// A NULL argument `name` (with its length when it is an array).
fn null(name: &str, length: Option<usize>) -> Error {
    Error::NullPointer {
        argument: name.to_string(),
        length,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn guard_catches_a_panic() {
        let status = guard(Status::Error, || -> Status { panic!("boom") });
        assert_eq!(status, Status::Error);
    }

    #[test]
    fn empty_arrays_ignore_the_pointer() {
        let s: &[f64] = unsafe { slice_in(std::ptr::null(), 0, "vr").unwrap() };
        assert!(s.is_empty());
        let e = unsafe { slice_in::<f64>(std::ptr::null(), 2, "value").unwrap_err() }.to_string();
        assert!(e.contains("value") && e.contains('2'), "{e}");
    }

    #[test]
    fn a_panic_becomes_an_error_and_reset_recovers() {
        use crate::fmi::fsm::FsmState;
        let c = into_component(Instance::for_tests());
        let state_is = |want: FsmState| unsafe {
            with_instance(c, "check", |i| {
                if i.state() == want {
                    Status::Ok
                } else {
                    Status::Fatal
                }
            })
        };
        let status = unsafe { with_instance(c, "fmi2DoStep", |_| -> Status { panic!("boom") }) };
        assert_eq!(status, Status::Error);
        assert_eq!(state_is(FsmState::Error), Status::Ok);
        assert_eq!(
            unsafe { with_instance(c, "fmi2Reset", Instance::reset) },
            Status::Ok
        );
        assert_eq!(state_is(FsmState::Instantiated), Status::Ok);
        unsafe { free_component(c) };
    }

    #[test]
    fn null_and_foreign_instances_are_rejected() {
        let status = unsafe { with_instance(std::ptr::null_mut(), "f", |_| Status::Ok) };
        assert_eq!(status, Status::Error);
        let mut not_an_instance = [0u64; 8];
        let c = not_an_instance.as_mut_ptr() as Component;
        assert_eq!(
            unsafe { with_instance(c, "f", |_| Status::Ok) },
            Status::Error
        );
        unsafe { free_component(c) };
    }
}
