//! No heap allocation per Newton iteration (issue 15 item 5), counted by the counting
//! `#[global_allocator]` of the guards test binary (`Counting` in tests/guards/main.rs), on this
//! test's own thread only, so that tests running beside it on other threads are not counted.
//!
//! What is measured: the heap allocations (`alloc`, `alloc_zeroed` and `realloc` calls, on
//! the test's own thread only) made by one `Engine::solve` of a step, and their bytes. The same
//! scene and step are solved twice, by fresh engines that differ only in the tolerance, so that
//! the second solve takes more Newton iterations in the same number of increments; the
//! difference of the counts, divided by the difference of the iterations, is what one more
//! iteration allocates. Everything done once per solve or per increment (the path's vectors,
//! the outputs, the active set, the first iterations' growth of the reused buffers) is the
//! same in both solves and cancels.
//!
//! Scenes: the Hencky disc at 16 rings (plain membrane, 2163 unknowns, follower pressure), the
//! wrinkled shear film (WrinkledShear: wrinkle states change and are frozen; slack and wrinkled
//! triangles) and the sleeve cable on a sheet (SleeveCable: 9 sleeve points with friction,
//! slip rows, the dense slip block, the residual line search).
//!
//! Asserted: an extra iteration makes no allocation of 1 KiB or more (every buffer that grows
//! with the model is larger than that at these sizes: the smallest, a vector over the
//! unknowns, is 1.9 KB for the sleeve sheet), and its small allocations are only the solver
//! log's line of that iteration (the `StepReport::log` a master reads through logSolver: one
//! formatted String per iteration, at most 4 allocations each: the string, its growth, and
//! the |r_slip| note's own string with its growth), so per extra iteration at most 4 small
//! allocations per extra log line and under 1 KiB in all.
//!
//! Still allocating per iteration, by design or left (docs/performance.md, memory): the log
//! line above; under `path: arc_length` the loads of λ and the bordered rows (`arc.rs`); a
//! volume input's row gradient and column (`volume.rs`, one vector over the unknowns per
//! volume input); nodal relaxation's per-round element lists when Newton stalls are reused,
//! but the probe evaluations at a converged point (`natural_states_converged`, once per
//! converged point, not per iteration) collect their states.

use std::cell::Cell;
use std::sync::atomic::{AtomicUsize, Ordering};
use velarium::{Engine, Scene};

thread_local! {
    static ACTIVE: Cell<bool> = const { Cell::new(false) };
    static SMALL: Cell<u64> = const { Cell::new(0) };
    static LARGE: Cell<u64> = const { Cell::new(0) };
    static BYTES: Cell<u64> = const { Cell::new(0) };
}

/// Allocations of at least this size count as large (model-sized).
const LARGE_BYTES: usize = 1024;

/// The sizes of the first large allocations of a counted solve (shown when a check fails).
static LARGE_SIZES: [AtomicUsize; 256] = [const { AtomicUsize::new(0) }; 256];
static LARGE_SEEN: AtomicUsize = AtomicUsize::new(0);

/// Called by the binary's counting allocator (`crate::Counting`) for every allocation.
pub(crate) fn count(size: usize) {
    let _ = ACTIVE.try_with(|active| {
        if active.get() {
            if size >= LARGE_BYTES {
                let k = LARGE_SEEN.fetch_add(1, Ordering::Relaxed);
                if let Some(slot) = LARGE_SIZES.get(k) {
                    slot.store(size, Ordering::Relaxed);
                }
            }
            let cell = if size >= LARGE_BYTES { &LARGE } else { &SMALL };
            let _ = cell.try_with(|c| c.set(c.get() + 1));
            let _ = BYTES.try_with(|b| b.set(b.get() + size as u64));
        }
    });
}

/// What one solve allocated and did.
#[derive(Debug, Clone, Copy)]
struct Solve {
    small: u64,
    large: u64,
    bytes: u64,
    iterations: usize,
    increments: usize,
    log_lines: usize,
}

/// The sizes of the large allocations of the last counted solve, in order.
fn large_sizes() -> Vec<usize> {
    let k = LARGE_SEEN.load(Ordering::Relaxed).min(LARGE_SIZES.len());
    LARGE_SIZES[..k]
        .iter()
        .map(|s| s.load(Ordering::Relaxed))
        .collect()
}

fn scene(name: &str) -> Scene {
    let path = format!(
        "{}/modelDescription/{name}/scene.json",
        env!("CARGO_MANIFEST_DIR")
    );
    Scene::from_json(&std::fs::read_to_string(path).unwrap()).unwrap()
}

/// A fresh engine of `scene` at `tolerance`, the inputs set, one solve counted.
fn solve(scene: &Scene, tolerance: f64, inputs: &[(&str, f64)]) -> Solve {
    let mut scene = scene.clone();
    scene.solver.tolerance = tolerance;
    let mut engine = Engine::try_new(scene).expect("a shipped scene");
    for (name, value) in inputs {
        let vr = engine
            .variables()
            .iter()
            .find(|v| v.name == *name)
            .unwrap_or_else(|| panic!("input {name}"))
            .value_reference;
        engine.set_real(vr, *value).unwrap();
    }
    for c in [&SMALL, &LARGE, &BYTES] {
        c.with(|c| c.set(0));
    }
    LARGE_SEEN.store(0, Ordering::Relaxed);
    ACTIVE.with(|a| a.set(true));
    let report = engine.solve();
    ACTIVE.with(|a| a.set(false));
    assert!(report.converged(), "{}", report.message);
    Solve {
        small: SMALL.with(Cell::get),
        large: LARGE.with(Cell::get),
        bytes: BYTES.with(Cell::get),
        iterations: report.iterations,
        increments: report.increments,
        log_lines: report.log.len(),
    }
}

/// Solve at both tolerances and check what the extra iterations allocated.
fn check(name: &str, loose: f64, tight: f64, inputs: &[(&str, f64)]) {
    let scene = scene(name);
    // A first solve warms up what the process does once (lazily initialised statics, the
    // first use of a library), which would otherwise count against the first measured solve.
    solve(&scene, loose, inputs);
    let a = solve(&scene, loose, inputs);
    let sizes_a = large_sizes();
    let b = solve(&scene, tight, inputs);
    let sizes_b = large_sizes();
    println!("{name}: tolerance {loose:e}: {a:?}");
    println!("{name}: tolerance {tight:e}: {b:?}");
    assert_eq!(
        a.increments, b.increments,
        "{name}: the same increments, so that per-increment allocations cancel"
    );
    assert!(
        b.iterations > a.iterations,
        "{name}: the tighter tolerance takes more iterations: {a:?} {b:?}"
    );
    let extra = (b.iterations - a.iterations) as u64;
    let lines = b.log_lines.saturating_sub(a.log_lines) as u64;
    println!(
        "{name}: {extra} more iterations allocate {} large, {} small ({} bytes) for {lines} more log lines",
        b.large as i64 - a.large as i64,
        b.small as i64 - a.small as i64,
        b.bytes as i64 - a.bytes as i64
    );
    assert_eq!(
        b.large, a.large,
        "{name}: no allocation of {LARGE_BYTES} bytes or more per iteration; sizes\n{sizes_a:?}\n{sizes_b:?}"
    );
    assert!(
        b.small <= a.small + 4 * lines,
        "{name}: small allocations per iteration are the log lines only: {a:?} {b:?}"
    );
    assert!(
        b.bytes <= a.bytes + 1024 * extra,
        "{name}: under 1 KiB per extra iteration: {a:?} {b:?}"
    );
}

/// One test for the three scenes: the counters are per thread, and one thread runs them in
/// turn.
#[test]
fn a_newton_iteration_allocates_nothing_but_its_log_line() {
    // 5 against 7 iterations, one increment.
    check("HenckyDisc", 1e-3, 1e-11, &[("pressure", 40.0)]);
    // 6 against 8 at shear 0.002 (at 0.003 the local convergence test takes 11 iterations at
    // every tolerance from 1e-3 to 1e-12: the last iteration is quadratic).
    check("WrinkledShear", 1e-4, 1e-11, &[("shear", 0.002)]);
    // 18 against 19 (likewise).
    check("SleeveCable", 1e-6, 1e-10, &[("force_2P", 3.0)]);
}
