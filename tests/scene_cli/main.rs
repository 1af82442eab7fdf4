//! Scenes and the `velarium` command: validation of scenes and sleeves (every problem located
//! by JSON path), the ranges of the solver settings, the pressure sign convention, hostile
//! input, memory limits and the command line's outputs. One file alone:
//! `cargo test --release --test scene_cli cli::`.

#[path = "../common/mod.rs"]
mod common;

mod cli;
mod hostile_input;
mod memory_limits;
mod plausibility;
mod pressure_sign;
mod scene_validation;
mod settings_bounds;
mod sleeve_validation;
mod solve_elements;
