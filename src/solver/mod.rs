//! The solver: assembly, sparse LDLT, one Newton loop with line search and damping, and load
//! increments with cut-back. It sees the model only; it owns scratch buffers, never committed
//! state.
//!
//! ```text
//! path.rs         solve_step(from, to, u): load(λ) = from + λ (to − from), λ: 0 → 1 in
//!                 increments Δλ; a tangent predictor for moved prescribed displacements; on
//!                 failure Δλ ← Δλ/4 (down to min_increment); on success Δλ grows
//! newton.rs       the one Newton loop: assemble → active set → convergence test → direction
//!                 → line search → damping update
//! active_set.rs   wrinkle-state freezing and stick/slip states, one chatter policy
//! slip.rs         slip rows and columns, return map, Schur direction (m = 0: plain LDLT)
//! volume.rs       volume control: pressure unknowns of closed groups, their rows and columns
//!                 (eliminated with the slips)
//! arc.rs          arc-length path following: the load factor an unknown (normal plane);
//!                 path logic only, the corrector is newton.rs with the arc row bordered
//! order.rs        sleeve points keep their order along a cable: touching points merge into
//!                 one contact group and part when the contact force would pull
//! line_search.rs  one backtracking search: potential, slope or residual merit
//! relax.rs        nodal relaxation of the few nodes that carry a stalled residual
//! ```
//! Non-convergence is an outcome ([`StepReport`]), not an error: the caller's state is left as
//! it was. Every constant that tunes the iteration is a field of [`Settings`] with its default
//! and the reason for it.
//!
//! # References
//! Crisfield 1991, *Non-linear Finite Element Analysis of Solids and Structures*, vol. 1, §9.3
//! (line search on the slope); Bonet & Wood 2008, §9.6; docs/mechanics.md (solver).

mod active_set;
pub mod arc;
pub mod assemble;
mod core;
mod dense;
mod line_search;
mod factor;
pub mod linear;
pub mod loads;
pub mod mechanism;
mod newton;
mod order;
mod path;
pub mod relax;
pub mod renumber;
mod report;
mod rows;
pub mod sensitivity;
mod settings;
mod slope;
mod stepper;
pub mod slip;
mod split;
pub mod threads;
mod volume;
mod work;

pub use self::core::Solver;
pub use path::Attempt;
pub use report::{push_log, Outcome, StepReport, MAX_LOG_LINES};
pub use settings::{InexactNewton, Settings, INEXACT_MIN_EQUATIONS, MIN_AREA_RATIO};
pub use stepper::Stepper;
