//! Assembly: the sparsity pattern and the element-to-CSC position map are built once per model;
//! every Newton iteration zeroes the values and scatters element blocks in place.
//!
//! ```text
//! eq[dof]        equation number of a free DOF (held DOFs: NONE)
//! K              upper triangle (row <= col) of the free-free tangent, CSC
//! map            per element, per local (i, j): position in K's values, or NONE
//! R = f_int − f_ext   on every DOF; at held DOFs R is the reaction (what the support supplies)
//! ```

use crate::model::membrane::Evaluation;
use crate::model::wrinkling::WrinkleState;
use crate::model::{cable, membrane, pressure, sleeve, LoadModel, Model};
use nalgebra::{SMatrix, Vector3};

pub const NONE: usize = usize::MAX;

/// Pattern and position maps of one model.
pub struct Pattern {
    pub eq: Vec<usize>,
    pub n: usize,
    pub col_ptr: Vec<usize>,
    pub row_idx: Vec<usize>,
    tri_map: Vec<[usize; 81]>,
    seg_map: Vec<[usize; 36]>,
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
}

impl Pattern {
    pub fn new(model: &Model) -> Pattern {
        let mut eq = vec![NONE; model.dof_count()];
        let mut n = 0;
        for (d, held) in model.held.iter().enumerate() {
            if !held {
                eq[d] = n;
                n += 1;
            }
        }
        // Column lists (rows <= col) from every element's DOFs.
        let mut cols: Vec<Vec<usize>> = vec![Vec::new(); n];
        let eqr = &eq;
        let element_dofs = |nodes: &[usize]| -> Vec<usize> {
            nodes
                .iter()
                .flat_map(|&i| (0..3).map(move |c| eqr[3 * i + c]))
                .collect()
        };
        let elements: Vec<Vec<usize>> = model
            .triangles
            .iter()
            .map(|t| element_dofs(&t.nodes))
            .chain(model.segments.iter().map(|s| element_dofs(&s.nodes)))
            .chain(model.ties.iter().map(|t| element_dofs(&t.nodes)))
            .collect();
        for dofs in &elements {
            for &i in dofs.iter().filter(|&&i| i != NONE) {
                for &j in dofs.iter().filter(|&&j| j != NONE && i <= j) {
                    cols[j].push(i);
                }
            }
        }
        let mut col_ptr = Vec::with_capacity(n + 1);
        let mut row_idx = Vec::new();
        col_ptr.push(0);
        for (j, c) in cols.iter_mut().enumerate() {
            c.push(j); // a diagonal entry for every equation, even one no element touches
            c.sort_unstable();
            c.dedup();
            row_idx.extend_from_slice(c);
            col_ptr.push(row_idx.len());
        }
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
        let nt = model.triangles.len();
        let tri_map = elements[..nt]
            .iter()
            .map(|d| {
                let mut m = [NONE; 81];
                map(d, &mut m);
                m
            })
            .collect();
        let seg_map = elements[nt..]
            .iter()
            .map(|d| {
                let mut m = [NONE; 36];
                map(d, &mut m);
                m
            })
            .collect();
        Pattern {
            eq,
            n,
            col_ptr,
            row_idx,
            tri_map,
            seg_map,
        }
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

fn add_force(r: &mut [f64], nodes: &[usize], f: &[f64]) {
    for (a, &i) in nodes.iter().enumerate() {
        for c in 0..3 {
            r[3 * i + c] += f[3 * a + c];
        }
    }
}

/// Per-triangle wrinkle states: frozen ones to use, and where to write the evaluations.
#[derive(Default)]
pub struct Membranes<'a> {
    /// States frozen by the solver against chatter (None: the mixed criterion decides).
    pub forced: Option<&'a [WrinkleState]>,
    /// Evaluation of every triangle (state, tension angle, stress), if wanted.
    pub out: Option<&'a mut Vec<Evaluation>>,
    /// Held-DOF coupling: given a displacement change on held DOFs (zero elsewhere), add
    /// K·change (element tangents, every row) into the second vector. Needs the tangent.
    pub held_step: Option<(&'a [f64], &'a mut [f64])>,
    /// Factor on every triangle's artificial prestress (None: 1).
    pub prestress_factor: Option<f64>,
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

/// [`assemble`] with control over the membranes' wrinkle states.
pub fn assemble_with(
    model: &Model,
    pattern: &Pattern,
    u: &[f64],
    loads: &[f64],
    r: &mut [f64],
    mut k: Option<&mut [f64]>,
    mut membranes: Membranes,
) -> AssemblyInfo {
    r.fill(0.0);
    if let Some(k) = k.as_deref_mut() {
        k.fill(0.0);
    }
    let mut info = AssemblyInfo {
        min_area_ratio: f64::INFINITY,
        ..Default::default()
    };
    if let Some(out) = membranes.out.as_deref_mut() {
        out.clear();
    }
    let mut ke = membrane::Mat9::zeros();
    for (e, t) in model.triangles.iter().enumerate() {
        let x = gather(model, u, t.nodes);
        let forced = membranes.forced.map(|f| f[e]);
        let want_k = k.is_some() || membranes.held_step.is_some();
        let (f, eval) = membrane::triangle(
            &t.reference,
            &t.material,
            t.prestress * membranes.prestress_factor.unwrap_or(1.0),
            &x,
            forced,
            want_k.then_some(&mut ke),
        );
        add_force(r, &t.nodes, f.as_slice());
        if let Some(k) = k.as_deref_mut() {
            scatter(&ke, &pattern.tri_map[e], k);
        }
        if let Some((du, out)) = membranes.held_step.as_mut() {
            couple(&ke, &t.nodes, du, out);
        }
        if let Some(out) = membranes.out.as_deref_mut() {
            out.push(eval);
        }
        info.potential += eval.energy;
        let ratio = membrane::signed_area_ratio(&t.reference, &x);
        info.min_area_ratio = info.min_area_ratio.min(ratio);
    }
    for (e, s) in model.segments.iter().enumerate() {
        let x = gather(model, u, s.nodes);
        let (f, ke, w) = cable::segment(s.law, s.ea, model.segment_l0(u, e), &x[0], &x[1]);
        add_force(r, &s.nodes, f.as_slice());
        info.potential += w;
        if let Some(k) = k.as_deref_mut() {
            scatter(&ke, &pattern.seg_map[e], k);
        }
        if let Some((du, out)) = membranes.held_step.as_mut() {
            couple(&ke, &s.nodes, du, out);
        }
    }
    let ns = model.segments.len();
    for (e, t) in model.ties.iter().enumerate() {
        let x = gather(model, u, t.nodes);
        let (f, w) = sleeve::tie_force(t.k, &x[0], &x[1]);
        add_force(r, &t.nodes, &[f.x, f.y, f.z, -f.x, -f.y, -f.z]);
        info.potential += w;
        if let Some(k) = k.as_deref_mut() {
            scatter(&sleeve::tie_stiffness(t.k), &pattern.seg_map[ns + e], k);
        }
    }
    // External loads: R −= f_ext.
    let mut fext = vec![0.0; r.len()];
    for (load, &value) in model.loads.iter().zip(loads) {
        match load {
            LoadModel::PointForce(dofs) => {
                for &(d, f) in dofs {
                    fext[d] += f * value;
                }
            }
            LoadModel::Pressure {
                triangles,
                follower,
            } => {
                for &e in triangles {
                    let t = &model.triangles[e];
                    if *follower {
                        let x = gather(model, u, t.nodes);
                        let f = pressure::follower_force(value, &x);
                        for &i in &t.nodes {
                            for c in 0..3 {
                                fext[3 * i + c] += f[c];
                            }
                        }
                        if k.is_some() || membranes.held_step.is_some() {
                            let kp = pressure::follower_stiffness(value, &x);
                            let ks = (kp + kp.transpose()) * 0.5;
                            if let Some(k) = k.as_deref_mut() {
                                scatter(&ks, &pattern.tri_map[e], k);
                            }
                            if let Some((du, out)) = membranes.held_step.as_mut() {
                                couple(&ks, &t.nodes, du, out);
                            }
                        }
                    } else {
                        let f = t.reference.normal * (value * t.reference.area / 3.0);
                        for &i in &t.nodes {
                            for c in 0..3 {
                                fext[3 * i + c] += f[c];
                            }
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
    info
}
