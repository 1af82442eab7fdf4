//! The FMI 2.0 Co-Simulation `modelDescription.xml` of a scene, generated from the same variable
//! table the FMU binary uses (`crate::variables`), so the two cannot disagree.
//!
//! ```text
//! fmiModelDescription  fmiVersion 2.0, modelName = scene.name, guid = hash of this document
//!   CoSimulation       modelIdentifier = scene.name, the capability flags of crate::fmi
//!   UnitDefinitions    only the units some variable uses, with SI base-unit exponents
//!   LogCategories      crate::fmi::log_categories(): every category the binary logs under
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

use crate::fmi;
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

/// The complete FMI 2.0 modelDescription.xml of a scene.
///
/// `scene` is the scene the FMU builds its model from, which for a scene with `form_finding`
/// is the found one (`Engine::scene`), not the one given: its geometry and prestress, and so
/// parameter start values and array sizes, are the found ones. `variables` is that scene's
/// table as FMI 2 sees it, arrays as scalars (`variables::scalars` of `variables::try_table`,
/// or `Engine::variables`). Nothing else goes into the document: no solved state.
pub fn model_description(scene: &Scene, variables: &[Variable]) -> String {
    document(scene, variables, Version::Fmi2)
}

/// The GUID of [`model_description`] of the same arguments, `{8-4-4-4-12}` lowercase hex.
pub fn guid(scene: &Scene, variables: &[Variable]) -> String {
    token(scene, variables, Version::Fmi2)
}

/// The FMI version a description is written for: what differs between the two documents.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Version {
    Fmi2,
    Fmi3,
}

impl Version {
    fn number(self) -> &'static str {
        match self {
            Version::Fmi2 => "2.0",
            Version::Fmi3 => "3.0",
        }
    }

    /// The attribute that carries the document's hash.
    fn token_attribute(self) -> &'static str {
        match self {
            Version::Fmi2 => "guid",
            Version::Fmi3 => "instantiationToken",
        }
    }

    fn capability_flags(self) -> &'static [(&'static str, bool)] {
        match self {
            Version::Fmi2 => fmi::capability_flags(),
            Version::Fmi3 => fmi::capability_flags_fmi3(),
        }
    }
}

/// The document of `version` with its hash filled in.
pub(crate) fn document(scene: &Scene, variables: &[Variable], version: Version) -> String {
    let draft = render(scene, variables, version);
    draft.replacen(GUID_PLACEHOLDER, &guid_of(&draft), 1)
}

/// The hash of the document of `version` (the GUID or the instantiation token).
pub(crate) fn token(scene: &Scene, variables: &[Variable], version: Version) -> String {
    guid_of(&render(scene, variables, version))
}

/// The document with [`GUID_PLACEHOLDER`] where its hash goes.
fn render(scene: &Scene, variables: &[Variable], version: Version) -> String {
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
    match version {
        Version::Fmi2 => {
            model_variables(&mut x, variables);
            model_structure(&mut x, variables);
        }
        Version::Fmi3 => {
            crate::description3::model_variables(&mut x, variables);
            crate::description3::model_structure(&mut x, variables);
        }
    }
    x.push_str("</fmiModelDescription>\n");
    x
}

fn header(x: &mut String, scene: &Scene, variables: &[Variable], version: Version) {
    let structured = variables.iter().any(|v| v.name.contains(['.', '[']))
        && variables.iter().all(|v| is_structured_name(&v.name));
    let _ = writeln!(
        x,
        "<fmiModelDescription\n  fmiVersion=\"{}\"",
        version.number()
    );
    let _ = writeln!(x, "  modelName=\"{}\"", escape(&scene.name));
    let _ = writeln!(x, "  {}=\"{GUID_PLACEHOLDER}\"", version.token_attribute());
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
    match version {
        Version::Fmi2 => x.push_str("\n  numberOfEventIndicators=\"0\">\n"),
        Version::Fmi3 => x.push_str(">\n"),
    }
}

fn co_simulation(x: &mut String, scene: &Scene, version: Version) {
    let _ = write!(
        x,
        "  <CoSimulation\n    modelIdentifier=\"{}\"",
        escape(&scene.name)
    );
    for (flag, value) in version.capability_flags() {
        let _ = write!(x, "\n    {flag}=\"{value}\"");
    }
    let _ = writeln!(
        x,
        "\n    maxOutputDerivativeOrder=\"{}\"/>",
        fmi::MAX_OUTPUT_DERIVATIVE_ORDER
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

pub(crate) fn log_categories(x: &mut String) {
    x.push_str("  <LogCategories>\n");
    for (name, description) in fmi::log_categories() {
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
