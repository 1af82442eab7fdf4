//! The solver's own worker threads (`solver.threads` > 1): a rayon pool that the solver
//! creates, owns and joins, used for the triangle loop of the assembly (`assemble.rs`) and for
//! faer's parallel numeric factorization (`linear.rs`, `Par::rayon`).
//!
//! Never rayon's global pool: its threads live until the process ends, and a live thread that
//! runs (or will run the thread-local destructors of) code in the FMU's shared library keeps
//! that library from unloading after `dlclose` (the 2000-run tests of
//! harness/test_conformance_robust.py, one of them with 2 solver threads). So the pool's threads
//! are started through [`Start`] (rayon's `spawn_handler`) and joined: dropping a [`Pool`] first
//! drops the rayon pool (which tells its workers to finish) and then joins every one of them;
//! when `Drop` returns no thread of the pool exists, and their thread-local destructors have run.
//!
//! How a thread is started is the caller's choice ([`set_start`]): by default `std::thread`;
//! the FMU sets `pthread_create` (src/fmi/worker.rs), because a std thread's start creates a
//! pthread TLS key in the library (std's thread-local guard, Rust 1.95) that is never deleted, so
//! every load of the FMU would use up one of the process's 1024 keys ("fatal runtime error: out
//! of TLS keys" after about 1000 runs: measured with std threads here).
//!
//! What does stay behind after `dlclose` with a pool: about 11 KB of heap per load of the
//! library (measured with glibc's mallinfo2 over 300 loads; 0 without a pool). rayon's
//! work-stealing deques use crossbeam-epoch's collector, a lazily allocated static of the
//! library: its global record and the records each pool thread leaves when it exits are freed
//! only by a later thread of the same collector, and after the last pool thread has ended there
//! is none (collecting on an extra short-lived thread was tried: it leaves its own record, no
//! net gain). A host that loads and unloads such an FMU 1000 times holds about 11 MB more.
//!
//! Nothing else may call rayon outside [`Pool::install`] / [`Pool::scope`]: a rayon call from
//! a thread outside any pool would start the global pool (tests/threads_join.rs counts the
//! process's threads before and after to show that none is left).

use std::sync::{Arc, Mutex, OnceLock};

/// Most threads a pool may have (the scene's `solver.threads` is validated to 1..=64 too). The
/// pool's memory (stacks, per-thread assembly buffers) grows with the count; 64 bounds it.
pub const MAX_THREADS: usize = 64;

/// Stack of each pool thread (virtual; only the pages used are resident).
pub const STACK_BYTES: usize = 8 << 20;

/// What joins one started thread (blocks until it has ended).
pub struct Joiner(Box<dyn FnOnce() + Send>);

impl Joiner {
    pub fn new(join: impl FnOnce() + Send + 'static) -> Joiner {
        Joiner(Box::new(join))
    }
}

/// Starts a thread running `body` (with a stack of [`STACK_BYTES`]) and returns its joiner.
pub type Start = fn(Box<dyn FnOnce() + Send>) -> std::io::Result<Joiner>;

/// How this library starts pool threads: set once, before the first pool (the FMU's
/// `Worker::new` does); unset, `std::thread`. Later calls are ignored (the first setter wins:
/// a library-wide constant, not per-instance state).
static START: OnceLock<Start> = OnceLock::new();

/// Choose how pool threads are started (see [`START`]).
pub fn set_start(start: Start) {
    let _ = START.set(start);
}

fn start_std(body: Box<dyn FnOnce() + Send>) -> std::io::Result<Joiner> {
    let handle = std::thread::Builder::new()
        .name("velarium-pool".into())
        .stack_size(STACK_BYTES)
        .spawn(body)?;
    Ok(Joiner::new(move || {
        // rayon catches a job's panic and resumes it in the caller; the thread ends normally.
        let _ = handle.join();
    }))
}

/// A fixed-size pool of worker threads owned by one solver, joined when dropped.
pub struct Pool {
    pool: Option<rayon::ThreadPool>,
    handles: Arc<Mutex<Vec<Joiner>>>,
    count: usize,
}

/// Why the pool could not be started (the OS refused a thread).
#[derive(Debug)]
pub struct PoolError(pub String);

impl Pool {
    /// A pool of `count` (1..=[`MAX_THREADS`]) threads.
    pub fn try_new(count: usize) -> Result<Pool, PoolError> {
        let count = count.clamp(1, MAX_THREADS);
        let handles: Arc<Mutex<Vec<Joiner>>> = Arc::new(Mutex::new(Vec::new()));
        let sink = Arc::clone(&handles);
        let start = *START.get().unwrap_or(&(start_std as Start));
        let built = rayon::ThreadPoolBuilder::new()
            .num_threads(count)
            .spawn_handler(move |thread| {
                let handle = start(Box::new(move || thread.run()))?;
                sink.lock().unwrap_or_else(|e| e.into_inner()).push(handle);
                Ok(())
            })
            .build();
        match built {
            Ok(pool) => Ok(Pool {
                pool: Some(pool),
                handles,
                count,
            }),
            Err(e) => {
                // rayon terminates the threads it did start; wait for them before returning.
                join_all(&handles);
                Err(PoolError(format!(
                    "cannot start {count} solver threads: {e}"
                )))
            }
        }
    }

    /// Number of threads.
    pub fn count(&self) -> usize {
        self.count
    }

    /// Run `f` on the pool (the calling thread waits): rayon and faer's `Par::rayon` inside it
    /// use this pool's threads.
    pub fn install<R: Send>(&self, f: impl FnOnce() -> R + Send) -> R {
        self.pool.as_ref().expect("a live pool").install(f)
    }

    /// `rayon::ThreadPool::scope` on this pool.
    pub fn scope<'scope, R: Send>(&self, f: impl FnOnce(&rayon::Scope<'scope>) -> R + Send) -> R {
        self.pool.as_ref().expect("a live pool").scope(f)
    }
}

fn join_all(handles: &Mutex<Vec<Joiner>>) {
    let handles = std::mem::take(&mut *handles.lock().unwrap_or_else(|e| e.into_inner()));
    for h in handles {
        (h.0)();
    }
}

impl Drop for Pool {
    fn drop(&mut self) {
        // Dropping the rayon pool asks its workers to exit once their queues are empty (no
        // work is pending: every install/scope has returned); then wait for each to end.
        drop(self.pool.take());
        join_all(&self.handles);
    }
}

impl std::fmt::Debug for Pool {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Pool({} threads)", self.count)
    }
}
