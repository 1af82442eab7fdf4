//! GOAL: the natural frequencies of `Engine::modes` (shift-invert Lanczos on the true tangent
//!       and the mass matrix) match the closed forms of prestressed membranes and taut and
//!       sagging cables, and converge at the linear elements' rate O(h²).
//! MESH: per case below (rectangle and disc generators; explicit cable nodes).
//! BOUNDARY CONDITIONS: membrane boundaries clamped; cable ends pinned.
//! PARAMETERS: per case below.
//! REFERENCE:
//!   rectangular membrane a × b under isotropic N:  f_mn = ½ √(N/(ρt)) √((m/a)² + (n/b)²)
//!   circular membrane, radius R:                   f_01 = 2.4048/(2πR) √(N/(ρt))
//!     (Graff 1975, *Wave Motion in Elastic Solids*, §4.3; 2.4048 the first zero of J0)
//!   taut string, length L, tension T, mass μ:      f_n = n/(2L) √(T/μ)  (Graff §1.1)
//!   sagging cable (Irvine & Caughey 1974, Proc. R. Soc. A 341, 299-315): in-plane symmetric
//!     modes from tan(w/2) = w/2 − (4/λ²)(w/2)³, antisymmetric w = 2nπ, w = ω L/√(H/m),
//!     λ² = (m g L/H)² L/(H L_e/(EA)), L_e = L (1 + 8 (d/L)²); H and the sag d are read from
//!     the computed equilibrium (inputs of the closed form, not the answer)
//! TOLERANCE: the errors are printed per mesh (`cargo test --release --test verification
//!   natural_frequencies -- --nocapture`); each test holds the finest mesh to a bound a small
//!   multiple of the error measured there (stated at each assertion) and the observed order of
//!   convergence log2(e_h / e_h/2) to [1.8, 2.2] (linear elements: O(h²) in the eigenvalue).

use crate::common::*;
use std::f64::consts::PI;
use velarium::scene::MassKind;
use velarium::Scene;

/// The lowest `count` frequencies (Hz) of the scene's start equilibrium.
fn frequencies(scene: Scene, count: usize) -> Vec<f64> {
    let mut e = engine(scene);
    solve(&mut e);
    let modes = e.modes(count).unwrap_or_else(|err| panic!("{err}"));
    assert_eq!(modes.frequencies.len(), count);
    modes.frequencies
}

fn scene(json: serde_json::Value) -> Scene {
    Scene::from_json(&json.to_string()).unwrap_or_else(|p| panic!("{p}"))
}

/// Relative errors as percentages, for the printed lines.
fn pct(e: &[f64]) -> String {
    let parts: Vec<String> = e.iter().map(|x| format!("{:+.4} %", 100.0 * x)).collect();
    parts.join(", ")
}

/// Observed order of convergence from the errors of two meshes, the second twice as fine.
fn order(coarse: f64, fine: f64) -> f64 {
    (coarse.abs() / fine.abs()).log2()
}

// Rectangular membrane: a = 1 m, b = 0.7 m (no repeated frequency among the lowest six),
// N = 1000 N/m, ρ t = 1 kg/m² (t = 1 mm, ρ = 1000 kg/m³), SVK E = 1 GPa, ν = 0.3 (the in-plane
// modes lie far above: √(E/ρ)/(2a) ≈ 500 Hz), meshes 20 × 14, 40 × 28, 80 × 56 cells.
const A: f64 = 1.0;
const B: f64 = 0.7;
const N: f64 = 1000.0;
const RHO_T: f64 = 1.0;

fn rectangle(nx: usize, ny: usize, mass: MassKind) -> Scene {
    let mass = match mass {
        MassKind::Consistent => "consistent",
        MassKind::Lumped => "lumped",
    };
    scene(serde_json::json!({
        "format": 1, "name": "Rectangle",
        "geometry": {"generators": [{"kind": "rectangle", "name": "s", "origin": [0, 0, 0],
                                     "size": [A, B], "divisions": [nx, ny]}]},
        "membranes": [{"name": "m", "triangles": "s", "thickness": 0.001, "density": 1000.0,
                       "material": {"kind": "svk", "E": 1e9, "nu": 0.3},
                       "prestress": {"kind": "isotropic", "n": N}}],
        "supports": [{"nodes": "s.boundary", "fix": ["x", "y", "z"]}],
        "dynamics": {"mass": mass}
    }))
}

/// The lowest six f_mn of the rectangle, ascending.
fn rectangle_exact() -> Vec<f64> {
    let c = (N / RHO_T).sqrt();
    let mut f: Vec<f64> = (1..8)
        .flat_map(|m| (1..8).map(move |n| (m as f64, n as f64)))
        .map(|(m, n)| 0.5 * c * ((m / A).powi(2) + (n / B).powi(2)).sqrt())
        .collect();
    f.sort_by(f64::total_cmp);
    f.truncate(6);
    f
}

/// Measured relative errors of f11, f21, f12, f31, f22, f32: consistent mass 20 × 14 +0.40 %
/// ... +2.35 %, 40 × 28 +0.10 % ... +0.59 %, 80 × 56 +0.025 % ... +0.147 %; lumped mass from
/// below, 80 × 56 −0.014 % ... −0.074 %; observed orders 2.000 to 2.004. Bounds at 80 × 56:
/// every mode within 0.3 % (consistent) and 0.15 % (lumped), 2x the largest error measured;
/// f11 within 0.05 % (2x).
#[test]
fn rectangular_membrane() {
    let exact = rectangle_exact();
    for mass in [MassKind::Consistent, MassKind::Lumped] {
        let mut errors: Vec<Vec<f64>> = Vec::new();
        for (nx, ny) in [(20, 14), (40, 28), (80, 56)] {
            let f = frequencies(rectangle(nx, ny, mass), 6);
            let e: Vec<f64> = f.iter().zip(&exact).map(|(f, x)| (f - x) / x).collect();
            println!(
                "rectangle {mass:?} {nx}x{ny}: f = {f:.4?} Hz, relative errors {}",
                pct(&e)
            );
            errors.push(e);
        }
        let fine = &errors[2];
        let bound = match mass {
            MassKind::Consistent => 3e-3,
            MassKind::Lumped => 1.5e-3,
        };
        for (k, e) in fine.iter().enumerate() {
            assert!(e.abs() <= bound, "{mass:?} mode {}: error {e:e}", k + 1);
            match mass {
                MassKind::Consistent => assert!(*e > 0.0, "consistent mass bounds from above"),
                MassKind::Lumped => assert!(*e < 0.0, "lumped mass: from below here"),
            }
            let p = order(errors[1][k], errors[2][k]);
            println!("  mode {}: observed order {p:.3}", k + 1);
            assert!(
                (1.8..=2.2).contains(&p),
                "{mass:?} mode {}: order {p}",
                k + 1
            );
        }
        assert!(fine[0].abs() <= 5e-4, "{mass:?} f11: {:e}", fine[0]);
    }
}

/// Circular membrane: R = 1 m, N = 1000 N/m, ρ t = 1 kg/m², disc of 8, 16 and 32 rings.
/// Measured (consistent mass) f01 errors: 8 rings +0.333 %, 16 +0.085 %, 32 +0.022 % (the
/// polygonal rim included), observed order 1.94. Bound 0.05 % at 32 rings (2x) and the order
/// within [1.8, 2.2].
#[test]
fn circular_membrane() {
    let exact = 2.4048 / (2.0 * PI) * (N / RHO_T).sqrt();
    let mut errors = Vec::new();
    for rings in [8, 16, 32] {
        let s = scene(serde_json::json!({
            "format": 1, "name": "Disc",
            "geometry": {"generators": [{"kind": "disc", "name": "d", "center": [0, 0, 0],
                                         "radius": 1.0, "rings": rings}]},
            "membranes": [{"name": "m", "triangles": "d", "thickness": 0.001, "density": 1000.0,
                           "material": {"kind": "svk", "E": 1e9, "nu": 0.3},
                           "prestress": {"kind": "isotropic", "n": N}}],
            "supports": [{"nodes": "d.boundary", "fix": ["x", "y", "z"]}]
        }));
        let f = frequencies(s, 1)[0];
        let e = (f - exact) / exact;
        println!("disc {rings} rings: f01 = {f:.5} Hz (exact {exact:.5}), relative error {e:.3e}");
        errors.push(e);
    }
    let p = order(errors[1], errors[2]);
    println!("  observed order {p:.3}");
    assert!(errors[2].abs() <= 5e-4, "{:e}", errors[2]);
    assert!((1.8..=2.2).contains(&p), "order {p}");
}

// Taut cable: L = 2 m, T = 1000 N, μ = 0.5 kg/m, EA = 1e7 N (axial modes at
// n/(2L) √(EA/μ) ≈ 1100 n Hz, far above the lowest transverse ones).
const L: f64 = 2.0;
const T: f64 = 1000.0;
const MU: f64 = 0.5;

fn cable(segments: usize, planar: bool) -> Scene {
    let nodes: Vec<[f64; 3]> = (0..=segments)
        .map(|i| [L * i as f64 / segments as f64, 0.0, 0.0])
        .collect();
    let all: Vec<usize> = (0..=segments).collect();
    let mut supports = vec![serde_json::json!({"nodes": [0, segments], "fix": ["x", "y", "z"]})];
    if planar {
        supports.push(serde_json::json!({"nodes": all, "fix": ["z"]}));
    }
    scene(serde_json::json!({
        "format": 1, "name": "String",
        "geometry": {"nodes": nodes},
        "cables": [{"name": "c", "nodes": all, "EA": 1e7, "pretension": T, "mass_per_length": MU}],
        "supports": supports
    }))
}

/// Measured (consistent mass, f1 ... f6, in y only): 20 segments +0.103 % ... +3.73 %, 40:
/// +0.026 % ... +0.93 %, 80: +0.0064 % ... +0.23 % (the error grows as (n h)²); orders 2.000
/// to 2.006. Bound 0.5 % at 80 segments (2.2x the largest error) and the order within
/// [1.8, 2.2].
#[test]
fn taut_cable() {
    let base = 1.0 / (2.0 * L) * (T / MU).sqrt();
    let mut errors: Vec<Vec<f64>> = Vec::new();
    for segments in [20, 40, 80] {
        let f = frequencies(cable(segments, true), 6);
        let e: Vec<f64> = f
            .iter()
            .enumerate()
            .map(|(k, f)| (f - (k + 1) as f64 * base) / ((k + 1) as f64 * base))
            .collect();
        println!(
            "taut cable {segments} segments: f = {f:.4?} Hz, relative errors {}",
            pct(&e)
        );
        errors.push(e);
    }
    for (k, (coarse, fine)) in errors[1].iter().zip(&errors[2]).enumerate() {
        let p = order(*coarse, *fine);
        println!("  mode {}: observed order {p:.3}", k + 1);
        assert!(fine.abs() <= 5e-3, "mode {}: {fine:e}", k + 1);
        assert!((1.8..=2.2).contains(&p), "mode {}: order {p}", k + 1);
    }
}

/// The same cable free to move in y and z: every transverse frequency twice (a repeated
/// eigenvalue that one Lanczos start vector sees once; the block of 4 sees both).
/// Bound: each pair within 1e-9 relative of each other, and of the planar cable's (which
/// has the same discrete spectrum in y).
#[test]
fn taut_cable_repeated_frequencies() {
    let planar = frequencies(cable(20, true), 3);
    let free = frequencies(cable(20, false), 6);
    println!("planar {planar:.6?}\nfree   {free:.6?}");
    for k in 0..3 {
        for f in [free[2 * k], free[2 * k + 1]] {
            assert!(
                rel(f, planar[k]) <= 1e-9,
                "mode {}: {f} against {}",
                k + 1,
                planar[k]
            );
        }
    }
}

/// A massless scene is refused with a message that says what gives mass.
#[test]
fn a_massless_scene_is_refused() {
    let mut s = cable(4, true);
    s.cables[0].mass_per_length = None;
    let mut e = engine(s);
    solve(&mut e);
    let err = e.modes(2).unwrap_err().to_string();
    assert!(err.contains("mass_per_length"), "{err}");
}

// Sagging cable (Irvine & Caughey 1974): span L = 10 m between pins at one level, m = 1 kg/m
// under g = 9.81 m/s² (a `self_weight` input), drawn straight (d/L = 0.3 % to 2 %), in-plane
// motion only (y held); EA and the unstretched length chosen for λ² below, near and above
// 4π².
const SPAN: f64 = 10.0;
const G: f64 = 9.81;

/// `slack`: None, a pretension of 1000 N as drawn; Some(l0), that unstretched length (m).
fn sagging(segments: usize, ea: f64, slack: Option<f64>) -> Scene {
    let nodes: Vec<[f64; 3]> = (0..=segments)
        .map(|i| [SPAN * i as f64 / segments as f64, 0.0, 0.0])
        .collect();
    let all: Vec<usize> = (0..=segments).collect();
    let mut cable =
        serde_json::json!({"name": "c", "nodes": all, "EA": ea, "mass_per_length": 1.0});
    match slack {
        None => cable["pretension"] = serde_json::json!(1000.0),
        Some(l0) => cable["unstretched_length"] = serde_json::json!(l0),
    }
    scene(serde_json::json!({
        "format": 1, "name": "Sagging",
        "geometry": {"nodes": nodes},
        "cables": [cable],
        "supports": [{"nodes": [0, segments], "fix": ["x", "y", "z"]},
                     {"nodes": all, "fix": ["y"]}],
        "inputs": [{"name": "g", "load": {"kind": "self_weight"}, "start": G}],
        "outputs": [{"name": "H", "probe": {"kind": "reaction", "nodes": [0], "component": "x"}},
                    {"name": "w", "probe": {"kind": "displacement", "node": segments / 2,
                                            "component": "z"}}]
    }))
}

/// The first root w of tan(w/2) = w/2 − (4/λ²)(w/2)³ (the first symmetric in-plane mode),
/// by bisection on x = w/2 in (π/2, 3π/2), where tan x − x + (4/λ²) x³ runs from −∞ to +∞.
fn first_symmetric_root(lambda2: f64) -> f64 {
    let g = |x: f64| x.tan() - x + 4.0 / lambda2 * x.powi(3);
    let (mut lo, mut hi) = (PI / 2.0 + 1e-12, 1.5 * PI - 1e-12);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if g(mid) < 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    lo + hi
}

/// (λ², f of the first symmetric and antisymmetric in-plane modes computed, the same from
/// the closed form) for one mesh and EA.
fn sagging_case(segments: usize, ea: f64, slack: Option<f64>) -> (f64, [f64; 2], [f64; 2]) {
    let mut e = engine(sagging(segments, ea, slack));
    solve(&mut e);
    let h = get(&e, "H").abs();
    let d = -get(&e, "w");
    let le = SPAN * (1.0 + 8.0 * (d / SPAN).powi(2));
    let lambda2 = (G * SPAN / h).powi(2) * SPAN / (h * le / ea);
    let modes = e.modes(4).unwrap();
    // Symmetric: z equal at mirrored nodes; antisymmetric: opposite.
    let mut symmetric = None;
    let mut antisymmetric = None;
    for (f, shape) in modes.frequencies.iter().zip(&modes.shapes) {
        let z = |i: usize| shape[3 * i + 2];
        let (mut same, mut opposite) = (0.0f64, 0.0f64);
        for i in 0..=segments {
            same = same.max((z(i) - z(segments - i)).abs());
            opposite = opposite.max((z(i) + z(segments - i)).abs());
        }
        if same < 1e-6 * opposite && symmetric.is_none() {
            symmetric = Some(*f);
        } else if opposite < 1e-6 * same && antisymmetric.is_none() {
            antisymmetric = Some(*f);
        }
    }
    let c = (h / 1.0).sqrt() / SPAN / (2.0 * PI);
    let exact = [first_symmetric_root(lambda2) * c, 2.0 * PI * c];
    (lambda2, [symmetric.unwrap(), antisymmetric.unwrap()], exact)
}

/// Five cables: drawn straight with 1000 N (EA 1e6 and 2e7 N: λ² = 4.87 and 13.99; a cable
/// drawn taut ends below λ² = 24) and drawn with unstretched lengths 10.0005, 10.0011 and
/// 10.003 m (EA 2e7 N: λ² = 37.98, 59.76, 159.2). Measured at 80 segments: errors of the
/// symmetric mode +0.016, +0.006, +0.008, +0.017, +0.049 %, of the antisymmetric −0.011,
/// +0.016, +0.006, −0.001, −0.025 % (20 → 40 → 80 segments: the symmetric errors fall 4x per
/// halving). Bounds: 0.1 % at 80 segments on both modes (2x the largest error), and the first
/// symmetric frequency below the antisymmetric one at λ² = 37.98 < 4π², above it at
/// λ² = 59.76 > 4π² (the crossing).
#[test]
fn sagging_cable_irvine_caughey() {
    for (ea, slack) in [
        (1e6, None),
        (2e7, None),
        (2e7, Some(10.0005)),
        (2e7, Some(10.0011)),
        (2e7, Some(10.003)),
    ] {
        let mut errors = Vec::new();
        for segments in [20, 40, 80] {
            let (lambda2, f, exact) = sagging_case(segments, ea, slack);
            let e = [(f[0] - exact[0]) / exact[0], (f[1] - exact[1]) / exact[1]];
            println!(
                "EA {ea:e}, l0 {slack:?}, {segments} segments: λ² = {lambda2:.3} (4π² = {:.3}); symmetric {:.5} Hz (closed form {:.5}), antisymmetric {:.5} Hz ({:.5}); errors {}",
                4.0 * PI * PI, f[0], exact[0], f[1], exact[1], pct(&e)
            );
            errors.push((lambda2, f, e));
        }
        let (lambda2, f, e) = errors[2];
        assert!(e[0].abs() <= 1e-3 && e[1].abs() <= 1e-3, "{e:?}");
        if lambda2 < 4.0 * PI * PI * 0.95 {
            assert!(f[0] < f[1]);
        } else if lambda2 > 4.0 * PI * PI * 1.05 {
            assert!(f[0] > f[1]);
        }
    }
}

/// The `natural_frequency` output (Hz): after each step, the k-th frequency of
/// `Engine::modes` at the committed state, bit for bit; f11 of the 40 x 28 rectangle within
/// 0.2 % of the closed form (measured +0.10 %); a pressure raises it (the sheet stiffens).
/// Derivatives of it are refused; a massless scene with it fails `check` naming the output.
#[test]
fn natural_frequency_output() {
    let mut s = rectangle(40, 28, MassKind::Consistent);
    s.inputs = serde_json::from_value(serde_json::json!([
        {"name": "p", "load": {"kind": "pressure", "membrane": "m"}}
    ]))
    .unwrap();
    s.outputs = serde_json::from_value(serde_json::json!([
        {"name": "f1", "probe": {"kind": "natural_frequency", "mode": 1}},
        {"name": "f3", "probe": {"kind": "natural_frequency", "mode": 3}}
    ]))
    .unwrap();
    let mut e = engine(s.clone());
    solve(&mut e);
    let (f1, f3) = (get(&e, "f1"), get(&e, "f3"));
    let modes = e.modes(3).unwrap();
    assert_eq!(f1, modes.frequencies[0]);
    assert_eq!(f3, modes.frequencies[2]);
    let exact = rectangle_exact();
    assert!(rel(f1, exact[0]) < 2e-3, "{f1} against {}", exact[0]);
    set(&mut e, "p", 50.0);
    solve(&mut e);
    let loaded = get(&e, "f1");
    println!("f1 = {f1} Hz unloaded, {loaded} Hz under 50 Pa");
    assert!(loaded > f1);
    let slot = e.outputs().iter().position(|(n, _)| n == "f1").unwrap();
    let input = velarium::engine::derivatives::Known::Input(0);
    let err = e.directional_derivative(&[input], &[1.0], &[slot]);
    assert!(err.is_err());

    s.membranes[0].density = None;
    let problems = velarium::scene::validate::validate(&s);
    assert!(
        problems.iter().any(|p| p.path == "outputs[0].probe"),
        "{problems:?}"
    );
}
