//! The equations of one URS iteration (the symbols of the parent module): L_k assembled at X_k
//! (membranes, cables), the mesh control with the relief across the cables, and the solve for
//! X_{k+1} with the finishing step's refinement.

use super::measure::crossings;
use super::state::{
    Halt, Report, Setup, State, TriangleStress, AXIAL_KEPT, COLLAPSE, MESH_SPRING, REFINEMENTS,
};
use crate::model::membrane;
use crate::scene::{FormFinding, Problem};
use crate::solver::assemble::{Pattern, NONE};
use nalgebra::{Matrix2, Matrix3, Vector3};

/// Membrane blocks of the matrix between two cable nodes, summed per node pair.
type CableMembrane = std::collections::HashMap<(usize, usize), Matrix3<f64>>;

/// K(X_k) and R = K X_k, membrane part: each triangle's reference-stress stiffness
/// A t (∇N_a·S0 ∇N_b) I (for isotropic groups before the finishing step, plus λ times the
/// material part) into the matrix, its forces at X_k into the residual; each triangle's stage
/// (reference data and S0 in X_k) recorded. Returns the blocks between cable nodes (for the
/// relief across the cables).
pub(super) fn assemble_membranes(
    setup: &Setup,
    settings: &FormFinding,
    state: &mut State,
    k: usize,
) -> Result<CableMembrane, Halt> {
    let State {
        x,
        linear,
        r,
        stage,
        finishing,
        ..
    } = state;
    let values = linear.values_mut();
    let mut cable_membrane = CableMembrane::new();
    for (e, t) in setup.tris.iter().enumerate() {
        let (reference, smat) = reference_stress(setup, e, x, k)?;
        stage[e] = (reference.clone(), smat);
        let vol = reference.area * t.thickness;
        // Isotropic groups: λ times the material part of the surface-tension tangent at
        // the reference; it does not enter the residual.
        let material = (t.warp == t.fill && settings.homotopy > 0.0 && !*finishing)
            .then(|| material_part(&reference, t, settings.homotopy * vol));
        for a in 0..3 {
            for b in 0..3 {
                let kab = reference.grad[a].dot(&(smat * reference.grad[b])) * vol;
                let mut block = Matrix3::identity() * kab;
                if let Some((bm, d)) = &material {
                    block += bm[a].transpose() * d * bm[b];
                }
                add_full_block(&setup.pattern, values, t.nodes[a], t.nodes[b], &block);
                if setup.on_cable[t.nodes[a]] && setup.on_cable[t.nodes[b]] {
                    *cable_membrane
                        .entry((t.nodes[a], t.nodes[b]))
                        .or_insert_with(Matrix3::zeros) += block;
                }
                for c in 0..3 {
                    r[3 * t.nodes[a] + c] += kab * x[t.nodes[b]][c];
                }
            }
        }
    }
    Ok(cable_membrane)
}

/// Reference data of triangle `e` in X_k and its prescribed PK2 stress S0 there (the group's
/// prestress / t, 2x2 in the triangle's frame). Fails if the triangle has collapsed (zero
/// area, or below [`COLLAPSE`] of its start area); invalid if the warp direction is normal to
/// it.
fn reference_stress(
    setup: &Setup,
    e: usize,
    x: &[Vector3<f64>],
    k: usize,
) -> Result<(membrane::TriangleRef, Matrix2<f64>), Halt> {
    let t = &setup.tris[e];
    let Some(reference) = membrane::triangle_ref(t.nodes.map(|i| x[i])) else {
        return Err(Halt::Failed(format!(
            "iteration {k}: {} has collapsed to zero area; the prestress has no equilibrium between these supports",
            t.describe()
        )));
    };
    let ratio = reference.area / setup.start_area[e];
    if ratio < COLLAPSE {
        return Err(Halt::Failed(format!(
            "iteration {k}: {} shrank to {ratio:.1e} of its start area and keeps contracting: the prestress has no equilibrium between these supports (a soap film between rings too far apart pinches off)",
            t.describe()
        )));
    }
    let (warp, fill, direction) = t.prescribed(x);
    let Some(s0) = membrane::initial_stress(&reference, warp, fill, &direction, t.thickness) else {
        return Err(Halt::Invalid(crate::Error::Scene(vec![Problem {
            path: format!("membranes[{}].prestress.warp_direction", t.group),
            message: format!(
                "is normal to {} in the shape of iteration {k}",
                t.describe()
            ),
        }])));
    };
    Ok((reference, Matrix2::new(s0[0], s0[2], s0[2], s0[1])))
}

/// The material part of the surface-tension tangent of an isotropic triangle at its reference
/// (C = I), scaled by `scale` (λ A t): the strain-displacement rows B_a of its nodes and
/// D = (n/t) (1⊗1 − 2 I_sym), Voigt [[-1, 1, 0], [1, -1, 0], [0, 0, -1]]; node block B_aᵀ D B_b.
fn material_part(
    reference: &membrane::TriangleRef,
    t: &TriangleStress,
    scale: f64,
) -> ([Matrix3<f64>; 3], Matrix3<f64>) {
    let [e1, e2] = reference.frame;
    let b: [Matrix3<f64>; 3] = [0, 1, 2].map(|a| {
        let (n1, n2) = (reference.grad[a].x, reference.grad[a].y);
        Matrix3::from_rows(&[
            (e1 * n1).transpose(),
            (e2 * n2).transpose(),
            (e1 * n2 + e2 * n1).transpose(),
        ])
    });
    let k = t.warp / t.thickness;
    let d = Matrix3::new(-k, k, 0.0, k, -k, 0.0, 0.0, 0.0, -k);
    (b, d * scale)
}

/// K(X_k) and R = K X_k, cable part: each segment's force density q = T/L_k on its node pair
/// into the matrix (less the relief along the segment, see below) and its forces at X_k into
/// the residual; L_k recorded. Fails on a segment of zero length.
pub(super) fn assemble_cables(setup: &Setup, state: &mut State, k: usize) -> Result<(), Halt> {
    let State {
        x,
        linear,
        r,
        lengths,
        finishing,
        ..
    } = state;
    let pattern = &setup.pattern;
    let values = linear.values_mut();
    let fixed_net: Vec<bool> = crossings(&setup.segments, &setup.seg_cable, &setup.on_membrane, x)
        .iter()
        .enumerate()
        .map(|(i, &crossing)| crossing || (0..3).all(|c| pattern.eq[3 * i + c] == NONE))
        .collect();
    for (si, &(a, b, t)) in setup.segments.iter().enumerate() {
        let l = (x[b] - x[a]).norm();
        if !(l > 0.0) {
            return Err(Halt::Failed(format!(
                "iteration {k}: the segment between nodes {a} and {b} of cables[{}] has zero length",
                setup.seg_cable[si]
            )));
        }
        lengths[si] = l;
        let q = t / l;
        // A segment of a cable net between nodes that cannot slide (crossings of cables
        // without membrane, or held nodes): the force density's stiffness along the
        // segment is an artefact of the linear model (a cable of constant force T has the
        // stiffness (T/L)(I − d dᵀ), none along d), which slows a net to 0.78 per
        // iteration; all but AXIAL_KEPT of it leaves the matrix (not the residual). Where
        // a node can slide along its cable (one cable, or a membrane node) it stays: there
        // the along-cable direction has no stiffness at all but this.
        let net = !*finishing && fixed_net[a] && fixed_net[b];
        let d = (x[b] - x[a]) / l;
        let relief = d * d.transpose() * (-(1.0 - AXIAL_KEPT) * q);
        for (i, j, s) in [(a, a, q), (b, b, q), (a, b, -q), (b, a, -q)] {
            add_block(pattern, values, i, j, s);
            if net {
                add_full_block(pattern, values, i, j, &(relief * s.signum()));
            }
            for c in 0..3 {
                r[3 * i + c] += s * x[j][c];
            }
        }
    }
    Ok(())
}

/// Mesh control (once the mesh creeps, until the shape has converged): the residual keeps
/// only its shape part at free nodes (along the surface normal; across the cable at cable
/// nodes) and a stiff spring (`MESH_SPRING` times the node's own stiffness) holds the other
/// directions, so the fixed point is the equilibrium of the shape and the mesh stays put
/// within the surface; and the relief across the cables (keeping `kept`). Returns the
/// residual the step solves for (R itself when the control is off).
pub(super) fn control_mesh(
    setup: &Setup,
    state: &mut State,
    cable_membrane: &CableMembrane,
    kept: f64,
) -> Vec<f64> {
    let mut g = state.r.clone();
    if !state.projecting || state.finishing {
        return g;
    }
    let (x, r, pattern) = (&state.x, &state.r, &setup.pattern);
    let (normal_k, tangent_k) = directions(&setup.tris, &setup.segments, x);
    let crossing_k = crossings(&setup.segments, &setup.seg_cable, &setup.on_membrane, x);
    let values = state.linear.values_mut();
    for i in 0..x.len() {
        if !(0..3).all(|c| pattern.eq[3 * i + c] != NONE) || crossing_k[i] {
            continue;
        }
        let Some(shape) = shape_projector(setup.on_cable[i], normal_k[i], tangent_k[i]) else {
            continue;
        };
        let own = (0..3)
            .map(|c| values[position(pattern, pattern.eq[3 * i + c], pattern.eq[3 * i + c])])
            .sum::<f64>()
            / 3.0;
        let spring = (Matrix3::identity() - shape) * (MESH_SPRING * own);
        add_full_block(pattern, values, i, i, &spring);
        let gi = shape * Vector3::new(r[3 * i], r[3 * i + 1], r[3 * i + 2]);
        g[3 * i..3 * i + 3].copy_from_slice(gi.as_slice());
    }
    if kept < 1.0 {
        relieve_across_cables(pattern, values, cable_membrane, &normal_k, &tangent_k, kept);
    }
    g
}

/// The projector on a node's shape directions: across the cable (I − t tᵀ, t the summed unit
/// tangent) at a cable node, along the normal (n nᵀ) at a membrane node; None where that
/// direction is zero.
fn shape_projector(
    on_cable: bool,
    normal: Vector3<f64>,
    tangent: Vector3<f64>,
) -> Option<Matrix3<f64>> {
    if on_cable {
        (tangent.norm() > 0.0).then(|| {
            let t = tangent.normalize();
            Matrix3::identity() - t * t.transpose()
        })
    } else {
        (normal.norm() > 0.0).then(|| {
            let n = normal.normalize();
            n * n.transpose()
        })
    }
}

/// At cable nodes the membrane's stiffness across the cable within the surface is an
/// artefact of the linear model (a fixed stress moves a node's force not at all when the node
/// moves in the triangle's plane: A ∇N_a depends only on the opposite edge); with the
/// neighbouring membrane nodes held by the springs it makes the edge cables' arcs converge at
/// 0.78 per iteration on the FourPointSail. All but `kept` of it (along m = normal x tangent
/// at each node) is taken out of the matrix (the residual, and so the fixed point, is
/// unchanged).
fn relieve_across_cables(
    pattern: &Pattern,
    values: &mut [f64],
    cable_membrane: &CableMembrane,
    normal: &[Vector3<f64>],
    tangent: &[Vector3<f64>],
    kept: f64,
) {
    let across = |i: usize| -> Option<Vector3<f64>> {
        let (n, t) = (normal[i], tangent[i]);
        let m = n.cross(&t);
        (m.norm() > 0.0).then(|| m.normalize())
    };
    for (&(i, j), block) in cable_membrane {
        let (Some(mi), Some(mj)) = (across(i), across(j)) else {
            continue;
        };
        let s = mi.dot(&(block * mj));
        let sub = mi * mj.transpose() * (-(1.0 - kept) * s);
        add_full_block(pattern, values, i, j, &sub);
    }
}

/// Area-weighted node normals of the membranes and summed unit tangents of the cables at `x`.
fn directions(
    tris: &[TriangleStress],
    segments: &[(usize, usize, f64)],
    x: &[Vector3<f64>],
) -> (Vec<Vector3<f64>>, Vec<Vector3<f64>>) {
    let mut normal = vec![Vector3::zeros(); x.len()];
    for t in tris {
        let [a, b, c] = t.nodes.map(|i| x[i]);
        let n = (b - a).cross(&(c - a));
        t.nodes.iter().for_each(|&i| normal[i] += n);
    }
    let mut tangent = vec![Vector3::zeros(); x.len()];
    for &(a, b, _) in segments {
        let d = x[b] - x[a];
        if d.norm() > 0.0 {
            tangent[a] += d.normalize();
            tangent[b] += d.normalize();
        }
    }
    (normal, tangent)
}

/// Solve K step = −g at the free DOFs (the log gets the largest residual |R| there); in the
/// finishing iteration refine the step on the plain equations. Fails if the solve does.
pub(super) fn solve_step(
    setup: &Setup,
    state: &mut State,
    g: &[f64],
    report: &mut Report,
    k: usize,
) -> Result<Vec<Vector3<f64>>, Halt> {
    let pattern = &setup.pattern;
    let mut unbalanced = 0.0f64;
    for (d, &e) in pattern.eq.iter().enumerate() {
        if e != NONE {
            state.rhs[e] = -g[d];
            unbalanced = unbalanced.max(state.r[d].abs());
        }
    }
    report
        .log
        .push(format!("iteration {k}: residual {:.3e} N", unbalanced));
    if let Err(why) = state.linear.factor_solve(&mut state.rhs) {
        return Err(Halt::Failed(format!("iteration {k}: {why}")));
    }
    let mut step = vec![Vector3::zeros(); state.x.len()];
    for (d, &e) in pattern.eq.iter().enumerate() {
        if e != NONE {
            step[d / 3][d % 3] = state.rhs[e];
        }
    }
    if state.finishing {
        refine(setup, state, &mut step);
    }
    Ok(step)
}

/// The last step solves the plain equations L_k x = 0 (no homotopy, no springs); iterative
/// refinement takes its residual to round-off so that the found stress state balances the
/// found shape.
fn refine(setup: &Setup, state: &mut State, step: &mut [Vector3<f64>]) {
    let pattern = &setup.pattern;
    for _ in 0..REFINEMENTS {
        let moved_to: Vec<Vector3<f64>> = state
            .x
            .iter()
            .zip(step.iter())
            .map(|(p, d)| p + d)
            .collect();
        let rr = plain_residual(
            &setup.tris,
            &state.stage,
            &setup.segments,
            &state.lengths,
            &moved_to,
        );
        for (d, &e) in pattern.eq.iter().enumerate() {
            if e != NONE {
                state.rhs[e] = -rr[d];
            }
        }
        if state.linear.solve(&mut state.rhs).is_err() {
            break;
        }
        for (d, &e) in pattern.eq.iter().enumerate() {
            if e != NONE {
                step[d / 3][d % 3] += state.rhs[e];
            }
        }
    }
}

/// The plain URS residual L_k x at positions `x` (reference data and stresses of iteration
/// k in `stage`, cable force densities T/L_k).
fn plain_residual(
    tris: &[TriangleStress],
    stage: &[(membrane::TriangleRef, Matrix2<f64>)],
    segments: &[(usize, usize, f64)],
    lengths: &[f64],
    x: &[Vector3<f64>],
) -> Vec<f64> {
    let mut r = vec![0.0; 3 * x.len()];
    for (t, (reference, smat)) in tris.iter().zip(stage) {
        let vol = reference.area * t.thickness;
        for a in 0..3 {
            for b in 0..3 {
                let kab = reference.grad[a].dot(&(smat * reference.grad[b])) * vol;
                for c in 0..3 {
                    r[3 * t.nodes[a] + c] += kab * x[t.nodes[b]][c];
                }
            }
        }
    }
    for (&(a, b, t), l) in segments.iter().zip(lengths) {
        let q = t / l;
        for c in 0..3 {
            let f = q * (x[b][c] - x[a][c]);
            r[3 * a + c] -= f;
            r[3 * b + c] += f;
        }
    }
    r
}

/// Position of the entry (equation i, equation j), i <= j, in the values of the
/// upper-triangular free-free matrix.
fn position(pattern: &Pattern, i: usize, j: usize) -> usize {
    let col = &pattern.row_idx[pattern.col_ptr[j]..pattern.col_ptr[j + 1]];
    pattern.col_ptr[j]
        + col
            .binary_search(&i)
            .expect("pattern holds every element pair")
}

/// Add a 3x3 block to (node i, node j) of the upper-triangular free-free matrix.
fn add_full_block(pattern: &Pattern, values: &mut [f64], i: usize, j: usize, k: &Matrix3<f64>) {
    for c in 0..3 {
        for d in 0..3 {
            let (ei, ej) = (pattern.eq[3 * i + c], pattern.eq[3 * j + d]);
            if ei != NONE && ej != NONE && ei <= ej {
                values[position(pattern, ei, ej)] += k[(c, d)];
            }
        }
    }
}

/// Add s·I (3x3) to the block (node i, node j) of the upper-triangular free-free matrix.
fn add_block(pattern: &Pattern, values: &mut [f64], i: usize, j: usize, s: f64) {
    for c in 0..3 {
        let (ei, ej) = (pattern.eq[3 * i + c], pattern.eq[3 * j + c]);
        if ei != NONE && ej != NONE && ei <= ej {
            values[position(pattern, ei, ej)] += s;
        }
    }
}
