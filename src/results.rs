//! Outputs computed from the model and a committed state.
//!
//! ```text
//! displacement   u[dof]                       m
//! position       X[dof] + u[dof]              m
//! cable length   Σ |x_b − x_a| over segments  m
//! cable tension  T of a segment, or the largest     N
//! reaction       Σ R[dof] over held DOFs of the set, R = f_int − f_ext: the force the supports
//!                and prescribed displacements exert on the structure        N
//! iterations     Newton iterations of the last step
//! ```

use crate::model::{cable, Model, ProbeModel};
use crate::solver::Solver;

/// Every output of the model, in probe order.
/// `u` displacement, `applied` input values it carries, `iterations` of the last step.
pub fn evaluate(model: &Model, solver: &mut Solver, u: &[f64], applied: &[f64], iterations: u32) -> Vec<f64> {
    let needs_reactions = model.probes.iter().any(|p| matches!(p, ProbeModel::Reaction { .. }));
    let r = if needs_reactions { solver.residual(model, u, applied) } else { Vec::new() };
    model
        .probes
        .iter()
        .map(|p| match p {
            ProbeModel::Displacement { dof } => u[*dof],
            ProbeModel::Position { dof, reference } => reference + u[*dof],
            ProbeModel::CableLength { cable } => segment_lengths(model, u, *cable).iter().sum(),
            ProbeModel::CableTension { cable, segment } => {
                let tensions = segment_tensions(model, u, *cable);
                match segment {
                    Some(k) => tensions[*k],
                    None => tensions.iter().copied().fold(0.0, f64::max),
                }
            }
            ProbeModel::Reaction { dofs } => dofs.iter().filter(|&&d| model.held[d]).map(|&d| r[d]).sum(),
            ProbeModel::NewtonIterations => iterations as f64,
        })
        .collect()
}

fn segment_lengths(model: &Model, u: &[f64], cable: usize) -> Vec<f64> {
    model.cables[cable]
        .segments
        .clone()
        .map(|s| {
            let [a, b] = model.segments[s].nodes;
            (model.position(u, b) - model.position(u, a)).norm()
        })
        .collect()
}

/// Axial force of every segment of a cable.
pub fn segment_tensions(model: &Model, u: &[f64], cable: usize) -> Vec<f64> {
    let lengths = segment_lengths(model, u, cable);
    model.cables[cable]
        .segments
        .clone()
        .zip(lengths)
        .map(|(s, l)| {
            let seg = &model.segments[s];
            cable::tension(seg.law, seg.ea, seg.l0, l).0
        })
        .collect()
}
