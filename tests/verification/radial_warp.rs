//! GOAL: a warp/fill fabric whose warp runs radially from an axis (`warp_axis`, the tent's
//!       fabric) has, on a flat annulus pulled in at its inner rim, the radial displacement
//!       of a cylindrically orthotropic plate: each triangle's warp follows its own radial
//!       direction.
//! MESH: annulus generator, inner radius a = 0.2 m, outer b = 1 m, `rings` radial divisions,
//!       96 sectors.
//! BOUNDARY CONDITIONS: outer rim fixed; inner rim moved radially by δ = −2e-7 m (a
//!       `polar_displacement` input about z); every node fixed in z; wrinkling off (the hoop
//!       direction is compressed).
//! PARAMETERS: E_warp (radial) = 2e8 Pa, E_fill (hoop) = 5e7 Pa, nu_wf = 0.3, G = 3e7 Pa,
//!       t = 1 mm; and the swapped moduli (warp hoop-stiff in effect).
//! REFERENCE: plane-stress cylindrical orthotropy (Lekhnitskii): with σ_r = Q11 u' + Q12 u/r,
//!       σ_θ = Q12 u' + Q22 u/r, equilibrium (r σ_r)' = σ_θ gives r² u'' + r u' − k² u = 0,
//!       k² = Q22/Q11 = E_fill/E_warp, so u(r) = A r^k + B r^−k with u(a) = δ, u(b) = 0.
//!       Strains of 1e-6: the SVK membrane is linear to about 1e-6 there.
//! TOLERANCE: at every node at 24 rings, 1e-3 of |δ| with the stiff warp radial and 7e-3
//!       with the stiff fill around (the CST's O(h²) error, about twice the measured 4.8e-4
//!       and 3.3e-3: the second profile, k = 2, is the steeper), and the error must fall by
//!       more than 3 from 12 to 24 rings (measured 4.1 and 3.7); a warp along x instead (the
//!       same moduli, no `warp_axis`) must miss the closed form by more than 5 % (measured
//!       15 % and 30 %).

use crate::common;
use common::*;

const A: f64 = 0.2;
const B: f64 = 1.0;
const DELTA: f64 = -2e-7;

fn closed_form(r: f64, k: f64) -> f64 {
    let coef = DELTA / (A.powf(k) - B.powf(2.0 * k) * A.powf(-k));
    coef * (r.powf(k) - B.powf(2.0 * k) * r.powf(-k))
}

/// Largest |u_r − closed form| / |δ| over the annulus' nodes.
fn error(rings: usize, e_warp: f64, e_fill: f64, radial: bool) -> f64 {
    let axis = if radial {
        r#", "warp_axis": {"center": [0, 0, 0], "axis": [0, 0, 1]}"#
    } else {
        ""
    };
    let text = format!(
        r#"{{"format": 1, "name": "RadialWarp",
        "geometry": {{"generators": [{{"kind": "annulus", "name": "ann", "center": [0, 0, 0],
            "inner_radius": {A}, "outer_radius": {B}, "rings": {rings}, "sectors": 96}}]}},
        "membranes": [{{"name": "fabric", "triangles": "ann", "thickness": 1e-3, "wrinkling": false,
            "material": {{"kind": "orthotropic", "E_warp": {e_warp}, "E_fill": {e_fill}, "nu_wf": 0.3,
                          "G": 3e7, "warp": [1, 0, 0]{axis}}}}}],
        "supports": [{{"nodes": "ann.outer_rim", "fix": ["x", "y", "z"]}}, {{"nodes": "ann.all", "fix": ["z"]}}],
        "inputs": [{{"name": "d", "load": {{"kind": "polar_displacement", "nodes": "ann.inner_rim",
            "center": [0, 0, 0], "axis": "z", "component": "radial"}}, "start": 0}}],
        "outputs": [],
        "experiment": {{"start_time": 0, "stop_time": 1, "step_size": 0.1}}}}"#
    );
    let mut e = engine(velarium::Scene::from_json(&text).unwrap());
    solve(&mut e);
    set(&mut e, "d", DELTA);
    solve(&mut e);
    let k = (e_fill / e_warp).sqrt();
    let model = e.model();
    let u = &e.state().displacement;
    let mut worst = 0.0f64;
    for (i, x0) in model.reference.iter().enumerate() {
        let r = x0.norm();
        let ur = (model.position(u, i) - x0).dot(&(x0 / r));
        worst = worst.max((ur - closed_form(r, k)).abs() / DELTA.abs());
    }
    worst
}

#[test]
fn radial_warp_gives_the_cylindrically_orthotropic_annulus() {
    for (e_warp, e_fill, tolerance) in [(2e8, 5e7, 1e-3), (5e7, 2e8, 7e-3)] {
        let coarse = error(12, e_warp, e_fill, true);
        let fine = error(24, e_warp, e_fill, true);
        let along_x = error(24, e_warp, e_fill, false);
        println!(
            "E_warp {e_warp:e}, E_fill {e_fill:e}: error {coarse:.2e} at 12 rings, {fine:.2e} at 24; warp along x {along_x:.2e}"
        );
        assert!(fine < tolerance, "24 rings: {fine:e}");
        assert!(coarse > 3.0 * fine, "O(h²): {coarse:e} then {fine:e}");
        assert!(
            along_x > 0.05,
            "a warp along x must not give it: {along_x:e}"
        );
    }
}
