//! GOAL: the ETFE foil law (`material.kind: "etfe"`, src/model/etfe.rs) through the whole
//!       program: a strip loaded, unloaded and reloaded in uniaxial tension follows the
//!       piecewise-linear curve it was given and keeps its plastic strain; a clamped circular
//!       foil inflated past both yield points (the bubble-inflation test) carries at its dome
//!       the equibiaxial curve of the law, and its dome stress equals p R / (2 t) from the
//!       rise.
//! MESH: strip 0.1 m x 0.02 m, rectangle generator 4 x 1 cells (8 CST triangles: a homogeneous
//!       deformation is exact on them); disc of radius 0.1 m, 12 rings.
//! BOUNDARY CONDITIONS: strip: left edge x fixed, its lower corner y, every node z; the load a
//!       point force along x split over the 2 right-edge nodes. Disc: rim clamped; follower
//!       pressure.
//! PARAMETERS: E = 1 GPa, nu = 0.43, first yield 16 MPa (strain 1.6 %), second yield 24 MPa at
//!       10 %, 10 MPa beyond; t = 200 µm. Values of the size ETFE design data give (foils of
//!       100-250 µm: first yield 15-17 MPa at about 2 %, second yield 21-26 MPa), not a fit to one
//!       foil.
//! REFERENCE: strip: the closed form of the law in the strip's measures (Green-Lagrange E11,
//!       PK2 S11, nominal force F = t W λ S11 with λ = √(1 + 2 E11)): loading
//!       E11 = S/E + α(S), α(S) the inverse of the hardening (α = (S − σ1)/H1 up to σ2, then
//!       α2 + (S − σ2)/H2); unloading and reloading below the largest stress S_max
//!       E11 = α(S_max) + S/E. Unloaded to 0.5 MPa, not 0: at zero force a tension-only strip
//!       is slack at any length up to its plastic length L (√(1 + 2 α_max) − 1), and every
//!       such shape is an equilibrium (a one-step unloading to 0 stops at one of them).
//!       Disc: at the dome the state is equibiaxial (S11 = S22 = S, E11 = E22 = e): the law's
//!       closed form e = (1 − ν) S / E + α(S) / 2 (von Mises: equibiaxial yield at S = σy, the
//!       equivalent plastic strain is twice the in-plane plastic strain); and the membrane
//!       equilibrium at the pole, σ = p R / (2 t), R the pole's radius of curvature from the
//!       computed shape (spheres through the pole and the first two rings, Richardson).
//! TOLERANCE: strip 1e-8 relative on the elongation (homogeneous, so only the solver's
//!       tolerance 1e-9 on forces: measured 2.7e-9 at most). Dome, law: 3e-4 relative on the
//!       strain at the stress the dome triangles carry (equibiaxial only to O(h²) on the
//!       triangulated disc: measured 9.4e-5 at most). Dome, equilibrium at the pole: 1e-2
//!       (measured 4.8e-3 at most). The bubble test's own processing, R from the rise through
//!       the rim, is printed beside: it is 2.5-9.6 % below the pole stress here (the cap is not
//!       a sphere), which is why it is not the reference.
//!       Not done: a comparison with a measured bubble curve of ETFE foil (Galliot &
//!       Luchsinger 2011, Polym. Test. 30:356-365, report such curves); their numbers were not
//!       available to us.

use crate::common;
use common::*;
use velarium::model::etfe::Hardening;
use velarium::model::membrane;

const E: f64 = 1.0e9;
const NU: f64 = 0.43;
const S1: f64 = 16e6;
const S2: f64 = 24e6;
const E2: f64 = 0.10;
const ET3: f64 = 10e6;
const T: f64 = 2e-4;

fn material() -> serde_json::Value {
    serde_json::json!({"kind": "etfe", "E": E, "nu": NU, "yield_stress": S1,
        "second_yield_stress": S2, "second_yield_strain": E2, "tangent_modulus": ET3})
}

fn hardening() -> Hardening {
    Hardening::from_curve(E, S1, (E2, S2), ET3)
}

/// α reached on loading to the yield stress `s` (0 below the first yield).
fn alpha_at(h: &Hardening, s: f64) -> f64 {
    if s <= h.s1 {
        0.0
    } else if s <= h.s1 + h.h1 * h.a2 {
        (s - h.s1) / h.h1
    } else {
        h.a2 + (s - h.s1 - h.h1 * h.a2) / h.h2
    }
}

const L: f64 = 0.1;
const W: f64 = 0.02;

fn strip() -> velarium::Engine {
    let scene = serde_json::json!({
        "format": 1, "name": "EtfeStrip",
        "geometry": {"generators": [{"kind": "rectangle", "name": "s", "origin": [0, 0, 0],
            "size": [L, W], "divisions": [4, 1]}]},
        "membranes": [{"name": "foil", "triangles": "s", "thickness": T, "material": material()}],
        "supports": [{"nodes": "s.edge_left", "fix": ["x"]}, {"nodes": "s.corner_bl", "fix": ["y"]},
            {"nodes": "s.all", "fix": ["z"]}],
        "inputs": [{"name": "F", "load": {"kind": "point_force", "nodes": "s.edge_right",
            "direction": [1, 0, 0]}, "start": 0}],
        "outputs": [{"name": "ux", "probe": {"kind": "displacement", "node": "s.corner_tr",
            "component": "x"}}],
        "experiment": {"start_time": 0, "stop_time": 1, "step_size": 0.1}
    });
    engine(velarium::Scene::from_json(&scene.to_string()).unwrap())
}

/// The total force (split over the right edge's nodes) that carries PK2 stress `s` at
/// Green-Lagrange strain `e11`.
fn force(s: f64, e11: f64) -> f64 {
    T * W * (1.0 + 2.0 * e11).sqrt() * s
}

fn elongation(e11: f64) -> f64 {
    L * ((1.0 + 2.0 * e11).sqrt() - 1.0)
}

#[test]
fn strip_follows_the_uniaxial_curve_loaded_unloaded_and_reloaded() {
    let h = hardening();
    let mut e = strip();
    solve(&mut e);
    // Loading through both yield points, unloading to zero, reloading past the largest stress.
    let s_max = 26e6;
    let a_max = alpha_at(&h, s_max);
    let mut path: Vec<(&str, f64, f64)> = Vec::new();
    for s in [8e6, 16e6, 20e6, 24e6, 25e6, s_max] {
        path.push(("loading", s, s / E + alpha_at(&h, s)));
    }
    // Down to 0.5 MPa, not 0: at zero force a tension-only strip is slack anywhere it is not
    // longer than its plastic length (every such shape is an equilibrium).
    for s in [20e6, 10e6, 0.5e6] {
        path.push(("unloading", s, a_max + s / E));
    }
    for s in [20e6, s_max] {
        path.push(("reloading", s, a_max + s / E));
    }
    path.push(("beyond", 27e6, 27e6 / E + alpha_at(&h, 27e6)));
    let mut worst = 0.0f64;
    for (what, s, e11) in path {
        set(&mut e, "F", force(s, e11));
        solve(&mut e);
        let (u, want) = (get(&e, "ux"), elongation(e11));
        let err = rel(u, want);
        println!(
            "{what} S = {:5.1} MPa: ux {u:.9e}, closed form {want:.9e}, error {err:.1e}",
            s / 1e6
        );
        worst = worst.max(err);
        assert!(err < 1e-8, "{what} at S = {s:e}: ux {u} vs {want}");
    }
    println!(
        "residual elongation after unloading: {:.6e} m (plastic strain α_max = {a_max:.5})",
        elongation(a_max)
    );
    println!("worst relative error {worst:.1e}");
}

/// The dome triangles' mean Green-Lagrange strain and PK2 stress (mean of the two normal
/// components in the element frame) and the rise h.
fn dome(e: &velarium::Engine) -> (f64, f64, f64, f64) {
    let model = e.model();
    let u = &e.state().displacement;
    let (mut strain, mut stress, mut cauchy, mut n) = (0.0, 0.0, 0.0, 0.0);
    for (k, t) in model.triangles.iter().enumerate() {
        let c: nalgebra::Vector3<f64> = t
            .nodes
            .iter()
            .map(|&i| model.reference[i])
            .sum::<nalgebra::Vector3<f64>>()
            / 3.0;
        if c.norm() > 0.012 {
            continue;
        }
        let x = t.nodes.map(|i| model.position(u, i));
        let f = membrane::deformation_gradient(&t.reference, &x);
        let g = membrane::green_lagrange(&f);
        let ev = &e.membranes()[k];
        strain += 0.5 * (g[0] + g[1]);
        stress += 0.5 * (ev.stress[0] + ev.stress[1]);
        cauchy += 0.5 * (ev.cauchy.0 + ev.cauchy.1);
        n += 1.0;
    }
    (strain / n, stress / n, cauchy / n, get(e, "center_uz"))
}

/// The radius of curvature at the pole from the current positions: the sphere through the
/// pole and each of the first two rings (mean over the ring), R_k = (r² + d²) / (2 d), then
/// Richardson's (4 R1 − R2) / 3 (the rings' error is O(r²)).
fn pole_radius(e: &velarium::Engine, a: f64, rings: usize) -> f64 {
    let model = e.model();
    let u = &e.state().displacement;
    let pole = (0..model.reference.len())
        .find(|&i| model.reference[i].norm() < 1e-12)
        .expect("the disc's centre node");
    let top = model.position(u, pole);
    let mut radius = [0.0; 2];
    for (k, r) in radius.iter_mut().enumerate() {
        let r0 = a * (k + 1) as f64 / rings as f64;
        let (mut sum, mut n) = (0.0, 0.0);
        for (i, x0) in model.reference.iter().enumerate() {
            if (x0.norm() - r0).abs() > 1e-9 {
                continue;
            }
            let x = model.position(u, i) - top;
            let (rr, d) = ((x.x * x.x + x.y * x.y).sqrt(), -x.z);
            sum += (rr * rr + d * d) / (2.0 * d);
            n += 1.0;
        }
        *r = sum / n;
    }
    (4.0 * radius[0] - radius[1]) / 3.0
}

#[test]
fn inflated_disc_carries_the_equibiaxial_curve_at_its_dome() {
    let a = 0.1;
    let scene = serde_json::json!({
        "format": 1, "name": "EtfeBubble",
        "geometry": {"generators": [{"kind": "disc", "name": "disc", "center": [0, 0, 0],
            "radius": a, "rings": 12}]},
        "membranes": [{"name": "foil", "triangles": "disc", "thickness": T, "material": material()}],
        "supports": [{"nodes": "disc.rim", "fix": ["x", "y", "z"]}],
        "inputs": [{"name": "p", "load": {"kind": "pressure", "membrane": "foil", "follower": true},
            "start": 0}],
        "outputs": [{"name": "center_uz", "probe": {"kind": "displacement", "node": "disc.center",
            "component": "z"}}],
        "experiment": {"start_time": 0, "stop_time": 1, "step_size": 0.1}
    });
    let mut e = engine(velarium::Scene::from_json(&scene.to_string()).unwrap());
    solve(&mut e);
    let h = hardening();
    let (mut worst_law, mut worst_cap) = (0.0f64, 0.0f64);
    for p in [10e3, 20e3, 30e3, 40e3, 50e3, 60e3, 70e3] {
        set(&mut e, "p", p);
        solve(&mut e);
        let (strain, stress, cauchy, rise) = dome(&e);
        let rise = rise.abs();
        // The law's equibiaxial strain at the dome's stress.
        let law = (1.0 - NU) * stress / E + 0.5 * alpha_at(&h, stress);
        // Equilibrium at the pole, with its own radius of curvature; and the test's processing
        // with R from the rise (a sphere through the rim), printed for comparison.
        let pole = p * pole_radius(&e, a, 12) / (2.0 * T);
        let r = (a * a + rise * rise) / (2.0 * rise);
        let cap = p * r / (2.0 * T);
        let (err_law, err_cap) = (rel(strain, law), rel(cauchy, pole));
        println!(
            "p {:4.0} kPa: rise {:.4} m, dome E {strain:.5} (law {law:.5}, {err_law:.1e}), S {:.2} MPa, sigma {:.2} MPa vs pR/2t {:.2} MPa at the pole ({err_cap:.1e}), {:.2} MPa from the rise ({:+.1} %)",
            p / 1e3,
            rise,
            stress / 1e6,
            cauchy / 1e6,
            pole / 1e6,
            cap / 1e6,
            100.0 * (cap / cauchy - 1.0)
        );
        worst_law = worst_law.max(err_law);
        worst_cap = worst_cap.max(err_cap);
    }
    println!("worst: law {worst_law:.1e}, cap {worst_cap:.1e}");
    assert!(worst_law < 3e-4, "dome strain vs the law: {worst_law:e}");
    assert!(
        worst_cap < 1e-2,
        "dome stress vs p R / (2 t): {worst_cap:e}"
    );
    // The dome went past the second yield point.
    let (_, stress, _, _) = dome(&e);
    assert!(stress > S2, "dome stress {stress:e}");
}

/// GOAL: the plastic strain is state: a strip's state taken past yield (`Engine::state`, what
/// an FMU state holds) and set into a fresh engine unloads to the same elongation, bit for
/// bit, as the engine it came from; the same state with its plastic strains zeroed does not
/// (so the comparison can fail). Loaded in one step (path increments inside it).
/// REFERENCE: the closed form at 0.5 MPa after 25 MPa, L (√(1 + 2 (α_max + S/E)) − 1).
/// TOLERANCE: bit-identical between the engines; 1e-8 to the closed form (as the strip above).
#[test]
fn plastic_strain_travels_with_the_state() {
    let h = hardening();
    let s_max = 25e6;
    let a_max = alpha_at(&h, s_max);
    let mut first = strip();
    solve(&mut first);
    set(&mut first, "F", force(s_max, s_max / E + a_max));
    let report = solve(&mut first);
    println!(
        "loading in one step: {} increments, {} Newton iterations",
        report.increments, report.iterations
    );
    println!(
        "loaded: ux {:e} vs {:e}; alpha {:?}",
        get(&first, "ux"),
        elongation(s_max / E + a_max),
        first
            .state()
            .plastic
            .chunks(4)
            .map(|c| c[3])
            .collect::<Vec<_>>()
    );
    let saved = first.state().clone();
    assert!(saved.plastic.iter().any(|&p| p != 0.0));
    let mut second = strip();
    second.set_state(saved.clone()).unwrap();
    let mut virgin = saved.clone();
    virgin.plastic.iter_mut().for_each(|p| *p = 0.0);
    let mut third = strip();
    third.set_state(virgin).unwrap();
    // Unloaded to 0.5 MPa (at zero force the slack strip's length is not unique).
    let s_low = 0.5e6;
    for e in [&mut first, &mut second, &mut third] {
        set(e, "F", force(s_low, a_max + s_low / E));
        solve(e);
    }
    let (a, b, c) = (get(&first, "ux"), get(&second, "ux"), get(&third, "ux"));
    let want = elongation(a_max + s_low / E);
    println!("unloaded: {a:e} (restored {b:e}, plastic zeroed {c:e}), closed form {want:e}");
    assert_eq!(a.to_bits(), b.to_bits());
    assert_eq!(first.state().plastic, second.state().plastic);
    assert!(rel(a, want) < 1e-8, "{a} vs {want}");
    assert!(rel(c, want) > 0.5, "zeroed plastic strain must not give it");
}
