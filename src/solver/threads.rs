//! The solver's own helper threads (`solver.threads` > 1): started when the solver is built,
//! joined when it is dropped. The solving thread itself is the first of the `threads`; the
//! pool holds the others (`threads - 1` helpers). Used by the two-domain factorization
//! (`split.rs`): the solving thread factors one half of the tangent while a helper factors the
//! other; and by the assembly (`assemble.rs`): the solving thread evaluates one half of the
//! triangles while a helper evaluates the other. Each has its own job slot on the helper; a
//! third runs one-off jobs beside the caller's own work ([`Pool::beside`]: the coarse start's
//! transfer, `engine/coarse.rs`).
//!
//! No global pool and no rayon: a thread that outlives the instance (rayon's global pool does)
//! keeps the FMU's shared library mapped after `dlclose` (the 2000-run tests of
//! harness/test_conformance_robust.py, one of them with 2 solver threads), and rayon's
//! work-stealing deques leave crossbeam-epoch's collector behind in the library (about 12 KB of
//! heap per load, measured on branch i15t). A helper here is a plain loop that waits on a
//! condition variable for its next job, and `Drop` tells it to end and joins it.
//!
//! Jobs are `'static` closures (the solver has no `unsafe` blocks, so a job cannot borrow the
//! caller's stack): what a job works on lives behind an `Arc<Mutex<_>>` that the caller fills
//! before [`Pool::start`] and reads after [`Pool::wait`]. A job is installed once
//! ([`Pool::set_job`]) and run any number of times, so a Newton iteration allocates nothing.
//!
//! How a thread is started is the caller's choice ([`set_start`]): by default `std::thread`;
//! the FMU sets `pthread_create` (src/fmi/worker.rs), because a std thread's start creates a
//! pthread TLS key in the library (std's thread-local guard, Rust 1.95) that is never deleted,
//! so every load of the FMU would use up one of the process's 1024 keys ("fatal runtime error:
//! out of TLS keys" after about 1000 runs: measured with std threads on branch i15t).

use crate::error::{Error, ThreadFailure};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::{Arc, Condvar, Mutex, MutexGuard, OnceLock};

/// Most threads a solver may have (the scene's `solver.threads` is validated to 1..=64 too).
pub const MAX_THREADS: usize = 64;

/// Stack of each helper thread (virtual; only the pages used are resident).
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

/// How this library starts helper threads: set once, before the first pool (the FMU's
/// `Worker::new` does); unset, `std::thread`. Later calls are ignored (the first setter wins:
/// a library-wide constant, not per-instance state).
static START: OnceLock<Start> = OnceLock::new();

/// Choose how helper threads are started (see [`START`]).
pub fn set_start(start: Start) {
    let _ = START.set(start);
}

fn start_std(body: Box<dyn FnOnce() + Send>) -> std::io::Result<Joiner> {
    let handle = std::thread::Builder::new()
        .name("velarium-pool".into())
        .stack_size(STACK_BYTES)
        .spawn(body)?;
    Ok(Joiner::new(move || {
        // A job's panic is caught inside the helper's loop; the thread ends normally.
        let _ = handle.join();
    }))
}

/// A job a helper runs each time it is started.
pub type Job = Box<dyn FnMut() + Send>;

/// Jobs a helper can hold at once, each in its own slot: the two-domain factorization's
/// ([`FACTOR`], `split.rs`), the assembly's ([`ASSEMBLE`], `assemble.rs`), a one-off job's
/// ([`ONCE`], [`Pool::beside`]) and the product K x's ([`PRODUCT`], `linear.rs`).
pub const SLOTS: usize = 4;
/// The slot of the two-domain factorization's job ([`Pool::set_job`], [`Pool::start`]).
pub const FACTOR: usize = 0;
/// The slot of the parallel assembly's job.
pub const ASSEMBLE: usize = 1;
/// The slot of a one-off job ([`Pool::beside`]).
pub const ONCE: usize = 2;
/// The slot of the product K x on two threads (`linear.rs`).
pub const PRODUCT: usize = 3;

#[derive(Default)]
struct State {
    jobs: [Option<Job>; SLOTS],
    /// The slot whose job the current (or last) start runs.
    slot: usize,
    /// Started and not yet finished.
    running: bool,
    /// The last run panicked (reported by [`Pool::wait`]).
    panicked: bool,
    exit: bool,
}

struct Shared {
    state: Mutex<State>,
    changed: Condvar,
}

impl Shared {
    fn lock(&self) -> MutexGuard<'_, State> {
        self.state.lock().unwrap_or_else(|e| e.into_inner())
    }
}

struct Helper {
    shared: Arc<Shared>,
    /// Behind a mutex so that the pool is `Sync` (a joiner is only `Send`).
    joiner: Mutex<Option<Joiner>>,
}

/// The solver's threads: the caller's plus `count - 1` helpers, joined when dropped.
pub struct Pool {
    helpers: Vec<Helper>,
    count: usize,
}

fn helper_loop(shared: Arc<Shared>) {
    let mut state = shared.lock();
    loop {
        while !state.running && !state.exit {
            state = shared
                .changed
                .wait(state)
                .unwrap_or_else(|e| e.into_inner());
        }
        if state.exit {
            return;
        }
        let slot = state.slot;
        let mut job = state.jobs[slot].take();
        drop(state);
        let panicked = match job.as_mut() {
            Some(job) => catch_unwind(AssertUnwindSafe(job)).is_err(),
            None => false,
        };
        state = shared.lock();
        state.jobs[slot] = job;
        state.panicked = panicked;
        state.running = false;
        shared.changed.notify_all();
    }
}

impl Pool {
    /// The solving thread plus `count - 1` (count in 1..=[`MAX_THREADS`]) helpers.
    /// Err([`ThreadFailure::Start`]) when the OS refuses a thread.
    pub fn try_new(count: usize) -> Result<Pool, Error> {
        let count = count.clamp(1, MAX_THREADS);
        let start = *START.get().unwrap_or(&(start_std as Start));
        let mut pool = Pool {
            helpers: Vec::new(),
            count,
        };
        for _ in 1..count {
            let shared = Arc::new(Shared {
                state: Mutex::new(State::default()),
                changed: Condvar::new(),
            });
            let mine = Arc::clone(&shared);
            match start(Box::new(move || helper_loop(mine))) {
                Ok(joiner) => pool.helpers.push(Helper {
                    shared,
                    joiner: Mutex::new(Some(joiner)),
                }),
                // Dropping `pool` ends and joins the helpers already started.
                Err(e) => {
                    return Err(Error::Thread(ThreadFailure::Start {
                        count,
                        reason: e.to_string(),
                    }))
                }
            }
        }
        Ok(pool)
    }

    /// Number of threads, the solving thread included.
    pub fn count(&self) -> usize {
        self.count
    }

    /// Number of helper threads (`count() - 1`).
    pub fn helpers(&self) -> usize {
        self.helpers.len()
    }

    /// Install the job helper `i` runs on each [`Pool::start`] (slot [`FACTOR`], replacing any
    /// earlier one). The helper must be idle (no start without its wait).
    pub fn set_job(&self, i: usize, job: Job) {
        self.set_job_in(i, FACTOR, job);
    }

    /// Install the job of helper `i`'s `slot` (< [`SLOTS`]), run by [`Pool::start_in`].
    pub fn set_job_in(&self, i: usize, slot: usize, job: Job) {
        let mut state = self.helpers[i].shared.lock();
        debug_assert!(!state.running);
        state.jobs[slot] = Some(job);
    }

    /// Run helper `i`'s [`FACTOR`] job once, on the helper (returns at once).
    pub fn start(&self, i: usize) {
        self.start_in(i, FACTOR);
    }

    /// Run the job of helper `i`'s `slot` once, on the helper (returns at once). The helper
    /// must be idle (every start is followed by its [`Pool::wait`]).
    pub fn start_in(&self, i: usize, slot: usize) {
        let shared = &self.helpers[i].shared;
        let mut state = shared.lock();
        debug_assert!(!state.running);
        state.slot = slot;
        state.running = true;
        shared.changed.notify_all();
    }

    /// `job` once on helper `i` (slot [`ONCE`]) while the calling thread runs `here`; both
    /// results once both have ended. What the job needs it owns (`Arc`s of what both read),
    /// and it is dropped after its run. The helper must be idle, and `here` must not start
    /// it. Err([`ThreadFailure::Panicked`]) if the job panicked.
    pub fn beside<T, U>(
        &self,
        i: usize,
        job: impl FnOnce() -> T + Send + 'static,
        here: impl FnOnce() -> U,
    ) -> Result<(T, U), Error>
    where
        T: Send + 'static,
    {
        let output: Arc<Mutex<Option<T>>> = Arc::new(Mutex::new(None));
        let theirs = Arc::clone(&output);
        let mut job = Some(job);
        self.set_job_in(
            i,
            ONCE,
            Box::new(move || {
                if let Some(job) = job.take() {
                    let value = job();
                    *theirs.lock().unwrap_or_else(|e| e.into_inner()) = Some(value);
                }
            }),
        );
        self.start_in(i, ONCE);
        let mine = here();
        let waited = self.wait(i);
        self.helpers[i].shared.lock().jobs[ONCE] = None;
        waited?;
        let theirs = output.lock().unwrap_or_else(|e| e.into_inner()).take();
        Ok((theirs.ok_or(Error::Thread(ThreadFailure::Panicked))?, mine))
    }

    /// `job` once on helper `i` (slot [`ONCE`]), returning at once; [`Pending::join`] waits
    /// for it and gives its result. What the job needs it owns. Until it has ended the helper
    /// is busy: a caller that starts another job on it first waits for it ([`Pool::wait`]),
    /// and no [`Pool::beside`] may run before the join.
    pub fn launch<T>(
        pool: &Arc<Pool>,
        i: usize,
        job: impl FnOnce() -> T + Send + 'static,
    ) -> Pending<T>
    where
        T: Send + 'static,
    {
        let output: Arc<Mutex<Option<T>>> = Arc::new(Mutex::new(None));
        let theirs = Arc::clone(&output);
        let mut job = Some(job);
        pool.set_job_in(
            i,
            ONCE,
            Box::new(move || {
                if let Some(job) = job.take() {
                    let value = job();
                    *theirs.lock().unwrap_or_else(|e| e.into_inner()) = Some(value);
                }
            }),
        );
        pool.start_in(i, ONCE);
        Pending {
            pool: Arc::clone(pool),
            i,
            output,
        }
    }

    /// Wait until helper `i`'s job has finished. Err([`ThreadFailure::Panicked`]) if it
    /// panicked.
    pub fn wait(&self, i: usize) -> Result<(), Error> {
        let shared = &self.helpers[i].shared;
        let mut state = shared.lock();
        while state.running {
            state = shared
                .changed
                .wait(state)
                .unwrap_or_else(|e| e.into_inner());
        }
        if std::mem::take(&mut state.panicked) {
            Err(Error::Thread(ThreadFailure::Panicked))
        } else {
            Ok(())
        }
    }
}

/// A job started by [`Pool::launch`].
pub struct Pending<T> {
    pool: Arc<Pool>,
    i: usize,
    output: Arc<Mutex<Option<T>>>,
}

impl<T> Pending<T> {
    /// The job's result once it has ended (the spent job dropped).
    /// Err([`ThreadFailure::Panicked`]) if it panicked (also when a [`Pool::wait`] in between
    /// was told so).
    pub fn join(self) -> Result<T, Error> {
        let waited = self.pool.wait(self.i);
        self.pool.helpers[self.i].shared.lock().jobs[ONCE] = None;
        waited?;
        let value = self.output.lock().unwrap_or_else(|e| e.into_inner()).take();
        value.ok_or(Error::Thread(ThreadFailure::Panicked))
    }
}

impl Drop for Pool {
    fn drop(&mut self) {
        for h in &self.helpers {
            let mut state = h.shared.lock();
            state.exit = true;
            h.shared.changed.notify_all();
        }
        for h in &mut self.helpers {
            let joiner = h.joiner.lock().unwrap_or_else(|e| e.into_inner()).take();
            if let Some(j) = joiner {
                (j.0)();
            }
            // The jobs (and what they hold) go with the helper.
            h.shared.lock().jobs = Default::default();
        }
    }
}

impl std::fmt::Debug for Pool {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Pool({} threads)", self.count)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_job_runs_on_its_helper_each_time_it_is_started() {
        let pool = Pool::try_new(3).unwrap();
        assert_eq!(pool.helpers(), 2);
        let counts: Vec<Arc<Mutex<usize>>> = (0..2).map(|_| Arc::default()).collect();
        for (i, c) in counts.iter().enumerate() {
            let c = Arc::clone(c);
            pool.set_job(i, Box::new(move || *c.lock().unwrap() += i + 1));
        }
        for _ in 0..5 {
            pool.start(0);
            pool.start(1);
            pool.wait(0).unwrap();
            pool.wait(1).unwrap();
        }
        assert_eq!(*counts[0].lock().unwrap(), 5);
        assert_eq!(*counts[1].lock().unwrap(), 10);
    }

    #[test]
    fn a_job_beside_the_caller_gives_both_results_and_is_dropped() {
        let pool = Pool::try_new(2).unwrap();
        let held = Arc::new(vec![1.0, 2.0, 3.0]);
        let theirs = Arc::clone(&held);
        let (a, b) = pool
            .beside(0, move || theirs.iter().sum::<f64>(), || held[0] * 10.0)
            .unwrap();
        assert_eq!((a, b), (6.0, 10.0));
        assert_eq!(Arc::strong_count(&held), 1, "the spent job holds nothing");
        let failed = pool.beside(0, || -> usize { panic!("the job fails") }, || 1);
        assert!(failed.is_err());
        assert_eq!(pool.beside(0, || 2, || 3).unwrap(), (2, 3));
    }

    #[test]
    fn a_launched_job_gives_its_result_at_the_join_and_is_dropped() {
        let pool = Arc::new(Pool::try_new(2).unwrap());
        let held = Arc::new(vec![1.0, 2.0, 3.0]);
        let theirs = Arc::clone(&held);
        let pending = Pool::launch(&pool, 0, move || theirs.iter().sum::<f64>());
        let here = held[0] * 10.0;
        assert_eq!((pending.join().unwrap(), here), (6.0, 10.0));
        assert_eq!(Arc::strong_count(&held), 1, "the spent job holds nothing");
        // A wait in between (another job's start) leaves the result to the join.
        let pending = Pool::launch(&pool, 0, || 7);
        pool.wait(0).unwrap();
        assert_eq!(pending.join().unwrap(), 7);
        let failed = Pool::launch(&pool, 0, || -> usize { panic!("the job fails") });
        assert!(pool.wait(0).is_err());
        assert!(failed.join().is_err());
        assert_eq!(pool.beside(0, || 2, || 3).unwrap(), (2, 3));
    }

    #[test]
    fn a_panicking_job_is_reported_and_the_helper_lives_on() {
        let pool = Pool::try_new(2).unwrap();
        let hits = Arc::new(Mutex::new(0));
        let h = Arc::clone(&hits);
        pool.set_job(
            0,
            Box::new(move || {
                let mut n = h.lock().unwrap();
                *n += 1;
                if *n == 1 {
                    drop(n);
                    panic!("first run fails");
                }
            }),
        );
        pool.start(0);
        assert!(pool.wait(0).is_err());
        pool.start(0);
        assert!(pool.wait(0).is_ok());
        assert_eq!(*hits.lock().unwrap(), 2);
    }
}
