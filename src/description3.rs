//! The FMI 3.0 Co-Simulation `modelDescription.xml` of a scene, from the same variable table as
//! the FMI 2 one (`crate::description`) and the binary.
//!
//! ```text
//! fmiModelDescription  fmiVersion 3.0, modelName = scene.name, instantiationToken = hash of
//!                      this document (the binary compares it in fmi3InstantiateCoSimulation)
//!   CoSimulation       modelIdentifier = scene.name, [`capability_flags_fmi3`]
//!   UnitDefinitions    as in FMI 2 (only the units some variable uses)
//!   LogCategories      as in FMI 2
//!   DefaultExperiment  scene.experiment
//!   ModelVariables     time (Float64, valueReference 0, causality independent), then the
//!                      table: Real -> <Float64>, Integer -> <Int32 variability="discrete">;
//!                      the value references are the FMI 2 ones
//!   ModelStructure     <Output valueReference=.../> and <InitialUnknown valueReference=.../>
//!                      for every output (all initial="calculated"), in table order
//! ```
//!
//! The token is the FMI 2 GUID's construction applied to this document, so it differs from the
//! FMI 2 GUID of the same scene: an FMU state serialized by one archive is rejected by the
//! other (its bytes carry the GUID or token they were made with).

use crate::description::{
    causality, document, escape, token, variability, Version,
    CAN_BE_INSTANTIATED_ONLY_ONCE_PER_PROCESS, CAN_GET_AND_SET_FMU_STATE,
    CAN_HANDLE_VARIABLE_COMMUNICATION_STEP_SIZE, CAN_SERIALIZE_FMU_STATE, NEEDS_EXECUTION_TOOL,
    PROVIDES_DIRECTIONAL_DERIVATIVE,
};
use crate::format::xs_double;
use crate::scene::Scene;
use crate::variables::{Causality, VarType, Variable};
use std::fmt::Write;

/// The name of the independent variable (value reference [`TIME_VALUE_REFERENCE`]).
pub const TIME_NAME: &str = "time";

/// The value reference of the one `causality="independent"` variable, `time` (FMI 3 requires
/// exactly one; the variable table starts at 1, so 0 is free).
pub const TIME_VALUE_REFERENCE: u32 = 0;

/// FMI 3 `CoSimulation` capability flags (booleans), consistent with what the binary does, as
/// (XML attribute, value) in the order of the FMI 3.0 schema. `maxOutputDerivativeOrder` is
/// [`crate::description::MAX_OUTPUT_DERIVATIVE_ORDER`].
const CAPABILITY_FLAGS: &[(&str, bool)] = &[
    ("needsExecutionTool", NEEDS_EXECUTION_TOOL),
    (
        "canBeInstantiatedOnlyOncePerProcess",
        CAN_BE_INSTANTIATED_ONLY_ONCE_PER_PROCESS,
    ),
    ("canGetAndSetFMUState", CAN_GET_AND_SET_FMU_STATE),
    ("canSerializeFMUState", CAN_SERIALIZE_FMU_STATE),
    (
        "providesDirectionalDerivatives",
        PROVIDES_DIRECTIONAL_DERIVATIVE,
    ),
    (
        "providesAdjointDerivatives",
        PROVIDES_DIRECTIONAL_DERIVATIVE,
    ),
    ("providesPerElementDependencies", false),
    (
        "canHandleVariableCommunicationStepSize",
        CAN_HANDLE_VARIABLE_COMMUNICATION_STEP_SIZE,
    ),
    ("providesIntermediateUpdate", true),
    ("mightReturnEarlyFromDoStep", true),
    ("canReturnEarlyAfterIntermediateUpdate", true),
    ("hasEventMode", false),
    ("providesEvaluateDiscreteStates", false),
];

/// FMI 3 `CoSimulation` capability flags (booleans), consistent with what the binary does, as
/// (XML attribute, value) in the order of the FMI 3.0 schema.
pub fn capability_flags_fmi3() -> &'static [(&'static str, bool)] {
    CAPABILITY_FLAGS
}

/// The FMI 3.0 document: `time`, then the table with arrays as arrays.
const FMI3: Version = Version {
    number: "3.0",
    token_attribute: "instantiationToken",
    header_end: ">\n",
    capability_flags: CAPABILITY_FLAGS,
    model_variables,
    model_structure,
};

/// The complete FMI 3.0 modelDescription.xml of a scene.
///
/// `scene` is the scene the FMU builds its model from (for a scene with `form_finding`, the
/// found one: `Engine::scene`), as for [`crate::description::model_description`]; `arrays` is
/// its table with arrays as arrays (`variables::try_table`, or `Engine::arrays`).
pub fn model_description_fmi3(scene: &Scene, arrays: &[Variable]) -> String {
    document(scene, arrays, &FMI3)
}

/// The instantiation token of [`model_description_fmi3`] of the same arguments,
/// `{8-4-4-4-12}` lowercase hex.
pub fn instantiation_token(scene: &Scene, arrays: &[Variable]) -> String {
    token(scene, arrays, &FMI3)
}

/// `time`, then every variable of the table.
fn model_variables(x: &mut String, variables: &[Variable]) {
    x.push_str("  <ModelVariables>\n");
    let _ = writeln!(
        x,
        "    <Float64 name=\"{TIME_NAME}\" valueReference=\"{}\" causality=\"independent\" variability=\"continuous\" description=\"Simulation time\"/>",
        TIME_VALUE_REFERENCE
    );
    for v in variables {
        variable(x, v);
    }
    x.push_str("  </ModelVariables>\n");
}

fn variable(x: &mut String, v: &Variable) {
    let element = match v.var_type {
        VarType::Real => "Float64",
        VarType::Integer => "Int32",
        VarType::UInt8 => "UInt8",
    };
    let _ = write!(
        x,
        "    <{element}\n      name=\"{}\"\n      valueReference=\"{}\"",
        escape(&v.name),
        v.value_reference
    );
    if !v.description.is_empty() {
        let _ = write!(x, "\n      description=\"{}\"", escape(&v.description));
    }
    let _ = write!(
        x,
        "\n      causality=\"{}\"\n      variability=\"{}\"",
        causality(v.causality),
        variability(v.variability)
    );
    if let Some(unit) = v.unit {
        let _ = write!(x, "\n      unit=\"{}\"", escape(unit));
    }
    // Outputs are `initial="calculated"` (the default) and so carry no start value.
    let start = if v.causality == Causality::Output {
        None
    } else {
        v.start
    };
    for (name, value) in [("min", v.min), ("max", v.max), ("start", start)] {
        if let Some(value) = value {
            let text = match v.var_type {
                VarType::Real => xs_double(value),
                VarType::Integer | VarType::UInt8 => format!("{}", value.round() as i64),
            };
            // An array's start lists every element (row-major).
            let text = if name == "start" && v.is_array() {
                vec![text; v.len()].join(" ")
            } else {
                text
            };
            let _ = write!(x, "\n      {name}=\"{text}\"");
        }
    }
    if v.is_array() {
        x.push_str(">\n");
        for n in &v.dims {
            let _ = writeln!(x, "      <Dimension start=\"{n}\"/>");
        }
        let _ = writeln!(x, "    </{element}>");
    } else {
        x.push_str("/>\n");
    }
}

/// Every output is listed in Outputs and in InitialUnknowns (all `initial="calculated"`; no
/// calculated parameters), by value reference, in table order; no `dependencies` attribute
/// (= depends on every input and parameter).
fn model_structure(x: &mut String, variables: &[Variable]) {
    x.push_str("  <ModelStructure>\n");
    for element in ["Output", "InitialUnknown"] {
        for v in variables
            .iter()
            .filter(|v| v.causality == Causality::Output)
        {
            let _ = writeln!(
                x,
                "    <{element} valueReference=\"{}\"/>",
                v.value_reference
            );
        }
    }
    x.push_str("  </ModelStructure>\n");
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn token_is_in_the_document_and_differs_from_the_fmi2_guid() {
        let scene = crate::Scene::from_json(
            r#"{"format": 1, "name": "c",
            "geometry": {"nodes": [[0, 0, 0], [1, 0, 0], [2, 0, 0]]},
            "cables": [{"name": "c", "nodes": [0, 1, 2], "EA": 1e5, "pretension": 100}],
            "supports": [{"nodes": [0, 2], "fix": ["x", "y", "z"]}, {"nodes": [1], "fix": ["y"]}],
            "outputs": [{"name": "t", "probe": {"kind": "cable_tension", "cable": "c"}}]}"#,
        )
        .unwrap();
        let engine = crate::Engine::try_new(scene).unwrap();
        let (scene, arrays) = (engine.scene(), engine.arrays());
        let xml = model_description_fmi3(scene, arrays);
        let token = instantiation_token(scene, arrays);
        assert!(xml.contains(&format!("instantiationToken=\"{token}\"")));
        assert_ne!(token, crate::description::guid(scene, engine.variables()));
        assert!(xml.contains("causality=\"independent\""));
        assert!(xml.contains("<Output valueReference=\"1\"/>"));
        assert!(xml.contains("<InitialUnknown valueReference=\"1\"/>"));
    }
}
