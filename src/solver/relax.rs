//! Nodal relaxation: equilibrate a few nodes with all other nodes held.
//!
//! ```text
//! for a node i:  r_i = the node's rows of R,  K_ii its 3x3 diagonal block of K
//!                Newton on the free components, Δ = −K_ii⁻¹ r_i, each step with the slope
//!                search of the global iteration along it (line_search.rs, bracket_slope)
//! for a patch P: r_P, K_PP (dense, 3 per node), the same, with a smaller regularisation of
//!                wrinkled and slack triangles in K_PP (relax_patch)
//! ```
//! Used by Newton when the global step stalls: a node held only by nearly stress-free wrinkled
//! or slack triangles (free-edge corners of a sheared sheet) sits on a near-mechanism whose
//! tangent is valid only over strain changes of the size of its tiny strains, so every global
//! step overshoots there and the line search then shortens the step everywhere. Solving those
//! few nodes locally (nonlinear Gauss-Seidel, then Newton on the patch as a whole: a nonlinear
//! elimination of the bad unknowns) costs evaluations of a handful of elements, no global
//! factorization. The equilibrium sought is unchanged: only the path to it.
//!
//! # References
//! Cai & Li 2011, *Inexact Newton methods with restricted additive Schwarz based nonlinear
//! elimination*, SIAM J. Sci. Comput. 33:746-762; Brandt 1977 (nonlinear Gauss-Seidel
//! smoothing); docs/mechanics.md (slack and wrinkled near-mechanisms).

use super::assemble::{
    pressure_contribution, segment_contribution, tie_contribution, triangle_contribution, Aid,
};
use super::dense::dense_solve;
use super::settings::MIN_AREA_RATIO;
use super::slope::bracket_slope;
use crate::memory::{self, OutOfMemory};
use crate::model::cable::{Mat6, Vec6};
use crate::model::membrane::Mat9;
use crate::model::wrinkling::{WrinkleState, REGULARIZATION};
use crate::model::{ElementKind, LoadModel, Model, PerKind};
use nalgebra::{Matrix3, Vector3};

/// What touches a node: per element kind, (element, local index) of every element at it.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Adjacency {
    elements: PerKind<Lists<(usize, usize)>>,
    /// Per triangle: (load index, follower) of the pressures acting on it.
    pressures: Lists<(usize, bool)>,
    /// Per node: (load index, component, force per unit load value).
    forces: Lists<(usize, usize, f64)>,
}

/// Per key (a node or a triangle) a list of items, stored flat: one offset array and one item
/// array, both allocated fallibly (`crate::memory`), in the order the pairs come.
#[derive(Clone, Debug, Default, PartialEq)]
struct Lists<T> {
    start: Vec<usize>,
    items: Vec<T>,
}

impl<T: Copy + Default> Lists<T> {
    /// From (key, item) pairs, which `pairs` yields twice (count, then place).
    fn try_build<I>(keys: usize, pairs: impl Fn() -> I) -> Result<Lists<T>, OutOfMemory>
    where
        I: Iterator<Item = (usize, T)>,
    {
        const WHAT: &str = "the node adjacency";
        let mut start: Vec<usize> = memory::zeros(keys + 1, WHAT)?;
        for (k, _) in pairs() {
            start[k + 1] += 1;
        }
        for k in 0..keys {
            start[k + 1] += start[k];
        }
        let mut items = memory::filled(start[keys], T::default(), WHAT)?;
        let mut next = memory::copy(&start[..keys], WHAT)?;
        for (k, item) in pairs() {
            items[next[k]] = item;
            next[k] += 1;
        }
        Ok(Lists { start, items })
    }
}

impl<T> std::ops::Index<usize> for Lists<T> {
    type Output = [T];
    fn index(&self, key: usize) -> &[T] {
        &self.items[self.start[key]..self.start[key + 1]]
    }
}

/// Local Newton steps per node and sweep.
const LOCAL_ITERATIONS: usize = 20;
/// Slope evaluations of one local line search, and the slope ratio it accepts.
const LOCAL_TRIES: usize = 30;
const LOCAL_SLOPE_RATIO: f64 = 0.1;

impl Adjacency {
    pub fn try_new(model: &Model) -> Result<Adjacency, OutOfMemory> {
        let pressures: Vec<(usize, bool, &[usize])> = pressed(model).collect();
        let forces: Vec<(usize, &[(usize, f64)])> = forced(model).collect();
        Adjacency::from_parts(
            model.reference.len(),
            model.triangles.len(),
            |kind| model.element_count(kind),
            |kind, e| model.element_nodes(kind, e),
            &pressures,
            &forces,
        )
    }

    /// What [`Adjacency::try_new`] reads of `model`, copied (element nodes, pressed
    /// triangles, point forces): built from it by [`AdjacencyInput::build`], on another
    /// thread (`core.rs`: the solver's helper, while this one numbers the nodes).
    pub fn input(model: &Model) -> Result<AdjacencyInput, OutOfMemory> {
        const WHAT: &str = "the node adjacency";
        let elements = PerKind::try_from_fn(|kind| {
            let count = model.element_count(kind);
            let len: usize = (0..count).map(|e| model.element_nodes(kind, e).len()).sum();
            let mut start = memory::with_capacity(count + 1, WHAT)?;
            let mut nodes = memory::with_capacity(len, WHAT)?;
            start.push(0);
            for e in 0..count {
                nodes.extend_from_slice(model.element_nodes(kind, e));
                start.push(nodes.len());
            }
            Ok(Lists {
                start,
                items: nodes,
            })
        })?;
        let mut pressures = memory::with_capacity(model.loads.len(), WHAT)?;
        for (l, follower, triangles) in pressed(model) {
            pressures.push((l, follower, memory::copy(triangles, WHAT)?));
        }
        let mut forces = memory::with_capacity(model.loads.len(), WHAT)?;
        for (l, dofs) in forced(model) {
            forces.push((l, memory::copy(dofs, WHAT)?));
        }
        Ok(AdjacencyInput {
            nodes: model.reference.len(),
            triangles: model.triangles.len(),
            elements,
            pressures,
            forces,
        })
    }

    /// The lists from the model's parts: `nodes` nodes, `triangles` triangles, each kind's
    /// element count and element nodes, the pressed triangles (load, follower, triangles)
    /// and the point forces (load, (DOF, force)) in load order.
    fn from_parts<'a>(
        nodes: usize,
        triangles: usize,
        count: impl Fn(ElementKind) -> usize,
        element_nodes: impl Fn(ElementKind, usize) -> &'a [usize],
        pressures: &[(usize, bool, &[usize])],
        forces: &[(usize, &[(usize, f64)])],
    ) -> Result<Adjacency, OutOfMemory> {
        let n = nodes;
        let (count, element_nodes) = (&count, &element_nodes);
        Ok(Adjacency {
            elements: PerKind::try_from_fn(|kind| {
                Lists::try_build(n, || {
                    (0..count(kind)).flat_map(move |e| {
                        let nodes = element_nodes(kind, e);
                        nodes.iter().enumerate().map(move |(k, &i)| (i, (e, k)))
                    })
                })
            })?,
            pressures: Lists::try_build(triangles, || {
                pressures.iter().flat_map(|&(l, follower, triangles)| {
                    triangles.iter().map(move |&e| (e, (l, follower)))
                })
            })?,
            forces: Lists::try_build(n, || {
                forces
                    .iter()
                    .flat_map(|&(l, dofs)| dofs.iter().map(move |&(d, f)| (d / 3, (l, d % 3, f))))
            })?,
        })
    }
}

/// The model's pressures (a gas pressure of an enclosed volume is a follower pressure):
/// (load, follower, triangles), in load order.
fn pressed(model: &Model) -> impl Iterator<Item = (usize, bool, &[usize])> {
    model
        .loads
        .iter()
        .enumerate()
        .filter_map(|(l, load)| match load {
            LoadModel::Pressure {
                triangles,
                follower,
            } => Some((l, *follower, &triangles[..])),
            LoadModel::Volume { triangles, .. } => Some((l, true, &triangles[..])),
            _ => None,
        })
}

/// The model's point forces: (load, (DOF, force per unit load value)), in load order.
fn forced(model: &Model) -> impl Iterator<Item = (usize, &[(usize, f64)])> {
    model
        .loads
        .iter()
        .enumerate()
        .filter_map(|(l, load)| match load {
            LoadModel::PointForce(dofs) => Some((l, &dofs[..])),
            _ => None,
        })
}

/// What an [`Adjacency`] is built from, owned ([`Adjacency::input`]): the same lists as
/// [`Adjacency::try_new`] of the model it was copied from, item for item.
#[derive(Debug)]
pub struct AdjacencyInput {
    nodes: usize,
    triangles: usize,
    /// Per kind, every element's nodes (flat, by element).
    elements: PerKind<Lists<usize>>,
    pressures: Vec<(usize, bool, Vec<usize>)>,
    forces: Vec<(usize, Vec<(usize, f64)>)>,
}

impl AdjacencyInput {
    pub fn build(self) -> Result<Adjacency, OutOfMemory> {
        let pressures: Vec<(usize, bool, &[usize])> = self
            .pressures
            .iter()
            .map(|(l, f, t)| (*l, *f, &t[..]))
            .collect();
        let forces: Vec<(usize, &[(usize, f64)])> =
            self.forces.iter().map(|(l, d)| (*l, &d[..])).collect();
        let elements = &self.elements;
        Adjacency::from_parts(
            self.nodes,
            self.triangles,
            |kind| elements[kind].start.len().saturating_sub(1),
            |kind, e| &elements[kind][e],
            &pressures,
            &forces,
        )
    }
}

/// One node's residual rows, diagonal tangent block and local potential (None with follower
/// pressure, which has no potential).
struct Local {
    r: Vector3<f64>,
    k: Matrix3<f64>,
    potential: Option<f64>,
    inverted: bool,
    /// Elements evaluated for it (the work it cost, `Solver::relax`).
    evaluated: usize,
}

/// The node's rows of R and its 3x3 diagonal block of K, from the same element routines as
/// the global assembly (`super::assemble`), so ties and slipped cable lengths are included.
fn local(
    model: &Model,
    adj: &Adjacency,
    u: &[f64],
    loads: &[f64],
    node: usize,
    forced: Frozen,
    want_k: bool,
) -> Local {
    let mut out = Local {
        r: Vector3::zeros(),
        k: Matrix3::zeros(),
        potential: Some(0.0),
        inverted: false,
        evaluated: 0,
    };
    for kind in ElementKind::ALL {
        let at = &adj.elements[kind][node];
        out.evaluated += at.len();
        match kind {
            ElementKind::Membrane => {
                local_triangles(model, adj, u, loads, node, forced, at, want_k, &mut out)
            }
            ElementKind::Cable => {
                let lines = at
                    .iter()
                    .map(|&(e, a)| (segment_contribution(model, e, u), a));
                local_lines(lines, &mut out)
            }
            ElementKind::Tie => {
                let lines = at.iter().map(|&(e, a)| (tie_contribution(model, e, u), a));
                local_lines(lines, &mut out)
            }
            // Contacts (model/contact.rs): a pair as a line, a rigid point on its own node.
            ElementKind::ContactPair => {
                let lines = at.iter().map(|&(e, a)| (model.pair_contribution(e, u), a));
                local_lines(lines, &mut out)
            }
            ElementKind::ContactPoint => {
                for &(e, _) in at {
                    let (f, k, w) = model.point_contribution(e, u);
                    out.r += f;
                    out.k += k;
                    out.potential = out.potential.map(|p| p + w);
                }
            }
        }
    }
    for &(l, c, f) in &adj.forces[node] {
        out.r[c] -= f * loads[l];
        out.potential = out.potential.map(|p| p - f * loads[l] * u[3 * node + c]);
    }
    out
}

/// The triangles at `node` (`at`: (triangle, the node's local index)) and their pressure
/// loads into the node's rows and block.
#[allow(clippy::too_many_arguments)]
fn local_triangles(
    model: &Model,
    adj: &Adjacency,
    u: &[f64],
    loads: &[f64],
    node: usize,
    forced: Frozen,
    at: &[(usize, usize)],
    want_k: bool,
    out: &mut Local,
) {
    let mut ke = Mat9::zeros();
    for &(e, a) in at {
        let state = forced.states.and_then(|f| f[e]);
        let (f, eval, ratio) = triangle_contribution(
            model,
            e,
            u,
            forced.aid(),
            state,
            want_k.then_some(&mut ke),
            REGULARIZATION,
        );
        out.r += f.fixed_rows::<3>(3 * a);
        if want_k {
            out.k += ke.fixed_view::<3, 3>(3 * a, 3 * a);
        }
        out.potential = out.potential.map(|p| p + eval.energy);
        out.inverted |= !(ratio > MIN_AREA_RATIO);
        for &(l, follower) in &adj.pressures[e] {
            let value = model.load_value(l, u, loads);
            let (f, kp) = pressure_contribution(model, e, u, value, follower, want_k);
            out.r -= f;
            if let Some(kp) = kp {
                out.k += kp.fixed_view::<3, 3>(3 * a, 3 * a);
                out.potential = None;
            } else if follower {
                out.potential = None;
            } else {
                out.potential = out.potential.map(|p| p - f.dot(&displacement(u, node)));
            }
        }
    }
}

/// Two-node elements at a node ((force, tangent, energy), the node's local index) into its
/// rows and block.
fn local_lines(lines: impl Iterator<Item = ((Vec6, Mat6, f64), usize)>, out: &mut Local) {
    for ((f, k, w), a) in lines {
        out.r += f.fixed_rows::<3>(3 * a);
        out.k += k.fixed_view::<3, 3>(3 * a, 3 * a);
        out.potential = out.potential.map(|p| p + w);
    }
}

/// What the global iteration holds for the relaxation: its frozen wrinkle states (None: the
/// law decides) and the prestress continuation's pre-strain (`path.rs`; 0: none), so that
/// relaxation balances the same problem as the Newton iteration around it.
#[derive(Clone, Copy, Debug, Default)]
pub struct Frozen<'a> {
    pub states: Option<&'a [Option<WrinkleState>]>,
    pub pre_strain: f64,
}

impl Frozen<'_> {
    fn aid(&self) -> Aid {
        Aid {
            prestress_factor: 1.0,
            pre_strain: self.pre_strain,
        }
    }
}

fn displacement(u: &[f64], node: usize) -> Vector3<f64> {
    Vector3::new(u[3 * node], u[3 * node + 1], u[3 * node + 2])
}

/// Relax each node of `nodes` in turn (free components only, `held` per DOF), adding to
/// `evaluated` the element evaluations it made (what it cost: `Solver::relax` counts it in
/// the step's whole work). Returns the number of nodes that moved.
#[allow(clippy::too_many_arguments)]
pub fn relax_nodes(
    model: &Model,
    adj: &Adjacency,
    u: &mut [f64],
    loads: &[f64],
    nodes: &[usize],
    forced: Frozen,
    target: f64,
    evaluated: &mut usize,
) -> usize {
    let mut moved = 0;
    for &node in nodes {
        // The node's free components (no allocation per node).
        let (mut comps, mut k) = ([0usize; 3], 0);
        for c in (0..3).filter(|&c| !model.held[3 * node + c]) {
            comps[k] = c;
            k += 1;
        }
        let free = &comps[..k];
        if free.is_empty() {
            continue;
        }
        let mut changed = false;
        for _ in 0..LOCAL_ITERATIONS {
            let here = local(model, adj, u, loads, node, forced, true);
            *evaluated += here.evaluated;
            let norm = free.iter().fold(0.0f64, |m, &c| m.max(here.r[c].abs()));
            if norm <= target {
                break;
            }
            let Some(step) = newton_step(&here, free) else {
                break;
            };
            if !line_search(model, adj, u, loads, node, forced, &here, &step, evaluated) {
                break;
            }
            changed = true;
        }
        moved += changed as usize;
    }
    moved
}

/// Δ = −K⁻¹ r on the free components (a tiny diagonal shift keeps a singular block solvable).
fn newton_step(here: &Local, free: &[usize]) -> Option<Vector3<f64>> {
    let mut k = Matrix3::identity();
    let mut r = Vector3::zeros();
    for &a in free {
        r[a] = here.r[a];
        for &b in free {
            k[(a, b)] = here.k[(a, b)];
        }
    }
    let shift = 1e-12
        * free
            .iter()
            .map(|&c| here.k[(c, c)].abs())
            .fold(0.0, f64::max);
    for &a in free {
        k[(a, a)] += shift;
    }
    let step = -(k.try_inverse()? * r);
    step.iter().all(|v| v.is_finite()).then_some(step)
}

/// The node's line search: the slope search of the global iteration (`line_search.rs`,
/// `bracket_slope`) on s(α) = Δ·r(x + αΔ), with more tries, as a node's evaluations are cheap.
/// A slack node's Newton step (its tangent holds only the regularisation) overshoots far into
/// the region where its triangles turn taut; halving from the full step then crept toward that
/// border by factors of two, while the bracket finds the line's minimum near the border in a
/// few secant steps. The potential is not used: for the nearly stress-free nodes this is for,
/// its change along a step (1e-22 J against 8e-10 J in the 0.1 mm film) is below its round-off.
#[allow(clippy::too_many_arguments)]
fn line_search(
    model: &Model,
    adj: &Adjacency,
    u: &mut [f64],
    loads: &[f64],
    node: usize,
    forced: Frozen,
    here: &Local,
    step: &Vector3<f64>,
    evaluated: &mut usize,
) -> bool {
    let start = displacement(u, node);
    let s0 = here.r.dot(step);
    if s0.is_nan() || s0 >= 0.0 {
        // Not a descent direction (an indefinite block: a wrinkled triangle's tangent, a
        // follower pressure's unsymmetric part): the search would take the full step untried.
        return false;
    }
    let (alpha, met) = bracket_slope(s0, LOCAL_TRIES, LOCAL_SLOPE_RATIO, |alpha| {
        for c in 0..3 {
            u[3 * node + c] = start[c] + alpha * step[c];
        }
        // Only the residual along the step: no tangent.
        let trial = local(model, adj, u, loads, node, forced, false);
        *evaluated += trial.evaluated;
        let s = trial.r.dot(step);
        (!trial.inverted && s.is_finite()).then_some(s)
    });
    let alpha = if met { alpha } else { 0.0 };
    for c in 0..3 {
        u[3 * node + c] = start[c] + alpha * step[c];
    }
    met && alpha > 0.0
}

/// Buffers of the patch Newton, reused from call to call (they only grow).
#[derive(Default)]
pub struct PatchWork {
    /// Per element kind, the elements that touch the patch.
    elements: PerKind<Vec<usize>>,
    /// The patch's tangent, row-major (3m x 3m), factored in place by each solve.
    k: Vec<f64>,
    r: Vec<f64>,
    step: Vec<f64>,
    start: Vec<f64>,
    /// (node, its place in the patch) sorted by node: where each node's rows go, for a patch
    /// given in any order (the sweep order, `Pattern::sweep_order`).
    slots: Vec<(usize, usize)>,
}

impl PatchWork {
    /// Room for patches of up to `nodes` nodes (the dense block and vectors; 8 elements of each
    /// kind per node), so that a larger patch met in a later iteration does not allocate
    /// there (`tests/guards/alloc_per_iteration.rs`). Only grows.
    pub fn reserve(&mut self, nodes: usize) {
        let n = 3 * nodes;
        for (v, len) in [
            (&mut self.k, n * n),
            (&mut self.r, n),
            (&mut self.step, n),
            (&mut self.start, n),
        ] {
            v.reserve(len.saturating_sub(v.len()));
        }
        for v in &mut self.elements.0 {
            v.reserve((8 * nodes).saturating_sub(v.len()));
        }
        self.slots.reserve(nodes.saturating_sub(self.slots.len()));
    }
}

/// What a patch Newton did: its iterations and the patch's residual |r|∞ at the end.
#[derive(Clone, Copy, Debug, Default)]
pub struct PatchOutcome {
    pub iterations: usize,
    pub residual: f64,
    /// Element evaluations made (each evaluation of the patch evaluates every element that
    /// touches it): the work it cost.
    pub evaluated: usize,
}

/// Newton on a patch of nodes as a whole, every other node held (a nonlinear elimination of
/// the patch, Cai & Li 2011): the patch's rows of R and its block of K from the same element
/// routines as the global assembly, a dense solve, and the slope search of the global
/// iteration along each step, until the patch's residual is within `target` or `iterations`
/// run out. The tangent's regularisation of wrinkled and slack triangles is `regularization`
/// (the global tangent's is `REGULARIZATION`): the patch is small, so its Newton can afford a
/// nearly singular tangent and the long steps that go with it.
///
/// Why a patch and not node by node: two neighbouring free-edge nodes whose triangles are
/// barely stressed can move together along a direction in which the pair has almost no
/// stiffness while each node alone is stiff. Gauss-Seidel then balances one node, which
/// unbalances the other by nearly as much, and the pair drifts by the same small amount per
/// sweep (measured in the 0.1 mm film: a node's residual came back to 1.3e-8 N after every
/// sweep, against the tolerance 4.6e-9 N). Newton on the pair moves it along that direction at
/// once.
///
/// `nodes` in any order, each once: the unknowns are numbered in that order (a node's place
/// is looked up in `work`'s list sorted by node). Allocates only when `work`'s buffers must
/// grow.
#[allow(clippy::too_many_arguments)]
pub fn relax_patch(
    model: &Model,
    adj: &Adjacency,
    u: &mut [f64],
    loads: &[f64],
    nodes: &[usize],
    forced: Frozen,
    target: f64,
    iterations: usize,
    regularization: f64,
    work: &mut PatchWork,
) -> PatchOutcome {
    let n = 3 * nodes.len();
    let PatchWork {
        elements,
        k,
        r,
        step,
        start,
        slots,
    } = work;
    slots.clear();
    slots.extend(nodes.iter().enumerate().map(|(p, &i)| (i, p)));
    slots.sort_unstable();
    debug_assert!(slots.windows(2).all(|w| w[0].0 < w[1].0));
    for kind in ElementKind::ALL {
        touching(&mut elements[kind], nodes, &adj.elements[kind]);
    }
    let elements = PatchElements {
        nodes,
        slots,
        elements,
        forced,
        regularization,
    };
    r.resize(n, 0.0);
    step.resize(n, 0.0);
    start.resize(n, 0.0);
    k.resize(n * n, 0.0);
    let mut out = PatchOutcome::default();
    let per_evaluation: usize = ElementKind::ALL
        .iter()
        .map(|&kind| elements.elements[kind].len())
        .sum();
    let mut evaluated = 0;
    for it in 0..=iterations {
        elements.evaluate(model, adj, u, loads, r, Some(k));
        evaluated += per_evaluation;
        out = PatchOutcome {
            iterations: it,
            residual: r.iter().fold(0.0f64, |m, v| m.max(v.abs())),
            evaluated,
        };
        if out.residual <= target || it == iterations {
            break;
        }
        // Δ = −K⁻¹ r, a tiny diagonal shift keeping a singular block solvable (as per node).
        let shift = 1e-12 * (0..n).map(|d| k[d * n + d].abs()).fold(0.0, f64::max);
        for d in 0..n {
            k[d * n + d] += shift;
            step[d] = -r[d];
        }
        if !dense_solve(k, step) || step.iter().any(|v| !v.is_finite()) {
            break;
        }
        for (d, x) in start.iter_mut().enumerate() {
            *x = u[3 * nodes[d / 3] + d % 3];
        }
        let place = |u: &mut [f64], alpha: f64| {
            for (d, (&x, &s)) in start.iter().zip(step.iter()).enumerate() {
                u[3 * nodes[d / 3] + d % 3] = x + alpha * s;
            }
        };
        let s0: f64 = r.iter().zip(step.iter()).map(|(a, b)| a * b).sum();
        let (alpha, met) = bracket_slope(s0, LOCAL_TRIES, LOCAL_SLOPE_RATIO, |alpha| {
            place(u, alpha);
            let inverted = elements.evaluate(model, adj, u, loads, r, None);
            evaluated += per_evaluation;
            out.evaluated = evaluated;
            let s: f64 = r.iter().zip(step.iter()).map(|(a, b)| a * b).sum();
            (!inverted && s.is_finite()).then_some(s)
        });
        let alpha = if met { alpha } else { 0.0 };
        place(u, alpha);
        if alpha == 0.0 {
            break;
        }
    }
    out
}

/// The elements (sorted, each once) that touch any of `nodes`, from an adjacency list.
fn touching(list: &mut Vec<usize>, nodes: &[usize], of: &Lists<(usize, usize)>) {
    list.clear();
    list.extend(nodes.iter().flat_map(|&i| of[i].iter().map(|&(e, _)| e)));
    list.sort_unstable();
    list.dedup();
}

/// The elements of a patch and how they are evaluated.
struct PatchElements<'a> {
    nodes: &'a [usize],
    /// (node, place in `nodes`) sorted by node.
    slots: &'a [(usize, usize)],
    /// Per element kind, the elements that touch the patch (sorted, each once).
    elements: &'a PerKind<Vec<usize>>,
    forced: Frozen<'a>,
    regularization: f64,
}

impl PatchElements<'_> {
    /// The patch's rows of R into `r` and, when given, its block of K into `k` (row-major);
    /// held DOFs get r = 0 and an identity row and column. Returns whether a triangle is
    /// inverted (or too thin, `MIN_AREA_RATIO`).
    fn evaluate(
        &self,
        model: &Model,
        adj: &Adjacency,
        u: &[f64],
        loads: &[f64],
        r: &mut [f64],
        mut k: Option<&mut Vec<f64>>,
    ) -> bool {
        let n = r.len();
        let slots = self.slots;
        let slot = |i: usize| {
            slots
                .binary_search_by_key(&i, |&(node, _)| node)
                .ok()
                .map(|k| slots[k].1)
        };
        r.fill(0.0);
        if let Some(k) = k.as_deref_mut() {
            k.fill(0.0);
        }
        // Add one element's force f (nodes `on`) and stiffness ke (dimension 3·on.len()).
        let mut add =
            |on: &[usize], f: &[f64], ke: Option<&[f64]>, k: &mut Option<&mut Vec<f64>>| {
                let dim = 3 * on.len();
                for (a, &i) in on.iter().enumerate() {
                    let Some(p) = slot(i) else { continue };
                    for c in 0..3 {
                        r[3 * p + c] += f[3 * a + c];
                    }
                    let (Some(ke), Some(k)) = (ke, k.as_deref_mut()) else {
                        continue;
                    };
                    for (b, &j) in on.iter().enumerate() {
                        let Some(q) = slot(j) else { continue };
                        for c in 0..3 {
                            for d in 0..3 {
                                // nalgebra's matrices are column-major.
                                k[(3 * p + c) * n + 3 * q + d] += ke[(3 * b + d) * dim + 3 * a + c];
                            }
                        }
                    }
                }
            };
        let want_k = k.is_some();
        let mut inverted = false;
        let mut ke = Mat9::zeros();
        for kind in ElementKind::ALL {
            let list = &self.elements[kind];
            match kind {
                ElementKind::Membrane => {
                    for &e in list {
                        let state = self.forced.states.and_then(|f| f[e]);
                        let (f, _, ratio) = triangle_contribution(
                            model,
                            e,
                            u,
                            self.forced.aid(),
                            state,
                            want_k.then_some(&mut ke),
                            self.regularization,
                        );
                        inverted |= !(ratio > MIN_AREA_RATIO);
                        let on = &model.triangles[e].nodes;
                        add(on, f.as_slice(), want_k.then_some(ke.as_slice()), &mut k);
                        for &(l, follower) in &adj.pressures[e] {
                            let value = model.load_value(l, u, loads);
                            let (f, kp) =
                                pressure_contribution(model, e, u, value, follower, want_k);
                            let f = [-f.x, -f.y, -f.z, -f.x, -f.y, -f.z, -f.x, -f.y, -f.z];
                            add(on, &f, kp.as_ref().map(|kp| kp.as_slice()), &mut k);
                        }
                    }
                }
                ElementKind::Cable => {
                    for &e in list {
                        let (f, ks, _) = segment_contribution(model, e, u);
                        let on = &model.segments[e].nodes;
                        add(on, f.as_slice(), Some(ks.as_slice()), &mut k);
                    }
                }
                ElementKind::Tie => {
                    for &e in list {
                        let (f, kt, _) = tie_contribution(model, e, u);
                        add(
                            &model.ties[e].nodes,
                            f.as_slice(),
                            Some(kt.as_slice()),
                            &mut k,
                        );
                    }
                }
                ElementKind::ContactPair => {
                    for &e in list {
                        let (f, kc, _) = model.pair_contribution(e, u);
                        let on = &model.contact_pairs[e].nodes;
                        add(on, f.as_slice(), Some(kc.as_slice()), &mut k);
                    }
                }
                ElementKind::ContactPoint => {
                    for &e in list {
                        let (f, kc, _) = model.point_contribution(e, u);
                        let on = &model.contact_points[e].nodes;
                        add(on, f.as_slice(), Some(kc.as_slice()), &mut k);
                    }
                }
            }
        }
        for (p, &i) in self.nodes.iter().enumerate() {
            for &(l, c, f) in &adj.forces[i] {
                r[3 * p + c] -= f * loads[l];
            }
        }
        for d in 0..n {
            if model.held[3 * self.nodes[d / 3] + d % 3] {
                r[d] = 0.0;
                if let Some(k) = k.as_deref_mut() {
                    for j in 0..n {
                        k[d * n + j] = 0.0;
                        k[j * n + d] = 0.0;
                    }
                    k[d * n + d] = 1.0;
                }
            }
        }
        inverted
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::solver::core::Solver;
    use crate::solver::settings::Settings;

    fn model(name: &str, rings: Option<usize>) -> Model {
        let path = format!(
            "{}/modelDescription/{name}/scene.json",
            env!("CARGO_MANIFEST_DIR")
        );
        let mut value: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
        if let Some(rings) = rings {
            value["geometry"]["generators"][0]["rings"] = rings.into();
        }
        let scene = crate::scene::Scene::from_json(&value.to_string()).unwrap();
        Model::try_build(&scene).unwrap()
    }

    /// The adjacency built from its copied input (on the solver's helper with two threads)
    /// is the model's, list for list: shipped scenes with cables, sleeve ties, follower and
    /// dead pressures, a gas volume and point forces.
    #[test]
    fn the_adjacency_from_its_copied_input_is_the_models() {
        for name in [
            "SleeveCable",
            "SlidingCable",
            "EtfeGasCushion",
            "FourPointSail",
            "HenckyDisc",
            "PrestressedCable",
        ] {
            let model = model(name, None);
            let serial = Adjacency::try_new(&model).unwrap();
            assert!(
                !serial.elements[ElementKind::Membrane].items.is_empty()
                    || model.triangles.is_empty()
            );
            let built = Adjacency::input(&model).unwrap().build().unwrap();
            assert_eq!(built, serial, "{name}");
        }
        // A solver on two threads (its helper built the lists) holds one thread's.
        let model = model("HenckyDisc", Some(64));
        let settings = |threads| Settings {
            threads,
            ..Settings::default()
        };
        let two = Solver::try_new(&model, settings(2)).unwrap();
        assert!(two.pool().is_some(), "the disc is split on two threads");
        let one = Solver::try_new(&model, settings(1)).unwrap();
        assert_eq!(two.adjacency, one.adjacency);
        assert_eq!(two.adjacency, Adjacency::try_new(&model).unwrap());
    }
}
