//! Nodal relaxation: equilibrate single nodes with all other nodes held.
//!
//! ```text
//! for a node i:  Π_i(x_i) = Σ_{e ∋ i} W_e − f_dead·u_i      (its elements' energy and its loads)
//!                r_i = ∂Π_i/∂x_i (the node's rows of R),  K_ii (its 3x3 diagonal block of K)
//!                damped Newton on the free components: Δ = −K_ii⁻¹ r_i, Armijo on Π_i
//! ```
//! Used by Newton when the global step stalls: a node held only by nearly stress-free wrinkled
//! or slack triangles (free-edge corners of a sheared sheet) sits on a near-mechanism whose
//! tangent is valid only over strain changes of the size of its tiny strains, so every global
//! step overshoots there and the line search then shortens the step everywhere. Solving those
//! few nodes locally (nonlinear Gauss-Seidel, a nonlinear elimination of the bad unknowns) costs
//! assemblies of a handful of elements, no factorization, and never raises the potential.
//! The equilibrium sought is unchanged: only the path to it.
//!
//! # References
//! Cai & Li 2011, *Inexact Newton methods with restricted additive Schwarz based nonlinear
//! elimination*, SIAM J. Sci. Comput. 33:746-762; Brandt 1977 (nonlinear Gauss-Seidel
//! smoothing); docs/mechanics.md (slack and wrinkled near-mechanisms).

use super::assemble::{
    pressure_contribution, segment_contribution, tie_contribution, triangle_contribution,
};
use crate::memory::{self, OutOfMemory};
use crate::model::membrane::Mat9;
use crate::model::wrinkling::WrinkleState;
use crate::model::{LoadModel, Model};
use nalgebra::{Matrix3, Vector3};

/// What touches a node: (element, local index) for triangles, segments and ties.
#[derive(Clone, Debug, Default)]
pub struct Adjacency {
    triangles: Lists<(usize, usize)>,
    segments: Lists<(usize, usize)>,
    ties: Lists<(usize, usize)>,
    /// Per triangle: (load index, follower) of the pressures acting on it.
    pressures: Lists<(usize, bool)>,
    /// Per node: (load index, component, force per unit load value).
    forces: Lists<(usize, usize, f64)>,
}

/// Per key (a node or a triangle) a list of items, stored flat: one offset array and one item
/// array, both allocated fallibly (`crate::memory`), in the order the pairs come.
#[derive(Clone, Debug, Default)]
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
/// Backtracking halvings of one local step.
const LOCAL_HALVINGS: usize = 30;

impl Adjacency {
    pub fn try_new(model: &Model) -> Result<Adjacency, OutOfMemory> {
        let n = model.reference.len();
        Ok(Adjacency {
            triangles: Lists::try_build(n, || {
                model
                    .triangles
                    .iter()
                    .enumerate()
                    .flat_map(|(e, t)| t.nodes.iter().enumerate().map(move |(k, &i)| (i, (e, k))))
            })?,
            segments: Lists::try_build(n, || {
                model
                    .segments
                    .iter()
                    .enumerate()
                    .flat_map(|(e, s)| s.nodes.iter().enumerate().map(move |(k, &i)| (i, (e, k))))
            })?,
            ties: Lists::try_build(n, || {
                model
                    .ties
                    .iter()
                    .enumerate()
                    .flat_map(|(e, t)| t.nodes.iter().enumerate().map(move |(k, &i)| (i, (e, k))))
            })?,
            pressures: Lists::try_build(model.triangles.len(), || {
                model.loads.iter().enumerate().flat_map(|(l, load)| {
                    let (triangles, follower): (&[usize], bool) = match load {
                        LoadModel::Pressure {
                            triangles,
                            follower,
                        } => (triangles, *follower),
                        // Gas pressure of an enclosed volume: a follower pressure.
                        LoadModel::Volume { triangles, .. } => (triangles, true),
                        _ => (&[], false),
                    };
                    triangles.iter().map(move |&e| (e, (l, follower)))
                })
            })?,
            forces: Lists::try_build(n, || {
                model.loads.iter().enumerate().flat_map(|(l, load)| {
                    let dofs: &[(usize, f64)] = match load {
                        LoadModel::PointForce(dofs) => dofs,
                        _ => &[],
                    };
                    dofs.iter().map(move |&(d, f)| (d / 3, (l, d % 3, f)))
                })
            })?,
        })
    }
}

/// One node's residual rows, diagonal tangent block and local potential (None with follower
/// pressure, which has no potential).
struct Local {
    r: Vector3<f64>,
    k: Matrix3<f64>,
    potential: Option<f64>,
    inverted: bool,
}

/// The node's rows of R and its 3x3 diagonal block of K, from the same element routines as
/// the global assembly (`super::assemble`), so ties and slipped cable lengths are included.
fn local(
    model: &Model,
    adj: &Adjacency,
    u: &[f64],
    loads: &[f64],
    node: usize,
    forced: Option<&[Option<WrinkleState>]>,
) -> Local {
    let mut out = Local {
        r: Vector3::zeros(),
        k: Matrix3::zeros(),
        potential: Some(0.0),
        inverted: false,
    };
    let mut ke = Mat9::zeros();
    for &(e, a) in &adj.triangles[node] {
        let state = forced.and_then(|f| f[e]);
        let (f, eval, ratio) = triangle_contribution(model, e, u, 1.0, state, Some(&mut ke));
        out.r += f.fixed_rows::<3>(3 * a);
        out.k += ke.fixed_view::<3, 3>(3 * a, 3 * a);
        out.potential = out.potential.map(|p| p + eval.energy);
        out.inverted |= !(ratio > super::MIN_AREA_RATIO);
        for &(l, follower) in &adj.pressures[e] {
            let value = model.load_value(l, u, loads);
            let (f, kp) = pressure_contribution(model, e, u, value, follower, true);
            out.r -= f;
            if let Some(kp) = kp {
                out.k += kp.fixed_view::<3, 3>(3 * a, 3 * a);
                out.potential = None;
            } else {
                out.potential = out.potential.map(|p| p - f.dot(&displacement(u, node)));
            }
        }
    }
    let lines = adj.segments[node]
        .iter()
        .map(|&(e, a)| (segment_contribution(model, e, u), a))
        .chain(
            adj.ties[node]
                .iter()
                .map(|&(e, a)| (tie_contribution(model, e, u), a)),
        );
    for ((f, k, w), a) in lines {
        out.r += f.fixed_rows::<3>(3 * a);
        out.k += k.fixed_view::<3, 3>(3 * a, 3 * a);
        out.potential = out.potential.map(|p| p + w);
    }
    for &(l, c, f) in &adj.forces[node] {
        out.r[c] -= f * loads[l];
        out.potential = out.potential.map(|p| p - f * loads[l] * u[3 * node + c]);
    }
    out
}

fn displacement(u: &[f64], node: usize) -> Vector3<f64> {
    Vector3::new(u[3 * node], u[3 * node + 1], u[3 * node + 2])
}

/// Relax each node of `nodes` in turn (free components only, `held` per DOF). Returns the
/// number of nodes that moved.
pub fn relax_nodes(
    model: &Model,
    adj: &Adjacency,
    u: &mut [f64],
    loads: &[f64],
    nodes: &[usize],
    forced: Option<&[Option<WrinkleState>]>,
    target: f64,
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
            let here = local(model, adj, u, loads, node, forced);
            let norm = free.iter().fold(0.0f64, |m, &c| m.max(here.r[c].abs()));
            if norm <= target {
                break;
            }
            let Some(step) = newton_step(&here, free) else {
                break;
            };
            if !line_search(model, adj, u, loads, node, forced, &here, &step, norm) {
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

/// Backtrack along `step` until the local potential drops (Armijo) or, without a potential,
/// the local residual shrinks. Leaves `u` at the accepted point; false if none was found.
#[allow(clippy::too_many_arguments)]
fn line_search(
    model: &Model,
    adj: &Adjacency,
    u: &mut [f64],
    loads: &[f64],
    node: usize,
    forced: Option<&[Option<WrinkleState>]>,
    here: &Local,
    step: &Vector3<f64>,
    norm: f64,
) -> bool {
    let start = displacement(u, node);
    let slope = here.r.dot(step);
    let mut alpha = 1.0;
    for _ in 0..LOCAL_HALVINGS {
        for c in 0..3 {
            u[3 * node + c] = start[c] + alpha * step[c];
        }
        let trial = local(model, adj, u, loads, node, forced);
        let ok = !trial.inverted
            && match (here.potential, trial.potential) {
                // Below its round-off the potential cannot rank the points: the residual does.
                (Some(p0), Some(p1)) if (p1 - p0).abs() > 1e-13 * p0.abs() => {
                    p1 - p0 <= 1e-4 * alpha * slope
                }
                _ => trial.r.amax() < norm,
            };
        if ok {
            return true;
        }
        alpha *= 0.5;
    }
    for c in 0..3 {
        u[3 * node + c] = start[c];
    }
    false
}
