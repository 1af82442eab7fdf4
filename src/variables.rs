//! The variable table: the one list of FMU variables (parameters, inputs, outputs) derived from
//! a scene. The FMU binary, the generated modelDescription.xml and `velarium solve` all read
//! this table, so they cannot disagree.
//!
//! Value references are unique across types and assigned in order: parameters, inputs,
//! outputs (scene order within each), starting at 1.

use crate::scene::{Load, Material, ParameterVariability, Probe, Scene};

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Causality {
    Parameter,
    Input,
    Output,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Variability {
    Fixed,
    Tunable,
    Continuous,
    Discrete,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum VarType {
    Real,
    Integer,
}

/// Which scene entry a variable stands for (index into `scene.parameters`, `.inputs`,
/// `.outputs`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Binding {
    Parameter(usize),
    Input(usize),
    Output(usize),
}

#[derive(Clone, Debug, PartialEq)]
pub struct Variable {
    pub name: String,
    pub value_reference: u32,
    pub causality: Causality,
    pub variability: Variability,
    pub var_type: VarType,
    /// Unit name as declared in the modelDescription's UnitDefinitions (None: dimensionless).
    pub unit: Option<&'static str>,
    /// Start value (parameters and inputs); outputs have none (initial = calculated).
    pub start: Option<f64>,
    pub min: Option<f64>,
    pub max: Option<f64>,
    pub description: String,
    pub binding: Binding,
}

/// Every unit a variable may carry, with its SI base-unit exponents (kg, m, s, rad).
pub const UNITS: &[(&str, [i32; 4])] = &[
    ("m", [0, 1, 0, 0]),
    ("N", [1, 1, -2, 0]),
    ("Pa", [1, -1, -2, 0]),
    ("N/m", [1, 0, -2, 0]),
    ("m3", [0, 3, 0, 0]),
    ("N.m", [1, 2, -2, 0]),
    ("rad", [0, 0, 0, 1]),
];

/// Build the table of a (validated) scene. Parameter start values are read from the scene.
pub fn table(scene: &Scene) -> Vec<Variable> {
    let mut vars = Vec::new();
    let mut vr = 1u32;
    let mut next = || {
        let v = vr;
        vr += 1;
        v
    };
    for (i, p) in scene.parameters.iter().enumerate() {
        vars.push(Variable {
            name: p.name.clone(),
            value_reference: next(),
            causality: Causality::Parameter,
            variability: match p.variability {
                ParameterVariability::Fixed => Variability::Fixed,
                ParameterVariability::Tunable => Variability::Tunable,
            },
            var_type: VarType::Real,
            unit: parameter_unit(&p.target),
            start: parameter_value(scene, &p.target),
            min: None,
            max: None,
            description: p.description.clone(),
            binding: Binding::Parameter(i),
        });
    }
    for (i, input) in scene.inputs.iter().enumerate() {
        vars.push(Variable {
            name: input.name.clone(),
            value_reference: next(),
            causality: Causality::Input,
            variability: Variability::Continuous,
            var_type: VarType::Real,
            unit: Some(match input.load {
                Load::PointForce { .. } => "N",
                Load::Pressure { .. } => "Pa",
                Load::Displacement { .. } | Load::PolarDisplacement { .. } => "m",
                Load::Rotation { .. } => "rad",
                Load::RadialEdgeLoad { .. } => "N/m",
                Load::Volume { .. } | Load::Gas { .. } => "m3",
            }),
            start: Some(input.start),
            min: input.min,
            max: input.max,
            description: input.description.clone(),
            binding: Binding::Input(i),
        });
    }
    for (i, out) in scene.outputs.iter().enumerate() {
        let (var_type, variability, unit) = match out.probe {
            Probe::NewtonIterations | Probe::ElementState { .. } | Probe::SlipCount { .. } => {
                (VarType::Integer, Variability::Discrete, None)
            }
            Probe::WrinkledFraction { .. }
            | Probe::SlackFraction { .. }
            | Probe::ContactGap { .. } => (VarType::Real, Variability::Continuous, None),
            Probe::MaxPrincipalStress { .. } | Probe::MinPrincipalStress { .. } => {
                (VarType::Real, Variability::Continuous, Some("Pa"))
            }
            Probe::Displacement { .. }
            | Probe::Position { .. }
            | Probe::CableLength { .. }
            | Probe::CableSlip { .. }
            | Probe::CableEndSlip { .. } => (VarType::Real, Variability::Continuous, Some("m")),
            Probe::CableTension { .. }
            | Probe::Reaction { .. }
            | Probe::ReactionResultant { .. }
            | Probe::ContactForce { .. } => (VarType::Real, Variability::Continuous, Some("N")),
            Probe::ReactionMoment { .. } => (VarType::Real, Variability::Continuous, Some("N.m")),
            Probe::EnclosedVolume { .. } => (VarType::Real, Variability::Continuous, Some("m3")),
            Probe::EnclosedPressure { .. } => (VarType::Real, Variability::Continuous, Some("Pa")),
        };
        vars.push(Variable {
            name: out.name.clone(),
            value_reference: next(),
            causality: Causality::Output,
            variability,
            var_type,
            unit,
            start: None,
            min: None,
            max: None,
            description: out.description.clone(),
            binding: Binding::Output(i),
        });
    }
    vars
}

/// The unit of a parameter target, or None for a dimensionless one (nu) or an unknown target.
pub fn parameter_unit(target: &str) -> Option<&'static str> {
    if target.starts_with("cables.") && target.ends_with(".mu") {
        return None; // a friction coefficient
    }
    match target.rsplit('.').next() {
        Some("E") | Some("mu") | Some("artificial_prestress") => Some("Pa"),
        Some("thickness") => Some("m"),
        Some("EA") | Some("pretension") => Some("N"),
        _ => None,
    }
}

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
