//! Parameter targets: the scene value a parameter names, read and written by its target path.
//!
//! ```text
//! membranes.<name>.<field>   E, nu (svk), mu (neo_hookean), E_warp, E_fill, nu_wf, G
//!                            (orthotropic), thickness
//! cables.<name>.<field>      EA, pretension, mu (the sleeve's friction coefficient)
//! solver.artificial_prestress
//! debug.<field>              fail_after_time, panic_after_time
//! ```
//! Validation asks whether a target exists and has a value, the variable table takes a
//! parameter's start value from the scene, and a parameter change is written into the scene
//! before the model is built again: all three through these functions, so they cannot disagree.

use super::{Material, Scene};

/// Split a parameter target `membranes.<name>.<field>` into its three parts.
fn split_target(target: &str) -> Option<(&str, &str, &str)> {
    for section in ["solver", "debug"] {
        if let Some(field) = target
            .strip_prefix(section)
            .and_then(|t| t.strip_prefix('.'))
        {
            return Some((section, "", field));
        }
    }
    let (kind, rest) = target.split_once('.')?;
    let (name, field) = rest.rsplit_once('.')?;
    Some((kind, name, field))
}

/// The scene's current value of a parameter target (None: the target does not exist).
pub fn parameter_value(scene: &Scene, target: &str) -> Option<f64> {
    let (kind, name, field) = split_target(target)?;
    match (kind, field) {
        ("solver", "artificial_prestress") => {
            Some(scene.solver.artificial_prestress.unwrap_or(f64::NAN))
        }
        ("debug", _) => scene.debug.get(field),
        ("membranes", _) => {
            let m = scene.membranes.iter().find(|m| m.name == name)?;
            match (field, &m.material) {
                ("E", Material::Svk { young, .. }) => Some(*young),
                ("nu", Material::Svk { nu, .. }) => Some(*nu),
                ("E", Material::Etfe { young, .. }) => Some(*young),
                ("nu", Material::Etfe { nu, .. }) => Some(*nu),
                ("mu", Material::NeoHookean { mu }) => Some(*mu),
                ("E_warp", Material::Orthotropic { e_warp, .. }) => Some(*e_warp),
                ("E_fill", Material::Orthotropic { e_fill, .. }) => Some(*e_fill),
                ("nu_wf", Material::Orthotropic { nu_wf, .. }) => Some(*nu_wf),
                ("G", Material::Orthotropic { g, .. }) => Some(*g),
                ("thickness", _) => Some(m.thickness),
                _ => None,
            }
        }
        ("cables", _) => {
            let c = scene.cables.iter().find(|c| c.name == name)?;
            match field {
                "EA" => Some(c.ea),
                "pretension" => Some(c.pretension.unwrap_or(0.0)),
                "mu" => c.sleeve.as_ref().map(|s| s.mu),
                _ => None,
            }
        }
        _ => None,
    }
}

/// Write a parameter value into the scene. Returns false when the target does not exist.
pub fn set_parameter_value(scene: &mut Scene, target: &str, value: f64) -> bool {
    let Some((kind, name, field)) = split_target(target) else {
        return false;
    };
    match (kind, field) {
        ("solver", "artificial_prestress") => {
            scene.solver.artificial_prestress = Some(value);
            true
        }
        ("debug", _) => scene.debug.set(field, value),
        ("membranes", _) => {
            let Some(m) = scene.membranes.iter_mut().find(|m| m.name == name) else {
                return false;
            };
            match (field, &mut m.material) {
                ("E", Material::Svk { young, .. }) => *young = value,
                ("nu", Material::Svk { nu, .. }) => *nu = value,
                ("E", Material::Etfe { young, .. }) => *young = value,
                ("nu", Material::Etfe { nu, .. }) => *nu = value,
                ("mu", Material::NeoHookean { mu }) => *mu = value,
                ("E_warp", Material::Orthotropic { e_warp, .. }) => *e_warp = value,
                ("E_fill", Material::Orthotropic { e_fill, .. }) => *e_fill = value,
                ("nu_wf", Material::Orthotropic { nu_wf, .. }) => *nu_wf = value,
                ("G", Material::Orthotropic { g, .. }) => *g = value,
                ("thickness", _) => m.thickness = value,
                _ => return false,
            }
            true
        }
        ("cables", _) => {
            let Some(c) = scene.cables.iter_mut().find(|c| c.name == name) else {
                return false;
            };
            match field {
                "EA" => c.ea = value,
                "mu" => match c.sleeve.as_mut() {
                    Some(sleeve) => sleeve.mu = value,
                    None => return false,
                },
                "pretension" => {
                    c.pretension = Some(value);
                    c.unstretched_length = None;
                }
                _ => return false,
            }
            true
        }
        _ => false,
    }
}
