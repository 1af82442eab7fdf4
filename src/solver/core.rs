//! The solver's workspace: the tangent's pattern and factorization, the assembly buffers and
//! the per-increment state every phase of the iteration reads (newton.rs, line_search.rs,
//! slip.rs, path.rs, arc.rs, sensitivity.rs add their methods to [`Solver`]).

use super::assemble::{self, Pattern, NONE};
use super::linear::{self, Ldlt};
use super::settings::{InexactNewton, Settings, INEXACT_MIN_EQUATIONS, MIN_AREA_RATIO};
use super::{relax, threads, work};
use crate::error::Error;
use crate::memory::{self, OutOfMemory};
use crate::model::membrane::Evaluation;
use crate::model::wrinkling::WrinkleState;
use crate::model::Model;

/// Err([`Error::Inverted`]) when an assembly found an inverted or collapsed membrane triangle.
pub(super) fn check_inversion(model: &Model, info: &assemble::AssemblyInfo) -> Result<(), Error> {
    if model.triangles.is_empty() || info.min_guard_ratio > MIN_AREA_RATIO {
        Ok(())
    } else {
        Err(Error::Inverted {
            area_ratio: info.min_guard_ratio,
        })
    }
}

/// A solver's two threads started before its model is built (`Engine::try_new`), and the
/// buffer of the triangles' position maps their helper allocates and touches meanwhile
/// (`assemble::Pattern`): the solving thread then writes the maps into pages already there.
pub struct Started {
    pool: std::sync::Arc<threads::Pool>,
    maps: threads::Pending<Result<Vec<u32>, OutOfMemory>>,
}

impl Started {
    /// The threads, with the maps' buffer for `triangles` triangles begun on the helper.
    /// None where the OS refuses the thread (the solver then tries again and reports it).
    pub fn begin(triangles: usize) -> Option<Started> {
        let pool = std::sync::Arc::new(threads::Pool::try_new(2).ok()?);
        let len = triangles.saturating_mul(crate::model::ElementKind::Membrane.block_len());
        let maps = threads::Pool::launch(&pool, 0, move || assemble::touched_maps(len));
        Some(Started { pool, maps })
    }
}

pub struct Solver {
    pub(super) settings: Settings,
    /// Shared with the helper thread's half of the assembly (`assemble::Parallel`).
    pub(super) pattern: std::sync::Arc<Pattern>,
    pub(super) linear: Ldlt,
    pub(super) residual: Vec<f64>,
    pub(super) trial: Vec<f64>,
    pub(super) rhs: Vec<f64>,
    /// Per DOF, the magnitudes of the forces meeting there (last assembly).
    pub(super) magnitude: Vec<f64>,
    /// Work spent in the current step, in half Newton iterations ([`super::Stepper::begin`]
    /// resets it; `settings.max_step_iterations` bounds it, [`Solver::work_spent`]): each
    /// iteration counts one whole (`WORK_ITERATION`: its assembly with the tangent, its
    /// factorization and its first line-search trial), every further line-search trial and
    /// every re-check of frozen wrinkle states one half (an assembly without the tangent,
    /// which costs less than half of an iteration's factorization and two assemblies), and a
    /// round of nodal relaxation one whole (a global residual and the local work, within two
    /// assemblies). So a step that gives up has spent at most `max_step_iterations` times the
    /// cost of one iteration, whatever its line searches did.
    pub(super) step_work: usize,
    /// What the step's nodal relaxation cost beyond what `step_work` counts for it, in the same
    /// halves: a round counts one iteration there, and here its element evaluations in
    /// assemblies' worth beyond that (relaxation.rs). `step_work + relax_extra` is the step's
    /// whole work, bounded by `COST_BOUND` times the budget ([`Solver::work_spent`]).
    pub(super) relax_extra: usize,
    /// Trial points of the current line search (line_search.rs).
    pub(super) trials: usize,
    /// G of the convergence test (system.rs): the scene's load scale at the last assembly.
    pub(super) load_scale: f64,
    /// Work buffer of G (a capacity of one entry per node, allocated once).
    pub(super) loads_seen: Vec<f64>,
    /// Position of every equation's diagonal entry in the tangent's values.
    pub(super) diagonal_positions: Vec<usize>,
    /// D of the damped system: per equation the diagonal stiffness of the structure with every
    /// element taut and elastic, then one entry per slip.
    pub(super) reference_diagonal: Vec<f64>,
    /// Largest coordinate magnitude of the reference nodes.
    pub(super) reference_size: f64,
    /// Per-triangle evaluations of the last assembly.
    pub(super) evaluations: Vec<Evaluation>,
    /// Wrinkle states frozen against chatter inside the current increment.
    pub(super) frozen: Option<Vec<Option<WrinkleState>>>,
    /// Elements and loads at each node, for nodal relaxation.
    pub(super) adjacency: relax::Adjacency,
    /// Factor on the artificial prestress in the tangent of the current Newton iteration.
    pub(super) prestress_factor: f64,
    /// Inside a problem of the proximal continuation with a spring (proximal.rs): no
    /// artificial prestress, and solved at a relative residual of `proximal::ACCEPT`.
    pub(super) proximal: bool,
    /// The prestress continuation's isotropic pre-strain of every membrane triangle while one
    /// of its intermediate problems is solved (`path.rs`); 0 otherwise.
    pub(super) pre_strain: f64,
    /// States held by the probe evaluations ([`Solver::hold_states`]).
    pub(super) probe_states: Option<Vec<Option<WrinkleState>>>,
    /// The Newton loop's reused work buffers (`work.rs`).
    pub(super) work: work::Work,
    /// |R|∞ on the equations at the last Newton direction (inexact Newton's gate, `slip.rs`).
    pub(super) last_direction_residual: f64,
    /// Conjugate-gradient vectors of inexact Newton (four of the equations' length, allocated
    /// at the first inexact direction and reused).
    pub(super) pcg_work: Vec<f64>,
    /// The inertia force of the time sub-step being solved (`dynamic.rs`); None in statics.
    pub(super) inertia: Option<super::inertia::Inertia>,
    /// M and C of the time integration, built at the first dynamic step.
    pub(super) dynamic_matrices: Option<super::inertia::Matrices>,
    /// M for the kinetic energy output, built at its first use.
    pub(super) kinetic_mass: Option<Vec<f64>>,
    /// The modal analysis's work space (the Lanczos basis), kept between analyses (`modes.rs`).
    pub(super) modes_work: super::work::ModesWork,
}

/// One Newton iteration in the step's work budget (`Solver::step_work` counts halves).
pub(super) const WORK_ITERATION: usize = 2;

/// The step's whole work, its nodal relaxation counted at what it evaluates
/// (`Solver::relax_extra`), may reach this many times the budget, whatever its relaxation
/// does. An assembly's worth of relaxation, counted half an iteration, costs less than that
/// (measured on a corpus drawstring: 18 100 iterations' worth of whole work in 1.5-2.2 s where
/// `check` announces 0.49 s for 1000 iterations), so the failing steps stay within a few
/// times the announcement. 10 ended two failing steps before they reached what their
/// messages should say (a squeezed triangle, the film's edge node: tests/solver), 20 did not
/// (docs/robustness.md, fourteenth session).
pub(super) const COST_BOUND: usize = 20;

impl Solver {
    /// The step's work budget in halves of an iteration (`step_work`'s unit).
    fn budget_halves(&self) -> usize {
        self.settings
            .max_step_iterations
            .saturating_mul(WORK_ITERATION)
    }

    /// Whether the step's work budget (`settings.max_step_iterations`) is spent, or its whole
    /// work with the relaxation counted at its cost is `COST_BOUND` times that.
    pub(super) fn work_spent(&self) -> bool {
        let budget = self.budget_halves();
        self.step_work >= budget
            || self.step_work.saturating_add(self.relax_extra) >= budget.saturating_mul(COST_BOUND)
    }

    /// Whether the whole work's bound, not the budget, ended the step.
    pub(super) fn cost_bound_reached(&self) -> bool {
        self.step_work < self.budget_halves()
    }

    /// Stored entries of the tangent's LDLT factor.
    pub fn factor_nonzeros(&self) -> usize {
        self.linear.factor_nonzeros()
    }

    /// Flops of one numeric factorization of the tangent (Σ c² over the factor's columns).
    pub fn factor_flops(&self) -> f64 {
        self.linear.factor_flops()
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

    /// The solver's threads when it has a helper (the assembly's, `assemble::Parallel`):
    /// free between the solver's own jobs, for work beside it (the coarse start's transfer).
    pub fn pool(&self) -> Option<&std::sync::Arc<threads::Pool>> {
        self.work.scratch.parallel.as_ref().map(|p| p.pool())
    }

    /// Pattern, position maps and the symbolic factorization, once per model. Every buffer
    /// that grows with the model is allocated fallibly (`crate::memory`): a shortage is an
    /// [`OutOfMemory`], never an abort.
    pub fn try_new(model: &Model, settings: Settings) -> Result<Solver, OutOfMemory> {
        Solver::try_new_started(model, settings, None)
    }

    /// [`Solver::try_new`] with the threads started before the model was built and what
    /// their helper prepared meanwhile ([`Started`]); the same solver. Where this solver has
    /// no pool (one thread, or fewer equations than the split's), the started one is ended.
    pub fn try_new_started(
        model: &Model,
        settings: Settings,
        started: Option<Started>,
    ) -> Result<Solver, OutOfMemory> {
        use crate::phases::start;
        let _phase = start("Solver::try_new");
        // The equations (free DOFs) before the pattern: the pool is started first, so that
        // the pattern's ordering runs on its helper (`Pattern::try_ordered_on`).
        let equations = model.held.iter().filter(|&&held| !held).count();
        let gate = settings.threads > 1 && equations >= linear::SPLIT_MIN_EQUATIONS;
        let (started, maps) = match started.filter(|_| gate) {
            Some(Started { pool, maps }) => {
                // The helper's buffer, or none where its job failed (then allocated here).
                let maps = maps.join().ok().and_then(Result::ok);
                (Some(pool), maps)
            }
            None => (None, None),
        };
        let pool = if let Some(pool) = started {
            Some(pool)
        } else if gate {
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
        // Nodal relaxation's adjacency on the helper, from a copy of what it reads, while
        // this thread numbers the nodes (the ordering, the helper's next job, waits for it:
        // `Pattern::try_ordered_then`). The lists of one thread.
        type Built = Result<relax::Adjacency, OutOfMemory>;
        let adjacency: Option<Box<dyn FnOnce() -> Built + Send>> = match &pool {
            Some(_) => {
                let input = relax::Adjacency::input(model)?;
                let depth = crate::phases::depth();
                Some(Box::new(move || {
                    let _phase = crate::phases::start_under("adjacency (on the helper)", depth);
                    input.build()
                }))
            }
            None => None,
        };
        let (mut pattern, adjacency) =
            Pattern::try_ordered_then(model, settings.node_order, pool.as_ref(), adjacency, maps)?;
        // The factorization takes over the pattern's row indices: nothing reads them from the
        // solver's pattern once its position maps are built, and a copy would be K's largest
        // index array twice (88 MB at 1M DOF).
        let row_idx = std::mem::take(&mut pattern.row_idx);
        let fill = pattern.fill.take();
        let pattern = std::sync::Arc::new(pattern);
        let phase = start("parallel assembly's halves");
        // The same gate as the factorization's split: with a pool, the assembly's element loop
        // runs in two halves too (`assemble::Parallel`).
        let parallel = match &pool {
            Some(pool) => assemble::Parallel::try_new(std::sync::Arc::clone(pool), &pattern)?,
            None => None,
        };
        drop(phase);
        let phase = start("factorization set-up (Ldlt::try_filled)");
        let mut linear = Ldlt::try_filled(
            pattern.n,
            memory::copy(&pattern.col_ptr, "the tangent's pattern")?,
            row_idx,
            pool,
            fill,
        )?;
        // Each node's equations one group: the pivots are regularized relative to the node's
        // own stiffness (linear.rs).
        let mut groups = memory::zeros::<u32>(pattern.n, "the tangent's scaling")?;
        for (d, &e) in pattern.eq.iter().enumerate() {
            if e != NONE {
                groups[e] = (d / 3) as u32;
            }
        }
        linear.set_groups(groups)?;
        drop(phase);
        let phase = start("solver vectors, reference diagonal, adjacency");
        let n = model.dof_count();
        let trial_len = model.unknown_count();
        let diagonal_positions = memory::collect(
            (0..pattern.n).map(|j| pattern.col_ptr[j + 1] - 1),
            "the solver's vectors",
        )?;
        let reference_diagonal = reference_diagonal(model, &pattern)?;
        let reference_size = model.reference.iter().fold(0.0f64, |m, x| m.max(x.amax()));
        let vector = |len| memory::zeros(len, "the solver's vectors");
        let adjacency = match adjacency.map(threads::Pending::join) {
            Some(Ok(built)) => built?,
            // No helper, or it failed: here, as with one thread.
            _ => relax::Adjacency::try_new(model)?,
        };
        drop(phase);
        Ok(Solver {
            settings,
            linear,
            residual: vector(n)?,
            trial: vector(trial_len)?,
            rhs: vector(pattern.n)?,
            magnitude: vector(n)?,
            step_work: 0,
            relax_extra: 0,
            trials: 0,
            load_scale: 0.0,
            loads_seen: memory::with_capacity(n / 3, "the solver's vectors")?,
            diagonal_positions,
            reference_diagonal,
            reference_size,
            evaluations: memory::with_capacity(model.triangles.len(), "the element evaluations")?,
            frozen: None,
            adjacency,
            prestress_factor: 1.0,
            proximal: false,
            pre_strain: 0.0,
            probe_states: None,
            work: work::Work {
                scratch: assemble::AssemblyScratch::with_parallel(parallel),
                ..Default::default()
            },
            last_direction_residual: f64::INFINITY,
            pcg_work: Vec::new(),
            inertia: None,
            dynamic_matrices: None,
            kinetic_mass: None,
            modes_work: Default::default(),
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
        let m = (model.slips.len() + model.volumes) as u64;
        let vectors = copies.saturating_mul(unknowns).saturating_mul(8);
        let evaluations = 4u64
            .saturating_mul(model.triangles.len() as u64)
            .saturating_mul(std::mem::size_of::<Evaluation>() as u64 + 8);
        let slip = m
            .saturating_mul(self.pattern.n as u64 + m + 8)
            .saturating_mul(8);
        vectors.saturating_add(evaluations).saturating_add(slip)
    }

    /// The settings.
    pub fn settings(&self) -> &Settings {
        &self.settings
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

    /// The energy stored in the elements at `u` under `loads` (J): membranes, cables, ties and
    /// contacts, no load's work (the `strain_energy` output).
    pub fn stored_energy(&mut self, model: &Model, u: &[f64], loads: &[f64]) -> f64 {
        let mut r = vec![0.0; model.dof_count()];
        let membranes = assemble::Membranes {
            forced: self.probe_states.as_deref(),
            scratch: Some(&mut self.work.scratch),
            ..Default::default()
        };
        assemble::assemble_with(model, &self.pattern, u, loads, &mut r, None, membranes).stored
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
        self.evaluate_committed(model, u, loads).membranes
    }
}

/// D of the damped system (`newton.rs`): per free equation, the diagonal stiffness its node
/// would have if every element at it were taut and elastic and unstressed
/// (`Element::reference_stiffness`: membranes E t A |∇N_a|², cables EA/L, ties k; the same for
/// x, y, z), and per slip the axial stiffness of its two segments. Positive wherever an element
/// touches; 1 N/m elsewhere.
fn reference_diagonal(model: &Model, pattern: &Pattern) -> Result<Vec<f64>, OutOfMemory> {
    let mut node: Vec<f64> = memory::zeros(model.reference.len(), "the solver's vectors")?;
    for (kind, e) in model.elements() {
        let element = model.element(kind, e);
        for (a, &i) in element.nodes().iter().enumerate() {
            node[i] += element.reference_stiffness(a);
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
