//! What a failed step knows about the structure. A mechanism (a finite motion that strains no
//! element and that no support stops) on which the loads do work has no equilibrium where it
//! stands: the loads move it along that motion. It is named only once verified; otherwise the
//! message says what the tangent at the last converged point shows and what was checked, and
//! never calls the structure a mechanism.
//!
//! ```text
//! 0 squeezed  the triangle with the smallest signed area ratio at the last converged point,
//!             named when below 3/4 of its reference area (a fact, not a diagnosis: a
//!             tension-only film does not resist being gathered, and a gathering that goes
//!             on ends in a collapsed triangle, which no answer may have; the drawstrings of
//!             docs/robustness.md stop so)
//! 1 rigid     parts (every element joins its nodes: triangles, cable segments, sleeve ties)
//!             at their current positions x (the last converged point), rigid modes
//!             v(x) = t + ω × (x − c): 6 columns per node, [I, −[(x − c)/L]×] (L: part size)
//!             free:   rank of the modes over all the part's DOFs > rank over its held DOFs
//!             loaded: the loads of the failed increment (pressures on the current geometry)
//!                     do work on a free motion, g = Σ f·v ≠ 0 (a free motion the loads
//!                     balance, e.g. a rotation of a symmetrically loaded ring about a point
//!                     no support holds, is harmless and not reported)
//!             A rigid motion changes no strain to any order: free and loaded, it is named.
//! 2 tangent   the physical tangent K of the displacements (no artificial prestress, no
//!             damping; slips and volume pressures held) at the last converged point under
//!             the failed increment's loads, by inverse iteration from the out-of-balance
//!             force: v ← (K + σD)⁻¹ v, normalized (3 solves; D the elastic diagonal, every
//!             element taut; σ = 1e-10 lets a tangent with no stiffness at all factor), and
//!             ρ = |vᵀKv| / vᵀDv. ρ < 1e-6: the tangent is near-singular, and the nodes v
//!             moves most are named (nothing is said otherwise).
//! 3 finite    whether the nodes v moves (|v_i| >= 1e-3 max, at most 64 of them, with up to
//!             two rings of neighbours while within 64) have a finite motion the loads push
//!             along. Constraints c(x): the squared length of every cable segment and
//!             triangle edge they touch (a triangle keeping its three edges keeps its strain),
//!             the gap vector of every sleeve tie and closed link, the volume of a volume
//!             input's triangles; the unknowns: their free components, every other node, held
//!             DOF and slip fixed. The loads' direction among the motions that keep c to first
//!             order, t = P f (P the projection on the null space of ∂c/∂x), is followed as a
//!             curve c(x) = c(x0) by pseudo-arclength continuation (Gauss–Newton corrector,
//!             steps of 1/16 of the curve halved down to 1/256) over 5 % of the elements'
//!             median length, every point within 1e-10 of each squared length (relative; a
//!             gap against that length, a volume against its area times that length).
//!             Followed to its end: named a mechanism, with the nodes it moved. Otherwise the
//!             message says which check failed: the loads push along no motion that keeps the
//!             lengths to first order (then also whether v itself changes lengths at first
//!             order: the tangent has no stiffness against it there, slack or wrinkled
//!             elements or a limit point), or the first-order motion does not extend (it
//!             strains the elements at second order: tension or a change of shape stiffens it,
//!             as a node pushed sideways on a straight cable or a flat membrane pushed out of
//!             its plane).
//! ```
//! A sliding motion of sleeve points is never named (slips are held throughout).
//!
//! # References
//! Pellegrino & Calladine 1986, Int. J. Solids Struct. 22:409–428 (matrix analysis of
//! statically and kinematically indeterminate frameworks: inextensional mechanisms, first
//! order and finite); Allgower & Georg 2003, *Introduction to Numerical Continuation Methods*,
//! ch. 2 (pseudo-arclength predictor-corrector).

use super::assemble::{self, NONE};
use super::core::Solver;
use crate::model::{ElementKind, LoadModel, Model};
use nalgebra::{DMatrix, DVector, Matrix3, Matrix6, SMatrix, Vector3};
use std::collections::{BTreeMap, BTreeSet};

/// Share of its reference area below which a triangle at the last converged point of a failed
/// step is named (module docs, 0).
const SQUEEZED: f64 = 0.75;

/// Longest list of node ids a message names.
const NAMED_NODES: usize = 12;
/// Rayleigh quotient of the tangent against the elastic diagonal below which the tangent is
/// called near-singular.
const NEAR_SINGULAR: f64 = 1e-6;
/// Inverse-iteration solves.
const INVERSE_ITERATIONS: usize = 3;
/// Shift σ of the inverse iteration's K + σD (D the elastic diagonal): far below
/// [`NEAR_SINGULAR`], and a tangent with no stiffness at all factors.
const SHIFT: f64 = 1e-10;
/// Share of the largest nodal motion from which a node counts as moved.
const MOVED: f64 = 1e-3;
/// Most nodes whose motion is checked for a finite mechanism (a dense problem of 3 unknowns
/// per node).
const CHECKED_NODES: usize = 64;
/// Rings of neighbours added to the moved nodes for the finite-motion check.
const NEIGHBOUR_RINGS: usize = 2;
/// Length of the followed curve, as a share of the elements' median length.
const PATH_LENGTH: f64 = 0.05;
/// Steps of the curve at full length, and the shortest step as a share of the curve.
const PATH_STEPS: f64 = 16.0;
const SHORTEST_STEP: f64 = 1.0 / 256.0;
/// Largest relative change of a constraint on the curve.
const KEPT: f64 = 1e-10;
/// Share of the loads' norm the work on a motion must exceed to count as pushing along it.
const LOADED: f64 = 1e-6;
/// Share of the moving nodes' motion that the first-order projection keeps, below which the
/// motion strains the elements at first order.
const FIRST_ORDER_KEPT: f64 = 0.1;

/// External forces per DOF under `loads` at the current positions of `u` (displacements, then
/// slips and volume pressures): follower pressures and volume pressures on the current
/// triangles, dead pressures on the reference ones, point forces as given.
pub fn external_forces_at(model: &Model, u: &[f64], loads: &[f64]) -> Vec<f64> {
    let mut f = vec![0.0f64; model.dof_count()];
    for (l, load) in model.loads.iter().enumerate() {
        if let LoadModel::PointForce(dofs) = load {
            let value = model.load_value(l, u, loads);
            for &(d, unit) in dofs {
                f[d] += unit * value;
            }
            continue;
        }
        let Some(how) = assemble::Pressing::of(load) else {
            continue;
        };
        let value = model.load_value(l, u, loads);
        for &e in assemble::pressed_triangles(load) {
            let (share, _) = assemble::pressing_contribution(model, e, u, value, how, false);
            for (&i, share) in model.triangles[e].nodes.iter().zip(&share) {
                for c in 0..3 {
                    f[3 * i + c] += share[c];
                }
            }
        }
    }
    f
}

/// The parts of the model: node lists (ascending) of the sets every element joins.
fn parts(model: &Model) -> Vec<Vec<usize>> {
    let n = model.reference.len();
    let mut parent: Vec<usize> = (0..n).collect();
    fn find(p: &mut [usize], mut i: usize) -> usize {
        while p[i] != i {
            p[i] = p[p[i]];
            i = p[i];
        }
        i
    }
    let mut used = vec![false; n];
    for (kind, e) in model.elements() {
        let nodes = model.element_nodes(kind, e);
        for &i in &nodes[1..] {
            let (ra, rb) = (find(&mut parent, nodes[0]), find(&mut parent, i));
            if ra != rb {
                parent[ra] = rb;
            }
        }
        nodes.iter().for_each(|&i| used[i] = true);
    }
    let mut parts: BTreeMap<usize, Vec<usize>> = Default::default();
    for i in (0..n).filter(|&i| used[i]) {
        parts.entry(find(&mut parent, i)).or_default().push(i);
    }
    parts.into_values().collect()
}

/// "a, b, c" of at most [`NAMED_NODES`] ids, then "… (N nodes)".
fn name_nodes(nodes: &[usize]) -> String {
    let mut ids: Vec<String> = nodes
        .iter()
        .take(NAMED_NODES)
        .map(|i| i.to_string())
        .collect();
    if nodes.len() > NAMED_NODES {
        ids.push(format!("… ({} nodes)", nodes.len()));
    }
    ids.join(", ")
}

/// A sentence naming a part of the model that can move as a rigid body, at the current
/// positions of `u`, with no support to stop it while the external forces `f_ext` (per DOF, on
/// the current geometry: [`external_forces_at`]) do work on that motion, or None.
pub fn diagnose(model: &Model, u: &[f64], f_ext: &[f64]) -> Option<String> {
    for nodes in parts(model) {
        let x: Vec<Vector3<f64>> = nodes.iter().map(|&i| model.position(u, i)).collect();
        let c: Vector3<f64> = x.iter().sum::<Vector3<f64>>() / nodes.len() as f64;
        let size = x
            .iter()
            .map(|p| (p - c).norm())
            .fold(0.0, f64::max)
            .max(f64::MIN_POSITIVE);
        let (mut all, mut held) = (Matrix6::<f64>::zeros(), Matrix6::<f64>::zeros());
        // Generalized load (work on each rigid mode) and the size of the loads on the part.
        let (mut work, mut load) = (nalgebra::Vector6::<f64>::zeros(), 0.0f64);
        for (&i, p) in nodes.iter().zip(&x) {
            let r = (p - c) / size;
            let mut m = SMatrix::<f64, 3, 6>::zeros();
            m.fixed_view_mut::<3, 3>(0, 0)
                .copy_from(&Matrix3::identity());
            m.fixed_view_mut::<3, 3>(0, 3)
                .copy_from(&(-r.cross_matrix()));
            for comp in 0..3 {
                let row = m.row(comp).transpose();
                let g = row * row.transpose();
                all += g;
                if model.held[3 * i + comp] {
                    held += g;
                } else {
                    let f = f_ext.get(3 * i + comp).copied().unwrap_or(0.0);
                    work += row * f;
                    load += f.abs();
                }
            }
        }
        let top = all.symmetric_eigenvalues().amax();
        let free = rank(&all, top) - rank(&held, top);
        // The free motions: directions the held DOFs do not see but the part's nodes do.
        let eig = held.symmetric_eigen();
        let loaded = (0..6).any(|k| {
            let v = eig.eigenvectors.column(k);
            let moves = (all * v).norm() > 1e-10 * top;
            eig.eigenvalues[k] <= 1e-10 * top && moves && v.dot(&work).abs() > 1e-9 * load
        });
        if free > 0 && loaded {
            return Some(format!(
                "the structure is a mechanism: nodes {} form a part with {free} rigid-body motion{} that no support stops and the loads push along (fix more components of its nodes, or connect it to a supported part)",
                name_nodes(&nodes),
                if free == 1 { "" } else { "s" }
            ));
        }
    }
    None
}

/// Numerical rank of a symmetric positive semi-definite 6x6 matrix, eigenvalues counted above
/// 1e-10 of `top`.
fn rank(g: &Matrix6<f64>, top: f64) -> usize {
    g.symmetric_eigenvalues()
        .iter()
        .filter(|&&v| v > 1e-10 * top)
        .count()
}

/// One constraint of the finite-motion check (module docs, 3).
enum Constraint {
    /// Squared distance of two nodes (a cable segment, a triangle edge).
    Length(usize, usize),
    /// Gap vector between two nodes (a sleeve tie, a closed link): three rows.
    Gap(usize, usize),
    /// Volume under the listed triangles (those of a volume input that touch the moving
    /// nodes; the others do not move).
    Volume(Vec<usize>),
}

/// What the finite-motion check found (module docs, 3).
#[derive(Debug, PartialEq)]
enum Finite {
    /// A curve that keeps every constraint, followed over `length` (m), the loads pushing
    /// along it; the nodes it moved.
    Mechanism { length: f64, moved: Vec<usize> },
    /// The loads push along no first-order motion of the nodes; whether the candidate itself
    /// keeps the lengths to first order.
    Unloaded { first_order: bool },
    /// The loads push along a first-order motion that stops after `reached` of the asked
    /// `length` (m): no point `step` (m) further keeps the constraints, the nearest found
    /// changes one by `nearest` (relative; infinite: the curve turned back or lost its
    /// first-order motion).
    FirstOrderOnly {
        reached: f64,
        length: f64,
        step: f64,
        nearest: f64,
    },
    /// Not checked, and why.
    NotChecked(String),
}

/// The constraints on the moving nodes `moving`: every element touching them (membrane edges
/// and cable segments deduplicated) and every volume input's touching triangles.
fn constraints(model: &Model, u: &[f64], moving: &BTreeSet<usize>) -> Vec<Constraint> {
    let touches = |nodes: &[usize]| nodes.iter().any(|i| moving.contains(i));
    let mut lengths: BTreeSet<(usize, usize)> = BTreeSet::new();
    let mut gaps: BTreeSet<(usize, usize)> = BTreeSet::new();
    let pair = |a: usize, b: usize| (a.min(b), a.max(b));
    for (kind, e) in model.elements() {
        let nodes = model.element_nodes(kind, e);
        if !touches(nodes) {
            continue;
        }
        match kind {
            ElementKind::Membrane => {
                for k in 0..3 {
                    lengths.insert(pair(nodes[k], nodes[(k + 1) % 3]));
                }
            }
            ElementKind::Cable => {
                if model.segment_closed(u, e) {
                    gaps.insert((nodes[0], nodes[1]));
                } else {
                    lengths.insert(pair(nodes[0], nodes[1]));
                }
            }
            ElementKind::Tie => {
                gaps.insert((nodes[0], nodes[1]));
            }
            // Unilateral: no constraint while apart, so none for the mechanism count.
            ElementKind::ContactPair | ElementKind::ContactPoint => {}
        }
    }
    let mut out: Vec<Constraint> = lengths
        .into_iter()
        .map(|(a, b)| Constraint::Length(a, b))
        .collect();
    out.extend(gaps.into_iter().map(|(a, b)| Constraint::Gap(a, b)));
    for load in &model.loads {
        if let LoadModel::Volume { triangles, .. } = load {
            let touching: Vec<usize> = triangles
                .iter()
                .copied()
                .filter(|&e| touches(&model.triangles[e].nodes))
                .collect();
            if !touching.is_empty() {
                out.push(Constraint::Volume(touching));
            }
        }
    }
    out
}

/// The constraint problem of the finite-motion check: unknowns (free components of the moving
/// nodes, in units of `scale`), positions of every node the constraints touch.
struct Linkage<'a> {
    model: &'a Model,
    constraints: Vec<Constraint>,
    /// (node, component) of every unknown.
    unknowns: Vec<(usize, usize)>,
    /// Unknown index of (node, component), if it is one.
    index: BTreeMap<(usize, usize), usize>,
    /// Start positions of every touched node.
    start: BTreeMap<usize, Vector3<f64>>,
    /// Per constraint row: its value at the start and its scale.
    reference: Vec<(f64, f64)>,
    /// Length unit of the unknowns (the elements' median length).
    scale: f64,
}

impl<'a> Linkage<'a> {
    fn new(model: &'a Model, u: &[f64], moving: &BTreeSet<usize>) -> Linkage<'a> {
        let constraints = constraints(model, u, moving);
        let mut start = BTreeMap::new();
        let mut touch = |i: usize| {
            start.entry(i).or_insert_with(|| model.position(u, i));
        };
        for c in &constraints {
            match c {
                Constraint::Length(a, b) | Constraint::Gap(a, b) => {
                    touch(*a);
                    touch(*b);
                }
                Constraint::Volume(tris) => {
                    tris.iter()
                        .flat_map(|&e| model.triangles[e].nodes)
                        .for_each(&mut touch);
                }
            }
        }
        moving.iter().for_each(|&i| touch(i));
        let mut lengths: Vec<f64> = constraints
            .iter()
            .filter_map(|c| match c {
                Constraint::Length(a, b) => Some((start[b] - start[a]).norm()),
                _ => None,
            })
            .filter(|l| *l > 0.0)
            .collect();
        lengths.sort_by(f64::total_cmp);
        let scale = lengths
            .get(lengths.len() / 2)
            .copied()
            .unwrap_or(model.length_scale)
            .max(f64::MIN_POSITIVE);
        let mut unknowns = Vec::new();
        let mut index = BTreeMap::new();
        for &i in moving {
            for c in 0..3 {
                if !model.held[3 * i + c] {
                    index.insert((i, c), unknowns.len());
                    unknowns.push((i, c));
                }
            }
        }
        let mut linkage = Linkage {
            model,
            constraints,
            unknowns,
            index,
            start,
            reference: Vec::new(),
            scale,
        };
        let x0 = linkage.start.clone();
        linkage.reference = linkage.values(&x0);
        linkage
    }

    /// Positions at unknowns `y` (displacements from the start in units of `scale`).
    fn positions(&self, y: &DVector<f64>) -> BTreeMap<usize, Vector3<f64>> {
        let mut x = self.start.clone();
        for (k, &(i, c)) in self.unknowns.iter().enumerate() {
            if let Some(p) = x.get_mut(&i) {
                p[c] += y[k] * self.scale;
            }
        }
        x
    }

    /// Every constraint row's value and scale at positions `x`.
    fn values(&self, x: &BTreeMap<usize, Vector3<f64>>) -> Vec<(f64, f64)> {
        let mut out = Vec::new();
        for c in &self.constraints {
            match c {
                Constraint::Length(a, b) => {
                    let l2 = (x[b] - x[a]).norm_squared();
                    out.push((l2, l2.max(f64::MIN_POSITIVE)));
                }
                Constraint::Gap(a, b) => {
                    let g = x[b] - x[a];
                    for k in 0..3 {
                        out.push((g[k], self.scale));
                    }
                }
                Constraint::Volume(tris) => {
                    let (mut v, mut area) = (0.0, 0.0);
                    for &e in tris {
                        let [p, q, r] = self.model.triangles[e].nodes.map(|i| x[&i]);
                        v += p.dot(&q.cross(&r)) / 6.0;
                        area += (q - p).cross(&(r - p)).norm() / 2.0;
                    }
                    out.push((v, (area * self.scale).max(f64::MIN_POSITIVE)));
                }
            }
        }
        out
    }

    /// The constraints' relative changes from the start and their Jacobian (per unknown) at
    /// `y`.
    fn residual(&self, y: &DVector<f64>) -> (DVector<f64>, DMatrix<f64>) {
        let x = self.positions(y);
        let now = self.values(&x);
        let rows = now.len();
        let mut e = DVector::zeros(rows);
        for (k, ((v, _), (v0, s0))) in now.iter().zip(&self.reference).enumerate() {
            e[k] = (v - v0) / s0;
        }
        let mut j = DMatrix::zeros(rows, self.unknowns.len());
        let l = self.scale;
        let mut add = |row: usize, node: usize, grad: Vector3<f64>| {
            for c in 0..3 {
                if let Some(&k) = self.index.get(&(node, c)) {
                    j[(row, k)] += grad[c] * l;
                }
            }
        };
        let mut row = 0;
        for c in &self.constraints {
            match c {
                Constraint::Length(a, b) => {
                    let d = (x[b] - x[a]) * (2.0 / self.reference[row].1);
                    add(row, *b, d);
                    add(row, *a, -d);
                    row += 1;
                }
                Constraint::Gap(a, b) => {
                    for k in 0..3 {
                        let mut g = Vector3::zeros();
                        g[k] = 1.0 / self.reference[row].1;
                        add(row, *b, g);
                        add(row, *a, -g);
                        row += 1;
                    }
                }
                Constraint::Volume(tris) => {
                    let s = 1.0 / (6.0 * self.reference[row].1);
                    for &e in tris {
                        let n = self.model.triangles[e].nodes;
                        let [p, q, r] = n.map(|i| x[&i]);
                        add(row, n[0], q.cross(&r) * s);
                        add(row, n[1], r.cross(&p) * s);
                        add(row, n[2], p.cross(&q) * s);
                    }
                    row += 1;
                }
            }
        }
        (e, j)
    }
}

/// The minimizer of |A δ − r|² + μ |δ|², μ = 1e-14 of A's largest squared column or row norm
/// (the minimum-norm least-squares solution where A's singular values exceed √μ), through
/// the smaller of the two normal systems. None if it cannot be solved.
fn tikhonov(a: &DMatrix<f64>, r: &DVector<f64>) -> Option<DVector<f64>> {
    let (m, n) = a.shape();
    if n == 0 {
        return Some(DVector::zeros(0));
    }
    if m <= n {
        let mut g = a * a.transpose();
        let mu = 1e-14 * g.diagonal().amax().max(f64::MIN_POSITIVE);
        for k in 0..m {
            g[(k, k)] += mu;
        }
        let z = g.cholesky()?.solve(r);
        Some(a.transpose() * z)
    } else {
        let mut g = a.transpose() * a;
        let mu = 1e-14 * g.diagonal().amax().max(f64::MIN_POSITIVE);
        for k in 0..n {
            g[(k, k)] += mu;
        }
        Some(g.cholesky()?.solve(&(a.transpose() * r)))
    }
}

/// `t` projected on the null space of `j` (the motions that keep every constraint to first
/// order).
fn project(j: &DMatrix<f64>, t: &DVector<f64>) -> Option<DVector<f64>> {
    if j.nrows() == 0 {
        return Some(t.clone());
    }
    Some(t - tikhonov(j, &(j * t))?)
}

/// The finite-motion check (module docs, 3) of the candidate motion `v` (per DOF) under the
/// external forces `f` (per DOF), at the current positions of `u`.
fn finite(model: &Model, u: &[f64], v: &[f64], f: &[f64]) -> Finite {
    let norm = |i: usize| Vector3::new(v[3 * i], v[3 * i + 1], v[3 * i + 2]).norm();
    let largest = (0..model.reference.len()).map(norm).fold(0.0, f64::max);
    let moving: BTreeSet<usize> = (0..model.reference.len())
        .filter(|&i| largest > 0.0 && norm(i) >= MOVED * largest)
        .collect();
    if moving.len() > CHECKED_NODES {
        return Finite::NotChecked(format!(
            "it moves {} nodes, more than the {CHECKED_NODES} the check takes",
            moving.len()
        ));
    }
    // With the neighbours (up to NEIGHBOUR_RINGS rings, while within CHECKED_NODES): a
    // mechanism may need nodes the candidate hardly moves (the far hinge of a swinging
    // chain). More unknowns only let the check find more motions; each one it names is one.
    let mut moving = moving;
    for _ in 0..NEIGHBOUR_RINGS {
        let mut grown = moving.clone();
        for (kind, e) in model.elements() {
            let nodes = model.element_nodes(kind, e);
            if nodes.iter().any(|i| moving.contains(i)) {
                grown.extend(nodes.iter().copied());
            }
        }
        if grown.len() > CHECKED_NODES || grown.len() == moving.len() {
            break;
        }
        moving = grown;
    }
    let linkage = Linkage::new(model, u, &moving);
    let n = linkage.unknowns.len();
    if n == 0 {
        return Finite::NotChecked("it moves no free component".into());
    }
    let gather =
        |w: &[f64]| DVector::from_iterator(n, linkage.unknowns.iter().map(|&(i, c)| w[3 * i + c]));
    let (v, load) = (gather(v), gather(f));
    let y0 = DVector::zeros(n);
    let (_, j0) = linkage.residual(&y0);
    let Some((pv, pf)) = project(&j0, &v).zip(project(&j0, &load)) else {
        return Finite::NotChecked("its constraint equations could not be solved".into());
    };
    let first_order = pv.norm() >= FIRST_ORDER_KEPT * v.norm();
    // The loads' work on the first-order motions: |P f|² = f·P f.
    if !(pf.norm() > LOADED * load.norm() && pf.norm() > 0.0) {
        return Finite::Unloaded { first_order };
    }
    let length = PATH_LENGTH; // in units of the scale
    let mut h = length / PATH_STEPS;
    let (mut y, mut t, mut travelled) = (y0.clone(), pf.normalize(), 0.0);
    let mut nearest = f64::INFINITY;
    while travelled < length {
        let step = h.min(length - travelled);
        let predicted = &y + &t * step;
        let next = correct(&linkage, &predicted, &t)
            .and_then(|next| match (&next - &y).norm() >= 0.5 * step {
                true => Ok(next),
                // Pulled back towards the last point: no progress along the curve.
                false => Err(f64::INFINITY),
            })
            .and_then(|next| {
                let (_, j) = linkage.residual(&next);
                match project(&j, &t) {
                    // The first-order motion goes on from there.
                    Some(turned) if turned.norm() >= 0.5 => Ok((next, turned.normalize())),
                    _ => Err(f64::INFINITY),
                }
            });
        match next {
            Ok((next, turned)) => {
                travelled += (&next - &y).norm();
                t = turned;
                y = next;
                h = (2.0 * h).min(length / PATH_STEPS);
            }
            Err(off) => {
                nearest = off;
                h /= 2.0;
                if h < SHORTEST_STEP * length {
                    break;
                }
            }
        }
    }
    let scale = linkage.scale;
    if travelled >= length * (1.0 - 1e-9) {
        let x = linkage.positions(&y);
        let shift = |i: usize| (x[&i] - linkage.start[&i]).norm();
        let most = moving.iter().map(|&i| shift(i)).fold(0.0, f64::max);
        let moved = moving
            .iter()
            .copied()
            .filter(|&i| shift(i) >= MOVED * most)
            .collect();
        Finite::Mechanism {
            length: travelled * scale,
            moved,
        }
    } else {
        Finite::FirstOrderOnly {
            reached: travelled * scale,
            length: length * scale,
            step: 2.0 * h * scale,
            nearest,
        }
    }
}

/// Gauss–Newton (minimum-norm steps) from `predicted` to a point that keeps every constraint
/// within [`KEPT`] on the hyperplane through `predicted` normal to `t`; Err(the smallest
/// largest relative change of a constraint it reached) if it does not get there in 20
/// iterations.
fn correct(
    linkage: &Linkage,
    predicted: &DVector<f64>,
    t: &DVector<f64>,
) -> Result<DVector<f64>, f64> {
    let n = predicted.len();
    let mut y = predicted.clone();
    let mut nearest = f64::INFINITY;
    for _ in 0..20 {
        let (e, j) = linkage.residual(&y);
        let along = t.dot(&(&y - predicted));
        let off = e.amax();
        if !off.is_finite() {
            return Err(nearest);
        }
        nearest = nearest.min(off);
        if off <= KEPT && along.abs() <= KEPT {
            return Ok(y);
        }
        let mut a = DMatrix::zeros(j.nrows() + 1, n);
        a.rows_mut(0, j.nrows()).copy_from(&j);
        a.row_mut(j.nrows()).copy_from(&t.transpose());
        let mut r = DVector::zeros(j.nrows() + 1);
        r.rows_mut(0, j.nrows()).copy_from(&e);
        r[j.nrows()] = along;
        match tikhonov(&a, &r) {
            Some(d) => y -= d,
            None => return Err(nearest),
        }
    }
    Err(nearest)
}

/// The most squeezed membrane triangle at `u` (module docs, 0), as a clause of a failed
/// step's message, or nothing when every triangle keeps at least [`SQUEEZED`] of its area.
fn squeezed(model: &Model, u: &[f64], lambda: f64) -> String {
    let Some((t, ratio)) = model
        .triangles
        .iter()
        .map(|t| {
            let x = t.nodes.map(|n| model.position(u, n));
            (
                t,
                crate::model::membrane::signed_area_ratio(&t.reference, &x),
            )
        })
        .min_by(|a, b| a.1.total_cmp(&b.1))
    else {
        return String::new();
    };
    if !(ratio < SQUEEZED) {
        return String::new();
    }
    format!(
        "; at the last converged point (load fraction {lambda:.6}) triangle {} (nodes {}, {}, {}) is squeezed to {ratio:.2} of its reference area: a tension-only film does not resist being gathered, and a gathering that goes on collapses that triangle, which no answer may have (a finer mesh where the film gathers, or membranes[].residual_stiffness, gives it something to resist with)",
        t.id, t.nodes[0], t.nodes[1], t.nodes[2]
    )
}

impl Solver {
    /// What is known about the structure where the increment to `loads` failed from the
    /// converged point `u` at load fraction `lambda` (module docs): "; the structure is a
    /// mechanism: …" once verified, otherwise what the tangent there shows and what was
    /// checked, or nothing when the tangent is regular. Leaves the solver's tangent and
    /// residual buffers overwritten (the step has failed); the next Newton direction factors
    /// afresh.
    pub(super) fn diagnose_failure(
        &mut self,
        model: &Model,
        u: &[f64],
        loads: &[f64],
        lambda: f64,
    ) -> String {
        let squeezed = squeezed(model, u, lambda);
        let f = external_forces_at(model, u, loads);
        if let Some(why) = diagnose(model, u, &f) {
            return format!("; {why}");
        }
        let Some((v, ratio)) = self.soft_motion(model, u, loads) else {
            return squeezed;
        };
        if !(ratio < NEAR_SINGULAR) {
            return squeezed;
        }
        // The nodes v moves most, named in id order.
        let size = |i: &usize| Vector3::new(v[3 * i], v[3 * i + 1], v[3 * i + 2]).norm();
        let mut order: Vec<usize> = (0..model.reference.len())
            .filter(|i| size(i) > 0.0)
            .collect();
        let largest = order.iter().map(size).fold(0.0, f64::max);
        let moving = order.iter().filter(|&i| size(i) >= MOVED * largest).count();
        order.sort_by(|a, b| size(b).total_cmp(&size(a)));
        let mut most: Vec<usize> = order.into_iter().take(NAMED_NODES.min(moving)).collect();
        most.sort_unstable();
        let named = most
            .iter()
            .map(|i| i.to_string())
            .collect::<Vec<_>>()
            .join(", ");
        let of = if moving > most.len() {
            format!(" (of {moving} it moves)")
        } else {
            String::new()
        };
        let held = match (model.slips.is_empty(), model.volumes == 0) {
            (true, true) => "",
            (false, true) => ", sleeve slips held",
            (true, false) => ", volume pressures held",
            (false, false) => ", sleeve slips and volume pressures held",
        };
        let stiffness = if ratio < 1e-12 {
            "which has no stiffness (below 1e-12 of the elements' elastic stiffness)".to_string()
        } else {
            format!("whose stiffness is {ratio:.1e} of the elements' elastic stiffness")
        };
        let head = format!(
            "; the tangent at the last converged point (load fraction {lambda:.6}{held}) is near-singular: the out-of-balance load drives a motion largest at node{} {named}{of}, {stiffness}",
            if most.len() == 1 { "" } else { "s" }
        );
        let tail = match finite(model, u, &v, &f) {
            Finite::Mechanism { length, moved } => {
                return format!(
                    "; the structure is a mechanism: nodes {} can move along a finite motion that keeps the length of every cable segment and triangle edge they touch (followed over {length:.2e} m, each within {KEPT:.0e} of its length), that no support stops and the loads push along (fix more components of these nodes, or add members that brace them)",
                    name_nodes(&moved)
                );
            }
            Finite::Unloaded { first_order: true } => "; that motion keeps the element lengths to first order, but the loads push along no motion of these nodes and their neighbours that does".to_string(),
            Finite::Unloaded { first_order: false } => "; that motion changes element lengths at first order (the tangent has no stiffness against it there: slack or wrinkled elements, or a limit point), and the loads push along no motion of these nodes and their neighbours that keeps the lengths".to_string(),
            Finite::FirstOrderOnly {
                reached,
                length,
                step,
                nearest,
            } => {
                let nearest = if nearest.is_finite() {
                    format!(" (the nearest found changes a length by {nearest:.1e} of it)")
                } else {
                    String::new()
                };
                let after = if reached > 0.0 {
                    format!("it keeps them over {reached:.2e} m of the {length:.2e} m asked, then ")
                } else {
                    String::new()
                };
                format!(
                    "; the loads push along a motion of these nodes and their neighbours that keeps the element lengths to first order, but it does not extend to a finite one: {after}no point found {step:.1e} m further along keeps every length{nearest}; first order only, so tension or a change of shape stiffens it"
                )
            }
            Finite::NotChecked(why) => format!("; whether it extends to a finite motion was not checked ({why})"),
        };
        format!("{head}{tail}{squeezed}")
    }

    /// The motion along which the physical tangent at `u` under `loads` is softest in the
    /// direction of the out-of-balance force (module docs, 2): per DOF (0 on held ones), and
    /// its stiffness as a share of the elastic diagonal. None where there is nothing to solve
    /// or the solves fail.
    fn soft_motion(&mut self, model: &Model, u: &[f64], loads: &[f64]) -> Option<(Vec<f64>, f64)> {
        let n = self.pattern.n;
        if n == 0 {
            return None;
        }
        let (frozen, factor) = (self.frozen.take(), self.prestress_factor);
        self.prestress_factor = 0.0;
        self.assemble_at(model, loads, u);
        self.prestress_factor = factor;
        self.frozen = frozen;
        // The factorization below is not of a Newton tangent: no inexact direction may start
        // from it.
        self.last_direction_residual = f64::INFINITY;
        let mut v = vec![0.0; n];
        for (d, &e) in self.pattern.eq.iter().enumerate() {
            if e != NONE {
                v[e] = -self.residual[d];
            }
        }
        let norm = |v: &[f64]| v.iter().map(|x| x * x).sum::<f64>().sqrt();
        if !(norm(&v) > 0.0 && norm(&v).is_finite()) {
            // Nothing pushes (a prescribed displacement's step): a fixed start.
            v.iter_mut()
                .enumerate()
                .for_each(|(k, x)| *x = 1.0 + 0.1 * (k % 7) as f64);
        }
        let first = norm(&v);
        v.iter_mut().for_each(|x| *x /= first);
        // K + σD: a tangent with no stiffness at all (unstressed cables) factors too.
        let values = self.linear.values_mut();
        for (p, d) in self.diagonal_positions.iter().zip(&self.reference_diagonal) {
            values[*p] += SHIFT * d;
        }
        self.linear.factor().ok()?;
        let mut rho = f64::NAN;
        for _ in 0..INVERSE_ITERATIONS {
            let mut w = v.clone();
            self.linear.solve(&mut w).ok()?;
            let ww: f64 = w.iter().map(|x| x * x).sum();
            if !(ww > 0.0 && ww.is_finite()) {
                return None;
            }
            // vᵀ(K + σD)v for the next v = w/|w|: wᵀ(K + σD)w/|w|² = wᵀv/|w|².
            rho = w.iter().zip(&v).map(|(a, b)| a * b).sum::<f64>() / ww;
            let s = ww.sqrt();
            v = w.into_iter().map(|x| x / s).collect();
        }
        let elastic: f64 = v
            .iter()
            .zip(&self.reference_diagonal[..n])
            .map(|(x, d)| d * x * x)
            .sum();
        if !(elastic > 0.0 && rho.is_finite()) {
            return None;
        }
        let ratio = (rho / elastic - SHIFT).abs();
        let mut motion = vec![0.0; model.dof_count()];
        for (d, &e) in self.pattern.eq.iter().enumerate() {
            if e != NONE {
                motion[d] = v[e];
            }
        }
        Some((motion, ratio))
    }
}

#[cfg(test)]
mod tests {
    //! The finite-motion check on linkages whose motions are known by hand (no solver: the
    //! candidate motion is given). Each asserts the kind of answer and, for a mechanism, the
    //! nodes moved.
    use super::*;

    fn model(scene: serde_json::Value) -> Model {
        let scene = crate::Scene::from_json(&scene.to_string()).unwrap_or_else(|p| panic!("{p}"));
        Model::build(&scene)
    }

    /// Cables through `nodes` (coordinates), `held` held in x, y and z.
    fn chain(coordinates: serde_json::Value, cables: serde_json::Value, held: &[usize]) -> Model {
        model(serde_json::json!({
            "format": 1, "name": "Chain",
            "geometry": {"nodes": coordinates, "node_sets": {"held": held}},
            "cables": cables,
            "supports": [{"nodes": "held", "fix": ["x", "y", "z"]}]
        }))
    }

    /// Per DOF: `value` at (node, component).
    fn at(model: &Model, entries: &[(usize, usize, f64)]) -> Vec<f64> {
        let mut v = vec![0.0; model.dof_count()];
        for &(i, c, x) in entries {
            v[3 * i + c] = x;
        }
        v
    }

    /// A unit-square parallelogram of cables A–N1–N2–B (A, B held) pushed in x at N1: both
    /// free nodes swing on circles and no length changes, a finite mechanism of nodes 1 and 2.
    #[test]
    fn a_parallelogram_swings() {
        let m = chain(
            serde_json::json!([
                [0.0, 0.0, 0.0],
                [0.0, 1.0, 0.0],
                [1.0, 1.0, 0.0],
                [1.0, 0.0, 0.0]
            ]),
            serde_json::json!([{"name": "c", "nodes": [0, 1, 2, 3], "EA": 1e4}]),
            &[0, 3],
        );
        let u = vec![0.0; m.unknown_count()];
        let f = at(&m, &[(1, 0, 1.0)]);
        // The curve is followed over 5 % of the median length (1 m), chord by chord.
        let found = finite(&m, &u, &f, &f);
        assert!(
            matches!(found, Finite::Mechanism { length, ref moved }
                if moved == &[1, 2] && length >= PATH_LENGTH * (1.0 - 1e-9)),
            "{found:?}"
        );
    }

    /// A node in the middle of a straight cable between two held nodes, pushed sideways: its
    /// two segments lengthen as δ²/2 per metre, so the first-order motion does not extend.
    #[test]
    fn a_node_on_a_straight_cable_moves_to_first_order_only() {
        let m = chain(
            serde_json::json!([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]]),
            serde_json::json!([{"name": "c", "nodes": [0, 1, 2], "EA": 1e4}]),
            &[0, 2],
        );
        let u = vec![0.0; m.unknown_count()];
        let f = at(&m, &[(1, 1, 1.0)]);
        assert!(
            matches!(finite(&m, &u, &f, &f), Finite::FirstOrderOnly { reached, .. } if reached == 0.0)
        );
        // Pushed along the cable: it changes the lengths at first order, and no motion that
        // keeps them is pushed along.
        let along = at(&m, &[(1, 0, 1.0)]);
        assert_eq!(
            finite(&m, &u, &along, &along),
            Finite::Unloaded { first_order: false }
        );
    }

    /// A flat square of two triangles, three corners held, the fourth pushed out of the plane:
    /// each triangle alone would turn about its held edge, but the two edges are not in line, so
    /// the corner's motion keeps both triangles' edges to first order only.
    #[test]
    fn a_flat_membrane_corner_moves_to_first_order_only() {
        let m = model(serde_json::json!({
            "format": 1, "name": "Corner",
            "geometry": {"nodes": [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]],
                         "triangles": [[0, 1, 2], [0, 2, 3]],
                         "node_sets": {"held": [0, 1, 3]}},
            "membranes": [{"name": "film", "triangles": [0, 1], "thickness": 1e-4,
                           "material": {"kind": "svk", "E": 1e9, "nu": 0.3}}],
            "supports": [{"nodes": "held", "fix": ["x", "y", "z"]}]
        }));
        let u = vec![0.0; m.unknown_count()];
        let f = at(&m, &[(2, 2, 1.0)]);
        assert!(matches!(
            finite(&m, &u, &f, &f),
            Finite::FirstOrderOnly { .. }
        ));
    }

    /// A three-bar chain in space between two held nodes (not in line) has three degrees of
    /// freedom of finite motion: pushed anywhere, the free nodes move along one of them.
    #[test]
    fn a_three_bar_chain_in_space_moves() {
        let m = chain(
            serde_json::json!([
                [0.0, 0.0, 0.0],
                [0.3, 0.8, 0.1],
                [1.1, 0.9, -0.2],
                [1.4, 0.1, 0.3]
            ]),
            serde_json::json!([{"name": "c", "nodes": [0, 1, 2, 3], "EA": 1e4}]),
            &[0, 3],
        );
        let u = vec![0.0; m.unknown_count()];
        let f = at(&m, &[(1, 2, 1.0), (2, 0, -0.5)]);
        assert!(matches!(
            finite(&m, &u, &f, &f),
            Finite::Mechanism { ref moved, .. } if moved == &[1, 2]
        ));
    }
}
