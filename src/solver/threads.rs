//! The solver's own worker threads (`solver.threads` > 1): a rayon pool that the solver
//! creates, owns and joins, used for the triangle loop of the assembly (`assemble.rs`) and for
//! faer's parallel numeric factorization (`linear.rs`, `Par::rayon`).
//!
//! Never rayon's global pool: its threads live until the process ends, and a live thread that
//! runs (or will run the thread-local destructors of) code in the FMU's shared library keeps
//! that library from unloading after `dlclose` (the 2000-run test, harness/test_reliability.py).
//! So the pool's threads are spawned here with `std::thread::Builder` (rayon's `spawn_handler`)
//! and their join handles kept; dropping a [`Pool`] first drops the rayon pool (which tells its
//! workers to finish) and then joins every one of them. When `Drop` returns, no thread of the
//! pool exists any more.
//!
//! Nothing else may call rayon outside [`Pool::install`] / [`Pool::scope`]: a rayon call from
//! a thread outside any pool would start the global pool (tests/threads_join.rs counts the
//! process's threads before and after to show that none is left).

use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;

/// Most threads a scene may ask for (`solver.threads`). The pool's memory (stacks, per-thread
/// assembly buffers) grows with the count; 64 bounds it.
pub const MAX_THREADS: usize = 64;

/// A fixed-size pool of worker threads owned by one solver, joined when dropped.
pub struct Pool {
    pool: Option<rayon::ThreadPool>,
    handles: Arc<Mutex<Vec<JoinHandle<()>>>>,
    count: usize,
}

/// Why the pool could not be started (the OS refused a thread).
#[derive(Debug)]
pub struct PoolError(pub String);

impl Pool {
    /// A pool of `count` (2..=[`MAX_THREADS`]) threads named `velarium-<i>`.
    pub fn try_new(count: usize) -> Result<Pool, PoolError> {
        let count = count.clamp(1, MAX_THREADS);
        let handles: Arc<Mutex<Vec<JoinHandle<()>>>> = Arc::new(Mutex::new(Vec::new()));
        let sink = Arc::clone(&handles);
        let built = rayon::ThreadPoolBuilder::new()
            .num_threads(count)
            .thread_name(|i| format!("velarium-{i}"))
            .spawn_handler(move |thread| {
                let mut b = std::thread::Builder::new();
                if let Some(name) = thread.name() {
                    b = b.name(name.to_owned());
                }
                let handle = b.spawn(move || thread.run())?;
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

fn join_all(handles: &Mutex<Vec<JoinHandle<()>>>) {
    let handles = std::mem::take(&mut *handles.lock().unwrap_or_else(|e| e.into_inner()));
    for h in handles {
        // A worker's panic is caught by rayon and re-raised in the caller; the thread itself
        // ends normally. Nothing to report here either way.
        let _ = h.join();
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
