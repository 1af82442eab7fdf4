//! GOAL: with 2 solver threads a Newton iteration allocates nothing on either thread but its
//!       log line (issue 15 item 5, as `alloc_per_iteration.rs` checks for 1 thread): the
//!       two-thread assembly (src/solver/assemble.rs, `Parallel`) and the two-domain
//!       factorization (src/solver/split.rs) run jobs installed once, in buffers allocated when
//!       the solver is built.
//! MESH: HenckyDisc at 50 rings (22 053 free DOF: above the 20 000 equations at which the
//!       solver starts its helper thread, so both the assembly and the factorization run in
//!       two halves).
//! BOUNDARY CONDITIONS / PARAMETERS: the scene's own, q = 40 Pa from the flat start, solved
//!       at tolerance 1e-3 and 1e-11 (more Newton iterations in the same one increment).
//! REFERENCE: counts, not numbers: the counting `#[global_allocator]` of the guards test binary
//!       (`Counting` in tests/guards/main.rs) counts the allocations of every thread (the
//!       helper's too) while a solve runs, so the test runs alone in a fresh process of that
//!       binary (`crate::alone`): no other test's allocations are counted. As in
//!       alloc_per_iteration.rs, the difference between the two solves divided by the
//!       difference of their iterations is what one more iteration allocates: no allocation of
//!       1 KiB or more, at most 4 small ones per extra log line, under 1 KiB per iteration,
//!       and none on the helper thread (measured: it makes 1 allocation per solve, in both).

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use velarium::scene::Generator;
use velarium::{Engine, Scene};

static ACTIVE: AtomicBool = AtomicBool::new(false);
static SMALL: AtomicU64 = AtomicU64::new(0);
static LARGE: AtomicU64 = AtomicU64::new(0);
static BYTES: AtomicU64 = AtomicU64::new(0);
/// Allocations made by threads other than the test's own (the solver's helper).
static ELSEWHERE: AtomicU64 = AtomicU64::new(0);

thread_local! {
    /// Set on the test's own thread.
    static MINE: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

/// Allocations of at least this size count as large (model-sized).
const LARGE_BYTES: usize = 1024;

/// Called by the binary's counting allocator (`crate::Counting`) for every allocation.
pub(crate) fn count(size: usize) {
    if ACTIVE.load(Ordering::Relaxed) {
        let c = if size >= LARGE_BYTES { &LARGE } else { &SMALL };
        c.fetch_add(1, Ordering::Relaxed);
        BYTES.fetch_add(size as u64, Ordering::Relaxed);
        if !MINE.try_with(|m| m.get()).unwrap_or(false) {
            ELSEWHERE.fetch_add(1, Ordering::Relaxed);
        }
    }
}

#[derive(Debug, Clone, Copy)]
struct Solve {
    small: u64,
    large: u64,
    bytes: u64,
    iterations: usize,
    increments: usize,
    log_lines: usize,
    elsewhere: u64,
}

fn disc() -> Scene {
    let path = format!(
        "{}/modelDescription/HenckyDisc/scene.json",
        env!("CARGO_MANIFEST_DIR")
    );
    let mut scene = Scene::from_json(&std::fs::read_to_string(path).unwrap()).unwrap();
    let Generator::Disc { rings, .. } = &mut scene.geometry.generators[0] else {
        panic!("HenckyDisc is a generated disc");
    };
    *rings = 50;
    scene.solver.threads = 2;
    // The iterations of this mesh only: no coarser meshes solved first.
    scene.solver.coarse_start = velarium::scene::CoarseStart::Off;
    scene
}

fn solve(scene: &Scene, tolerance: f64) -> Solve {
    let mut scene = scene.clone();
    scene.solver.tolerance = tolerance;
    let mut engine = Engine::try_new(scene).expect("a valid scene");
    assert!(
        engine.assembly_halves().is_some(),
        "assembled on two threads"
    );
    assert!(engine.split_sizes().is_some(), "factored in two halves");
    let vr = engine
        .variables()
        .iter()
        .find(|v| v.name == "pressure")
        .unwrap()
        .value_reference;
    engine.set_real(vr, 40.0).unwrap();
    MINE.with(|m| m.set(true));
    for c in [&SMALL, &LARGE, &BYTES, &ELSEWHERE] {
        c.store(0, Ordering::Relaxed);
    }
    ACTIVE.store(true, Ordering::SeqCst);
    let report = engine.solve();
    ACTIVE.store(false, Ordering::SeqCst);
    assert!(report.converged(), "{}", report.message);
    let s = Solve {
        small: SMALL.load(Ordering::Relaxed),
        large: LARGE.load(Ordering::Relaxed),
        bytes: BYTES.load(Ordering::Relaxed),
        iterations: report.iterations,
        increments: report.increments,
        log_lines: report.log.len(),
        elsewhere: ELSEWHERE.load(Ordering::Relaxed),
    };
    drop(engine);
    s
}

#[test]
fn a_two_thread_newton_iteration_allocates_nothing_but_its_log_line() {
    if !crate::alone(
        module_path!(),
        "a_two_thread_newton_iteration_allocates_nothing_but_its_log_line",
    ) {
        return;
    }
    let scene = disc();
    solve(&scene, 1e-3);
    let a = solve(&scene, 1e-3);
    let b = solve(&scene, 1e-11);
    println!("tolerance 1e-3: {a:?}\ntolerance 1e-11: {b:?}");
    assert_eq!(a.increments, b.increments);
    assert!(b.iterations > a.iterations, "{a:?} {b:?}");
    let extra = (b.iterations - a.iterations) as u64;
    let lines = b.log_lines.saturating_sub(a.log_lines) as u64;
    println!(
        "{extra} more iterations allocate {} large, {} small ({} bytes) for {lines} more log lines",
        b.large as i64 - a.large as i64,
        b.small as i64 - a.small as i64,
        b.bytes as i64 - a.bytes as i64
    );
    assert_eq!(
        b.large, a.large,
        "no allocation of {LARGE_BYTES} bytes or more per iteration"
    );
    assert!(
        b.small <= a.small + 4 * lines,
        "small ones: the log lines only"
    );
    assert!(
        b.bytes <= a.bytes + 1024 * extra,
        "under 1 KiB per iteration"
    );
    assert_eq!(
        b.elsewhere, a.elsewhere,
        "the helper thread allocates nothing per iteration"
    );
}
