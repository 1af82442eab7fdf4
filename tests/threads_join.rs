//! GOAL: the solver's threads belong to the instance: an engine with `solver.threads = 2`
//!       starts exactly 2 threads, a solve starts no other (no rayon global pool, which would
//!       add one thread per core for the life of the process and keep an FMU's library mapped
//!       after dlclose), and dropping the engine joins them, so the process is back to the
//!       threads it had. With 1 thread no thread is started at all.
//! REFERENCE: the kernel's count of the process's threads (/proc/self/task), exact. This file
//!       holds one test so that no other test's thread is counted.
mod common;
use common::*;

fn threads_now() -> usize {
    std::fs::read_dir("/proc/self/task")
        .expect("/proc/self/task")
        .count()
}

#[test]
fn the_pool_starts_with_the_engine_and_is_joined_when_it_is_dropped() {
    let before = threads_now();
    for cycle in 0..3 {
        let mut scene = read_scene(&shipped("HenckyDisc"));
        scene.solver.threads = 2;
        let mut e = engine(scene);
        assert_eq!(
            threads_now(),
            before + 2,
            "cycle {cycle}: after building the engine"
        );
        solve(&mut e);
        set(&mut e, "pressure", 40.0);
        solve(&mut e);
        assert_eq!(threads_now(), before + 2, "cycle {cycle}: after solving");
        drop(e);
        assert_eq!(
            threads_now(),
            before,
            "cycle {cycle}: after dropping the engine"
        );
    }
    let mut e = engine(read_scene(&shipped("HenckyDisc")));
    set(&mut e, "pressure", 40.0);
    solve(&mut e);
    assert_eq!(threads_now(), before, "1 thread: none started");
}
