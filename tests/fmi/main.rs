//! The FMU: the FMI 2.0 and 3.0 C ABI from inside (through the rlib), a second importer that
//! loads the packed archives with `dlopen`, the committed model descriptions, array variables,
//! derivatives of the outputs (at every kind of converged state: derivative_states), the FMU
//! state and the cheap step. One file alone:
//! `cargo test --release --test fmi importer::`.

#[path = "../common/mod.rs"]
mod common;

mod arrays;
mod cheap_step;
mod derivative_states;
mod derivatives;
mod dynamic_derivatives;
mod fmi3_abi;
mod fmi_abi;
mod importer;
mod model_descriptions;
mod sleeve_fmu_state;
