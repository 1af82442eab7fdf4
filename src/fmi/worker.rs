//! Each instance owns one worker thread, created with `pthread_create` directly, that runs its
//! solves while the calling thread waits; the thread is joined when the instance is dropped
//! (`fmi2FreeInstance`).
//!
//! Why: the dense kernels under faer's factorization (the `gemm` crates) keep scratch buffers
//! in thread-locals that have destructors. glibc keeps a shared library loaded while any thread
//! still holds a TLS destructor registered from it (`__cxa_thread_atexit_impl`), so on the
//! master's thread, which lives as long as the process, they would pin this `.so` in memory
//! after every `dlclose`: one more copy per extracted FMU (docs/fmu.md, threads and the binary; the crash after
//! ~1000 runs). On the worker, the destructors run when it is joined, before
//! `fmi2FreeInstance` returns. Keeping one worker per instance (rather than one thread per
//! solve) keeps those buffers warm from step to step.
//!
//! Why not `std::thread`: spawning a std thread (scoped or not) itself initializes
//! thread-locals with destructors on the *calling* thread (the current-thread handle, spawn
//! hooks), which pins the library just the same. The hand-over below uses only a `Mutex` and a
//! `Condvar` (futexes, no thread-locals).
//!
//! A panic inside a job is caught on the worker and resumed on the calling thread, where the
//! panic boundary of `ffi.rs` turns it into fmi2Error. If no thread can be created, jobs run on
//! the calling thread (correct results; only the unloading guarantee is lost).

use std::any::Any;
use std::ffi::c_void;
use std::panic::{catch_unwind, resume_unwind, AssertUnwindSafe};
use std::ptr::null_mut;
use std::sync::{Arc, Condvar, Mutex, MutexGuard, PoisonError};

/// Stack of the worker: what the master's main thread typically has.
const STACK_BYTES: usize = 8 << 20;

/// The owner's job, type-erased: it lives on the owner's stack while the owner waits for
/// [`Slot::Finished`], so the worker never holds it longer than that.
struct Task(*mut (dyn FnMut() + Send));

// SAFETY: the pointee is `Send` and is only called by the worker while the owner is blocked.
unsafe impl Send for Task {}

enum Slot {
    Idle,
    Run(Task),
    Finished,
    Quit,
}

struct Shared {
    slot: Mutex<Slot>,
    changed: Condvar,
}

impl Shared {
    fn lock(&self) -> MutexGuard<'_, Slot> {
        self.slot.lock().unwrap_or_else(PoisonError::into_inner)
    }

    fn wait<'a>(&self, guard: MutexGuard<'a, Slot>) -> MutexGuard<'a, Slot> {
        self.changed
            .wait(guard)
            .unwrap_or_else(PoisonError::into_inner)
    }
}

/// One instance's worker thread (see the module docs).
pub(crate) struct Worker {
    shared: Arc<Shared>,
    thread: Option<libc::pthread_t>,
}

impl Worker {
    /// Start the thread (None inside if it could not be created: jobs then run in place).
    pub(crate) fn new() -> Worker {
        // The solver's pool threads (scenes with `solver.threads` > 1) are started the same
        // way as this worker, never as std threads (`solver::threads`).
        crate::solver::threads::set_start(start_pool_thread);
        let shared = Arc::new(Shared {
            slot: Mutex::new(Slot::Idle),
            changed: Condvar::new(),
        });
        let arg = Arc::into_raw(shared.clone()) as *mut c_void;
        // SAFETY: `arg` is an `Arc<Shared>` from `Arc::into_raw`, what `worker_main` expects.
        let thread = unsafe { spawn(arg) };
        if thread.is_none() {
            // SAFETY: the thread never took its reference, so this is its one owner: release it.
            drop(unsafe { Arc::from_raw(arg as *const Shared) });
        }
        Worker { shared, thread }
    }

    /// Run `work` on the worker and return its result; a panic in it is resumed here.
    pub(crate) fn run<F, T>(&self, work: F) -> T
    where
        F: FnOnce() -> T + Send,
        T: Send,
    {
        if self.thread.is_none() {
            return work();
        }
        let mut work = Some(work);
        let mut result: Option<Result<T, Box<dyn Any + Send>>> = None;
        let mut job = || {
            if let Some(work) = work.take() {
                result = Some(catch_unwind(AssertUnwindSafe(work)));
            }
        };
        let job: &mut (dyn FnMut() + Send + '_) = &mut job;
        // SAFETY: only the lifetime is erased; `hand_over` returns after the worker is done
        // with the job, while `job` is still alive.
        let task = Task(unsafe {
            std::mem::transmute::<*mut (dyn FnMut() + Send + '_), *mut (dyn FnMut() + Send)>(job)
        });
        self.hand_over(task);
        match result {
            Some(Ok(value)) => value,
            Some(Err(payload)) => resume_unwind(payload),
            None => unreachable!("the worker ran the job"),
        }
    }

    /// Give the worker the task and wait until it has run it.
    fn hand_over(&self, task: Task) {
        let mut slot = self.shared.lock();
        *slot = Slot::Run(task);
        self.shared.changed.notify_all();
        while !matches!(*slot, Slot::Finished) {
            slot = self.shared.wait(slot);
        }
        *slot = Slot::Idle;
    }
}

impl Drop for Worker {
    /// Stop the thread and join it: its thread-local destructors have run when this returns.
    fn drop(&mut self) {
        let Some(thread) = self.thread else {
            return;
        };
        *self.shared.lock() = Slot::Quit;
        self.shared.changed.notify_all();
        // SAFETY: `thread` is the joinable thread `spawn` created, joined only here.
        unsafe { libc::pthread_join(thread, null_mut()) };
    }
}

/// The worker's loop: run each task handed over, until told to quit. `arg` is an
/// `Arc<Shared>` turned into a raw pointer by [`Worker::new`], owned by this thread.
extern "C" fn worker_main(arg: *mut c_void) -> *mut c_void {
    // SAFETY: `arg` is the `Arc<Shared>` reference `Worker::new` handed to this thread.
    let shared = unsafe { Arc::from_raw(arg as *const Shared) };
    let mut slot = shared.lock();
    loop {
        match std::mem::replace(&mut *slot, Slot::Idle) {
            Slot::Run(task) => {
                drop(slot);
                // SAFETY: see `Task`; the job catches panics itself.
                unsafe { (*task.0)() };
                slot = shared.lock();
                *slot = Slot::Finished;
                shared.changed.notify_all();
            }
            Slot::Quit => return null_mut(),
            other => {
                *slot = other;
                slot = shared.wait(slot);
            }
        }
    }
}

/// Create the worker thread with `arg`. None: no thread could be created.
///
/// # Safety
/// `arg` must be what [`worker_main`] expects.
unsafe fn spawn(arg: *mut c_void) -> Option<libc::pthread_t> {
    // SAFETY: plain pthread calls on an attribute initialized before use; `arg` is what
    // `worker_main` expects (the caller's precondition).
    unsafe {
        let mut attr: libc::pthread_attr_t = std::mem::zeroed();
        if libc::pthread_attr_init(&mut attr) != 0 {
            return None;
        }
        libc::pthread_attr_setstacksize(&mut attr, STACK_BYTES);
        let mut thread: libc::pthread_t = 0;
        let created = libc::pthread_create(&mut thread, &attr, worker_main, arg) == 0;
        libc::pthread_attr_destroy(&mut attr);
        created.then_some(thread)
    }
}

/// The solver pool's thread starter in the FMU (`solver::threads::set_start`): `body` on a
/// thread of `pthread_create`, joined with `pthread_join`. Not `std::thread`: its start creates
/// a pthread TLS key in this library that is never deleted (std's thread-local guard), one per
/// load of the FMU, until the process runs out of keys after about 1000 loads.
fn start_pool_thread(
    body: Box<dyn FnOnce() + Send>,
) -> std::io::Result<crate::solver::threads::Joiner> {
    let arg = Box::into_raw(Box::new(body)) as *mut c_void;
    // SAFETY: plain pthread calls on an initialized attribute; `arg` is a boxed closure that
    // `pool_main` takes ownership of, or that is freed here when no thread starts.
    unsafe {
        let mut attr: libc::pthread_attr_t = std::mem::zeroed();
        let rc = libc::pthread_attr_init(&mut attr);
        if rc != 0 {
            drop(Box::from_raw(arg as *mut Box<dyn FnOnce() + Send>));
            return Err(std::io::Error::from_raw_os_error(rc));
        }
        libc::pthread_attr_setstacksize(&mut attr, crate::solver::threads::STACK_BYTES);
        let mut thread: libc::pthread_t = 0;
        let rc = libc::pthread_create(&mut thread, &attr, pool_main, arg);
        libc::pthread_attr_destroy(&mut attr);
        if rc != 0 {
            drop(Box::from_raw(arg as *mut Box<dyn FnOnce() + Send>));
            return Err(std::io::Error::from_raw_os_error(rc));
        }
        Ok(crate::solver::threads::Joiner::new(move || {
            // SAFETY: a joinable thread created above, joined once (the joiner is FnOnce).
            libc::pthread_join(thread, null_mut());
        }))
    }
}

/// A pool thread: the boxed body (rayon's worker loop), no panic across the C frame.
extern "C" fn pool_main(arg: *mut c_void) -> *mut c_void {
    // SAFETY: `start_pool_thread` passes a boxed closure and gives up ownership of it.
    let body = unsafe { Box::from_raw(arg as *mut Box<dyn FnOnce() + Send>) };
    let _ = catch_unwind(AssertUnwindSafe(body));
    null_mut()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn runs_jobs_in_turn_on_another_thread_with_borrowed_data() {
        let worker = Worker::new();
        let caller = std::thread::current().id();
        let mut v = vec![1, 2];
        for i in 3..6 {
            let (n, elsewhere) = worker.run(|| {
                v.push(i);
                (v.len(), std::thread::current().id() != caller)
            });
            assert_eq!(n, i as usize);
            assert!(elsewhere);
        }
        assert_eq!(v, vec![1, 2, 3, 4, 5]);
    }

    #[test]
    fn a_panic_comes_back_to_the_caller_and_the_worker_goes_on() {
        let worker = Worker::new();
        let caught = catch_unwind(AssertUnwindSafe(|| {
            worker.run(|| -> u8 { panic!("inside") })
        }));
        let payload = caught.expect_err("the panic is resumed");
        assert_eq!(payload.downcast_ref::<&str>(), Some(&"inside"));
        assert_eq!(worker.run(|| 7), 7);
    }
}
