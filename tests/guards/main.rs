//! Guards: the architecture of the source, and what the solver costs: no allocation per Newton
//! iteration (1 and 2 threads), the solver's threads owned and joined by its instance, the
//! linear cost of a long strip, the bounded allocation of a hostile serialized FMU state. One file alone: `cargo test --release --test guards threads_join::`.
//!
//! Two things in this binary concern the whole process, not one test:
//! - its one `#[global_allocator]`, [`Counting`], which hands every allocation to the counters
//!   of `alloc_per_iteration` (per thread: other tests running beside it are not counted) and
//!   of `threads_alloc` (every thread: the solver's helper allocates on its own thread) and
//!   of `fmu_state_codec` (bytes live and their peak, every thread);
//! - the tests that measure the whole process (`threads_alloc`: every thread's allocations;
//!   `fmu_state_codec`: the bytes live during a call;
//!   `threads_join`: the process's threads) run [`alone`] in a fresh process of this binary,
//!   as they did when each was a test binary of its own: tests running in parallel in the same
//!   process would add their threads and allocations to the counts.

#[path = "../common/mod.rs"]
mod common;

mod alloc_per_iteration;
mod architecture;
mod fmu_state_codec;
mod strip_cost;
mod threads_alloc;
mod threads_join;

use std::alloc::{GlobalAlloc, Layout, System};
use std::process::Command;

/// The system allocator, with every allocation (`alloc`, `alloc_zeroed`, `realloc`) counted by
/// the counters that are on.
struct Counting;

fn count(size: usize) {
    alloc_per_iteration::count(size);
    threads_alloc::count(size);
    fmu_state_codec::alloc(size);
}

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        count(layout.size());
        unsafe { System.alloc(layout) }
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        count(layout.size());
        unsafe { System.alloc_zeroed(layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        count(new_size);
        fmu_state_codec::dealloc(layout.size());
        unsafe { System.realloc(ptr, layout, new_size) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        fmu_state_codec::dealloc(layout.size());
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

/// Environment variable that names the one test a fresh process of this binary runs.
const ALONE: &str = "VELARIUM_TEST_ALONE";

/// Run the calling test `test` of module `module` (its `module_path!()`) alone in a fresh
/// process of this binary: there, with libtest's main thread waiting and the test on its own
/// thread (as in a test binary of one test), this returns true and the caller runs its body.
/// Anywhere else it starts that process (`--exact` with the test's name, one test thread),
/// shows its output, asserts that exactly this test ran there and passed, and returns false.
pub fn alone(module: &str, test: &str) -> bool {
    // libtest's name of the test: the module path without the crate's (this binary's) name.
    let name = match module.split_once("::") {
        Some((_, path)) => format!("{path}::{test}"),
        None => test.to_string(),
    };
    if std::env::var(ALONE).is_ok_and(|v| v == name) {
        return true;
    }
    let out = Command::new(std::env::current_exe().expect("the test binary's path"))
        .args([name.as_str(), "--exact", "--test-threads=1", "--nocapture"])
        .env(ALONE, &name)
        .output()
        .expect("the test binary runs");
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    print!("{stdout}");
    eprint!("{stderr}");
    assert!(
        out.status.success() && stdout.contains("test result: ok. 1 passed;"),
        "{name}, run alone in a fresh process: {}",
        out.status
    );
    false
}
