//! The solver: assembly, sparse LDLT, one Newton loop with line search and damping, and load
//! increments with cut-back. It sees the model only; it owns scratch buffers, never committed
//! state.
//!
//! ```text
//! stepper.rs      the one stepper of every driver (CLI, FMI 2, FMI 3): begin / advance /
//!                 finish over a load-control or an arc-length path
//! path.rs         load control: λ: 0 → 1 in increments Δλ; a tangent predictor for moved
//!                 prescribed displacements; on failure Δλ ← Δλ/4 (down to min_increment), on
//!                 success Δλ grows; the prestress continuation of a flat start, then the
//!                 overshoot (overshoot.rs) and proximal (proximal.rs) continuations
//! arc.rs          arc-length path following: the load factor an unknown (normal plane);
//!                 path logic only, the corrector is newton.rs with the arc row bordered
//! newton.rs       the one Newton loop, in phases: equations → verdict → budget → direction
//!                 → step (line search, damping)
//! system.rs       the System boundary: the equations at a load factor (assembly, rows,
//!                 bordered rows, convergence test, direction of the bordered system)
//! relaxation.rs   nodal relaxation when Newton stalls (kernels in relax.rs)
//! active_set.rs   wrinkle-state freezing and stick/slip states, one chatter policy
//! slip.rs         slip rows and columns, return map, Schur direction (m = 0: plain LDLT)
//! volume.rs       volume control: pressure unknowns of closed groups, their rows and columns
//! order.rs        sleeve points keep their order along a cable: touching points merge into
//!                 one contact group and part when the contact force would pull
//! line_search.rs  one backtracking search: potential, slope or residual merit (slope.rs)
//! assemble.rs     pattern and assembly of residual and tangent over the model's elements
//! linear.rs       sparse LDLT (factor.rs: faer's calls; split.rs: two halves on 2 threads)
//! mass.rs         the mass matrix on the tangent's pattern (consistent or lumped)
//! dynamic.rs      time integration: generalized-α sub-steps (inertia.rs: the inertia force
//!                 on the System's equations)
//! modes.rs        natural frequencies and modes: shift-invert Lanczos on K and M
//! stability.rs    whether an equilibrium under ponding water is stable (K positive definite)
//! flat_start.rs   a flat start's in-plane and out-of-plane tangent blocks: the strict test
//!                 that they decouple, and their measurement (not used by the Newton loop)
//! core.rs         the Solver's workspace; settings.rs, report.rs, loads.rs, rows.rs: plain
//!                 data and functions every phase shares
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
mod contact;
mod core;
mod dense;
pub mod dissect;
pub mod dynamic;
mod factor;
pub mod flat_start;
mod inertia;
mod line_search;
pub mod linear;
pub mod loads;
pub mod mass;
pub mod mechanism;
pub mod modes;
mod newton;
mod order;
pub mod outputs;
mod overshoot;
mod path;
mod proximal;
pub mod relax;
mod relaxation;
pub mod renumber;
mod report;
mod rows;
pub mod sensitivity;
mod settings;
pub mod slip;
mod slope;
mod split;
pub mod stability;
pub mod step_sensitivity;
mod stepper;
mod system;
pub mod threads;
mod volume;
mod work;

pub use self::core::{Solver, Started};
pub use dynamic::Integration;
pub use path::Attempt;
pub use report::{push_log, Outcome, StepReport, MAX_LOG_LINES};
pub use settings::{InexactNewton, Settings, INEXACT_MIN_EQUATIONS, MIN_AREA_RATIO};
pub use stepper::Stepper;
