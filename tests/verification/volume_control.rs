//! GOAL: volume control traces the whole pressure-stretch curve of an inflated rubber balloon,
//!       through and past the limit pressure that stops pressure control (issue 10 item 3).
//! MESH: the closed octahedral sphere of tests/solver/hard_cases.rs with 16 divisions per edge (2048 CST
//!       triangles, outward), radius R = 1 m.
//! BOUNDARY CONDITIONS: held by its mirror symmetry planes only (nodes on x = 0 held in x, on
//!       y = 0 in y, on z = 0 in z).
//! MATERIAL: incompressible neo-Hookean, μ = 100 kPa, H = 1 mm.
//! LOADING: input `dV` of kind `volume` (the enclosed volume's change from the reference),
//!       increased in rows to stretches 1.05, 1.10, …, 2.00 and 7^(1/6), each row from the last.
//! REFERENCE: docs/mechanics.md §4i (thin incompressible neo-Hookean sphere): p R/(μH) =
//!       2 (λ⁻¹ − λ⁻⁷), with a maximum p_max = 1.239463 μH/R at λ = 7^(1/6) = 1.383. Our λ is
//!       the volume stretch (V/V⁰)^(1/3), V⁰ the polyhedron's reference volume computed here from
//!       the nodes; p is the `enclosed_pressure` output. (1) Against the smooth sphere: within
//!       0.5 % at every row on both sides of the limit (the target; measured +0.27 %, the
//!       faceting of the inscribed polyhedron) and the largest p of the trace within 0.5 % of
//!       p_max (+0.27 %). (2) Against the polyhedron inflated homothetically (the same energy
//!       argument with R replaced by R_eff = 3V⁰/A⁰, V⁰ and A⁰ computed here from the mesh):
//!       within 1e-4 (measured 1.7e-5: what is left is the mesh's departure from homothety).
//!       The volume is held to 1e-9 in λ. Newton iterations per row must stay <= 10 (the
//!       issue's target; measured 3-5).
use crate::common;
use common::*;
use nalgebra::Vector3;
use serde_json::json;
use velarium::Scene;

const MU: f64 = 1e5;
const H: f64 = 1e-3;
const PMAX: f64 = 1.239463;

/// Reference volume V⁰ and area A⁰ of the mesh (computed here from the node coordinates).
fn volume_and_area(nodes: &[[f64; 3]], triangles: &[[usize; 3]]) -> (f64, f64) {
    let mut v = 0.0;
    let mut a = 0.0;
    for t in triangles {
        let [p, q, r] = t.map(|k| Vector3::from(nodes[k]));
        v += p.dot(&q.cross(&r)) / 6.0;
        a += 0.5 * (q - p).cross(&(r - p)).norm();
    }
    (v, a)
}

fn balloon(divisions: usize) -> Scene {
    balloon_with(divisions, json!({"kind": "volume", "membrane": "rubber"}))
}

fn balloon_with(divisions: usize, load: serde_json::Value) -> Scene {
    balloon_scene(divisions, H, MU, load)
}

/// p R/(μH) of the thin neo-Hookean sphere at stretch λ.
fn closed_form(lambda: f64) -> f64 {
    2.0 * (1.0 / lambda - lambda.powi(-7))
}

#[test]
fn volume_control_traces_the_sphere_through_its_limit_point() {
    let divisions = 16;
    let (nodes, triangles) = octasphere(divisions, 1.0);
    let (v0, a0) = volume_and_area(&nodes, &triangles);
    // The polyhedron inflated homothetically: p = (A⁰/3V⁰) μH 2(λ⁻¹ − λ⁻⁷), i.e. R replaced by
    // R_eff = 3V⁰/A⁰ (the smooth sphere: 3V/A = R).
    let r_eff = 3.0 * v0 / a0;
    let mut e = engine(balloon(divisions));
    assert!((get(&e, "V") - v0).abs() < 1e-12 * v0);
    let mut worst_eff: f64 = 0.0;
    let mut worst: f64 = 0.0;
    let mut largest: f64 = 0.0;
    let mut iterations = Vec::new();
    let mut stretches: Vec<f64> = (1..=20).map(|k| 1.0 + 0.05 * k as f64).collect();
    stretches.push(7f64.powf(1.0 / 6.0)); // the limit point itself
    stretches.sort_by(f64::total_cmp);
    for &target in &stretches {
        set(&mut e, "dV", (target.powi(3) - 1.0) * v0);
        let report = solve(&mut e);
        iterations.push(report.iterations);
        let (p, v) = (get(&e, "p") / (MU * H), get(&e, "V"));
        let lambda = (v / v0).cbrt();
        let reference = closed_form(lambda);
        let error = (p - reference).abs() / reference;
        let faceted = closed_form(lambda) / r_eff;
        worst_eff = worst_eff.max((p - faceted).abs() / faceted);
        println!(
            "λ = {lambda:.6} (target {target:.2}): p R/(μH) = {p:.6} vs sphere {reference:.6} ({:+.3} %), vs polyhedron {faceted:.6} ({:+.2e}), {} iterations",
            100.0 * (p - reference) / reference,
            (p - faceted) / faceted,
            report.iterations
        );
        assert!(
            (lambda - target).abs() < 1e-9,
            "volume held: λ {lambda} vs {target}"
        );
        worst = worst.max(error);
        largest = largest.max(p);
    }
    println!(
        "largest p R/(μH) {largest:.6} vs p_max {PMAX} ({:+.3} %); worst error {:.3} % (sphere), {worst_eff:.2e} (polyhedron, R_eff = {r_eff:.6}); iterations per row {iterations:?}",
        100.0 * (largest - PMAX) / PMAX,
        100.0 * worst
    );
    assert!(worst < 5e-3, "worst error against the sphere {worst}");
    assert!(
        worst_eff < 1e-4,
        "worst error against the polyhedron {worst_eff}"
    );
    assert!((largest - PMAX).abs() / PMAX < 5e-3);
    assert!(
        stretches.iter().any(|&l| l > 1.6),
        "the trace goes well past the limit λ = 1.383"
    );
    assert!(
        iterations.iter().all(|&i| i <= 10),
        "iterations per row {iterations:?}"
    );
}

/// GOAL: gas control (an isothermal ideal gas, `gas` input) traces the same balloon past its
/// limit pressure.
/// LOADING: the added gas ΔN (m³ at the atmosphere's pressure, here a soft 1000 Pa so that the
/// gas law matters: p changes the gas volume by up to 12 %) for the stretches 1.1 … 2.0 and
/// 7^(1/6): ΔN = (p(λ) + p_atm) V⁰ λ³/p_atm − V⁰ with p(λ) the faceted balloon's closed form.
/// REFERENCE: (1) the gas law (p + p_atm) V = p_atm (V⁰ + ΔN) on the outputs, within 1e-9
/// relative (measured 1e-14: the row is solved to the tolerance); (2) p against the faceted
/// balloon's closed form at the stretch reached, within 1e-4 (as the volume test; measured
/// 9e-6); (3) the stretch reached within 2e-6 of the one ΔN was computed for (measured 2e-7, the
/// p error through the gas law). Newton iterations per row <= 10 (measured 3-6).
#[test]
fn gas_control_traces_the_sphere_through_its_limit_point() {
    let divisions = 16;
    let (nodes, triangles) = octasphere(divisions, 1.0);
    let (v0, a0) = volume_and_area(&nodes, &triangles);
    let r_eff = 3.0 * v0 / a0;
    let atm = 1000.0;
    let mut e = engine(balloon_with(
        divisions,
        json!({"kind": "gas", "membrane": "rubber", "atmosphere": atm}),
    ));
    let mut targets: Vec<f64> = (1..=10).map(|k| 1.0 + 0.1 * k as f64).collect();
    targets.push(7f64.powf(1.0 / 6.0));
    targets.sort_by(f64::total_cmp);
    let mut iterations = Vec::new();
    for &target in &targets {
        let p_target = MU * H * closed_form(target) / r_eff;
        let added = (p_target + atm) * v0 * target.powi(3) / atm - v0;
        set(&mut e, "dV", added);
        let report = solve(&mut e);
        iterations.push(report.iterations);
        let (p, v) = (get(&e, "p"), get(&e, "V"));
        let lambda = (v / v0).cbrt();
        let faceted = MU * H * closed_form(lambda) / r_eff;
        let gas = ((p + atm) * v - atm * (v0 + added)) / (atm * (v0 + added));
        println!(
            "λ = {lambda:.6} (for {target:.4}, {:+.1e}): p = {p:.6} Pa vs {faceted:.6} ({:+.2e}); gas law {gas:.1e}; {} iterations",
            lambda - target,
            (p - faceted) / faceted,
            report.iterations
        );
        assert!(gas.abs() < 1e-9, "gas law off by {gas}");
        assert!((p - faceted).abs() < 1e-4 * faceted, "p {p} vs {faceted}");
        assert!((lambda - target).abs() < 2e-6, "λ {lambda} vs {target}");
    }
    println!("gas: iterations per row {iterations:?}");
    assert!(
        iterations.iter().all(|&i| i <= 10),
        "iterations per row {iterations:?}"
    );
}

/// Bad input: a volume needs a closed, outward group; an `enclosed_pressure` probe needs a
/// volume input. Each error names its JSON path.
#[test]
fn a_volume_input_on_an_open_or_inward_group_is_rejected() {
    let open = json!({
        "format": 1, "name": "Flat",
        "geometry": {"generators": [{"kind": "rectangle", "name": "sheet", "origin": [0.0, 0.0, 0.0], "size": [1.0, 1.0], "divisions": [2, 2]}]},
        "membranes": [{"name": "film", "triangles": "sheet", "thickness": 1e-3,
                       "material": {"kind": "neo_hookean", "mu": 1e5}}],
        "supports": [{"nodes": "sheet.edge_bottom", "fix": ["x", "y", "z"]}],
        "inputs": [{"name": "dV", "load": {"kind": "volume", "membrane": "film"}}],
        "outputs": [{"name": "p", "probe": {"kind": "enclosed_pressure", "input": "dv"}}]
    });
    let refusal = |v: &serde_json::Value| {
        let scene = Scene::from_json(&v.to_string()).unwrap();
        let err = velarium::Engine::try_new(scene)
            .err()
            .expect("rejected")
            .to_string();
        println!("{err}");
        err
    };
    let err = refusal(&open);
    assert!(
        err.contains("inputs[0].load.membrane") && err.contains("is not closed"),
        "{err}"
    );
    assert!(
        err.contains("outputs[0].probe.input") && err.contains("dV"),
        "{err}"
    );
    let (nodes, mut triangles) = octasphere(2, 1.0);
    for t in &mut triangles {
        t.swap(1, 2);
    }
    // A closed rubber group under a volume input must be refused as not facing outward.
    let refused_as_inward = |nodes: &[[f64; 3]], triangles: &[[usize; 3]]| {
        let v = json!({
            "format": 1, "name": "Inward",
            "geometry": {"nodes": nodes, "triangles": triangles,
                         "triangle_sets": {"all": (0..triangles.len()).collect::<Vec<_>>()}},
            "membranes": [{"name": "rubber", "triangles": "all", "thickness": H,
                           "material": {"kind": "neo_hookean", "mu": MU}}],
            "supports": [{"nodes": [0], "fix": ["x", "y", "z"]}],
            "inputs": [{"name": "dV", "load": {"kind": "volume", "membrane": "rubber"}}]
        });
        let err = refusal(&v);
        assert!(
            err.contains("inputs[0].load.membrane") && err.contains("face outward"),
            "{err}"
        );
    };
    refused_as_inward(&nodes, &triangles);
    // Zero volume is accepted only for a flat group (every node in one plane): a sphere facing
    // outward beside the same sphere facing inward encloses none either, and is refused.
    let (nodes, triangles) = octasphere(2, 1.0);
    let shift = nodes.len();
    let mut both_nodes = nodes.clone();
    both_nodes.extend(nodes.iter().map(|p| [p[0] + 3.0, p[1], p[2]]));
    let mut both = triangles.clone();
    both.extend(
        triangles
            .iter()
            .map(|t| [t[0] + shift, t[2] + shift, t[1] + shift]),
    );
    refused_as_inward(&both_nodes, &both);
}

/// GOAL: arc length (`solver.path: arc_length`, `src/solver/arc.rs`) traces the same balloon
///       through its limit point under plain (follower) pressure control, where load control
///       stops at the limit (issue 10 item 3, second way).
/// MESH, BOUNDARY CONDITIONS, MATERIAL: as the volume-control test above (2048 CST, μ = 100 kPa,
///       H = 1 mm, R = 1 m, symmetry planes).
/// LOADING: input `p` of kind `pressure` (follower), the step 0 → p_ref = 2 p_max; the path is
///       followed by 30 arc-length increments of RMS length 0.025 m (`Solver::trace_arc_length`,
///       fixed size, no load control anywhere), from the unstressed sphere to λ ≈ 2.
/// REFERENCE: docs/mechanics.md §4i as above: p R/(μH) = 2 (λ⁻¹ − λ⁻⁷), λ the volume stretch
///       (V/V⁰)^(1/3) computed here from the nodes, p = λ_load p_ref. (1) Every converged point
///       within 0.5 % of the smooth sphere (the target; the faceting gives +0.27 %)
///       and within 1e-4 of the faceted balloon (R_eff = 3V⁰/A⁰) on both sides of the limit;
///       (2) the largest load of the trace within 0.5 % of p_max; (3) points on both sides:
///       some below λ = 1.3 and some above 1.6; (4) at most 10 Newton iterations per
///       increment (the target).
#[test]
fn arc_length_traces_the_sphere_through_its_limit_point_under_pressure() {
    use velarium::model::Model;
    use velarium::solver::{Settings, Solver};
    let divisions = 16;
    let (nodes, triangles) = octasphere(divisions, 1.0);
    let (v0, a0) = volume_and_area(&nodes, &triangles);
    let r_eff = 3.0 * v0 / a0;
    let mut scene = balloon_with(
        divisions,
        json!({"kind": "pressure", "membrane": "rubber", "follower": true}),
    );
    scene.outputs.retain(|o| o.name != "p"); // enclosed_pressure reads a volume input
    let model = Model::build(&scene);
    let mut solver = Solver::try_new(&model, Settings::default()).expect("memory");
    let p_ref = 2.0 * PMAX * MU * H;
    let u0 = vec![0.0; model.unknown_count()];
    let points = solver
        .trace_arc_length(&model, &[0.0], &[p_ref], &u0, 0.025, 30)
        .unwrap_or_else(|e| panic!("{e}"));
    let all: Vec<usize> = (0..triangles.len()).collect();
    let (mut worst, mut worst_eff, mut largest) = (0.0f64, 0.0f64, 0.0f64);
    let (mut below, mut above) = (false, false);
    let mut iterations = Vec::new();
    for pt in &points {
        let v = model.enclosed_volume(&pt.u, &all);
        let lambda = (v / v0).cbrt();
        let p = pt.lambda * p_ref / (MU * H);
        let reference = closed_form(lambda);
        let faceted = reference / r_eff;
        println!(
            "λ = {lambda:.6}: p R/(μH) = {p:.6} vs sphere {reference:.6} ({:+.3} %), vs polyhedron ({:+.2e}), {} iterations",
            100.0 * (p - reference) / reference,
            (p - faceted) / faceted,
            pt.iterations
        );
        worst = worst.max((p - reference).abs() / reference);
        worst_eff = worst_eff.max((p - faceted).abs() / faceted);
        largest = largest.max(p);
        below |= lambda < 1.3;
        above |= lambda > 1.6;
        iterations.push(pt.iterations);
    }
    println!(
        "largest p R/(μH) {largest:.6} vs p_max {PMAX} ({:+.3} %); worst {:.3} % (sphere), {worst_eff:.2e} (polyhedron); iterations {iterations:?}",
        100.0 * (largest - PMAX) / PMAX,
        100.0 * worst
    );
    assert!(below && above, "the trace covers both sides of the limit");
    assert!(worst < 5e-3, "worst error against the sphere {worst}");
    assert!(
        worst_eff < 1e-4,
        "worst error against the polyhedron {worst_eff}"
    );
    assert!((largest - PMAX).abs() / PMAX < 5e-3);
    assert!(
        iterations.iter().all(|&i| i <= 10),
        "iterations {iterations:?}"
    );
}

/// GOAL: an FMU step by arc length whose target lies beyond the limit load fails cleanly and
///       names the limit (docs/solver.md, arc length: a step ends at its target).
/// SETUP: the balloon above (8 divisions per edge, 512 CST) under follower pressure with
///       `solver.path: arc_length`; one step 0 → 1.1 p_max.
/// REFERENCE: no equilibrium exists at 1.1 p_max (§4i): the step must not converge, the state
///       must be kept, and the largest load fraction it reports must be that of the faceted
///       balloon's limit load, p_max/R_eff/(1.1 p_max), within 1 % (the path is sampled by
///       increments, so the largest sampled load lies at or just below the limit).
#[test]
fn arc_length_step_beyond_the_limit_load_fails_naming_it() {
    let divisions = 8;
    let (nodes, triangles) = octasphere(divisions, 1.0);
    let (v0, a0) = volume_and_area(&nodes, &triangles);
    let r_eff = 3.0 * v0 / a0;
    let mut scene = balloon_with(
        divisions,
        json!({"kind": "pressure", "membrane": "rubber", "follower": true}),
    );
    scene.outputs.retain(|o| o.name != "p");
    scene.inputs[0].name = "p".into();
    scene.solver.path = velarium::scene::PathMethod::ArcLength;
    let mut e = engine(scene);
    solve(&mut e);
    set(&mut e, "p", 1.1 * PMAX * MU * H);
    let report = e.solve();
    assert!(!report.converged(), "no equilibrium at 1.1 p_max");
    assert!((get(&e, "V") - v0).abs() < 1e-12 * v0, "state kept");
    let tail = report
        .message
        .split("largest load fraction reached ")
        .nth(1)
        .unwrap_or_else(|| panic!("message names the limit: {}", report.message));
    // The number ends at the parenthesis (what is known of the structure may follow it).
    let reached: f64 = tail
        .split(')')
        .next()
        .unwrap_or_default()
        .parse()
        .unwrap_or_else(|_| panic!("{}", report.message));
    let expected = 1.0 / (1.1 * r_eff);
    println!(
        "{}\nlargest load fraction {reached:.6} vs limit {expected:.6} ({:+.3} %), {} increments",
        report.message,
        100.0 * (reached - expected) / expected,
        report.increments
    );
    assert!((reached - expected).abs() < 0.01 * expected);
}

/// GOAL: volume and gas unknowns under `solver.path: arc_length`: the arc-length row is one
///       more bordered row of the one Newton loop, eliminated with the volume rows (a moving
///       volume or gas input moves the rows' targets with λ: docs/solver.md, arc length), so a
///       balloon step is traced by arc length and gives load control's equilibrium.
/// SETUP: the balloon of 8 divisions (512 CST), (a) `volume` input dV to the stretches 1.2,
///       1.4 (past the limit 1.383), 1.6; (b) `gas` input (p_atm = 1000 Pa) with the added gas
///       ΔN of the faceted balloon's closed form at the same stretches. RMS arc length 0.02 m:
///       several arc-length increments per row.
/// REFERENCE: the same scene under load control (a different iteration path to the same
///       equations; both converged to the residual tolerance 1e-9): p and V agree to 1e-7
///       relative (the bound of tests/verification/arc_length.rs); every row takes arc-length
///       increments and is not load-controlled as a whole. Iterations printed.
#[test]
fn volume_and_gas_inputs_under_arc_length_match_load_control() {
    let divisions = 8;
    let (nodes, triangles) = octasphere(divisions, 1.0);
    let (v0, a0) = volume_and_area(&nodes, &triangles);
    let r_eff = 3.0 * v0 / a0;
    let atm = 1000.0;
    for gas in [false, true] {
        let make = || {
            if gas {
                balloon_with(
                    divisions,
                    json!({"kind": "gas", "membrane": "rubber", "atmosphere": atm}),
                )
            } else {
                balloon(divisions)
            }
        };
        let mut arc = make();
        arc.solver.path = velarium::scene::PathMethod::ArcLength;
        arc.solver.arc_length = Some(0.02);
        let mut a = engine(make());
        let mut b = engine(arc);
        let mut arcs = 0;
        for stretch in [1.2f64, 1.4, 1.6] {
            let input = if gas {
                let p = MU * H * closed_form(stretch) / r_eff;
                (p + atm) * v0 * stretch.powi(3) / atm - v0
            } else {
                (stretch.powi(3) - 1.0) * v0
            };
            set(&mut a, "dV", input);
            set(&mut b, "dV", input);
            let ra = solve(&mut a);
            let rb = solve(&mut b);
            assert!(
                !rb.log[0].starts_with("arc length does not apply"),
                "{}",
                rb.log[0]
            );
            let by_arc = rb
                .log
                .iter()
                .filter(|l| l.starts_with("increment") && l.contains("(arc length,"))
                .count();
            arcs += by_arc;
            let (pa, pb) = (get(&a, "p"), get(&b, "p"));
            let (va, vb) = (get(&a, "V"), get(&b, "V"));
            let (dp, dv) = ((pa - pb).abs() / pa.abs(), (va - vb).abs() / va);
            println!(
                "{} stretch {stretch}: p = {pb:.6} Pa (difference {dp:.1e}), V difference {dv:.1e}; load control {} iterations / {} increments, arc length {} iterations / {} increments ({by_arc} by arc length)",
                if gas { "gas" } else { "volume" },
                ra.iterations,
                ra.increments,
                rb.iterations,
                rb.increments
            );
            assert!(dp < 1e-7, "{pa} vs {pb}");
            assert!(dv < 1e-7, "{va} vs {vb}");
        }
        assert!(arcs > 0, "gas {gas}: the run used arc length");
    }
}

/// GOAL: a flat cushion (two sheets on top of each other, sharing their rim: it encloses no
///       volume) can be inflated by a `volume` input from flat, and its answer is the known one.
///       Until the sixteenth session the scene was refused ("encloses the volume 0 m³").
/// MESH: the disc generator's 20-ring mesh (radius a = 0.5 m) as the top sheet, facing +z; the
///       bottom sheet the same triangles turned over on copies of the inner nodes (1261 nodes
///       in all, 2400 CST triangles); the rim nodes are the two sheets' common nodes.
/// BOUNDARY CONDITIONS: the rim clamped (x, y, z), as a cushion in its frame.
/// MATERIAL: SVK, E = 200 MPa, ν = 0.3, h = 0.1 mm (the shipped HenckyDisc's film).
/// LOADING: input `dV` of kind `volume` from 0 (flat) to ΔV₁ (an estimate), then to
///       ΔV₂ = ΔV₁ (40 Pa / p₁)^(1/3) (the Hencky scaling V ∝ p^(1/3)), so that the pressure
///       p₂ read by the `enclosed_pressure` output lands near 40 Pa, qa/(Eh) = 1e-3.
/// REFERENCE: by symmetry each sheet is a clamped flat disc under the follower pressure p₂:
///       docs/mechanics.md §4a, exact kinematics, w0/a = 0.065404 at qa/(Eh) = 1e-3, carried
///       to p₂ by the Hencky scaling w0 ∝ p^(1/3) (p₂ within 1 % of 40 Pa: the finite-rotation
///       part of w0, 9e-4 of it at 1e-3, changes by less than 1e-5 over that). The mirror image:
///       the bottom sheet's centre at −w0. The volume computed here from the deformed nodes
///       equals ΔV₂.
/// TOLERANCE: w0 within 1e-3 at 20 rings, as tests/verification/hencky_disc.rs (its measured
///       CST error 4.79e-4; measured here 4.8e-4); the bottom sheet the top's mirror to 1e-9 of
///       w0; the volume to 1e-8 relative (the volume row's own test is 1e-9 of the forces it
///       balances); p₂ within 1 % of 40 Pa.
#[test]
fn a_flat_framed_cushion_inflated_by_volume_is_two_hencky_discs() {
    const A: f64 = 0.5;
    let disc = read_scene(&shipped("HenckyDisc"));
    let mut geometry = disc.geometry.clone();
    let velarium::scene::Generator::Disc { rings, .. } = &mut geometry.generators[0] else {
        panic!("HenckyDisc is a disc")
    };
    *rings = 20;
    let mesh = velarium::scene::generate::resolve(&geometry);
    let rim: Vec<usize> = mesh.node_sets["disc.rim"].clone();
    let on_rim: Vec<bool> = (0..mesh.nodes.len()).map(|i| rim.contains(&i)).collect();
    let center = mesh.node_sets["disc.center"][0];
    let mut nodes = mesh.nodes.clone();
    let mut copy = vec![usize::MAX; nodes.len()];
    for i in 0..mesh.nodes.len() {
        if !on_rim[i] {
            copy[i] = nodes.len();
            nodes.push(mesh.nodes[i]);
        } else {
            copy[i] = i;
        }
    }
    let normal_z = |t: &[usize; 3]| {
        let [p, q, r] = t.map(|k| Vector3::from(mesh.nodes[k]));
        (q - p).cross(&(r - p))[2]
    };
    let mut triangles: Vec<[usize; 3]> = Vec::new();
    for t in &mesh.triangles {
        let top = if normal_z(t) > 0.0 {
            *t
        } else {
            [t[0], t[2], t[1]]
        };
        triangles.push(top);
    }
    for k in 0..mesh.triangles.len() {
        let [a, b, c] = triangles[k];
        triangles.push([copy[a], copy[c], copy[b]]);
    }
    let all: Vec<usize> = (0..triangles.len()).collect();
    let scene_json = json!({
        "format": 1, "name": "FlatCushion",
        "geometry": {"nodes": nodes, "triangles": triangles,
                     "node_sets": {"rim": rim, "top": [center], "bottom": [copy[center]]},
                     "triangle_sets": {"all": all}},
        "membranes": [{"name": "sheets", "triangles": "all", "thickness": 1e-4,
                       "material": {"kind": "svk", "E": 2e8, "nu": 0.3}}],
        "supports": [{"nodes": "rim", "fix": ["x", "y", "z"]}],
        "inputs": [{"name": "dV", "load": {"kind": "volume", "membrane": "sheets"}}],
        "outputs": [{"name": "p", "probe": {"kind": "enclosed_pressure", "input": "dV"}},
                    {"name": "V", "probe": {"kind": "enclosed_volume", "membrane": "sheets"}},
                    {"name": "w_top", "probe": {"kind": "displacement", "node": "top", "component": "z"}},
                    {"name": "w_bottom", "probe": {"kind": "displacement", "node": "bottom", "component": "z"}}]
    });
    let scene = Scene::from_json(&scene_json.to_string()).unwrap();
    let mut e = engine(scene);
    solve(&mut e);
    // A first estimate: two caps of half the cylinder under the Hencky centre deflection.
    let dv1 = std::f64::consts::PI * A * A * 0.065404 * A;
    set(&mut e, "dV", dv1);
    let r1 = solve(&mut e);
    let p1 = get(&e, "p");
    let dv2 = dv1 * (40.0 / p1).cbrt();
    set(&mut e, "dV", dv2);
    let r2 = solve(&mut e);
    let (p2, w_top, w_bottom) = (get(&e, "p"), get(&e, "w_top"), get(&e, "w_bottom"));
    // The volume from the deformed nodes, computed here.
    let u = &e.state().displacement;
    let x = |k: usize| Vector3::from(nodes[k]) + Vector3::new(u[3 * k], u[3 * k + 1], u[3 * k + 2]);
    let volume: f64 = triangles
        .iter()
        .map(|t| x(t[0]).dot(&x(t[1]).cross(&x(t[2]))) / 6.0)
        .sum();
    let reference = 0.065404 * A * (p2 / 40.0).cbrt();
    let error = rel(w_top, reference);
    println!(
        "ΔV1 {dv1:.6e} -> p1 {p1:.4} Pa ({} it); ΔV2 {dv2:.6e} -> p2 {p2:.4} Pa ({} it); w0 top {w_top:.6e}, bottom {w_bottom:.6e}, reference {reference:.6e}: error {error:.2e}; volume {volume:.9e}",
        r1.iterations, r2.iterations
    );
    assert!((p2 / 40.0 - 1.0).abs() < 1e-2, "p2 = {p2} Pa");
    assert!(error < 1e-3, "w0 error {error:.3e}");
    assert!(
        (w_top + w_bottom).abs() <= 1e-9 * w_top,
        "mirror: {w_top} {w_bottom}"
    );
    assert!(
        (volume / dv2 - 1.0).abs() < 1e-8,
        "volume {volume} against {dv2}"
    );
    assert!(
        (get(&e, "V") / dv2 - 1.0).abs() < 1e-8,
        "enclosed_volume output"
    );
}
