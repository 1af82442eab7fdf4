//! The FMI 2.0 Co-Simulation `modelDescription.xml` of a scene, generated from the same variable
//! table the FMU binary uses (`crate::variables`), so the two cannot disagree.
//!
//! ```text
//! fmiModelDescription  fmiVersion 2.0, modelName = scene.name, guid = hash of this document
//!   CoSimulation       modelIdentifier = scene.name, [`capability_flags`]
//!   UnitDefinitions    only the units some variable uses, with SI base-unit exponents
//!   LogCategories      [`LOG_CATEGORIES`]: every category the binary logs under
//!   DefaultExperiment  scene.experiment
//!   ModelVariables     parameters (fixed | tunable, start), inputs (continuous, start, no
//!                      `initial`), outputs (Real continuous | Integer discrete, no start)
//!   ModelStructure     Outputs and InitialUnknowns: every output, 1-based indices, no
//!                      `dependencies` attribute (= depends on every input and parameter)
//! ```
//!
//! The GUID is a 128-bit FNV-1a hash of the document rendered with a placeholder GUID: the same
//! scene and crate version give the same GUID on every machine, any change to the description
//! gives a different one, and the FMU binary compares it at instantiation.
//!
//! What the FMU declares about itself (capability flags, log categories) is defined here and
//! implemented by `crate::fmi`, which imports it: the adapter depends on the description, never
//! the other way round. `crate::description3` writes the FMI 3.0 document with the skeleton of
//! this one (see `Version`).

use crate::format::xs_double;
use crate::scene::Scene;
use crate::variables::{Causality, VarType, Variability, Variable, UNITS};
use std::fmt::Write;

/// Stands where the GUID goes while the document is hashed.
pub(crate) const GUID_PLACEHOLDER: &str = "{00000000-0000-0000-0000-000000000000}";

/// Display units offered per unit: (unit, display unit, factor from unit to display unit).
const DISPLAY_UNITS: &[(&str, &str, f64)] = &[
    ("m", "mm", 1e3),
    ("N", "kN", 1e-3),
    ("Pa", "MPa", 1e-6),
    ("Pa", "GPa", 1e-9),
    ("N.m", "kN.m", 1e-3),
    ("rad", "deg", 57.29577951308232),
];

/// `CoSimulation` capability flags, consistent with what the binary (`crate::fmi`) does.
pub const CAN_HANDLE_VARIABLE_COMMUNICATION_STEP_SIZE: bool = true;
pub const CAN_GET_AND_SET_FMU_STATE: bool = true;
pub const CAN_SERIALIZE_FMU_STATE: bool = true;
pub const CAN_NOT_USE_MEMORY_MANAGEMENT_FUNCTIONS: bool = true;
pub const CAN_INTERPOLATE_INPUTS: bool = false;
/// `providesDirectionalDerivative` (FMI 2) and `providesDirectionalDerivatives` /
/// `providesAdjointDerivatives` (FMI 3): derivatives at the committed equilibrium.
pub const PROVIDES_DIRECTIONAL_DERIVATIVE: bool = true;
pub const CAN_RUN_ASYNCHRONUOUSLY: bool = false;
pub const CAN_BE_INSTANTIATED_ONLY_ONCE_PER_PROCESS: bool = false;
pub const NEEDS_EXECUTION_TOOL: bool = false;
/// `maxOutputDerivativeOrder`: `fmi2GetRealOutputDerivatives` is not supported.
pub const MAX_OUTPUT_DERIVATIVE_ORDER: u32 = 0;

/// The boolean FMI 2 `CoSimulation` attributes as (XML attribute name, value), in the order
/// the FMI 2.0 schema lists them.
const CAPABILITY_FLAGS: &[(&str, bool)] = &[
    ("needsExecutionTool", NEEDS_EXECUTION_TOOL),
    (
        "canHandleVariableCommunicationStepSize",
        CAN_HANDLE_VARIABLE_COMMUNICATION_STEP_SIZE,
    ),
    ("canInterpolateInputs", CAN_INTERPOLATE_INPUTS),
    ("canRunAsynchronuously", CAN_RUN_ASYNCHRONUOUSLY),
    (
        "canBeInstantiatedOnlyOncePerProcess",
        CAN_BE_INSTANTIATED_ONLY_ONCE_PER_PROCESS,
    ),
    (
        "canNotUseMemoryManagementFunctions",
        CAN_NOT_USE_MEMORY_MANAGEMENT_FUNCTIONS,
    ),
    ("canGetAndSetFMUstate", CAN_GET_AND_SET_FMU_STATE),
    ("canSerializeFMUstate", CAN_SERIALIZE_FMU_STATE),
    (
        "providesDirectionalDerivative",
        PROVIDES_DIRECTIONAL_DERIVATIVE,
    ),
];

/// The boolean FMI 2 `CoSimulation` attributes as (XML attribute name, value), in the order
/// the FMI 2.0 schema lists them. The description writes them as they are.
pub fn capability_flags() -> &'static [(&'static str, bool)] {
    CAPABILITY_FLAGS
}

/// The log categories declared in `<LogCategories>`, as (name, description), in order. The
/// binary logs under these and no other (`crate::fmi::logging::Category` indexes this list).
pub const LOG_CATEGORIES: &[(&str, &str)] = &[
    (
        "logStatusWarning",
        "Warnings: the call succeeded, but something deserves attention",
    ),
    (
        "logStatusDiscard",
        "Discarded steps: the load increments did not converge (reached fraction and reason)",
    ),
    (
        "logStatusError",
        "Errors: illegal calls, invalid arguments, rejected states (always logged)",
    ),
    ("logStatusFatal", "Fatal errors (always logged)"),
    (
        "logSolver",
        "Solver progress: Newton iterations and residuals per load increment",
    ),
    (
        "logCalls",
        "A trace of the FMI function calls and their arguments",
    ),
];

/// The complete FMI 2.0 modelDescription.xml of a scene.
///
/// `scene` is the scene the FMU builds its model from, which for a scene with `form_finding`
/// is the found one (`Engine::scene`), not the one given: its geometry and prestress, and so
/// parameter start values and array sizes, are the found ones. `variables` is that scene's
/// table as FMI 2 sees it, arrays as scalars (`variables::scalars` of `variables::try_table`,
/// or `Engine::variables`). Nothing else goes into the document: no solved state.
pub fn model_description(scene: &Scene, variables: &[Variable]) -> String {
    document(scene, variables, &FMI2)
}

/// The GUID of [`model_description`] of the same arguments, `{8-4-4-4-12}` lowercase hex.
pub fn guid(scene: &Scene, variables: &[Variable]) -> String {
    token(scene, variables, &FMI2)
}

/// What differs between the FMI 2 and the FMI 3 document. [`FMI2`] is here,
/// `description3::FMI3` beside its own variable sections; the skeleton ([`render`]) is shared.
pub(crate) struct Version {
    /// `fmiVersion`.
    pub(crate) number: &'static str,
    /// The attribute that carries the document's hash.
    pub(crate) token_attribute: &'static str,
    /// What closes the root element's start tag.
    pub(crate) header_end: &'static str,
    /// The boolean `CoSimulation` attributes, in schema order.
    pub(crate) capability_flags: &'static [(&'static str, bool)],
    /// Writes `<ModelVariables>`.
    pub(crate) model_variables: fn(&mut String, &[Variable]),
    /// Writes `<ModelStructure>`.
    pub(crate) model_structure: fn(&mut String, &[Variable]),
}

/// The FMI 2.0 document: variables as `<ScalarVariable>`s (arrays as their scalars).
const FMI2: Version = Version {
    number: "2.0",
    token_attribute: "guid",
    header_end: "\n  numberOfEventIndicators=\"0\">\n",
    capability_flags: CAPABILITY_FLAGS,
    model_variables,
    model_structure,
};

/// The document of `version` with its hash filled in.
pub(crate) fn document(scene: &Scene, variables: &[Variable], version: &Version) -> String {
    let draft = render(scene, variables, version);
    draft.replacen(GUID_PLACEHOLDER, &guid_of(&draft), 1)
}

/// The hash of the document of `version` (the GUID or the instantiation token).
pub(crate) fn token(scene: &Scene, variables: &[Variable], version: &Version) -> String {
    guid_of(&render(scene, variables, version))
}

/// The document with [`GUID_PLACEHOLDER`] where its hash goes.
fn render(scene: &Scene, variables: &[Variable], version: &Version) -> String {
    let mut x = String::new();
    x.push_str("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n");
    header(&mut x, scene, variables, version);
    co_simulation(&mut x, scene, version);
    unit_definitions(&mut x, variables);
    log_categories(&mut x);
    let e = &scene.experiment;
    let _ = writeln!(
        x,
        "  <DefaultExperiment startTime=\"{}\" stopTime=\"{}\" stepSize=\"{}\"/>",
        xs_double(e.start_time),
        xs_double(e.stop_time),
        xs_double(e.step_size)
    );
    (version.model_variables)(&mut x, variables);
    (version.model_structure)(&mut x, variables);
    x.push_str("</fmiModelDescription>\n");
    x
}

fn header(x: &mut String, scene: &Scene, variables: &[Variable], version: &Version) {
    let structured = variables.iter().any(|v| v.name.contains(['.', '[']))
        && variables.iter().all(|v| is_structured_name(&v.name));
    let _ = writeln!(
        x,
        "<fmiModelDescription\n  fmiVersion=\"{}\"",
        version.number
    );
    let _ = writeln!(x, "  modelName=\"{}\"", escape(&scene.name));
    let _ = writeln!(x, "  {}=\"{GUID_PLACEHOLDER}\"", version.token_attribute);
    if !scene.description.is_empty() {
        let _ = writeln!(x, "  description=\"{}\"", escape(&scene.description));
    }
    let _ = writeln!(
        x,
        "  generationTool=\"Velarium {}\"",
        env!("CARGO_PKG_VERSION")
    );
    let convention = if structured { "structured" } else { "flat" };
    let _ = write!(x, "  variableNamingConvention=\"{convention}\"");
    x.push_str(version.header_end);
}

fn co_simulation(x: &mut String, scene: &Scene, version: &Version) {
    let _ = write!(
        x,
        "  <CoSimulation\n    modelIdentifier=\"{}\"",
        escape(&scene.name)
    );
    for (flag, value) in version.capability_flags {
        let _ = write!(x, "\n    {flag}=\"{value}\"");
    }
    let _ = writeln!(
        x,
        "\n    maxOutputDerivativeOrder=\"{}\"/>",
        MAX_OUTPUT_DERIVATIVE_ORDER
    );
}

/// Units in `UNITS` order, only those some variable uses; absent when none is used.
pub(crate) fn unit_definitions(x: &mut String, variables: &[Variable]) {
    let used: Vec<&(&str, [i32; 4])> = UNITS
        .iter()
        .filter(|(name, _)| variables.iter().any(|v| v.unit == Some(*name)))
        .collect();
    if used.is_empty() {
        return;
    }
    x.push_str("  <UnitDefinitions>\n");
    for (name, exponents) in used {
        let _ = writeln!(x, "    <Unit name=\"{}\">", escape(name));
        x.push_str("      <BaseUnit");
        for (base, exponent) in ["kg", "m", "s", "rad"].iter().zip(exponents) {
            if *exponent != 0 {
                let _ = write!(x, " {base}=\"{exponent}\"");
            }
        }
        x.push_str("/>\n");
        for (_, display, factor) in DISPLAY_UNITS.iter().filter(|(u, _, _)| u == name) {
            let _ = writeln!(
                x,
                "      <DisplayUnit name=\"{display}\" factor=\"{}\"/>",
                xs_double(*factor)
            );
        }
        x.push_str("    </Unit>\n");
    }
    x.push_str("  </UnitDefinitions>\n");
}

fn log_categories(x: &mut String) {
    x.push_str("  <LogCategories>\n");
    for (name, description) in LOG_CATEGORIES {
        let _ = writeln!(
            x,
            "    <Category name=\"{}\" description=\"{}\"/>",
            escape(name),
            escape(description)
        );
    }
    x.push_str("  </LogCategories>\n");
}

fn model_variables(x: &mut String, variables: &[Variable]) {
    x.push_str("  <ModelVariables>\n");
    for (i, v) in variables.iter().enumerate() {
        let _ = writeln!(x, "    <!-- index {} -->", i + 1);
        scalar_variable(x, v);
    }
    x.push_str("  </ModelVariables>\n");
}

fn scalar_variable(x: &mut String, v: &Variable) {
    let _ = write!(
        x,
        "    <ScalarVariable\n      name=\"{}\"\n      valueReference=\"{}\"",
        escape(&v.name),
        v.value_reference
    );
    if !v.description.is_empty() {
        let _ = write!(x, "\n      description=\"{}\"", escape(&v.description));
    }
    let _ = writeln!(
        x,
        "\n      causality=\"{}\"\n      variability=\"{}\">",
        causality(v.causality),
        variability(v.variability)
    );
    let (element, mut attributes) = match v.var_type {
        VarType::Real => ("Real", String::new()),
        VarType::Integer | VarType::UInt8 => ("Integer", String::new()),
    };
    if let Some(unit) = v.unit {
        let _ = write!(attributes, " unit=\"{}\"", escape(unit));
    }
    // Outputs are `initial="calculated"` (the default) and so carry no start value.
    let start = if v.causality == Causality::Output {
        None
    } else {
        v.start
    };
    for (name, value) in [("start", start), ("min", v.min), ("max", v.max)] {
        if let Some(value) = value {
            let text = match v.var_type {
                VarType::Real => xs_double(value),
                VarType::Integer | VarType::UInt8 => format!("{}", value.round() as i64),
            };
            let _ = write!(attributes, " {name}=\"{text}\"");
        }
    }
    let _ = writeln!(x, "      <{element}{attributes}/>");
    x.push_str("    </ScalarVariable>\n");
}

/// Outputs and InitialUnknowns both list exactly the outputs (all `initial="calculated"`; there
/// are no calculated parameters), by 1-based index, in index order.
fn model_structure(x: &mut String, variables: &[Variable]) {
    let outputs: Vec<usize> = variables
        .iter()
        .enumerate()
        .filter(|(_, v)| v.causality == Causality::Output)
        .map(|(i, _)| i + 1)
        .collect();
    x.push_str("  <ModelStructure>\n");
    if !outputs.is_empty() {
        for section in ["Outputs", "InitialUnknowns"] {
            let _ = writeln!(x, "    <{section}>");
            for index in &outputs {
                let _ = writeln!(x, "      <Unknown index=\"{index}\"/>");
            }
            let _ = writeln!(x, "    </{section}>");
        }
    }
    x.push_str("  </ModelStructure>\n");
}

pub(crate) fn causality(c: Causality) -> &'static str {
    match c {
        Causality::Parameter => "parameter",
        Causality::Input => "input",
        Causality::Output => "output",
    }
}

pub(crate) fn variability(v: Variability) -> &'static str {
    match v {
        Variability::Fixed => "fixed",
        Variability::Tunable => "tunable",
        Variability::Continuous => "continuous",
        Variability::Discrete => "discrete",
    }
}

/// Text for an XML attribute value in double quotes.
pub(crate) fn escape(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&apos;"),
            '\n' => out.push_str("&#10;"),
            '\r' => out.push_str("&#13;"),
            '\t' => out.push_str("&#9;"),
            c if (c as u32) < 0x20 => {} // not representable in XML 1.0
            c => out.push(c),
        }
    }
    out
}

/// A name under FMI 2's structured convention as far as our names can go (no quoted names, no
/// `der(...)`): `B-name [indices] {"." B-name [indices]}`, indices `[1]` or `[1,2]`.
pub(crate) fn is_structured_name(name: &str) -> bool {
    name.split('.').all(|part| {
        let (base, indices) = match part.find('[') {
            Some(at) => (&part[..at], Some(&part[at..])),
            None => (part, None),
        };
        let mut chars = base.chars();
        let base_ok = matches!(chars.next(), Some(c) if c.is_ascii_alphabetic() || c == '_')
            && chars.all(|c| c.is_ascii_alphanumeric() || c == '_');
        let indices_ok = indices.is_none_or(|ix| {
            ix.strip_prefix('[')
                .and_then(|s| s.strip_suffix(']'))
                .is_some_and(|list| {
                    list.split(',')
                        .all(|n| !n.is_empty() && n.bytes().all(|b| b.is_ascii_digit()))
                })
        });
        base_ok && indices_ok
    })
}

/// 128-bit FNV-1a of the text, formatted `{8-4-4-4-12}`.
pub(crate) fn guid_of(text: &str) -> String {
    const OFFSET: u128 = 0x6c62272e07bb014262b821756295c58d;
    const PRIME: u128 = 0x0000000001000000000000000000013b;
    let hash = text
        .bytes()
        .fold(OFFSET, |h, b| (h ^ u128::from(b)).wrapping_mul(PRIME));
    let hex = format!("{hash:032x}");
    format!(
        "{{{}-{}-{}-{}-{}}}",
        &hex[0..8],
        &hex[8..12],
        &hex[12..16],
        &hex[16..20],
        &hex[20..32]
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fnv1a_128_matches_the_published_vectors() {
        // Of "" it is the offset basis; of "a" the value in the FNV reference test suite.
        assert_eq!(guid_of(""), "{6c62272e-07bb-0142-62b8-21756295c58d}");
        assert_eq!(guid_of("a"), "{d228cb69-6f1a-8caf-7891-2b704e4a8964}");
    }

    #[test]
    fn structured_names() {
        for ok in ["a", "a.b", "cable[2].length", "u[12,3]", "_x1.y_2[0]"] {
            assert!(is_structured_name(ok), "{ok}");
        }
        for bad in ["a..b", "a[", "a[]", "1a", "a.[1]", "a]b", ".a", "a."] {
            assert!(!is_structured_name(bad), "{bad}");
        }
    }

    #[test]
    fn escapes_attribute_text() {
        assert_eq!(
            escape("a<b & \"c\" 'd'>\n"),
            "a&lt;b &amp; &quot;c&quot; &apos;d&apos;&gt;&#10;"
        );
    }
}
