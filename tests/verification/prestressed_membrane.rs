//! GOAL: the membrane prestress (`membranes[].prestress`) is an initial stress state: a
//!       prestressed flat sheet under a small lateral pressure deflects as the linear
//!       prestressed membrane (the Poisson equation N0 ∇²w + p = 0), and warp/fill prestress
//!       acts along its warp direction; the warp/fill (orthotropic) law takes the prestress
//!       the same way (E_warp = E_fill: the isotropic field; E_warp != E_fill: the strip).
//! MESH: disc generator (isotropic case, 8 and 16 rings); 20 x 20 crossed rectangle (warp/fill).
//! BOUNDARY CONDITIONS: disc rim held in x, y, z. Rectangle: every edge held in x, y (the
//!       prestress needs them), z held on x = 0 and x = a only (the y edges are free in z).
//! PARAMETERS: SVK E = 1e8 Pa, ν = 0.3, t = 1 mm (E t = 1e5 N/m); isotropic N0 = 1000 N/m,
//!       p = 1 Pa on a disc of R = 1 m; warp/fill 500 / 2000 N/m along x, p = 1 Pa on a 1 m
//!       square. Dead pressure (per reference area along z).
//! REFERENCE: a membrane with uniform membrane force N0 carries a lateral pressure p by
//!       N0 ∇²w + p = 0 (the membrane equation, e.g. Timoshenko & Woinowsky-Krieger, *Theory of
//!       Plates and Shells*, 2nd ed. 1959, §1 and the membrane analogy; Graff, *Wave Motion in
//!       Elastic Solids*, 1975, §4.1). Clamped circle: w(r) = p (R² − r²)/(4 N0), centre
//!       w0 = 2.5e-4 m. Strip with warp force n_w along x and w independent of y:
//!       w(x) = p x (a − x)/(2 n_w), centre 2.5e-4 m (with the fill force instead it would be
//!       4 times smaller).
//!       The finite-strain solution differs by the extra membrane force from stretching,
//!       about E t (w/R)² ~ 6e-3 N/m against N0 = 1000 N/m (relative 6e-6).
//! TOLERANCES: the CST error of the Poisson problem is O(h²) (it is the discretisation, not the
//!       finite-strain term: p = 0.01 Pa gives the same relative errors). Disc: measured
//!       whole-field max error / w0 = 1.0e-3 (8 rings) and 3.2e-4 (16 rings); tolerance 1e-3 at
//!       16 rings, and the error must fall by more than 3 per halving of h. Warp strip
//!       (crossed diagonals, not nodally exact): measured 1.4e-3 (10 divisions) and 3.7e-4
//!       (20); tolerance 1e-3 at 20 and the same rate check.
//!       Zero load: a prestressed sheet whose edges hold its prestress is in equilibrium:
//!       0 Newton iterations, displacement exactly 0, PK2 stress = N0/t to round-off.
//!       Orthotropic: E_warp = E_fill = 1e8, ν_wf = 0.3, G = E/2.6, warp at 53°: the disc field
//!       equals the SVK field within 1e-11 w0 (measured 5.3e-13: the same elasticity in another
//!       frame, round-off only) and has the same closed-form error. E_warp = 2e8, E_fill = 5e7,
//!       ν_wf = 0.4, G = 1e7 with the material warp along x and along y under the 500/2000 N/m
//!       warp/fill prestress along x: the linear membrane deflection does not depend on the
//!       moduli; measured 1.44e-3 / 4.06e-4 (warp x) and 1.42e-3 / 3.57e-4 (warp y) at 10 / 20
//!       divisions; same tolerance and rate check as the SVK strip.

use crate::common;
use common::*;
use velarium::Scene;

const N0: f64 = 1000.0;
const P: f64 = 1.0;

fn disc_scene(rings: usize) -> Scene {
    disc_scene_with(rings, SVK)
}

const SVK: &str = r#"{"kind": "svk", "E": 1e8, "nu": 0.3}"#;
/// The warp/fill law with E_warp = E_fill = 1e8, ν = 0.3, G = E/(2(1 + ν)): the SVK law above.
const ORTHO_EQUAL: &str = r#"{"kind": "orthotropic", "E_warp": 1e8, "E_fill": 1e8, "nu_wf": 0.3, "G": 38461538.46153846, "warp": [0.6, 0.8, 0]}"#;

fn disc_scene_with(rings: usize, material: &str) -> Scene {
    let text = format!(
        r#"{{
  "format": 1, "name": "PrestressedDisc",
  "geometry": {{"generators": [{{"kind": "disc", "name": "disc", "center": [0, 0, 0], "radius": 1.0, "rings": {rings}}}]}},
  "membranes": [{{"name": "film", "triangles": "disc", "thickness": 1e-3,
                  "material": {material},
                  "prestress": {{"kind": "isotropic", "n": {N0}}}}}],
  "supports": [{{"nodes": "disc.rim", "fix": ["x", "y", "z"]}}],
  "inputs": [{{"name": "p", "load": {{"kind": "pressure", "membrane": "film", "follower": false}}}}],
  "outputs": [{{"name": "uz", "probe": {{"kind": "displacement", "node": "disc.center", "component": "z"}}}},
              {{"name": "iterations", "probe": {{"kind": "newton_iterations"}}}}]
}}"#
    );
    Scene::from_json(&text).unwrap()
}

/// Largest |w − p (R² − r²)/(4 N0)| over all nodes, relative to the centre value.
fn disc_error(rings: usize) -> f64 {
    disc_field(disc_scene(rings)).0
}

/// (max error / w0 against the closed form, the displacement field) of a solved disc scene.
fn disc_field(scene: Scene) -> (f64, Vec<f64>) {
    let mut e = engine(scene);
    solve(&mut e);
    set(&mut e, "p", P);
    solve(&mut e);
    let w0 = P / (4.0 * N0);
    let u = &e.state().displacement;
    let x = &e.model().reference;
    let err = (0..x.len())
        .map(|i| {
            let r2 = x[i].x * x[i].x + x[i].y * x[i].y;
            (u[3 * i + 2] - P * (1.0 - r2) / (4.0 * N0)).abs() / w0
        })
        .fold(0.0, f64::max);
    (err, u.clone())
}

#[test]
fn prestressed_disc_at_zero_load_is_in_equilibrium() {
    let mut e = engine(disc_scene(8));
    let report = solve(&mut e);
    assert_eq!(report.iterations, 0, "{}", report.log.join("\n"));
    assert!(e.state().displacement.iter().all(|&u| u == 0.0));
    // The stress is the prestress: every principal Cauchy stress is N0 / t.
    for m in e.membranes() {
        let s0 = N0 / 1e-3;
        let gap = (m.stress - nalgebra::Vector3::new(s0, s0, 0.0)).amax() / s0;
        // Round-off of the strain at rest (~1e-15) times E/s0 = 100: up to ~1e-13.
        assert!(gap < 1e-12, "PK2 {:?}", m.stress);
        // Principal values from the 2x2 eigenvalue formula: the square root of a round-off
        // discriminant (~1e-16 s0²) moves them by up to ~1e-8 s0.
        assert!(rel(m.cauchy.0, s0) < 1e-7 && rel(m.cauchy.1, s0) < 1e-7);
    }
}

#[test]
fn prestressed_disc_deflects_as_the_poisson_membrane() {
    let errors = [disc_error(8), disc_error(16)];
    println!("max error / w0 at 8, 16 rings: {errors:?}");
    assert!(errors[1] < 1e-3, "16 rings: {:e}", errors[1]);
    assert!(errors[0] > 3.0 * errors[1], "O(h²) rate: {errors:?}");
}

/// Largest |w − p x (a − x)/(2 n_w)| over all nodes of the warp strip, relative to its centre
/// value.
fn strip_error(divisions: usize) -> f64 {
    strip_error_with(divisions, SVK)
}

fn strip_error_with(divisions: usize, material: &str) -> f64 {
    let text = r#"{
  "format": 1, "name": "WarpStrip",
  "geometry": {"generators": [{"kind": "rectangle", "name": "sq", "origin": [0, 0, 0], "size": [1, 1], "divisions": [DIV, DIV]}]},
  "membranes": [{"name": "fabric", "triangles": "sq", "thickness": 1e-3,
                 "material": MATERIAL,
                 "prestress": {"kind": "warp_fill", "warp": 500, "fill": 2000, "warp_direction": [1, 0, 0]}}],
  "supports": [{"nodes": "sq.boundary", "fix": ["x", "y"]},
               {"nodes": "sq.edge_left", "fix": ["z"]}, {"nodes": "sq.edge_right", "fix": ["z"]}],
  "inputs": [{"name": "p", "load": {"kind": "pressure", "membrane": "fabric", "follower": false}}],
  "outputs": [{"name": "uz", "probe": {"kind": "displacement", "node": "sq.center", "component": "z"}}]
}"#
    .replace("DIV", &divisions.to_string())
    .replace("MATERIAL", material);
    let mut e = engine(Scene::from_json(&text).unwrap());
    let report = solve(&mut e);
    assert_eq!(report.iterations, 0);
    set(&mut e, "p", P);
    solve(&mut e);
    let (u, x) = (&e.state().displacement, &e.model().reference);
    let w0 = P / (8.0 * 500.0);
    (0..x.len())
        .map(|i| (u[3 * i + 2] - P * x[i].x * (1.0 - x[i].x) / (2.0 * 500.0)).abs() / w0)
        .fold(0.0, f64::max)
}

#[test]
fn warp_fill_prestress_acts_along_its_warp_direction() {
    let errors = [strip_error(10), strip_error(20)];
    println!("warp strip: max error / w0 at 10, 20 divisions: {errors:?}");
    assert!(errors[1] < 1e-3, "{errors:?}");
    assert!(errors[0] > 3.0 * errors[1], "O(h²) rate: {errors:?}");
}

/// Warp/fill law with E_warp = E_fill (and G = E/(2(1 + ν))), its warp at 53° to x, under the
/// isotropic prestress: the same field as the SVK law (the same elasticity, so the same
/// equivalent initial strain and the same Newton iterates; measured difference below) and the
/// same Poisson-membrane error. Zero load: 0 iterations.
#[test]
fn orthotropic_with_equal_moduli_takes_the_prestress_as_the_isotropic_law() {
    let mut e = engine(disc_scene_with(8, ORTHO_EQUAL));
    assert_eq!(solve(&mut e).iterations, 0);
    let (iso_err, iso) = disc_field(disc_scene_with(16, SVK));
    let (ortho_err, ortho) = disc_field(disc_scene_with(16, ORTHO_EQUAL));
    let w0 = P / (4.0 * N0);
    let gap = iso
        .iter()
        .zip(&ortho)
        .map(|(a, b)| (a - b).abs() / w0)
        .fold(0.0, f64::max);
    println!(
        "16 rings: isotropic error {iso_err:e}, orthotropic {ortho_err:e}, field gap / w0 {gap:e}"
    );
    assert!(gap < 1e-11, "{gap:e}");
    assert!(ortho_err < 1e-3, "{ortho_err:e}");
}

/// Warp/fill prestress on warp/fill fabric with E_warp != E_fill (4:1, ν_wf = 0.4, material warp
/// along x and, second case, along y): the linear membrane deflection depends on the membrane
/// force only, w = p x (a − x)/(2 n_w) whatever the moduli, and zero load needs 0 iterations
/// (the equivalent strain D⁻¹ S0 of the warp/fill elasticity reproduces S0). Same tolerance and
/// rate check as the isotropic strip.
#[test]
fn warp_fill_prestress_on_orthotropic_fabric_deflects_as_its_membrane() {
    for warp in ["[1, 0, 0]", "[0, 1, 0]"] {
        let m = format!(
            r#"{{"kind": "orthotropic", "E_warp": 2e8, "E_fill": 5e7, "nu_wf": 0.4, "G": 1e7, "warp": {warp}}}"#
        );
        let errors = [strip_error_with(10, &m), strip_error_with(20, &m)];
        println!("orthotropic warp {warp}: max error / w0 at 10, 20 divisions: {errors:?}");
        assert!(errors[1] < 1e-3, "{errors:?}");
        assert!(errors[0] > 3.0 * errors[1], "O(h²) rate: {errors:?}");
    }
}
