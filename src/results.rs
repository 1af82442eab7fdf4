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

use crate::model::membrane::Evaluation;
use crate::model::wrinkling::WrinkleState;
use crate::model::{cable, Model, ProbeModel};
use crate::solver::Solver;

/// Every output of the model, in probe order. `u` displacement, `applied` input values it
/// carries, `iterations` of the last step, `membranes` the evaluation of every triangle at `u`.
pub fn evaluate(
    model: &Model,
    solver: &mut Solver,
    u: &[f64],
    applied: &[f64],
    iterations: u32,
    membranes: &[Evaluation],
) -> Vec<f64> {
    let needs_reactions = model
        .probes
        .iter()
        .any(|p| matches!(p, ProbeModel::Reaction { .. }));
    let r = if needs_reactions {
        solver.residual(model, u, applied)
    } else {
        Vec::new()
    };
    let fraction = |tris: &[usize], state: WrinkleState| -> f64 {
        let area = |e: &usize| model.triangles[*e].reference.area;
        let total: f64 = tris.iter().map(area).sum();
        let part: f64 = tris
            .iter()
            .filter(|e| membranes[**e].state == state)
            .map(area)
            .sum();
        if total > 0.0 && part > 0.0 {
            part / total
        } else {
            0.0
        }
    };
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
            ProbeModel::Reaction { dofs } => {
                dofs.iter().filter(|&&d| model.held[d]).map(|&d| r[d]).sum()
            }
            ProbeModel::NewtonIterations => iterations as f64,
            ProbeModel::WrinkledFraction(tris) => fraction(tris, WrinkleState::Wrinkled),
            ProbeModel::SlackFraction(tris) => fraction(tris, WrinkleState::Slack),
            ProbeModel::MaxPrincipalStress(tris) => tris
                .iter()
                .map(|e| membranes[*e].cauchy.0)
                .fold(f64::NEG_INFINITY, f64::max),
            ProbeModel::MinPrincipalStress(tris) => tris
                .iter()
                .map(|e| membranes[*e].cauchy.1)
                .fold(f64::INFINITY, f64::min),
            ProbeModel::ElementState(e) => state_code(membranes[*e].state) as f64,
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

/// Integer code of a wrinkle state: 0 taut, 1 wrinkled, 2 slack.
pub fn state_code(state: WrinkleState) -> u8 {
    match state {
        WrinkleState::Taut => 0,
        WrinkleState::Wrinkled => 1,
        WrinkleState::Slack => 2,
    }
}
