//! Solver settings: every constant that tunes the iteration, with its default and the reason
//! for it (the scene's `solver` section fills the user-facing ones).

use super::renumber;

/// Solver settings: the scene's solver section (tolerance, iterations, increments, line search)
/// and the tuning constants of the iteration, each with its default and why.
#[derive(Clone, Debug, PartialEq)]
pub struct Settings {
    /// Relative residual tolerance (see `newton.rs`, the convergence test): every free DOF's
    /// residual within tolerance · F (F the applied and carried force scale) plus its
    /// round-off floor. Default 1e-9.
    pub tolerance: f64,
    /// Newton iterations per increment before it is cut back, counted again from a release of
    /// frozen states found wrong at convergence (`newton.rs`). Default 50 (the scene's
    /// `solver.max_iterations`).
    pub max_iterations: usize,
    /// Newton iterations a whole step may spend (every increment, cut-back and continuation)
    /// before it fails, saying so (`Stepper`). Default 1000 (the scene's
    /// `solver.max_step_iterations`).
    pub max_step_iterations: usize,
    /// Iterations an increment may continue past `max_iterations` while its residual still
    /// halves every 10 iterations (steady linear convergence, e.g. a flat membrane unloaded to
    /// exactly zero load, where the tangent is singular at the solution and each Newton step
    /// goes a third of the way, or a free-rim cushion inflated from flat, whose equilibrium at
    /// any load fraction is as far from the start as the whole step's). Cutting such an
    /// increment back only repeats the same ending. Default 200.
    pub max_iterations_progressing: usize,
    /// First increment as a fraction of the step's load change. Default 1.
    pub initial_increment: f64,
    /// Smallest increment before the step fails. Default 1e-4.
    pub min_increment: f64,
    /// Increment growth aims at this many iterations per increment. Default 6.
    pub target_iterations: usize,
    /// Backtracking line search on every Newton correction. Default on.
    pub line_search: bool,
    /// Iterations with wrinkle or stick/slip state changes before chattering states are frozen
    /// until convergence (chatter guard; active_set.rs): from here on a triangle back in the
    /// state it left two iterations ago is frozen, and from twice this on every triangle that
    /// still changes. Default 6: a state switch costs 2-4 iterations.
    pub freeze_after: usize,
    /// Times frozen states may turn out wrong at convergence before the increment is cut back.
    /// Default 3.
    pub max_unfreeze: usize,
    /// Trial steps of one line search. Default 8 (α down to about 1e-3 with interpolation).
    pub line_search_tries: usize,
    /// Increments (converged or cut back) one step may use before it fails: a step that creeps
    /// forward by tiny increments is reported, not left to run for minutes. Default 400.
    pub max_increments: usize,
    /// c of the round-off floor c·ε·(Σ|f|_d + K_dd X) of the convergence test. Default 64: an
    /// element force is a sum of a few dozen rounded products; measured residuals of converged
    /// iterates sit at 1-8 ε of those terms, and those of a free-rim cushion unloaded to its
    /// slack state at up to 48 ε (strains of 1e-15 in barely taut triangles; docs/solver.md).
    pub roundoff_factor: f64,
    /// Damping τ of the globalisation when it switches on (relative to the taut-structure
    /// diagonal). Default 1e-3: a mechanism then moves by 1000 elastic displacements per step.
    pub damping_start: f64,
    /// Damping below which it switches off. Default 1e-12: far below any effect on the Newton
    /// direction, and low enough that a slack mechanism can travel 8^9 times its first damped
    /// step before the damping would stop.
    pub damping_min: f64,
    /// Largest damping. Default 1e6.
    pub damping_max: f64,
    /// A step the line search cuts below this (or a failed search) switches the damping on or
    /// raises it: the Newton step was 1e5 times too long, the mark of a mechanism. Default
    /// 1e-5. Measured: 1e-3 also caught the occasional short step of the deeply wrinkled shear
    /// film (0.1 mm separation), where the damping then cost 5 of 20 steps; 1e-5 keeps those
    /// and still takes SlidingCable's sliding nodes (median 10, max 19 iterations per row).
    pub damping_trigger: f64,
    /// The damping also switches on when the slip part of a step must be cut below this to keep
    /// every sleeved segment's unstretched length (`keep_length`): the step asks several
    /// segment lengths of slip, a sliding mechanism's step. Default 0.25. Measured: hard case
    /// d (unloaded sliding nodes) 30 -> 24 iterations, SlidingCable largest row 19 -> 12.
    pub damping_slip_cap: f64,
    /// Iterates whose merit the non-monotone line search remembers (Grippo et al. 1986).
    /// Default 5.
    pub nonmonotone_memory: usize,
    /// Armijo sufficient-decrease fraction. Default 1e-4 (Nocedal & Wright §3.1).
    pub armijo: f64,
    /// The artificial prestress fades with the relative residual below this level. Default
    /// 1e-2: the over-stiff out-of-plane tangent it gives a nearly unstressed membrane (a flat
    /// sheet unloaded) would otherwise make the last iterations converge only linearly.
    pub prestress_fade: f64,
    /// Starting pre-strain of the prestress continuation (`path.rs`): an increment that fails
    /// from an unstressed membrane (no triangle carrying more tension than its artificial
    /// prestress, the flat start) is solved again through a sequence of problems in which every
    /// triangle carries an isotropic pre-strain h0, h0/4, h0/16, ... (down to h0/1000), then 0,
    /// each from the last one's equilibrium; the last is the scene's own problem, so the
    /// equilibrium is unchanged. Not with friction in a sleeve (history). 0 switches it off.
    /// Default 1e-3 (a tension of about 1.4e-3 E for SVK: of the order of the stress of a
    /// pressurised sheet at qa/Eh = 1e-3).
    pub continuation_strain: f64,
    /// First spring τ0 (relative to the taut, unstressed diagonal stiffness D) of the proximal
    /// continuation (`proximal.rs`): an increment Newton could not solve is solved again
    /// through problems R(u) + τ D (u − u_k) = 0 with τ falling from τ0, each from the last
    /// one's solution, then the scene's own problem. Not with sleeve points, volume inputs,
    /// elastoplastic groups or in a time sub-step. 0 switches it off. Default 1e-3 (the
    /// damping's start).
    pub proximal_start: f64,
    /// Load-to-stiffness ratio Σ|f| / (√A · E t) of the first problem of the overshoot
    /// continuation (`overshoot.rs`): an increment that fails from an unstressed membrane is
    /// solved again with its force loads raised to that ratio, then brought back in steps to
    /// the scene's. Not with sleeve points, volume or water inputs, elastoplastic groups or in
    /// a time sub-step. 0 switches it off. Default 3e-2.
    pub overshoot_ratio: f64,
    /// Nodal relaxation takes the nodes whose residual is at least this share of the largest.
    /// Default 0.1.
    pub relax_share: f64,
    /// Relaxation is for local trouble: not when more than this share of the nodes qualify.
    /// Default 0.1.
    pub relax_max_share: f64,
    /// Rounds of relaxation, each over the nodes that then carry the residual, while each round
    /// lowers it by at least a tenth. Default 20.
    pub relax_rounds: usize,
    /// Gauss-Seidel sweeps over the nodes of one round. Default 3.
    pub relax_sweeps: usize,
    /// After the sweeps, a round whose patch has at most this many nodes also runs Newton on
    /// the patch as a whole (`relax.rs`, dense: 3 unknowns per node), once the relative
    /// residual is below `relax_patch_below`. Default 64 (a 192 x 192 solve per iteration); 0
    /// switches the patch Newton off.
    pub relax_patch_nodes: usize,
    /// The patch Newton runs only below this relative residual (|R|∞ over the force scale).
    /// Default 1e-4: it is for the last drift of a few nearly stress-free nodes; further from
    /// equilibrium its long steps can lead away (measured: the corner-pulled rubber sheet of
    /// hard case j fails with it at 1e-3 and above, converges at 1e-4 and below).
    pub relax_patch_below: f64,
    /// Iterations of one patch Newton. Default 200 (each costs the patch's elements and one
    /// dense solve, microseconds for the free-edge patches of a sheared film).
    pub relax_patch_iterations: usize,
    /// The patch Newton's tangent-only regularisation of wrinkled and slack triangles, in
    /// place of the global tangent's 1e-6 (`wrinkling::REGULARIZATION`). Default 1e-8: small
    /// enough that the patch moves along its nearly stress-free directions in a few steps.
    pub relax_patch_regularization: f64,
    /// Smallest fraction of its current unstretched length a sleeved segment may keep in one
    /// step (fraction to the boundary L > 0). Default 0.1.
    pub keep_length: f64,
    /// Two neighbouring sleeve points of a cable touch (their segment closes, `order.rs`) when
    /// the unstretched cable between them falls to this fraction of its reference length.
    /// Default 1e-3: three fraction-to-boundary steps from a full segment, and a jump of a
    /// thousandth of a segment when the points are put together.
    pub merge_gap: f64,
    /// A touching pair that parts starts with this fraction of its segment's reference
    /// unstretched length between the points. Default 1e-2 (ten times `merge_gap`, so the pair
    /// does not close again at once).
    pub reopen_gap: f64,
    /// Follow each step's path by arc length (`arc.rs`) instead of load increments. Default
    /// off (the scene's `solver.path`).
    pub arc_length_path: bool,
    /// The stick/slip return map runs inside an increment only once the relative residual of
    /// the last iterate is at most this (and always at a converged point). Default 1e-3.
    pub contact_settle: f64,
    /// First arc length of a step, RMS displacement of the free DOFs in metres; 0: set by a
    /// first load-controlled increment of `initial_increment` (the scene's
    /// `solver.arc_length`). Default 0.
    pub arc_length: f64,
    /// Threads of the assembly's element loop and of the numeric factorization (`threads.rs`):
    /// 1 runs everything on the caller's thread; n > 1 starts a pool of n threads owned by
    /// the solver and joined when it is dropped. Default 1 (the scene's `solver.threads`).
    pub threads: usize,
    /// Internal node numbering of the tangent (`renumber.rs`). Default rings from a central
    /// node: any numbering of the same mesh then costs the same (docs/performance.md).
    pub node_order: renumber::NodeOrder,
    /// Inexact Newton (`slip.rs`, [`linear::Ldlt::pcg`]): once the residual falls at least 10x
    /// per iteration (the quadratic regime), the direction is first sought by conjugate
    /// gradients on the current tangent preconditioned by the last factorization, and the
    /// tangent is factored afresh only when that fails. Default [`InexactNewton::Auto`]: on
    /// for tangents of at least [`INEXACT_MIN_EQUATIONS`] equations (the scene's
    /// `solver.inexact_newton`; docs/performance.md).
    pub inexact_newton: InexactNewton,
}

/// When Newton directions may come from conjugate gradients on an earlier factorization
/// (`Settings::inexact_newton`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum InexactNewton {
    /// On for tangents of at least [`INEXACT_MIN_EQUATIONS`] equations, off below.
    #[default]
    Auto,
    /// On at every size.
    On,
    /// Off: every direction from a fresh factorization (exact Newton).
    Off,
}

/// Smallest tangent (equations) on which [`InexactNewton::Auto`] uses inexact Newton: from
/// here up it gained CPU time in every measured pair (6-14 % at 100k, 8-10 % at 300k, 9 % at
/// 1M on 1 thread: docs/performance.md); below it the gain was within the noise, and every
/// verification and hard case, all far smaller, keeps exact Newton's path.
pub const INEXACT_MIN_EQUATIONS: usize = 100_000;

impl Default for Settings {
    fn default() -> Settings {
        Settings {
            tolerance: 1e-9,
            max_iterations: 50,
            max_step_iterations: 1000,
            max_iterations_progressing: 200,
            initial_increment: 1.0,
            min_increment: 1e-4,
            target_iterations: 6,
            line_search: true,
            freeze_after: 6,
            max_unfreeze: 3,
            line_search_tries: 8,
            max_increments: 400,
            roundoff_factor: 64.0,
            damping_start: 1e-3,
            damping_min: 1e-12,
            damping_max: 1e6,
            damping_trigger: 1e-5,
            damping_slip_cap: 0.25,
            nonmonotone_memory: 5,
            armijo: 1e-4,
            prestress_fade: 1e-2,
            continuation_strain: 1e-3,
            proximal_start: 1e-3,
            overshoot_ratio: 3e-2,
            relax_share: 0.1,
            relax_max_share: 0.1,
            relax_rounds: 20,
            relax_sweeps: 3,
            relax_patch_nodes: 64,
            relax_patch_below: 1e-4,
            relax_patch_iterations: 200,
            relax_patch_regularization: 1e-8,
            keep_length: 0.1,
            merge_gap: 1e-3,
            reopen_gap: 1e-2,
            arc_length_path: false,
            contact_settle: 1e-3,
            arc_length: 0.0,
            threads: 1,
            node_order: renumber::NodeOrder::Rings,
            inexact_newton: InexactNewton::Auto,
        }
    }
}

/// Smallest signed current/reference area ratio a membrane triangle may reach: below it the
/// triangle has collapsed or turned over (inversion guard of the Newton loop and of nodal
/// relaxation).
pub const MIN_AREA_RATIO: f64 = 1e-6;
