//! Velarium: geometrically nonlinear cable-reinforced membranes, shipped as FMI co-simulation
//! FMUs.
//!
//! Data flows one way (each module imports only those above it):
//!
//! ```text
//! format     text of numbers and CSV cells shared by every writer   src/format.rs
//! phases     wall and CPU time of the setup's phases (off by default) src/phases.rs
//! memory     fallible allocation of what grows with the input       src/memory.rs
//! scene      validated plain data (serde), mesh generators          src/scene/
//! error      the library's error type (scene problems, memory)      src/error.rs
//! variables  the FMU variable table derived from a scene            src/variables.rs
//! model      mesh, DOFs, element kernels, loads, probes             src/model/
//! solver     assembly, sparse LDLT, Newton, load increments         src/solver/
//! formfind   equilibrium shape of a prescribed prestress (URS)       src/formfind.rs
//! results    outputs computed from model + state                    src/results.rs
//! engine     model + state + solver workspace: the one facade       src/engine.rs
//! description  modelDescription.xml (FMI 2, 3) of a scene and its   src/description.rs
//!            variable table; what the FMU declares (capabilities,   src/description3.rs
//!            log categories). Never imports fmi
//! fmi        thin C ABI adapter over the engine (the only unsafe);  src/fmi/
//!            implements what the description declares
//! vtu        VTK XML grids of a state and of the reference mesh     src/vtu.rs
//! pack, history, vtk   FMU archives, load histories, ParaView series (CLI)
//! ```
//! tests/guards/architecture.rs checks this order on the source (no exception) and that no two
//! src files import each other through any chain. Units are SI throughout: m, N, Pa.

// Functions marked `unsafe` (the C ABI in src/fmi) still put each operation that needs it in a
// block of its own, with a `SAFETY:` comment naming the precondition it relies on.
#![deny(unsafe_op_in_unsafe_fn)]
// `!(x > 0.0)` is how this code rejects NaN along with the out-of-range values: the negated
// comparison is deliberate wherever clippy would suggest `x <= 0.0`, which lets NaN through.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod description;
pub mod description3;
pub mod engine;
pub mod error;
pub mod fmi;
pub mod format;
pub mod formfind;
pub mod history;
pub mod memory;
pub mod model;
pub mod pack;
pub mod phases;
pub mod results;
pub mod scene;
pub mod solver;
pub mod variables;
pub mod vtk;
pub mod vtu;

pub use engine::{Engine, EngineState};
pub use error::Error;
pub use scene::Scene;
