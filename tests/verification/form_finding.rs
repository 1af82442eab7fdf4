//! GOAL: form finding (Updated Reference Strategy, src/formfind.rs) finds the closed-form
//!       equilibrium shapes of a prescribed prestress, reports a prestress with no equilibrium
//!       as a failure with a clear message, and hands the analysis a scene that starts in
//!       equilibrium.
//! MESH / BOUNDARY CONDITIONS: per test below (cylinder between two held rings; a square with
//!       its boundary placed on the Scherk surface and held; a flat square with held corners
//!       and four edge cables, every z held; a 7 x 7 cable net with its boundary on a hypar;
//!       the shipped FourPointSail).
//! REFERENCES:
//!   - Catenoid (a minimal surface, Euler 1744): between coaxial rings of radius R a distance H
//!     apart, r(z) = a cosh((z − H/2)/a) with R = a cosh(H/(2a)) (the larger root a: the
//!     stable catenoid); no solution for H/R > 1.3255 (the Goldschmidt limit, e.g. Isenberg,
//!     *The Science of Soap Films and Soap Bubbles*, 1978, §4.6). H/R = 1: neck a = 0.848338.
//!   - Scherk's first surface z = ln(cos(a y)/cos(a x))/a (Scherk 1835), a minimal surface;
//!     here a = 1 on |x|, |y| <= 1.
//!   - The hyperbolic paraboloid z = c x y is doubly ruled: the lines x = const and y = const
//!     on it are straight (e.g. Otto, *Tensile Structures*, 1967; any differential geometry
//!     text), and a straight cable of constant force exerts no force on its inner nodes.
//!   - A cable of force T bounding a membrane of isotropic prestress n is a circular arc of
//!     radius R = T/n (equilibrium of the cable under the normal edge load n; e.g. Bletzinger &
//!     Ramm 1999, Linhard et al. 2009).
//!
//! TOLERANCES: the shapes carry the discretisation error of linear triangles, O(h²):
//!   catenoid neck measured 8.5e-4 (48 x 16) and 2.0e-4 (96 x 32) relative: tolerance 5e-3 (the
//!   issue's target 0.5 %) at 48 x 16 and a > 3x fall per halving of h. Scherk: largest
//!   |z − f(x, y)| over the nodes, z compared with the surface at the node's own current
//!   (x, y). With x, y held at every node (graph form) it falls as h²: 4.1e-4, 1.1e-4, 2.8e-5
//!   at 12, 24, 48 cells a side, tolerance 3.5e-5 at 48 and a fall > 3.5 per halving. With
//!   the mesh free in plane it stays at 2.3e-3 to 2.9e-3 from 6 to 48 cells (the normal-only
//!   equilibrium of the mesh control on a crept mesh; docs/mechanics.md §10), bound 5e-3.
//!   Edge-cable arcs (measured 1.3e-4): the found forces balance exactly and the edge
//!   load of the membrane on each cable is n per unit length, so the polygon is inscribed in
//!   the circle up to the form-finding tolerance (stress deviation 1e-4): radius of the
//!   least-squares circle through each cable's nodes within 1e-3 of T/n.
//!   Cable nets: a net along the rulings of a hyperbolic paraboloid is straight, so the grid on
//!   the surface is the equilibrium for any cable forces: node distance 1e-9 of the span at
//!   form-finding tolerance 1e-9 (measured 7.1e-11); a single cable between two held ends is
//!   found straight to round-off. FourPointSail: at most 20 URS iterations (the issue's target;
//!   measured 15), the same nodes as without the cable relief within the stopping tolerance
//!   1e-6 of the span (2.9e-7), edge-cable circumradius T/n = 10 m (median 8.0e-4, all 4.0e-3;
//!   bounds 2e-3, 1e-2).
//!   The analysis of a found scene at zero load: 0 or 1 Newton iterations and the largest
//!   displacement below 1e-9 of the span (the issue's target; measured 0 iterations, 0
//!   displacement for the catenoid and the FourPointSail).
//!   Acceptance (issue 27): every found state above is accepted by `formfind::MAX_DEVIATION`
//!   (1 %; measured deviations 8.2e-5 and 2.2e-5 catenoid, 3.4e-6 arcs, 7.8e-3 and 6.1e-3
//!   Scherk free in plane, at most 2.3e-5 as a graph, 3.9e-11 and 0 cable nets, 4.1e-3
//!   FourPointSail) and `MIN_ANGLE_DEGREES` (5°). A cone with a constant radial warp and hoop
//!   fill prestress has no equilibrium shape: a membrane of revolution without load balances
//!   along its meridian only if d(r n_s)/ds = n_θ dr/ds, which constant forces meet only at
//!   n_s = n_θ (membrane theory of shells of revolution, e.g. Timoshenko & Woinowsky-Krieger,
//!   *Theory of Plates and Shells*, 1959, ch. 14). Its form finding fails naming the deviation
//!   (measured 27.9 % against the 1 % bound) and the degenerate first ring (smallest angle
//!   10.8° to 2.4°, bound 5°); the same cone with warp = fill is found (deviation 6.6e-3,
//!   smallest angle 10.4°).

use crate::common;
use common::*;
use std::f64::consts::PI;
use velarium::formfind;
use velarium::Scene;

/// A cylinder of radius 1 between z = 0 and z = h, `nt` nodes per ring, `nz` rows of cells,
/// diagonals alternating in a checkerboard (mirror-symmetric), both rings held.
fn catenoid_scene(h: f64, nt: usize, nz: usize) -> Scene {
    let mut nodes = Vec::new();
    for j in 0..=nz {
        for i in 0..nt {
            let th = 2.0 * PI * i as f64 / nt as f64;
            nodes.push([th.cos(), th.sin(), h * j as f64 / nz as f64]);
        }
    }
    let id = |i: usize, j: usize| j * nt + i % nt;
    let mut tris = Vec::new();
    for j in 0..nz {
        for i in 0..nt {
            let (a, b, c, d) = (id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1));
            if (i + j) % 2 == 0 {
                tris.push([a, b, c]);
                tris.push([a, c, d]);
            } else {
                tris.push([a, b, d]);
                tris.push([b, c, d]);
            }
        }
    }
    let ring = |j: usize| (j * nt..(j + 1) * nt).collect::<Vec<_>>();
    let json = serde_json::json!({
        "format": 1, "name": "Catenoid",
        "geometry": {"nodes": nodes, "triangles": tris,
            "node_sets": {"bottom": ring(0), "top": ring(nz), "neck": ring(nz / 2)},
            "triangle_sets": {"film": (0..tris.len()).collect::<Vec<_>>()}},
        "membranes": [{"name": "film", "triangles": "film", "thickness": 1e-3,
            "material": {"kind": "svk", "E": 1e6, "nu": 0.3},
            "prestress": {"kind": "isotropic", "n": 1.0}}],
        "supports": [{"nodes": "bottom", "fix": ["x", "y", "z"]},
                     {"nodes": "top", "fix": ["x", "y", "z"]}],
        "form_finding": {}
    });
    Scene::from_json(&json.to_string()).unwrap()
}

/// The neck radius a of the stable catenoid through rings of radius 1 a distance h apart.
fn neck_exact(h: f64) -> f64 {
    // a cosh(h/(2a)) = 1, larger root: bisection on [a*, 1] where a* minimises a cosh(h/2a).
    let g = |a: f64| a * (h / (2.0 * a)).cosh() - 1.0;
    let (mut lo, mut hi) = (0.5, 1.0);
    for _ in 0..200 {
        let m = 0.5 * (lo + hi);
        if g(m) > 0.0 {
            hi = m
        } else {
            lo = m
        }
    }
    0.5 * (lo + hi)
}

fn found(scene: &Scene) -> (Scene, formfind::Report) {
    let report = formfind::run(scene).unwrap_or_else(|e| panic!("{e}"));
    let s = report
        .scene
        .clone()
        .unwrap_or_else(|| panic!("not converged: {}", report.message));
    println!(
        "found: {} iterations, shape move {:.2e} at the tolerance, finishing step {:.2e}, deviation {:.2e}, smallest angle {:.2}° ({:.2}° at the start)",
        report.iterations,
        report.shape_move,
        report.last_move,
        report.deviation,
        report.min_angle.0,
        report.min_angle.1
    );
    (s, report)
}

fn neck_error(nt: usize, nz: usize) -> (f64, usize) {
    let (s, report) = found(&catenoid_scene(1.0, nt, nz));
    let neck = &s.geometry.node_sets["neck"];
    let x = &s.geometry.nodes;
    let r = neck.iter().map(|&i| x[i][0].hypot(x[i][1])).sum::<f64>() / neck.len() as f64;
    (rel(r, neck_exact(1.0)), report.iterations)
}

#[test]
fn catenoid_neck_matches_the_closed_form() {
    let (coarse, it0) = neck_error(48, 16);
    let (fine, it1) = neck_error(96, 32);
    println!("catenoid H/R = 1: neck error {coarse:.2e} (48x16, {it0} it), {fine:.2e} (96x32, {it1} it); exact a = {}", neck_exact(1.0));
    assert!(coarse < 5e-3, "48 x 16: {coarse:e}");
    assert!(coarse > 3.0 * fine, "O(h²): {coarse:e} -> {fine:e}");
}

#[test]
fn catenoid_beyond_the_critical_ratio_fails_with_a_clear_message() {
    let report = formfind::run(&catenoid_scene(1.4, 48, 16)).unwrap();
    println!("H/R = 1.4: {}", report.message);
    assert!(!report.converged());
    assert!(
        report
            .message
            .contains("no equilibrium between these supports"),
        "{}",
        report.message
    );
    // The engine refuses such a scene with the same message (an FMU's instantiation fails).
    let err = match velarium::Engine::try_new(catenoid_scene(1.4, 48, 16)) {
        Err(e) => e.to_string(),
        Ok(_) => panic!("a scene with no equilibrium shape built an engine"),
    };
    assert!(err.contains("form finding failed"), "{err}");
}

#[test]
fn found_catenoid_starts_the_analysis_in_equilibrium() {
    let scene = catenoid_scene(1.0, 48, 16);
    // The engine form-finds a scene that asks for it, then solves at zero load.
    let mut e = engine(scene);
    let report = solve(&mut e);
    let span = e.model().length_scale;
    let worst = e
        .state()
        .displacement
        .iter()
        .fold(0.0f64, |m, u| m.max(u.abs()));
    println!(
        "found catenoid at zero load: {} iterations, max |u| / span = {:e}",
        report.iterations,
        worst / span
    );
    assert!(report.iterations <= 1);
    assert!(worst < 1e-9 * span, "{:e}", worst / span);
}

fn scherk(x: f64, y: f64) -> f64 {
    (y.cos() / x.cos()).ln()
}

/// Largest |z − f(x, y)| over the nodes of the Scherk patch with `n` x `n` cells.
fn scherk_error(n: usize) -> (f64, usize) {
    scherk_error_with(n, false)
}

/// As [`scherk_error`]; `graph`: every node is held in x and y (the surface found as a graph
/// over the start mesh, z free at interior nodes).
fn scherk_error_with(n: usize, graph: bool) -> (f64, usize) {
    let inplane = if graph {
        r#", {"nodes": "sq.all", "fix": ["x", "y"]}"#
    } else {
        ""
    };
    let text = format!(
        r#"{{"format": 1, "name": "Scherk",
  "geometry": {{"generators": [{{"kind": "rectangle", "name": "sq", "origin": [-1, -1, 0], "size": [2, 2], "divisions": [{n}, {n}]}}]}},
  "membranes": [{{"name": "film", "triangles": "sq", "thickness": 1e-3,
                  "material": {{"kind": "svk", "E": 1e6, "nu": 0.3}},
                  "prestress": {{"kind": "isotropic", "n": 1.0}}}}],
  "supports": [{{"nodes": "sq.boundary", "fix": ["x", "y", "z"]}}{inplane}],
  "form_finding": {{}}}}"#
    );
    let mut scene = Scene::from_json(&text).unwrap();
    // Place every boundary node on the surface: z = f(x, y) at its (x, y).
    let mesh = velarium::scene::generate::resolve(&scene.geometry);
    let place = mesh.node_sets["sq.boundary"]
        .iter()
        .map(|&i| {
            let [x, y, _] = mesh.nodes[i];
            velarium::scene::Placement {
                node: Some(velarium::scene::OneNode::Id(i)),
                position: Some([x, y, scherk(x, y)]),
                nodes: None,
                translate: None,
                rotate: None,
            }
        })
        .collect();
    scene.form_finding.as_mut().unwrap().place = place;
    let (s, report) = found(&scene);
    let worst = s
        .geometry
        .nodes
        .iter()
        .map(|p| (p[2] - scherk(p[0], p[1])).abs())
        .fold(0.0, f64::max);
    (worst, report.iterations)
}

/// The Scherk patch from a flat start with the mesh free in plane: the mesh creeps within the
/// surface, the mesh control holds it, and the shape error does NOT fall with h (measured
/// 1.9e-3, 2.3e-3, 2.6e-3, 2.6e-3 at 6, 12, 24, 48 cells a side; with homotopy 0 and
/// tolerance 1e-9: 2.2e-3, 2.9e-3, 2.9e-3, 2.9e-3, so it is not the stopping test; the plain
/// URS fixed point at 12 x 12, reached after ~1100 iterations, has 8.0e-4): the normal-only
/// equilibrium on a crept, irregular mesh is biased at the 0.2 % level, while the same
/// equations with x, y held converge at O(h²) (the test above). Tolerance 5e-3 at both
/// meshes (2x measured); docs/mechanics.md §10 says why and how users avoid it.
#[test]
fn scherk_surface_is_found_within_its_known_bias() {
    let (coarse, it0) = scherk_error(12);
    let (fine, it1) = scherk_error(24);
    println!("Scherk: max |z − f| = {coarse:.3e} (12x12, {it0} it), {fine:.3e} (24x24, {it1} it)");
    assert!(coarse < 5e-3 && fine < 5e-3, "{coarse:e} {fine:e}");
}

/// The Scherk patch with every node held in x and y (z free inside): the found surface is the
/// Galerkin finite-element solution of the minimal-surface equation in graph form (the z-force
/// of an isotropic membrane force n is n ∂A/∂z_i, the area functional's derivative), which
/// converges at O(h²). Measured max |z − f| 1.37e-3 (6 x 6), 4.14e-4 (12 x 12), 1.09e-4
/// (24 x 24), 2.76e-5 (48 x 48): ratios 3.3, 3.8, 3.9 per halving of h. Tolerances 3.5e-5 at
/// 48 x 48 (1.27x measured) and a fall of more than 3.5 per halving from 12 to 48.
#[test]
fn scherk_surface_as_a_graph_converges_at_second_order() {
    let e: Vec<(f64, usize)> = [12, 24, 48]
        .iter()
        .map(|&n| scherk_error_with(n, true))
        .collect();
    println!("Scherk (x, y held): max |z − f| at 12, 24, 48: {e:?}");
    assert!(e[2].0 < 3.5e-5, "{e:?}");
    assert!(
        e[0].0 > 3.5 * e[1].0 && e[1].0 > 3.5 * e[2].0,
        "O(h²): {e:?}"
    );
}

/// The shipped FourPointSail: form finding in at most 20 URS iterations (the issue's target;
/// measured 15; time printed, target 2 s), its analysis at zero load (0 or 1 iterations,
/// displacement below 1e-9 of the span), and the wind ramp to both input limits converging.
#[test]
fn four_point_sail_is_found_and_carries_wind() {
    let scene = read_scene(&shipped("FourPointSail"));
    let report = formfind::run(&scene).unwrap();
    println!(
        "FourPointSail: {} triangles, form finding {} iterations, {:.3} s, stress deviation {:.2e}",
        velarium::scene::generate::resolve(&scene.geometry)
            .triangles
            .len(),
        report.iterations,
        report.seconds,
        report.deviation
    );
    assert!(report.converged(), "{}", report.message);
    assert!(report.iterations <= 20, "{} iterations", report.iterations);
    let mut e = engine(scene);
    let step = solve(&mut e);
    let span = e.model().length_scale;
    let worst = e
        .state()
        .displacement
        .iter()
        .fold(0.0f64, |m, u| m.max(u.abs()));
    println!(
        "zero load: {} iterations, max |u| / span = {:e}",
        step.iterations,
        worst / span
    );
    assert!(step.iterations <= 1 && worst < 1e-9 * span);
    for wind in [100.0, 300.0] {
        set(&mut e, "wind", wind);
        let r = solve(&mut e);
        println!(
            "wind {wind} Pa: {} iterations, centre uz {:.4} m",
            r.iterations,
            get(&e, "center_uz")
        );
    }
    assert!(
        get(&e, "center_uz") > 0.0,
        "positive pressure lifts the centre"
    );
    set(&mut e, "wind", -300.0);
    solve(&mut e);
    assert!(get(&e, "center_uz") < 0.0);
}

/// The FourPointSail's edge cables found with and without the mesh control's relief of the
/// membrane stiffness across the cables (`formfind::ACROSS_CABLE_KEPT`): the relief changes
/// the matrix, not the residual, so both reach the same fixed point; it only takes fewer
/// iterations (measured 29 without, 15 with). Every node of the two found scenes within the
/// stopping tolerance (1e-6 of the span; measured 2.9e-7). And the edge cables are arcs of
/// radius T/n = 20 kN / 2 kN/m = 10 m within the surface (curvature n/T, the cable's
/// equilibrium under the membrane's edge load n): the circumradius through three successive
/// nodes of each cable, median within 2e-3 (measured 8.0e-4) and every one within 1e-2
/// (measured 4.0e-3: discretisation and the found stress's deviation 4.1e-3 from the
/// prescribed one, largest near the corners).
#[test]
fn four_point_sail_relief_keeps_the_shape_and_the_arcs() {
    let scene = read_scene(&shipped("FourPointSail"));
    let settings = scene.form_finding.clone().unwrap();
    let with = formfind::form_find_keeping(&scene, &settings, formfind::ACROSS_CABLE_KEPT).unwrap();
    let without = formfind::form_find_keeping(&scene, &settings, 1.0).unwrap();
    println!(
        "FourPointSail: {} iterations with the relief, {} without",
        with.iterations, without.iterations
    );
    assert!(with.converged() && without.converged());
    assert!(with.iterations < without.iterations);
    let (a, b) = (with.scene.unwrap(), without.scene.unwrap());
    let (xa, xb) = (&a.geometry.nodes, &b.geometry.nodes);
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in xa {
        for c in 0..3 {
            lo[c] = lo[c].min(p[c]);
            hi[c] = hi[c].max(p[c]);
        }
    }
    let span = (0..3).map(|c| (hi[c] - lo[c]).powi(2)).sum::<f64>().sqrt();
    let apart = xa
        .iter()
        .zip(xb)
        .map(|(p, q)| (0..3).map(|c| (p[c] - q[c]).powi(2)).sum::<f64>().sqrt())
        .fold(0.0f64, f64::max)
        / span;
    println!("largest node distance between the two found shapes: {apart:.2e} of the span");
    assert!(apart < 1e-6, "{apart:e}");
    let mut radii = Vec::new();
    for c in &a.cables {
        let velarium::scene::NodeRef::Set(name) = &c.nodes else {
            panic!("the sail's cables are named node sets")
        };
        let ids = &a.geometry.node_sets[name];
        for w in ids.windows(3) {
            let [p, q, r] = [w[0], w[1], w[2]].map(|i| nalgebra::Vector3::from(xa[i]));
            let (u, v, s) = ((q - r).norm(), (p - r).norm(), (p - q).norm());
            radii.push(u * v * s / (2.0 * (q - p).cross(&(r - p)).norm()));
        }
    }
    radii.sort_by(f64::total_cmp);
    let median = radii[radii.len() / 2];
    let worst = radii.iter().map(|r| rel(*r, 10.0)).fold(0.0f64, f64::max);
    println!(
        "edge-cable circumradius: median {median:.4} m, range {:.4} to {:.4} m (T/n = 10 m), worst {worst:.2e}",
        radii[0],
        radii[radii.len() - 1]
    );
    assert!(
        rel(median, 10.0) < 2e-3 && worst < 1e-2,
        "{median} {worst:e}"
    );
}

#[test]
fn edge_cables_become_arcs_of_radius_t_over_n() {
    let (t, n) = (2.0, 1.0);
    let text = format!(
        r#"{{"format": 1, "name": "Arcs",
  "geometry": {{"generators": [{{"kind": "rectangle", "name": "sq", "origin": [0, 0, 0], "size": [1, 1], "divisions": [16, 16]}}]}},
  "membranes": [{{"name": "film", "triangles": "sq", "thickness": 1e-3,
                  "material": {{"kind": "svk", "E": 1e6, "nu": 0.3}},
                  "prestress": {{"kind": "isotropic", "n": {n}}}}}],
  "cables": [{{"name": "b", "nodes": "sq.edge_bottom", "EA": 1e5, "pretension": {t}}},
             {{"name": "t", "nodes": "sq.edge_top", "EA": 1e5, "pretension": {t}}},
             {{"name": "l", "nodes": "sq.edge_left", "EA": 1e5, "pretension": {t}}},
             {{"name": "r", "nodes": "sq.edge_right", "EA": 1e5, "pretension": {t}}}],
  "supports": [{{"nodes": "sq.all", "fix": ["z"]}},
               {{"nodes": [0, 16, 272, 288], "fix": ["x", "y"]}}],
  "form_finding": {{}}}}"#
    );
    let (s, report) = found(&Scene::from_json(&text).unwrap());
    let x = &s.geometry.nodes;
    let mut worst = 0.0f64;
    for edge in [
        "sq.edge_bottom",
        "sq.edge_top",
        "sq.edge_left",
        "sq.edge_right",
    ] {
        let ids = &s.geometry.node_sets[edge];
        let r = fit_circle(&ids.iter().map(|&i| [x[i][0], x[i][1]]).collect::<Vec<_>>());
        println!("{edge}: fitted radius {r:.6} (T/n = {})", t / n);
        worst = worst.max(rel(r, t / n));
    }
    println!(
        "edge arcs: worst relative radius error {worst:.2e}, {} iterations",
        report.iterations
    );
    assert!(worst < 1e-3, "{worst:e}");
    let mut e = engine(s);
    let step = solve(&mut e);
    assert!(step.iterations <= 1);
}

/// A cable net of 7 x 7 nodes, 1 m apart, its boundary nodes placed on the hyperbolic
/// paraboloid z = c (x − 3)(y − 3) and held, the five cables along x with force `tx`, the five
/// along y with `ty` (the interior starts flat at z = 0).
fn hypar_net(tx: f64, ty: f64, c: f64) -> Scene {
    let n = 7;
    let id = |i: usize, j: usize| j * n + i;
    let mut nodes = Vec::new();
    for j in 0..n {
        for i in 0..n {
            nodes.push(format!("[{i}, {j}, 0]"));
        }
    }
    let boundary: Vec<usize> = (0..n * n)
        .filter(|k| k % n == 0 || k % n == n - 1 || k / n == 0 || k / n == n - 1)
        .collect();
    let place: Vec<String> = boundary
        .iter()
        .map(|&k| {
            let (x, y) = ((k % n) as f64, (k / n) as f64);
            format!(
                r#"{{"node": {k}, "position": [{x}, {y}, {}]}}"#,
                c * (x - 3.0) * (y - 3.0)
            )
        })
        .collect();
    let mut cables = Vec::new();
    for j in 1..n - 1 {
        let ids: Vec<String> = (0..n).map(|i| id(i, j).to_string()).collect();
        cables.push(format!(
            r#"{{"name": "x{j}", "nodes": [{}], "EA": 1e6, "pretension": {tx}}}"#,
            ids.join(", ")
        ));
    }
    for i in 1..n - 1 {
        let ids: Vec<String> = (0..n).map(|j| id(i, j).to_string()).collect();
        cables.push(format!(
            r#"{{"name": "y{i}", "nodes": [{}], "EA": 1e6, "pretension": {ty}}}"#,
            ids.join(", ")
        ));
    }
    let b: Vec<String> = boundary.iter().map(|k| k.to_string()).collect();
    let text = format!(
        r#"{{"format": 1, "name": "HyparNet",
  "geometry": {{"nodes": [{}], "node_sets": {{"boundary": [{}]}}}},
  "cables": [{}],
  "supports": [{{"nodes": "boundary", "fix": ["x", "y", "z"]}}],
  "form_finding": {{"place": [{}], "tolerance": 1e-9}}}}"#,
        nodes.join(", "),
        b.join(", "),
        cables.join(", "),
        place.join(", ")
    );
    Scene::from_json(&text).unwrap()
}

/// Cable nets (force density start, then the URS with force densities T/L). On a hyperbolic
/// paraboloid z = c (x − 3)(y − 3) the lines x = const and y = const are straight (the
/// rulings), so a net along them with its boundary on the surface is in equilibrium for any
/// force per cable (a straight cable of constant force loads its inner nodes with nothing):
/// the found interior nodes are the grid points on the hypar, with x and y unchanged. Checked
/// with forces 1 kN along x and 3 kN along y and form-finding tolerance 1e-9: largest node
/// distance from the closed form below 1e-9 of the span (measured 7.1e-11, 15 iterations;
/// before crossing nodes were exempted from the mesh control the net came out 1.0e-2 of the
/// span off, at either tolerance). Its analysis at zero load: 0 Newton iterations. And a
/// single cable between two held ends, its inner nodes starting off the line: found on the
/// straight line within 1e-15 of the span (measured 1.2e-17, 3 iterations).
#[test]
fn cable_nets_are_found_on_their_closed_forms() {
    let c = 0.2;
    let (s, report) = found(&hypar_net(1000.0, 3000.0, c));
    let x = &s.geometry.nodes;
    let span = (6.0f64 * 6.0 * 2.0 + (2.0 * 9.0 * c) * (2.0 * 9.0 * c)).sqrt();
    let worst = (0..49)
        .map(|k| {
            let (gx, gy) = ((k % 7) as f64, (k / 7) as f64);
            let want = [gx, gy, c * (gx - 3.0) * (gy - 3.0)];
            (0..3)
                .map(|i| (x[k][i] - want[i]).powi(2))
                .sum::<f64>()
                .sqrt()
        })
        .fold(0.0f64, f64::max)
        / span;
    println!(
        "hypar net: largest distance from the ruled grid {worst:.2e} of the span, {} iterations",
        report.iterations
    );
    assert!(worst < 1e-9, "{worst:e}");
    let mut e = engine(s);
    let step = solve(&mut e);
    assert_eq!(step.iterations, 0);

    let text = r#"{"format": 1, "name": "Line",
  "geometry": {"nodes": [[0, 0, 0], [1, 0.3, 0.2], [2, -0.2, 1.4], [3, 0.1, 1.1], [4, 0, 2]]},
  "cables": [{"name": "c", "nodes": [0, 1, 2, 3, 4], "EA": 1e6, "pretension": 500}],
  "supports": [{"nodes": [0, 4], "fix": ["x", "y", "z"]}],
  "form_finding": {}}"#;
    let (s, report) = found(&Scene::from_json(text).unwrap());
    let x = &s.geometry.nodes;
    let off = (1..4)
        .map(|k| {
            // Distance from the line through (0, 0, 0) and (4, 0, 2).
            let d = nalgebra::Vector3::new(4.0, 0.0, 2.0).normalize();
            let p = nalgebra::Vector3::from(x[k]);
            (p - d * p.dot(&d)).norm()
        })
        .fold(0.0f64, f64::max)
        / 20f64.sqrt();
    println!(
        "straight cable: largest distance from the line {off:.2e} of the span, {} iterations",
        report.iterations
    );
    assert!(off < 1e-15, "{off:e}");
}

/// Radius of the least-squares circle (Kåsa fit) through points.
fn fit_circle(p: &[[f64; 2]]) -> f64 {
    // x² + y² + D x + E y + F = 0, least squares in (D, E, F).
    let mut a = nalgebra::Matrix3::<f64>::zeros();
    let mut b = nalgebra::Vector3::<f64>::zeros();
    for q in p {
        let row = nalgebra::Vector3::new(q[0], q[1], 1.0);
        a += row * row.transpose();
        b -= row * (q[0] * q[0] + q[1] * q[1]);
    }
    let s = a.lu().solve(&b).unwrap();
    (0.25 * (s[0] * s[0] + s[1] * s[1]) - s[2]).sqrt()
}

/// A cone between a held mast ring (radius 0.5 m at height `h`) and a held rim (radius 5 m at
/// z = 0), 10 rings of 36 sectors (alternate rings turned half a sector), started on the
/// straight cone; a `warp_fill` prestress with the warp direction z, which each triangle's
/// plane projects onto the meridian: `warp` radial, `fill` hoop (N/m).
fn cone_scene(warp: f64, fill: f64, h: f64) -> Scene {
    let (ri, ro, rings, sectors) = (0.5, 5.0, 10, 36);
    let mut nodes = Vec::new();
    for j in 0..=rings {
        let r = ri + (ro - ri) * j as f64 / rings as f64;
        for i in 0..sectors {
            let th = 2.0 * PI * (i as f64 + 0.5 * (j % 2) as f64) / sectors as f64;
            nodes.push([r * th.cos(), r * th.sin(), h * (ro - r) / (ro - ri)]);
        }
    }
    let id = |i: usize, j: usize| j * sectors + i % sectors;
    let mut tris = Vec::new();
    for j in 0..rings {
        for i in 0..sectors {
            let (a, b, c, d) = (id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1));
            if j % 2 == 0 {
                tris.push([a, b, d]);
                tris.push([b, c, d]);
            } else {
                tris.push([a, b, c]);
                tris.push([a, c, d]);
            }
        }
    }
    let json = serde_json::json!({
        "format": 1, "name": "Cone",
        "geometry": {"nodes": nodes, "triangles": tris,
            "node_sets": {"mast": (0..sectors).collect::<Vec<_>>(),
                          "rim": (rings * sectors..(rings + 1) * sectors).collect::<Vec<_>>()},
            "triangle_sets": {"cone": (0..tris.len()).collect::<Vec<_>>()}},
        "membranes": [{"name": "fabric", "triangles": "cone", "thickness": 1e-3,
            "material": {"kind": "svk", "E": 6e8, "nu": 0.3},
            "prestress": {"kind": "warp_fill", "warp": warp, "fill": fill,
                          "warp_direction": [0, 0, 1]}}],
        "supports": [{"nodes": "mast", "fix": ["x", "y", "z"]},
                     {"nodes": "rim", "fix": ["x", "y", "z"]}],
        "form_finding": {}
    });
    Scene::from_json(&json.to_string()).unwrap()
}

/// Issue 27: a warp/fill cone (2 kN/m radial, 1 kN/m hoop) has no equilibrium shape (module
/// header), yet its shape iteration settles within the tolerance; form finding now fails
/// naming the stress deviation and the degenerate first ring (the mesh slides outward, the
/// first ring of triangles from r = 0.5-0.95 m to 0.5-2.5 m), and so does the engine (an FMU's
/// instantiation). The same cone with warp = fill is found.
#[test]
fn warp_fill_cone_without_an_equilibrium_fails_with_the_reason() {
    let report = formfind::run(&cone_scene(2000.0, 1000.0, 1.0)).unwrap();
    println!(
        "warp/fill cone: {}; deviation {:.3e}, smallest angle {:.2}° ({:.2}° at the start), shape move {:.2e} at the tolerance, finishing step {:.2e}",
        report.message,
        report.deviation,
        report.min_angle.0,
        report.min_angle.1,
        report.shape_move,
        report.last_move
    );
    assert!(!report.converged());
    assert!(report.shape_move <= 1e-6, "the shape iteration did settle");
    assert!(report.deviation > formfind::MAX_DEVIATION);
    assert!(report.min_angle.0 < formfind::MIN_ANGLE_DEGREES);
    for needle in [
        "deviates",
        "from the prescribed one (at most 1 %)",
        "has degenerated: its smallest angle fell",
    ] {
        assert!(
            report.message.contains(needle),
            "{needle}: {}",
            report.message
        );
    }
    let err = match velarium::Engine::try_new(cone_scene(2000.0, 1000.0, 1.0)) {
        Err(e) => e.to_string(),
        Ok(_) => panic!("a cone with no equilibrium shape built an engine"),
    };
    assert!(
        err.contains("form finding failed") && err.contains("deviates"),
        "{err}"
    );
    let (_, report) = found(&cone_scene(1000.0, 1000.0, 1.0));
    println!(
        "isotropic cone: deviation {:.3e}, smallest angle {:.2}°, {} iterations",
        report.deviation, report.min_angle.0, report.iterations
    );
    assert!(report.deviation <= formfind::MAX_DEVIATION);
    assert!(report.min_angle.0 >= formfind::MIN_ANGLE_DEGREES);
}
