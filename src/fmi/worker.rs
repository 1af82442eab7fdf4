//! Run a piece of work on a short-lived thread of its own, created with `pthread_create`
//! directly, and wait for it.
//!
//! Why: the dense kernels under faer's factorization (the `gemm` crates) keep scratch buffers
//! in thread-locals that have destructors. glibc keeps a shared library loaded while any thread
//! still holds a TLS destructor registered from it (`__cxa_thread_atexit_impl`), so on the
//! master's thread, which lives as long as the process, they would pin this `.so` in memory
//! after every `dlclose`: one more copy per extracted FMU (FMI.md pitfall 4, the crash after
//! ~1000 runs). On a thread that ends here the destructors run before `pthread_join` returns.
//!
//! Why not `std::thread`: spawning a std thread (scoped or not) itself initializes
//! thread-locals with destructors on the *calling* thread (the current-thread handle, spawn
//! hooks), which pins the library just the same.
//!
//! A panic inside is caught on the worker and resumed on the calling thread, where the panic
//! boundary of `ffi.rs` turns it into fmi2Error. If no thread can be created, the work runs on
//! the calling thread (correct results; only the unloading guarantee is lost).

use std::any::Any;
use std::ffi::c_void;
use std::panic::{catch_unwind, resume_unwind, AssertUnwindSafe};
use std::ptr::null_mut;

/// Stack of the worker: what the master's main thread typically has.
const STACK_BYTES: usize = 8 << 20;

struct Job<F, T> {
    work: Option<F>,
    result: Option<Result<T, Box<dyn Any + Send>>>,
}

/// The worker's entry point. `arg` points to a live `Job<F, T>` that nothing else touches
/// until the thread is joined (only [`on_own_thread`] passes it).
extern "C" fn run<F: FnOnce() -> T, T>(arg: *mut c_void) -> *mut c_void {
    let job = unsafe { &mut *(arg as *mut Job<F, T>) };
    if let Some(work) = job.work.take() {
        job.result = Some(catch_unwind(AssertUnwindSafe(work)));
    }
    null_mut()
}

/// Run `work` on a fresh thread and return its result (see the module docs).
pub(crate) fn on_own_thread<F, T>(work: F) -> T
where
    F: FnOnce() -> T + Send,
    T: Send,
{
    let mut job = Job {
        work: Some(work),
        result: None,
    };
    let started = unsafe { spawn_and_join(run::<F, T>, &mut job as *mut Job<F, T> as *mut c_void) };
    if !started {
        let work = job.work.take().expect("the work did not start");
        return work();
    }
    match job.result.take() {
        Some(Ok(value)) => value,
        Some(Err(payload)) => resume_unwind(payload),
        None => unreachable!("the worker always stores a result"),
    }
}

/// Create a thread running `entry(arg)` and join it. False: no thread could be created (the
/// entry did not run).
///
/// # Safety
/// `entry(arg)` must be safe to run on another thread while the caller waits.
unsafe fn spawn_and_join(
    entry: extern "C" fn(*mut c_void) -> *mut c_void,
    arg: *mut c_void,
) -> bool {
    let mut attr: libc::pthread_attr_t = std::mem::zeroed();
    if libc::pthread_attr_init(&mut attr) != 0 {
        return false;
    }
    libc::pthread_attr_setstacksize(&mut attr, STACK_BYTES);
    let mut thread: libc::pthread_t = 0;
    let created = libc::pthread_create(&mut thread, &attr, entry, arg) == 0;
    libc::pthread_attr_destroy(&mut attr);
    if created {
        libc::pthread_join(thread, null_mut());
    }
    created
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn returns_the_value_and_mutates_borrowed_data() {
        let mut v = vec![1, 2];
        let n = on_own_thread(|| {
            v.push(3);
            v.len()
        });
        assert_eq!((n, v), (3, vec![1, 2, 3]));
    }

    #[test]
    fn a_panic_comes_back_to_the_caller() {
        let caught = catch_unwind(|| on_own_thread(|| -> u8 { panic!("inside") }));
        let payload = caught.expect_err("the panic is resumed");
        assert_eq!(payload.downcast_ref::<&str>(), Some(&"inside"));
    }
}
