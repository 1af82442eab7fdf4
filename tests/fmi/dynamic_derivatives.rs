//! Derivatives of a step of time integration: the change of the outputs at the end of the last
//! step with the inputs set before it, the step's start state held (docs/dynamics.md,
//! "Derivatives of a time step").
//!
//! GOAL: (1) the directional derivative of every continuous output (displacements, positions,
//!       velocities, accelerations, the enclosed volume, cable tensions, reactions, principal
//!       stresses) with respect to every input after a step of generalized-α equals a central
//!       difference of that very step: the start state restored (`Engine::set_state`), the
//!       input set to x ± δ, the step taken again; on four states: the shipped
//!       VibratingMembrane vibrating freely (ρ∞ = 1, no damping), the coupling example's
//!       cushion with the foil's mass and Rayleigh damping (follower pressure: a non-symmetric
//!       tangent; a snow load), the shipped GustSail in its gust (form-found, edge cables,
//!       follower wind) and the WrinkledShear film with mass sheared by its prescribed
//!       displacement inputs (939 of 988 triangles wrinkled or slack, held DOFs driven by the
//!       seeds); each in steps of one sub-step and of four (the chain through the sub-steps,
//!       solver/step_sensitivity.rs); (2) the adjoint equals the transposed directional
//!       derivative to round-off (one sub-step: seeded on the outputs with exact gradients, so
//!       that it is one transposed solve; several: one forward chain per known, equal by
//!       construction); (3) what is not implemented is refused with an Error that names why
//!       (more sub-steps than are kept, sleeves through several sub-steps, a state set from
//!       outside with no step since, a parameter seed, an energy output), and a cheap step
//!       from rest has the step's derivative (one sub-step and four), not the static one.
//! MESH: VibratingMembrane and GustSail as shipped; the cushion of
//!       examples/coupling/cushion_pressure.json (two skins, 144 triangles); WrinkledShear as
//!       shipped (988 triangles).
//! BOUNDARY CONDITIONS: the scenes'.
//! PARAMETERS: VibratingMembrane released from 10 Pa, three steps of 1 ms, then the step under
//!       test (1 ms) to 3 Pa. The cushion: density 1750 kg/m³, Rayleigh α = 20/s, ρ∞ = 0.9
//!       (as `velarium.couple_dynamic`), from its static equilibrium at 200 Pa two steps of
//!       10 ms to (210 Pa, no snow) and (220 Pa, 50 Pa), then to (230 Pa, 100 Pa). GustSail:
//!       six steps of 25 ms to 150 Pa, then to 160 Pa (four sub-steps: three steps of 0.1 s to
//!       150 Pa, then to 170 Pa). WrinkledShear: density 1420 kg/m³, Rayleigh α 100/s, ρ∞ 0.9,
//!       eight steps of 0.2 ms shearing to 2 mm, then to 2.1 mm. Four sub-steps:
//!       max_time_step a quarter of the step.
//! REFERENCE: central differences of the step itself, the equilibria solved to a residual
//!       tolerance of 1e-13; δ = 0.01 Pa for pressures and snow, 1e-7 m for the prescribed
//!       displacements (chosen from δ = 0.1, 0.01, 0.001 Pa and 1e-6, 1e-7, 1e-8 m: the
//!       smallest error, truncation against round-off). The error of an entry is relative to
//!       the largest difference of the same output over the inputs.
//! TOLERANCE: (measured 2026-11-28) one sub-step: VibratingMembrane 1.9e-10, asserted 1e-9;
//!       cushion 1.1e-9, asserted 5e-9; GustSail 1.4e-7 (the largest cable tension; 6.6e-10 on
//!       the displacements), asserted 1e-6; WrinkledShear 1.7e-9, asserted 1e-8. Four
//!       sub-steps: cushion 9.6e-9 (the acceleration; the difference's own floor: 4.1e-8,
//!       4.5e-9, 9.6e-9, 5.3e-8 at δ = 0.1, 0.03, 0.01, 0.003 Pa, ≤ 1.1e-9 on the other
//!       outputs), asserted 2e-8; GustSail 2.5e-8, asserted 1e-7; VibratingMembrane 1.5e-9
//!       (the acceleration), asserted 5e-9; WrinkledShear 3.7e-8 (the acceleration, 4.9e-8
//!       and 2.0e-8 at δ = 3e-7 m; ≤ 3.3e-9 on the other outputs), asserted 1e-7: an
//!       acceleration over a sub-step Δt is the displacement's change over βΔt², so the
//!       differences' noise grows as the sub-steps shrink. The adjoint: worst 4.4e-13
//!       (GustSail), asserted 5e-12. A derivative that left out the step's K_d would be the
//!       static compliance: dV/dp 2.6e-4 m³/Pa against 4.8e-6 over a 1 ms step from rest
//!       (test 3), far outside every tolerance; the chain from rest in four sub-steps 3.3e-6,
//!       within 3.4e-10 of the difference of the step (asserted 1e-9).

use crate::common;
use common::*;
use velarium::engine::derivatives::Known;
use velarium::variables::Binding;
use velarium::Engine;

/// The step of the central differences of a pressure or snow input (Pa).
const DELTA: f64 = 0.01;
/// The step of the central differences of a prescribed displacement input (m).
const DELTA_DISPLACEMENT: f64 = 1e-7;

/// The slot of an input or output (its index in the engine's flat vector).
fn slot(e: &Engine, name: &str) -> usize {
    match e
        .variables()
        .iter()
        .find(|v| v.name == name)
        .unwrap_or_else(|| panic!("no variable {name}"))
        .binding
    {
        Binding::Output(k) | Binding::Input(k) => k,
        Binding::Parameter(_) => panic!("{name} is a parameter"),
    }
}

/// One step of length `h` to the inputs `to`.
fn step(e: &mut Engine, h: f64, to: &[(&str, f64)]) {
    for (name, value) in to {
        set(e, name, *value);
    }
    e.set_step_duration(h);
    solve(e);
}

/// The outputs `outputs` after the step `h` to `to` from the state `start`.
fn step_from(
    e: &mut Engine,
    start: &velarium::engine::EngineState,
    h: f64,
    to: &[(&str, f64)],
    outputs: &[&str],
) -> Vec<f64> {
    e.set_state(start.clone()).unwrap();
    step(e, h, to);
    outputs.iter().map(|o| get(e, o)).collect()
}

/// Worst relative error of the directional derivative against central differences of the
/// step, and of the adjoint against the transposed directional derivative.
fn check(
    name: &str,
    e: &mut Engine,
    h: f64,
    to: &[(&str, f64)],
    outputs: &[&str],
    exact: usize,
    delta: f64,
) -> (f64, f64) {
    let start = e.state().clone();
    step(e, h, to);
    let inputs: Vec<&str> = to.iter().map(|(n, _)| *n).collect();
    let knowns: Vec<Known> = inputs.iter().map(|n| Known::Input(slot(e, n))).collect();
    let unknowns: Vec<usize> = outputs.iter().map(|n| slot(e, n)).collect();
    let columns: Vec<Vec<f64>> = knowns
        .iter()
        .map(|k| e.directional_derivative(&[*k], &[1.0], &unknowns).unwrap())
        .collect();
    // The adjoint at the same state, seeded with the first `exact` outputs (those with an
    // exact gradient: one transposed solve with the step's tangent, not one forward solve per
    // input), each scaled by its largest entry.
    let seed: Vec<f64> = (0..outputs.len())
        .map(|i| {
            let size = columns.iter().map(|c| c[i].abs()).fold(0.0, f64::max);
            if i < exact && size > 0.0 {
                [0.7, -1.3, 0.4, 2.1, -0.6][i % 5] / size
            } else {
                0.0
            }
        })
        .collect();
    let adjoint = e.adjoint_derivative(&unknowns, &seed, &knowns).unwrap();
    let mut worst_adjoint = 0.0f64;
    for (j, column) in columns.iter().enumerate() {
        let expected: f64 = column.iter().zip(&seed).map(|(a, b)| a * b).sum();
        let size: f64 = column.iter().zip(&seed).map(|(a, b)| (a * b).abs()).sum();
        let err = (adjoint[j] - expected).abs() / size;
        eprintln!(
            "{name}: adjoint d/d {}: {:e} against {expected:e}, rel {err:.1e}",
            inputs[j], adjoint[j]
        );
        worst_adjoint = worst_adjoint.max(err);
    }
    // Central differences of the step from its start state.
    let mut differences = Vec::new();
    for input in &inputs {
        let at = |sign: f64| -> Vec<(&str, f64)> {
            to.iter()
                .map(|&(n, v)| (n, if n == *input { v + sign * delta } else { v }))
                .collect()
        };
        let plus = step_from(e, &start, h, &at(1.0), outputs);
        let minus = step_from(e, &start, h, &at(-1.0), outputs);
        differences.push(
            plus.iter()
                .zip(&minus)
                .map(|(a, b)| (a - b) / (2.0 * delta))
                .collect::<Vec<f64>>(),
        );
    }
    let mut worst = 0.0f64;
    for (i, output) in outputs.iter().enumerate() {
        let scale = differences.iter().map(|d| d[i].abs()).fold(0.0, f64::max);
        for (j, input) in inputs.iter().enumerate() {
            let (a, f) = (columns[j][i], differences[j][i]);
            let err = (a - f).abs() / scale;
            eprintln!(
                "{name}: d {output} / d {input}: analytic {a:e}, difference {f:e}, rel {err:.1e}"
            );
            worst = worst.max(err);
        }
    }
    eprintln!("{name}: worst {worst:.2e}, adjoint {worst_adjoint:.2e}");
    (worst, worst_adjoint)
}

fn with_tolerance(mut scene: serde_json::Value) -> velarium::Scene {
    scene["solver"]["tolerance"] = serde_json::json!(1e-13);
    velarium::Scene::from_json(&scene.to_string()).unwrap()
}

fn vibrating_membrane() -> Engine {
    vibrating_membrane_with(None)
}

/// VibratingMembrane, its sub-steps at most `max_time_step` long (None: one per step).
fn vibrating_membrane_with(max_time_step: Option<f64>) -> Engine {
    let text = std::fs::read_to_string(shipped("VibratingMembrane")).unwrap();
    let mut scene: serde_json::Value = serde_json::from_str(&text).unwrap();
    let outputs = scene["outputs"].as_array_mut().unwrap();
    // f1 (a natural frequency) and the energies have no derivatives: left out; an
    // acceleration, a reaction and a stress added.
    outputs.retain(|o| {
        matches!(
            o["probe"]["kind"].as_str(),
            Some("displacement" | "velocity" | "newton_iterations")
        )
    });
    outputs.push(serde_json::json!({"name": "a_center", "probe": {"kind": "acceleration", "node": "s.center", "component": "z"}}));
    outputs.push(serde_json::json!({"name": "reaction_z", "probe": {"kind": "reaction", "nodes": "s.boundary", "component": "z"}}));
    if let Some(m) = max_time_step {
        scene["dynamics"]["time_integration"]["max_time_step"] = serde_json::json!(m);
    }
    engine(with_tolerance(scene))
}

fn dynamic_cushion() -> Engine {
    dynamic_cushion_with(None)
}

/// The dynamic cushion, its sub-steps at most `max_time_step` long (None: one per step).
fn dynamic_cushion_with(max_time_step: Option<f64>) -> Engine {
    let path = format!(
        "{}/examples/coupling/cushion_pressure.json",
        env!("CARGO_MANIFEST_DIR")
    );
    let mut scene: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    scene["membranes"][0]["density"] = serde_json::json!(1750.0);
    scene["dynamics"] = serde_json::json!({"mass": "consistent", "rayleigh_alpha": 20.0,
        "time_integration": {"rho_inf": 0.9}});
    if let Some(m) = max_time_step {
        scene["dynamics"]["time_integration"]["max_time_step"] = serde_json::json!(m);
    }
    // The top skin's centre (node 24 of its 7 x 7 grid).
    scene["geometry"]["node_sets"]["top_centre"] = serde_json::json!([24]);
    let outputs = scene["outputs"].as_array_mut().unwrap();
    for (name, kind) in [
        ("w", "displacement"),
        ("v", "velocity"),
        ("a", "acceleration"),
    ] {
        outputs.push(serde_json::json!({"name": name, "probe": {"kind": kind, "node": "top_centre", "component": "z"}}));
    }
    outputs.push(serde_json::json!({"name": "rim_reaction_z", "probe": {"kind": "reaction", "nodes": "rim", "component": "z"}}));
    outputs.push(serde_json::json!({"name": "max_stress", "probe": {"kind": "max_principal_stress", "membrane": "foil"}}));
    // A parameter, for the refusal of parameter seeds.
    scene["parameters"] =
        serde_json::json!([{"name": "E", "target": "membranes.foil.E", "variability": "fixed"}]);
    engine(with_tolerance(scene))
}

/// The shipped GustSail (form-found four-point sail with edge cables, wrinkling law, follower
/// wind pressure, Rayleigh α 4/s, ρ∞ 0.9, sub-steps of at most 25 ms), an acceleration output
/// added; the energies (no derivatives) and the integer and fraction outputs left out.
fn gust_sail() -> Engine {
    let text = std::fs::read_to_string(shipped("GustSail")).unwrap();
    let mut scene: serde_json::Value = serde_json::from_str(&text).unwrap();
    let outputs = scene["outputs"].as_array_mut().unwrap();
    outputs.retain(|o| {
        !matches!(
            o["probe"]["kind"].as_str(),
            Some("kinetic_energy" | "newton_iterations" | "wrinkled_fraction")
        )
    });
    outputs.push(serde_json::json!({"name": "center_az", "probe": {"kind": "acceleration", "node": "sail.center", "component": "z"}}));
    engine(with_tolerance(scene))
}

/// Outputs, the first ones those with an exact gradient (the adjoint's seeds).
const MEMBRANE_OUTPUTS: [&str; 4] = ["w_center", "v_center", "a_center", "reaction_z"];
const CUSHION_OUTPUTS: [&str; 6] = ["V", "w", "v", "a", "rim_reaction_z", "max_stress"];
const SHEAR_OUTPUTS: [&str; 6] = [
    "ax",
    "vx",
    "ux",
    "shear_force",
    "separation_force",
    "max_principal_stress",
];
const SAIL_OUTPUTS: [&str; 8] = [
    "center_uz",
    "center_vz",
    "center_z",
    "center_az",
    "max_cable_tension",
    "corner_bl_reaction_z",
    "max_stress",
    "min_stress",
];

#[test]
fn vibrating_membrane_step_matches_differences_of_the_step() {
    let mut e = vibrating_membrane();
    solve(&mut e);
    for _ in 0..3 {
        step(&mut e, 1e-3, &[("p", 0.0)]);
    }
    assert!(get(&e, "v_center").abs() > 1e-3, "the membrane moves");
    let (worst, adjoint) = check(
        "VibratingMembrane",
        &mut e,
        1e-3,
        &[("p", 3.0)],
        &MEMBRANE_OUTPUTS,
        3,
        DELTA,
    );
    assert!(worst < 1e-9, "{worst}");
    assert!(adjoint < 5e-12, "{adjoint}");
}

#[test]
fn dynamic_cushion_step_matches_differences_of_the_step() {
    let mut e = dynamic_cushion();
    solve(&mut e);
    step(&mut e, 0.01, &[("p", 210.0), ("snow", 0.0)]);
    step(&mut e, 0.01, &[("p", 220.0), ("snow", 50.0)]);
    assert!(get(&e, "v").abs() > 1e-3, "the skins move");
    let to = [("p", 230.0), ("snow", 100.0)];
    let (worst, adjoint) = check("cushion", &mut e, 0.01, &to, &CUSHION_OUTPUTS, 4, DELTA);
    assert!(worst < 5e-9, "{worst}");
    assert!(adjoint < 5e-12, "{adjoint}");
}

#[test]
fn gust_sail_step_matches_differences_of_the_step() {
    let mut e = gust_sail();
    solve(&mut e);
    for k in 1..=6 {
        step(&mut e, 0.025, &[("wind", 25.0 * k as f64)]);
    }
    let wrinkled = e
        .membranes()
        .iter()
        .filter(|m| m.state != velarium::model::wrinkling::WrinkleState::Taut)
        .count();
    eprintln!(
        "GustSail: {wrinkled} of {} triangles wrinkled or slack",
        e.membranes().len()
    );
    let (worst, adjoint) = check(
        "GustSail",
        &mut e,
        0.025,
        &[("wind", 160.0)],
        &SAIL_OUTPUTS,
        5,
        DELTA,
    );
    assert!(worst < 1e-6, "{worst}");
    assert!(adjoint < 5e-12, "{adjoint}");
}

/// What is not implemented is refused, naming why; and a cheap step at rest after the
/// initialization is a step of one sub-step whose derivative exists.
#[test]
fn what_is_not_implemented_is_refused_with_the_reason() {
    let mut e = dynamic_cushion();
    solve(&mut e);
    let known = [Known::Input(slot(&e, "p"))];
    let out = [slot(&e, "V")];
    // Before the first step: the static equilibrium's derivative.
    let initial = e.directional_derivative(&known, &[1.0], &out).unwrap();
    // A step at rest under unchanged inputs (the cheap step): the skins' inertia now counts.
    e.set_step_duration(1e-3);
    assert!(e.keep().is_some(), "at rest, unchanged inputs: kept");
    let kept = e.directional_derivative(&known, &[1.0], &out).unwrap();
    eprintln!(
        "dV/dp static {:e}, over a 1 ms step from rest {:e}",
        initial[0], kept[0]
    );
    assert!(
        kept[0] > 0.0 && kept[0] < 0.1 * initial[0],
        "inertia limits the step's compliance"
    );
    // The same in four sub-steps (max_time_step 0.25 ms): the chain from rest against a
    // central difference of the step, δ = 0.1 Pa (at 0.01 Pa the difference's own noise, 3.8e-9;
    // measured 3.4e-10 at 0.1 Pa).
    let mut rest = dynamic_cushion_with(Some(2.5e-4));
    solve(&mut rest);
    rest.set_step_duration(1e-3);
    assert!(rest.keep().is_some(), "at rest, unchanged inputs: kept");
    let chained = rest.directional_derivative(&known, &[1.0], &out).unwrap();
    let at_rest = rest.state().clone();
    let v = |e: &mut Engine, p: f64| step_from(e, &at_rest, 1e-3, &[("p", p)], &["V"])[0];
    let fd = (v(&mut rest, 200.1) - v(&mut rest, 199.9)) / 0.2;
    let err = (chained[0] - fd).abs() / fd.abs();
    eprintln!(
        "kept, 4 sub-steps: {:e} against {fd:e}, rel {err:.1e}",
        chained[0]
    );
    assert!(err < 1e-9, "{err}");
    let why = |r: Result<Vec<f64>, velarium::Error>| r.expect_err("refused").to_string();
    // More sub-steps than the chain keeps (66 of 0.1 ms).
    let mut many = dynamic_cushion_with(Some(1e-4));
    solve(&mut many);
    step(&mut many, 0.0066, &[("p", 201.0)]);
    let m = why(many.directional_derivative(&known, &[1.0], &out));
    assert!(
        m.contains("66 sub-steps") && m.contains("at most 64"),
        "{m}"
    );
    let m = why(many.adjoint_derivative(&out, &[1.0], &known));
    assert!(m.contains("66 sub-steps"), "{m}");
    // Sleeves through several sub-steps (their history carries from sub-step to sub-step).
    let mut sleeve = dynamic_sleeve();
    solve(&mut sleeve);
    step(&mut sleeve, 2e-3, &[("force_2P", 0.5)]);
    let ks = [Known::Input(slot(&sleeve, "force_2P"))];
    let os = [slot(&sleeve, "A_dy")];
    let m = why(sleeve.directional_derivative(&ks, &[1.0], &os));
    assert!(m.contains("sleeves"), "{m}");
    // A state set from outside, no step since.
    let state = e.state().clone();
    e.set_state(state).unwrap();
    let m = why(e.directional_derivative(&known, &[1.0], &out));
    assert!(m.contains("set from outside"), "{m}");
    // A parameter seed.
    step(&mut e, 1e-3, &[("p", 201.0)]);
    let m = why(e.directional_derivative(&[Known::Parameter(0)], &[1.0], &out));
    assert!(
        m.contains("parameter") && m.contains("time_integration"),
        "{m}"
    );
    // The energies.
    let mut vm = engine(read_scene(&shipped("VibratingMembrane")));
    solve(&mut vm);
    step(&mut vm, 1e-3, &[("p", 0.0)]);
    let m = why(vm.directional_derivative(
        &[Known::Input(slot(&vm, "p"))],
        &[1.0],
        &[slot(&vm, "kinetic_energy")],
    ));
    assert!(m.contains("energy"), "{m}");
}

/// The shipped WrinkledShear film (Kapton, 25 µm, clamped edges, the top one moved by two
/// prescribed displacement inputs) with Kapton's density 1420 kg/m³, Rayleigh α 100/s and
/// ρ∞ 0.9: held DOFs driven by the inputs, wrinkled triangles.
fn dynamic_shear() -> Engine {
    dynamic_shear_with(None)
}

/// The dynamic WrinkledShear, its sub-steps at most `max_time_step` long (None: one per step).
fn dynamic_shear_with(max_time_step: Option<f64>) -> Engine {
    let text = std::fs::read_to_string(shipped("WrinkledShear")).unwrap();
    let mut scene: serde_json::Value = serde_json::from_str(&text).unwrap();
    scene["membranes"][0]["density"] = serde_json::json!(1420.0);
    scene["dynamics"] = serde_json::json!({"mass": "consistent", "rayleigh_alpha": 100.0,
        "time_integration": {"rho_inf": 0.9}});
    if let Some(m) = max_time_step {
        scene["dynamics"]["time_integration"]["max_time_step"] = serde_json::json!(m);
    }
    let outputs = scene["outputs"].as_array_mut().unwrap();
    outputs.retain(|o| {
        matches!(
            o["probe"]["kind"].as_str(),
            Some("reaction" | "max_principal_stress")
        )
    });
    for (name, kind, c) in [
        ("ux", "displacement", "x"),
        ("vx", "velocity", "x"),
        ("ax", "acceleration", "x"),
    ] {
        outputs.insert(0, serde_json::json!({"name": name, "probe": {"kind": kind, "node": "film.center", "component": c}}));
    }
    engine(with_tolerance(scene))
}

#[test]
fn dynamic_wrinkled_shear_step_matches_differences_of_the_step() {
    let mut e = dynamic_shear();
    solve(&mut e);
    for k in 1..=8 {
        step(
            &mut e,
            2e-4,
            &[("separation", 0.001), ("shear", 2.5e-4 * k as f64)],
        );
    }
    let wrinkled = e
        .membranes()
        .iter()
        .filter(|m| m.state != velarium::model::wrinkling::WrinkleState::Taut)
        .count();
    eprintln!(
        "WrinkledShear: {wrinkled} of {} triangles wrinkled or slack",
        e.membranes().len()
    );
    assert!(wrinkled > e.membranes().len() / 2, "wrinkled");
    let outputs = SHEAR_OUTPUTS;
    let to = [("separation", 0.001), ("shear", 2.1e-3)];
    let (worst, adjoint) = check(
        "WrinkledShear",
        &mut e,
        2e-4,
        &to,
        &outputs,
        3,
        DELTA_DISPLACEMENT,
    );
    assert!(worst < 1e-8, "{worst}");
    assert!(adjoint < 5e-12, "{adjoint}");
}

/// The shipped SleeveCable with mass (membrane 1000 kg/m³, cables 1 kg/m), in sub-steps of at
/// most 1 ms.
fn dynamic_sleeve() -> Engine {
    let text = std::fs::read_to_string(shipped("SleeveCable")).unwrap();
    let mut scene: serde_json::Value = serde_json::from_str(&text).unwrap();
    for m in scene["membranes"].as_array_mut().unwrap() {
        m["density"] = serde_json::json!(1000.0);
    }
    for c in scene["cables"].as_array_mut().unwrap() {
        c["mass_per_length"] = serde_json::json!(1.0);
    }
    scene["dynamics"] =
        serde_json::json!({"time_integration": {"rho_inf": 0.9, "max_time_step": 1e-3}});
    engine(with_tolerance(scene))
}

/// Steps of several sub-steps: the chain through them (solver/step_sensitivity.rs) against
/// central differences of the whole step.
#[test]
fn steps_of_several_sub_steps_match_differences_of_the_step() {
    // The cushion in sub-steps of 2.5 ms, steps of 10 ms: four sub-steps each.
    let mut e = dynamic_cushion_with(Some(2.5e-3));
    solve(&mut e);
    step(&mut e, 0.01, &[("p", 210.0), ("snow", 0.0)]);
    step(&mut e, 0.01, &[("p", 220.0), ("snow", 50.0)]);
    let to = [("p", 230.0), ("snow", 100.0)];
    let (worst, adjoint) = check(
        "cushion, 4 sub-steps",
        &mut e,
        0.01,
        &to,
        &CUSHION_OUTPUTS,
        4,
        DELTA,
    );
    assert!(worst < 2e-8, "{worst}");
    assert!(adjoint < 5e-12, "{adjoint}");
    // GustSail in steps of 0.1 s (four sub-steps of 25 ms).
    let mut e = gust_sail();
    solve(&mut e);
    for k in 1..=3 {
        step(&mut e, 0.1, &[("wind", 50.0 * k as f64)]);
    }
    let (worst, adjoint) = check(
        "GustSail, 4 sub-steps",
        &mut e,
        0.1,
        &[("wind", 170.0)],
        &SAIL_OUTPUTS,
        5,
        DELTA,
    );
    assert!(worst < 1e-7, "{worst}");
    assert!(adjoint < 5e-12, "{adjoint}");
    // VibratingMembrane in steps of 1 ms of four sub-steps of 0.25 ms.
    let mut e = vibrating_membrane_with(Some(2.5e-4));
    solve(&mut e);
    for _ in 0..3 {
        step(&mut e, 1e-3, &[("p", 0.0)]);
    }
    let (worst, _) = check(
        "VibratingMembrane, 4 sub-steps",
        &mut e,
        1e-3,
        &[("p", 3.0)],
        &MEMBRANE_OUTPUTS,
        3,
        DELTA,
    );
    assert!(worst < 5e-9, "{worst}");
    // WrinkledShear in steps of 0.2 ms of four sub-steps of 50 µs: the prescribed motion
    // λ_k of the way at each sub-step's end.
    let mut e = dynamic_shear_with(Some(5e-5));
    solve(&mut e);
    for k in 1..=8 {
        step(
            &mut e,
            2e-4,
            &[("separation", 0.001), ("shear", 2.5e-4 * k as f64)],
        );
    }
    let to = [("separation", 0.001), ("shear", 2.1e-3)];
    let (worst, _) = check(
        "WrinkledShear, 4 sub-steps",
        &mut e,
        2e-4,
        &to,
        &SHEAR_OUTPUTS,
        3,
        DELTA_DISPLACEMENT,
    );
    assert!(worst < 1e-7, "{worst}");
}
