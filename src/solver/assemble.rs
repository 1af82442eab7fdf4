//! Assembly: the sparsity pattern and the element-to-CSC position map are built once per model;
//! every Newton iteration zeroes the values and scatters element blocks in place.
//!
//! ```text
//! eq[dof]        equation number of a free DOF (held DOFs: NONE)
//! K              upper triangle (row <= col) of the free-free tangent, CSC
//! map            per element, per local (i, j): position in K's values, or NONE
//! R = f_int − f_ext   on every DOF; at held DOFs R is the reaction (what the support supplies)
//! ```

use super::threads::Pool;
use crate::memory::{self, OutOfMemory};
use crate::model::membrane::Evaluation;
use crate::model::wrinkling::WrinkleState;
use crate::model::{cable, membrane, pressure, sleeve, LoadModel, Model};
use nalgebra::{SMatrix, Vector3};
use std::sync::{Arc, Mutex};

pub const NONE: usize = usize::MAX;

/// Pattern and position maps of one model.
pub struct Pattern {
    pub eq: Vec<usize>,
    pub n: usize,
    pub col_ptr: Vec<usize>,
    pub row_idx: Vec<usize>,
    tri_map: Vec<[usize; 81]>,
    seg_map: Vec<[usize; 36]>,
    /// The solver's worker threads and their assembly buffers (None: one thread).
    parallel: Option<Parallel>,
}

/// Models with fewer triangles are assembled on one thread whatever the setting: below this
/// the hand-over to the pool and the extra buffers cost more than the element work saved
/// (docs/performance.md, "Threads").
pub const PARALLEL_MIN_TRIANGLES: usize = 256;

/// The pool and, per thread after the first, the buffers its triangles are summed into.
struct Parallel {
    pool: Arc<Pool>,
    scratch: Mutex<Vec<Scratch>>,
}

/// One thread's share of an assembly (threads 1.., thread 0 writes the caller's buffers).
#[derive(Default)]
struct Scratch {
    r: Vec<f64>,
    k: Vec<f64>,
    magnitude: Vec<f64>,
    evaluations: Vec<Evaluation>,
    info: AssemblyInfo,
}

/// What one assembly found besides R and K.
#[derive(Clone, Copy, Debug, Default)]
pub struct AssemblyInfo {
    /// Stored energy minus the work of dead loads (the potential; follower pressure excluded).
    pub potential: f64,
    /// |f_ext|∞ over all DOFs.
    pub external: f64,
    /// Smallest signed current/reference area ratio of a membrane triangle (inversion check:
    /// negative for a triangle turned over against its reference normal).
    pub min_area_ratio: f64,
    /// Largest nodal force component any single element carries (N): the internal-force part
    /// of the convergence test's force scale.
    pub carried: f64,
}

impl Pattern {
    /// Pattern and position maps of `model`, every buffer that grows with it allocated
    /// fallibly (`crate::memory`).
    pub fn try_new(model: &Model) -> Result<Pattern, OutOfMemory> {
        let mut eq = memory::filled(model.dof_count(), NONE, "the equation numbers")?;
        let mut n = 0;
        for (d, held) in model.held.iter().enumerate() {
            if !held {
                eq[d] = n;
                n += 1;
            }
        }
        // Every element's DOFs (equation numbers, NONE where held), 9 for a triangle, 6 for a
        // segment or tie; triangles first, then segments and ties (the maps' order).
        let eqr = &eq;
        let dofs_of = |nodes: &[usize], out: &mut [usize; 9]| -> usize {
            for (a, &i) in nodes.iter().enumerate() {
                for c in 0..3 {
                    out[3 * a + c] = eqr[3 * i + c];
                }
            }
            3 * nodes.len()
        };
        let lines = || {
            model
                .segments
                .iter()
                .map(|s| s.nodes)
                .chain(model.ties.iter().map(|t| t.nodes))
        };
        let for_each_element = |f: &mut dyn FnMut(&[usize])| {
            let mut d = [NONE; 9];
            for t in &model.triangles {
                let m = dofs_of(&t.nodes, &mut d);
                f(&d[..m]);
            }
            for nodes in lines() {
                let m = dofs_of(&nodes, &mut d);
                f(&d[..m]);
            }
        };
        // Column lists (rows <= col), flat: count, place, then sort and dedup each column.
        let mut start = memory::zeros::<usize>(n + 1, "the tangent's pattern")?;
        for j in 0..n {
            start[j + 1] = 1; // a diagonal entry for every equation, even one no element touches
        }
        for_each_element(&mut |dofs| {
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
        for_each_element(&mut |dofs| {
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
        let position = |i: usize, j: usize| -> usize {
            if i == NONE || j == NONE || i > j {
                return NONE;
            }
            let col = &row_idx[col_ptr[j]..col_ptr[j + 1]];
            col_ptr[j]
                + col
                    .binary_search(&i)
                    .expect("pattern holds every element pair")
        };
        let map = |dofs: &[usize], out: &mut [usize]| {
            let m = dofs.len();
            for a in 0..m {
                for b in 0..m {
                    out[a * m + b] = position(dofs[a], dofs[b]);
                }
            }
        };
        let mut d = [NONE; 9];
        let mut tri_map =
            memory::with_capacity(model.triangles.len(), "the element position maps")?;
        for t in &model.triangles {
            dofs_of(&t.nodes, &mut d);
            let mut m = [NONE; 81];
            map(&d, &mut m);
            tri_map.push(m);
        }
        let mut seg_map = memory::with_capacity(
            model.segments.len() + model.ties.len(),
            "the element position maps",
        )?;
        for nodes in lines() {
            dofs_of(&nodes, &mut d);
            let mut m = [NONE; 36];
            map(&d[..6], &mut m);
            seg_map.push(m);
        }
        Ok(Pattern {
            eq,
            n,
            col_ptr,
            row_idx,
            tri_map,
            seg_map,
            parallel: None,
        })
    }

    /// Assemble the triangles of `model` on `pool`'s threads from now on (when there are at
    /// least [`PARALLEL_MIN_TRIANGLES`]). Each thread after the first gets buffers of R, K's
    /// values and the force magnitudes, allocated here (fallibly) and reused.
    pub fn use_pool(&mut self, model: &Model, pool: Arc<Pool>) -> Result<(), OutOfMemory> {
        self.parallel = None;
        if pool.count() < 2 || model.triangles.len() < PARALLEL_MIN_TRIANGLES {
            return Ok(());
        }
        let what = "the assembly buffers of the solver's threads";
        let mut scratch = memory::with_capacity(pool.count() - 1, what)?;
        let share = model.triangles.len().div_ceil(pool.count());
        for _ in 1..pool.count() {
            scratch.push(Scratch {
                r: memory::zeros(model.dof_count(), what)?,
                k: memory::zeros(self.row_idx.len(), what)?,
                magnitude: memory::zeros(model.dof_count(), what)?,
                evaluations: memory::with_capacity(share, what)?,
                info: AssemblyInfo::default(),
            });
        }
        self.parallel = Some(Parallel {
            pool,
            scratch: Mutex::new(scratch),
        });
        Ok(())
    }
}

fn scatter<const N: usize>(k: &SMatrix<f64, N, N>, map: &[usize], values: &mut [f64]) {
    for a in 0..N {
        for b in 0..N {
            let p = map[a * N + b];
            if p != NONE {
                values[p] += k[(a, b)];
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
    /// Per DOF, the sum of the magnitudes of every force that meets there (element forces and
    /// loads): the size of the terms whose sum is R, for its round-off floor. Zeroed here.
    pub magnitude: Option<&'a mut [f64]>,
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

/// One membrane triangle's internal force, tangent (into `ke` when given) and evaluation at `u`:
/// the element routine every assembly (global or per node) goes through.
pub(super) fn triangle_contribution(
    model: &Model,
    e: usize,
    u: &[f64],
    prestress_factor: f64,
    forced: Option<WrinkleState>,
    ke: Option<&mut membrane::Mat9>,
) -> (membrane::Vec9, Evaluation, f64) {
    let t = &model.triangles[e];
    let x = gather(model, u, t.nodes);
    let (f, eval) = membrane::triangle(
        &t.reference,
        &t.material,
        t.prestress * prestress_factor,
        &x,
        forced,
        ke,
    );
    (f, eval, membrane::signed_area_ratio(&t.reference, &x))
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

/// One sleeve tie's force (cable point, then membrane node), tangent and energy at `u`.
pub(super) fn tie_contribution(
    model: &Model,
    e: usize,
    u: &[f64],
) -> (cable::Vec6, cable::Mat6, f64) {
    let t = &model.ties[e];
    let x = gather(model, u, t.nodes);
    let (f, w) = sleeve::tie_force(t.k, &x[0], &x[1]);
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
    if follower {
        let x = gather(model, u, t.nodes);
        let k = want_k.then(|| {
            let kp = pressure::follower_stiffness(value, &x);
            (kp + kp.transpose()) * 0.5
        });
        (pressure::follower_force(value, &x), k)
    } else {
        (t.reference.normal * (value * t.reference.area / 3.0), None)
    }
}

impl AssemblyInfo {
    fn empty() -> AssemblyInfo {
        AssemblyInfo {
            min_area_ratio: f64::INFINITY,
            ..Default::default()
        }
    }

    /// Fold another part's findings into these (potentials add, in the order merged).
    fn merge(&mut self, part: &AssemblyInfo) {
        self.potential += part.potential;
        self.external = self.external.max(part.external);
        self.min_area_ratio = self.min_area_ratio.min(part.min_area_ratio);
        self.carried = self.carried.max(part.carried);
    }
}

/// The membrane triangles `range`: forces into `r` (and `magnitude`), tangents into `k`
/// and `held_step`, evaluations appended to `out`, in element order.
#[allow(clippy::too_many_arguments)]
fn triangle_range(
    model: &Model,
    pattern: &Pattern,
    range: std::ops::Range<usize>,
    u: &[f64],
    factor: f64,
    forced: Option<&[Option<WrinkleState>]>,
    want_k: bool,
    r: &mut [f64],
    mut k: Option<&mut [f64]>,
    mut magnitude: Option<&mut [f64]>,
    mut held_step: Option<(&[f64], &mut [f64])>,
    mut out: Option<&mut Vec<Evaluation>>,
) -> AssemblyInfo {
    let mut info = AssemblyInfo::empty();
    let mut ke = membrane::Mat9::zeros();
    for e in range {
        let t = &model.triangles[e];
        let forced = forced.and_then(|f| f[e]);
        let (f, eval, ratio) =
            triangle_contribution(model, e, u, factor, forced, want_k.then_some(&mut ke));
        add_force(r, &t.nodes, f.as_slice(), &mut magnitude);
        info.carried = info.carried.max(largest(f.as_slice()));
        if let Some(k) = k.as_deref_mut() {
            scatter(&ke, &pattern.tri_map[e], k);
        }
        if let Some((du, out)) = held_step.as_mut() {
            couple(&ke, &t.nodes, du, out);
        }
        if let Some(out) = out.as_deref_mut() {
            out.push(eval);
        }
        info.potential += eval.energy;
        info.min_area_ratio = info.min_area_ratio.min(ratio);
    }
    info
}

/// The triangle loop on the pool: thread i takes the i-th contiguous share of the triangles
/// (a fixed split), thread 0 into the caller's buffers, the others into their own; then each
/// buffer is added into the caller's in thread order, K's values split between the threads by
/// position. Every entry is summed in an order fixed by the thread count alone, so a run
/// repeats bit for bit; against one thread only the grouping of the sums differs (round-off).
#[allow(clippy::too_many_arguments)]
fn parallel_triangles(
    model: &Model,
    pattern: &Pattern,
    parallel: &Parallel,
    u: &[f64],
    factor: f64,
    forced: Option<&[Option<WrinkleState>]>,
    r: &mut [f64],
    mut k: Option<&mut [f64]>,
    mut magnitude: Option<&mut [f64]>,
    mut out: Option<&mut Vec<Evaluation>>,
) -> AssemblyInfo {
    let mut guard = parallel.scratch.lock().unwrap_or_else(|e| e.into_inner());
    let scratch: &mut Vec<Scratch> = &mut guard;
    let threads = scratch.len() + 1;
    let count = model.triangles.len();
    let share = |i: usize| i * count / threads..(i + 1) * count / threads;
    let want_k = k.is_some();
    let want_magnitude = magnitude.is_some();
    let want_out = out.is_some();
    let first = parallel.pool.scope(|s| {
        for (i, part) in scratch.iter_mut().enumerate() {
            s.spawn(move |_| {
                part.r.fill(0.0);
                if want_k {
                    part.k.fill(0.0);
                }
                if want_magnitude {
                    part.magnitude.fill(0.0);
                }
                part.evaluations.clear();
                part.info = triangle_range(
                    model,
                    pattern,
                    share(i + 1),
                    u,
                    factor,
                    forced,
                    want_k,
                    &mut part.r,
                    want_k.then_some(&mut part.k[..]),
                    want_magnitude.then_some(&mut part.magnitude[..]),
                    None,
                    want_out.then_some(&mut part.evaluations),
                );
            });
        }
        triangle_range(
            model,
            pattern,
            share(0),
            u,
            factor,
            forced,
            want_k,
            r,
            k.as_deref_mut(),
            magnitude.as_deref_mut(),
            None,
            out.as_deref_mut(),
        )
    });
    let mut info = first;
    for part in scratch.iter() {
        info.merge(&part.info);
        add_into(r, &part.r);
        if let Some(m) = magnitude.as_deref_mut() {
            add_into(m, &part.magnitude);
        }
        if let Some(out) = out.as_deref_mut() {
            out.extend_from_slice(&part.evaluations);
        }
    }
    if let Some(k) = k {
        // K's values are the large sum: each thread adds every buffer into its own range.
        let parts: &[Scratch] = &scratch;
        let len = k.len();
        parallel.pool.scope(|s| {
            let mut rest = k;
            let mut start = 0;
            for i in 0..threads {
                let end = (i + 1) * len / threads;
                let (mine, tail) = rest.split_at_mut(end - start);
                rest = tail;
                let range = start..end;
                s.spawn(move |_| {
                    for part in parts {
                        add_into(mine, &part.k[range.clone()]);
                    }
                });
                start = end;
            }
        });
    }
    info
}

fn add_into(sum: &mut [f64], part: &[f64]) {
    for (s, p) in sum.iter_mut().zip(part) {
        *s += p;
    }
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
    r.fill(0.0);
    if let Some(k) = k.as_deref_mut() {
        k.fill(0.0);
    }
    if let Some(m) = extra.magnitude.as_deref_mut() {
        m.fill(0.0);
    }
    let mut info = AssemblyInfo {
        min_area_ratio: f64::INFINITY,
        ..Default::default()
    };
    if let Some(out) = extra.out.as_deref_mut() {
        out.clear();
    }
    let want_k = k.is_some() || extra.held_step.is_some();
    let factor = extra.prestress_factor.unwrap_or(1.0);
    match (&pattern.parallel, extra.held_step.is_none()) {
        (Some(parallel), true) => {
            let part = parallel_triangles(
                model,
                pattern,
                parallel,
                u,
                factor,
                extra.forced,
                r,
                k.as_deref_mut(),
                extra.magnitude.as_deref_mut(),
                extra.out.as_deref_mut(),
            );
            info.merge(&part);
        }
        _ => {
            let part = triangle_range(
                model,
                pattern,
                0..model.triangles.len(),
                u,
                factor,
                extra.forced,
                want_k,
                r,
                k.as_deref_mut(),
                extra.magnitude.as_deref_mut(),
                extra.held_step.as_mut().map(|(du, out)| (*du, &mut **out)),
                extra.out.as_deref_mut(),
            );
            info.merge(&part);
        }
    }
    let ns = model.segments.len();
    let lines = (0..ns).map(|e| {
        (
            e,
            segment_contribution(model, e, u),
            model.segments[e].nodes,
        )
    });
    let ties =
        (0..model.ties.len()).map(|e| (ns + e, tie_contribution(model, e, u), model.ties[e].nodes));
    for (m, (f, ke, w), nodes) in lines.chain(ties) {
        add_force(r, &nodes, f.as_slice(), &mut extra.magnitude);
        info.carried = info.carried.max(largest(f.as_slice()));
        info.potential += w;
        if let Some(k) = k.as_deref_mut() {
            scatter(&ke, &pattern.seg_map[m], k);
        }
        if let Some((du, out)) = extra.held_step.as_mut() {
            couple(&ke, &nodes, du, out);
        }
    }
    // External loads: R −= f_ext.
    let mut fext = vec![0.0; r.len()];
    for (l, load) in model.loads.iter().enumerate() {
        // A volume input's load is the follower pressure held in its unknown.
        let value = model.load_value(l, u, loads);
        let pressed = match load {
            LoadModel::Pressure {
                triangles,
                follower,
            } => Some((triangles, *follower)),
            LoadModel::Volume { triangles, .. } => Some((triangles, true)),
            _ => None,
        };
        match load {
            LoadModel::PointForce(dofs) => {
                for &(d, f) in dofs {
                    fext[d] += f * value;
                }
            }
            LoadModel::Pressure { .. } | LoadModel::Volume { .. } => {
                let (triangles, follower) = pressed.expect("a pressure load");
                for &e in triangles {
                    let nodes = model.triangles[e].nodes;
                    let (f, kp) = pressure_contribution(model, e, u, value, follower, want_k);
                    for &i in &nodes {
                        for c in 0..3 {
                            fext[3 * i + c] += f[c];
                        }
                    }
                    if let Some(kp) = kp {
                        if let Some(k) = k.as_deref_mut() {
                            scatter(&kp, &pattern.tri_map[e], k);
                        }
                        if let Some((du, out)) = extra.held_step.as_mut() {
                            couple(&kp, &nodes, du, out);
                        }
                    }
                }
            }
            LoadModel::Displacement(_) => {}
        }
    }
    for (d, f) in fext.iter().enumerate() {
        r[d] -= f;
        if !model.held[d] {
            info.potential -= f * u[d];
        }
        info.external = info.external.max(f.abs());
    }
    if let Some(m) = extra.magnitude.as_deref_mut() {
        for (m, f) in m.iter_mut().zip(&fext) {
            *m += f.abs();
        }
    }
    info
}
