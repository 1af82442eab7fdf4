//! The loads of a step at a load factor: load(λ) = from + λ (to − from), the prescribed
//! displacements they set, and the force measures the convergence test and the mechanism
//! diagnosis weigh. Plain functions of the model, shared by every driver (load control, arc
//! length, the predictor, the line search).

use crate::model::pressure::SurfaceLaw;
use crate::model::{LoadModel, Model};

/// load(λ) = from + λ (to − from).
pub fn loads_at(from: &[f64], to: &[f64], lambda: f64) -> Vec<f64> {
    from.iter()
        .zip(to)
        .map(|(a, b)| a + lambda * (b - a))
        .collect()
}

/// Set prescribed DOFs to their load values: the sum of what every input prescribing the DOF
/// gives it (a rotation plus a translation, a radial plus a tangential component).
pub fn prescribe(model: &Model, loads: &[f64], u: &mut [f64]) {
    for load in &model.loads {
        if let LoadModel::Displacement(p) = load {
            for &d in &p.dofs {
                u[d] = 0.0;
            }
        }
    }
    for (load, &value) in model.loads.iter().zip(loads) {
        if let LoadModel::Displacement(p) = load {
            p.add(&model.reference, value, u);
        }
    }
}

/// du/dλ of the prescribed DOFs at λ (zero elsewhere), None when no prescribed displacement
/// moves in the step.
pub fn prescribed_rate(
    model: &Model,
    from: &[f64],
    to: &[f64],
    lambda: f64,
    u: &[f64],
) -> Option<Vec<f64>> {
    let moves = model
        .loads
        .iter()
        .zip(from.iter().zip(to))
        .any(|(load, (a, b))| a != b && matches!(load, LoadModel::Displacement(_)));
    if !moves {
        return None;
    }
    let eps = 1e-6;
    let (mut plus, mut minus) = (u.to_vec(), u.to_vec());
    prescribe(model, &loads_at(from, to, lambda + eps), &mut plus);
    prescribe(model, &loads_at(from, to, lambda - eps), &mut minus);
    let mut rate = vec![0.0; model.dof_count()];
    for load in &model.loads {
        if let LoadModel::Displacement(p) = load {
            for &d in &p.dofs {
                rate[d] = (plus[d] - minus[d]) / (2.0 * eps);
            }
        }
    }
    Some(rate)
}

/// |Δf_ext|∞ of the load change `from` → `to` (pressures on the reference areas): the part of
/// the convergence test's force scale that makes a changed load count.
pub fn load_change(model: &Model, from: &[f64], to: &[f64]) -> f64 {
    let mut f = vec![0.0f64; model.dof_count()];
    for ((load, a), b) in model.loads.iter().zip(from).zip(to) {
        let delta = b - a;
        if delta == 0.0 {
            continue;
        }
        match load {
            LoadModel::PointForce(dofs) => {
                for &(d, unit) in dofs {
                    f[d] += unit * delta;
                }
            }
            LoadModel::Pressure { triangles, .. } => {
                for &e in triangles {
                    let t = &model.triangles[e];
                    let share = (delta * t.reference.area / 3.0).abs();
                    for &i in &t.nodes {
                        for c in 0..3 {
                            f[3 * i + c] += share * t.reference.normal[c].abs();
                        }
                    }
                }
            }
            // Snow per plan area (the reference one), a level change's pressure change γ_w Δh
            // on the reference area.
            LoadModel::Surface { triangles, law } => {
                for &e in triangles {
                    let t = &model.triangles[e];
                    let n = t.reference.normal;
                    let (share, dir) = match law {
                        SurfaceLaw::Snow => (delta * t.reference.area * n.z / 3.0, [0.0, 0.0, 1.0]),
                        SurfaceLaw::Ponding { gamma_w } => {
                            (gamma_w * delta * t.reference.area / 3.0, [n.x, n.y, n.z])
                        }
                    };
                    for &i in &t.nodes {
                        for c in 0..3 {
                            f[3 * i + c] += (share * dir[c]).abs();
                        }
                    }
                }
            }
            // A volume's pressure and a water volume's level are unknowns: their forces count
            // once assembled (|f_ext|∞).
            LoadModel::Displacement(_) | LoadModel::Volume { .. } | LoadModel::Water { .. } => {}
        }
    }
    f.iter().fold(0.0, |m, v| m.max(v.abs()))
}

/// External forces per DOF under `loads`, pressures on the reference geometry (the loads a
/// mechanism diagnosis weighs against the rigid motions).
pub fn external_forces(model: &Model, loads: &[f64]) -> Vec<f64> {
    let mut f = vec![0.0f64; model.dof_count()];
    for (load, &value) in model.loads.iter().zip(loads) {
        match load {
            LoadModel::PointForce(dofs) => {
                for &(d, unit) in dofs {
                    f[d] += unit * value;
                }
            }
            LoadModel::Pressure { triangles, .. } => {
                for &e in triangles {
                    let t = &model.triangles[e];
                    let share = t.reference.normal * (value * t.reference.area / 3.0);
                    for &i in &t.nodes {
                        for c in 0..3 {
                            f[3 * i + c] += share[c];
                        }
                    }
                }
            }
            LoadModel::Surface { triangles, law } => {
                for &e in triangles {
                    let t = &model.triangles[e];
                    let x = t.nodes.map(|i| model.reference[i]);
                    for (&i, share) in t.nodes.iter().zip(&law.forces(value, &x)) {
                        for c in 0..3 {
                            f[3 * i + c] += share[c];
                        }
                    }
                }
            }
            LoadModel::Displacement(_) | LoadModel::Volume { .. } | LoadModel::Water { .. } => {}
        }
    }
    f
}
