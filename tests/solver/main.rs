//! The solver: its hard cases, outcomes and paths, nodal relaxation, inexact Newton, node
//! renumbering, threads and the CI slice of the robustness corpus. One file alone: `cargo test --release --test solver hard_cases::`;
//! one case: `cargo test --release --test solver hard_cases::m2_`.

#[path = "../common/mod.rs"]
mod common;

mod coarse_start;

mod diagnostics;
mod hard_cases;
mod inexact_newton;
mod relax_patch;
mod renumber;
mod robustness;
mod solver_outcomes;
mod threads;
