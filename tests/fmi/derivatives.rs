//! Directional and adjoint derivatives of the outputs at a converged equilibrium.
//!
//! GOAL: (1) the compliance of the prestressed cable (dw/dP, dT/dP, dR/dP and dw/dT0 for the
//!       pretension parameter) equals its closed form at small and at large load; (2) on every
//!       shipped scene, at an operating point half way up its input ranges, the directional
//!       derivative of every continuous output with respect to every input equals a
//!       second-order one-sided finite difference of converged equilibria (in the loading
//!       direction, so stick/slip and wrinkle states stay on their branch); (3) the adjoint is
//!       the transpose of the directional derivative (SleeveCable with friction: the
//!       tangent is not symmetric).
//! MESH: the shipped scenes as they are.
//! BOUNDARY CONDITIONS: the scenes'.
//! PARAMETERS: cable half-span a = 1 m, EA = 1e5 N, T0 = 100 N, P = 1 N and 5000 N.
//! REFERENCE: (1) engineering-strain cable, l = sqrt(a² + w²), L0 = EA a / (EA + T0),
//!            T = EA (l − L0)/L0, P = 2 T w / l; dP/dw = 2 (EA/L0 · w²/l² + T a²/l³),
//!            dT/dP = EA/L0 · (w/l) · dw/dP, the end reactions carry P; w from P by a scalar
//!            Newton iteration in this file. Tolerance 1e-9 relative (measured below 1e-12);
//!            the pretension derivative goes through central differences of the residual
//!            (step 1e-4 of T0): tolerance 1e-8 (measured 8e-10); the reaction's from the held
//!            rows of the tangent: 1e-9 (measured 0 at P = 1 and 5000 N; 1.9e-9 by the former
//!            central difference of the probe).
//!            (2) second-order one-sided differences of equilibria solved to a residual
//!            tolerance of 1e-13 (not 1e-9: the difference would then measure the solver's
//!            tolerance over the step; 1e-13 since the test is local, each node's residual
//!            against the sum of the forces meeting there, several times the largest single
//!            force the former global scale took: at 1e-12 HenckyDisc's reaction derivative
//!            was off by 1.1e-5), step 1e-5 of the ramp (1e-3 with friction, where the
//!            penalty ties make the contact outputs noisier); tolerance 1e-5 relative to the
//!            largest difference among the outputs of the same unit (the target, away
//!            from switches), also where wrinkled or slack triangles are present: the
//!            derivatives remove the tangent-only stiffness ε·D0 (ε = 1e-6) of those triangles
//!            (measured with it left in: LiftedMembrane 1.9e-6, SleeveCable 4.2e-6), and the
//!            reactions (AnnulusTorsion's hub and rim moments) follow exactly from the held
//!            rows of the tangent along the solution (was 3.9e-5 by a difference of the probe,
//!            which is not smooth on the scale of its step 1e-6 there). Measured worst (local convergence test, 2026-11-27):
//!            PrestressedCable 4.6e-10, HenckyDisc 7.3e-9, WrinkledShear 5.1e-8, LiftedMembrane
//!            1.8e-7, SleeveCable 4.3e-7, SlidingCable 7.7e-7, FourPointSail 1.3e-6,
//!            AnnulusTorsion 3.9e-6 (it moves with the order of floating-point sums in the
//!            assembly: 1.5e-6 to 1.0e-5 measured over triangle visit orders,
//!            solver/assemble.rs). With the sleeve ties closed by their multipliers and the
//!            derivative keeping them closed (same day): SleeveCable 1.7e-7, SlidingCable
//!            5.3e-7, the others unchanged.
//!            (3) 1e-10 relative (measured 3e-15).

use crate::common;
use common::*;
use velarium::engine::derivatives::Known;
use velarium::variables::{Binding, Causality, VarType, Variable};
use velarium::Engine;

/// The slot of an input or output (its index in the engine's flat vector).
fn slot(e: &Engine, name: &str) -> usize {
    match e
        .variables()
        .iter()
        .find(|v| v.name == name)
        .unwrap()
        .binding
    {
        Binding::Output(k) | Binding::Input(k) => k,
        Binding::Parameter(_) => panic!("{name} is a parameter"),
    }
}

/// w (positive, downwards) of the prestressed cable under P, by Newton on P(w).
fn cable_sag(p: f64, ea: f64, t0: f64, a: f64) -> (f64, f64, f64, f64) {
    let l0 = ea * a / (ea + t0);
    let mut w: f64 = (p * a / (2.0 * t0)).min(a);
    for _ in 0..200 {
        let l = (a * a + w * w).sqrt();
        let t = ea * (l - l0) / l0;
        let f = 2.0 * t * w / l - p;
        let df = 2.0 * (ea / l0 * w * w / (l * l) + t * a * a / (l * l * l));
        let step = f / df;
        w -= step;
        if step.abs() <= 1e-16 * w.abs() {
            break;
        }
    }
    let l = (a * a + w * w).sqrt();
    let t = ea * (l - l0) / l0;
    let dpdw = 2.0 * (ea / l0 * w * w / (l * l) + t * a * a / (l * l * l));
    (w, t, dpdw, l)
}

#[test]
fn prestressed_cable_compliance_is_the_closed_form() {
    let (ea, t0, a) = (1e5, 100.0, 1.0);
    for p in [1.0, 5000.0] {
        let mut e = engine(read_scene(&shipped("PrestressedCable")));
        solve(&mut e);
        set(&mut e, "P", p);
        solve(&mut e);
        let (w, t, dpdw, l) = cable_sag(p, ea, t0, a);
        assert!(
            rel(-get(&e, "midspan_uz"), w) < 1e-9,
            "the equilibrium itself"
        );
        let unknowns = ["midspan_uz", "tension", "reaction_z", "cable_length"].map(|n| slot(&e, n));
        let known = [Known::Input(slot(&e, "P"))];
        let d = e.directional_derivative(&known, &[1.0], &unknowns).unwrap();
        let dwdp = 1.0 / dpdw;
        let l0 = ea * a / (ea + t0);
        let expected = [-dwdp, ea / l0 * (w / l) * dwdp, 1.0, 2.0 * (w / l) * dwdp];
        // Every one an exact gradient (the reaction's from the held rows of the tangent): 1e-9.
        let tolerance = [1e-9; 4];
        for (k, (got, want)) in d.iter().zip(expected).enumerate() {
            let err = (got - want).abs() / want.abs();
            eprintln!(
                "P = {p}: {} analytic {got:e} closed form {want:e} rel {err:e}",
                ["w", "T", "R", "l"][k]
            );
            assert!(err < tolerance[k], "{k}: {got} vs {want}");
        }
        // The pretension parameter: F(w, T0) = 2 T w / l − P = 0 at fixed P.
        let dl0 = -ea * a / ((ea + t0) * (ea + t0));
        let dt_dl0 = -ea * l / (l0 * l0);
        let df_dt0 = 2.0 * (w / l) * dt_dl0 * dl0;
        let dw_dt0 = -df_dt0 / dpdw;
        let _ = t;
        let param = e
            .variables()
            .iter()
            .position(|v| v.name == "pretension")
            .unwrap();
        let Binding::Parameter(i) = e.variables()[param].binding else {
            panic!()
        };
        let d = e
            .directional_derivative(&[Known::Parameter(i)], &[1.0], &[unknowns[0]])
            .unwrap();
        let err = (d[0] + dw_dt0).abs() / dw_dt0.abs();
        eprintln!(
            "P = {p}: dw/dT0 analytic {:e} closed form {:e} rel {err:e}",
            -d[0], dw_dt0
        );
        assert!(err < 1e-8);
    }
}

/// Where an input goes in the operating point: half way from start to its max (or to 10x the
/// start, or 1).
fn operating_value(v: &Variable) -> f64 {
    let start = v.start.unwrap_or(0.0);
    let target = v
        .max
        .unwrap_or(if start != 0.0 { 10.0 * start } else { 1.0 });
    start + 0.5 * (target - start)
}

fn outputs_of(e: &Engine, slots: &[usize]) -> Vec<f64> {
    let all: Vec<f64> = e.outputs().into_iter().map(|(_, v)| v).collect();
    slots.iter().map(|&k| all[k]).collect()
}

/// The worst relative error of the directional derivatives against finite differences of
/// converged equilibria, over every (continuous output, seed) of a scene. Seeds: each input
/// alone along its range; with friction, the one direction the inputs were ramped along (a
/// seed that reverses a slipping point's load is at a stick/slip switch, where the frozen-state
/// derivative is one-sided by design).
/// The worst relative error, and whether any triangle is wrinkled or slack at the operating
/// point.
fn check_scene(name: &str) -> (f64, bool) {
    check_scene_at(name, &shipped(name))
}

fn check_scene_at(name: &str, path: &str) -> (f64, bool) {
    let mut scene = read_scene(path);
    // Equilibria to round-off, so the differences measure the derivative and not the
    // solver's tolerance (1e-9 of the force scale, over a step of 1e-5).
    scene.solver.tolerance = 1e-13;
    let friction = scene
        .cables
        .iter()
        .any(|c| c.sleeve.as_ref().is_some_and(|s| s.mu > 0.0));
    let mut e = engine(scene);
    solve(&mut e);
    let inputs: Vec<Variable> = e
        .variables()
        .iter()
        .filter(|v| v.causality == Causality::Input)
        .cloned()
        .collect();
    // Ramp to the operating point in a few steps (the FMU's way).
    for k in 1..=4 {
        for v in &inputs {
            let start = v.start.unwrap_or(0.0);
            let value = start + (operating_value(v) - start) * k as f64 / 4.0;
            e.set_real(v.value_reference, value).unwrap();
        }
        solve(&mut e);
    }
    let outputs: Vec<(String, usize, Option<&str>)> = e
        .variables()
        .iter()
        .filter(|v| v.causality == Causality::Output && v.var_type == VarType::Real)
        // Area fractions step with the states; the contact gap (a penetration check) divides by
        // the adjacent segment's length, which is 1e-7 of the span where sleeve points merged
        // (SlidingCable): the differences of equilibria there carry the solver's tolerance
        // over that length (measured 3.8e-5), not the derivative.
        .filter(|v| !v.name.contains("fraction") && v.name != "contact_gap")
        .map(|v| {
            let Binding::Output(k) = v.binding else {
                panic!()
            };
            (v.name.clone(), k, v.unit)
        })
        .collect();
    let slots: Vec<usize> = outputs.iter().map(|o| o.1).collect();
    let knowns: Vec<Known> = inputs
        .iter()
        .map(|v| {
            let Binding::Input(k) = v.binding else {
                panic!()
            };
            Known::Input(k)
        })
        .collect();
    let ramp: Vec<f64> = inputs
        .iter()
        .map(|v| operating_value(v) - v.start.unwrap_or(0.0))
        .collect();
    let seeds: Vec<(String, Vec<f64>)> = if friction {
        vec![("the ramp".into(), ramp.clone())]
    } else {
        (0..inputs.len())
            .map(|i| {
                let mut s = vec![0.0; inputs.len()];
                // An input already at its operating value (start = max) is moved by its range,
                // towards the inside of [min, max].
                s[i] = if ramp[i] != 0.0 {
                    ramp[i]
                } else {
                    let v = &inputs[i];
                    let range = v.max.unwrap_or(1.0) - v.min.unwrap_or(0.0);
                    let range = if range > 0.0 { range } else { 1.0 };
                    if v.max.is_some_and(|m| operating_value(v) + 0.1 * range > m) {
                        -range
                    } else {
                        range
                    }
                };
                (inputs[i].name.clone(), s)
            })
            .collect()
    };
    let base_state = e.state().clone();
    let base = outputs_of(&e, &slots);
    let mut analytic = Vec::new();
    let mut fd = Vec::new();
    for (_, seed) in &seeds {
        let d = e
            .directional_derivative(&knowns, seed, &slots)
            .unwrap_or_else(|err| panic!("{name}: {err}"));
        let delta = if friction { 1e-3 } else { 1e-5 };
        let at = |e: &mut Engine, t: f64| -> Vec<f64> {
            e.set_state(base_state.clone()).unwrap();
            for (v, s) in inputs.iter().zip(seed) {
                let Binding::Input(k) = v.binding else {
                    panic!()
                };
                e.set_real(v.value_reference, base_state.applied[k] + t * s)
                    .unwrap();
            }
            solve(e);
            outputs_of(e, &slots)
        };
        let (f1, f2) = (at(&mut e, delta), at(&mut e, 2.0 * delta));
        e.set_state(base_state.clone()).unwrap();
        // Second-order one-sided difference: (−3 f0 + 4 f(δ) − f(2δ)) / 2δ.
        let diff: Vec<f64> = (0..slots.len())
            .map(|k| (-3.0 * base[k] + 4.0 * f1[k] - f2[k]) / (2.0 * delta))
            .collect();
        analytic.push(d);
        fd.push(diff);
    }
    // Each output against the largest difference among the outputs of its unit and seed (a
    // derivative that is 0 by symmetry is compared with its neighbours' size), at least 1e-4
    // of the model's natural size of that unit (force scale E t √A or EA, length scale, their
    // product): below that the difference of equilibria is noise (AnnulusTorsion's hub force
    // resultant, 0 by symmetry: analytic 1e-11 N, difference 8.5e-8 N, force scale 1e3 N).
    let model = e.model();
    let natural = |unit: Option<&str>| match unit {
        Some("N") => model.force_scale,
        Some("m") => model.length_scale,
        Some("N.m") => model.force_scale * model.length_scale,
        _ => 0.0,
    };
    let mut worst: f64 = 0.0;
    for (k, (out, _, unit)) in outputs.iter().enumerate() {
        for (i, (seed_name, _)) in seeds.iter().enumerate() {
            let scale = outputs
                .iter()
                .enumerate()
                .filter(|(_, o)| o.2 == *unit)
                .map(|(j, _)| fd[i][j].abs())
                .fold(1e-4 * natural(*unit), f64::max);
            let (a, f) = (analytic[i][k], fd[i][k]);
            let err = if scale == 0.0 {
                (a - f).abs()
            } else {
                (a - f).abs() / scale
            };
            if err
                > std::env::var("SHOW")
                    .ok()
                    .and_then(|s| s.parse().ok())
                    .unwrap_or(1e-6)
            {
                eprintln!("{name}: d {out} / d {seed_name}: analytic {a:e}, difference {f:e}, rel {err:e}");
            }
            worst = worst.max(err);
        }
    }
    let wrinkled = e
        .membranes()
        .iter()
        .any(|m| m.state != velarium::model::wrinkling::WrinkleState::Taut);
    eprintln!(
        "{name}: worst relative error {worst:e} over {} outputs x {} seeds{}",
        outputs.len(),
        seeds.len(),
        if wrinkled {
            " (wrinkled or slack triangles)"
        } else {
            ""
        }
    );
    (worst, wrinkled)
}

#[test]
fn every_shipped_scene_matches_finite_differences() {
    let mut failures = Vec::new();
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("modelDescription");
    let mut names: Vec<String> = std::fs::read_dir(root)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert!(names.len() >= 6, "{names:?}");
    for name in &names {
        // A scene with time integration: the derivatives of its steps are checked against
        // differences of the steps in dynamic_derivatives.rs.
        if engine(read_scene(&shipped(name))).is_dynamic() {
            continue;
        }
        let (worst, _) = check_scene(name);
        if worst > 1e-5 {
            failures.push(format!("{name}: {worst:e}"));
        }
    }
    assert!(failures.is_empty(), "{failures:?}");
}

#[test]
fn the_adjoint_is_the_transpose() {
    let mut e = engine(read_scene(&shipped("SleeveCable")));
    solve(&mut e);
    for k in 1..=3 {
        set(&mut e, "force_2P", k as f64);
        solve(&mut e);
    }
    assert!(
        get(&e, "slipping") > 0.0,
        "some sleeve points slip (friction in the tangent)"
    );
    let inputs = ["force_2P", "cable_preload"].map(|n| Known::Input(slot(&e, n)));
    let outputs = ["A_dx", "A_dy", "B_dy", "end_x", "end_slip"].map(|n| slot(&e, n));
    let mut jacobian = Vec::new();
    for k in inputs {
        jacobian.push(e.directional_derivative(&[k], &[1.0], &outputs).unwrap());
    }
    let seed = [0.3, -1.2, 0.7, 2.0, -0.5];
    let adjoint = e.adjoint_derivative(&outputs, &seed, &inputs).unwrap();
    for (i, column) in jacobian.iter().enumerate() {
        let expected: f64 = column.iter().zip(&seed).map(|(a, b)| a * b).sum();
        let size: f64 = column.iter().zip(&seed).map(|(a, b)| (a * b).abs()).sum();
        let err = (adjoint[i] - expected).abs() / size;
        eprintln!("adjoint {i}: {:e} vs {expected:e}, rel {err:e}", adjoint[i]);
        assert!(err < 1e-10);
    }
}

/// The follower pressure's skew part matters where the loaded surface has free edges (here
/// edge cables): the shipped ZonedCushion, with array inputs (zone pressures, corner support
/// displacements) and array outputs (the displacement field, stresses, tensions). Tolerance
/// 5e-5 with wrinkling off and on: measured 1.2e-5 and 1.3e-5, on the edge tensions against a
/// corner's z displacement. That is the reference's error, not the derivative's: the analytic
/// d edge_tension[8] / d corners[i,3] of the four corners agree in magnitude to 1e-12 (1224.27313
/// N/m without wrinkling), while their differences of equilibria scatter around it by ±1.2e-5
/// (1224.2844, −1224.2640, −1224.2588, 1224.2859 at δ = 1e-5), and the worst error moves
/// without trend with the step (without wrinkling: δ = 3e-6 6.3e-6, 1e-5 1.2e-5, 3e-5 2.7e-6;
/// wrinkled: 1.2e-5, 1.3e-5, 5.1e-6; δ = 1e-4 crosses a state change, 0.2): the equilibria's
/// own noise over the step. With the wrinkle regularisation left in, the wrinkled cushion
/// measured 3.9e-5.
#[test]
fn zoned_cushion_matches_finite_differences() {
    let path = format!(
        "{}/modelDescription/ZonedCushion/scene.json",
        env!("CARGO_MANIFEST_DIR")
    );
    let mut scene: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    scene["membranes"][0]["wrinkling"] = serde_json::json!(false);
    let plain = std::env::temp_dir().join(format!("velarium-cushion-{}.json", std::process::id()));
    std::fs::write(&plain, scene.to_string()).unwrap();
    let (exact, _) = check_scene_at("ZonedCushion (no wrinkling)", plain.to_str().unwrap());
    let _ = std::fs::remove_file(&plain);
    assert!(exact <= 5e-5, "{exact:e}");
    let (wrinkled, _) = check_scene_at("ZonedCushion", &path);
    assert!(wrinkled <= 5e-5, "{wrinkled:e}");
}

/// AnnulusTorsion carries no external moment about z (no pressure, no point load): the hub's
/// and the rim's reaction moments balance at every equilibrium, so their derivatives must too.
/// REFERENCE: 0 (moment balance), relative to |d hub_moment|; the operating point itself
/// balances to 6.5e-13 of the moment. The reactions' change comes from the held rows of the
/// tangent (exact up to round-off): tolerance 1e-13 (measured 2.4e-15 to 7.0e-15 over the three
/// inputs; 4e-5 with the former central difference of the probe along the solution).
#[test]
fn annulus_hub_and_rim_moment_derivatives_balance() {
    let mut e = engine(read_scene(&shipped("AnnulusTorsion")));
    solve(&mut e);
    let inputs: Vec<Variable> = e
        .variables()
        .iter()
        .filter(|v| v.causality == Causality::Input)
        .cloned()
        .collect();
    for k in 1..=4 {
        for v in &inputs {
            let start = v.start.unwrap_or(0.0);
            e.set_real(
                v.value_reference,
                start + (operating_value(v) - start) * k as f64 / 4.0,
            )
            .unwrap();
        }
        solve(&mut e);
    }
    let balance = get(&e, "hub_moment") + get(&e, "rim_moment");
    eprintln!(
        "hub {:e} + rim {:e} = {balance:e}",
        get(&e, "hub_moment"),
        get(&e, "rim_moment")
    );
    let moments = [slot(&e, "hub_moment"), slot(&e, "rim_moment")];
    for v in &inputs {
        let d = e
            .directional_derivative(&[Known::Input(slot(&e, &v.name))], &[1.0], &moments)
            .unwrap();
        let err = (d[0] + d[1]).abs() / d[0].abs();
        eprintln!(
            "d/d {}: hub {:e}, rim {:e}, relative imbalance {err:e}",
            v.name, d[0], d[1]
        );
        assert!(err < 1e-13, "{}: {err:e}", v.name);
    }
}

/// A shipped scene with outputs added, written to a temporary file: its path.
fn with_outputs(name: &str, added: &[serde_json::Value]) -> std::path::PathBuf {
    let mut scene: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(shipped(name)).unwrap()).unwrap();
    let outputs = scene["outputs"].as_array_mut().unwrap();
    outputs.extend(added.iter().cloned());
    let file = std::env::temp_dir().join(format!(
        "velarium-{name}-reactions-{}.json",
        std::process::id()
    ));
    std::fs::write(&file, scene.to_string()).unwrap();
    file
}

fn reaction(name: &str, nodes: &str, component: &str) -> serde_json::Value {
    serde_json::json!({"name": name,
        "probe": {"kind": "reaction", "nodes": nodes, "component": component}})
}

/// The reactions of scenes with sliding cable points. SleeveCable: the clamped edge anchors
/// the cable at C (node 73), whose segment to the first sleeve point has the slip there in its
/// unstretched length, so the edge's reaction changes with the slips (through the slip columns
/// on the held rows: without them d R_C,x came out 6.3 times too large, measured); Coulomb
/// friction, the seed is the ramp. SlidingCable: reactions at both anchors, their moment about z through the
/// midspan and A's resultant (frictionless; its slips do not move at this operating point).
/// REFERENCE and TOLERANCE: as `every_shipped_scene_matches_finite_differences`, 1e-5 (measured:
/// SleeveCable's reactions within 2.1e-9, the scene's worst 9.1e-8; SlidingCable's reactions
/// within 3.8e-8, the scene's worst 2.1e-7).
#[test]
fn reactions_with_sliding_cables_match_finite_differences() {
    let sleeve = with_outputs(
        "SleeveCable",
        &[
            reaction("R_edge_x", "sheet.edge_left", "x"),
            reaction("R_edge_y", "sheet.edge_left", "y"),
            reaction("R_C_x", "sleeve_start", "x"),
            reaction("R_C_y", "sleeve_start", "y"),
            serde_json::json!({"name": "M_edge", "probe": {"kind": "reaction_moment",
                "nodes": "sheet.edge_left", "point": [0, 0, 0], "axis": [0, 0, 1]}}),
        ],
    );
    let (worst_sleeve, _) = check_scene_at("SleeveCable with reactions", sleeve.to_str().unwrap());
    let _ = std::fs::remove_file(&sleeve);
    let sliding = with_outputs(
        "SlidingCable",
        &[
            reaction("RAx", "A", "x"),
            reaction("RAy", "A", "y"),
            reaction("RBx", "B", "x"),
            reaction("RBy", "B", "y"),
            serde_json::json!({"name": "M_anchors", "probe": {"kind": "reaction_moment",
                "nodes": "anchors", "point": [2, 0, 0], "axis": [0, 0, 1]}}),
            serde_json::json!({"name": "R_A",
                "probe": {"kind": "reaction_resultant", "nodes": "A"}}),
        ],
    );
    let (worst_sliding, _) =
        check_scene_at("SlidingCable with reactions", sliding.to_str().unwrap());
    let _ = std::fs::remove_file(&sliding);
    assert!(worst_sleeve <= 1e-5, "SleeveCable {worst_sleeve:e}");
    assert!(worst_sliding <= 1e-5, "SlidingCable {worst_sliding:e}");
}

/// The cushion of the coupling example (examples/coupling/cushion_gas.json: two foil skins
/// sharing a held rim, wrinkling off) under a snow load, its pressure an unknown of the bordered
/// system: held by a `gas` input (isothermal gas law), by a `volume` input, and by the gas with
/// one rim edge lifted by a prescribed displacement (the border's rows move with the held
/// DOFs). Each at its operating point (half of its input ranges: ΔN 0.07 m³, ΔV 0.05 m³, snow
/// 50 Pa, lift 5 cm), every output (p, V; p alone under volume control, where V is the control
/// itself) against every input by the second-order one-sided differences of `check_scene_at`;
/// tolerance 1e-5 as for the shipped scenes. Measured (2026-11-28): gas 5.2e-8, volume 9.6e-9,
/// lifted 1.3e-7 (with a 5 mm lift the difference of V's equilibria is round-off over a step of
/// 5e-8 m: 8.6e-6). The adjoint equals the transpose of the directional derivatives to 1e-9
/// (measured 9.5e-11: the gas row, k_V V/p_atm against the skins' stiffness, conditions the
/// bordered system more than SleeveCable's 3e-15).
#[test]
fn volume_and_gas_scenes_match_finite_differences() {
    let path = format!(
        "{}/examples/coupling/cushion_gas.json",
        env!("CARGO_MANIFEST_DIR")
    );
    let base: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    let dir = std::env::temp_dir().join(format!(
        "velarium-volume-derivatives-{}",
        std::process::id()
    ));
    std::fs::create_dir_all(&dir).unwrap();
    let mut gas = base.clone();
    gas["inputs"][0]["max"] = 0.14.into();
    gas["inputs"][1]["max"] = 100.0.into();
    let mut volume = gas.clone();
    volume["name"] = "CushionVolume".into();
    volume["inputs"][0]["load"] = serde_json::json!({"kind": "volume", "membrane": "foil"});
    volume["inputs"][0]["max"] = 0.1.into();
    // V is the control itself: its derivatives are the seed's ΔV and 0, no test of the border.
    volume["outputs"] =
        serde_json::json!([{"name": "p", "probe": {"kind": "enclosed_pressure", "input": "dN"}}]);
    let mut lifted = gas.clone();
    lifted["name"] = "CushionLifted".into();
    let edge: Vec<usize> = base["geometry"]["nodes"]
        .as_array()
        .unwrap()
        .iter()
        .enumerate()
        .filter(|(_, p)| p[0].as_f64().unwrap() == 0.0)
        .map(|(i, _)| i)
        .collect();
    let rest: Vec<u64> = base["geometry"]["node_sets"]["rim"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_u64().unwrap())
        .filter(|i| !edge.contains(&(*i as usize)))
        .collect();
    lifted["geometry"]["node_sets"]["edge"] = serde_json::json!(edge);
    lifted["geometry"]["node_sets"]["rest"] = serde_json::json!(rest);
    lifted["supports"] = serde_json::json!([
        {"nodes": "rim", "fix": ["x", "y"]}, {"nodes": "rest", "fix": ["z"]}]);
    lifted["inputs"]
        .as_array_mut()
        .unwrap()
        .push(serde_json::json!(
        {"name": "lift", "load": {"kind": "displacement", "nodes": "edge", "component": "z"},
         "start": 0, "min": -0.1, "max": 0.1}));
    let mut failures = Vec::new();
    for scene in [&gas, &volume, &lifted] {
        let name = scene["name"].as_str().unwrap().to_string();
        let file = dir.join(format!("{name}.json"));
        std::fs::write(&file, scene.to_string()).unwrap();
        let (worst, _) = check_scene_at(&name, file.to_str().unwrap());
        if worst > 1e-5 {
            failures.push(format!("{name}: {worst:e}"));
        }
    }
    // The adjoint: the transpose of the directional derivatives (gas scene, lifted).
    let mut e = engine(read_scene(dir.join("CushionLifted.json").to_str().unwrap()));
    solve(&mut e);
    for k in 1..=3 {
        set(&mut e, "dN", 0.02 * k as f64);
        set(&mut e, "snow", 15.0 * k as f64);
        set(&mut e, "lift", 0.015 * k as f64);
        solve(&mut e);
    }
    let inputs = ["dN", "snow", "lift"].map(|n| Known::Input(slot(&e, n)));
    let outputs = ["p", "V"].map(|n| slot(&e, n));
    let mut jacobian = Vec::new();
    for k in inputs {
        jacobian.push(e.directional_derivative(&[k], &[1.0], &outputs).unwrap());
    }
    let seed = [0.3, -1.2];
    let adjoint = e.adjoint_derivative(&outputs, &seed, &inputs).unwrap();
    for (i, column) in jacobian.iter().enumerate() {
        let expected: f64 = column.iter().zip(&seed).map(|(a, b)| a * b).sum();
        let size: f64 = column.iter().zip(&seed).map(|(a, b)| (a * b).abs()).sum();
        let err = (adjoint[i] - expected).abs() / size;
        eprintln!("adjoint {i}: {:e} vs {expected:e}, rel {err:e}", adjoint[i]);
        if err >= 1e-9 {
            failures.push(format!("adjoint {i}: {err:e}"));
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
    assert!(failures.is_empty(), "{failures:?}");
}

/// Ponding with the water volume given (`water_volume`): the level is an unknown of the
/// bordered system, as a volume input's pressure. A prestressed flat sheet (2 m x 1 m, 8 x 4
/// cells, N = 1000 N/m, γ_w 6000 N/m³, about half the ponding threshold) holding water of
/// volume V (operating point 2e-3 m³) under snow (25 Pa): the level, the centre deflection and
/// the rim reaction against both inputs by `check_scene_at`'s differences; tolerance 1e-5 as
/// for the shipped scenes (measured 2.1e-8; at a tenth of that volume the water's forces,
/// 0.1 N, are so small against the prestressed sheet's internal forces that the differences
/// of equilibria carry 1e-5 of round-off, and the exact dRz/dV = γ_w is missed by 4e-6).
#[test]
fn water_volume_scene_matches_finite_differences() {
    let scene = serde_json::json!({
        "format": 1, "name": "WaterVolume",
        "geometry": {"generators": [{"kind": "rectangle", "name": "sheet", "origin": [0, 0, 0],
                                     "size": [2.0, 1.0], "divisions": [8, 4]}]},
        "membranes": [{"name": "film", "triangles": "sheet", "thickness": 1e-3,
                       "material": {"kind": "svk", "E": 6e8, "nu": 0.3},
                       "prestress": {"kind": "isotropic", "n": 1000}}],
        "supports": [{"nodes": "sheet.boundary", "fix": ["x", "y", "z"]}],
        "inputs": [{"name": "V", "load": {"kind": "water_volume", "membrane": "film", "gamma_w": 6000},
                    "start": 0, "min": 0, "max": 4e-3},
                   {"name": "snow", "load": {"kind": "snow", "membrane": "film"}, "start": 0, "min": 0, "max": 50}],
        "outputs": [{"name": "h", "probe": {"kind": "water_level", "input": "V"}},
                    {"name": "w", "probe": {"kind": "displacement", "node": "sheet.center", "component": "z"}},
                    {"name": "Rz", "probe": {"kind": "reaction", "nodes": "sheet.boundary", "component": "z"}}],
        "solver": {"artificial_prestress": 0}
    });
    let file =
        std::env::temp_dir().join(format!("velarium-water-volume-{}.json", std::process::id()));
    std::fs::write(&file, scene.to_string()).unwrap();
    let (worst, _) = check_scene_at("WaterVolume", file.to_str().unwrap());
    let _ = std::fs::remove_file(&file);
    eprintln!("water volume derivatives: worst {worst:e}");
    assert!(worst <= 1e-5, "WaterVolume {worst:e}");
}
