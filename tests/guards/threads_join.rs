//! GOAL: the solver's threads belong to the instance: an engine with `solver.threads = 2` on a
//!       model large enough for the two-domain factorization (>= 20 000 equations,
//!       `SPLIT_MIN_EQUATIONS`) starts exactly 1 helper thread (the solving thread is the
//!       other), a solve starts no other (no global pool, which would outlive the instance and
//!       keep an FMU's library mapped after dlclose), and dropping the engine joins it, so the
//!       process is back to the threads it had. With 1 thread, or a model below the threshold,
//!       no thread is started at all.
//! REFERENCE: the kernel's count of the process's threads (/proc/self/task), exact. The test
//!       runs alone in a fresh process of the guards binary (`crate::alone`), so that no other
//!       test's thread is counted.
use crate::common;
use common::*;
use velarium::scene::{Generator, Scene};

fn threads_now() -> usize {
    std::fs::read_dir("/proc/self/task")
        .expect("/proc/self/task")
        .count()
}

/// The Hencky disc with `rings` rings (50 rings: 22 053 free DOF; the shipped 16: 2163).
fn disc(rings: usize, threads: usize) -> Scene {
    let mut scene = read_scene(&shipped("HenckyDisc"));
    let Generator::Disc { rings: r, .. } = &mut scene.geometry.generators[0] else {
        panic!("HenckyDisc is a generated disc");
    };
    *r = rings;
    scene.solver.threads = threads;
    scene
}

#[test]
fn the_helper_starts_with_the_engine_and_is_joined_when_it_is_dropped() {
    if !crate::alone(
        module_path!(),
        "the_helper_starts_with_the_engine_and_is_joined_when_it_is_dropped",
    ) {
        return;
    }
    let before = threads_now();
    for cycle in 0..2 {
        let mut e = engine(disc(50, 2));
        assert!(e.free_dofs() >= 20_000, "{}", e.free_dofs());
        assert_eq!(
            threads_now(),
            before + 1,
            "cycle {cycle}: after building the engine"
        );
        set(&mut e, "pressure", 40.0);
        solve(&mut e);
        assert_eq!(threads_now(), before + 1, "cycle {cycle}: after solving");
        drop(e);
        assert_eq!(
            threads_now(),
            before,
            "cycle {cycle}: after dropping the engine"
        );
    }
    let mut small = engine(disc(16, 2));
    set(&mut small, "pressure", 40.0);
    solve(&mut small);
    assert_eq!(threads_now(), before, "below the threshold: none started");
    let mut e = engine(disc(16, 1));
    set(&mut e, "pressure", 40.0);
    solve(&mut e);
    assert_eq!(threads_now(), before, "1 thread: none started");
}
