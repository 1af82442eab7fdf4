//! GOAL: the shape-following loads of issue 29 point 2 (`snow`, `self_weight`, `ponding`) put
//!       their closed-form totals into the supports, and ponding water softens a prestressed
//!       flat membrane until, at γ_w,cr = N π² (1/a² + 1/b²), its tangent stops being positive
//!       definite: below it the deflection stays bounded (and matches the linear theory),
//!       above it the step fails naming the ponding instability.
//! MESH: rectangle generator a × b = 2 m × 1 m, crossed diagonals, 16 × 8 and 32 × 16 cells.
//! BOUNDARY CONDITIONS: every boundary node held in x, y, z (ponding, self weight). Snow: the
//!       boundary held in y and z, the left edge in x, the right edge moved in x by a
//!       `displacement` input d = 0.02 m (so the current plan area is (a + d) b, not a b).
//! PARAMETERS: SVK E = 6e8 Pa, ν = 0.3, t = 1 mm; isotropic prestress N = 1000 N/m. Snow
//!       s = 500 Pa. Self weight: density 1000 kg/m³ (1 kg/m²), a cable along y = b/2 with
//!       mass_per_length 0.5 kg/m, g = 9.81 m/s² along [0, 0, −1] and along [0, 0.6, −0.8].
//!       Ponding: γ_w = 6000 N/m³ (about half the threshold) at level h = 1e-4 m; the
//!       threshold cases at 0.9 and 1.1 times the discrete threshold.
//! REFERENCE: totals by statics: snow s (a + d) b (snow per current plan area, vertical);
//!       self weight g (ρ t a b + μ a); ponding γ_w times the volume of water held, computed
//!       here from the deformed nodes (prisms over the triangles' plan areas, depth h − z
//!       linear between nodes: exactly what the load integrates) and, independently, from the
//!       linear theory of the prestressed membrane under its own water: −N ∇²δ − γ_w δ = γ_w h
//!       on the rectangle, δ = 0 on the edges (δ the downward deflection), whose double sine
//!       series is δ = Σ_{m,n odd} 16 γ_w h / (π² m n (N π² (m²/a² + n²/b²) − γ_w))
//!       sin(mπx/a) sin(nπy/b) (the membrane equation N ∇²w + p = 0 of Timoshenko &
//!       Woinowsky-Krieger, *Theory of Plates and Shells*, 2nd ed. 1959, §1, solved by Navier's
//!       double sine series as in their §28, with the water's feedback −γ_w δ added to p). The
//!       series stops being bounded where its first denominator vanishes: the ponding
//!       threshold γ_w,cr = N π² (1/a² + 1/b²) = 12337.0 N/m³ here, the smallest Rayleigh
//!       quotient N ∫|∇δ|² / ∫δ² over the rectangle. The discrete threshold is the smallest γ
//!       with K0 + γ K1 singular (K0 the tangent with no water, K1 the ponding stiffness per
//!       unit γ_w, the z rows and columns of the flat sheet), found here by a dense symmetric
//!       eigenproblem.
//! TOLERANCES: statics (snow, self weight): 1e-10 of the total (the solver's residual;
//!       measured 1.1e-12 snow, 1.3e-11 self weight). Ponding against the prism volume of its
//!       deformed nodes: 1e-8 (measured 8.4e-10 and 1.1e-9). Linear theory (centre deflection,
//!       total water): CST error O(h²): measured 1.53 % at 16 × 8 and 0.40 % at 32 × 16 (the
//!       finite-strain term E t (δ/b)² ~ 1e-2 N/m is 1e-5 of N); tolerance 0.6 % at 32 × 16 and
//!       a fall of more than 3 per halving. Threshold: the CST eigenvalue is an upper bound,
//!       measured +1.86 % at 16 × 8 and +0.46 % at 32 × 16; tolerance 0.7 % at 32 × 16, above
//!       the closed form, and a fall of more than 3 per halving. Below the threshold (0.9 of the
//!       discrete one) the centre deflection lies between the dry sheet's (the water's first
//!       load, no feedback) and the linear theory's at the same γ_w (whose threshold is lower).

use crate::common;
use common::*;
use nalgebra::{DMatrix, Vector3};
use velarium::Scene;

const A: f64 = 2.0;
const B: f64 = 1.0;
const N: f64 = 1000.0;

/// The prestressed sheet with `extra` fields spliced into the scene (inputs, outputs, ...).
fn sheet(nx: usize, supports: &str, extra: &str, membrane_extra: &str) -> Scene {
    let text = format!(
        r#"{{
  "format": 1, "name": "Sheet",
  "geometry": {{"generators": [{{"kind": "rectangle", "name": "sheet", "origin": [0, 0, 0],
                 "size": [{A}, {B}], "divisions": [{nx}, {ny}]}}]}},
  "membranes": [{{"name": "film", "triangles": "sheet", "thickness": 1e-3,
                  "material": {{"kind": "svk", "E": 6e8, "nu": 0.3}},
                  "prestress": {{"kind": "isotropic", "n": {N}}}{membrane_extra}}}],
  "supports": {supports},
  {extra}
}}"#,
        ny = nx / 2
    );
    Scene::from_json(&text).unwrap_or_else(|p| panic!("{p}"))
}

const HELD: &str = r#"[{"nodes": "sheet.boundary", "fix": ["x", "y", "z"]}]"#;

#[test]
fn snow_reaction_is_the_load_on_the_current_plan_area() {
    let supports = r#"[{"nodes": "sheet.boundary", "fix": ["y", "z"]},
                       {"nodes": "sheet.edge_left", "fix": ["x"]}]"#;
    let extra = r#""inputs": [
        {"name": "d", "load": {"kind": "displacement", "nodes": "sheet.edge_right", "component": "x"}},
        {"name": "s", "load": {"kind": "snow", "membrane": "film"}}],
      "outputs": [{"name": "Rz", "probe": {"kind": "reaction", "nodes": "sheet.boundary", "component": "z"}},
                  {"name": "w", "probe": {"kind": "displacement", "node": "sheet.center", "component": "z"}}]"#;
    let mut e = engine(sheet(16, supports, extra, ""));
    solve(&mut e);
    set(&mut e, "d", 0.02);
    solve(&mut e);
    set(&mut e, "s", 500.0);
    solve(&mut e);
    let expected = 500.0 * (A + 0.02) * B;
    let error = rel(get(&e, "Rz"), expected);
    eprintln!(
        "snow: Rz = {} N, s (a + d) b = {expected} N, error {error:.1e}, centre w = {:.4} m",
        get(&e, "Rz"),
        get(&e, "w")
    );
    assert!(get(&e, "w") < -1e-3, "the snow did not push the sheet down");
    assert!(error < 1e-10, "snow reaction error {error:e}");
}

#[test]
fn self_weight_reaction_is_the_weight() {
    let nx = 16;
    let middle: Vec<String> = (0..=nx)
        .map(|i| ((nx / 4) * (nx + 1) + i).to_string())
        .collect();
    for (direction, along) in [
        ([0.0, 0.0, -1.0], [0.0, 0.0, -1.0]),
        ([0.0, 0.6, -0.8], [0.0, 0.6, -0.8]),
    ] {
        let extra = format!(
            r#""cables": [{{"name": "c", "nodes": [{}], "EA": 1e5, "pretension": 100, "mass_per_length": 0.5}}],
      "inputs": [{{"name": "g", "load": {{"kind": "self_weight", "direction": {direction:?}}}}}],
      "outputs": [{{"name": "Ry", "probe": {{"kind": "reaction", "nodes": "sheet.boundary", "component": "y"}}}},
                  {{"name": "Rz", "probe": {{"kind": "reaction", "nodes": "sheet.boundary", "component": "z"}}}}]"#,
            middle.join(", ")
        );
        let mut e = engine(sheet(nx, HELD, &extra, r#", "density": 1000"#));
        solve(&mut e);
        set(&mut e, "g", 9.81);
        solve(&mut e);
        let weight = 9.81 * (1000.0 * 1e-3 * A * B + 0.5 * A);
        // The supports push against the weight.
        let (ry, rz) = (get(&e, "Ry"), get(&e, "Rz"));
        let error = ((ry + weight * along[1]).abs() + (rz + weight * along[2]).abs()) / weight;
        eprintln!("self weight along {direction:?}: R = ({ry}, {rz}) N, weight {weight} N, error {error:.1e}");
        assert!(error < 1e-10, "self-weight reaction error {error:e}");
    }
}

/// δ at the centre and the water volume Σ over the linear theory's series.
fn linear_theory(gamma: f64, h: f64) -> (f64, f64) {
    let (mut centre, mut volume) = (0.0, h * A * B);
    let pi = std::f64::consts::PI;
    for m in (1..600).step_by(2) {
        for n in (1..600).step_by(2) {
            let (mf, nf) = (m as f64, n as f64);
            let amp = 16.0 * gamma * h
                / (pi
                    * pi
                    * mf
                    * nf
                    * (N * pi * pi * (mf * mf / (A * A) + nf * nf / (B * B)) - gamma));
            let sign = if ((m - 1) / 2 + (n - 1) / 2) % 2 == 0 {
                1.0
            } else {
                -1.0
            };
            centre += amp * sign;
            volume += amp * 4.0 * A * B / (mf * nf * pi * pi);
        }
    }
    (centre, volume)
}

fn pond(nx: usize, gamma: f64) -> Scene {
    let extra = format!(
        r#""inputs": [{{"name": "h", "load": {{"kind": "ponding", "membrane": "film", "gamma_w": {gamma}}}}}],
      "outputs": [{{"name": "Rz", "probe": {{"kind": "reaction", "nodes": "sheet.boundary", "component": "z"}}}},
                  {{"name": "w", "probe": {{"kind": "displacement", "node": "sheet.center", "component": "z"}}}}],
      "solver": {{"artificial_prestress": 0}}"#
    );
    sheet(nx, HELD, &extra, "")
}

/// Water volume held by the deformed sheet below level `h`, from its nodes: per triangle its
/// plan area times the mean depth (all triangles are wet here).
fn water_volume(e: &velarium::Engine, h: f64) -> f64 {
    let model = e.model();
    let u = &e.state().displacement;
    let x = |i: usize| model.reference[i] + Vector3::new(u[3 * i], u[3 * i + 1], u[3 * i + 2]);
    model
        .triangles
        .iter()
        .map(|t| {
            let p = t.nodes.map(x);
            let plan = 0.5 * ((p[1] - p[0]).cross(&(p[2] - p[0]))).z;
            assert!(p.iter().all(|q| q.z < h), "a dry node");
            plan * p.iter().map(|q| h - q.z).sum::<f64>() / 3.0
        })
        .sum()
}

#[test]
fn ponding_holds_the_weight_of_its_water_and_follows_the_linear_theory() {
    let (gamma, h) = (6000.0, 1e-4);
    let (centre, volume) = linear_theory(gamma, h);
    let mut errors = Vec::new();
    for nx in [16, 32] {
        let mut e = engine(pond(nx, gamma));
        solve(&mut e);
        set(&mut e, "h", h);
        solve(&mut e);
        let rz = get(&e, "Rz");
        let held = gamma * water_volume(&e, h);
        let statics = rel(rz, held);
        let (dc, dv) = (rel(-get(&e, "w"), centre), rel(rz, gamma * volume));
        eprintln!(
            "ponding {nx}x{}: Rz = {rz} N, γ V(nodes) = {held} N ({statics:.1e}); centre δ {} vs {centre} ({dc:.2e}), Rz vs γ V(series) {} ({dv:.2e})",
            nx / 2,
            -get(&e, "w"),
            gamma * volume
        );
        assert!(
            statics < 1e-8,
            "ponding reaction against its water {statics:e}"
        );
        errors.push(dc.max(dv));
    }
    assert!(
        errors[1] < 6e-3,
        "linear theory at 32 x 16: {:e}",
        errors[1]
    );
    assert!(
        errors[0] > 3.0 * errors[1],
        "no O(h²) convergence: {errors:?}"
    );
}

fn pond_volume(nx: usize, gamma: f64) -> Scene {
    let extra = format!(
        r#""inputs": [{{"name": "V", "load": {{"kind": "water_volume", "membrane": "film", "gamma_w": {gamma}}}}}],
      "outputs": [{{"name": "Rz", "probe": {{"kind": "reaction", "nodes": "sheet.boundary", "component": "z"}}}},
                  {{"name": "h", "probe": {{"kind": "water_level", "input": "V"}}}},
                  {{"name": "w", "probe": {{"kind": "displacement", "node": "sheet.center", "component": "z"}}}}],
      "solver": {{"artificial_prestress": 0}}"#
    );
    sheet(nx, HELD, &extra, "")
}

/// GOAL: ponding with the water volume given (`water_volume`): the level is the unknown that
/// holds the volume. The same sheet and water as the level test above, the volume V_w given:
/// the linear theory's volume at the level h = 1e-4 m (the series above, independent of the
/// code), so the level found must be that h, the centre deflection the series', and the
/// reactions the water's weight γ_w V_w.
/// Above the ponding threshold (γ_w = 1.1 times the discrete one, 16 x 8) the level cannot
/// be given (the step fails, test below), but the volume can: the volume row keeps the
/// bordered system regular and the water gathers in the middle, its level below the rim
/// (h < 0, the region partly dry); checked there: converged, reactions γ_w V_w, h < 0.
/// TOLERANCES: level and centre deflection against the linear theory: the CST error O(h²)
/// (measured: level 1.52 % at 16 x 8 and 0.389 % at 32 x 16, centre 3.3e-4 and 9.6e-5):
/// 0.6 % at 32 x 16 and a fall of more than 3 per halving. Reactions against γ_w V_w: the
/// water row and the force rows converge to the solver's force tolerance (1e-9 of the force
/// scale, about 1e2 N here, against a water weight of 2 N): 5e-9 of γ_w V_w (measured 5.5e-10
/// and 6.9e-10; above the threshold printed).
#[test]
fn ponding_water_volume_finds_the_level_that_holds_it() {
    let (gamma, h) = (6000.0, 1e-4);
    let (centre, volume) = linear_theory(gamma, h);
    let mut errors = Vec::new();
    for nx in [16, 32] {
        let mut e = engine(pond_volume(nx, gamma));
        solve(&mut e);
        set(&mut e, "V", volume);
        let report = solve(&mut e);
        let (rz, level, w) = (get(&e, "Rz"), get(&e, "h"), -get(&e, "w"));
        let statics = rel(rz, gamma * volume);
        let (dh, dc) = (rel(level, h), rel(w, centre));
        eprintln!(
            "water volume {nx}x{}: V_w {volume:.6e} m3 ({} iterations): level {level:.6e} m vs {h:e} ({dh:.2e}), centre δ {w:.6e} vs {centre:.6e} ({dc:.2e}); Rz {rz} N vs γ V_w {} ({statics:.1e})",
            nx / 2,
            report.iterations,
            gamma * volume
        );
        assert!(
            statics < 5e-9,
            "reaction against the water's weight {statics:e}"
        );
        errors.push(dh.max(dc));
    }
    assert!(
        errors[1] < 6e-3,
        "linear theory at 32 x 16: {:e}",
        errors[1]
    );
    assert!(
        errors[0] > 3.0 * errors[1],
        "no O(h²) convergence: {errors:?}"
    );
    // Above the threshold: the volume is followed.
    let gamma = 1.1 * discrete_threshold(16);
    let mut e = engine(pond_volume(16, gamma));
    solve(&mut e);
    set(&mut e, "V", volume);
    let report = solve(&mut e);
    let (rz, level, w) = (get(&e, "Rz"), get(&e, "h"), -get(&e, "w"));
    let statics = rel(rz, gamma * volume);
    eprintln!(
        "water volume above the threshold (γ_w {gamma:.1}): {} iterations, level {level:.4e} m, centre δ {w:.4e} m; Rz {rz} N vs γ V_w {} ({statics:.1e})",
        report.iterations,
        gamma * volume
    );
    assert!(statics < 5e-9 && level < 0.0 && w > 0.0);
}

/// The z rows and columns of the free-free tangent at u = 0 as a dense matrix (at the flat
/// state they do not couple to the in-plane ones: membrane and ponding terms alike).
fn dense_tangent(model: &velarium::model::Model, level: f64) -> DMatrix<f64> {
    use velarium::solver::assemble::{assemble, Pattern, NONE};
    let pattern = Pattern::try_new(model).unwrap();
    let u = vec![0.0; model.unknown_count()];
    let mut r = vec![0.0; model.dof_count()];
    let mut k = vec![0.0; pattern.row_idx.len()];
    assemble(model, &pattern, &u, &[level], &mut r, Some(&mut k));
    let n = pattern.n;
    let mut full = DMatrix::zeros(n, n);
    for j in 0..n {
        let column = pattern.col_ptr[j]..pattern.col_ptr[j + 1];
        for (&i, &v) in pattern.row_idx[column.clone()].iter().zip(&k[column]) {
            full[(i, j)] = v;
            full[(j, i)] = v;
        }
    }
    let z: Vec<usize> = (2..model.dof_count())
        .step_by(3)
        .map(|d| pattern.eq[d])
        .filter(|&q| q != NONE)
        .collect();
    let x: Vec<usize> = (0..n).filter(|q| !z.contains(q)).collect();
    let coupling = x.iter().flat_map(|&i| z.iter().map(move |&j| (i, j)));
    assert!(
        coupling
            .map(|(i, j)| full[(i, j)].abs())
            .fold(0.0, f64::max)
            < 1e-9 * full.amax()
    );
    DMatrix::from_fn(z.len(), z.len(), |i, j| full[(z[i], z[j])])
}

/// The smallest γ_w at which the flat sheet's tangent is singular: K(γ) = K0 + γ K1 with K0
/// dry and K1 the ponding stiffness per unit γ_w (water just above the sheet).
fn discrete_threshold(nx: usize) -> f64 {
    let model = velarium::model::Model::build(&pond(nx, 1.0));
    let k0 = dense_tangent(&model, -1.0);
    let k1 = dense_tangent(&model, 1e-12) - &k0;
    let l = k0
        .clone()
        .cholesky()
        .expect("the dry tangent is positive definite")
        .l();
    let li = l.try_inverse().unwrap();
    let c = &li * (-k1) * li.transpose();
    let c = (&c + c.transpose()) * 0.5;
    let largest = c.symmetric_eigenvalues().max();
    1.0 / largest
}

#[test]
fn ponding_threshold_is_where_the_tangent_stops_being_positive_definite() {
    let pi = std::f64::consts::PI;
    let closed = N * pi * pi * (1.0 / (A * A) + 1.0 / (B * B));
    let coarse = discrete_threshold(16);
    let fine = discrete_threshold(32);
    let (ec, ef) = ((coarse - closed) / closed, (fine - closed) / closed);
    eprintln!("ponding threshold: closed form {closed:.1} N/m³, 16x8 {coarse:.1} ({ec:+.2e}), 32x16 {fine:.1} ({ef:+.2e})");
    assert!(ef > 0.0 && ef < 7e-3, "threshold at 32 x 16 off by {ef:e}");
    assert!(
        ec > 3.0 * ef,
        "no O(h²) convergence of the threshold: {ec:e}, {ef:e}"
    );
    // The library's own test of the tangent agrees with the eigenvalue on either side, and the
    // solver: bounded below, a failure naming the instability above.
    for (factor, stable) in [(0.9, true), (1.1, false)] {
        let gamma = factor * coarse;
        let model = velarium::model::Model::build(&pond(16, gamma));
        let u = vec![0.0; model.unknown_count()];
        assert_eq!(
            velarium::solver::stability::positive_definite(&model, &u, &[1e-4]),
            Some(stable),
            "γ = {factor} γ_cr"
        );
        let mut e = engine(pond(16, gamma));
        solve(&mut e);
        set(&mut e, "h", 1e-4);
        let report = e.solve();
        eprintln!(
            "γ = {factor} γ_cr: converged {}, w = {}, {}",
            report.converged(),
            get(&e, "w"),
            report.message
        );
        assert_eq!(report.converged(), stable, "{}", report.message);
        if stable {
            let (dry, _) = linear_theory(1e-9, 1e-4 * gamma / 1e-9);
            let (series, _) = linear_theory(gamma, 1e-4);
            let w = -get(&e, "w");
            eprintln!(
                "  centre δ {w:.3e} between {dry:.3e} (no feedback) and {series:.3e} (series)"
            );
            assert!(w > dry && w < series, "{dry} < {w} < {series}");
        } else {
            assert!(
                report.message.contains("ponding instability"),
                "{}",
                report.message
            );
            assert!(
                report.message.contains("not positive definite"),
                "{}",
                report.message
            );
        }
    }
}

/// The first root above N π²(1/a² + 1/b²) of the secular equation of the flat sheet with its
/// water volume held (the level eliminated: −N ∇²δ − γ_w (δ − δ̄) = 0, δ̄ the mean over the
/// wet rectangle): 1 + γ Σ_{m,n odd} 64 / (π⁴ m² n² (λ_mn − γ)) = 0, λ_mn = N π² (m²/a² +
/// n²/b²) (the modes with a non-zero mean; 64/(π⁴ m² n²) is the square of a mode's mean over
/// its mean square). Bisection between λ_11 and the next odd-odd λ.
fn volume_held_symmetric_root() -> f64 {
    let pi = std::f64::consts::PI;
    let lambda = |m: f64, n: f64| N * pi * pi * (m * m / (A * A) + n * n / (B * B));
    let f = |g: f64| {
        let mut sum = 0.0;
        for m in (1..400).step_by(2) {
            for n in (1..400).step_by(2) {
                let (mf, nf) = (m as f64, n as f64);
                sum += 64.0 / (pi.powi(4) * mf * mf * nf * nf * (lambda(mf, nf) - g));
            }
        }
        1.0 + g * sum
    };
    let (mut lo, mut hi) = (
        lambda(1.0, 1.0) * (1.0 + 1e-9),
        lambda(3.0, 1.0) * (1.0 - 1e-9),
    );
    assert!(f(lo) < 0.0 && f(hi) > 0.0);
    for _ in 0..100 {
        let mid = 0.5 * (lo + hi);
        if f(mid) < 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// The smallest γ_w at which the flat, just-wet sheet's tangent with the water volume held is
/// singular: K0 + γ (K1 + m mᵀ/A), the level eliminated from the bordered system (K1 the
/// ponding stiffness per unit γ_w, m_i = ∫ N_i dA over the free nodes, a third of each
/// triangle's area, A = a b the wet area the level spreads over).
fn discrete_volume_threshold(nx: usize) -> f64 {
    use velarium::solver::assemble::{Pattern, NONE};
    let model = velarium::model::Model::build(&pond(nx, 1.0));
    let k0 = dense_tangent(&model, -1.0);
    let k1 = dense_tangent(&model, 1e-12) - &k0;
    // m over the free z equations, in dense_tangent's order.
    let pattern = Pattern::try_new(&model).unwrap();
    let mut m_node = vec![0.0; model.reference.len()];
    for t in &model.triangles {
        let x = t.nodes.map(|i| model.reference[i]);
        let area = 0.5 * (x[1] - x[0]).cross(&(x[2] - x[0])).norm();
        for &i in &t.nodes {
            m_node[i] += area / 3.0;
        }
    }
    let m: Vec<f64> = (0..model.reference.len())
        .filter(|&i| pattern.eq[3 * i + 2] != NONE)
        .map(|i| m_node[i])
        .collect();
    let m = nalgebra::DVector::from_vec(m);
    assert_eq!(m.len(), k0.nrows());
    let k1v = k1 + &m * m.transpose() / (A * B);
    let l = k0
        .clone()
        .cholesky()
        .expect("the dry tangent is positive definite")
        .l();
    let li = l.try_inverse().unwrap();
    let c = &li * (-k1v) * li.transpose();
    let c = (&c + c.transpose()) * 0.5;
    1.0 / c.symmetric_eigenvalues().max()
}

/// GOAL: with the water given as a volume (`water_volume`) the flat prestressed sheet stays
///       stable past the level-controlled threshold N π² (1/a² + 1/b²), up to the first mode
///       that moves no water: γ_V,cr = min(N π² (4/a² + 1/b²), N π² (1/a² + 4/b²), the first
///       root of the symmetric modes' secular equation); and `stability::water_volume_stable`
///       says which side of it a state is on.
/// MESH, BOUNDARY CONDITIONS, PARAMETERS: the ponding sheet above (2 m × 1 m, N = 1000 N/m,
///       edges held), 16 × 8 and 32 × 16 cells.
/// REFERENCE: the linear theory with the volume held: the level follows the mean sag, so the
///       water's softening is −γ_w (δ − δ̄) (δ̄ the mean over the wet area), the Rayleigh
///       quotient N ∫|∇δ|² / ∫(δ² − δ̄² ) over δ = 0 on the edges. Modes with a zero mean
///       (m or n even) keep their λ_mn = N π² (m²/a² + n²/b²); the odd-odd ones couple through
///       the mean into the secular equation of `volume_held_symmetric_root` (its root 2.517 N π²
///       here, computed in the test from the series). Here γ_V,cr = λ_21 = N π² (4/a² + 1/b²)
///       = 19739.2 N/m³, 1.6 times the level-controlled 12337.0: the water runs from one half
///       of the sheet to the other. The discrete threshold: the
///       smallest γ with K0 + γ (K1 + m mᵀ/A) singular, m and A computed here from the mesh.
/// TOLERANCES: CST upper bound, O(h²): measured +3.46 % at 16 × 8 and +0.86 % at 32 × 16 (the
///       λ_21 mode varies twice as fast along a as λ_11: about twice the level threshold's error);
///       tolerance 1 % at 32 × 16, above the closed form, and a fall of
///       more than 3 per halving. `water_volume_stable` at the flat, just-wet sheet (level
///       1e-4 m above it) against the dense eigenvalue: stable at 0.99 and unstable at 1.01 of
///       the discrete γ_V,cr (both sides of an eigenvalue found to round-off), and stable at
///       1.1 of the level-controlled discrete threshold, where `positive_definite` (the level
///       held) is not. Measured (asserted as measured, no closed form): the engine, given the
///       series' volume at h = 1e-4 m at 0.68, 0.9 and 1.1 of the discrete γ_V,cr, converges to
///       states with the water gathered in the middle (level below the rim), which the check
///       finds stable: the smaller wet area has a higher threshold of its own.
#[test]
fn water_volume_threshold_is_the_first_mode_that_moves_no_water() {
    let pi = std::f64::consts::PI;
    let antisymmetric = N * pi * pi * (4.0 / (A * A) + 1.0 / (B * B));
    let root = volume_held_symmetric_root();
    let closed = antisymmetric
        .min(N * pi * pi * (1.0 / (A * A) + 4.0 / (B * B)))
        .min(root);
    eprintln!(
        "volume held: λ_21 {antisymmetric:.1}, symmetric root {root:.1} ({:.4} N π²): γ_V,cr {closed:.1} N/m³",
        root / (N * pi * pi)
    );
    assert_eq!(closed, antisymmetric);
    let coarse = discrete_volume_threshold(16);
    let fine = discrete_volume_threshold(32);
    let (ec, ef) = ((coarse - closed) / closed, (fine - closed) / closed);
    eprintln!("volume-held threshold: 16x8 {coarse:.1} ({ec:+.2e}), 32x16 {fine:.1} ({ef:+.2e})");
    assert!(ef > 0.0 && ef < 1e-2, "threshold at 32 x 16 off by {ef:e}");
    assert!(ec > 3.0 * ef, "no O(h²) convergence: {ec:e}, {ef:e}");
    // The library's check at the flat sheet with the level 1e-4 m above it.
    let check = |gamma: f64| {
        let model = velarium::model::Model::build(&pond_volume(16, gamma));
        let mut u = vec![0.0; model.unknown_count()];
        let unknown = model
            .loads
            .iter()
            .find_map(|l| match l {
                velarium::model::LoadModel::Water { unknown, .. } => Some(*unknown),
                _ => None,
            })
            .unwrap();
        u[model.volume_unknown(unknown)] = 1e-4;
        (
            velarium::solver::stability::water_volume_stable(&model, &u, &[0.0]),
            velarium::solver::stability::positive_definite(&model, &u, &[0.0]),
        )
    };
    assert_eq!(check(0.99 * coarse).0, Some(true));
    assert_eq!(check(1.01 * coarse).0, Some(false));
    let level_held = discrete_threshold(16);
    assert_eq!(check(1.1 * level_held), (Some(true), Some(false)));
    // What the engine does with a volume given (the series' volume at h = 1e-4 m): the states
    // it returns (after its own stability check) and the check at them.
    let (_, volume) = linear_theory(6000.0, 1e-4);
    for gamma in [1.1 * level_held, 0.9 * coarse, 1.1 * coarse] {
        let mut e = engine(pond_volume(16, gamma));
        solve(&mut e);
        set(&mut e, "V", volume);
        let report = e.solve();
        let stable = velarium::solver::stability::water_volume_stable(
            e.model(),
            &e.state().displacement,
            &e.state().inputs,
        );
        eprintln!(
            "γ_w {gamma:.1} ({:.3} γ_V,cr discrete): converged {} in {} iterations, level {:.4e} m, centre δ {:.4e} m; water_volume_stable {stable:?}",
            gamma / coarse,
            report.converged(),
            report.iterations,
            get(&e, "h"),
            -get(&e, "w")
        );
        assert!(
            report.converged() && stable == Some(true),
            "{}",
            report.message
        );
    }
}
