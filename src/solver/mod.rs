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
mod line_search;
pub mod linear;
pub mod mechanism;
mod newton;
mod order;
mod path;
pub mod relax;
pub mod renumber;
pub mod sensitivity;
pub mod slip;
mod split;
pub mod threads;
mod volume;
mod work;

use crate::memory::{self, OutOfMemory};
use crate::model::membrane::Evaluation;
use crate::model::wrinkling::WrinkleState;
use crate::model::Model;
use assemble::{Pattern, NONE};
use linear::Ldlt;

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
    /// Iterations an increment may continue past `max_iterations` while its residual, already
    /// below 1e-4 of the force scale, still halves every 10 iterations (steady linear
    /// convergence near the solution, e.g. a flat membrane unloaded to
    /// exactly zero load, where the tangent is singular at the solution and each Newton step
    /// goes a third of the way). Cutting such an increment back only repeats the same ending.
    /// Default 200.
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
    /// c of the round-off floor c·ε·(Σ|f|_d + K_dd X) of the convergence test. Default 16: an
    /// element force is a sum of a few dozen rounded products, and measured residuals of
    /// converged iterates sit at 1-8 ε of those terms.
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
            max_iterations_progressing: 200,
            initial_increment: 1.0,
            min_increment: 1e-4,
            target_iterations: 6,
            line_search: true,
            freeze_after: 6,
            max_unfreeze: 3,
            line_search_tries: 8,
            max_increments: 400,
            roundoff_factor: 16.0,
            damping_start: 1e-3,
            damping_min: 1e-12,
            damping_max: 1e6,
            damping_trigger: 1e-5,
            damping_slip_cap: 0.25,
            nonmonotone_memory: 5,
            armijo: 1e-4,
            prestress_fade: 1e-2,
            continuation_strain: 1e-3,
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

/// How a step ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Outcome {
    /// The whole load change was applied and the equilibrium committed.
    Converged,
    /// The smallest increment failed; nothing was committed.
    Failed,
}

/// What one step did.
#[derive(Clone, Debug, PartialEq)]
pub struct StepReport {
    pub outcome: Outcome,
    /// Newton iterations (factorizations), failed increments included.
    pub iterations: usize,
    /// Converged increments.
    pub increments: usize,
    /// Increments that were cut back.
    pub cutbacks: usize,
    /// Fraction of the load change reached by converged increments (1 when converged).
    pub reached: f64,
    /// Why the step failed (empty when converged).
    pub message: String,
    /// One line per increment and per Newton iteration (capped), for the FMU's logSolver.
    pub log: Vec<String>,
}

impl StepReport {
    pub fn converged(&self) -> bool {
        self.outcome == Outcome::Converged
    }
}

/// Smallest signed current/reference area ratio a membrane triangle may reach: below it the
/// triangle has collapsed or turned over (inversion guard of the Newton loop and of nodal
/// relaxation).
pub(super) const MIN_AREA_RATIO: f64 = 1e-6;

/// Err with the reason when an assembly found an inverted or collapsed membrane triangle.
pub(super) fn check_inversion(model: &Model, info: &assemble::AssemblyInfo) -> Result<(), String> {
    if model.triangles.is_empty() || info.min_area_ratio > MIN_AREA_RATIO {
        Ok(())
    } else {
        Err(format!(
            "a membrane element inverted or collapsed (area ratio {:.2e})",
            info.min_area_ratio
        ))
    }
}

/// Longest solver log kept per step.
const MAX_LOG_LINES: usize = 2000;

pub struct Solver {
    settings: Settings,
    /// Shared with the helper thread's half of the assembly (`assemble::Parallel`).
    pattern: std::sync::Arc<Pattern>,
    linear: Ldlt,
    residual: Vec<f64>,
    trial: Vec<f64>,
    rhs: Vec<f64>,
    /// Per DOF, the magnitudes of the forces meeting there (last assembly).
    magnitude: Vec<f64>,
    /// Position of every equation's diagonal entry in the tangent's values.
    diagonal_positions: Vec<usize>,
    /// D of the damped system: per equation the diagonal stiffness of the structure with every
    /// element taut and elastic, then one entry per slip.
    reference_diagonal: Vec<f64>,
    /// Largest coordinate magnitude of the reference nodes.
    reference_size: f64,
    /// Per-triangle evaluations of the last assembly.
    evaluations: Vec<Evaluation>,
    /// Wrinkle states frozen against chatter inside the current increment.
    frozen: Option<Vec<Option<WrinkleState>>>,
    /// Elements and loads at each node, for nodal relaxation.
    adjacency: relax::Adjacency,
    /// Factor on the artificial prestress in the tangent of the current Newton iteration.
    prestress_factor: f64,
    /// The prestress continuation's isotropic pre-strain of every membrane triangle while one
    /// of its intermediate problems is solved (`path.rs`); 0 otherwise.
    pre_strain: f64,
    /// States held by the probe evaluations ([`Solver::hold_states`]).
    probe_states: Option<Vec<Option<WrinkleState>>>,
    /// The Newton loop's reused work buffers (`work.rs`).
    work: work::Work,
    /// |R|∞ on the equations at the last Newton direction (inexact Newton's gate, `slip.rs`).
    last_direction_residual: f64,
    /// Conjugate-gradient vectors of inexact Newton (four of the equations' length, allocated
    /// at the first inexact direction and reused).
    pcg_work: Vec<f64>,
}

impl Solver {
    /// Stored entries of the tangent's LDLT factor.
    pub fn factor_nonzeros(&self) -> usize {
        self.linear.factor_nonzeros()
    }

    /// Numeric factorizations of the tangent since the solver was made (every Newton
    /// direction, prescribed-displacement predictor, sensitivity and timing included).
    pub fn factorizations(&self) -> usize {
        self.linear.factorizations()
    }

    /// Factorizations and inexact-Newton directions and solves so far.
    pub fn linear_counts(&self) -> linear::Counts {
        self.linear.counts
    }

    /// Whether Newton directions may come from conjugate gradients on an earlier
    /// factorization (`Settings::inexact_newton`, decided by the tangent's size under
    /// [`InexactNewton::Auto`]).
    pub fn inexact_newton(&self) -> bool {
        match self.settings.inexact_newton {
            InexactNewton::On => true,
            InexactNewton::Off => false,
            InexactNewton::Auto => self.pattern.n >= INEXACT_MIN_EQUATIONS,
        }
    }

    /// (A, B, separator) equations of the two-domain factorization, if it is used.
    pub fn split_sizes(&self) -> Option<(usize, usize, usize)> {
        self.linear.split_sizes()
    }

    /// Triangles the assembly evaluates on (the solving thread, the helper) when it runs on
    /// two threads (`assemble::Parallel`); None when it runs on one.
    pub fn assembly_halves(&self) -> Option<(usize, usize)> {
        self.work.scratch.parallel.as_ref().map(|p| p.halves())
    }

    /// Pattern, position maps and the symbolic factorization, once per model. Every buffer
    /// that grows with the model is allocated fallibly (`crate::memory`): a shortage is an
    /// [`OutOfMemory`], never an abort.
    pub fn try_new(model: &Model, settings: Settings) -> Result<Solver, OutOfMemory> {
        let mut pattern = Pattern::try_ordered(model, settings.node_order)?;
        // The factorization takes over the pattern's row indices: nothing reads them from the
        // solver's pattern once its position maps are built, and a copy would be K's largest
        // index array twice (88 MB at 1M DOF).
        let row_idx = std::mem::take(&mut pattern.row_idx);
        let pool = if settings.threads > 1 && pattern.n >= linear::SPLIT_MIN_EQUATIONS {
            // The OS refusing a thread is a resource shortage like memory: reported, not fatal.
            // Two threads at most: the factorization has two halves (`split.rs`).
            let pool =
                threads::Pool::try_new(settings.threads.min(2)).map_err(|_| OutOfMemory {
                    what: "the solver's threads (their stacks)",
                    bytes: (settings.threads as u64).saturating_mul(2 << 20),
                })?;
            Some(std::sync::Arc::new(pool))
        } else {
            None
        };
        let pattern = std::sync::Arc::new(pattern);
        // The same gate as the factorization's split: with a pool, the assembly's element loop
        // runs in two halves too (`assemble::Parallel`).
        let parallel = match &pool {
            Some(pool) => assemble::Parallel::try_new(std::sync::Arc::clone(pool), &pattern)?,
            None => None,
        };
        let linear = Ldlt::try_with_pool(
            pattern.n,
            memory::copy(&pattern.col_ptr, "the tangent's pattern")?,
            row_idx,
            pool,
        )?;
        let n = model.dof_count();
        let trial_len = model.unknown_count();
        let diagonal_positions = memory::collect(
            (0..pattern.n).map(|j| pattern.col_ptr[j + 1] - 1),
            "the solver's vectors",
        )?;
        let reference_diagonal = reference_diagonal(model, &pattern)?;
        let reference_size = model.reference.iter().fold(0.0f64, |m, x| m.max(x.amax()));
        let vector = |len| memory::zeros(len, "the solver's vectors");
        Ok(Solver {
            settings,
            linear,
            residual: vector(n)?,
            trial: vector(trial_len)?,
            rhs: vector(pattern.n)?,
            magnitude: vector(n)?,
            diagonal_positions,
            reference_diagonal,
            reference_size,
            evaluations: memory::with_capacity(model.triangles.len(), "the element evaluations")?,
            frozen: None,
            adjacency: relax::Adjacency::try_new(model)?,
            prestress_factor: 1.0,
            pre_strain: 0.0,
            probe_states: None,
            work: work::Work {
                scratch: assemble::AssemblyScratch::with_parallel(parallel),
                ..Default::default()
            },
            last_direction_residual: f64::INFINITY,
            pcg_work: Vec::new(),
            pattern,
        })
    }

    /// Working memory of one step beyond what the solver and the state already hold, in
    /// bytes: a generous bound on the vectors the path, Newton loop, line search and slip
    /// block allocate while a step runs (about 16 copies of the unknowns and the forces, the
    /// element evaluations four times (one the assembly's copy in visit order,
    /// `assemble::AssemblyScratch`), and with m slip and volume unknowns the m solved
    /// columns and the dense m x m block; 4 more vectors of the equations under inexact
    /// Newton). Probed before every step (`crate::memory::probe`).
    pub fn step_bytes(&self, model: &Model) -> u64 {
        let unknowns = model.unknown_count() as u64;
        let copies = if self.inexact_newton() { 20u64 } else { 16 };
        // Slips and volume pressures: the unknowns eliminated in the dense block.
        let m = (model.unknown_count() - model.dof_count()) as u64;
        let vectors = copies.saturating_mul(unknowns).saturating_mul(8);
        let evaluations = 4u64
            .saturating_mul(model.triangles.len() as u64)
            .saturating_mul(std::mem::size_of::<Evaluation>() as u64 + 8);
        let slip = m
            .saturating_mul(self.pattern.n as u64 + m + 8)
            .saturating_mul(8);
        vectors.saturating_add(evaluations).saturating_add(slip)
    }

    /// The settings, to change for the next solves (the engine's increment-by-increment
    /// driver, `engine/stepping.rs`, runs one increment per solve).
    pub fn settings_mut(&mut self) -> &mut Settings {
        &mut self.settings
    }

    /// Number of unknowns (free DOFs).
    pub fn free_dofs(&self) -> usize {
        self.pattern.n
    }

    /// Residual R = f_int − f_ext on all DOFs (reactions at held DOFs) at `u` under `loads`.
    pub fn residual(&mut self, model: &Model, u: &[f64], loads: &[f64]) -> Vec<f64> {
        let mut r = vec![0.0; model.dof_count()];
        // With the solver's scratch: on two threads when it has a helper's half.
        let membranes = assemble::Membranes {
            forced: self.probe_states.as_deref(),
            scratch: Some(&mut self.work.scratch),
            ..Default::default()
        };
        assemble::assemble_with(model, &self.pattern, u, loads, &mut r, None, membranes);
        r
    }

    /// Wrinkle states that [`Solver::residual`] and [`Solver::evaluate_membranes`] hold instead
    /// of the law's own (None: the law decides). The derivatives evaluate their probe
    /// differences on the branch of the committed equilibrium with them (`engine/derivatives.rs`).
    pub fn hold_states(&mut self, states: Option<Vec<Option<WrinkleState>>>) {
        self.probe_states = states;
    }

    /// Evaluation (state, tension angle, stress, energy) of every membrane triangle at `u`.
    pub fn evaluate_membranes(
        &mut self,
        model: &Model,
        u: &[f64],
        loads: &[f64],
    ) -> Vec<Evaluation> {
        let mut r = vec![0.0; model.dof_count()];
        let mut out = Vec::with_capacity(model.triangles.len());
        let membranes = assemble::Membranes {
            out: Some(&mut out),
            forced: self.probe_states.as_deref(),
            scratch: Some(&mut self.work.scratch),
            ..Default::default()
        };
        assemble::assemble_with(model, &self.pattern, u, loads, &mut r, None, membranes);
        out
    }
}

/// D of the damped system (`newton.rs`): per free equation, the diagonal stiffness its node
/// would have if every element at it were taut and elastic and unstressed (membranes E t A
/// |∇N_a|², cables EA/L, ties k; the same for x, y, z), and per slip the axial stiffness of
/// its two segments. Positive wherever an element touches; 1 N/m elsewhere.
fn reference_diagonal(model: &Model, pattern: &Pattern) -> Result<Vec<f64>, OutOfMemory> {
    let mut node: Vec<f64> = memory::zeros(model.reference.len(), "the solver's vectors")?;
    for t in &model.triangles {
        let k = t.material.modulus() * t.material.thickness * t.reference.area;
        for (a, &i) in t.nodes.iter().enumerate() {
            node[i] += k * t.reference.grad[a].norm_squared();
        }
    }
    for s in &model.segments {
        for &i in &s.nodes {
            node[i] += s.ea / s.l0;
        }
    }
    for t in &model.ties {
        for &i in &t.nodes {
            node[i] += t.k;
        }
    }
    let mut d: Vec<f64> = memory::zeros(pattern.n + model.slips.len(), "the solver's vectors")?;
    for (dof, &e) in pattern.eq.iter().enumerate() {
        if e != NONE {
            d[e] = node[dof / 3];
        }
    }
    for (j, p) in model.slips.iter().enumerate() {
        d[pattern.n + j] = p
            .segments
            .iter()
            .map(|&s| model.segments[s].ea / model.segments[s].l0)
            .sum();
    }
    for v in &mut d {
        if !(*v > 0.0 && v.is_finite()) {
            *v = 1.0;
        }
    }
    Ok(d)
}

impl Solver {
    /// Wall time in seconds of one assembly (residual and tangent) and of one numeric
    /// factorization plus solve at `u`: the floor a Newton iteration cannot beat. Best of
    /// `repeats`.
    pub fn time_floor(
        &mut self,
        model: &Model,
        u: &[f64],
        loads: &[f64],
        repeats: usize,
    ) -> (f64, f64) {
        let (assembly, factor, solve) = self.time_floor_parts(model, u, loads, repeats);
        (assembly, factor + solve)
    }

    /// [`Solver::time_floor`] with the numeric factorization and the solve (forward and back
    /// substitution) timed apart, each the best of `repeats`.
    pub fn time_floor_parts(
        &mut self,
        model: &Model,
        u: &[f64],
        loads: &[f64],
        repeats: usize,
    ) -> (f64, f64, f64) {
        let (mut assembly, mut factor, mut solve) = (f64::INFINITY, f64::INFINITY, f64::INFINITY);
        for _ in 0..repeats.max(1) {
            let t = std::time::Instant::now();
            let membranes = assemble::Membranes {
                scratch: Some(&mut self.work.scratch),
                ..Default::default()
            };
            assemble::assemble_with(
                model,
                &self.pattern,
                u,
                loads,
                &mut self.residual,
                Some(self.linear.values_mut()),
                membranes,
            );
            assembly = assembly.min(t.elapsed().as_secs_f64());
            for (d, &e) in self.pattern.eq.iter().enumerate() {
                if e != assemble::NONE {
                    self.rhs[e] = -self.residual[d];
                }
            }
            // A failed factorization or solve still costs its time; the floor is about cost
            // only.
            let t = std::time::Instant::now();
            let factored = self.linear.factor().is_ok();
            factor = factor.min(t.elapsed().as_secs_f64());
            if factored && !self.rhs.is_empty() {
                let t = std::time::Instant::now();
                let _ = self.linear.solve(&mut self.rhs);
                solve = solve.min(t.elapsed().as_secs_f64());
            } else {
                solve = 0.0;
            }
        }
        (assembly, factor, solve)
    }
}

fn push_log(log: &mut Vec<String>, line: String) {
    if log.len() < MAX_LOG_LINES {
        log.push(line);
    }
}
