//! Wall and CPU time of the named phases of building an engine (mesh generation, the model,
//! the pattern, renumbering, ordering, symbolic analyses, allocation): off unless switched on
//! by [`enable`] (the scaling benchmark's `--timings`), so that an ordinary build pays one
//! relaxed atomic load per phase and nothing else. No environment variable switches it on:
//! in a host that never calls [`take`] (an FMU's) the record would only grow.
//!
//! A phase is timed from [`start`] to the drop of the guard it returns; phases nest (the
//! depth on the thread is recorded, so a report can indent them). The CPU time is the whole
//! process's (every thread, the helper's included, in 10 ms ticks) and the phase's own
//! thread's (the scheduler's run time, nanoseconds), both from /proc (no `unsafe` outside
//! src/fmi), so two engines built at once would see each other's; the scaling benchmark builds one at a time
//! (`examples/scale.rs --timings`, docs/performance.md "Setup phases").

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Mutex;
use std::time::Instant;

/// Whether phases are recorded.
static ON: AtomicBool = AtomicBool::new(false);
static LOG: Mutex<Vec<Phase>> = Mutex::new(Vec::new());
/// Phases started so far (each phase's [`Phase::seq`]).
static STARTED: AtomicU64 = AtomicU64::new(0);
thread_local! {
    /// Phases open on this thread.
    static DEPTH: std::cell::Cell<usize> = const { std::cell::Cell::new(0) };
}

/// One timed phase.
#[derive(Clone, Debug, PartialEq)]
pub struct Phase {
    pub name: &'static str,
    /// How many phases enclose it on its thread (0: outermost).
    pub depth: usize,
    /// Its place in the order the phases started.
    pub seq: u64,
    /// The thread it ran on (a helper's phases overlap the solving thread's).
    pub thread: std::thread::ThreadId,
    /// Seconds of wall time.
    pub wall: f64,
    /// Seconds of CPU time of the whole process (user + system) over the phase.
    pub cpu: f64,
    /// Seconds of CPU time of the phase's own thread: on an idle machine with a core for
    /// each thread, what the phase's wall time would be where it waits for nothing.
    pub thread_cpu: f64,
}

/// Switch recording on or off for the whole process.
pub fn enable(on: bool) {
    ON.store(on, Ordering::Relaxed);
}

/// Whether phases are recorded.
pub fn enabled() -> bool {
    ON.load(Ordering::Relaxed)
}

/// The phases recorded so far, in the order they started; the record is emptied.
pub fn take() -> Vec<Phase> {
    let mut out = std::mem::take(&mut *LOG.lock().unwrap_or_else(|e| e.into_inner()));
    out.sort_by_key(|p| p.seq);
    out
}

/// CPU seconds (user + system) of the whole process so far, every thread's, those that have
/// ended included (/proc/self/stat, utime + stime, in clock ticks of 10 ms: Linux's USER_HZ of
/// 100 on every architecture we build for). NaN where that is missing (not Linux). Summing the
/// live threads' scheduler run times instead (nanoseconds) fell when a thread ended during a
/// phase, giving negative CPU times.
pub fn process_cpu() -> f64 {
    process_ticks().map_or(f64::NAN, |t| t as f64 / USER_HZ)
}

/// Clock ticks per second of /proc's CPU times (USER_HZ).
const USER_HZ: f64 = 100.0;

/// utime + stime of /proc/self/stat (fields 14 and 15; the command name, field 2, is in
/// parentheses and may hold spaces, so the fields are counted after its closing one).
fn process_ticks() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/self/stat").ok()?;
    let mut after = text[text.rfind(')')? + 1..].split_whitespace();
    // After the name: field 3 (state) is the first; utime is field 14.
    let utime: u64 = after.nth(11)?.parse().ok()?;
    let stime: u64 = after.next()?.parse().ok()?;
    Some(utime + stime)
}

/// CPU seconds (user + system) of the calling thread so far (/proc/thread-self/schedstat;
/// NaN where that is missing).
pub fn thread_cpu() -> f64 {
    run_time(std::path::Path::new("/proc/thread-self/schedstat")).unwrap_or(f64::NAN)
}

/// The first field of a schedstat file: nanoseconds on a CPU, in seconds.
fn run_time(path: &std::path::Path) -> Option<f64> {
    let text = std::fs::read_to_string(path).ok()?;
    let ns: u64 = text.split_whitespace().next()?.parse().ok()?;
    Some(ns as f64 * 1e-9)
}

/// Phases open on this thread (what a job handed to a helper passes to [`start_under`]).
pub fn depth() -> usize {
    DEPTH.with(|d| d.get())
}

/// Times one phase until the guard is dropped (None when recording is off).
pub fn start(name: &'static str) -> Option<Timer> {
    if !enabled() {
        return None;
    }
    let depth = DEPTH.with(|d| d.replace(d.get() + 1));
    Some(Timer::new(name, depth))
}

/// [`start`] on a helper thread for work handed over by a thread with `depth` phases open
/// ([`depth`]): the phase and those inside it are recorded as nested there.
pub fn start_under(name: &'static str, depth: usize) -> Option<Timer> {
    if !enabled() {
        return None;
    }
    DEPTH.with(|d| d.set(depth + 1));
    Some(Timer::new(name, depth))
}

impl Timer {
    fn new(name: &'static str, depth: usize) -> Timer {
        Timer {
            name,
            depth,
            seq: STARTED.fetch_add(1, Ordering::Relaxed),
            wall: Instant::now(),
            cpu: process_cpu(),
            thread_cpu: thread_cpu(),
        }
    }
}

/// The running phase (see [`start`]).
pub struct Timer {
    name: &'static str,
    depth: usize,
    seq: u64,
    wall: Instant,
    cpu: f64,
    thread_cpu: f64,
}

impl Drop for Timer {
    fn drop(&mut self) {
        let phase = Phase {
            name: self.name,
            depth: self.depth,
            seq: self.seq,
            thread: std::thread::current().id(),
            wall: self.wall.elapsed().as_secs_f64(),
            cpu: process_cpu() - self.cpu,
            thread_cpu: thread_cpu() - self.thread_cpu,
        };
        DEPTH.with(|d| d.set(self.depth));
        LOG.lock().unwrap_or_else(|e| e.into_inner()).push(phase);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nested_phases_are_recorded_with_their_depth_and_nonnegative_times() {
        enable(true);
        take();
        {
            let _outer = start("outer");
            let _inner = start("inner");
            let depth = depth();
            std::thread::spawn(move || drop(start_under("handed over", depth)))
                .join()
                .unwrap();
        }
        let phases = take();
        enable(false);
        let names: Vec<_> = phases.iter().map(|p| (p.name, p.depth)).collect();
        // Other tests of the library run in parallel and may record phases of their own
        // while recording is on: only this test's two are checked.
        assert!(names.contains(&("inner", 1)), "{names:?}");
        assert!(names.contains(&("handed over", 2)), "{names:?}");
        let at = |name| names.iter().position(|&(n, _)| n == name);
        assert!(
            at("outer") < at("inner"),
            "in the order they started: {names:?}"
        );
        assert!(names.contains(&("outer", 0)), "{names:?}");
        assert!(phases
            .iter()
            .all(|p| p.wall >= 0.0 && p.cpu >= 0.0 && p.thread_cpu >= 0.0));
        assert!(start("off").is_none());
    }

    /// A thread that burns CPU and ends still counts: the process's CPU time never falls.
    #[test]
    fn process_cpu_keeps_the_time_of_ended_threads() {
        let before = process_cpu();
        assert!(before.is_finite() && before >= 0.0, "{before}");
        std::thread::spawn(|| {
            let t = thread_cpu();
            let mut x = 0u64;
            while thread_cpu() - t < 0.05 {
                x = x.wrapping_mul(6364136223846793005).wrapping_add(1);
            }
            std::hint::black_box(x);
        })
        .join()
        .unwrap();
        let after = process_cpu();
        // 0.05 s burnt on the ended thread; ticks of 10 ms.
        assert!(after - before >= 0.03, "{before} -> {after}");
    }
}
