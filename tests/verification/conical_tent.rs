//! GOAL: the ConicalTent (issue 29 point 1) is form-found under its radial/hoop prestress
//!       into the shape the axisymmetric membrane equations give, fast, with the prescribed
//!       stress and well-shaped triangles; the shipped tent, anchored at 8 points with
//!       scalloped edge cables between them, is form-found too and carries snow, wind and its
//!       weight into its anchors and its top ring.
//! MESH: the shipped annulus (32 sectors x 20 rings graded 1.2); for the convergence check
//!       the same with 16 sectors x 10 rings graded 1.2² (the same ring radii every other).
//! BOUNDARY CONDITIONS: axisymmetric case: base ring (r = 5 m, z = 0) and top ring (r = 0.5 m,
//!       raised to z = 3 m by a rigid `place` of the node set) held in x, y, z, no edge cables
//!       (the test removes them). Shipped: the top ring as above; the base held only at 8
//!       anchors (every 4th base node), 8 edge cables along the base between them (10 kN
//!       pretension, EA 2 MN). `form_finding.blend` carries the fabric along.
//! PARAMETERS: hoop n_θ = 1000 N/m, radial n_r = 4000 N/m at r0 = 0.5 m, n_r(r) = n_θ + (n_r0 −
//!       n_θ) r0/r; E t = 600 kN/m; snow 1000 Pa, wind (follower) ±1000 Pa, g = 9.81 on
//!       1.2 kg/m².
//! REFERENCE: the membrane equations of a surface of revolution without load (Timoshenko &
//!       Woinowsky-Krieger, *Theory of Plates and Shells*, 2nd ed. 1959, ch. 14, membrane
//!       theory of shells of revolution under axisymmetric load: N_φ/r1 + N_θ/r2 = −Z and
//!       d(N_φ r0)/dφ − N_θ r1 cos φ = −Y r1 r0, here with Z = Y = 0). With the meridian as
//!       z(r), r the distance from the axis, meridional force n_r and hoop force n_θ:
//!       meridional equilibrium d(r n_r)/dr = n_θ, so n_r = n_θ + C/r (the prescribed field
//!       satisfies it: C = (n_r0 − n_θ) r0); normal equilibrium n_r κ_m + n_θ κ_θ = 0 with
//!       κ_m = z''/(1 + z'²)^(3/2), κ_θ = z'/(r (1 + z'²)^(1/2)), so
//!       z'' = −(n_θ/n_r(r)) z' (1 + z'²)/r, z(0.5) = 3, z(5) = 0, solved here by RK4 (20 000
//!       steps) and bisection on z'(0.5). (With n_r = n_θ it is the catenoid z = a acosh(r/a),
//!       which cannot drop more than 1.5 m between these rings: isotropic prestress has no
//!       3 m tent.) Statics of the shipped tent: snow s times the plan area of the current
//!       shape (Σ |c_z|/2 over the triangles at the loaded state: the free edges move); a
//!       follower pressure p on an open surface sums to p times its vector area, whose
//!       vertical part is Σ c_z/2 (upward); the weight is g ρ t times the found area (the
//!       model's reference areas). The edge cables' in-plane scallop depth is printed beside
//!       the estimate c²/(8 R), R = T/n_r(5 m) = 7.7 m, c the chord: 0.238 m (an estimate
//!       only: n normal to the cable varies along it and the surface is curved).
//! TOLERANCES: shape: largest |z_FE(r) − z_ODE(r)| over the nodes, relative to the height:
//!       measured 4.8e-3 at 16 x 10 and 1.18e-3 at 32 x 20 (O(h²)); tolerance 1.5e-3 at 32 x 20
//!       and a fall of more than 3 per halving. Stress: the form finding's own acceptance is
//!       1 %; measured 1.9e-4, tolerance 1e-3 (shipped, with edge cables: 6.6e-3, tolerance
//!       the acceptance 1e-2; the edge cable's tension within 1e-2 of its 10 kN, measured
//!       3.8e-3). Triangles: aspect ratio (longest edge over 2√3 times the inradius; 1 for an
//!       equilateral triangle) at most 1.5 (measured 1.13), smallest angle at least 40°
//!       (44.6°); shipped 2.0 (1.28) and 35° (37.3°). Time: issue 29's target is under 2 s
//!       (measured 0.06-0.15 s, printed); asserted is the work, which does not depend on the
//!       machine's load: at most 24 form-finding iterations at 32 x 20 (measured 12) and 34
//!       for the shipped tent (measured 17), twice what is reached.
//!       Statics of the loaded tent: 2e-8 of the load: the solver's force tolerance (1e-9 of
//!       the force scale per DOF) summed over the free edge's nodes (measured 3.9e-11 snow,
//!       5.4e-9 suction, 1.2e-10 pressure, 2.0e-13 weight; with the base held all round it was
//!       about 1e-12). Scallop depth > 0.1 m (the cables pull the edge in; measured 0.229 m).

use crate::common;
use common::*;
use nalgebra::Vector3;
use velarium::formfind;
use velarium::Scene;

const R0: f64 = 0.5;
const R1: f64 = 5.0;
const H: f64 = 3.0;
const NT: f64 = 1000.0;
const NR0: f64 = 4000.0;

/// z(r) of the meridian with z(R0) = H and slope `s0` = −z'(R0), on a grid of `n` steps.
fn meridian(s0: f64, n: usize) -> Vec<f64> {
    let c = (NR0 - NT) * R0;
    let f = |r: f64, z: f64, zp: f64| {
        let _ = z;
        (zp, -(NT / (NT + c / r)) * zp * (1.0 + zp * zp) / r)
    };
    let h = (R1 - R0) / n as f64;
    let (mut r, mut z, mut zp) = (R0, H, -s0);
    let mut out = vec![z];
    for _ in 0..n {
        let k1 = f(r, z, zp);
        let k2 = f(r + h / 2.0, z + h / 2.0 * k1.0, zp + h / 2.0 * k1.1);
        let k3 = f(r + h / 2.0, z + h / 2.0 * k2.0, zp + h / 2.0 * k2.1);
        let k4 = f(r + h, z + h * k3.0, zp + h * k3.1);
        z += h / 6.0 * (k1.0 + 2.0 * k2.0 + 2.0 * k3.0 + k4.0);
        zp += h / 6.0 * (k1.1 + 2.0 * k2.1 + 2.0 * k3.1 + k4.1);
        r += h;
        out.push(z);
    }
    out
}

/// The meridian through both rings: bisection on the top slope (z(R1) falls as it steepens).
fn ode_shape() -> impl Fn(f64) -> f64 {
    let n = 20_000;
    let (mut lo, mut hi) = (0.5, 16.0);
    assert!(meridian(lo, n)[n] > 0.0 && meridian(hi, n)[n] < 0.0);
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if meridian(mid, n)[n] > 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let z = meridian(0.5 * (lo + hi), n);
    move |r: f64| {
        let t = (r - R0) / (R1 - R0) * n as f64;
        let i = (t.floor() as usize).min(n - 1);
        z[i] + (t - i as f64) * (z[i + 1] - z[i])
    }
}

/// The shipped tent made axisymmetric (its whole base ring held, no edge cables) on an annulus
/// of `sectors` x `rings` graded `grading`.
fn tent(sectors: usize, rings: usize, grading: f64) -> Scene {
    let path = common::shipped("ConicalTent");
    let mut scene: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    let annulus = &mut scene["geometry"]["generators"][0];
    annulus["sectors"] = sectors.into();
    annulus["rings"] = rings.into();
    annulus["grading"] = grading.into();
    // The anchors, the edge cables and the shipped outputs name nodes of the shipped mesh.
    scene["geometry"]
        .as_object_mut()
        .unwrap()
        .remove("node_sets");
    scene.as_object_mut().unwrap().remove("cables");
    scene["supports"] = serde_json::json!([
        {"nodes": "tent.inner_rim", "fix": ["x", "y", "z"]},
        {"nodes": "tent.outer_rim", "fix": ["x", "y", "z"]}]);
    scene["outputs"] = serde_json::json!([]);
    Scene::from_json(&scene.to_string()).unwrap_or_else(|e| panic!("{e}"))
}

/// Σ |c_z|/2 and Σ c_z/2 over the triangles at the engine's current shape (the plan area snow
/// acts on, and the vertical projection of the area vector a follower pressure acts on).
fn plan_areas(e: &velarium::Engine) -> (f64, f64) {
    let model = e.model();
    let u = &e.state().displacement;
    let (mut snow, mut wind) = (0.0, 0.0);
    for t in &model.triangles {
        let x = t.nodes.map(|i| model.position(u, i));
        let cz = 0.5 * (x[1] - x[0]).cross(&(x[2] - x[0])).z;
        snow += cz.abs();
        wind += cz;
    }
    (snow, wind)
}

/// (largest |z − z_ODE|/H, largest aspect ratio, smallest angle in degrees, area) of a found
/// scene.
fn measure(found: &Scene, z_ode: &dyn Fn(f64) -> f64) -> (f64, f64, f64, f64) {
    let nodes: Vec<Vector3<f64>> = found
        .geometry
        .nodes
        .iter()
        .map(|p| Vector3::from(*p))
        .collect();
    let shape = nodes
        .iter()
        .map(|p| (p.z - z_ode(p.x.hypot(p.y))).abs() / H)
        .fold(0.0, f64::max);
    let (mut aspect, mut angle, mut area) = (0.0f64, 180.0f64, 0.0);
    for t in &found.geometry.triangles {
        let p = t.clone().map(|c| match c {
            velarium::scene::OneNode::Id(i) => nodes[i],
            velarium::scene::OneNode::Set(_) => unreachable!("the found scene is explicit"),
        });
        let e = [0, 1, 2].map(|i| (p[(i + 1) % 3] - p[(i + 2) % 3]).norm());
        let a = 0.5 * (p[1] - p[0]).cross(&(p[2] - p[0])).norm();
        area += a;
        let inradius = 2.0 * a / (e[0] + e[1] + e[2]);
        aspect =
            aspect.max(e.iter().fold(0.0f64, |m, v| m.max(*v)) / (2.0 * 3f64.sqrt() * inradius));
        for i in 0..3 {
            let (b, c) = (e[(i + 1) % 3], e[(i + 2) % 3]);
            let cos = (b * b + c * c - e[i] * e[i]) / (2.0 * b * c);
            angle = angle.min(cos.clamp(-1.0, 1.0).acos().to_degrees());
        }
    }
    (shape, aspect, angle, area)
}

#[test]
fn the_conical_tent_is_the_axisymmetric_membrane_and_carries_its_loads() {
    let z_ode = ode_shape();
    let mut shape_errors = Vec::new();
    for (sectors, rings, grading) in [(16, 10, 1.44), (32, 20, 1.2)] {
        let report =
            formfind::run(&tent(sectors, rings, grading)).unwrap_or_else(|e| panic!("{e}"));
        let found = report
            .scene
            .clone()
            .unwrap_or_else(|| panic!("not form-found: {}", report.message));
        let (shape, aspect, angle, area) = measure(&found, &z_ode);
        eprintln!(
            "{sectors} x {rings}: {} iterations, {:.3} s, stress within {:.1e}, shape {shape:.2e} of H, aspect <= {aspect:.3}, angle >= {angle:.1}°, area {area:.4} m²",
            report.iterations, report.seconds, report.deviation
        );
        shape_errors.push(shape);
        if sectors == 32 {
            // The work, not the time (no timed assertions): the "under 2 s" is printed.
            assert!(
                report.iterations <= 24,
                "form finding took {} iterations",
                report.iterations
            );
            assert!(report.deviation < 1e-3, "stress {:e} off", report.deviation);
            assert!(aspect <= 1.5, "aspect ratio {aspect}");
            assert!(angle >= 40.0, "smallest angle {angle}°");
        }
    }
    assert!(shape_errors[1] < 1.5e-3, "shape {:e} of H", shape_errors[1]);
    assert!(
        shape_errors[0] > 3.0 * shape_errors[1],
        "no O(h²): {shape_errors:?}"
    );

    // The shipped tent: 8 anchors at the base, scalloped edge cables between them.
    let shipped_scene = common::read_scene(&common::shipped("ConicalTent"));
    let report = formfind::run(&shipped_scene).unwrap_or_else(|e| panic!("{e}"));
    let found = report
        .scene
        .clone()
        .unwrap_or_else(|| panic!("not form-found: {}", report.message));
    let (_, aspect, angle, _) = measure(&found, &z_ode);
    // The scallop: how far each edge cable's middle node lies inside the chord between its
    // anchors, in plan.
    let nodes = &found.geometry.nodes;
    let scallop = found
        .cables
        .iter()
        .map(|c| {
            let velarium::scene::NodeRef::Ids(ids) = &c.nodes else {
                unreachable!("the found scene is explicit")
            };
            let [a, m, b] = [ids[0], ids[ids.len() / 2], ids[ids.len() - 1]].map(|i| nodes[i]);
            let (cx, cy) = (b[0] - a[0], b[1] - a[1]);
            ((cx * (a[1] - m[1]) - (a[0] - m[0]) * cy) / cx.hypot(cy)).abs()
        })
        .fold(f64::INFINITY, f64::min);
    eprintln!(
        "shipped (edge cables): {} iterations, {:.3} s, stress within {:.1e}, aspect <= {aspect:.3}, angle >= {angle:.1}°, scallops {scallop:.4} m deep",
        report.iterations, report.seconds, report.deviation
    );
    assert!(
        report.iterations <= 34,
        "form finding took {} iterations",
        report.iterations
    );
    assert!(report.deviation < 1e-2, "stress {:e} off", report.deviation);
    assert!(aspect <= 2.0, "aspect ratio {aspect}");
    assert!(angle >= 35.0, "smallest angle {angle}°");
    assert!(
        scallop > 0.1,
        "the edge cables must pull the edge in: {scallop} m"
    );

    // The shipped scene through the engine (form-found at construction): loads into the
    // anchors and the top ring.
    let mut e = engine(shipped_scene);
    solve(&mut e);
    let area: f64 = e.model().triangles.iter().map(|t| t.reference.area).sum();
    let total = |e: &velarium::Engine| get(e, "base_Rz") + get(e, "top_Rz");
    assert!(total(&e).abs() < 1e-8 * NR0, "unloaded: {}", total(&e));
    let tension = get(&e, "T_edge");
    assert!((tension - 1e4).abs() < 1e-2 * 1e4, "edge cable {tension} N");
    for (input, value) in [
        ("snow", 1000.0),
        ("wind", 1000.0),
        ("wind", -1000.0),
        ("g", 9.81),
    ] {
        set(&mut e, input, value);
        let report = solve(&mut e);
        let (snow_area, wind_area) = plan_areas(&e);
        let expected = match input {
            "snow" => value * snow_area,
            "wind" => -value * wind_area,
            _ => value * 1.2 * area,
        };
        let error = (total(&e) - expected).abs() / expected.abs();
        eprintln!(
            "{input} {value}: anchors and top ring carry {} N, expected {expected} N ({error:.1e}), {} iterations, edge cable {:.0} N",
            total(&e),
            report.iterations,
            get(&e, "T_edge")
        );
        assert!(error < 2e-8, "{input}: {error:e}");
        set(&mut e, input, 0.0);
        solve(&mut e);
    }
}
