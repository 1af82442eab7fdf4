//! The variable table: the one list of FMU variables (parameters, inputs, outputs) derived from
//! a scene. The FMU binary, the generated modelDescription.xml and `velarium solve` all read
//! this table, so they cannot disagree.
//!
//! Value references are unique across types and assigned in order: parameters, inputs,
//! outputs (scene order within each), starting at 1. An array variable (`scene::shape`) takes
//! as many value references as it has elements: its own is the first, and FMI 2, which has no
//! arrays, numbers its scalars `name[i]` / `name[i,j]` (1-based, row-major) with it and the
//! ones after it ([`scalars`]). So one numbering serves both versions, and a scene without
//! arrays has the same table in both.

use crate::scene::generate::try_resolve;
use crate::scene::shape::{element_count, has_arrays, input_shape, output_shape};
pub use crate::scene::target::{parameter_value, set_parameter_value};
use crate::scene::{Load, ParameterVariability, Probe, Scene};

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
    /// An FMI 3 UInt8 (wrinkle states); an Integer in FMI 2.
    UInt8,
}

impl VarType {
    /// The FMI 2 type the variable is read with (Real or Integer).
    pub fn fmi2(self) -> VarType {
        match self {
            VarType::Real => VarType::Real,
            VarType::Integer | VarType::UInt8 => VarType::Integer,
        }
    }
}

/// Where a variable's value lives: the index into `scene.parameters`, or the first slot of the
/// engine's flat input (load channel) or output (probe) vector; an array's elements follow in
/// row-major order.
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
    /// Array dimensions (FMI 3 `<Dimension start=...>`), outermost first; empty for a scalar.
    pub dims: Vec<usize>,
}

impl Variable {
    /// Number of scalar elements (1 for a scalar).
    pub fn len(&self) -> usize {
        element_count(&self.dims)
    }

    /// Whether it has no elements (an array with a zero dimension).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    pub fn is_array(&self) -> bool {
        !self.dims.is_empty()
    }

    /// The value-reference range of the variable's elements.
    pub fn references(&self) -> std::ops::Range<u32> {
        self.value_reference..self.value_reference + self.len() as u32
    }
}

/// Every unit a variable may carry, with its SI base-unit exponents (kg, m, s, rad).
pub const UNITS: &[(&str, [i32; 4])] = &[
    ("m", [0, 1, 0, 0]),
    ("N", [1, 1, -2, 0]),
    ("Pa", [1, -1, -2, 0]),
    ("N/m", [1, 0, -2, 0]),
    ("m2", [0, 2, 0, 0]),
    ("m3", [0, 3, 0, 0]),
    ("m/s", [0, 1, -1, 0]),
    ("m/s2", [0, 1, -2, 0]),
    ("J", [1, 2, -2, 0]),
    ("N.m", [1, 2, -2, 0]),
    ("rad", [0, 0, 0, 1]),
    ("Hz", [0, 0, -1, 0]),
];

/// Build the table of a (validated) scene. Parameter start values are read from the scene.
pub fn table(scene: &Scene) -> Vec<Variable> {
    try_table(scene).expect("the mesh of a scene with array variables")
}

/// [`table`], with the memory for the mesh an array's shape needs (only a scene with arrays
/// builds it) reported instead of assumed.
pub fn try_table(scene: &Scene) -> Result<Vec<Variable>, crate::memory::OutOfMemory> {
    let mesh = if has_arrays(scene) {
        try_resolve(&scene.geometry)?
    } else {
        crate::scene::generate::Mesh::default()
    };
    let mut vars = Vec::new();
    let mut vr = 1u32;
    let mut next = |len: usize| {
        let v = vr;
        vr += len as u32;
        v
    };
    let (mut input_slot, mut output_slot) = (0, 0);
    for (i, p) in scene.parameters.iter().enumerate() {
        vars.push(Variable {
            name: p.name.clone(),
            value_reference: next(1),
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
            dims: Vec::new(),
        });
    }
    for input in &scene.inputs {
        let dims = input_shape(&mesh, &input.load);
        let len = element_count(&dims);
        vars.push(Variable {
            name: input.name.clone(),
            value_reference: next(len),
            causality: Causality::Input,
            variability: Variability::Continuous,
            var_type: VarType::Real,
            unit: Some(match input.load {
                Load::PointForce { .. } => "N",
                Load::Pressure { .. } | Load::ZonePressure { .. } | Load::Snow { .. } => "Pa",
                Load::SelfWeight { .. } => "m/s2",
                Load::Ponding { .. } => "m",
                Load::WaterVolume { .. } => "m3",
                Load::Displacement { .. }
                | Load::PolarDisplacement { .. }
                | Load::SupportDisplacement { .. } => "m",
                Load::Rotation { .. } => "rad",
                Load::RadialEdgeLoad { .. } => "N/m",
                Load::Volume { .. } | Load::Gas { .. } => "m3",
            }),
            start: Some(input.start),
            min: input.min,
            max: input.max,
            description: input.description.clone(),
            binding: Binding::Input(input_slot),
            dims,
        });
        input_slot += len;
    }
    for out in &scene.outputs {
        let dims = output_shape(scene, &mesh, &out.probe);
        let len = element_count(&dims);
        let (var_type, variability, unit) = match out.probe {
            Probe::NewtonIterations | Probe::ElementState { .. } | Probe::SlipCount { .. } => {
                (VarType::Integer, Variability::Discrete, None)
            }
            Probe::WrinkleStates { .. } => (VarType::UInt8, Variability::Discrete, None),
            Probe::PrincipalStresses { .. } => (VarType::Real, Variability::Continuous, Some("Pa")),
            Probe::DisplacementField { .. }
            | Probe::PositionField { .. }
            | Probe::SleeveSlips { .. } => (VarType::Real, Variability::Continuous, Some("m")),
            Probe::CableTensions { .. } => (VarType::Real, Variability::Continuous, Some("N")),
            Probe::WrinkledFraction { .. }
            | Probe::SlackFraction { .. }
            | Probe::ContactGap { .. } => (VarType::Real, Variability::Continuous, None),
            Probe::MaxPrincipalStress { .. } | Probe::MinPrincipalStress { .. } => {
                (VarType::Real, Variability::Continuous, Some("Pa"))
            }
            Probe::Displacement { .. }
            | Probe::PolarDisplacement { .. }
            | Probe::Position { .. }
            | Probe::CableLength { .. }
            | Probe::CableSlip { .. }
            | Probe::CableEndSlip { .. } => (VarType::Real, Variability::Continuous, Some("m")),
            Probe::CableTension { .. }
            | Probe::Reaction { .. }
            | Probe::ReactionResultant { .. }
            | Probe::ZoneForce { .. }
            | Probe::ContactForce { .. } => (VarType::Real, Variability::Continuous, Some("N")),
            Probe::ReactionMoment { .. } => (VarType::Real, Variability::Continuous, Some("N.m")),
            Probe::EnclosedVolume { .. } => (VarType::Real, Variability::Continuous, Some("m3")),
            Probe::EnclosedPressure { .. } => (VarType::Real, Variability::Continuous, Some("Pa")),
            Probe::WaterLevel { .. } => (VarType::Real, Variability::Continuous, Some("m")),
            Probe::ContactTotal { .. } => (VarType::Real, Variability::Continuous, Some("N")),
            Probe::ContactArea { .. } => (VarType::Real, Variability::Continuous, Some("m2")),
            Probe::NaturalFrequency { .. } => (VarType::Real, Variability::Continuous, Some("Hz")),
            Probe::Velocity { .. } => (VarType::Real, Variability::Continuous, Some("m/s")),
            Probe::Acceleration { .. } => (VarType::Real, Variability::Continuous, Some("m/s2")),
            Probe::KineticEnergy | Probe::StrainEnergy => {
                (VarType::Real, Variability::Continuous, Some("J"))
            }
        };
        vars.push(Variable {
            name: out.name.clone(),
            value_reference: next(len),
            causality: Causality::Output,
            variability,
            var_type,
            unit,
            start: None,
            min: None,
            max: None,
            description: out.description.clone(),
            binding: Binding::Output(output_slot),
            dims,
        });
        output_slot += len;
    }
    Ok(vars)
}

/// The table as FMI 2 sees it: every array variable replaced by its scalars `name[i]` or
/// `name[i,j]` (1-based, row-major), value references and slots counting up from the
/// array's; scalars unchanged.
pub fn scalars(table: &[Variable]) -> Vec<Variable> {
    let mut out = Vec::with_capacity(table.len());
    for v in table {
        if !v.is_array() {
            out.push(v.clone());
            continue;
        }
        for k in 0..v.len() {
            let binding = match v.binding {
                Binding::Input(s) => Binding::Input(s + k),
                Binding::Output(s) => Binding::Output(s + k),
                Binding::Parameter(p) => Binding::Parameter(p),
            };
            out.push(Variable {
                name: format!("{}[{}]", v.name, element_index(&v.dims, k)),
                value_reference: v.value_reference + k as u32,
                binding,
                dims: Vec::new(),
                ..v.clone()
            });
        }
    }
    out
}

/// The 1-based subscripts of row-major element `k` of an array of shape `dims`: `"3"` or
/// `"2,1"`.
pub fn element_index(dims: &[usize], k: usize) -> String {
    let mut rest = k;
    let mut subscripts = vec![0; dims.len()];
    for (d, n) in dims.iter().enumerate().rev() {
        subscripts[d] = rest % n + 1;
        rest /= n;
    }
    subscripts
        .iter()
        .map(usize::to_string)
        .collect::<Vec<_>>()
        .join(",")
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
