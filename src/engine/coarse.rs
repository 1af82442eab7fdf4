//! The coarse start (`solver.coarse_start`): the first step from the undeformed state of a
//! scene with membranes starts Newton from the answer on a coarser mesh (nested iteration, or
//! grid sequencing).
//!
//! ```text
//! applies     the step starts from the undeformed state (every displacement 0) under load
//!             control, with only membranes, cables, supports, forces and pressures (no
//!             sleeves, contacts, volume inputs, prescribed displacements, elastoplastic
//!             groups, time integration); auto: at least AUTO_DOF free DOF
//! coarse      generated meshes: the same scene with every generator's divisions halved
//!             (rounded up; a generator already at its smallest stays); an explicit mesh (no
//!             generators): the same scene with about a quarter of its sheets' nodes left by
//!             edge collapses (`scene::coarsen`: the outline, the supports and every node
//!             anything else names kept). Solved from the undeformed state under the same
//!             loads and parameters: its own first step starts the same way, so the meshes
//!             nest down to one below AUTO_DOF (auto) or to the smallest (on)
//! transfer    each node of this mesh takes the displacement of the nearest point of the
//!             coarse mesh's triangles of its own membrane group (linear in the triangle);
//!             a node on no triangle takes that of the coarse node at the same place
//! Newton      on the whole step from that start (path.rs, `guessed`): the same equations,
//!             convergence test and work budget as any increment; if it does not converge,
//!             the step goes on from the undeformed state as without a coarse start
//! ```
//! Why it pays: Newton's iteration count from a fixed start grows with the mesh where
//! wrinkled regions form (their state boundaries move element by element), while from the
//! interpolated answer of the next coarser mesh the start is already within the
//! discretisation error of the equilibrium, where Newton converges in a number of
//! iterations independent of the mesh (the mesh-independence principle: Allgower, Böhmer,
//! Potra & Rheinboldt 1986, SIAM J. Numer. Anal. 23(1); nested iteration, Deuflhard 2004,
//! *Newton Methods for Nonlinear Problems*, §8.3, and Kelley 1995, *Iterative Methods for
//! Linear and Nonlinear Equations*, §8.5). Measured in docs/solver.md.

use super::Engine;
use crate::model::{LoadModel, Model};
use crate::scene::{CoarseStart, Generator, Scene};
use crate::solver::threads::Pool;
use std::collections::HashMap;
use std::hash::BuildHasherDefault;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Arc;

/// Free DOF from which `coarse_start: auto` applies (docs/solver.md, "The coarse start").
pub const AUTO_DOF: usize = 10_000;

/// A generator's divisions are halved only where the halved ones keep at least this many.
const MIN_DIVISIONS: usize = 4;

/// What the coarse meshes gave: the start for this mesh's Newton and the log lines.
pub(super) struct Guess {
    pub start: Vec<f64>,
    pub log: Vec<String>,
}

/// The coarser scene the first step of `scene` (built as `model`, with `free` free DOF) starts
/// from (module docs): None where the coarse start does not apply to the scene, whatever its
/// state (`velarium check` says so from this).
pub fn coarser_scene(scene: &Scene, model: &Model, free: usize) -> Option<Scene> {
    let wanted = match scene.solver.coarse_start {
        CoarseStart::Off => false,
        CoarseStart::On => true,
        CoarseStart::Auto => free >= AUTO_DOF,
    };
    let applies = wanted
        && scene
            .dynamics
            .as_ref()
            .is_none_or(|d| d.time_integration.is_none())
        && scene.solver.path == crate::scene::PathMethod::LoadControl
        && model.slips.is_empty()
        && model.ties.is_empty()
        && model.contact_pairs.is_empty()
        && model.contact_points.is_empty()
        && model.volumes == 0
        && model.plastic_len() == 0
        && model.unknown_count() == 3 * model.reference.len()
        && !model.triangles.is_empty()
        && model.loads.iter().all(|l| {
            matches!(
                l,
                LoadModel::PointForce(_) | LoadModel::Pressure { .. } | LoadModel::Surface { .. }
            )
        });
    if applies && !ids_into_generated(scene) {
        coarser(scene)
    } else {
        None
    }
}

/// Whether the scene names a generated node or triangle by its id (a support on node 1234 of
/// a disc): the coarser mesh numbers its nodes otherwise, so its scene would not be the same
/// problem. Conservative: every integer under a key that can hold node or triangle ids
/// (`nodes`, `node`, `top`, `bottom`, `from`, `to`, `triangles`, and the geometry's named
/// sets) at or above the explicit nodes' (triangles') count counts.
fn ids_into_generated(scene: &Scene) -> bool {
    let explicit = (scene.geometry.nodes.len(), scene.geometry.triangles.len());
    let sets = |m: &std::collections::BTreeMap<String, Vec<usize>>, n: usize| {
        m.values().flatten().any(|&i| i >= n)
    };
    if sets(&scene.geometry.node_sets, explicit.0)
        || sets(&scene.geometry.triangle_sets, explicit.1)
    {
        return true;
    }
    let Ok(mut value) = serde_json::to_value(scene) else {
        return true;
    };
    if let Some(g) = value.get_mut("geometry").and_then(|g| g.as_object_mut()) {
        g.clear();
    }
    fn walk(v: &serde_json::Value, limit: Option<usize>, explicit: (usize, usize)) -> bool {
        use serde_json::Value;
        match v {
            Value::Number(n) => limit.is_some_and(|l| n.as_u64().is_none_or(|i| i >= l as u64)),
            Value::Array(a) => a.iter().any(|x| walk(x, limit, explicit)),
            Value::Object(o) => o.iter().any(|(k, x)| {
                let limit = match k.as_str() {
                    "nodes" | "node" | "top" | "bottom" | "from" | "to" => Some(explicit.0),
                    "triangles" => Some(explicit.1),
                    _ => None,
                };
                walk(x, limit, explicit)
            }),
            _ => false,
        }
    }
    walk(&value, None, explicit)
}

impl Engine {
    /// The coarse start of this step (module docs): None where it does not apply; Err(why)
    /// where it was tried and gave nothing (the step then runs as without it).
    pub(super) fn coarse_guess(&self, dynamic: bool) -> Option<Result<Guess, String>> {
        let s = &self.state;
        if dynamic || s.inputs == s.applied || s.displacement.iter().any(|&x| x != 0.0) {
            return None;
        }
        let mut scene = coarser_scene(&self.scene, &self.model, self.free_dofs())?;
        // The coarse meshes' memory comes on top of this one's, within the same limit.
        let left = self.scene.solver.limits.max_memory_gb - self.memory_estimate as f64 / 1e9;
        if left < 1e-3 {
            return Some(Err(format!(
                "this mesh's estimated {:.3} GB leave nothing of solver.limits.max_memory_gb for a coarser one",
                self.memory_estimate as f64 / 1e9
            )));
        }
        scene.solver.limits.max_memory_gb = left;
        // All the coarse start's memory at once, on top of what this step has probed for
        // itself: the coarser meshes' models and solvers (each a quarter of the next finer
        // one's: a third of this one's in all, probed as a half), their transfers, and this
        // step's working memory, which must still be there when they are done.
        if !self.scene.debug.skip_memory_probes {
            let bytes = self.memory_estimate / 2
                + 200 * (self.model.reference.len() + self.model.triangles.len()) as u64
                + self.solver.step_bytes(&self.model);
            if let Err(e) = crate::memory::probe(bytes, "the coarse start") {
                return Some(Err(e.to_string()));
            }
        }
        let what = if self.scene.geometry.generators.is_empty() {
            "the mesh with edges collapsed"
        } else {
            "the mesh with half the divisions"
        };
        Some(self.solve_coarse(scene, what))
    }

    /// Solve `scene` (this one's coarser mesh) under this state's loads and parameters and
    /// carry its answer over to this mesh. With a helper in this solver's pool and a coarser
    /// mesh below `scene`'s likely, that coarser mesh's whole chain is solved on this thread
    /// while the helper builds `scene`'s engine ([`Engine::solve_beside`]); `scene`'s solve then
    /// starts from it. Where an earlier such chain solved `scene` already ([`EARLY`]), its
    /// answer is taken.
    fn solve_coarse(&self, scene: Scene, what: &str) -> Result<Guess, String> {
        let started = std::time::Instant::now();
        let probes = !self.scene.debug.skip_memory_probes;
        let solved = match take_early(&scene) {
            Some(solved) => solved,
            None => self.solve_scene(scene, what)?,
        };
        let transfer_bytes = 80 * self.model.reference.len() as u64
            + 60 * solved.model.reference.len() as u64
            + 200 * solved.model.triangles.len() as u64;
        if probes {
            crate::memory::probe(transfer_bytes, "the coarse start's transfer")
                .map_err(|e| e.to_string())?;
        }
        USED.with(|u| u.set(solved.estimate));
        let Solved {
            model,
            u,
            dofs,
            iterations,
            mut log,
            seconds,
            ..
        } = solved;
        let phase = crate::phases::start("coarse start: transfer");
        let start = transfer(model, u, &self.model, self.solver.pool())?;
        drop(phase);
        log.push(format!(
            "coarse start: {what} ({dofs} free DOF) converged in {iterations} iterations ({:.2} s, its coarser meshes included); Newton here starts from its answer",
            seconds + started.elapsed().as_secs_f64()
        ));
        Ok(Guess { start, log })
    }

    /// `scene` (this one's coarser mesh) built and solved under this state's loads and
    /// parameters (the coarse engine's solver is freed here; its model and answer are kept
    /// for the transfer).
    fn solve_scene(&self, scene: Scene, what: &str) -> Result<Solved, String> {
        let next = self.next_below(&scene);
        let built = match (next, self.solver.pool()) {
            (Some(next), Some(pool)) if pool.helpers() > 0 => {
                self.solve_beside(pool, scene.clone(), next)?
            }
            _ => Engine::try_new(scene.clone()).map_err(|e| format!("its scene: {e}"))?,
        };
        let nodes = self.model.reference.len();
        let solved = solve_built(built, &self.state, &self.scene, nodes, what, scene);
        // Whatever path `solve_built` left by (an early error included), an answer solved
        // beside this build is stale now: it does not outlive this chain on the thread.
        EARLY.with(|e| e.borrow_mut().take());
        solved
    }

    /// The scene below `scene` (this one's coarser mesh) that `scene`'s own first step will
    /// likely start from: where this mesh is large enough that `scene`'s mesh (about a quarter
    /// of it) has the coarse start too. A guess: the coarser mesh's own step decides, and
    /// takes the answer solved here only where its scene is this one (but for the memory
    /// limit, [`take_early`]).
    fn next_below(&self, scene: &Scene) -> Option<Scene> {
        let auto = scene.solver.coarse_start == CoarseStart::Auto;
        if auto && self.free_dofs() < 5 * AUTO_DOF {
            return None;
        }
        #[cfg(test)]
        if !tests::BESIDE.with(|b| b.get()) {
            return None;
        }
        coarser_scene(scene, &self.model, self.free_dofs())
    }

    /// `scene`'s engine built on `pool`'s helper while this thread solves the chain of `next`
    /// (the mesh below `scene`'s, which `scene`'s first step starts from); that answer is
    /// left in [`EARLY`] for `scene`'s step. Where the chain fails, `scene`'s step builds it
    /// again (and fails the same way). Err where the helper failed to build.
    fn solve_beside(&self, pool: &Arc<Pool>, scene: Scene, next: Scene) -> Result<Engine, String> {
        let what = if next.geometry.generators.is_empty() {
            "the mesh with edges collapsed"
        } else {
            "the mesh with half the divisions"
        };
        let build = move || Engine::try_new(scene);
        // The chain below on this thread: `next`'s engine, which, solving, starts from its
        // own coarser meshes (beside its own helper in turn).
        let here = || -> Option<Solved> {
            let started = std::time::Instant::now();
            let engine = Engine::try_new(next.clone()).ok()?;
            // Its transfer's lists are probed for a mesh of this one's nodes (the mesh it is
            // carried over to, being built, has about a quarter of them).
            let nodes = self.model.reference.len();
            let mut solved =
                solve_built(engine, &self.state, &self.scene, nodes, what, next).ok()?;
            solved.seconds = started.elapsed().as_secs_f64();
            Some(solved)
        };
        let (built, early) = pool
            .beside(0, build, here)
            .map_err(|e| format!("its engine's thread: {e}"))?;
        let built = built.map_err(|e| format!("its scene: {e}"))?;
        EARLY.with(|e| *e.borrow_mut() = early);
        Ok(built)
    }
}

/// A coarser mesh solved: its model and answer for the transfer, its free DOF, iterations and
/// the coarse start's log lines of its own chain; the scene it was solved from, its engine's
/// memory estimate with those of its own coarser meshes, and its wall time.
struct Solved {
    model: Model,
    u: Vec<f64>,
    dofs: usize,
    iterations: usize,
    log: Vec<String>,
    scene: Scene,
    estimate: u64,
    seconds: f64,
}

thread_local! {
    /// The answer of a coarser mesh solved beside the build of the next finer one
    /// ([`Engine::solve_beside`]), for that finer mesh's first step on this thread.
    static EARLY: std::cell::RefCell<Option<Solved>> = const { std::cell::RefCell::new(None) };
    /// The memory estimate of the coarser meshes the last coarse start on this thread used
    /// (the sum over its chain), read by [`solve_built`] after its engine's solve.
    static USED: std::cell::Cell<u64> = const { std::cell::Cell::new(0) };
}

/// The answer in [`EARLY`] where it was solved from `wanted` (the same scene but for the
/// memory limit: it was solved under the finer mesh's, before the mesh between was built, so
/// its chain's estimates must be within `wanted`'s limit, as its own size checks would have
/// asked). Emptied either way.
fn take_early(wanted: &Scene) -> Option<Solved> {
    let solved = EARLY.with(|e| e.borrow_mut().take())?;
    let mut scene = solved.scene.clone();
    scene.solver.limits.max_memory_gb = wanted.solver.limits.max_memory_gb;
    let within = (solved.estimate as f64 / 1e9) < wanted.solver.limits.max_memory_gb;
    let taken = scene == *wanted && within;
    #[cfg(test)]
    tests::TAKEN.with(|t| t.set(t.get() + usize::from(taken)));
    taken.then_some(solved)
}

/// `coarse` (built from `scene`, the coarser mesh of an engine in state `from` with scene
/// `fine` and `fine_nodes` nodes) solved under `from`'s loads and parameters.
fn solve_built(
    mut coarse: Engine,
    from: &super::EngineState,
    fine: &Scene,
    fine_nodes: usize,
    what: &str,
    scene: Scene,
) -> Result<Solved, String> {
    // Every allocation of the coarse start besides the coarse engine's own (probed by it):
    // its state's copy, and the transfer's lists (about 80 bytes per node of the finer mesh,
    // 60 per node and up to 200 per triangle of the coarse one), probed here and again
    // before the transfer, when the coarse solve's memory is in use.
    let transfer_bytes = 80 * fine_nodes as u64
        + 60 * coarse.model.reference.len() as u64
        + 200 * coarse.model.triangles.len() as u64;
    let state_bytes = 8 * (coarse.state.displacement.len() + 4 * coarse.state.inputs.len()) as u64
        + 16 * coarse.state.wrinkle.len() as u64;
    if !fine.debug.skip_memory_probes {
        crate::memory::probe(state_bytes + transfer_bytes, "the coarse start")
            .map_err(|e| e.to_string())?;
    }
    let mut state = coarse.state.clone();
    if state.inputs.len() != from.inputs.len() || state.parameters.len() != from.parameters.len() {
        return Err("its inputs or parameters differ from this mesh's".into());
    }
    state.inputs.clone_from(&from.inputs);
    state.applied.clone_from(&from.applied);
    state.parameters.clone_from(&from.parameters);
    coarse
        .set_state(state)
        .map_err(|e| format!("its start: {e}"))?;
    // The estimates of the coarser meshes its own step uses, for take_early's check.
    USED.with(|u| u.set(0));
    let report = coarse.solve();
    let below = USED.with(|u| u.get());
    // An answer solved beside this engine's build that its step did not take goes.
    EARLY.with(|e| e.borrow_mut().take());
    let dofs = coarse.free_dofs();
    if !report.converged() {
        return Err(format!(
            "{what} ({dofs} free DOF) did not converge: {}",
            report.message
        ));
    }
    let iterations = report.iterations;
    let log: Vec<String> = report
        .log
        .into_iter()
        .filter(|l| l.starts_with("coarse start"))
        .collect();
    // The coarse model and answer go to the transfer; the rest of the coarse engine (its
    // solver) is freed here.
    let estimate = coarse.memory_estimate + below;
    let Engine { model, state, .. } = coarse;
    Ok(Solved {
        model,
        u: state.displacement,
        dofs,
        iterations,
        log,
        scene,
        estimate,
        seconds: 0.0,
    })
}

/// The scene with every generator's divisions halved (rounded up) where they stay at least
/// `MIN_DIVISIONS`, or an explicit mesh's coarser copy (`scene::coarsen`); None where no
/// generator changes or an explicit mesh has no coarser copy.
fn coarser(scene: &Scene) -> Option<Scene> {
    if scene.geometry.generators.is_empty() {
        return crate::scene::coarsen::coarser_explicit(scene);
    }
    let half = |d: usize| (d.div_ceil(2) >= MIN_DIVISIONS).then(|| d.div_ceil(2));
    let mut out = scene.clone();
    let mut changed = false;
    for g in &mut out.geometry.generators {
        match g {
            Generator::Rectangle { divisions, .. } => {
                if let (Some(a), Some(b)) = (half(divisions[0]), half(divisions[1])) {
                    *divisions = [a, b];
                    changed = true;
                }
            }
            Generator::Disc { rings, .. } | Generator::Cushion { rings, .. } => {
                if let Some(r) = half(*rings) {
                    *rings = r;
                    changed = true;
                }
            }
            Generator::Annulus {
                rings,
                sectors,
                grading,
                ..
            } => {
                if let (Some(r), Some(s)) = (half(*rings), half(*sectors)) {
                    // The same radii every other ring: the ratio of one coarse ring to the
                    // next is two fine ones'.
                    *grading = *grading * *grading;
                    (*rings, *sectors) = (r, s);
                    changed = true;
                }
            }
        }
    }
    changed.then_some(out)
}

/// `u` (the coarse model's displacements) carried over to the nodes of `fine` (module docs),
/// 0 at every held DOF; Err(why) where a node of `fine` has no counterpart on the coarse mesh.
/// With a helper in `pool`, on two threads: the coarse side's grids on the helper while this
/// thread finds the fine nodes' places, groups and normals, then the fine nodes in chunks that
/// the two threads take in turn (each node's value is computed alone: the same answer as on
/// one thread, bit for bit).
fn transfer(
    coarse: Model,
    u: Vec<f64>,
    fine: &Model,
    pool: Option<&Arc<Pool>>,
) -> Result<Vec<f64>, String> {
    const OFF: &str = "a node of this mesh lies off the coarse mesh";
    if coarse.membrane_groups.len() != fine.membrane_groups.len() {
        return Err(OFF.into());
    }
    let helper = pool.filter(|p| p.helpers() > 0);
    let thread = |e: crate::error::Error| format!("the transfer's thread: {e}");
    let build = move || Coarse::new(coarse, u);
    let (mut coarse, nodes) = match helper {
        Some(pool) => pool
            .beside(0, build, || FineNodes::new(fine))
            .map_err(thread)?,
        None => (build(), FineNodes::new(fine)),
    };
    // Only where some node of this mesh is on no triangle.
    if nodes.group_of.contains(&usize::MAX) {
        coarse.index_places();
    }
    let (coarse, nodes) = (Arc::new(coarse), Arc::new(nodes));
    let next = Arc::new(AtomicUsize::new(0));
    let (theirs, mine) = {
        let (c, n, k) = (Arc::clone(&coarse), Arc::clone(&nodes), Arc::clone(&next));
        let job = move || c.carry_chunks(&n, &k);
        let here = || coarse.carry_chunks(&nodes, &next);
        match helper {
            Some(pool) => pool.beside(0, job, here).map_err(thread)?,
            None => (Some(Vec::new()), here()),
        }
    };
    let (Some(mine), Some(theirs)) = (mine, theirs) else {
        return Err(OFF.into());
    };
    let mut out = vec![0.0; fine.unknown_count()];
    for (k, values) in mine.into_iter().chain(theirs) {
        let at = 3 * k * CHUNK;
        out[at..at + values.len()].copy_from_slice(&values);
    }
    // A held DOF stays where its support holds it (0: no prescribed displacement here), even
    // where the node lies off the coarse mesh's rim (a curved rim's chord cuts the sheet, so
    // the nearest coarse point of a rim node can be inside a triangle that moves).
    for (x, &held) in out.iter_mut().zip(&fine.held) {
        if held {
            *x = 0.0;
        }
    }
    Ok(out)
}

/// The fine side of a transfer: every fine node's place, its membrane group (its first
/// triangle's) and its normal (the sum of its triangles' area vectors in that group: two
/// sheets that start on top of each other, a cushion's, face opposite ways).
struct FineNodes {
    x: Vec<[f64; 3]>,
    group_of: Vec<usize>,
    normal: Vec<[f64; 3]>,
}

impl FineNodes {
    fn new(fine: &Model) -> FineNodes {
        let x = fine.reference.iter().map(|p| [p[0], p[1], p[2]]).collect();
        let mut group_of = vec![usize::MAX; fine.reference.len()];
        let mut normal = vec![[0.0; 3]; fine.reference.len()];
        for (g, range) in fine.membrane_groups.iter().enumerate() {
            for t in &fine.triangles[range.clone()] {
                let a = area_vector(fine, t.nodes);
                for &n in &t.nodes {
                    if group_of[n] == usize::MAX {
                        group_of[n] = g;
                    }
                    if group_of[n] == g {
                        for k in 0..3 {
                            normal[n][k] += a[k];
                        }
                    }
                }
            }
        }
        FineNodes {
            x,
            group_of,
            normal,
        }
    }
}

/// Fine nodes per chunk of the transfer's node loop ([`Coarse::carry_chunks`]).
const CHUNK: usize = 4096;

/// The coarse side of a transfer: the coarse model, its displacements `u`, a grid over each
/// membrane group, and (only where some fine node is on no triangle) its nodes by place.
struct Coarse {
    model: Model,
    u: Vec<f64>,
    grids: Vec<Grid>,
    at_place: HashMap<[u64; 3], usize>,
}

impl Coarse {
    fn new(model: Model, u: Vec<f64>) -> Coarse {
        let grids = model
            .membrane_groups
            .iter()
            .map(|r| Grid::new(&model, r.clone()))
            .collect();
        Coarse {
            model,
            u,
            grids,
            at_place: HashMap::new(),
        }
    }

    /// Index the coarse nodes by their place (bit for bit), for fine nodes on no triangle.
    fn index_places(&mut self) {
        let place = |x: &nalgebra::Vector3<f64>| [x[0].to_bits(), x[1].to_bits(), x[2].to_bits()];
        self.at_place = self
            .model
            .reference
            .iter()
            .enumerate()
            .map(|(i, x)| (place(x), i))
            .collect();
    }

    /// The values of the fine nodes of the chunks `next` hands out ([`CHUNK`] nodes each,
    /// taken in turn with the other thread): (chunk, its values, three per node); None where
    /// a node has no counterpart on the coarse mesh.
    fn carry_chunks(
        &self,
        nodes: &FineNodes,
        next: &AtomicUsize,
    ) -> Option<Vec<(usize, Vec<f64>)>> {
        let count = nodes.x.len();
        let mut done = Vec::new();
        loop {
            let k = next.fetch_add(1, Ordering::Relaxed);
            if k.saturating_mul(CHUNK) >= count {
                return Some(done);
            }
            done.push((k, self.carry(nodes, k * CHUNK..count.min((k + 1) * CHUNK))?));
        }
    }

    /// The values of the fine nodes `range`, three per node; None where one has no
    /// counterpart on the coarse mesh.
    fn carry(&self, nodes: &FineNodes, range: std::ops::Range<usize>) -> Option<Vec<f64>> {
        let (model, u) = (&self.model, &self.u);
        let mut out = Vec::with_capacity(3 * range.len());
        for i in range {
            let p = nodes.x[i];
            let value = if nodes.group_of[i] == usize::MAX {
                let j = *self
                    .at_place
                    .get(&[p[0].to_bits(), p[1].to_bits(), p[2].to_bits()])?;
                [u[3 * j], u[3 * j + 1], u[3 * j + 2]]
            } else {
                let (t, w) = self.grids[nodes.group_of[i]].nearest(model, p, nodes.normal[i])?;
                let mut v = [0.0; 3];
                for (a, &n) in model.triangles[t].nodes.iter().enumerate() {
                    for k in 0..3 {
                        v[k] += w[a] * u[3 * n + k];
                    }
                }
                v
            };
            out.extend_from_slice(&value);
        }
        Some(out)
    }
}

/// A uniform grid of cells over one membrane group's coarse triangles, each triangle listed
/// in every cell its bounding box touches.
struct Grid {
    origin: [f64; 3],
    cell: f64,
    /// Every cell's range in `listed` (a cell in no triangle's box is absent).
    cells: HashMap<[i64; 3], (usize, usize), BuildHasherDefault<CellHasher>>,
    /// The triangles (places in the group) of every cell, each cell's in ascending order.
    listed: Vec<usize>,
    /// The smallest and the largest cell key on each axis over all triangles' boxes.
    keys: ([i64; 3], [i64; 3]),
    /// Each triangle's box in cell keys (lowest and highest corner), by place in the group.
    boxes: Vec<([i64; 3], [i64; 3])>,
    /// Twice each triangle's reference area vector, by place in the group.
    areas: Vec<[f64; 3]>,
    /// The group's first triangle in the model.
    first: usize,
}

/// The grid's hash of a cell key: the multiply-rotate mix of rustc's FxHasher, several times
/// cheaper than the default SipHash on three integers (the keys come from the mesh, not
/// from an adversary).
#[derive(Default)]
struct CellHasher(u64);

impl std::hash::Hasher for CellHasher {
    fn finish(&self) -> u64 {
        self.0
    }

    fn write(&mut self, bytes: &[u8]) {
        for chunk in bytes.chunks(8) {
            let mut word = [0u8; 8];
            word[..chunk.len()].copy_from_slice(chunk);
            self.write_u64(u64::from_le_bytes(word));
        }
    }

    fn write_u64(&mut self, i: u64) {
        self.0 = (self.0.rotate_left(5) ^ i).wrapping_mul(0x51_7c_c1_b7_27_22_0a_95);
    }

    fn write_usize(&mut self, i: usize) {
        self.write_u64(i as u64);
    }
}

/// The cells of the box from `a` to `b` (cell keys, both included), in lexicographic order.
fn cells_of(a: [i64; 3], b: [i64; 3]) -> impl Iterator<Item = [i64; 3]> {
    (a[0]..=b[0])
        .flat_map(move |i| (a[1]..=b[1]).flat_map(move |j| (a[2]..=b[2]).map(move |l| [i, j, l])))
}

impl Grid {
    fn new(model: &Model, range: std::ops::Range<usize>) -> Grid {
        let triangles = &model.triangles[range.clone()];
        let x = |n: usize| model.reference[n];
        let mut lo = [f64::INFINITY; 3];
        let (mut edge, mut longest) = (0.0, 0.0f64);
        for t in triangles {
            for a in 0..3 {
                for (k, low) in lo.iter_mut().enumerate() {
                    *low = low.min(x(t.nodes[a])[k]);
                }
                let l = (x(t.nodes[a]) - x(t.nodes[(a + 1) % 3])).norm();
                edge += l;
                longest = longest.max(l);
            }
        }
        // The mean edge, but at least a quarter of the longest: no triangle of a strongly
        // graded mesh is listed in more than 5 x 5 x 5 cells.
        let cell = (edge / (3.0 * triangles.len().max(1) as f64))
            .max(longest / 4.0)
            .max(f64::MIN_POSITIVE);
        let mut grid = Grid {
            origin: lo,
            cell,
            cells: HashMap::default(),
            listed: Vec::new(),
            keys: ([i64::MAX; 3], [i64::MIN; 3]),
            boxes: Vec::with_capacity(triangles.len()),
            areas: triangles
                .iter()
                .map(|t| area_vector(model, t.nodes))
                .collect(),
            first: range.start,
        };
        // Every cell's count, then its range in `listed`, then its triangles in ascending order.
        for t in triangles {
            let mut a = [i64::MAX; 3];
            let mut b = [i64::MIN; 3];
            for &n in &t.nodes {
                let c = grid.key([x(n)[0], x(n)[1], x(n)[2]]);
                for d in 0..3 {
                    a[d] = a[d].min(c[d]);
                    b[d] = b[d].max(c[d]);
                }
            }
            for d in 0..3 {
                grid.keys.0[d] = grid.keys.0[d].min(a[d]);
                grid.keys.1[d] = grid.keys.1[d].max(b[d]);
            }
            grid.boxes.push((a, b));
            for key in cells_of(a, b) {
                grid.cells.entry(key).or_insert((0, 0)).1 += 1;
            }
        }
        let mut next = 0;
        for range in grid.cells.values_mut() {
            let count = range.1;
            *range = (next, next);
            next += count;
        }
        grid.listed = vec![0; next];
        for (k, &(a, b)) in grid.boxes.iter().enumerate() {
            for key in cells_of(a, b) {
                if let Some(range) = grid.cells.get_mut(&key) {
                    grid.listed[range.1] = k;
                    range.1 += 1;
                }
            }
        }
        grid
    }

    fn key(&self, p: [f64; 3]) -> [i64; 3] {
        std::array::from_fn(|k| ((p[k] - self.origin[k]) / self.cell).floor() as i64)
    }

    /// The triangles listed in cell `key` (places in the group).
    fn listed(&self, key: [i64; 3]) -> &[usize] {
        self.cells
            .get(&key)
            .map_or(&[][..], |&(s, e)| &self.listed[s..e])
    }

    /// The squared distance from `p` to the group's `k`-th triangle and the weights of its
    /// nodes at the nearest point; None where the triangle faces away from `normal` (when
    /// `sided`).
    fn distance(
        &self,
        model: &Model,
        k: usize,
        p: [f64; 3],
        normal: [f64; 3],
        sided: bool,
    ) -> Option<(f64, [f64; 3])> {
        if sided {
            let a = self.areas[k];
            if a[0] * normal[0] + a[1] * normal[1] + a[2] * normal[2] <= 0.0 {
                return None;
            }
        }
        let n = model.triangles[self.first + k].nodes;
        let v = |a: usize| {
            let x = model.reference[n[a]];
            [x[0], x[1], x[2]]
        };
        Some(closest_point(p, v(0), v(1), v(2)))
    }

    /// The triangle nearest to `p` among those in the cells around it (up to three cells
    /// away) that face the side `normal` faces (all where the normal is zero, as at the
    /// shared rim of two sheets), and the weights of its nodes at the nearest point: the first
    /// found at the least distance, searching the cells in lexicographic order and each
    /// cell's triangles in ascending order.
    fn nearest(&self, model: &Model, p: [f64; 3], normal: [f64; 3]) -> Option<(usize, [f64; 3])> {
        let size = normal.iter().map(|v| v * v).sum::<f64>().sqrt();
        let sided = size > 1e-9 * self.cell * self.cell;
        let c = self.key(p);
        self.nearest_in_own_cell(model, p, normal, sided, c)
            .or_else(|| self.search(model, p, normal, sided, c))
    }

    /// [`Grid::nearest`] by searching the cells around `p`'s cell `c`, one cell farther at a
    /// time.
    fn search(
        &self,
        model: &Model,
        p: [f64; 3],
        normal: [f64; 3],
        sided: bool,
        c: [i64; 3],
    ) -> Option<(usize, [f64; 3])> {
        for reach in 1..=3i64 {
            let mut best: Option<(f64, usize, [f64; 3])> = None;
            for i in -reach..=reach {
                for j in -reach..=reach {
                    for l in -reach..=reach {
                        for &k in self.listed([c[0] + i, c[1] + j, c[2] + l]) {
                            let Some((d, w)) = self.distance(model, k, p, normal, sided) else {
                                continue;
                            };
                            if best.is_none_or(|b| d < b.0) {
                                best = Some((d, self.first + k, w));
                            }
                        }
                    }
                }
            }
            if let Some((d, t, w)) = best {
                // Only a point within the cells searched is surely the nearest.
                if d.sqrt() <= reach as f64 * self.cell {
                    return Some((t, w));
                }
            }
        }
        None
    }

    /// [`Grid::nearest`]'s answer from `p`'s own cell `c` alone where that decides it, None
    /// where the search around it has to run. A triangle not listed in `c` lies beyond one
    /// of the cell's faces that some triangle's box crosses (on an axis where every box
    /// holds `c`'s key, a face has nothing beyond it), so its distance is at least `p`'s
    /// distance to the nearest such face: a triangle of `c` nearer than that (and within
    /// one cell, where the search around `c` would stop) is the nearest. Of those at the
    /// same distance the search takes the first it meets: the one whose box's first cell in
    /// the search's order (its lowest corner, clipped to the 3 x 3 x 3 block around `c`)
    /// comes first, then the lowest place (the order of a cell's list), which is what the
    /// ranking below takes too.
    fn nearest_in_own_cell(
        &self,
        model: &Model,
        p: [f64; 3],
        normal: [f64; 3],
        sided: bool,
        c: [i64; 3],
    ) -> Option<(usize, [f64; 3])> {
        let mut margin = f64::INFINITY;
        for k in 0..3 {
            let low = self.origin[k] + c[k] as f64 * self.cell;
            if c[k] > self.keys.0[k] {
                margin = margin.min(p[k] - low);
            }
            if c[k] < self.keys.1[k] {
                margin = margin.min(low + self.cell - p[k]);
            }
        }
        // Round-off of the keys and the faces: far below a millionth of a cell.
        let margin = margin.min(self.cell) - 1e-6 * self.cell;
        let mut best: Option<(f64, [i64; 3], usize, [f64; 3])> = None;
        for &k in self.listed(c) {
            let Some((d, w)) = self.distance(model, k, p, normal, sided) else {
                continue;
            };
            if d.is_nan() {
                return None;
            }
            let a = self.boxes[k].0;
            let first = [
                (a[0] - c[0]).max(-1),
                (a[1] - c[1]).max(-1),
                (a[2] - c[2]).max(-1),
            ];
            let better =
                best.is_none_or(|(bd, bf, bk, _)| d < bd || (d == bd && (first, k) < (bf, bk)));
            if better {
                best = Some((d, first, k, w));
            }
        }
        let (d, _, k, w) = best?;
        (d.sqrt() < margin).then_some((self.first + k, w))
    }
}

/// Twice the area vector of the triangle on `nodes` in the reference configuration.
fn area_vector(model: &Model, nodes: [usize; 3]) -> [f64; 3] {
    let x = |a: usize| model.reference[nodes[a]];
    let n = (x(1) - x(0)).cross(&(x(2) - x(0)));
    [n[0], n[1], n[2]]
}

/// The squared distance from `p` to the triangle (a, b, c) and the weights of a, b, c at the
/// triangle's point nearest to `p` (Ericson 2005, *Real-Time Collision Detection*, §5.1.5).
fn closest_point(p: [f64; 3], a: [f64; 3], b: [f64; 3], c: [f64; 3]) -> (f64, [f64; 3]) {
    let sub = |x: [f64; 3], y: [f64; 3]| [x[0] - y[0], x[1] - y[1], x[2] - y[2]];
    let dot = |x: [f64; 3], y: [f64; 3]| x[0] * y[0] + x[1] * y[1] + x[2] * y[2];
    let (ab, ac, ap) = (sub(b, a), sub(c, a), sub(p, a));
    let (d1, d2) = (dot(ab, ap), dot(ac, ap));
    let w = if d1 <= 0.0 && d2 <= 0.0 {
        [1.0, 0.0, 0.0]
    } else {
        let bp = sub(p, b);
        let (d3, d4) = (dot(ab, bp), dot(ac, bp));
        let cp = sub(p, c);
        let (d5, d6) = (dot(ab, cp), dot(ac, cp));
        let (va, vb, vc) = (d3 * d6 - d5 * d4, d5 * d2 - d1 * d6, d1 * d4 - d3 * d2);
        if d3 >= 0.0 && d4 <= d3 {
            [0.0, 1.0, 0.0]
        } else if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
            let v = d1 / (d1 - d3);
            [1.0 - v, v, 0.0]
        } else if d6 >= 0.0 && d5 <= d6 {
            [0.0, 0.0, 1.0]
        } else if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
            let w = d2 / (d2 - d6);
            [1.0 - w, 0.0, w]
        } else if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
            let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
            [0.0, 1.0 - w, w]
        } else {
            let denom = 1.0 / (va + vb + vc);
            let (v, w) = (vb * denom, vc * denom);
            [1.0 - v - w, v, w]
        }
    };
    let q: [f64; 3] = std::array::from_fn(|k| w[0] * a[k] + w[1] * b[k] + w[2] * c[k]);
    let d = sub(p, q);
    (dot(d, d), w)
}

#[cfg(test)]
mod tests {
    use super::{closest_point, coarser, transfer, Grid};
    use crate::model::Model;
    use crate::scene::generate::resolve;
    use crate::Engine;
    use crate::Scene;
    use std::cell::Cell;

    thread_local! {
        /// Off: no coarser chain solved beside a build ([`super::Engine::next_below`]).
        pub(super) static BESIDE: Cell<bool> = const { Cell::new(true) };
        /// Answers solved beside a build and taken by the next finer mesh's step.
        pub(super) static TAKEN: Cell<usize> = const { Cell::new(0) };
    }

    /// With two threads the chain below a coarser mesh is solved while the helper builds that
    /// mesh's engine, and its answer taken by that mesh's step: the Hencky disc at 84 rings
    /// (62 751 free DOF, split on two threads) starts from 42 rings, which starts from 21,
    /// solved beside the 42-ring build. The same outputs, bit for bit, as the chain built and
    /// solved one mesh after the other, and the same log but for the times.
    #[test]
    fn the_chain_solved_beside_a_build_gives_the_serial_answer() {
        let path = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/modelDescription/HenckyDisc/scene.json"
        );
        let mut value: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
        value["geometry"]["generators"][0]["rings"] = 84.into();
        value["solver"]["threads"] = 2.into();
        let scene = Scene::from_json(&value.to_string()).expect("valid scene");
        let solve = |beside: bool| {
            BESIDE.with(|b| b.set(beside));
            TAKEN.with(|t| t.set(0));
            let mut engine = Engine::try_new(scene.clone()).expect("valid");
            let vr = engine
                .variables()
                .iter()
                .find(|v| v.name == "pressure")
                .expect("the pressure input")
                .value_reference;
            engine.set_real(vr, 40.0).unwrap();
            let report = engine.solve();
            assert!(report.converged(), "{}", report.message);
            // Each coarse mesh's line without its wall time.
            let times = |l: &String| match (l.find("iterations ("), l.find(" s, its")) {
                (Some(a), Some(b)) => format!("{}{}", &l[..a], &l[b..]),
                _ => l.clone(),
            };
            let log: Vec<String> = report.log.iter().map(times).collect();
            BESIDE.with(|b| b.set(true));
            (engine.outputs(), log, TAKEN.with(|t| t.get()))
        };
        let (serial, serial_log, none) = solve(false);
        let (beside, beside_log, taken) = solve(true);
        assert_eq!(none, 0);
        assert_eq!(
            taken, 1,
            "the 21-ring answer, solved beside the 42-ring build"
        );
        assert_eq!(serial, beside);
        assert_eq!(serial_log, beside_log);
        assert!(
            serial_log.iter().any(|l| l.contains("(3783 free DOF)")),
            "{serial_log:?}"
        );
    }

    fn scene(generator: &str, membranes: &str) -> Scene {
        let text = format!(
            r#"{{"format": 1, "name": "T", "geometry": {{"generators": [{generator}]}},
               "membranes": {membranes}, "supports": [{{"nodes": "g.boundary", "fix": ["x", "y", "z"]}}]}}"#
        );
        Scene::from_json(&text).expect("valid scene")
    }

    /// A displacement field linear in the reference coordinates, different per sheet (`side`).
    fn field(x: nalgebra::Vector3<f64>, side: f64) -> [f64; 3] {
        [
            0.1 + 0.2 * x[0] - 0.3 * x[1],
            -0.2 + 0.05 * x[0] + 0.4 * x[1],
            side * (0.3 + 0.1 * x[0] + 0.2 * x[1]),
        ]
    }

    /// A scene that names a generated node by its id gets no coarse start (the coarser mesh
    /// numbers its nodes otherwise); the same scene naming its nodes by a generator's set
    /// does, and so does one naming an explicit node by id.
    #[test]
    fn no_coarse_start_where_a_generated_node_is_named_by_id() {
        let with = |fix: &str, extra: &str| {
            let text = format!(
                r#"{{"format": 1, "name": "T", "geometry": {{"nodes": [[0, 0, 1]], "generators": [{{"kind": "disc", "name": "g", "center": [0, 0, 0], "radius": 1, "rings": 8}}]{extra}}},
                   "membranes": [{{"name": "m", "triangles": "g", "thickness": 1e-3, "material": {{"kind": "svk", "E": 1e9, "nu": 0.3}}}}],
                   "supports": [{{"nodes": "g.rim", "fix": ["x", "y", "z"]}}, {{"nodes": {fix}, "fix": ["x"]}}],
                   "solver": {{"coarse_start": "on"}}}}"#
            );
            let scene = Scene::from_json(&text).expect("valid scene");
            let model = Model::build(&scene);
            super::coarser_scene(&scene, &model, 1).is_some()
        };
        assert!(with(r#""g.center""#, ""));
        assert!(with("[0]", ""), "the explicit node 0");
        assert!(!with("[7]", ""), "generated node 7 by id");
        assert!(!with(r#""east""#, r#", "node_sets": {"east": [9]}"#));
    }

    /// A field linear in the reference coordinates is carried over exactly (the transfer is
    /// linear in each coarse triangle, and every fine node of a halved rectangle lies on
    /// the coarse mesh), except at the held boundary, which stays at 0. TOLERANCE: round-off,
    /// 1e-14 (fields of order 1).
    #[test]
    fn a_linear_field_is_carried_over_exactly() {
        let fine = scene(
            r#"{"kind": "rectangle", "name": "g", "origin": [0, 0, 0], "size": [4, 3], "divisions": [9, 8]}"#,
            r#"[{"name": "m", "triangles": "g", "thickness": 1e-3, "material": {"kind": "svk", "E": 1e9, "nu": 0.3}}]"#,
        );
        let coarse = coarser(&fine).expect("halved");
        let (cm, fm) = (Model::build(&coarse), Model::build(&fine));
        assert_eq!((cm.reference.len(), fm.reference.len()), (30, 90));
        let u: Vec<f64> = cm.reference.iter().flat_map(|x| field(*x, 1.0)).collect();
        let out =
            transfer(cm.clone(), u.clone(), &fm, None).expect("every node on the coarse mesh");
        let mut held = 0;
        for (i, x) in fm.reference.iter().enumerate() {
            let want = field(*x, 1.0);
            for k in 0..3 {
                if fm.held[3 * i + k] {
                    assert_eq!(out[3 * i + k], 0.0, "node {i} is held");
                    held += 1;
                } else {
                    assert!((out[3 * i + k] - want[k]).abs() < 1e-14, "node {i}");
                }
            }
        }
        assert_eq!(
            held,
            3 * 2 * (9 + 8),
            "the rectangle's boundary, held in x, y, z"
        );
    }

    /// The two sheets of a flat cushion start on top of each other: each fine node takes the
    /// field of its own sheet (the coarse triangles facing its way), the shared rim either
    /// (both fields agree there by construction below). TOLERANCE: round-off, 1e-14.
    #[test]
    fn each_sheet_of_a_flat_cushion_takes_its_own_field() {
        let fine = scene(
            r#"{"kind": "cushion", "name": "g", "center": [0, 0, 0], "outline": {"shape": "rectangle", "size": [2, 1]}, "rings": 8}"#,
            r#"[{"name": "m", "triangles": "g", "thickness": 1e-3, "material": {"kind": "svk", "E": 1e9, "nu": 0.3}}]"#,
        );
        let coarse = coarser(&fine).expect("halved");
        let (cm, fm) = (Model::build(&coarse), Model::build(&fine));
        let (cmesh, fmesh) = (resolve(&coarse.geometry), resolve(&fine.geometry));
        let side = |mesh: &crate::scene::generate::Mesh, n: usize| {
            if mesh.node_sets["g.bottom"].contains(&n) {
                -1.0
            } else if mesh.node_sets["g.top"].contains(&n) {
                1.0
            } else {
                0.0
            }
        };
        let u: Vec<f64> = cm
            .reference
            .iter()
            .enumerate()
            .flat_map(|(i, x)| field(*x, side(&cmesh, i)))
            .collect();
        let out =
            transfer(cm.clone(), u.clone(), &fm, None).expect("every node on the coarse mesh");
        let mut sheets = [0, 0];
        for (i, x) in fm.reference.iter().enumerate() {
            let s = side(&fmesh, i);
            if s == 0.0 {
                continue;
            }
            sheets[(s > 0.0) as usize] += 1;
            // Near the rim a coarse triangle touches the rim (where the field is 0 in z): the
            // comparison holds for nodes whose coarse triangle lies inside the sheet, so
            // only the in-plane components, linear everywhere, are compared for every node,
            // and z's sign for all.
            let want = field(*x, s);
            for k in 0..2 {
                assert!((out[3 * i + k] - want[k]).abs() < 1e-14, "node {i}");
            }
            assert!(
                out[3 * i + 2] * s > 0.0,
                "node {i} took the other sheet's z"
            );
        }
        assert!(sheets[0] > 50 && sheets[1] > 50, "{sheets:?}");
    }

    /// A disc of 24 rings and a flat 2 m x 1 m cushion of 12 rings (two sheets), each as the
    /// models of its halved (coarse) and its own (fine) mesh, with its case number (0, 1) for
    /// the tests' messages.
    fn disc_and_cushion() -> Vec<(Model, Model, usize)> {
        [
            (
                r#"{"kind": "disc", "name": "g", "center": [0, 0, 0], "radius": 1, "rings": 24}"#,
                0,
            ),
            (
                r#"{"kind": "cushion", "name": "g", "center": [0, 0, 0], "outline": {"shape": "rectangle", "size": [2, 1]}, "rings": 12}"#,
                1,
            ),
        ]
        .into_iter()
        .map(|(generator, case)| {
            let fine = scene(
                generator,
                r#"[{"name": "m", "triangles": "g", "thickness": 1e-3, "material": {"kind": "svk", "E": 1e9, "nu": 0.3}}]"#,
            );
            let coarse = coarser(&fine).expect("halved");
            (Model::build(&coarse), Model::build(&fine), case)
        })
        .collect()
    }

    /// On two threads (the grids on the helper, the fine nodes in chunks the two take in
    /// turn) the transfer gives one thread's answer bit for bit, on a disc and on a flat
    /// cushion's two sheets.
    #[test]
    fn two_threads_carry_over_one_threads_answer() {
        let pool = std::sync::Arc::new(crate::solver::threads::Pool::try_new(2).unwrap());
        for (cm, fm, _) in disc_and_cushion() {
            let u: Vec<f64> = (0..3 * cm.reference.len())
                .map(|i| (i as f64 * 0.37).sin())
                .collect();
            let one = transfer(cm.clone(), u.clone(), &fm, None).expect("on the coarse mesh");
            let two = transfer(cm, u, &fm, Some(&pool)).expect("on the coarse mesh");
            assert_eq!(one.len(), fm.unknown_count());
            assert!(one
                .iter()
                .map(|v| v.to_bits())
                .eq(two.iter().map(|v| v.to_bits())));
        }
    }

    /// The own cell's answer (`Grid::nearest_in_own_cell`) is the search's wherever it gives
    /// one, the same triangle and the same weights, on a disc (fine nodes on the coarse
    /// mesh, many on its edges and corners: ties) and on a flat cushion's two sheets (sided),
    /// and it decides most nodes.
    #[test]
    fn the_own_cell_gives_the_searchs_answer() {
        for (cm, fm, case) in disc_and_cushion() {
            let grid = Grid::new(&cm, cm.membrane_groups[0].clone());
            let (mut decided, mut found) = (0, 0);
            for (i, x) in fm.reference.iter().enumerate() {
                let p = [x[0], x[1], x[2]];
                // Both sides of the cushion, and no side.
                for normal in [[0.0, 0.0, 1.0], [0.0, 0.0, -1.0], [0.0; 3]] {
                    let size = normal.iter().map(|v: &f64| v * v).sum::<f64>().sqrt();
                    let sided = size > 1e-9 * grid.cell * grid.cell;
                    let c = grid.key(p);
                    let searched = grid.search(&cm, p, normal, sided, c);
                    found += searched.is_some() as usize;
                    if let Some(own) = grid.nearest_in_own_cell(&cm, p, normal, sided, c) {
                        decided += 1;
                        assert_eq!(
                            Some(own),
                            searched,
                            "node {i}, normal {normal:?}, case {case}"
                        );
                    }
                }
            }
            assert!(
                10 * decided > 9 * found,
                "{decided} of {found}, case {case}"
            );
        }
    }

    /// The nearest point of a triangle from inside, beside an edge and beyond a corner, by hand.
    #[test]
    fn closest_point_on_a_triangle() {
        let (a, b, c) = ([0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 2.0, 0.0]);
        let (d, w) = closest_point([0.5, 0.5, 1.0], a, b, c);
        assert!((d - 1.0).abs() < 1e-15);
        assert!((w[0] - 0.5).abs() < 1e-15 && (w[1] - 0.25).abs() < 1e-15);
        let (d, w) = closest_point([1.0, -1.0, 0.0], a, b, c);
        assert!(
            (d - 1.0).abs() < 1e-15 && (w[0] - 0.5).abs() < 1e-15 && (w[1] - 0.5).abs() < 1e-15
        );
        let (d, w) = closest_point([3.0, -1.0, 0.0], a, b, c);
        assert!((d - 2.0).abs() < 1e-15 && w == [0.0, 1.0, 0.0]);
        let (d, w) = closest_point([2.0, 2.0, 0.0], a, b, c);
        assert!(
            (d - 2.0).abs() < 1e-15 && (w[1] - 0.5).abs() < 1e-15 && (w[2] - 0.5).abs() < 1e-15
        );
    }
}
