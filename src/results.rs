//! Outputs computed from the model and a committed state.
//!
//! ```text
//! displacement   u[dof]                       m
//! position       X[dof] + u[dof]              m
//! polar          u_i · e, e the node's reference radial or tangential unit vector   m
//! cable length   Σ |x_b − x_a| over the segments of the cable or span      m
//! cable slip     −s_j: unstretched cable that passed the sleeve point toward the cable's end  m
//! contact force  |k_c (x_c − x_m)| of a sleeve tie (largest over the listed ones)  N
//! contact gap    largest |x_c − x_m| / min(l_a, l_b) over the sleeve (penetration check; open
//!                segments only)
//! slip count     sleeve points in the stick or slip state (a merged point: its group's)
//! cable tension  T of a segment, or the largest (a closed segment between touching sleeve
//!                points: the tension entering its group)     N
//! reaction       Σ R[dof] over held DOFs of the set, R = f_int − f_ext: the force the supports
//!                and prescribed displacements exert on the structure        N
//! moment         Σ ((x_i − p) × R_i)·a over the set's nodes (R_i: held components)  N·m
//! resultant      |Σ R_i| over the set's nodes (held components)              N
//! zone force     Σ p A n over the zone's pressure-loaded triangles (current A n for a
//!                follower pressure, reference for a dead one), one component       N
//! iterations     Newton iterations of the last step
//! ```

use crate::model::membrane::Evaluation;
use crate::model::sleeve::Contact;
use crate::model::wrinkling::WrinkleState;
use crate::model::{pressure, LoadModel, Model, ProbeModel};
use crate::solver::outputs::Committed;

/// Every output of the model, in probe order. `u` displacement, `applied` input values it
/// carries, `iterations` of the last step, `committed` the one assembly at `u` (every
/// triangle's evaluation, the residual, the stored energy: `Solver::evaluate_committed`).
pub fn evaluate(
    model: &Model,
    u: &[f64],
    applied: &[f64],
    iterations: u32,
    committed: &Committed,
    slip_states: &[Contact],
) -> Vec<f64> {
    let membranes: &[Evaluation] = &committed.membranes;
    let r: &[f64] = &committed.residual;
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
            ProbeModel::Along { node, unit } => (0..3).map(|c| u[3 * node + c] * unit[c]).sum(),
            ProbeModel::CableLength { segments } => {
                segments.clone().map(|e| segment_length(model, u, e)).sum()
            }
            ProbeModel::CableSlip { slip } => 0.0 - u[model.dof_count() + slip],
            ProbeModel::ContactForce { slips } => slips
                .iter()
                .map(|&j| model.tie_force(u, model.slips[j].tie).norm())
                .fold(0.0, f64::max),
            ProbeModel::ContactGap { slips } => slips
                .iter()
                .map(|&j| {
                    // A closed segment (touching sleeve points) has no length of its own.
                    let open = |e: usize| {
                        if model.segment_closed(u, e) {
                            f64::INFINITY
                        } else {
                            segment_length(model, u, e)
                        }
                    };
                    let [a, b] = model.slips[j].segments;
                    let shorter = open(a).min(open(b));
                    if shorter.is_finite() {
                        tie_gap(model, u, j) / shorter
                    } else {
                        0.0
                    }
                })
                .fold(0.0, f64::max),
            ProbeModel::SlipCount { slips, slipping } => slips
                .iter()
                .filter(|&&j| {
                    let state = group_state(model, slip_states, j);
                    (state != Contact::Stick) == *slipping
                })
                .count() as f64,
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
            ProbeModel::ReactionMoment { nodes, point, axis } => nodes
                .iter()
                .map(|&i| {
                    let arm = model.position(u, i) - point;
                    arm.cross(&held_force(model, r, i)).dot(axis)
                })
                .sum(),
            ProbeModel::ReactionResultant { nodes } => nodes
                .iter()
                .map(|&i| held_force(model, r, i))
                .sum::<nalgebra::Vector3<f64>>()
                .norm(),
            ProbeModel::ZoneForce { zone, component } => {
                zone_force(model, u, applied, zone)[*component]
            }
            ProbeModel::NewtonIterations => iterations as f64,
            // The engine fills it in (`Engine::refresh_outputs`).
            ProbeModel::NaturalFrequency { .. } => 0.0,
            // From the engine's state (velocities, the mass): filled in by the engine.
            ProbeModel::Velocity { .. }
            | ProbeModel::Acceleration { .. }
            | ProbeModel::KineticEnergy => 0.0,
            ProbeModel::StrainEnergy => committed.stored,
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
            ProbeModel::EnclosedVolume(tris) => model.enclosed_volume(u, tris),
            ProbeModel::EnclosedPressure(k) => model.unknown_value(u, *k),
            ProbeModel::ContactTotal { set, component } => model.contact_total(u, *set, *component),
            ProbeModel::ContactArea(set) => model.contact_area(u, *set),
        })
        .collect()
}

/// Resultant of the pressure loads (pressure and volume channels at their current values) on
/// the triangles marked in `zone`: Σ p A n, current or reference area and normal; snow and
/// ponding by their own laws on the current geometry.
fn zone_force(model: &Model, u: &[f64], applied: &[f64], zone: &[bool]) -> nalgebra::Vector3<f64> {
    let mut total = nalgebra::Vector3::zeros();
    for (l, load) in model.loads.iter().enumerate() {
        let (triangles, follower) = match load {
            LoadModel::Pressure {
                triangles,
                follower,
            } => (triangles, *follower),
            LoadModel::Volume { triangles, .. } => (triangles, true),
            LoadModel::Surface { .. } | LoadModel::Water { .. } => {
                let (triangles, law) = match load {
                    LoadModel::Surface { triangles, law } => (triangles, *law),
                    LoadModel::Water {
                        triangles, gamma_w, ..
                    } => (
                        triangles,
                        pressure::SurfaceLaw::Ponding { gamma_w: *gamma_w },
                    ),
                    _ => unreachable!(),
                };
                let value = model.load_value(l, u, applied);
                for &e in triangles.iter().filter(|&&e| zone.get(e) == Some(&true)) {
                    let x = model.triangles[e].nodes.map(|i| model.position(u, i));
                    total += law.forces(value, &x).iter().sum::<nalgebra::Vector3<f64>>();
                }
                continue;
            }
            _ => continue,
        };
        let p = model.load_value(l, u, applied);
        for &e in triangles.iter().filter(|&&e| zone.get(e) == Some(&true)) {
            let t = &model.triangles[e];
            total += if follower {
                let x = t.nodes.map(|i| model.position(u, i));
                pressure::follower_force(p, &x) * 3.0
            } else {
                t.reference.normal * (p * t.reference.area)
            };
        }
    }
    total
}

/// The reaction force at node `i`: its held components of the residual (zero elsewhere).
fn held_force(model: &Model, r: &[f64], i: usize) -> nalgebra::Vector3<f64> {
    nalgebra::Vector3::from_fn(|c, _| {
        if model.held[3 * i + c] {
            r[3 * i + c]
        } else {
            0.0
        }
    })
}

/// Stick/slip state of sleeve point `j`, a merged point taking its group's (the leader's).
fn group_state(model: &Model, slip_states: &[Contact], j: usize) -> Contact {
    let state = |k: usize| slip_states.get(k).copied().unwrap_or_default();
    let mut k = j;
    while state(k) == Contact::Merged {
        match model.segments[model.slips[k].segments[0]].slip[0] {
            Some(i) => k = i,
            None => return Contact::Stick,
        }
    }
    state(k)
}

fn segment_length(model: &Model, u: &[f64], e: usize) -> f64 {
    let [a, b] = model.segments[e].nodes;
    (model.position(u, b) - model.position(u, a)).norm()
}

/// |x_c − x_m| of the tie of sleeve point `j`.
fn tie_gap(model: &Model, u: &[f64], j: usize) -> f64 {
    let [c, m] = model.ties[model.slips[j].tie].nodes;
    (model.position(u, c) - model.position(u, m)).norm()
}

/// Axial force of every segment of a cable (a closed segment: the tension entering its group,
/// `Model::segment_tension`).
pub fn segment_tensions(model: &Model, u: &[f64], cable: usize) -> Vec<f64> {
    model.cables[cable]
        .segments
        .clone()
        .map(|s| model.segment_tension(u, s))
        .collect()
}

/// What one element shows as a cell of a ParaView file (`vtk.rs`); NaN (None for the state)
/// where its kind has no such value.
#[derive(Clone, Copy, Debug)]
pub struct ElementData {
    /// Wrinkle state of a membrane triangle.
    pub state: Option<WrinkleState>,
    /// Principal Cauchy stresses (largest, smallest), Pa.
    pub principal: (f64, f64),
    /// Unit tension direction in the current configuration: a triangle's major principal
    /// direction, a segment's axis (zero where it has collapsed).
    pub direction: nalgebra::Vector3<f64>,
    /// Axial force of a segment, N (`Model::segment_tension`).
    pub tension: f64,
    /// Unstretched length that flowed into a segment through its sleeve points
    /// (s_end − s_start), m.
    pub slip: f64,
}

/// [`ElementData`] of a membrane triangle with its evaluation at `u`.
pub fn triangle_data(
    model: &Model,
    u: &[f64],
    triangle: &crate::model::Triangle,
    evaluation: &Evaluation,
) -> ElementData {
    ElementData {
        state: Some(evaluation.state),
        principal: evaluation.cauchy,
        direction: tension_direction(model, u, triangle, evaluation),
        tension: f64::NAN,
        slip: f64::NAN,
    }
}

/// [`ElementData`] of cable segment `s` at `u`.
pub fn segment_data(model: &Model, u: &[f64], s: usize) -> ElementData {
    let [a, b] = model.segments[s].nodes;
    let d = model.position(u, b) - model.position(u, a);
    ElementData {
        state: None,
        principal: (f64::NAN, f64::NAN),
        direction: if d.norm() > 0.0 { d.normalize() } else { d },
        tension: model.segment_tension(u, s),
        slip: model.segment_l0(u, s) - model.segments[s].l0,
    }
}

/// Unit tension direction of a membrane triangle in the current configuration: the major
/// principal direction of its evaluation (an angle in the element's reference frame) pushed
/// forward by the deformation gradient (zero if the triangle has collapsed onto it).
pub fn tension_direction(
    model: &Model,
    u: &[f64],
    triangle: &crate::model::Triangle,
    evaluation: &Evaluation,
) -> nalgebra::Vector3<f64> {
    let x = triangle.nodes.map(|i| model.position(u, i));
    let d = crate::model::membrane::deformation_gradient(&triangle.reference, &x)
        * nalgebra::Vector2::new(evaluation.angle.cos(), evaluation.angle.sin());
    if d.norm() > 0.0 {
        d.normalize()
    } else {
        d
    }
}

/// Integer code of a wrinkle state: 0 taut, 1 wrinkled, 2 slack.
pub fn state_code(state: WrinkleState) -> u8 {
    match state {
        WrinkleState::Taut => 0,
        WrinkleState::Wrinkled => 1,
        WrinkleState::Slack => 2,
    }
}
