//! What one URS iteration did (the symbols of the parent module): the shape's move (normal to
//! the surface, across the cables), the stress state that balances the new positions and its
//! deviation from the prescribed one, and the crossing nodes of cable nets.

use super::state::{Halt, Report, Setup, State, TriangleStress};
use crate::model::membrane;
use nalgebra::{Matrix2, Vector3};

/// Per triangle: a membrane force tensor (global [xx, yy, zz, xy, yz, xz], N/m) and its
/// largest deviation from the prescribed one, relative to the largest prescribed force.
type Field = Vec<([f64; 6], f64)>;

/// The shape's move in `step` (taken to `x`): along the surface normal at membrane nodes (a
/// move within the surface changes the mesh, not the shape), across the cable at cable nodes
/// (an edge cable's shape is its move within the surface; along a cable of constant force its
/// nodes are free to slide too), the whole move at crossings of a net. The largest over the
/// nodes.
pub(super) fn shape_move(setup: &Setup, x: &[Vector3<f64>], step: &[Vector3<f64>]) -> f64 {
    let mut normal = vec![Vector3::zeros(); x.len()];
    for t in &setup.tris {
        let [a, b, c] = t.nodes.map(|i| x[i]);
        let n = (b - a).cross(&(c - a));
        t.nodes.iter().for_each(|&i| normal[i] += n);
    }
    // Not `directions` of the equations: a segment of zero length (which the next iteration
    // reports) is not skipped here, it makes its nodes' tangent NaN and their whole move count.
    let mut tangent = vec![Vector3::zeros(); x.len()];
    for &(a, b, _) in &setup.segments {
        let d = (x[b] - x[a]).normalize();
        tangent[a] += d;
        tangent[b] += d;
    }
    let crossing = crossings(&setup.segments, &setup.seg_cable, &setup.on_membrane, x);
    (0..x.len())
        .map(|i| {
            if crossing[i] {
                step[i].norm()
            } else if setup.on_cable[i] {
                let t = tangent[i];
                if t.norm() > 0.0 {
                    let t = t.normalize();
                    (step[i] - t * step[i].dot(&t)).norm()
                } else {
                    step[i].norm()
                }
            } else if normal[i].norm() == 0.0 {
                step[i].norm()
            } else {
                step[i].dot(&normal[i].normalize()).abs()
            }
        })
        .fold(0.0f64, f64::max)
}

/// The stress that balances X_{k+1} exactly: each S0 pushed forward from X_k (per triangle:
/// the force tensor and its deviation), each cable force T L_{k+1}/L_k. The largest deviation
/// from the prescribed state goes to the report, with the iteration's log line. Fails if a
/// triangle has no area.
pub(super) fn balancing_stress(
    setup: &Setup,
    state: &State,
    report: &mut Report,
    k: usize,
    moved: f64,
) -> Result<(Field, Vec<f64>), Halt> {
    let (x, segments) = (&state.x, &setup.segments);
    let field = pushed_forward(&setup.tris, &state.stage, x).map_err(|(e, why)| {
        Halt::Failed(format!("iteration {k}: {} {why}", setup.tris[e].describe()))
    })?;
    let forces: Vec<f64> = segments
        .iter()
        .zip(&state.lengths)
        .map(|(&(a, b, t), l)| t * (x[b] - x[a]).norm() / l)
        .collect();
    let deviation = field
        .iter()
        .map(|f| f.1)
        .chain(
            forces
                .iter()
                .zip(segments)
                .map(|(f, s)| (f - s.2).abs() / s.2),
        )
        .fold(0.0f64, f64::max);
    report.deviation = deviation;
    report.log.push(format!(
        "iteration {k}: shape moved {:.3e} of the span; balancing stress within {deviation:.3e} of the prescribed",
        moved / setup.span
    ));
    Ok((field, forces))
}

/// Per triangle: the membrane force tensor (global [xx, yy, zz, xy, yz, xz], N/m) on the new
/// positions `x` of the PK2 stress S0 prescribed on the reference of the iteration
/// (N = t (A_k/A_{k+1}) F S0 Fᵀ), and its largest deviation from the prescribed tensor on the
/// new triangle, relative to the largest prescribed force. Err: the first triangle that has no
/// area or no warp direction in its plane, and which.
fn pushed_forward(
    tris: &[TriangleStress],
    stage: &[(membrane::TriangleRef, Matrix2<f64>)],
    x: &[Vector3<f64>],
) -> Result<Field, (usize, &'static str)> {
    tris.iter()
        .zip(stage)
        .enumerate()
        .map(|(e, (t, (r, s0)))| {
            let xs = t.nodes.map(|i| x[i]);
            let f = membrane::deformation_gradient(r, &xs);
            let now = membrane::triangle_ref(xs).ok_or((e, "has collapsed to zero area"))?;
            let n = f * s0 * f.transpose() * (t.thickness * r.area / now.area);
            let (warp, fill, direction) = t.prescribed(x);
            let wanted = membrane::initial_stress(&now, warp, fill, &direction, 1.0)
                .ok_or((e, "has turned normal to the warp direction"))?;
            let [e1, e2] = now.frame;
            let local = Vector3::new(e1.dot(&(n * e1)), e2.dot(&(n * e2)), e1.dot(&(n * e2)));
            let deviation = (local - wanted).amax() / warp.max(fill);
            Ok((
                [
                    n[(0, 0)],
                    n[(1, 1)],
                    n[(2, 2)],
                    n[(0, 1)],
                    n[(1, 2)],
                    n[(0, 2)],
                ],
                deviation,
            ))
        })
        .collect()
}

/// Nodes of a cable net where cables cross (no membrane at the node; the summed unit tangents
/// of two of its cables at an angle of more than about 11°). Such a node cannot slide: moving
/// it along one cable lengthens the other, so its whole move is shape and the mesh control
/// leaves it alone. A node on one cable (or on cables meeting in line) can slide along it.
pub(super) fn crossings(
    segments: &[(usize, usize, f64)],
    seg_cable: &[usize],
    on_membrane: &[bool],
    x: &[Vector3<f64>],
) -> Vec<bool> {
    let mut per_node: Vec<Vec<(usize, Vector3<f64>)>> = vec![Vec::new(); x.len()];
    for (&(a, b, _), &c) in segments.iter().zip(seg_cable) {
        let d = x[b] - x[a];
        if d.norm() == 0.0 {
            continue;
        }
        let d = d.normalize();
        for i in [a, b] {
            match per_node[i].iter_mut().find(|(k, _)| *k == c) {
                Some((_, t)) => *t += d,
                None => per_node[i].push((c, d)),
            }
        }
    }
    per_node
        .iter()
        .zip(on_membrane)
        .map(|(tangents, &membrane)| {
            !membrane
                && tangents.iter().enumerate().any(|(j, (_, t))| {
                    tangents[j + 1..].iter().any(|(_, u)| {
                        let (t, u) = (t.normalize(), u.normalize());
                        t.cross(&u).norm() > 0.2
                    })
                })
        })
        .collect()
}
