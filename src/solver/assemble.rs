//! Assembly: the sparsity pattern and the element-to-CSC position map are built once per model;
//! every Newton iteration zeroes the values and scatters element blocks in place.
//!
//! ```text
//! eq[dof]        equation number of a free DOF (held DOFs: NONE)
//! K              upper triangle (row <= col) of the free-free tangent, CSC
//! map            per element, per local (i, j): position in K's values, or NONE
//! R = f_int − f_ext   on every DOF; at held DOFs R is the reaction (what the support supplies)
//! ```

use crate::memory::{self, OutOfMemory};
use crate::model::membrane::Evaluation;
use crate::model::wrinkling::{WrinkleState, REGULARIZATION};
use crate::model::{cable, membrane, pressure, sleeve, ElementKind, LoadModel, Model, PerKind};
use crate::solver::renumber::{self, NodeOrder};
use crate::solver::threads::{Pending, Pool, ASSEMBLE};
use nalgebra::{SMatrix, SVector, Vector3};
use std::ops::Range;
use std::sync::{Arc, Mutex, MutexGuard, RwLock};

pub const NONE: usize = usize::MAX;

/// A position map's entry with no place in K (a held DOF or the lower triangle).
pub const UNMAPPED: u32 = u32::MAX;

/// The most stored entries K may have: the position maps hold K's positions as `u32` (4
/// bytes an entry instead of 8: 81 per triangle, about 217 MB less at 1M DOF), with
/// [`UNMAPPED`] kept free. The default size limits (`scene/limits.rs`: 4 million unknowns,
/// about 130 million entries) stay far below; a scene whose raised limits let K grow past it
/// is refused by its validation, and a model given here directly by [`check_addressable`].
pub const MAX_ENTRIES: u64 = u32::MAX as u64;

/// Whether K with `entries` stored entries fits the position maps ([`MAX_ENTRIES`]); the
/// error names the limit (an [`OutOfMemory`] whose size is [`memory::UNADDRESSABLE`]: too
/// large to index, not a failed allocation).
pub fn check_addressable(entries: u64) -> Result<(), OutOfMemory> {
    if entries > MAX_ENTRIES {
        return Err(OutOfMemory {
            what: "the tangent's position maps: K has more stored entries than the 4294967295 a 32-bit position addresses; coarsen the mesh",
            bytes: memory::UNADDRESSABLE,
        });
    }
    Ok(())
}

/// Pattern and position maps of one model.
pub struct Pattern {
    pub eq: Vec<usize>,
    pub n: usize,
    /// K's upper CSC pattern: column starts (`col_ptr[n]` entries in all) and row indices.
    pub col_ptr: Vec<usize>,
    /// Empty in a solver's pattern: `Solver::try_new` hands them to the factorization.
    pub row_idx: Vec<usize>,
    /// Per element kind, per element in its visit order (`order`), the position in K's values
    /// of each entry of its tangent block (row-major, `ElementKind::block_len` entries: 81 for
    /// a triangle, 36 for a segment or tie; UNMAPPED: held or lower triangle), flat.
    maps: PerKind<Vec<u32>>,
    /// Per element kind, the order in which an assembly visits its elements
    /// ([`visit_order`]): the triangles by their lowest internal node (`renumber.rs`), so the
    /// scatter into K walks the mesh (the user's order under `NodeOrder::Given`); segments and
    /// ties in model order.
    order: PerKind<Vec<usize>>,
    /// Position of every triangle in its visit order (its slot in the maps).
    tri_slot: Vec<usize>,
    /// The model's triangles in visit order with their nodes' internal positions (empty under
    /// `NodeOrder::Given`): one assembly reads them, and the positions, front to back.
    triangles: Vec<crate::model::Triangle>,
    /// The user's node at every internal position (empty under `NodeOrder::Given`).
    node_of: Vec<usize>,
    /// Every node's internal position, the inverse of `node_of` (empty under
    /// `NodeOrder::Given`): relaxation's sweep order breaks ties of coincident nodes by it.
    rank: Vec<u32>,
    /// Per load, its pressed triangles in visit order (empty for other loads): the pressure
    /// loop streams through the triangles' maps too.
    pressed_order: Vec<Vec<usize>>,
    /// `pressed_order` as slots (positions in the triangles' visit order, ascending): the
    /// pressure loop reads its triangles' data and maps front to back without a lookup by the
    /// user's triangle number (which in a shuffled numbering lands anywhere).
    pressed_slots: Vec<Vec<usize>>,
    /// The factorization's fill-reducing order when it is not faer's AMD (`dissect.rs`):
    /// `Solver::try_new` hands it to the factorization.
    pub fill: Option<super::dissect::Fill>,
}

/// What one assembly found besides R and K.
#[derive(Clone, Copy, Debug, Default)]
pub struct AssemblyInfo {
    /// Stored energy minus the work of dead loads (the potential; follower pressure excluded).
    pub potential: f64,
    /// The stored (strain) energy alone: the elements' energies, no load's work.
    pub stored: f64,
    /// |f_ext|∞ over all DOFs.
    pub external: f64,
    /// Smallest signed current/reference area ratio of a membrane triangle (inversion check:
    /// negative for a triangle turned over against its reference normal).
    pub min_area_ratio: f64,
    /// The same over the triangles that are taut, and over the others only where they have
    /// turned over past `FOLD_LIMIT`: the inversion guard of an iterate (a wrinkled or slack
    /// triangle has no stiffness across its tension and may fold while Newton moves the
    /// sheet; a converged point has no fold, system.rs).
    pub min_guard_ratio: f64,
    /// Largest nodal force component any single element carries (N): the internal-force part
    /// of the heuristics' force scale.
    pub carried: f64,
}

impl Pattern {
    /// Sorts `nodes` into nodal relaxation's sweep order (`newton.rs`, `relax.rs`): by their
    /// reference coordinates, in rows of increasing y, each of increasing x, then z; coincident
    /// nodes (the two sheets of a cushion laid flat) by internal position. A block
    /// Gauss-Seidel sweep's result depends on its order, and this one is a property of the
    /// mesh, not of its numbering: a shuffled numbering of a mesh relaxes it the same way and
    /// takes the same Newton path. Rows of y then x are the rectangle generator's own
    /// numbering, in which the shipped sheets and the hard cases were measured; other orders
    /// were tried on hard case i (the 0.1 mm sheared film) and lost: the internal ring order
    /// took 77 iterations and 3 increments at its 7th step, largest residual first up to
    /// 2459 (docs/solver.md, nodal relaxation). Sorts in place (no allocation).
    pub fn sweep_order(&self, model: &Model, nodes: &mut [usize]) {
        let r = &model.reference;
        let rank = |i: usize| self.rank.get(i).map_or(i, |&k| k as usize);
        nodes.sort_unstable_by(|&a, &b| {
            (r[a].y.total_cmp(&r[b].y))
                .then(r[a].x.total_cmp(&r[b].x))
                .then(r[a].z.total_cmp(&r[b].z))
                .then(rank(a).cmp(&rank(b)))
        });
    }

    /// Pattern and position maps of `model` in the default internal node order
    /// (`NodeOrder::Rings`).
    pub fn try_new(model: &Model) -> Result<Pattern, OutOfMemory> {
        Pattern::try_ordered(model, NodeOrder::default())
    }

    /// Pattern and position maps of `model` with equations numbered node by node in `order`
    /// (`renumber.rs`), every buffer that grows with it allocated fallibly (`crate::memory`).
    pub fn try_ordered(model: &Model, order: NodeOrder) -> Result<Pattern, OutOfMemory> {
        Pattern::try_ordered_on(model, order, None)
    }

    /// [`Pattern::try_ordered`], with the nested dissection (large tangents) on `pool`'s
    /// helper while this thread builds K's pattern and the position maps; the helper must be
    /// idle. The same pattern and order as without the pool.
    pub fn try_ordered_on(
        model: &Model,
        order: NodeOrder,
        pool: Option<&std::sync::Arc<super::threads::Pool>>,
    ) -> Result<Pattern, OutOfMemory> {
        Pattern::try_ordered_then::<()>(model, order, pool, None, None).map(|(pattern, _)| pattern)
    }

    /// [`Pattern::try_ordered_on`] that, with a helper, also runs `then` there once the
    /// renumbering's keys and normals are done (while this thread numbers the nodes; the
    /// ordering waits for it): its [`Pending`] result, None without a helper (the caller then
    /// does that work itself). With a helper and a Cuthill-McKee order, the renumbering's
    /// keys, seeds and normals are computed there while this thread builds the node graph
    /// (`renumber::Prepared`, the same numbers).
    pub(super) fn try_ordered_then<T: Send + 'static>(
        model: &Model,
        order: NodeOrder,
        pool: Option<&std::sync::Arc<super::threads::Pool>>,
        then: Option<Box<dyn FnOnce() -> T + Send>>,
        maps: Option<Vec<u32>>,
    ) -> Result<(Pattern, Option<Pending<T>>), OutOfMemory> {
        use crate::phases::start;
        let _phase = start("pattern (Pattern::try_ordered)");
        let helper = pool.filter(|p| p.helpers() > 0);
        let depth = crate::phases::depth();
        let prepared = match (helper, order) {
            (Some(pool), NodeOrder::Rings | NodeOrder::Rcm) => {
                let input = renumber::PrepareInput::copy(model)?;
                Some(Pool::launch(pool, 0, move || {
                    let _phase =
                        crate::phases::start_under("renumbering's keys (on the helper)", depth);
                    input.prepare()
                }))
            }
            _ => None,
        };
        // The node graph, read by the renumbering, the dissection and K's pattern.
        let phase = start("node graph");
        let graph = renumber::node_graph(model)?;
        drop(phase);
        let phase = start("renumbering (node_rank)");
        let prepared = match prepared.map(Pending::join) {
            Some(Ok(prepared)) => Some(prepared?),
            // None, or the helper failed: here.
            _ => None,
        };
        let then = match (helper, then) {
            (Some(pool), Some(job)) => Some(Pool::launch(pool, 0, job)),
            _ => None,
        };
        let rank = renumber::node_rank_prepared(model, order, &graph, prepared)?;
        drop(phase);
        let phase = start("equation numbers");
        let (eq, n, by_rank) = number_equations(model, &rank)?;
        drop(phase);
        // Large tangents: nested dissection, where it fills no more than faer's AMD and its
        // top separator is the two-thread split (`dissect.rs`, docs/performance.md); with a
        // helper (two threads, from `linear::SPLIT_MIN_EQUATIONS`) at any size, since its top
        // separator gives the split without the whole tangent's symbolic analysis and the
        // breadth-first search for one, both serial (`dissect::MIN_EQUATIONS`). It needs
        // only the node graph, positions and equation counts in internal order: on a helper,
        // it runs while this thread builds the rest.
        let helper = pool.is_some_and(|p| p.helpers() > 0);
        let dissection = match n >= super::dissect::MIN_EQUATIONS || helper {
            true => Some(Dissection::start(
                dissection_input(model, &eq, n, &by_rank, &rank, &graph)?,
                pool.filter(|p| p.helpers() > 0),
            )),
            false => None,
        };
        let phase = start("visit order");
        let visits = PerKind::try_from_fn(|kind| visit_order(model, kind, order, &rank))?;
        drop(phase);
        let phase = start("triangle slots and copy");
        let tri_order = &visits[ElementKind::Membrane];
        let mut tri_slot = memory::zeros::<usize>(tri_order.len(), "the element order")?;
        for (k, &e) in tri_order.iter().enumerate() {
            tri_slot[e] = k;
        }
        let mut triangles = Vec::new();
        if order != NodeOrder::Given {
            triangles = memory::with_capacity(tri_order.len(), "the element order")?;
            triangles.extend(tri_order.iter().map(|&e| {
                let mut t = model.triangles[e].clone();
                t.nodes = t.nodes.map(|i| rank[i]);
                t
            }));
        }
        let (node_of, rank) = if order == NodeOrder::Given {
            (Vec::new(), Vec::new())
        } else {
            // Below u32::MAX: the size limits keep the unknowns far below it.
            let rank = memory::collect(rank.iter().map(|&r| r as u32), "the equation numbers")?;
            (by_rank, rank)
        };
        drop(phase);
        let phase = start("pressed lists");
        let (pressed_order, pressed_slots) = pressed_lists(model, tri_order, &tri_slot)?;
        drop(phase);
        let phase = start("node blocks (Blocks::try_new)");
        let blocks = Blocks::try_new(&eq, &by_rank_or_identity(&node_of, model), &graph)?;
        drop(graph);
        drop(phase);
        let phase = start("K's pattern (upper_pattern)");
        let (col_ptr, row_idx) = blocks.upper_pattern(n)?;
        drop(phase);
        let phase = start("position maps");
        let maps = position_maps(model, &eq, &col_ptr, &blocks, &visits, maps)?;
        drop(blocks);
        drop(phase);
        let fill = dissection.map(Dissection::finish).transpose()?;
        Ok((
            Pattern {
                eq,
                n,
                col_ptr,
                row_idx,
                maps,
                order: visits,
                tri_slot,
                triangles,
                node_of,
                rank,
                pressed_order,
                pressed_slots,
                fill,
            },
            then,
        ))
    }

    /// The order in which an assembly visits the triangles (slot → triangle).
    fn tri_order(&self) -> &[usize] {
        &self.order[ElementKind::Membrane]
    }

    /// Every element of `kind` with its position map (`ElementKind::block_len` entries, row
    /// major over the element's local DOFs; [`UNMAPPED`]: held or lower triangle), in visit
    /// order: what an assembly of another matrix on the tangent's pattern (the mass,
    /// `mass.rs`) scatters through.
    pub fn element_maps(&self, kind: ElementKind) -> impl Iterator<Item = (usize, &[u32])> {
        self.order[kind]
            .iter()
            .enumerate()
            .map(move |(slot, &e)| (e, self.map(kind, slot)))
    }

    /// The position map of the element at `slot` of `kind`'s visit order.
    fn map(&self, kind: ElementKind, slot: usize) -> &[u32] {
        let len = kind.block_len();
        &self.maps[kind][slot * len..(slot + 1) * len]
    }
}

/// What the nested dissection reads (`dissect::fill`), owned, in internal numbering: node
/// positions, the node graph (CSR), each node's first equation (node r's are
/// first[r]..first[r + 1]) and the number of equations.
struct DissectionInput {
    x: Vec<[f64; 3]>,
    ptr: Vec<usize>,
    adj: Vec<usize>,
    first: Vec<usize>,
    n: usize,
}

impl DissectionInput {
    fn fill(self) -> Result<super::dissect::Fill, OutOfMemory> {
        let _phase = crate::phases::start("dissect::fill");
        let first = &self.first;
        super::dissect::fill(
            &self.x,
            &self.ptr,
            &self.adj,
            |r| first[r]..first[r + 1],
            self.n,
        )
    }
}

type Filled = Result<super::dissect::Fill, OutOfMemory>;

/// The nested dissection, running on a helper or not yet run.
enum Dissection {
    Here(DissectionInput),
    Helper(
        std::sync::Arc<super::threads::Pool>,
        std::sync::Arc<std::sync::Mutex<Option<Filled>>>,
    ),
}

impl Dissection {
    /// Started on `pool`'s first helper (slot `threads::FACTOR`, free until the
    /// factorization installs its job) when there is one.
    fn start(input: DissectionInput, pool: Option<&std::sync::Arc<super::threads::Pool>>) -> Self {
        use std::sync::{Arc, Mutex};
        let Some(pool) = pool else {
            return Dissection::Here(input);
        };
        // The helper may still run the job given to `Pattern::try_ordered_then` (the
        // relaxation's adjacency, `Solver::try_new`): the ordering starts after it (a failure
        // of that job is its join's to report).
        let _ = pool.wait(0);
        let input = Mutex::new(Some(input));
        let output: Arc<Mutex<Option<Filled>>> = Arc::new(Mutex::new(None));
        let job_output = Arc::clone(&output);
        let depth = crate::phases::depth();
        pool.set_job(
            0,
            Box::new(move || {
                let taken = input.lock().unwrap_or_else(|e| e.into_inner()).take();
                if let Some(input) = taken {
                    let _phase = crate::phases::start_under("ordering (on the helper)", depth);
                    let filled = input.fill();
                    *job_output.lock().unwrap_or_else(|e| e.into_inner()) = Some(filled);
                }
            }),
        );
        pool.start(0);
        Dissection::Helper(Arc::clone(pool), output)
    }

    /// The order (waiting for the helper). A helper that failed is an error of the ordering's
    /// memory: it holds nothing else that could fail.
    fn finish(self) -> Filled {
        let _phase = crate::phases::start("ordering (nested dissection), or its wait");
        match self {
            Dissection::Here(input) => input.fill(),
            Dissection::Helper(pool, output) => {
                let waited = pool.wait(0);
                let filled = output.lock().unwrap_or_else(|e| e.into_inner()).take();
                match (waited, filled) {
                    (Ok(()), Some(filled)) => filled,
                    _ => Err(OutOfMemory {
                        what: "the nested-dissection ordering (its thread failed)",
                        bytes: 0,
                    }),
                }
            }
        }
    }
}

/// The input of the nested-dissection order of the equations (`dissect.rs`): the node graph
/// in internal numbering (`by_rank`: the node at every internal position, `rank` its
/// inverse).
fn dissection_input(
    model: &Model,
    eq: &[usize],
    n: usize,
    by_rank: &[usize],
    rank: &[usize],
    (uptr, uadj): &(Vec<usize>, Vec<usize>),
) -> Result<DissectionInput, OutOfMemory> {
    const WHAT: &str = "the nested-dissection ordering";
    let nodes = model.reference.len();
    let user = |r: usize| by_rank[r];
    let internal = |v: usize| rank[v];
    let _phase = crate::phases::start("node graph in internal order");
    let mut ptr = memory::with_capacity(nodes + 1, WHAT)?;
    let mut adj = memory::with_capacity(uadj.len(), WHAT)?;
    ptr.push(0);
    for r in 0..nodes {
        let v = user(r);
        adj.extend(uadj[uptr[v]..uptr[v + 1]].iter().map(|&w| internal(w)));
        ptr.push(adj.len());
    }
    let x = memory::collect(
        (0..nodes).map(|r| {
            let p = model.reference[user(r)];
            [p.x, p.y, p.z]
        }),
        WHAT,
    )?;
    // Equations are numbered node by node in internal order: node r's are first[r]..first[r+1].
    let mut first = memory::with_capacity(nodes + 1, WHAT)?;
    first.push(0usize);
    for r in 0..nodes {
        let v = user(r);
        let free = (0..3).filter(|&c| eq[3 * v + c] != NONE).count();
        first.push(first[r] + free);
    }
    Ok(DissectionInput {
        x,
        ptr,
        adj,
        first,
        n,
    })
}

/// Equation numbers handed out node by node in internal order (`rank[node]`), held DOFs
/// NONE: (eq per DOF, the number of equations, the node at every internal position).
fn number_equations(
    model: &Model,
    rank: &[usize],
) -> Result<(Vec<usize>, usize, Vec<usize>), OutOfMemory> {
    let mut by_rank = memory::zeros::<usize>(rank.len(), "the equation numbers")?;
    for (node, &r) in rank.iter().enumerate() {
        by_rank[r] = node;
    }
    let mut eq = memory::filled(model.dof_count(), NONE, "the equation numbers")?;
    let mut n = 0;
    for &node in &by_rank {
        let dofs = 3 * node..3 * node + 3;
        for (e, &held) in eq[dofs.clone()].iter_mut().zip(&model.held[dofs]) {
            if !held {
                *e = n;
                n += 1;
            }
        }
    }
    Ok((eq, n, by_rank))
}

/// The order in which an assembly visits the elements of `kind` (the order of its position
/// maps and of its sums into R and K), under the internal node ranks `rank`.
fn visit_order(
    model: &Model,
    kind: ElementKind,
    order: NodeOrder,
    rank: &[usize],
) -> Result<Vec<usize>, OutOfMemory> {
    let mut list = memory::collect(0..model.element_count(kind), "the element order")?;
    match kind {
        // By the lowest internal node, then the highest and the middle one: a property of
        // the mesh, not of its numbering, so a shuffled numbering of the same mesh visits
        // its triangles in the same order and forms every sum in the same order (the same
        // Newton path on a sensitive problem, tests/solver/renumber.rs). Which of the orders
        // with the lowest node first is not otherwise important; this one because
        // tests/fmi/derivatives.rs's difference check on AnnulusTorsion (wrinkled) moves with
        // the order of sums: 3.9e-6 here, 4.1e-6 ties by triangle number, 7.4e-6 and
        // 1.0e-5 (its limit) in two other orders. In place (a stable sort would allocate
        // its buffer infallibly); the triangle number breaks the remaining ties (two
        // triangles on the same three nodes).
        ElementKind::Membrane => {
            if order != NodeOrder::Given {
                let ranks = |e: usize| {
                    let mut r = model.triangles[e].nodes.map(|i| rank[i]);
                    r.sort_unstable();
                    [r[0], r[2], r[1]]
                };
                // The keys computed once, not twice per comparison (each a look-up of the
                // triangle and its three ranks): the same order, every key being distinct.
                let mut keyed =
                    memory::collect(list.iter().map(|&e| (ranks(e), e)), "the element order")?;
                keyed.sort_unstable();
                for (slot, &(_, e)) in list.iter_mut().zip(&keyed) {
                    *slot = e;
                }
            }
        }
        // Model order (cable by cable along each cable; sleeve point by sleeve point): the
        // order of every measurement with them so far; they are few next to the triangles.
        ElementKind::Cable
        | ElementKind::Tie
        | ElementKind::ContactPair
        | ElementKind::ContactPoint => {}
    }
    Ok(list)
}

/// One list per load.
type PerLoad = Vec<Vec<usize>>;

/// Per load, its pressed triangles in visit order (empty for other loads), and the same as
/// slots (positions in the triangles' visit order).
fn pressed_lists(
    model: &Model,
    tri_order: &[usize],
    tri_slot: &[usize],
) -> Result<(PerLoad, PerLoad), OutOfMemory> {
    const WHAT: &str = "the element order";
    let mut pressed_order = memory::with_capacity(model.loads.len(), WHAT)?;
    // How often each triangle is in the load's list (a list may name one twice).
    let mut times: Vec<u32> = Vec::new();
    for load in &model.loads {
        let list = match load {
            LoadModel::Pressure { triangles, .. }
            | LoadModel::Volume { triangles, .. }
            | LoadModel::Surface { triangles, .. }
            | LoadModel::Water { triangles, .. } => triangles,
            _ => {
                pressed_order.push(Vec::new());
                continue;
            }
        };
        // The list in visit order. A short list (below a sixteenth of the triangles) sorted
        // by slot; a long one by a pass over the visit order (slot by slot) taking each listed
        // triangle as often as it is listed: the same order, without the sort's look-ups.
        if list.len().saturating_mul(16) < tri_order.len() {
            let mut sorted = memory::copy(list, WHAT)?;
            sorted.sort_unstable_by_key(|&e| tri_slot[e]);
            pressed_order.push(sorted);
            continue;
        }
        if times.is_empty() {
            times = memory::zeros(tri_order.len(), WHAT)?;
        }
        for &e in list {
            times[e] += 1;
        }
        let mut sorted = memory::with_capacity(list.len(), WHAT)?;
        for &e in tri_order {
            for _ in 0..times[e] {
                sorted.push(e);
            }
            times[e] = 0;
        }
        pressed_order.push(sorted);
    }
    let mut pressed_slots = memory::with_capacity(model.loads.len(), "the element order")?;
    for list in &pressed_order {
        let mut slots = memory::with_capacity(list.len(), "the element order")?;
        slots.extend(list.iter().map(|&e| tri_slot[e]));
        pressed_slots.push(slots);
    }
    Ok((pressed_order, pressed_slots))
}

/// The equations of an element on `nodes` (3 per node, NONE where held) into `out`; returns
/// how many.
fn element_equations(eq: &[usize], nodes: &[usize], out: &mut [usize]) -> usize {
    for (a, &i) in nodes.iter().enumerate() {
        for c in 0..3 {
            out[3 * a + c] = eq[3 * i + c];
        }
    }
    3 * nodes.len()
}

/// Calls `f` with the equations of every element of the model (NONE where held), kind by kind.
#[cfg(test)]
fn for_each_element(model: &Model, eq: &[usize], f: &mut dyn FnMut(&[usize])) {
    let mut d = [NONE; 3 * ElementKind::MAX_NODES];
    for (kind, e) in model.elements() {
        let m = element_equations(eq, model.element_nodes(kind, e), &mut d);
        f(&d[..m]);
    }
}

/// K's upper CSC pattern (rows <= col) over the `n` equations `eq`: every pair of equations an
/// element couples, and a diagonal entry for every equation. Column lists, flat: count, place,
/// then sort and dedup each column. The pattern by elements, kept as the unit tests' reference
/// for [`Blocks::upper_pattern`].
#[cfg(test)]
fn upper_pattern(
    model: &Model,
    eq: &[usize],
    n: usize,
) -> Result<(Vec<usize>, Vec<usize>), OutOfMemory> {
    let mut start = memory::zeros::<usize>(n + 1, "the tangent's pattern")?;
    for j in 0..n {
        start[j + 1] = 1; // a diagonal entry for every equation, even one no element touches
    }
    for_each_element(model, eq, &mut |dofs| {
        for &i in dofs.iter().filter(|&&i| i != NONE) {
            for &j in dofs.iter().filter(|&&j| j != NONE && i <= j) {
                start[j + 1] += 1;
            }
        }
    });
    for j in 0..n {
        start[j + 1] += start[j];
    }
    let mut rows = memory::zeros::<usize>(start[n], "the tangent's pattern")?;
    let mut next = memory::copy(&start[..n], "the tangent's pattern")?;
    for (j, slot) in next.iter_mut().enumerate() {
        rows[*slot] = j;
        *slot += 1;
    }
    for_each_element(model, eq, &mut |dofs| {
        for &i in dofs.iter().filter(|&&i| i != NONE) {
            for &j in dofs.iter().filter(|&&j| j != NONE && i <= j) {
                rows[next[j]] = i;
                next[j] += 1;
            }
        }
    });
    drop(next);
    let mut col_ptr = memory::with_capacity(n + 1, "the tangent's pattern")?;
    col_ptr.push(0);
    let mut kept = 0;
    for j in 0..n {
        let col = &mut rows[start[j]..start[j + 1]];
        col.sort_unstable();
        let mut last = NONE;
        for k in start[j]..start[j + 1] {
            let r = rows[k];
            if r != last {
                rows[kept] = r;
                kept += 1;
                last = r;
            }
        }
        col_ptr.push(kept);
    }
    drop(start);
    let mut row_idx = memory::copy(&rows[..kept], "the tangent's pattern")?;
    drop(rows);
    row_idx.shrink_to_fit();
    check_addressable(kept as u64)?;
    Ok((col_ptr, row_idx))
}

/// The user's node at every internal position (`node_of`, or the identity under
/// `NodeOrder::Given`, where `node_of` is empty).
fn by_rank_or_identity(node_of: &[usize], model: &Model) -> Vec<usize> {
    match node_of.is_empty() {
        true => (0..model.reference.len()).collect(),
        false => node_of.to_vec(),
    }
}

/// K's upper pattern by nodes: equations are numbered node by node in internal order
/// (`number_equations`), so column j of K (equation j of internal node r) holds, in
/// ascending order, every equation of each node joined to r by an element that comes before r
/// (the nodes' lists sorted), then r's own equations up to j. Built from the node graph
/// once: no pass over the elements' 81 entry pairs and no sort per column, and an element
/// entry's position is found in its column node's short list instead of by a binary search
/// over the column's rows.
struct Blocks {
    /// Per internal node r, its range in `node` and `offset`.
    ptr: Vec<usize>,
    /// The nodes (internal positions) before r joined to r, ascending, then r itself.
    node: Vec<u32>,
    /// The rows in r's columns before that node's equations.
    offset: Vec<u32>,
    /// The internal node of every equation.
    node_of_eq: Vec<u32>,
    /// The first equation of every internal node (and the count at the end).
    first: Vec<usize>,
}

impl Blocks {
    fn try_new(
        eq: &[usize],
        by_rank: &[usize],
        (gptr, gadj): &(Vec<usize>, Vec<usize>),
    ) -> Result<Blocks, OutOfMemory> {
        const WHAT: &str = "the tangent's pattern";
        let nodes = by_rank.len();
        let mut rank = memory::zeros::<u32>(nodes, WHAT)?;
        for (r, &v) in by_rank.iter().enumerate() {
            rank[v] = r as u32;
        }
        let free = |v: usize| (0..3).filter(|&c| eq[3 * v + c] != NONE).count();
        let mut first = memory::with_capacity(nodes + 1, WHAT)?;
        first.push(0usize);
        for (r, &v) in by_rank.iter().enumerate() {
            first.push(first[r] + free(v));
        }
        let mut node_of_eq = memory::zeros::<u32>(first[nodes], WHAT)?;
        for r in 0..nodes {
            node_of_eq[first[r]..first[r + 1]].fill(r as u32);
        }
        let mut ptr = memory::with_capacity(nodes + 1, WHAT)?;
        let mut node = memory::with_capacity(gadj.len() / 2 + nodes, WHAT)?;
        let mut offset = memory::with_capacity(gadj.len() / 2 + nodes, WHAT)?;
        ptr.push(0usize);
        for (r, &v) in by_rank.iter().enumerate() {
            let start = node.len();
            if free(v) > 0 {
                node.extend(
                    gadj[gptr[v]..gptr[v + 1]]
                        .iter()
                        .filter(|&&w| (rank[w] as usize) < r && free(w) > 0)
                        .map(|&w| rank[w]),
                );
                node[start..].sort_unstable();
                node.push(r as u32);
                let mut rows = 0u32;
                for &s in &node[start..] {
                    offset.push(rows);
                    let s = s as usize;
                    rows += (first[s + 1] - first[s]) as u32;
                }
            }
            ptr.push(node.len());
        }
        Ok(Blocks {
            ptr,
            node,
            offset,
            node_of_eq,
            first,
        })
    }

    /// K's upper CSC pattern over the `n` equations.
    fn upper_pattern(&self, n: usize) -> Result<(Vec<usize>, Vec<usize>), OutOfMemory> {
        const WHAT: &str = "the tangent's pattern";
        let nodes = self.ptr.len() - 1;
        let mut entries = 0u64;
        for r in 0..nodes {
            let (a, b) = (self.ptr[r], self.ptr[r + 1]);
            if a == b {
                continue;
            }
            let own = (self.first[r + 1] - self.first[r]) as u64;
            let before = self.offset[b - 1] as u64;
            entries += own * before + own * (own + 1) / 2;
        }
        check_addressable(entries)?;
        let mut col_ptr = memory::with_capacity(n + 1, WHAT)?;
        let mut row_idx = memory::with_capacity(entries as usize, WHAT)?;
        col_ptr.push(0);
        for r in 0..nodes {
            let (a, b) = (self.ptr[r], self.ptr[r + 1]);
            for j in self.first[r]..self.first[r + 1] {
                for &s in &self.node[a..b.saturating_sub(1)] {
                    let s = s as usize;
                    row_idx.extend(self.first[s]..self.first[s + 1]);
                }
                row_idx.extend(self.first[r]..=j);
                col_ptr.push(row_idx.len());
            }
        }
        debug_assert_eq!(col_ptr.len(), n + 1);
        Ok((col_ptr, row_idx))
    }
}

/// Per element kind, the position maps of its elements in visit order `visits`.
///
/// Node pair by node pair: equations are numbered node by node (`number_equations`), so the
/// rows of node na's equations in every column of node nb (na before nb, or na = nb) start at
/// one offset, found once per pair in nb's short list of joined nodes; each entry's position
/// is then `col_ptr[j] + offset + (i - first equation of na)`. Pairs with na after nb lie in
/// the lower triangle. An element's map is built in a stack array and appended whole (no
/// per-entry push).
fn position_maps(
    model: &Model,
    eq: &[usize],
    col_ptr: &[usize],
    blocks: &Blocks,
    visits: &PerKind<Vec<usize>>,
    touched: Option<Vec<u32>>,
) -> Result<PerKind<Vec<u32>>, OutOfMemory> {
    // Every position is below the stored entries <= MAX_ENTRIES (`upper_pattern`), so below
    // UNMAPPED. The block term alone may be negative: sums are taken mod 2^64.
    const MAX_DOFS: usize = 3 * ElementKind::MAX_NODES;
    let mut touched = touched;
    PerKind::try_from_fn(|kind| {
        let len = visits[kind].len().saturating_mul(kind.block_len());
        // The triangles' maps into the buffer touched on the helper where it is the size
        // (`Started`): the same entries, written into pages already there.
        let membrane = match kind {
            ElementKind::Membrane => true,
            ElementKind::Cable
            | ElementKind::Tie
            | ElementKind::ContactPair
            | ElementKind::ContactPoint => false,
        };
        let mut maps = if membrane && touched.as_ref().is_some_and(|b| b.capacity() == len) {
            touched.take().unwrap_or_default()
        } else {
            memory::with_capacity(len, "the element position maps")?
        };
        maps.clear();
        let mut d = [NONE; MAX_DOFS];
        let mut out = [UNMAPPED; MAX_DOFS * MAX_DOFS];
        // Per element node: its internal node (u32::MAX: every DOF held).
        let mut node = [u32::MAX; ElementKind::MAX_NODES];
        for &e in &visits[kind] {
            let m = element_equations(eq, model.element_nodes(kind, e), &mut d);
            let k = m / 3;
            for (a, r) in node.iter_mut().enumerate().take(k) {
                *r = d[3 * a..3 * a + 3]
                    .iter()
                    .find(|&&i| i != NONE)
                    .map_or(u32::MAX, |&i| blocks.node_of_eq[i]);
            }
            out[..m * m].fill(UNMAPPED);
            for b in 0..k {
                let rb = node[b];
                if rb == u32::MAX {
                    continue;
                }
                let list = blocks.ptr[rb as usize]..blocks.ptr[rb as usize + 1];
                for a in 0..k {
                    let ra = node[a];
                    if ra == u32::MAX || ra > rb {
                        continue;
                    }
                    let at = blocks.node[list.clone()]
                        .iter()
                        .position(|&s| s == ra)
                        .expect("pattern holds every element pair");
                    let base = (blocks.offset[list.start + at] as usize)
                        .wrapping_sub(blocks.first[ra as usize]);
                    for cb in 0..3 {
                        let j = d[3 * b + cb];
                        if j == NONE {
                            continue;
                        }
                        let column = col_ptr[j].wrapping_add(base);
                        for ca in 0..3 {
                            let i = d[3 * a + ca];
                            if i != NONE && i <= j {
                                out[(3 * a + ca) * m + 3 * b + cb] = column.wrapping_add(i) as u32;
                            }
                        }
                    }
                }
            }
            maps.extend_from_slice(&out[..m * m]);
        }
        Ok(maps)
    })
}

/// Placeholder of a triangle's evaluation until the assembly writes it.
const UNEVALUATED: Evaluation = Evaluation {
    energy: 0.0,
    state: WrinkleState::Taut,
    angle: 0.0,
    stress: Vector3::new(0.0, 0.0, 0.0),
    cauchy: (0.0, 0.0),
    area_ratio: 1.0,
};

fn scatter<const N: usize>(k: &SMatrix<f64, N, N>, map: &[u32], values: &mut [f64]) {
    scatter_at(k, map, values, 0);
}

/// [`scatter`] into `values` holding K's values from position `offset` on.
fn scatter_at<const N: usize>(
    k: &SMatrix<f64, N, N>,
    map: &[u32],
    values: &mut [f64],
    offset: usize,
) {
    for a in 0..N {
        for b in 0..N {
            let p = map[a * N + b];
            if p != UNMAPPED {
                values[p as usize - offset] += k[(a, b)];
            }
        }
    }
}

fn gather<const M: usize>(model: &Model, u: &[f64], nodes: [usize; M]) -> [Vector3<f64>; M] {
    nodes.map(|i| model.position(u, i))
}

fn add_force(r: &mut [f64], nodes: &[usize], f: &[f64], magnitude: &mut Option<&mut [f64]>) {
    for (a, &i) in nodes.iter().enumerate() {
        for c in 0..3 {
            r[3 * i + c] += f[3 * a + c];
        }
    }
    if let Some(m) = magnitude.as_deref_mut() {
        for (a, &i) in nodes.iter().enumerate() {
            for c in 0..3 {
                m[3 * i + c] += f[3 * a + c].abs();
            }
        }
    }
}

fn largest(f: &[f64]) -> f64 {
    f.iter().fold(0.0f64, |m, v| m.max(v.abs()))
}

/// Work buffers of an assembly that grow with the model (node positions and forces in the
/// internal order, the external load vector): owned by the solver and reused by every
/// assembly of its Newton iterations and line searches, so that an iteration allocates
/// nothing (docs/performance.md, memory). An assembly given none makes its own.
#[derive(Default)]
pub struct AssemblyScratch {
    xi: Vec<Vector3<f64>>,
    ri: Vec<f64>,
    mi: Vec<f64>,
    /// The pressure loads' nodal forces in internal order (renumbered patterns, one thread).
    fi: Vec<f64>,
    /// The triangles' evaluations in visit order (renumbered patterns, one thread), handed
    /// to the caller's list (the user's triangle order) in one pass after the element loop.
    ei: Vec<Evaluation>,
    fext: Vec<f64>,
    /// The helper thread's half of the triangles (`solver.threads` >= 2 on a large model):
    /// an assembly given this scratch evaluates the two halves side by side.
    pub parallel: Option<Parallel>,
}

impl AssemblyScratch {
    /// The external forces of the last assembly (user DOF order).
    pub fn external(&self) -> &[f64] {
        &self.fext
    }

    /// Empty buffers, and the helper's half of the triangles if any.
    pub fn with_parallel(parallel: Option<Parallel>) -> AssemblyScratch {
        AssemblyScratch {
            parallel,
            ..Default::default()
        }
    }
}

/// What an assembly computes besides R (and K when a matrix is given).
#[derive(Default)]
pub struct Membranes<'a> {
    /// States frozen by the solver against chatter (None: the mixed criterion decides).
    pub forced: Option<&'a [Option<WrinkleState>]>,
    /// Evaluation of every triangle (state, tension angle, stress), if wanted.
    pub out: Option<&'a mut Vec<Evaluation>>,
    /// Held-DOF coupling: given a displacement change on held DOFs (zero elsewhere), add
    /// K·change (element tangents, every row) into the second vector. Needs the tangent.
    pub held_step: Option<(&'a [f64], &'a mut [f64])>,
    /// Factor on every triangle's artificial prestress (None: 1).
    pub prestress_factor: Option<f64>,
    /// The prestress continuation's isotropic pre-strain of every triangle (`path.rs`; 0:
    /// none, the scene's own problem).
    pub pre_strain: f64,
    /// Per DOF, the sum of the magnitudes of every force that meets there (element forces and
    /// loads): the size of the terms whose sum is R, for its round-off floor. Zeroed here.
    pub magnitude: Option<&'a mut [f64]>,
    /// Reused work buffers (None: allocated for this assembly).
    pub scratch: Option<&'a mut AssemblyScratch>,
}

/// What the iteration adds to every membrane triangle: the factor on its tangent-only
/// artificial prestress, and the prestress continuation's isotropic pre-strain (`path.rs`,
/// `membrane::triangle_with`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Aid {
    pub prestress_factor: f64,
    pub pre_strain: f64,
}

impl Aid {
    /// The full artificial prestress, no pre-strain.
    pub const PLAIN: Aid = Aid {
        prestress_factor: 1.0,
        pre_strain: 0.0,
    };

    fn of(extra: &Membranes) -> Aid {
        Aid {
            prestress_factor: extra.prestress_factor.unwrap_or(1.0),
            pre_strain: extra.pre_strain,
        }
    }
}

/// Add K_e·du_e (the element's rows) to `out` for an element with `nodes`.
fn couple<const N: usize>(k: &SMatrix<f64, N, N>, nodes: &[usize], du: &[f64], out: &mut [f64]) {
    let dofs = |a: usize| 3 * nodes[a / 3] + a % 3;
    for b in (0..N).filter(|&b| du[dofs(b)] != 0.0) {
        let d = du[dofs(b)];
        for a in 0..N {
            out[dofs(a)] += k[(a, b)] * d;
        }
    }
}

/// One membrane triangle's internal force, tangent (into `ke` when given, with the tangent-only
/// regularisation `regularization` of wrinkled and slack states) and evaluation at `u`: nodal
/// relaxation's element routine (`relax.rs`), the same `membrane::triangle` as the global
/// assembly's.
pub(super) fn triangle_contribution(
    model: &Model,
    e: usize,
    u: &[f64],
    aid: Aid,
    forced: Option<WrinkleState>,
    ke: Option<&mut membrane::Mat9>,
    regularization: f64,
) -> (membrane::Vec9, Evaluation, f64) {
    let t = &model.triangles[e];
    let x = gather(model, u, t.nodes);
    // The lock only for an elastoplastic triangle: nodal relaxation calls this per triangle.
    let held;
    let plastic: &[f64] = if t.material.plastic.is_some() {
        held = model.plastic.read();
        &held
    } else {
        &[]
    };
    let (f, eval) = membrane::triangle_plastic(
        &t.reference,
        &t.material,
        t.prestress * aid.prestress_factor,
        &x,
        forced,
        ke,
        regularization,
        aid.pre_strain,
        plastic,
    );
    (f, eval, membrane::signed_area_ratio(&t.reference, &x))
}

/// [`triangle_contribution`] of triangle data `t` (the model's, or the pattern's copy in
/// visit order).
fn triangle_of(
    model: &Model,
    t: &crate::model::Triangle,
    u: &[f64],
    aid: Aid,
    forced: Option<WrinkleState>,
    ke: Option<&mut membrane::Mat9>,
    plastic: &[f64],
) -> (membrane::Vec9, Evaluation, f64) {
    triangle_at(t, &gather(model, u, t.nodes), aid, forced, ke, plastic)
}

/// One triangle's force, evaluation and area ratio at current node positions `x`, with the
/// committed plastic history `plastic` (the model's store: `model::state`).
fn triangle_at(
    t: &crate::model::Triangle,
    x: &[Vector3<f64>; 3],
    aid: Aid,
    forced: Option<WrinkleState>,
    ke: Option<&mut membrane::Mat9>,
    plastic: &[f64],
) -> (membrane::Vec9, Evaluation, f64) {
    let (f, eval) = membrane::triangle_plastic(
        &t.reference,
        &t.material,
        t.prestress * aid.prestress_factor,
        x,
        forced,
        ke,
        REGULARIZATION,
        aid.pre_strain,
        plastic,
    );
    (f, eval, membrane::signed_area_ratio(&t.reference, x))
}

/// One cable segment's internal force, tangent and energy at `u` (its unstretched length
/// includes the slips at its sleeve ends; a closed segment is the link of its touching points).
pub(super) fn segment_contribution(
    model: &Model,
    e: usize,
    u: &[f64],
) -> (cable::Vec6, cable::Mat6, f64) {
    let s = &model.segments[e];
    let x = gather(model, u, s.nodes);
    if model.segment_closed(u, e) {
        // Two touching sleeve points: a zero-length link (`solver::order`), no 1/l anywhere.
        let k = model.link_stiffness(e);
        let (f, w) = sleeve::tie_force(k, &x[0], &x[1]);
        let f = cable::Vec6::from_column_slice(&[f.x, f.y, f.z, -f.x, -f.y, -f.z]);
        return (f, sleeve::tie_stiffness(k), w);
    }
    cable::segment(s.law, s.ea, model.segment_l0(u, e), &x[0], &x[1])
}

/// One sleeve tie's force (cable point, then membrane node), tangent and energy at `u` (with
/// its multiplier, held: the tangent is the penalty's).
pub(super) fn tie_contribution(
    model: &Model,
    e: usize,
    u: &[f64],
) -> (cable::Vec6, cable::Mat6, f64) {
    let t = &model.ties[e];
    let x = gather(model, u, t.nodes);
    let (f, w) = sleeve::augmented_tie_force(t.k, &model.tie_multiplier(u, e), &x[0], &x[1]);
    let f = cable::Vec6::from_column_slice(&[f.x, f.y, f.z, -f.x, -f.y, -f.z]);
    (f, sleeve::tie_stiffness(t.k), w)
}

/// Pressure `value` on triangle `e` at `u`: the nodal force (the same on its three nodes) and,
/// for a follower pressure, the symmetric part of its load stiffness (`model::pressure`).
pub(super) fn pressure_contribution(
    model: &Model,
    e: usize,
    u: &[f64],
    value: f64,
    follower: bool,
    want_k: bool,
) -> (Vector3<f64>, Option<membrane::Mat9>) {
    let t = &model.triangles[e];
    let x = if follower {
        gather(model, u, t.nodes)
    } else {
        [Vector3::zeros(); 3]
    };
    pressure_at(t, &x, value, follower, want_k)
}

/// [`pressure_contribution`] of triangle data `t` at node positions `x` (used if `follower`).
fn pressure_at(
    t: &crate::model::Triangle,
    x: &[Vector3<f64>; 3],
    value: f64,
    follower: bool,
    want_k: bool,
) -> (Vector3<f64>, Option<membrane::Mat9>) {
    if follower {
        let k = want_k.then(|| {
            let kp = pressure::follower_stiffness(value, x);
            (kp + kp.transpose()) * 0.5
        });
        (pressure::follower_force(value, x), k)
    } else {
        (t.reference.normal * (value * t.reference.area / 3.0), None)
    }
}

/// How the triangles a load presses are loaded: a pressure along the normal (follower or
/// dead; a volume's gas pressure is a follower one) or a surface law (snow, ponding).
#[derive(Clone, Copy, Debug)]
pub(super) enum Pressing {
    Pressure { follower: bool },
    Law(pressure::SurfaceLaw),
}

impl Pressing {
    /// How `load` presses its triangles, None for a load that presses none.
    pub(super) fn of(load: &LoadModel) -> Option<Self> {
        match load {
            LoadModel::Pressure { follower, .. } => Some(Pressing::Pressure {
                follower: *follower,
            }),
            LoadModel::Volume { .. } => Some(Pressing::Pressure { follower: true }),
            LoadModel::Surface { law, .. } => Some(Pressing::Law(*law)),
            // Ponding at the level its unknown gives (`Model::load_value`).
            LoadModel::Water { gamma_w, .. } => {
                Some(Pressing::Law(pressure::SurfaceLaw::Ponding {
                    gamma_w: *gamma_w,
                }))
            }
            LoadModel::PointForce(_) | LoadModel::Displacement(_) => None,
        }
    }
}

/// The triangles load `load` presses (empty for a load that presses none).
pub(super) fn pressed_triangles(load: &LoadModel) -> &[usize] {
    match load {
        LoadModel::Pressure { triangles, .. }
        | LoadModel::Volume { triangles, .. }
        | LoadModel::Surface { triangles, .. }
        | LoadModel::Water { triangles, .. } => triangles,
        LoadModel::PointForce(_) | LoadModel::Displacement(_) => &[],
    }
}

/// Nodal forces of a pressed triangle `t` at node positions `x` and, with `want_k`, the
/// symmetric part of its load stiffness: [`pressure_at`] for a pressure, the surface law's
/// own for snow and ponding (`model::pressure`).
pub(super) fn pressing_at(
    t: &crate::model::Triangle,
    x: &[Vector3<f64>; 3],
    value: f64,
    how: Pressing,
    want_k: bool,
) -> ([Vector3<f64>; 3], Option<membrane::Mat9>) {
    match how {
        Pressing::Pressure { follower } => {
            let (f, k) = pressure_at(t, x, value, follower, want_k);
            ([f; 3], k)
        }
        Pressing::Law(law) => {
            let k = want_k.then(|| {
                let kp = law.stiffness(value, x);
                (kp + kp.transpose()) * 0.5
            });
            (law.forces(value, x), k)
        }
    }
}

/// [`pressing_at`] of model triangle `e` at `u`.
pub(super) fn pressing_contribution(
    model: &Model,
    e: usize,
    u: &[f64],
    value: f64,
    how: Pressing,
    want_k: bool,
) -> ([Vector3<f64>; 3], Option<membrane::Mat9>) {
    let t = &model.triangles[e];
    let x = match how {
        Pressing::Pressure { follower: false } => [Vector3::zeros(); 3],
        _ => gather(model, u, t.nodes),
    };
    pressing_at(t, &x, value, how, want_k)
}

/// Residual R = f_int − f_ext(loads) on all DOFs at displacement `u`, and, if `k` is given,
/// the free-free tangent (upper triangle) into `k` (zeroed here).
pub fn assemble(
    model: &Model,
    pattern: &Pattern,
    u: &[f64],
    loads: &[f64],
    r: &mut [f64],
    k: Option<&mut [f64]>,
) -> AssemblyInfo {
    assemble_with(model, pattern, u, loads, r, k, Membranes::default())
}

/// [`assemble`] with control over the membranes' wrinkle states and the extra outputs.
pub fn assemble_with(
    model: &Model,
    pattern: &Pattern,
    u: &[f64],
    loads: &[f64],
    r: &mut [f64],
    mut k: Option<&mut [f64]>,
    mut extra: Membranes,
) -> AssemblyInfo {
    let _phase = crate::phases::start(match k {
        Some(_) => "solve: assembly (R and K)",
        None => "solve: assembly (R only)",
    });
    let mut own = AssemblyScratch::default();
    let scratch = extra.scratch.take().unwrap_or(&mut own);
    // Two threads when the scratch has a helper's half for this very pattern (the solver's,
    // renumbered); the held-DOF coupling (a prescribed displacement's predictor) stays on one.
    let two =
        scratch.parallel.as_ref().is_some_and(|p| p.serves(pattern)) && extra.held_step.is_none();
    if two {
        return assemble_two(model, pattern, u, loads, r, k, extra, scratch);
    }
    r.fill(0.0);
    if let Some(k) = k.as_deref_mut() {
        k.fill(0.0);
    }
    if let Some(m) = extra.magnitude.as_deref_mut() {
        m.fill(0.0);
    }
    let mut info = AssemblyInfo {
        min_area_ratio: f64::INFINITY,
        min_guard_ratio: f64::INFINITY,
        ..Default::default()
    };
    if let Some(out) = extra.out.as_deref_mut() {
        size_evaluations(out, model.triangles.len());
    }
    let want_k = k.is_some() || extra.held_step.is_some();
    let internal = prepare_internal(model, pattern, u, &extra, scratch);
    for kind in ElementKind::ALL {
        match kind {
            ElementKind::Membrane => {
                triangles_one(model, pattern, u, r, &mut k, &mut extra, scratch, &mut info)
            }
            ElementKind::Cable => elements_into(
                model,
                pattern,
                kind,
                r,
                &mut k,
                &mut extra.magnitude,
                &mut extra.held_step,
                &mut info,
                |e| segment_contribution(model, e, u),
            ),
            ElementKind::Tie => elements_into(
                model,
                pattern,
                kind,
                r,
                &mut k,
                &mut extra.magnitude,
                &mut extra.held_step,
                &mut info,
                |e| tie_contribution(model, e, u),
            ),
            ElementKind::ContactPair => elements_into(
                model,
                pattern,
                kind,
                r,
                &mut k,
                &mut extra.magnitude,
                &mut extra.held_step,
                &mut info,
                |e| model.pair_contribution(e, u),
            ),
            ElementKind::ContactPoint => elements_into(
                model,
                pattern,
                kind,
                r,
                &mut k,
                &mut extra.magnitude,
                &mut extra.held_step,
                &mut info,
                |e| model.point_contribution(e, u),
            ),
        }
    }
    let AssemblyScratch {
        xi, ri, fi, fext, ..
    } = scratch;
    fext.clear();
    fext.resize(r.len(), 0.0);
    // Pressure forces summed node by node in internal order and added to f_ext once per node.
    if internal {
        fi.resize(ri.len(), 0.0);
    }
    external_loads_into(
        model,
        pattern,
        u,
        loads,
        xi,
        fext,
        internal.then_some(&mut fi[..]),
        &mut k,
        &mut extra.held_step,
        want_k,
        true,
        |l| 0..pattern.pressed_order[l].len(),
    );
    if internal {
        to_user_order(pattern, fi, fext);
    }
    finish(model, u, r, fext, &mut extra.magnitude, &mut info);
    info
}

/// The scratch's internal-order buffers for one assembly of a renumbered pattern
/// (`pattern.triangles` holds the triangles in visit order with internal node numbers):
/// positions gathered once in internal order, forces (and magnitudes) to be summed in
/// internal order and added to R node by node at the end, so the element loop reads and
/// writes memory front to back whatever the user's numbering. Returns whether the pattern is
/// renumbered (the buffers stay empty otherwise).
fn prepare_internal(
    model: &Model,
    pattern: &Pattern,
    u: &[f64],
    extra: &Membranes,
    scratch: &mut AssemblyScratch,
) -> bool {
    let internal = !pattern.triangles.is_empty();
    let AssemblyScratch {
        xi, ri, mi, fi, ei, ..
    } = scratch;
    xi.clear();
    ri.clear();
    mi.clear();
    fi.clear();
    if internal {
        xi.extend(pattern.node_of.iter().map(|&i| model.position(u, i)));
        ri.resize(3 * xi.len(), 0.0);
        if extra.magnitude.is_some() {
            mi.resize(3 * xi.len(), 0.0);
        }
        if extra.out.is_some() {
            size_evaluations(ei, model.triangles.len());
        }
    }
    internal
}

/// The membrane triangles of a one-thread assembly, in visit order: forces into R (through
/// the internal-order buffers of a renumbered pattern, [`prepare_internal`]), tangents into K
/// and the held-DOF coupling, evaluations into `extra.out`.
#[allow(clippy::too_many_arguments)]
fn triangles_one(
    model: &Model,
    pattern: &Pattern,
    u: &[f64],
    r: &mut [f64],
    k: &mut Option<&mut [f64]>,
    extra: &mut Membranes,
    scratch: &mut AssemblyScratch,
    info: &mut AssemblyInfo,
) {
    let want_k = k.is_some() || extra.held_step.is_some();
    let factor = Aid::of(extra);
    let internal = !pattern.triangles.is_empty();
    let AssemblyScratch { xi, ri, mi, ei, .. } = scratch;
    let mut ke = membrane::Mat9::zeros();
    let plastic = model.plastic.read();
    for (slot, &e) in pattern.tri_order().iter().enumerate() {
        let user = &model.triangles[e];
        let forced = extra.forced.and_then(|f| f[e]);
        let kk = want_k.then_some(&mut ke);
        let (f, eval, ratio) = if internal {
            let t = &pattern.triangles[slot];
            let x = t.nodes.map(|i| xi[i]);
            let (f, eval, ratio) = triangle_at(t, &x, factor, forced, kk, &plastic);
            let mut m = (!mi.is_empty()).then_some(&mut mi[..]);
            add_force(ri, &t.nodes, f.as_slice(), &mut m);
            (f, eval, ratio)
        } else {
            let (f, eval, ratio) = triangle_of(model, user, u, factor, forced, kk, &plastic);
            add_force(r, &user.nodes, f.as_slice(), &mut extra.magnitude);
            (f, eval, ratio)
        };
        info.carried = info.carried.max(largest(f.as_slice()));
        if let Some(k) = k.as_deref_mut() {
            scatter(&ke, pattern.map(ElementKind::Membrane, slot), k);
        }
        if let Some((du, out)) = extra.held_step.as_mut() {
            couple(&ke, &user.nodes, du, out);
        }
        if internal && extra.out.is_some() {
            // In visit order here (a write to the user's triangle number would land anywhere
            // in the list under a shuffled numbering); handed over after the loop.
            ei[slot] = eval;
        } else if let Some(out) = extra.out.as_deref_mut() {
            out[e] = eval;
        }
        info.potential += eval.energy;
        info.stored += eval.energy;
        info.min_area_ratio = info.min_area_ratio.min(ratio);
        info.min_guard_ratio = info.min_guard_ratio.min(guard_ratio(ratio, eval.state));
    }
    if internal {
        to_user_order(pattern, ri, r);
        if let Some(m) = extra.magnitude.as_deref_mut() {
            to_user_order(pattern, mi, m);
        }
        if let Some(out) = extra.out.as_deref_mut() {
            for (eval, &e) in ei.iter().zip(pattern.tri_order()) {
                out[e] = *eval;
            }
        }
    }
}

/// An empty buffer for `len` position-map entries whose pages are touched (written) by the
/// calling thread: the solver's helper, while the solving thread builds the model
/// (`core::Started`).
pub fn touched_maps(len: usize) -> Result<Vec<u32>, OutOfMemory> {
    let mut maps = memory::filled(len, UNMAPPED, "the element position maps")?;
    maps.clear();
    Ok(maps)
}

/// One placeholder evaluation per triangle, written (its pages touched) by the calling
/// thread: what an assembly with evaluations writes into (every entry is overwritten).
pub fn unevaluated(triangles: usize) -> Result<Vec<Evaluation>, OutOfMemory> {
    memory::filled(triangles, UNEVALUATED, "the element evaluations")
}

/// `out` sized to one evaluation per triangle (every assembly writes every entry).
fn size_evaluations(out: &mut Vec<Evaluation>, triangles: usize) {
    if out.len() != triangles {
        out.clear();
        out.resize(triangles, UNEVALUATED);
    }
}

/// Add `internal` (3 values per internal node position) into `user` (the user's DOFs).
fn to_user_order(pattern: &Pattern, internal: &[f64], user: &mut [f64]) {
    for (k, &i) in pattern.node_of.iter().enumerate() {
        for c in 0..3 {
            user[3 * i + c] += internal[3 * k + c];
        }
    }
}

/// The elements of `kind` in its visit order (model order: a kind with no evaluation to keep,
/// a segment or a tie), each's force, tangent and energy from `contribution`: forces into R
/// (and the magnitudes), tangents into K and the held-DOF coupling, energies into the
/// potential.
#[allow(clippy::too_many_arguments)]
fn elements_into<const N: usize>(
    model: &Model,
    pattern: &Pattern,
    kind: ElementKind,
    r: &mut [f64],
    k: &mut Option<&mut [f64]>,
    magnitude: &mut Option<&mut [f64]>,
    held_step: &mut Option<(&[f64], &mut [f64])>,
    info: &mut AssemblyInfo,
    contribution: impl Fn(usize) -> (SVector<f64, N>, SMatrix<f64, N, N>, f64),
) {
    for (slot, &e) in pattern.order[kind].iter().enumerate() {
        let (f, ke, w) = contribution(e);
        let nodes = model.element_nodes(kind, e);
        add_force(r, nodes, f.as_slice(), magnitude);
        info.carried = info.carried.max(largest(f.as_slice()));
        info.potential += w;
        info.stored += w;
        if let Some(k) = k.as_deref_mut() {
            scatter(&ke, pattern.map(kind, slot), k);
        }
        if let Some((du, out)) = held_step.as_mut() {
            couple(&ke, nodes, du, out);
        }
    }
}

/// External loads into `fext` (the user's DOFs), load by load: the point forces if `points`,
/// and of every pressure load `l` its pressed triangles `pressed(l)` (a range of
/// `pattern.pressed_order[l]`), with their follower stiffness into K. `xi`: the positions in
/// internal order (renumbered patterns).
#[allow(clippy::too_many_arguments)]
fn external_loads(
    model: &Model,
    pattern: &Pattern,
    u: &[f64],
    loads: &[f64],
    xi: &[Vector3<f64>],
    fext: &mut [f64],
    k: &mut Option<&mut [f64]>,
    held_step: &mut Option<(&[f64], &mut [f64])>,
    want_k: bool,
    points: bool,
    pressed: impl Fn(usize) -> Range<usize>,
) {
    external_loads_into(
        model, pattern, u, loads, xi, fext, None, k, held_step, want_k, points, pressed,
    );
}

/// [`external_loads`] with the pressure loads' nodal forces into `fi` (3 values per internal
/// node position; renumbered patterns) instead of `fext` when it is given.
#[allow(clippy::too_many_arguments)]
fn external_loads_into(
    model: &Model,
    pattern: &Pattern,
    u: &[f64],
    loads: &[f64],
    xi: &[Vector3<f64>],
    fext: &mut [f64],
    mut fi: Option<&mut [f64]>,
    k: &mut Option<&mut [f64]>,
    held_step: &mut Option<(&[f64], &mut [f64])>,
    want_k: bool,
    points: bool,
    pressed: impl Fn(usize) -> Range<usize>,
) {
    let internal = !pattern.triangles.is_empty();
    for (l, load) in model.loads.iter().enumerate() {
        match load {
            LoadModel::PointForce(dofs) => {
                if points {
                    let value = model.load_value(l, u, loads);
                    for &(d, f) in dofs {
                        fext[d] += f * value;
                    }
                }
            }
            LoadModel::Pressure { .. }
            | LoadModel::Volume { .. }
            | LoadModel::Surface { .. }
            | LoadModel::Water { .. } => {
                let how = Pressing::of(load).expect("a pressing load");
                let triangles = pressed_triangles(load);
                let range = pressed(l);
                if range.is_empty() {
                    continue;
                }
                // A volume input's load is the follower pressure held in its unknown, a water
                // volume's the ponding at the level its unknown gives.
                let value = model.load_value(l, u, loads);
                debug_assert_eq!(triangles.len(), pattern.pressed_order[l].len());
                for (&slot, &e) in pattern.pressed_slots[l][range.clone()]
                    .iter()
                    .zip(&pattern.pressed_order[l][range])
                {
                    let kp = if internal {
                        let t = &pattern.triangles[slot];
                        let x = t.nodes.map(|i| xi[i]);
                        let (f, kp) = pressing_at(t, &x, value, how, want_k);
                        match fi.as_deref_mut() {
                            Some(fi) => {
                                for (&i, f) in t.nodes.iter().zip(&f) {
                                    for c in 0..3 {
                                        fi[3 * i + c] += f[c];
                                    }
                                }
                            }
                            None => {
                                for (&i, f) in t.nodes.iter().zip(&f) {
                                    let i = pattern.node_of[i];
                                    for c in 0..3 {
                                        fext[3 * i + c] += f[c];
                                    }
                                }
                            }
                        }
                        kp
                    } else {
                        let (f, kp) = pressing_contribution(model, e, u, value, how, want_k);
                        for (&i, f) in model.triangles[e].nodes.iter().zip(&f) {
                            for c in 0..3 {
                                fext[3 * i + c] += f[c];
                            }
                        }
                        kp
                    };
                    if let Some(kp) = kp {
                        if let Some(k) = k.as_deref_mut() {
                            scatter(&kp, pattern.map(ElementKind::Membrane, slot), k);
                        }
                        if let Some((du, out)) = held_step.as_mut() {
                            couple(&kp, &model.triangles[e].nodes, du, out);
                        }
                    }
                }
            }
            LoadModel::Displacement(_) => {}
        }
    }
}

/// R −= f_ext, the dead loads' work off the potential, |f_ext|∞, and |f_ext| into the
/// magnitudes.
fn finish(
    model: &Model,
    u: &[f64],
    r: &mut [f64],
    fext: &[f64],
    magnitude: &mut Option<&mut [f64]>,
    info: &mut AssemblyInfo,
) {
    for (d, f) in fext.iter().enumerate() {
        r[d] -= f;
        if !model.held[d] {
            info.potential -= f * u[d];
        }
        info.external = info.external.max(f.abs());
    }
    if let Some(m) = magnitude.as_deref_mut() {
        for (m, f) in m.iter_mut().zip(fext.iter()) {
            *m += f.abs();
        }
    }
}

/// What one thread's share of the triangles found besides forces and tangents.
#[derive(Clone, Copy, Debug)]
struct Sums {
    potential: f64,
    carried: f64,
    min_ratio: f64,
    min_guard: f64,
}

impl Default for Sums {
    fn default() -> Sums {
        Sums {
            potential: 0.0,
            carried: 0.0,
            min_ratio: f64::INFINITY,
            min_guard: f64::INFINITY,
        }
    }
}

/// The renumbered triangles in `slots` at internal positions `x`: forces into `r` (and their
/// magnitudes into `m`), 3 values per internal node from node `base` on; tangents into K's
/// values `k.0` held from position `k.1` on; every evaluation to `out` with its slot.
#[allow(clippy::too_many_arguments)]
fn triangles_into(
    pattern: &Pattern,
    slots: Range<usize>,
    x: &[Vector3<f64>],
    factor: Aid,
    forced: impl Fn(usize) -> Option<WrinkleState>,
    base: usize,
    r: &mut [f64],
    mut m: Option<&mut [f64]>,
    mut k: Option<(&mut [f64], usize)>,
    mut out: impl FnMut(usize, &Evaluation),
    plastic: &[f64],
) -> Sums {
    let want_k = k.is_some();
    let mut ke = membrane::Mat9::zeros();
    let mut sums = Sums::default();
    for slot in slots {
        let t = &pattern.triangles[slot];
        let kk = want_k.then_some(&mut ke);
        let xt = t.nodes.map(|i| x[i]);
        let (f, eval, ratio) = triangle_at(t, &xt, factor, forced(slot), kk, plastic);
        add_force(r, &t.nodes.map(|i| i - base), f.as_slice(), &mut m);
        sums.carried = sums.carried.max(largest(f.as_slice()));
        if let Some((k, offset)) = k.as_mut() {
            scatter_at(&ke, pattern.map(ElementKind::Membrane, slot), k, *offset);
        }
        out(slot, &eval);
        sums.potential += eval.energy;
        sums.min_ratio = sums.min_ratio.min(ratio);
        sums.min_guard = sums.min_guard.min(guard_ratio(ratio, eval.state));
    }
    sums
}

/// Where a wrinkled or slack triangle may fold while the iteration moves the sheet: its area
/// ratio counts in the inversion guard only once it has turned over past this.
pub const FOLD_LIMIT: f64 = -0.5;

/// A triangle's area ratio as the inversion guard of an iterate sees it (`min_guard_ratio`).
fn guard_ratio(ratio: f64, state: WrinkleState) -> f64 {
    if state == WrinkleState::Taut || ratio < FOLD_LIMIT {
        ratio
    } else {
        f64::INFINITY
    }
}

fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|e| e.into_inner())
}

/// The assembly on two threads (`solver.threads` >= 2, a tangent of at least
/// `linear::SPLIT_MIN_EQUATIONS` equations, renumbered nodes): the triangles in visit order
/// (by their lowest internal node, `renumber.rs`) are cut in two halves of equal count. The
/// solving thread evaluates the first half into R's internal-order buffer and straight into
/// K's values; the helper evaluates the second half into buffers of its own that cover only
/// the nodes and the K positions its triangles touch (the visit order keeps those at the back
/// of both, overlapping the first half's only along the cut). Each half does its own pressed
/// triangles too. Then the solving thread adds the helper's buffers in (a fixed order: the
/// answer of a given thread count is the same bit for bit on every run) and does the cable
/// segments, sleeve ties and point loads as one thread does. Sums that meet along the cut are
/// grouped differently from one thread's single pass, so the result equals one thread's to
/// round-off, not bit for bit.
pub struct Parallel {
    pool: Arc<Pool>,
    job: Arc<Mutex<HelperHalf>>,
    positions: Arc<RwLock<Vec<Vector3<f64>>>>,
    /// The pattern the helper's half belongs to.
    pattern: Arc<Pattern>,
    /// First triangle slot of the helper's half.
    first: usize,
    /// One past the last K position the first half writes.
    k_first_end: usize,
    /// First K position the helper's half writes (its buffer holds K from here on).
    k_lo: usize,
    /// Lowest internal node of the helper's half (its force buffers start here).
    node_lo: usize,
}

/// The helper's half: its inputs for one assembly, its buffers and what it found.
struct HelperHalf {
    pattern: Arc<Pattern>,
    positions: Arc<RwLock<Vec<Vector3<f64>>>>,
    first: usize,
    node_lo: usize,
    k_lo: usize,
    want_k: bool,
    want_m: bool,
    want_out: bool,
    factor: Aid,
    use_forced: bool,
    /// Frozen states of the helper's slots (when `use_forced`).
    forced: Vec<Option<WrinkleState>>,
    /// The model's committed plastic history (`model::state`; empty when elastic).
    plastic: Vec<f64>,
    /// Per pressing load: (load, value, how it presses, first index of
    /// `pattern.pressed_order[l]` in the helper's half).
    pressures: Vec<(usize, f64, Pressing, usize)>,
    /// K's values from position `k_lo` on.
    k: Vec<f64>,
    /// Forces, force magnitudes and pressure loads per internal node from `node_lo` on.
    r: Vec<f64>,
    m: Vec<f64>,
    fp: Vec<f64>,
    /// Evaluations of the helper's slots in slot order (when `want_out`).
    evals: Vec<Evaluation>,
    sums: Sums,
}

impl HelperHalf {
    fn run(&mut self) {
        let positions = Arc::clone(&self.positions);
        let x = positions.read().unwrap_or_else(|e| e.into_inner());
        let HelperHalf {
            pattern,
            first,
            node_lo,
            k_lo,
            want_k,
            want_m,
            want_out,
            factor,
            use_forced,
            forced,
            plastic,
            pressures,
            k,
            r,
            m,
            fp,
            evals,
            sums,
            ..
        } = self;
        let (first, node_lo, k_lo, want_k, want_out) =
            (*first, *node_lo, *k_lo, *want_k, *want_out);
        r.fill(0.0);
        if *want_m {
            m.fill(0.0);
        }
        if want_k {
            k.fill(0.0);
        }
        evals.clear();
        let use_forced = *use_forced;
        *sums = triangles_into(
            pattern,
            first..pattern.tri_order().len(),
            &x,
            *factor,
            |slot| {
                if use_forced {
                    forced[slot - first]
                } else {
                    None
                }
            },
            node_lo,
            r,
            want_m.then_some(&mut m[..]),
            want_k.then_some((&mut k[..], k_lo)),
            |_, eval| {
                if want_out {
                    evals.push(*eval)
                }
            },
            plastic,
        );
        if !pressures.is_empty() {
            fp.fill(0.0);
        }
        for &(l, value, how, start) in pressures.iter() {
            for &e in &pattern.pressed_order[l][start..] {
                let slot = pattern.tri_slot[e];
                let t = &pattern.triangles[slot];
                let (f, kp) = pressing_at(t, &t.nodes.map(|i| x[i]), value, how, want_k);
                for (&i, f) in t.nodes.iter().zip(&f) {
                    for c in 0..3 {
                        fp[3 * (i - node_lo) + c] += f[c];
                    }
                }
                if let Some(kp) = kp {
                    scatter_at(&kp, pattern.map(ElementKind::Membrane, slot), k, k_lo);
                }
            }
        }
    }
}

impl Parallel {
    /// The helper's half of `pattern`'s triangles on `pool`'s first helper (its
    /// [`ASSEMBLE`] job), with every buffer allocated here, fallibly: an assembly then
    /// allocates nothing. None when the pool has no helper or the pattern is in the user's
    /// order (`NodeOrder::Given`: no visit order to cut).
    pub fn try_new(pool: Arc<Pool>, pattern: &Arc<Pattern>) -> Result<Option<Self>, OutOfMemory> {
        let count = pattern.triangles.len();
        if pool.helpers() == 0 || count < 2 {
            return Ok(None);
        }
        let first = count / 2;
        let nodes = pattern.node_of.len();
        let nnz = pattern.col_ptr[pattern.n];
        let written = |slot: usize| {
            pattern
                .map(ElementKind::Membrane, slot)
                .iter()
                .copied()
                .filter(|&p| p != UNMAPPED)
                .map(|p| p as usize)
        };
        let k_first_end = (0..first)
            .filter_map(|s| written(s).max())
            .max()
            .map_or(0, |p| p + 1);
        let k_lo = (first..count)
            .filter_map(|s| written(s).min())
            .min()
            .unwrap_or(nnz);
        let node_lo = (first..count)
            .filter_map(|s| pattern.triangles[s].nodes.into_iter().min())
            .min()
            .unwrap_or(nodes);
        let what = "the parallel assembly's buffers";
        let helper_nodes = 3 * (nodes - node_lo);
        let positions = Arc::new(RwLock::new(memory::with_capacity(nodes, what)?));
        let half = HelperHalf {
            pattern: Arc::clone(pattern),
            positions: Arc::clone(&positions),
            first,
            node_lo,
            k_lo,
            want_k: false,
            want_m: false,
            want_out: false,
            factor: Aid::PLAIN,
            use_forced: false,
            plastic: Vec::new(),
            forced: memory::with_capacity(count - first, what)?,
            pressures: memory::with_capacity(pattern.pressed_order.len(), what)?,
            // Zeroed by each assembly before it writes them: fresh pages, first touched by the
            // helper's first assembly rather than here.
            k: memory::lazy_zeros(nnz - k_lo, what)?,
            r: memory::lazy_zeros(helper_nodes, what)?,
            m: memory::lazy_zeros(helper_nodes, what)?,
            fp: memory::lazy_zeros(helper_nodes, what)?,
            evals: memory::with_capacity(count - first, what)?,
            sums: Sums::default(),
        };
        let job = Arc::new(Mutex::new(half));
        let mine = Arc::clone(&job);
        pool.set_job_in(0, ASSEMBLE, Box::new(move || lock(&mine).run()));
        Ok(Some(Parallel {
            pool,
            job,
            positions,
            pattern: Arc::clone(pattern),
            first,
            k_first_end,
            k_lo,
            node_lo,
        }))
    }

    /// Triangles evaluated by (the solving thread, the helper).
    pub fn halves(&self) -> (usize, usize) {
        (self.first, self.pattern.tri_order().len() - self.first)
    }

    /// The threads it runs on.
    pub fn pool(&self) -> &Arc<Pool> {
        &self.pool
    }

    /// Whether this is the helper's half of `pattern`.
    fn serves(&self, pattern: &Pattern) -> bool {
        std::ptr::eq(Arc::as_ptr(&self.pattern), pattern)
    }

    /// Bytes of the buffers it holds (the helper's K, forces and evaluations).
    pub fn bytes(&self) -> u64 {
        let h = lock(&self.job);
        let f = std::mem::size_of::<f64>();
        let words = h.k.capacity() + h.r.capacity() + h.m.capacity() + h.fp.capacity();
        let positions = self
            .positions
            .read()
            .unwrap_or_else(|e| e.into_inner())
            .capacity();
        (words * f
            + positions * std::mem::size_of::<Vector3<f64>>()
            + h.evals.capacity() * std::mem::size_of::<Evaluation>()
            + h.forced.capacity() * std::mem::size_of::<Option<WrinkleState>>()) as u64
    }
}

/// [`assemble_with`] on two threads ([`Parallel`]).
#[allow(clippy::too_many_arguments)]
fn assemble_two(
    model: &Model,
    pattern: &Pattern,
    u: &[f64],
    loads: &[f64],
    r: &mut [f64],
    mut k: Option<&mut [f64]>,
    mut extra: Membranes,
    scratch: &mut AssemblyScratch,
) -> AssemblyInfo {
    r.fill(0.0);
    if let Some(m) = extra.magnitude.as_deref_mut() {
        m.fill(0.0);
    }
    scratch.fext.clear();
    scratch.fext.resize(r.len(), 0.0);
    let mut info = AssemblyInfo {
        min_area_ratio: f64::INFINITY,
        min_guard_ratio: f64::INFINITY,
        ..Default::default()
    };
    let mut no_held: Option<(&[f64], &mut [f64])> = None;
    for kind in ElementKind::ALL {
        match kind {
            // With their pressure loads: each half does its own pressed triangles.
            ElementKind::Membrane => triangles_two(
                model, pattern, u, loads, r, &mut k, &mut extra, scratch, &mut info,
            ),
            ElementKind::Cable => elements_into(
                model,
                pattern,
                kind,
                r,
                &mut k,
                &mut extra.magnitude,
                &mut no_held,
                &mut info,
                |e| segment_contribution(model, e, u),
            ),
            ElementKind::Tie => elements_into(
                model,
                pattern,
                kind,
                r,
                &mut k,
                &mut extra.magnitude,
                &mut no_held,
                &mut info,
                |e| tie_contribution(model, e, u),
            ),
            ElementKind::ContactPair => elements_into(
                model,
                pattern,
                kind,
                r,
                &mut k,
                &mut extra.magnitude,
                &mut no_held,
                &mut info,
                |e| model.pair_contribution(e, u),
            ),
            ElementKind::ContactPoint => elements_into(
                model,
                pattern,
                kind,
                r,
                &mut k,
                &mut extra.magnitude,
                &mut no_held,
                &mut info,
                |e| model.point_contribution(e, u),
            ),
        }
    }
    let want_k = k.is_some();
    external_loads(
        model,
        pattern,
        u,
        loads,
        &[],
        &mut scratch.fext,
        &mut k,
        &mut no_held,
        want_k,
        true,
        |_| 0..0,
    );
    finish(model, u, r, &scratch.fext, &mut extra.magnitude, &mut info);
    info
}

/// The membrane triangles and their pressure loads on two threads: the helper's half handed
/// over and started, the first half here, the helper's added in; forces into R (and the
/// magnitudes), pressure into `scratch.fext`, tangents into K, evaluations into `extra.out`.
#[allow(clippy::too_many_arguments)]
fn triangles_two(
    model: &Model,
    pattern: &Pattern,
    u: &[f64],
    loads: &[f64],
    r: &mut [f64],
    k: &mut Option<&mut [f64]>,
    extra: &mut Membranes,
    scratch: &mut AssemblyScratch,
    info: &mut AssemblyInfo,
) {
    let par = scratch.parallel.as_ref().expect("a parallel assembly");
    {
        let mut x = par.positions.write().unwrap_or_else(|e| e.into_inner());
        x.clear();
        x.extend(pattern.node_of.iter().map(|&i| model.position(u, i)));
    }
    hand_over(model, pattern, u, loads, k.is_some(), extra, par);
    par.pool.start_in(0, ASSEMBLE);
    // The first half, side by side with the helper's.
    let mut out = extra.out.take();
    let sums = first_half(model, pattern, u, loads, k, extra, &mut out, scratch);
    let AssemblyScratch {
        ri,
        mi,
        fext,
        parallel,
        ..
    } = scratch;
    let par = parallel.as_ref().expect("a parallel assembly");
    let waited = par.pool.wait(0);
    let mut h = lock(&par.job);
    if waited.is_err() {
        // The helper failed (a panic in its half): its half again on this thread, where a
        // second failure is this thread's own, as with one thread.
        h.run();
    }
    add_helper(pattern, par, &h, k, ri, mi, fext, &mut out);
    info.potential += sums.potential + h.sums.potential;
    info.stored += sums.potential + h.sums.potential;
    info.min_area_ratio = info
        .min_area_ratio
        .min(sums.min_ratio.min(h.sums.min_ratio));
    info.min_guard_ratio = info
        .min_guard_ratio
        .min(sums.min_guard.min(h.sums.min_guard));
    info.carried = info.carried.max(sums.carried.max(h.sums.carried));
    drop(h);
    to_user_order(pattern, ri, r);
    if let Some(m) = extra.magnitude.as_deref_mut() {
        to_user_order(pattern, mi, m);
    }
    extra.out = out;
}

/// The helper's inputs of one assembly: what to compute, the frozen states of its triangles,
/// and its pressure loads' values.
fn hand_over(
    model: &Model,
    pattern: &Pattern,
    u: &[f64],
    loads: &[f64],
    want_k: bool,
    extra: &Membranes,
    par: &Parallel,
) {
    let first = par.first;
    let mut h = lock(&par.job);
    h.want_k = want_k;
    h.want_m = extra.magnitude.is_some();
    h.want_out = extra.out.is_some();
    h.factor = Aid::of(extra);
    h.use_forced = extra.forced.is_some();
    h.plastic.clone_from(&model.plastic.read());
    h.forced.clear();
    if let Some(f) = extra.forced {
        h.forced
            .extend(pattern.tri_order()[first..].iter().map(|&e| f[e]));
    }
    h.pressures.clear();
    for (l, load) in model.loads.iter().enumerate() {
        let Some(how) = Pressing::of(load) else {
            continue;
        };
        let list = &pattern.pressed_order[l];
        let start = list.partition_point(|&e| pattern.tri_slot[e] < first);
        h.pressures
            .push((l, model.load_value(l, u, loads), how, start));
    }
}

/// The first half of the triangles on the solving thread: forces into the internal-order
/// buffers, tangents straight into K (zeroed up to the helper's exclusive part), evaluations
/// into `out`, and the first half's pressed triangles into `scratch.fext` and K.
#[allow(clippy::too_many_arguments)]
fn first_half(
    model: &Model,
    pattern: &Pattern,
    u: &[f64],
    loads: &[f64],
    k: &mut Option<&mut [f64]>,
    extra: &Membranes,
    out: &mut Option<&mut Vec<Evaluation>>,
    scratch: &mut AssemblyScratch,
) -> Sums {
    let AssemblyScratch {
        ri,
        mi,
        fext,
        parallel,
        ..
    } = scratch;
    let par = parallel.as_ref().expect("a parallel assembly");
    let first = par.first;
    let want_k = k.is_some();
    let want_m = extra.magnitude.is_some();
    let x = par.positions.read().unwrap_or_else(|e| e.into_inner());
    if let Some(k) = k.as_deref_mut() {
        k[..par.k_first_end.max(par.k_lo)].fill(0.0);
    }
    ri.clear();
    ri.resize(3 * pattern.node_of.len(), 0.0);
    mi.clear();
    if want_m {
        mi.resize(3 * pattern.node_of.len(), 0.0);
    }
    if let Some(out) = out.as_deref_mut() {
        size_evaluations(out, pattern.tri_order().len());
    }
    let forced = extra.forced;
    let sums = triangles_into(
        pattern,
        0..first,
        &x,
        Aid::of(extra),
        |slot| forced.and_then(|f| f[pattern.tri_order()[slot]]),
        0,
        ri,
        want_m.then_some(&mut mi[..]),
        k.as_deref_mut().map(|k| (k, 0)),
        |slot, eval| {
            if let Some(out) = out.as_deref_mut() {
                out[pattern.tri_order()[slot]] = *eval;
            }
        },
        &model.plastic.read(),
    );
    let mut no_held: Option<(&[f64], &mut [f64])> = None;
    external_loads(
        model,
        pattern,
        u,
        loads,
        &x,
        fext,
        k,
        &mut no_held,
        want_k,
        false,
        |l| {
            let list = &pattern.pressed_order[l];
            0..list.partition_point(|&e| pattern.tri_slot[e] < first)
        },
    );
    sums
}

/// The helper's half added in: K's overlap along the cut, then the rest of K copied; its
/// forces, magnitudes, pressure loads and evaluations.
#[allow(clippy::too_many_arguments)]
fn add_helper(
    pattern: &Pattern,
    par: &Parallel,
    h: &HelperHalf,
    k: &mut Option<&mut [f64]>,
    ri: &mut [f64],
    mi: &mut [f64],
    fext: &mut [f64],
    out: &mut Option<&mut Vec<Evaluation>>,
) {
    if let Some(k) = k.as_deref_mut() {
        let lo = par.k_lo;
        let k_split = par.k_first_end.max(par.k_lo);
        for (a, b) in k[lo..k_split].iter_mut().zip(&h.k) {
            *a += b;
        }
        k[k_split..].copy_from_slice(&h.k[k_split - lo..]);
    }
    let lo = 3 * par.node_lo;
    for (a, b) in ri[lo..].iter_mut().zip(&h.r) {
        *a += b;
    }
    if h.want_m {
        for (a, b) in mi[lo..].iter_mut().zip(&h.m) {
            *a += b;
        }
    }
    if !h.pressures.is_empty() {
        for (j, &i) in pattern.node_of[par.node_lo..].iter().enumerate() {
            for c in 0..3 {
                fext[3 * i + c] += h.fp[3 * j + c];
            }
        }
    }
    if let Some(out) = out.as_deref_mut() {
        for (j, eval) in h.evals.iter().enumerate() {
            out[pattern.tri_order()[par.first + j]] = *eval;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The position maps' limit, checked with counts alone (no 4e9-entry model): at the limit
    /// K fits, one entry more is a named error (not a panic, not a truncated position).
    #[test]
    fn more_entries_than_a_u32_position_addresses_is_a_named_error() {
        assert!(check_addressable(0).is_ok());
        assert!(check_addressable(MAX_ENTRIES).is_ok());
        // The largest position of a K at the limit is MAX_ENTRIES - 1: never UNMAPPED.
        assert!(MAX_ENTRIES - 1 < UNMAPPED as u64);
        let e = check_addressable(MAX_ENTRIES + 1).unwrap_err();
        assert_eq!(e.bytes, memory::UNADDRESSABLE);
        let message = e.to_string();
        assert!(
            message.starts_with("too large: the tangent's position maps"),
            "{message}"
        );
        assert!(message.contains("4294967295"), "{message}");
        assert!(!message.contains("out of memory"), "{message}");
        assert!(check_addressable(u64::MAX).is_err());
    }

    /// The triangles' position maps written into a buffer touched beforehand (on the
    /// solver's helper, `core::Started`) are those of a fresh allocation, entry for entry; a
    /// buffer of another size is not used.
    #[test]
    fn the_maps_in_a_touched_buffer_are_the_fresh_ones() {
        let model = crate::model::shipped_model("HenckyDisc");
        let fresh = Pattern::try_ordered(&model, NodeOrder::Rings).unwrap();
        let len = model.triangles.len() * ElementKind::Membrane.block_len();
        for touched in [touched_maps(len).unwrap(), touched_maps(len + 1).unwrap()] {
            let (pattern, _) = Pattern::try_ordered_then::<()>(
                &model,
                NodeOrder::Rings,
                None,
                None,
                Some(touched),
            )
            .unwrap();
            assert_eq!(pattern.maps, fresh.maps);
            assert_eq!(pattern.maps[ElementKind::Membrane].len(), len);
        }
    }

    /// The pattern by nodes is the pattern by elements, and every element entry's position
    /// is its row in its column, on shipped scenes with held DOFs, cables and sleeve ties, in
    /// the rings order and the user's.
    #[test]
    fn the_pattern_by_nodes_is_the_pattern_by_elements() {
        for name in [
            "SleeveCable",
            "WrinkledShear",
            "FourPointSail",
            "HenckyDisc",
        ] {
            let model = crate::model::shipped_model(name);
            for order in [NodeOrder::Rings, NodeOrder::Given] {
                let pattern = Pattern::try_ordered(&model, order).unwrap();
                let (cp, ri) = upper_pattern(&model, &pattern.eq, pattern.n).unwrap();
                assert_eq!(cp, pattern.col_ptr, "{name} {order:?}");
                assert_eq!(ri, pattern.row_idx, "{name} {order:?}");
                let mut d = [NONE; 3 * ElementKind::MAX_NODES];
                for kind in ElementKind::ALL {
                    for (slot, &e) in pattern.order[kind].iter().enumerate() {
                        let m =
                            element_equations(&pattern.eq, model.element_nodes(kind, e), &mut d);
                        let map = pattern.map(kind, slot);
                        for a in 0..m {
                            for b in 0..m {
                                let (i, j) = (d[a], d[b]);
                                if i == NONE || j == NONE || i > j {
                                    assert_eq!(map[a * m + b], UNMAPPED);
                                } else {
                                    let p = map[a * m + b] as usize;
                                    assert!(p >= cp[j] && p < cp[j + 1]);
                                    assert_eq!(ri[p], i, "{name} {order:?}");
                                }
                            }
                        }
                    }
                }
            }
        }
    }
}
