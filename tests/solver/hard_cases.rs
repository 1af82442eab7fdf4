//! GOAL: the hard cases of issue 9 and docs/solver.md ("Hard cases"): each test asserts the
//!       RIGHT answer (a closed form, exact statics, an exact symmetry or a hand bound) or, where
//!       no equilibrium exists, the specific failure. No test accepts both convergence and
//!       failure. On the solver of commit 79af9e6 (two Newton loops) 8 of the 19 passed; on the
//!       one-loop solver all pass, with case e asserted as the failure it is (no equilibrium).
//!
//! Conventions used in the tolerances below. The solver's documented criterion
//! (src/solver/newton.rs, docs/solver.md) is |R_d| <= tol · F at every free DOF, F the largest
//! of |f_ext|∞, |reactions|∞, the largest element force and the step's load change, tol = 1e-9
//! (scene default), or the round-off floor with a Newton correction within tol · X. A sum of
//! reactions therefore equals minus the sum of applied loads to within (number of free nodes) ·
//! tol · F, because the internal forces of any state sum to zero (translation invariance).
//! Where the reference involves a strain far below 1, the internal force carries a round-off of
//! about ε_mach · EA (the cancellation in l − L0), and the tolerance says so.
//!
//! All scenes are built here in Rust (JSON through serde_json) except where a shipped scene is
//! the case itself (PrestressedCable, HenckyDisc, WrinkledShear).

use crate::common;
use common::*;
use nalgebra::Vector3;
use serde_json::json;
use velarium::model::wrinkling::{Law, WrinkleState};
use velarium::scene::{Generator, Load, StrainLaw};
use velarium::{Engine, Scene};

fn scene_of(value: serde_json::Value) -> Scene {
    Scene::from_json(&value.to_string()).unwrap_or_else(|p| panic!("{p}"))
}

/// Current position of mesh node `n` in the committed state.
fn pos(e: &Engine, n: usize) -> Vector3<f64> {
    e.model().position(&e.state().displacement, n)
}

/// Displacement of mesh node `n` in the committed state.
fn disp(e: &Engine, n: usize) -> Vector3<f64> {
    pos(e, n) - e.model().reference[n]
}

/// Bisection for the root of a function that is negative at `lo` and positive at `hi`.
fn bisect(mut lo: f64, mut hi: f64, f: impl Fn(f64) -> f64) -> f64 {
    assert!(f(lo) < 0.0 && f(hi) > 0.0, "bracket [{lo}, {hi}]");
    for _ in 0..400 {
        let mid = 0.5 * (lo + hi);
        if f(mid) < 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

fn timed<T>(what: &str, f: impl FnOnce() -> T) -> T {
    let t = std::time::Instant::now();
    let out = f();
    println!("{what}: {:.3} s", t.elapsed().as_secs_f64());
    out
}

// ---------------------------------------------------------------------------------------------
// (a) A clamped disc with one very stiff tie must not be "converged" at 0 iterations.
// ---------------------------------------------------------------------------------------------

/// CASE (a), issue 9: the shipped HenckyDisc (16 rings, a = 0.5 m, h = 0.1 mm, E = 200 MPa,
/// ν = 0.3, rim clamped) plus one cable of EA = 1e11 N between two adjacent rim nodes. Both ends
/// of the tie are clamped, so it carries nothing and the equilibrium is EXACTLY the disc's; it only
/// raises the stiffest-member force scale (today's floor 1e-12 · 1e11 = 0.1 N exceeds every nodal
/// load of 40 Pa · 2.5e-4 m², so the step "converged" at 0 iterations with center_uz = 0).
/// REFERENCE: docs/mechanics.md §4a exact-kinematics follower value w0/a = 0.065404 at qa/(Eh) = 1e-3;
/// tolerance 0.2 % (16 rings reach 0.07 %, tests/verification/hencky_disc.rs header). Vertical
/// equilibrium: rim reaction = q × projected area of the 96-gon, 1e-8 relative (what
/// verification/hencky_disc.rs measures without the tie). At least one Newton iteration (the load changed).
#[test]
fn a_stiff_tie_does_not_hide_the_disc_load() {
    let mut scene = read_scene(&shipped("HenckyDisc"));
    // Rim node ids: the disc generator's rim set (outer ring, counter-clockwise).
    let mesh = velarium::scene::generate::resolve(&scene.geometry);
    let rim = &mesh.node_sets["disc.rim"];
    let (n0, n1) = (rim[0], rim[1]);
    scene.cables.push(
        serde_json::from_value(json!({"name": "tie", "nodes": [n0, n1], "EA": 1e11})).unwrap(),
    );
    let mut e = engine(scene);
    solve(&mut e);
    set(&mut e, "pressure", 40.0);
    let report = e.solve();
    assert!(report.converged(), "{}", report.message);
    assert!(
        report.iterations >= 1,
        "a changed load needs Newton iterations"
    );
    let w = get(&e, "center_uz") / 0.5;
    println!(
        "(a) w0/a = {w:.6} vs 0.065404, {} iterations",
        report.iterations
    );
    assert!(rel(w, 0.065404) < 2e-3, "w0/a = {w} vs 0.065404");
    let n = 96.0;
    let area = 0.5 * n * 0.25 * (2.0 * std::f64::consts::PI / n).sin();
    let r = get(&e, "rim_reaction_z");
    assert!(
        rel(-r, 40.0 * area) < 1e-8,
        "reaction {r} vs {}",
        40.0 * area
    );
}

// ---------------------------------------------------------------------------------------------
// (b) PrestressedCable with EA 1e16.
// ---------------------------------------------------------------------------------------------

/// Exact engineering-strain pretensioned cable (docs/mechanics.md §4g), half-span 1 m: midspan sag w
/// and tension T for EA, T0, P. Written to keep the tiny strains accurate: l − L = w²/(l + L),
/// L − L0 = L (T0/EA)/(1 + T0/EA).
fn pretensioned_cable(ea: f64, t0: f64, p: f64) -> (f64, f64) {
    let tension = |w: f64| {
        let l = (1.0 + w * w).sqrt();
        let l0 = 1.0 / (1.0 + t0 / ea);
        let stretch = w * w / (l + 1.0) + (t0 / ea) / (1.0 + t0 / ea);
        (ea * stretch / l0, l)
    };
    let w = bisect(0.0, 1.0, |w| {
        let (t, l) = tension(w);
        2.0 * t * w / l - p
    });
    (w, tension(w).0)
}

/// CASE (b), issue 9: PrestressedCable with EA = 1e16 N under P = 1000 N; with the old
/// convergence floor (1e-12 · EA = 1e4 N > P) the step returned a reaction of 0 N after 0
/// iterations. With the shipped pretension of 100 N the initial strain T0/EA = 1e-14 is below
/// round-off: since issue 11 the scene is rejected with a message on `cables[0].EA` (the
/// explicit failure, `b_pretension_below_round_off_is_rejected`). The convergence question
/// stands with the cable unstressed at the start (pretension 0, L0 = L): REFERENCE MECHANICS
/// §4g with T0 = 0, P = 2 T w/l, T = EA (l − L)/L, solved here by bisection: w ≈ L (P/EA)^(1/3)
/// = 4.6416e-5 m, T ≈ 1.0772e7 N. Tolerances: the residual criterion allows 1e-9 · T ≈ 1.1e-2
/// N at the midspan node; over the vertical stiffness 3P/w ≈ 6.5e7 N/m that is 1.7e-10 m =
/// 3.6e-6 of w, so w within 1e-5 relative; the sum of vertical reactions equals P within
/// 1e-9 · max(P, T) (+ 2 free DOF rows); T within 1e-6 relative (strain 1e-9 carries a
/// round-off of 1e-7 relative).
#[test]
fn b_prestressed_cable_with_ea_1e16() {
    let mut scene = read_scene(&shipped("PrestressedCable"));
    scene.cables[0].ea = 1e16;
    scene.cables[0].pretension = Some(0.0);
    let mut e = engine(scene);
    solve(&mut e);
    set(&mut e, "P", 1000.0);
    let report = e.solve();
    assert!(report.converged(), "{}", report.message);
    let (w_ref, t_ref) = pretensioned_cable(1e16, 0.0, 1000.0);
    let (w, t, rz) = (
        -get(&e, "midspan_uz"),
        get(&e, "tension"),
        get(&e, "reaction_z"),
    );
    println!(
        "(b) w = {w:.6e} vs {w_ref:.6e}, T = {t:.6e} vs {t_ref:.6e}, Rz = {rz}, {} iterations",
        report.iterations
    );
    assert!(
        (rz - 1000.0).abs() <= 1e-9 * t_ref * 2.0,
        "reaction {rz} vs P = 1000"
    );
    assert!(rel(w, w_ref) < 1e-5, "w = {w} vs {w_ref}");
    assert!(rel(t, t_ref) < 1e-6, "T = {t} vs {t_ref}");
}

/// CASE (b), the shipped pretension: T0 = 100 N at EA = 1e16 N is an initial strain of 1e-14,
/// below round-off, so the pretension could not be represented (issue 11). REFERENCE: the
/// scene is refused before a model is built, with the field and the largest usable EA named.
#[test]
fn b_pretension_below_round_off_is_rejected() {
    let mut scene = read_scene(&shipped("PrestressedCable"));
    scene.cables[0].ea = 1e16;
    let message = match Engine::try_new(scene) {
        Ok(_) => panic!("EA 1e16 with a 100 N pretension was accepted"),
        Err(e) => e.to_string(),
    };
    assert!(
        message.contains("cables[0].EA") && message.contains("pretension"),
        "{message}"
    );
}

// ---------------------------------------------------------------------------------------------
// (c) A membrane patch linked to the rest only through a slack cable.
// ---------------------------------------------------------------------------------------------

/// CASE (c), issue 9: a square SVK patch (0.2 m, 4 x 4 cells, crossed, t = 0.1 mm, E = 200 MPa,
/// wrinkling off so that the patch itself is an ordinary elastic body once held) whose only link
/// to a support is one cable (EA = 1e4 N) from the fixed anchor A = (0, 0) to the midpoint C of
/// its left edge, C = (0.5, 0): the cable's unstretched length 0.6 m is longer than the chord
/// 0.5 m, so it is slack at the start and the patch floats. A force F = 10 N in +x at the
/// midpoint of the right edge (on the line A–C) pulls the cable taut. All nodes held in z.
/// Today: Discard at load fraction 0 although the equilibrium exists.
/// REFERENCE (statics): the cable is the only path to the support, so its tension is F and the
/// anchor reaction is −F (x); the cable is straight along the line of action, C at
/// x = 0.6 (1 + F/EA) = 0.6006 m, y = 0 (mirror symmetry of the mesh and load about y = 0).
/// Tolerances: T and the reaction within 1e-7 relative (25 free nodes × the criterion 1e-9 · F);
/// x_C within 1e-9 m (ΔT of 1e-6 N over the cable compliance L0/EA = 6e-5 m/N), |y_C| < 1e-9 m.
#[test]
fn c_patch_held_only_by_a_slack_cable() {
    // Node 0: anchor; generated nodes from 1: (i, j) -> 1 + 5 j + i.
    let scene = scene_of(json!({
        "format": 1, "name": "SlackLink",
        "geometry": {"nodes": [[0.0, 0.0, 0.0]],
                     "node_sets": {"anchor": [0], "c": [11], "tip": [15]},
                     "generators": [{"kind": "rectangle", "name": "patch", "origin": [0.5, -0.1, 0.0],
                                     "size": [0.2, 0.2], "divisions": [4, 4]}]},
        "membranes": [{"name": "film", "triangles": "patch", "thickness": 1e-4, "wrinkling": false,
                       "material": {"kind": "svk", "E": 2e8, "nu": 0.3}}],
        "cables": [{"name": "link", "nodes": [0, 11], "EA": 1e4, "unstretched_length": 0.6}],
        "supports": [{"nodes": "anchor", "fix": ["x", "y", "z"]}, {"nodes": "patch.all", "fix": ["z"]}],
        "inputs": [{"name": "F", "load": {"kind": "point_force", "nodes": "tip", "direction": [1.0, 0.0, 0.0]}}],
        "outputs": [
            {"name": "T", "probe": {"kind": "cable_tension", "cable": "link"}},
            {"name": "Rx", "probe": {"kind": "reaction", "nodes": "anchor", "component": "x"}},
            {"name": "xc", "probe": {"kind": "position", "node": "c", "component": "x"}},
            {"name": "yc", "probe": {"kind": "position", "node": "c", "component": "y"}}
        ]
    }));
    let mut e = engine(scene);
    set(&mut e, "F", 10.0);
    let report = e.solve();
    assert!(report.converged(), "{}", report.message);
    let (t, rx, xc, yc) = (get(&e, "T"), get(&e, "Rx"), get(&e, "xc"), get(&e, "yc"));
    let xc_ref = 0.6 * (1.0 + 10.0 / 1e4);
    println!("(c) T = {t}, Rx = {rx}, C = ({xc:.12}, {yc:.3e}) vs x {xc_ref}");
    assert!(rel(t, 10.0) < 1e-7, "cable tension {t} vs F = 10");
    assert!(rel(-rx, 10.0) < 1e-7, "anchor reaction {rx} vs −10");
    assert!((xc - xc_ref).abs() < 1e-9, "x_C = {xc} vs {xc_ref}");
    assert!(yc.abs() < 1e-9, "y_C = {yc}");
}

// ---------------------------------------------------------------------------------------------
// (d), (k) Frictionless sliding: pulley statics.
// ---------------------------------------------------------------------------------------------

/// The ring on a frictionless elastic cable between A = (−1, 0) and B = (1, 0): equilibrium
/// T (e_a + e_b) + F = 0 with T = EA (l_a + l_b − L0)/L0, L0 the cable's total unstretched
/// length (which sliding does not change). The sum e_a + e_b
/// is along the inward normal of the ellipse with foci A, B through the point (reflection
/// property), so the point is where the ellipse's outward normal is F/|F|:
/// (x, y) = (a² n_x, b² n_y)/sqrt(a² n_x² + b² n_y²), b² = a² − 1; a from T(a) |e_a + e_b| = |F|
/// by bisection. Returns the cable point (x, y) and T.
fn ring_on_cable(ea: f64, l0: f64, f: [f64; 2]) -> ([f64; 2], f64) {
    let fmag = (f[0] * f[0] + f[1] * f[1]).sqrt();
    let n = [f[0] / fmag, f[1] / fmag];
    let point = |a: f64| {
        let b2 = a * a - 1.0;
        let c = (a * a * n[0] * n[0] + b2 * n[1] * n[1]).sqrt();
        [a * a * n[0] / c, b2 * n[1] / c]
    };
    let balance = |a: f64| {
        let [x, y] = point(a);
        let (la, lb) = (
            ((x + 1.0).powi(2) + y * y).sqrt(),
            ((x - 1.0).powi(2) + y * y).sqrt(),
        );
        let sum = [(-1.0 - x) / la + (1.0 - x) / lb, -y / la - y / lb];
        let t = ea * (la + lb - l0) / l0;
        t * (sum[0] * sum[0] + sum[1] * sum[1]).sqrt() - fmag
    };
    let a = bisect(f64::max(1.0, 0.5 * l0) * (1.0 + 1e-12), 4.0, balance);
    (point(a), ea * (2.0 * a - l0) / l0)
}

/// CASE (d), issue 9: sliding nodes with no load of their own, free to drift along a cable.
/// A cable A = (−1, 0) → N1 → M → N2 → B = (1, 0), straight at the start, EA = 1e4 N, T0 = 100 N
/// (engineering), frictionless sleeve at N1 (x = −0.7), M (x = −0.2) and N2 (x = 0.5), tie
/// penalty 1e9 N/m. Only M is loaded, P = 100 N in −y; N1 and N2 carry nothing. All nodes held
/// in z. REFERENCE (statics): frictionless ⇒ one tension T in every segment; an unloaded sleeve
/// node has a zero tie force, so the cable is straight through it (N1 on the line A–M', N2 on
/// M'–B, M' the cable point at M) and where it sits along that line is not determined (the drift
/// the issue names); M' is the ring on a cable of total unstretched length L0 = 2/(1 + T0/EA):
/// x = 0, sag w from `ring_on_cable` (the pulley of verification/sliding_cable.rs), and M at M' (the
/// ties closed by their multipliers to 1e-12 of the segment, model/sleeve.rs; with the penalty alone
/// M hung P/k = 1e-7 m below M' and the reference added that). Tolerances as in verification/sliding_cable.rs: 1e-8 m on M, tensions equal within 1e-6 relative
/// and equal to T within 1e-6; N1, N2 within 1e-8 m of their lines and strictly inside them.
#[test]
fn d_unloaded_sliding_nodes_drift_along_the_cable() {
    let k = 1e9;
    let scene = scene_of(json!({
        "format": 1, "name": "Drift",
        "geometry": {"nodes": [[-1.0, 0.0, 0.0], [-0.7, 0.0, 0.0], [-0.2, 0.0, 0.0], [0.5, 0.0, 0.0], [1.0, 0.0, 0.0]],
                     "node_sets": {"ends": [0, 4], "inner": [1, 2, 3], "m": [2]}},
        "cables": [{"name": "cable", "nodes": [0, 1, 2, 3, 4], "EA": 1e4, "pretension": 100.0,
                    "sleeve": {"mu": 0.0, "penalty": k}}],
        "supports": [{"nodes": "ends", "fix": ["x", "y", "z"]}, {"nodes": "inner", "fix": ["z"]}],
        "inputs": [{"name": "P", "load": {"kind": "point_force", "nodes": "m", "direction": [0.0, -1.0, 0.0]}}],
        "outputs": [
            {"name": "T0", "probe": {"kind": "cable_tension", "cable": "cable", "segment": 0}},
            {"name": "T1", "probe": {"kind": "cable_tension", "cable": "cable", "segment": 1}},
            {"name": "T2", "probe": {"kind": "cable_tension", "cable": "cable", "segment": 2}},
            {"name": "T3", "probe": {"kind": "cable_tension", "cable": "cable", "segment": 3}}
        ]
    }));
    let mut e = engine(scene);
    set(&mut e, "P", 100.0);
    let report = e.solve();
    assert!(report.converged(), "{}", report.message);
    let ([xr, yr], t_ref) = ring_on_cable(1e4, 2.0 / (1.0 + 100.0 / 1e4), [0.0, -100.0]);
    let m = pos(&e, 2);
    let t: Vec<f64> = (0..4).map(|s| get(&e, &format!("T{s}"))).collect();
    println!(
        "(d) M = ({:.3e}, {:.10}) vs ({xr:.1e}, {yr:.10}); T {t:?} vs {t_ref:.9}; N1 {:?} N2 {:?}; {} iterations",
        m.x,
        m.y,
        pos(&e, 1),
        pos(&e, 3),
        report.iterations
    );
    assert!((m.x - xr).abs() < 1e-8, "M at x = {} vs {xr}", m.x);
    assert!((m.y - yr).abs() < 1e-8, "M at y = {} vs {yr}", m.y);
    for (s, &t_s) in t.iter().enumerate().take(4) {
        assert!(
            rel(t_s, t_ref) < 1e-6,
            "segment {s}: T = {} vs {t_ref}",
            t[s]
        );
    }
    let m_cable = Vector3::new(m.x, m.y, 0.0);
    for (node, a, b) in [
        (1, Vector3::new(-1.0, 0.0, 0.0), m_cable),
        (3, m_cable, Vector3::new(1.0, 0.0, 0.0)),
    ] {
        let p = pos(&e, node);
        let d = (b - a).normalize();
        let along = (p - a).dot(&d);
        let off = ((p - a) - d * along).norm();
        assert!(
            off < 1e-8,
            "node {node} is {off:e} m off the straight cable"
        );
        assert!(
            along > 0.0 && along < (b - a).norm(),
            "node {node} must lie between its neighbours ({along} of {})",
            (b - a).norm()
        );
    }
}

/// CASE (k), issue 9 / docs/solver.md (hard cases): a ring (one node) on a frictionless cable, the
/// pulley, under load rows of varying direction, each row starting from the previous
/// equilibrium. Cable A = (−1, 0) – ring – B = (1, 0); the ring starts off-centre at
/// (−0.4, −0.6) with the cable pretensioned to 10 N in that V (so L0 = (l_a + l_b)/(1 + 10/EA)
/// = 2.36934 m, and the ring has room to move: a taut straight cable would send it to an anchor
/// under any sideways load); EA = 1e4 N, sleeve μ = 0, tie penalty k = 1e9 N/m; the ring is
/// held in z. The unloaded start is not an equilibrium (the pretensioned V pulls the ring).
/// REFERENCE: `ring_on_cable` (ellipse statics, derived above it), the node at the cable point
/// (its tie closed by its multiplier to 1e-12 of the segment; with the penalty alone the node
/// sat F/k beyond the cable point and the reference added that). Tolerances: 1e-8 m on the node position (the
/// verification/sliding_cable.rs pulley tolerance); Ta = Tb within 1e-6 relative and equal to T within 1e-6.
/// Speed (issue target: median <= 15 iterations per row) is printed, not asserted.
#[test]
fn k_ring_on_a_frictionless_cable() {
    let k = 1e9;
    let scene = scene_of(json!({
        "format": 1, "name": "Ring",
        "geometry": {"nodes": [[-1.0, 0.0, 0.0], [-0.4, -0.6, 0.0], [1.0, 0.0, 0.0]],
                     "node_sets": {"ends": [0, 2], "ring": [1]}},
        "cables": [{"name": "cable", "nodes": [0, 1, 2], "EA": 1e4, "pretension": 10.0,
                    "sleeve": {"mu": 0.0, "penalty": k}}],
        "supports": [{"nodes": "ends", "fix": ["x", "y", "z"]}, {"nodes": "ring", "fix": ["z"]}],
        "inputs": [
            {"name": "Fx", "load": {"kind": "point_force", "nodes": "ring", "direction": [1.0, 0.0, 0.0]}},
            {"name": "Fy", "load": {"kind": "point_force", "nodes": "ring", "direction": [0.0, 1.0, 0.0]}}
        ],
        "outputs": [
            {"name": "Ta", "probe": {"kind": "cable_tension", "cable": "cable", "segment": 0}},
            {"name": "Tb", "probe": {"kind": "cable_tension", "cable": "cable", "segment": 1}}
        ]
    }));
    let mut e = engine(scene);
    let l0 = ((0.6f64 * 0.6 + 0.6 * 0.6).sqrt() + (1.4f64 * 1.4 + 0.6 * 0.6).sqrt())
        / (1.0 + 10.0 / 1e4);
    let mut iterations = Vec::new();
    for f in [
        [0.0, -100.0],
        [30.0, -100.0],
        [-30.0, -100.0],
        [60.0, -80.0],
        [-10.0, -200.0],
    ] {
        set(&mut e, "Fx", f[0]);
        set(&mut e, "Fy", f[1]);
        let report = e.solve();
        assert!(report.converged(), "row {f:?}: {}", report.message);
        iterations.push(report.iterations);
        let ([x, y], t) = ring_on_cable(1e4, l0, f);
        let p = pos(&e, 1);
        let (ta, tb) = (get(&e, "Ta"), get(&e, "Tb"));
        println!("(k) F {f:?}: ring ({:.10}, {:.10}) vs ({x:.10}, {y:.10}), Ta {ta:.8} Tb {tb:.8} T {t:.8}", p.x, p.y);
        assert!(
            (p.x - x).abs() < 1e-8 && (p.y - y).abs() < 1e-8,
            "F {f:?}: ring at ({}, {}) vs ({x}, {y})",
            p.x,
            p.y
        );
        assert!(rel(ta, tb) < 1e-6, "F {f:?}: Ta {ta} vs Tb {tb}");
        assert!(rel(ta, t) < 1e-6, "F {f:?}: T {ta} vs {t}");
    }
    println!("(k) Newton iterations per load row: {iterations:?}");
}

// ---------------------------------------------------------------------------------------------
// (e) A membrane held only by a frictionless sleeve, wrinkling on.
// ---------------------------------------------------------------------------------------------

/// The curtain of cases (e) and (e'): a square film (0.4 m, 8 x 8 cells, crossed, SVK
/// E = 200 MPa, ν = 0.3, t = 0.1 mm, wrinkling ON) hangs from a cable threaded through a
/// frictionless sleeve along its top edge (all 9 top-edge nodes); the cable (EA = 1e5 N,
/// T0 = 50 N) is anchored at A = (−0.1, 0.4) and B = (0.5, 0.4). Nothing else holds the film;
/// its bottom edge carries the input F in −y shared by its 9 nodes. All film nodes held in z.
/// Explicit nodes 0 (A), 1 (B); generated (i, j) -> 2 + 9 j + i; top edge j = 8: 74..=82.
fn curtain(residual_stiffness: f64) -> Scene {
    let id = |i: usize, j: usize| 2 + 9 * j + i;
    let mut chain = vec![0];
    chain.extend((0..=8).map(|i| id(i, 8)));
    chain.push(1);
    let mut membrane = json!({"name": "film", "triangles": "film", "thickness": 1e-4,
                              "material": {"kind": "svk", "E": 2e8, "nu": 0.3}});
    if residual_stiffness > 0.0 {
        membrane["residual_stiffness"] = json!(residual_stiffness);
    }
    scene_of(json!({
        "format": 1, "name": "Curtain",
        "geometry": {"nodes": [[-0.1, 0.4, 0.0], [0.5, 0.4, 0.0]],
                     "node_sets": {"a": [0], "b": [1]},
                     "generators": [{"kind": "rectangle", "name": "film", "origin": [0.0, 0.0, 0.0],
                                     "size": [0.4, 0.4], "divisions": [8, 8]}]},
        "membranes": [membrane],
        "cables": [{"name": "cable", "nodes": chain, "EA": 1e5, "pretension": 50.0,
                    "sleeve": {"mu": 0.0}}],
        "supports": [{"nodes": "a", "fix": ["x", "y", "z"]}, {"nodes": "b", "fix": ["x", "y", "z"]},
                     {"nodes": "film.all", "fix": ["z"]}],
        "inputs": [{"name": "F", "load": {"kind": "point_force", "nodes": "film.edge_bottom", "direction": [0.0, -1.0, 0.0]}}],
        "outputs": [
            {"name": "RAx", "probe": {"kind": "reaction", "nodes": "a", "component": "x"}},
            {"name": "RAy", "probe": {"kind": "reaction", "nodes": "a", "component": "y"}},
            {"name": "RBx", "probe": {"kind": "reaction", "nodes": "b", "component": "x"}},
            {"name": "RBy", "probe": {"kind": "reaction", "nodes": "b", "component": "y"}},
            {"name": "T0", "probe": {"kind": "cable_tension", "cable": "cable", "segment": 0}},
            {"name": "T1", "probe": {"kind": "cable_tension", "cable": "cable", "segment": 1}},
            {"name": "T2", "probe": {"kind": "cable_tension", "cable": "cable", "segment": 2}},
            {"name": "T3", "probe": {"kind": "cable_tension", "cable": "cable", "segment": 3}},
            {"name": "T4", "probe": {"kind": "cable_tension", "cable": "cable", "segment": 4}},
            {"name": "T5", "probe": {"kind": "cable_tension", "cable": "cable", "segment": 5}},
            {"name": "T6", "probe": {"kind": "cable_tension", "cable": "cable", "segment": 6}},
            {"name": "T7", "probe": {"kind": "cable_tension", "cable": "cable", "segment": 7}},
            {"name": "T8", "probe": {"kind": "cable_tension", "cable": "cable", "segment": 8}},
            {"name": "T9", "probe": {"kind": "cable_tension", "cable": "cable", "segment": 9}}
        ]
    }))
}

/// CASE (e), issue 9: the curtain above, pure tension-field law, F = 20 N. Issue 9 lists it
/// among structures that have an equilibrium; it has none, and the right outcome is a failure
/// that says why.
/// WHY NO EQUILIBRIUM (statics, any F > 0): a frictionless sleeve point takes only the cable's
/// resultant at its node, T (t_a + t_b), along the bisector of the kink. Under any load the cable
/// sags and is steeper between A and the first film node than beyond it, so that resultant has a
/// horizontal part toward midspan of about T (s_a² − s_b²)/2 ≠ 0 at the top corner node. The
/// film can pull a node only toward its own interior (tension only), and the corner's interior
/// lies toward midspan too: nothing balances it, and the top edge gathers along the cable (a
/// curtain on a wire) until its triangles degenerate. A residual stiffness lets the film carry
/// that compression (case e').
/// ASSERTED: Discard (no convergence), the engine keeps the last equilibrium (the unloaded
/// state: outputs unchanged), and the message names a node of the film's top or side edges
/// where every triangle is wrinkled or slack (the crawl measured in docs/solver.md: nodes 65
/// and 73 move 2.8e-5 m inward per iteration while their residual falls 0.1 %; the residual
/// farthest above its local tolerance is now at node 79 in y, on the gathering top edge, with
/// |R| = 1.9e-8 N at 3.5e3 times its tolerance), and that the prestress
/// continuation (docs/solver.md) was tried from the unstressed start and failed at its first
/// stage. The wall time of the failure is printed (issue target: under 2 s; measured 0.32 s with
/// the continuation's failed attempt).
#[test]
fn e_membrane_held_only_by_a_frictionless_sleeve_has_no_equilibrium() {
    let mut e = engine(curtain(0.0));
    let before = e.solve();
    assert!(before.converged(), "unloaded: {}", before.message);
    let kept: Vec<f64> = (0..10).map(|s| get(&e, &format!("T{s}"))).collect();
    let rax = get(&e, "RAx");
    set(&mut e, "F", 20.0);
    let t = std::time::Instant::now();
    let report = e.solve();
    let seconds = t.elapsed().as_secs_f64();
    println!(
        "(e) {:?} after {seconds:.3} s: {}",
        report.outcome, report.message
    );
    assert!(
        !report.converged(),
        "the curtain converged: {}",
        report.message
    );
    // A node of the gathering top edge or of a side edge (id 2 + 9 j + i: i = 0 or 8, or
    // j = 8).
    let edge =
        |n: usize| n >= 2 && ((n - 2).is_multiple_of(9) || (n - 2) % 9 == 8 || (n - 2) / 9 == 8);
    let named = report
        .message
        .split("is at node ")
        .nth(1)
        .and_then(|rest| rest.split(' ').next())
        .and_then(|n| n.parse::<usize>().ok());
    assert!(
        named.is_some_and(edge),
        "the message does not name an edge node of the film: {}",
        report.message
    );
    assert!(
        report
            .message
            .contains("every triangle is wrinkled or slack"),
        "the message does not say why: {}",
        report.message
    );
    // The film starts unstressed, so the prestress continuation was tried once (and failed:
    // there is no equilibrium to continue to), and the message says so.
    assert!(
        report
            .message
            .contains("the prestress continuation was tried: from load fraction 0.000000 it failed at pre-strain 1.00e-3"),
        "the message does not say the continuation was tried: {}",
        report.message
    );
    for (s, k) in kept.iter().enumerate() {
        assert_eq!(
            get(&e, &format!("T{s}")),
            *k,
            "segment {s}: the state was not kept"
        );
    }
    assert_eq!(get(&e, "RAx"), rax, "R_A: the state was not kept");
}

/// CASE (e'), issue 9: the curtain with `residual_stiffness` 1e-4 (docs/mechanics.md §1.5): the
/// film now resists the gathering with a compressive stress ρ E e₂ and hangs in equilibrium at
/// F = 10 N (measured: the path follower reaches 0.674 of F = 20 N, where a side-edge triangle
/// degenerates, area ratio 9.9e-7, as the argument of case (e) predicts for growing loads).
/// REFERENCE (exact consequences, no closed form exists for the field): (1) global balance: the
/// anchors' reactions sum to (0, F), within 1e-7 F (81 free nodes × criterion 1e-9 F);
/// (2) frictionless ⇒ one tension in all 10 segments, within 1e-6 relative (as verification/sliding_cable.rs);
/// (3) an anchor is held by one segment only, so |R_A| = T_0 within 1e-7 relative;
/// (4) mirror symmetry about x = 0.2 (mesh, sleeve, anchors and load are symmetric): every node and
/// its mirror image agree within 1e-6 of the largest displacement (a residual of 1e-9 F over the
/// softest, pendulum-like sliding stiffness ~F/0.4 m gives 4e-10 m against displacements of mm);
/// (5) the bottom edge moves down (the film hangs: u_y < 0 at its midpoint).
#[test]
fn e2_curtain_with_a_residual_stiffness_hangs() {
    let id = |i: usize, j: usize| 2 + 9 * j + i;
    let f = 10.0;
    let mut e = engine(curtain(1e-4));
    set(&mut e, "F", f);
    let report = e.solve();
    assert!(report.converged(), "{}", report.message);
    let (rax, ray, rbx, rby) = (
        get(&e, "RAx"),
        get(&e, "RAy"),
        get(&e, "RBx"),
        get(&e, "RBy"),
    );
    let t: Vec<f64> = (0..10).map(|s| get(&e, &format!("T{s}"))).collect();
    println!(
        "(e) R_A = ({rax}, {ray}), R_B = ({rbx}, {rby}), T = {t:?}, {} iterations",
        report.iterations
    );
    assert!(
        (ray + rby - f).abs() < 1e-7 * f,
        "vertical reactions {ray} + {rby} vs {f}"
    );
    assert!(
        (rax + rbx).abs() < 1e-7 * f,
        "horizontal reactions {rax} + {rbx}"
    );
    for s in 1..10 {
        assert!(rel(t[s], t[0]) < 1e-6, "segment {s}: {} vs {}", t[s], t[0]);
    }
    assert!(
        rel((rax * rax + ray * ray).sqrt(), t[0]) < 1e-7,
        "|R_A| vs T"
    );
    let umax = (0..81)
        .map(|n| disp(&e, id(n % 9, n / 9)).norm())
        .fold(0.0, f64::max);
    for j in 0..=8 {
        for i in 0..=8 {
            let (p, q) = (pos(&e, id(i, j)), pos(&e, id(8 - i, j)));
            assert!(
                (p.x + q.x - 0.4).abs() < 1e-6 * umax && (p.y - q.y).abs() < 1e-6 * umax,
                "node ({i}, {j}) at {p:?} and its mirror at {q:?}"
            );
        }
    }
    assert!(disp(&e, id(4, 0)).y < 0.0, "the film hangs");
}

// ---------------------------------------------------------------------------------------------
// (f) Tiny loads on an unstressed or slack cable.
// ---------------------------------------------------------------------------------------------

/// CASE (f1), issue 9: P = 1e-6 N at midspan of a straight cable with no pretension
/// (PrestressedCable, half-span L = 1 m, EA = 1e5 N, SVK law). DERIVATION: with T0 = 0, L0 = L;
/// SVK T = A S l/L0, S = E (l² − L²)/(2L²) = E w²/(2L²), so T = EA w² l/(2L³); vertical balance
/// P = 2 T w/l = EA w³/L³, i.e. w = L (P/EA)^(1/3) exactly (docs/mechanics.md §4g) = 2.1544e-4 m.
/// Tolerances: w within 2e-6 relative (the criterion allows 1e-9 · T = 2.3e-12 N at the node;
/// over the vertical stiffness 3P/w = 1.4e-2 N/m that is 1.6e-10 m = 7.5e-7 of w); the vertical
/// reaction equals P within 1e-5 P (round-off of the internal force ε_mach · EA ≈ 1e-11 N).
#[test]
fn f1_micro_load_on_an_unstressed_straight_cable_cubic_law() {
    let mut scene = read_scene(&shipped("PrestressedCable"));
    scene.cables[0].strain = StrainLaw::GreenLagrange;
    scene.cables[0].pretension = Some(0.0);
    let mut e = engine(scene);
    solve(&mut e);
    set(&mut e, "P", 1e-6);
    let report = e.solve();
    assert!(report.converged(), "{}", report.message);
    let w_ref = (1e-6f64 / 1e5).cbrt();
    let (w, rz) = (-get(&e, "midspan_uz"), get(&e, "reaction_z"));
    println!(
        "(f1) w = {w:.10e} vs {w_ref:.10e}, Rz = {rz:e}, {} iterations",
        report.iterations
    );
    assert!(rel(w, w_ref) < 2e-6, "w = {w} vs {w_ref}");
    assert!((rz - 1e-6).abs() < 1e-11, "reaction {rz} vs 1e-6");
}

/// Exact symmetric slack-then-taut cable: two segments of unstretched length l0 over half-span 1
/// (engineering law, tension-only): sag w and tension T under midspan load P.
fn hanging_string(ea: f64, l0: f64, p: f64) -> (f64, f64) {
    let w_taut = (l0 * l0 - 1.0).sqrt();
    let tension = |w: f64| ea * (((1.0 + w * w).sqrt() - l0) / l0).max(0.0);
    let w = bisect(w_taut, 2.0 * l0, |w| {
        2.0 * tension(w) * w / (1.0 + w * w).sqrt() - p
    });
    (w, tension(w))
}

/// CASE (f2), issue 9: P = 1e-6 N on an initially slack cable, longer than its chord: the
/// PrestressedCable geometry (chord 2 m, straight nodes) with unstretched length 2.1 m, EA = 1e5 N
/// (engineering). It must hang: each half (unstretched 1.05 m) goes taut at
/// w = sqrt(1.05² − 1) = 0.320156 m, and the micro-load adds a stretch T L0/EA ≈ 1.7e-11 m.
/// REFERENCE: `hanging_string` (P = 2 T w/l, T = EA (l − L0)/L0, bisection). Tolerances: w within
/// 1e-9 m (geometry; round-off 1e-16 of l), T within 1e-4 relative (strain 1.6e-11 carries a
/// round-off of ε_mach/1.6e-11 ≈ 7e-6), vertical reaction = P within 1e-4 P (same floor).
#[test]
fn f2_micro_load_on_a_slack_cable_longer_than_its_chord() {
    let mut scene = read_scene(&shipped("PrestressedCable"));
    scene.cables[0].pretension = None;
    scene.cables[0].unstretched_length = Some(2.1);
    scene
        .parameters
        .retain(|p| !p.target.ends_with("pretension"));
    let mut e = engine(scene);
    solve(&mut e);
    set(&mut e, "P", 1e-6);
    let report = e.solve();
    if std::env::var("VLOG").is_ok() {
        println!("{}", report.log.join("\n"));
    }
    assert!(report.converged(), "{}", report.message);
    let (w_ref, t_ref) = hanging_string(1e5, 1.05, 1e-6);
    let (w, t, rz) = (
        -get(&e, "midspan_uz"),
        get(&e, "tension"),
        get(&e, "reaction_z"),
    );
    println!("(f2) w = {w:.12} vs {w_ref:.12}, T = {t:e} vs {t_ref:e}, Rz = {rz:e}");
    assert!((w - w_ref).abs() < 1e-9, "w = {w} vs {w_ref}");
    assert!(rel(t, t_ref) < 1e-4, "T = {t} vs {t_ref}");
    assert!((rz - 1e-6).abs() < 1e-10, "reaction {rz} vs 1e-6");
}

// ---------------------------------------------------------------------------------------------
// (g) Unloading a flat membrane to exactly 0 Pa.
// ---------------------------------------------------------------------------------------------

/// CASE (g), issue 9: the HenckyDisc at 48 rings, loaded to 40 Pa (follower) and then unloaded
/// to exactly 0 Pa in one step. On the solver of 79af9e6: 30 s, then Discard; now one increment
/// of 53 iterations (3.7 s): linear convergence at the singular flat state, allowed past
/// max_iterations while the residual keeps halving (docs/solver.md).
/// REFERENCE: at q = 0 the potential is the (relaxed) strain energy >= 0, zero only where the film
/// is stress-free, and a stress-free state with a clamped circular rim is the flat reference
/// itself (a non-stretching map of the disc that fixes its rim is the identity), so u = 0.
/// TOLERANCE: |u|∞ <= 1e-2 · w0(40 Pa). Near the flat state w ∝ q^(1/3) (Hencky, §4a), so a
/// converged state that leaves a residual equivalent to a pressure q_r sits at
/// w0(40 Pa) (q_r/40 Pa)^(1/3); the bound asks q_r < 1e-6 · 40 Pa. A tighter bound would ask more
/// than the relative criterion 1e-9 can promise through the cube root (1e-9 of the removed load
/// already allows 1e-3 · w0). The loaded state is checked first: w0/a = 0.065404 within 0.2 %.
/// Time (issue target < 2 s) is printed, not asserted.
#[test]
fn g_unloading_a_flat_membrane_to_zero() {
    let mut scene = read_scene(&shipped("HenckyDisc"));
    let Generator::Disc { rings, .. } = &mut scene.geometry.generators[0] else {
        panic!("HenckyDisc is a disc")
    };
    *rings = 48;
    let mut e = engine(scene);
    solve(&mut e);
    set(&mut e, "pressure", 40.0);
    let r = timed("(g) load to 40 Pa", || e.solve());
    assert!(r.converged(), "{}", r.message);
    let w40 = get(&e, "center_uz");
    assert!(
        rel(w40 / 0.5, 0.065404) < 2e-3,
        "w0/a = {} at 40 Pa",
        w40 / 0.5
    );
    set(&mut e, "pressure", 0.0);
    let report = timed("(g) unload to 0 Pa", || e.solve());
    assert!(report.converged(), "{}", report.message);
    let n = e.model().reference.len();
    let umax = (0..n).map(|k| disp(&e, k).norm()).fold(0.0, f64::max);
    println!(
        "(g) w0(40 Pa) = {w40:.6e} m, |u|max at 0 Pa = {umax:.3e} m, {} iterations",
        report.iterations
    );
    assert!(
        umax <= 1e-2 * w40,
        "|u|max = {umax:e} m after unloading (w0 = {w40:e})"
    );
}

// ---------------------------------------------------------------------------------------------
// (h) A two-sheet cushion inflated from flat, rim free in its plane.
// ---------------------------------------------------------------------------------------------

const CUSHION_N: usize = 16;
const CUSHION_S: f64 = 1.0;
const CUSHION_P: f64 = 40.0;

/// Node id of the top sheet's grid point (i, j).
fn top(i: usize, j: usize) -> usize {
    j * (CUSHION_N + 1) + i
}

/// Node id of the bottom sheet's grid point (i, j): the rim is shared with the top sheet.
fn bottom(i: usize, j: usize) -> usize {
    let n = CUSHION_N;
    if i == 0 || j == 0 || i == n || j == n {
        top(i, j)
    } else {
        (n + 1) * (n + 1) + (j - 1) * (n - 1) + (i - 1)
    }
}

/// Square cushion: two sheets on one grid (crossed diagonals, symmetric under x, y mirrors and
/// x ↔ y), the bottom sheet's triangles reversed so that the follower pressure pushes each sheet
/// outward. Rim held in z (the mid-plane: exact by top/bottom symmetry); rigid in-plane modes
/// removed by symmetry conditions only: the rim nodes on x = s/2 held in x, those on y = s/2
/// held in y. `two_sheets: false` is the half model (top sheet only).
fn cushion(two_sheets: bool) -> Scene {
    let n = CUSHION_N;
    let h = CUSHION_S / n as f64;
    let mut nodes = Vec::new();
    for j in 0..=n {
        for i in 0..=n {
            nodes.push([i as f64 * h, j as f64 * h, 0.0]);
        }
    }
    if two_sheets {
        for j in 1..n {
            for i in 1..n {
                nodes.push([i as f64 * h, j as f64 * h, 0.0]);
            }
        }
    }
    let mut triangles = Vec::new();
    let sheets: &[bool] = if two_sheets { &[true, false] } else { &[true] };
    for &is_top in sheets {
        let id = |i, j| if is_top { top(i, j) } else { bottom(i, j) };
        for j in 0..n {
            for i in 0..n {
                let (a, b, c, d) = (id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1));
                let pair = if (i + j) % 2 == 0 {
                    [[a, b, c], [a, c, d]]
                } else {
                    [[a, b, d], [b, c, d]]
                };
                for t in pair {
                    triangles.push(if is_top { t } else { [t[0], t[2], t[1]] });
                }
            }
        }
    }
    let rim: Vec<usize> = (0..=n)
        .flat_map(|j| (0..=n).map(move |i| (i, j)))
        .filter(|&(i, j)| i == 0 || j == 0 || i == n || j == n)
        .map(|(i, j)| top(i, j))
        .collect();
    let m = n / 2;
    scene_of(json!({
        "format": 1, "name": "Cushion",
        "geometry": {"nodes": nodes, "triangles": triangles,
                     "node_sets": {"rim": rim, "sym_x": [top(m, 0), top(m, n)], "sym_y": [top(0, m), top(n, m)],
                                   "centre": [top(m, m)]},
                     "triangle_sets": {"all": (0..triangles.len()).collect::<Vec<_>>()}},
        "membranes": [{"name": "film", "triangles": "all", "thickness": 1e-4,
                       "material": {"kind": "svk", "E": 2e8, "nu": 0.3}}],
        "supports": [{"nodes": "rim", "fix": ["z"]}, {"nodes": "sym_x", "fix": ["x"]}, {"nodes": "sym_y", "fix": ["y"]}],
        "inputs": [{"name": "p", "load": {"kind": "pressure", "membrane": "film", "follower": true}}],
        "outputs": [
            {"name": "w", "probe": {"kind": "displacement", "node": "centre", "component": "z"}},
            {"name": "smax", "probe": {"kind": "max_principal_stress"}}
        ]
    }))
}

/// CASE (h), issue 9: a flat two-sheet square cushion (s = 1 m, 16 x 16 cells per sheet, SVK
/// E = 200 MPa, ν = 0.3, t = 0.1 mm, wrinkling on) inflated from flat by a follower pressure of
/// 40 Pa, its shared rim free to move in its plane (`cushion` above). Today it fails at load
/// fraction 0 on every mesh finer than 8 x 8.
/// REFERENCE (exact consequences and a hand bound):
/// (1) top/bottom mirror: the bottom sheet's node (i, j) is the top one's mirrored in z;
/// (2) the x-mirror, y-mirror and x ↔ y symmetries of the square;
///     (1)-(2) within 1e-6 of the largest displacement (residual 1e-9 of the load over a
///     stiffness of order p s gives ~1e-9 m against ~0.1 m);
/// (3) every reaction vanishes: by the mirror symmetries the held DOFs carry nothing (the
///     pressure on the closed cushion is self-equilibrated), within 1e-7 p s² per DOF;
/// (4) the half model (top sheet only, rim held in z) is the same problem by symmetry: its centre
///     rise agrees within 1e-6 relative;
/// (5) bound: 0 < w_c <= (s/2)(1 + 2 σmax/E)^(1/2): the centre rises at most the stretched length
///     of the material line to an edge midpoint (Green strain <= σ1/E in a taut or wrinkled SVK
///     element, since ε2 >= −ν ε1 there); and the edge midpoints move inward (the rim contracts).
#[test]
fn h_two_sheet_cushion_inflated_from_flat() {
    let n = CUSHION_N;
    let mut e = engine(cushion(true));
    set(&mut e, "p", CUSHION_P);
    let report = e.solve();
    assert!(report.converged(), "{}", report.message);
    let wc = get(&e, "w");
    let smax = get(&e, "smax");
    let count = e.model().reference.len();
    let umax = (0..count).map(|k| disp(&e, k).norm()).fold(0.0, f64::max);
    println!(
        "(h) centre rise {wc:.6} m, σmax {smax:.4e} Pa, |u|max {umax:.4e}, {} iterations",
        report.iterations
    );
    let tol = 1e-6 * umax;
    for j in 0..=n {
        for i in 0..=n {
            let u = disp(&e, top(i, j));
            let ub = disp(&e, bottom(i, j));
            let close = |a: f64, b: f64| (a - b).abs() <= tol;
            assert!(
                close(ub.x, u.x) && close(ub.y, u.y) && close(ub.z, -u.z),
                "top/bottom ({i}, {j}): {u:?} vs {ub:?}"
            );
            let ux = disp(&e, top(n - i, j));
            assert!(
                close(ux.x, -u.x) && close(ux.y, u.y) && close(ux.z, u.z),
                "x-mirror ({i}, {j})"
            );
            let uy = disp(&e, top(i, n - j));
            assert!(
                close(uy.x, u.x) && close(uy.y, -u.y) && close(uy.z, u.z),
                "y-mirror ({i}, {j})"
            );
            let ud = disp(&e, top(j, i));
            assert!(
                close(ud.x, u.y) && close(ud.y, u.x) && close(ud.z, u.z),
                "diagonal ({i}, {j})"
            );
        }
    }
    let residual = e.residual();
    let held = &e.model().held;
    let worst = (0..held.len())
        .filter(|&d| held[d])
        .map(|d| residual[d].abs())
        .fold(0.0, f64::max);
    assert!(
        worst <= 1e-7 * CUSHION_P * CUSHION_S * CUSHION_S,
        "largest reaction {worst:e} N"
    );
    assert!(wc > 0.0, "the top sheet rises");
    let bound = 0.5 * CUSHION_S * (1.0 + 2.0 * smax / 2e8).sqrt();
    assert!(
        wc <= bound,
        "centre rise {wc} above the material-line bound {bound}"
    );
    assert!(disp(&e, top(n, n / 2)).x < 0.0, "the rim contracts");
    let mut half = engine(cushion(false));
    set(&mut half, "p", CUSHION_P);
    let r = half.solve();
    assert!(r.converged(), "half model: {}", r.message);
    assert!(
        rel(get(&half, "w"), wc) < 1e-6,
        "half model {} vs two sheets {wc}",
        get(&half, "w")
    );
}

// ---------------------------------------------------------------------------------------------
// (i) The sheared film at 0.1 mm separation.
// ---------------------------------------------------------------------------------------------

const SHEAR_H: f64 = 0.128;
/// Triangles of the centre cell of WrinkledShear (column 19 of 38, row 6 of 13).
const SHEAR_CENTRE: [usize; 2] = [494, 495];

/// CASE (i), issue 9: the shipped WrinkledShear scene with the separation set to 0.1 mm
/// (ε0 = 7.8e-4; today up to 2,572 iterations in one step and Discard at step 11), sheared
/// 0 → 3 mm in 20 steps. Every step must converge.
/// REFERENCE: as tests/verification/wrinkled_shear.rs (docs/mechanics.md §4c): the centre deforms as the
/// homogeneous F = [[1, δ/H], [0, 1 + s/H]], its stress is the tension-field SVK law at that
/// strain. State equal; tension direction within 0.5° (as there); S12 within 1 % (as there);
/// S11 and S22 within 2 % once wrinkled (S22 only while taut: the Poisson contraction toward the
/// free edges lowers S11 at the centre). Why 2 % and not 1 %: at this low pretension the free-edge
/// end effects reach the centre more strongly. Measured on the solver of 79af9e6 at the centre:
/// S11 1.0-1.13 %, S22 0.4-0.97 %, S12 0.1-0.2 % over steps 2-10 (identical with tolerance 1e-12,
/// so it is the model, not the iteration), and at δ = 3 mm, reached by another path (shear at
/// 1 mm separation, then lower the separation to 0.1 mm), S11 1.18 %, S22 1.05 %, S12 0.09 %,
/// tension direction 0.31° off. Onset δ_c = 1.5649 ε0 H = 0.1565 mm, so step 1 (0.15 mm) is taut.
/// ITERATIONS (issue 9's target: median <= 8, at most 40 per step): every step must converge in
/// one increment, in at most 40 Newton iterations. Measured with the patch Newton of nodal
/// relaxation (docs/solver.md): median 6.5, at most 17 (rings order); upper medians 7-8 and at
/// most 19-24 with the rcm, hilbert and given orders, whose round-off differs. Before it:
/// median 18.5, up to 2797 iterations and 7 steps cut back. The median is printed, not
/// asserted (its margin is 0-1.5 iterations over the orders).
#[test]
fn i_sheared_film_with_a_tenth_of_a_millimetre_separation() {
    let separation = 1e-4;
    let mut e = engine(read_scene(&shipped("WrinkledShear")));
    set(&mut e, "separation", separation);
    solve(&mut e);
    let mut iterations = Vec::new();
    for k in 1..=20 {
        let shear = 3e-3 * k as f64 / 20.0;
        set(&mut e, "shear", shear);
        let report = e.solve();
        assert!(
            report.converged() && report.increments == 1 && report.iterations <= 40,
            "step {k} (δ = {shear}): {} increments, {} iterations, {}",
            report.increments,
            report.iterations,
            report.message
        );
        iterations.push(report.iterations);
        check_shear_centre(&e, shear, separation);
    }
    let mut sorted = iterations.clone();
    sorted.sort();
    println!(
        "(i) Newton iterations per step: {iterations:?}, median {}",
        0.5 * (sorted[9] + sorted[10]) as f64
    );
}

/// CASE (i'), issue 9: case (i) with the film's `residual_stiffness` set to 1e-4 (a wrinkled or
/// slack triangle keeps 1e-4 of its elastic stiffness, in stress, energy and tangent alike;
/// docs/mechanics.md §1.5). This makes the equilibrium isolated where the pure tension field
/// leaves the displacement across the tension undetermined (docs/solver.md, hard cases), at the
/// price of a compressive stress ρ E e₂ in wrinkled directions.
/// REFERENCE: as case (i) (the homogeneous tension field at the centre, same tolerances: the
/// residual stiffness moves the centre's stresses by about ρ E |e₂| ≈ 1e-4 · 3.5e9 · 1e-3 =
/// 350 Pa, 4e-5 of S11); every step converges in one increment.
/// Measured: median 5, largest 8 Newton iterations per step (6 / 12 before nodal relaxation's
/// patch Newton; case (i) without the option: 6.5 / 17 now, 18.5 / 2797 before).
#[test]
fn i2_sheared_film_with_a_residual_stiffness() {
    let separation = 1e-4;
    let mut scene = read_scene(&shipped("WrinkledShear"));
    for m in &mut scene.membranes {
        m.residual_stiffness = Some(1e-4);
    }
    let mut e = engine(scene);
    set(&mut e, "separation", separation);
    solve(&mut e);
    let mut iterations = Vec::new();
    for k in 1..=20 {
        let shear = 3e-3 * k as f64 / 20.0;
        set(&mut e, "shear", shear);
        let report = e.solve();
        assert!(
            report.converged() && report.increments == 1,
            "step {k} (δ = {shear}): {} increments, {}",
            report.increments,
            report.message
        );
        iterations.push(report.iterations);
        check_shear_centre(&e, shear, separation);
    }
    let mut sorted = iterations.clone();
    sorted.sort();
    println!(
        "(i') residual stiffness 1e-4: Newton iterations per step {iterations:?}, median {}, largest {}",
        sorted[sorted.len() / 2],
        sorted[sorted.len() - 1]
    );
}

/// The centre of the sheared film against the homogeneous tension field (case i's reference and
/// tolerances, written in its header): state equal, S12 within 1 %, S11 and S22 within 2 %
/// (S22 only while taut), tension direction within 0.5°.
fn check_shear_centre(e: &Engine, shear: f64, separation: f64) {
    let (g, s) = (shear / SHEAR_H, separation / SHEAR_H);
    let strain = Vector3::new(0.0, 0.5 * (g * g + (1.0 + s) * (1.0 + s) - 1.0), g);
    let reference = Law::Svk {
        young: 3.5e9,
        nu: 0.3,
    }
    .response(&strain, None);
    for t in SHEAR_CENTRE {
        let ev = &e.membranes()[t];
        let tri = &e.model().triangles[t];
        let gs = tri.reference.to_global(&ev.stress);
        let stress = [gs[(0, 0)], gs[(1, 1)], gs[(0, 1)]];
        assert_eq!(ev.state, reference.state, "δ = {shear}: triangle {t} state");
        let compared = if ev.state == WrinkleState::Wrinkled {
            0..3
        } else {
            1..3
        };
        for c in compared {
            let tolerance = if c == 2 { 1e-2 } else { 2e-2 };
            assert!(
                rel(stress[c], reference.stress[c]) < tolerance,
                "δ = {shear}: triangle {t} S[{c}] = {} vs {}",
                stress[c],
                reference.stress[c]
            );
        }
        if ev.state == WrinkleState::Wrinkled {
            let d = tri.reference.direction(ev.angle);
            let angle = d.y.atan2(d.x).rem_euclid(std::f64::consts::PI);
            let expected = reference.angle.rem_euclid(std::f64::consts::PI);
            assert!(
                (angle - expected).abs().to_degrees() < 0.5,
                "δ = {shear}: {}° vs {}°",
                angle.to_degrees(),
                expected.to_degrees()
            );
        }
    }
}

// ---------------------------------------------------------------------------------------------
// (j) A rubber sheet pulled in-plane at one corner node.
// ---------------------------------------------------------------------------------------------

/// The rubber sheet of cases j and j2 (8 x 8 cells, 80 mm, neo-Hookean mu 3e5 Pa, 0.5 mm, its
/// left edge clamped, every node held in z, a point force F in +x at the top right corner, the
/// left edge's reactions as outputs), with `solver` as its solver section.
fn corner_pull(solver: serde_json::Value) -> Scene {
    scene_of(json!({
        "format": 1, "name": "CornerPull",
        "geometry": {"generators": [{"kind": "rectangle", "name": "sheet", "origin": [0.0, 0.0, 0.0],
                                     "size": [0.08, 0.08], "divisions": [8, 8]}]},
        "membranes": [{"name": "rubber", "triangles": "sheet", "thickness": 5e-4,
                       "material": {"kind": "neo_hookean", "mu": 3e5}}],
        "supports": [{"nodes": "sheet.edge_left", "fix": ["x", "y", "z"]}, {"nodes": "sheet.all", "fix": ["z"]}],
        "inputs": [{"name": "F", "load": {"kind": "point_force", "nodes": "sheet.corner_tr", "direction": [1.0, 0.0, 0.0]}}],
        "outputs": [
            {"name": "Rx", "probe": {"kind": "reaction", "nodes": "sheet.edge_left", "component": "x"}},
            {"name": "Ry", "probe": {"kind": "reaction", "nodes": "sheet.edge_left", "component": "y"}}
        ],
        "solver": solver
    }))
}

/// CASE (j), issue 9: an 80 mm rubber sheet (8 x 8 cells, crossed, neo-Hookean μ = 300 kPa,
/// t = 0.5 mm, wrinkling on), left edge clamped, all nodes held in z, pulled at its top-right
/// corner node by F = 1 N in +x (a point load: large local stretch, slack and wrinkled regions).
/// REFERENCE: (1) global balance: the left-edge reactions sum to (−F, 0) within 1e-7 F
/// (72 free nodes × the criterion 1e-9 F); (2) the tension field fans from the loaded corner:
/// near a point load the tension-field solution is a centred fan (straight tension rays through
/// the load point, zero hoop stress), so in every wrinkled triangle that carries the load path's
/// stress (major principal stress at least 1 % of the sheet's largest) the tension direction is
/// closer to the ray towards the corner than to the hoop direction (angle < 45°, a generous bound
/// for CST triangles seen from the corner under up to 45°; the largest deviation is printed).
/// Triangles below 1 % are left out because their direction is not determined: a wrinkled
/// triangle under a stress of 1e-8 to 1e3 Pa (against 4.0e5 Pa at the corner) is an equilibrium
/// for any tension direction to within the criterion; measured on this mesh, the 43 triangles
/// above 1 % lie within 42.2° of the ray, the 29 below scatter up to 86°;
/// (3) the two triangles at the loaded corner carry tension (not slack) and the corner moves in +x.
/// Solved in one increment: 42 Newton iterations, the wrinkle states of the chattering triangles
/// frozen from iteration 6, found wrong at the frozen equilibrium and then left to the law for
/// the rest of the increment (docs/solver.md, chatter).
#[test]
fn j_rubber_sheet_pulled_at_one_corner() {
    let scene = corner_pull(json!({}));
    let mut e = engine(scene);
    set(&mut e, "F", 1.0);
    let report = e.solve();
    assert!(report.converged(), "{}", report.message);
    let (rx, ry) = (get(&e, "Rx"), get(&e, "Ry"));
    let corner = 8 * 9 + 8;
    let corner_ref = e.model().reference[corner];
    println!(
        "(j) R = ({rx}, {ry}), corner moves {:?}, {} iterations",
        disp(&e, corner),
        report.iterations
    );
    assert!(
        (rx + 1.0).abs() < 1e-7 && ry.abs() < 1e-7,
        "reactions ({rx}, {ry}) vs (−1, 0)"
    );
    assert!(disp(&e, corner).x > 0.0);
    let mut worst: f64 = 0.0;
    let peak = e
        .membranes()
        .iter()
        .map(|ev| ev.cauchy.0)
        .fold(0.0_f64, f64::max);
    let mut checked = 0;
    for (t, tri) in e.model().triangles.iter().enumerate() {
        let ev = &e.membranes()[t];
        let touches = tri.nodes.contains(&corner);
        if touches {
            assert_ne!(
                ev.state,
                WrinkleState::Slack,
                "triangle {t} at the loaded corner is slack"
            );
        }
        if ev.state != WrinkleState::Wrinkled || touches || ev.cauchy.0 < 0.01 * peak {
            continue;
        }
        checked += 1;
        let centroid = tri
            .nodes
            .iter()
            .map(|&k| e.model().reference[k])
            .sum::<Vector3<f64>>()
            / 3.0;
        let ray = (corner_ref - centroid).normalize();
        let d = tri.reference.direction(ev.angle);
        let angle = d.dot(&ray).abs().min(1.0).acos().to_degrees();
        worst = worst.max(angle);
        assert!(
            angle < 45.0,
            "triangle {t}: tension {angle:.1}° off the ray to the loaded corner"
        );
    }
    println!(
        "(j) largest deviation from the fan ray in the {checked} wrinkled triangles above 1 % of the peak stress {peak:.3e} Pa: {worst:.1}°"
    );
    assert!(
        checked >= 20,
        "only {checked} wrinkled triangles carry the load path"
    );
}

/// CASE (j2), docs/solver.md ("A release of frozen ... states restarts the count"): case (j) with
/// `solver.max_iterations` 40. Its increment meets the tolerance with chattering wrinkle states
/// frozen at iteration 32, the re-check finds them wrong there, they are released, and the
/// law's own problem converges 12 iterations later (44 in all, measured; case j's log). The
/// iterations after a release count from it, so the increment converges whole, with case j's
/// reactions (-1, 0) N to 1e-7 as there. Before, the budget counted from the increment's start
/// and the increment was cut back at iteration 40 (this test then fails: more than one
/// increment).
#[test]
fn j2_a_release_of_frozen_states_restarts_the_iteration_budget() {
    let scene = corner_pull(json!({"max_iterations": 40}));
    let mut e = engine(scene);
    set(&mut e, "F", 1.0);
    let report = e.solve();
    let released = report
        .log
        .iter()
        .any(|l| l.contains("frozen states were wrong at convergence"));
    println!(
        "(j2) {} increments, {} iterations, released: {released}",
        report.increments, report.iterations
    );
    assert!(released, "the path no longer releases frozen states");
    assert!(
        report.converged() && report.increments == 1 && report.iterations > 40,
        "{} increments, {} iterations: {}",
        report.increments,
        report.iterations,
        report.message
    );
    let (rx, ry) = (get(&e, "Rx"), get(&e, "Ry"));
    assert!(
        (rx + 1.0).abs() < 1e-7 && ry.abs() < 1e-7,
        "reactions ({rx}, {ry}) vs (−1, 0)"
    );
}

// ---------------------------------------------------------------------------------------------
// (l) docs/solver.md hard-case list.
// ---------------------------------------------------------------------------------------------

/// CASE (l1), docs/solver.md (hard cases): a flat, stress-free cable net loaded normal to its plane.
/// Two crossing cables (x and y axes, half-span L = 1 m, EA = 1e5 N, SVK law, no pretension)
/// share the centre node; P = 10 N in −z there. DERIVATION: by symmetry the four segments carry
/// one tension T = EA w² l/(2L³) (SVK, L0 = L, as in f1); vertical balance P = 4 T w/l gives
/// w = L (P/(2EA))^(1/3) = 0.0368403 m exactly. Singular at u = 0 (no stiffness in any
/// direction). Tolerance 1e-8 m (as §4g's cable test); the centre stays on the z axis (1e-12 m).
#[test]
fn l1_flat_stress_free_cable_net_cubic_law() {
    let scene = scene_of(json!({
        "format": 1, "name": "CableCross",
        "geometry": {"nodes": [[0.0, 0.0, 0.0], [-1.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 1.0, 0.0]],
                     "node_sets": {"ends": [1, 2, 3, 4], "centre": [0]}},
        "cables": [{"name": "cx", "nodes": [1, 0, 2], "EA": 1e5, "strain": "green_lagrange"},
                   {"name": "cy", "nodes": [3, 0, 4], "EA": 1e5, "strain": "green_lagrange"}],
        "supports": [{"nodes": "ends", "fix": ["x", "y", "z"]}],
        "inputs": [{"name": "P", "load": {"kind": "point_force", "nodes": "centre", "direction": [0.0, 0.0, -1.0]}}],
        "outputs": [{"name": "Rz", "probe": {"kind": "reaction", "nodes": "ends", "component": "z"}}]
    }));
    let mut e = engine(scene);
    set(&mut e, "P", 10.0);
    let report = e.solve();
    assert!(report.converged(), "{}", report.message);
    let w_ref = (10.0f64 / 2e5).cbrt();
    let c = disp(&e, 0);
    println!(
        "(l1) w = {:.10} vs {w_ref:.10}, Rz = {}, {} iterations",
        -c.z,
        get(&e, "Rz"),
        report.iterations
    );
    assert!((-c.z - w_ref).abs() < 1e-8, "w = {} vs {w_ref}", -c.z);
    assert!(
        c.x.abs() < 1e-12 && c.y.abs() < 1e-12,
        "centre drifted sideways: {c:?}"
    );
    assert!(
        (get(&e, "Rz") - 10.0).abs() < 1e-8,
        "reaction {}",
        get(&e, "Rz")
    );
}

/// CASE (l2), docs/solver.md (hard cases) (slack zones): a node between two collinear pretensioned
/// segments A = (−1, 0, 0) – N – B = (1, 0, 0) (EA = 1e4 N, T0 = 100 N, engineering) pulled along
/// the cable by F = 300 N > 2 T0 toward B: segment N–B goes slack (zero stiffness) and A–N alone
/// carries F. REFERENCE: T_a = F, l_a = L0 (1 + F/EA), L0 = 1/(1 + T0/EA), so
/// u_x = l_a − 1 = 0.0198019802 m; T_b = 0; N stays on the axis (held there by T_a/l_a).
/// Tolerance 1e-10 m (linear in the taut segment; residual 1e-9 F over EA/L0).
#[test]
fn l2_slack_segment_beside_a_taut_one() {
    let scene = scene_of(json!({
        "format": 1, "name": "SlackSide",
        "geometry": {"nodes": [[-1.0, 0.0, 0.0], [0.0, 0.0, 0.0], [1.0, 0.0, 0.0]],
                     "node_sets": {"ends": [0, 2], "node": [1]}},
        "cables": [{"name": "c", "nodes": [0, 1, 2], "EA": 1e4, "pretension": 100.0}],
        "supports": [{"nodes": "ends", "fix": ["x", "y", "z"]}],
        "inputs": [{"name": "F", "load": {"kind": "point_force", "nodes": "node", "direction": [1.0, 0.0, 0.0]}}],
        "outputs": [
            {"name": "Ta", "probe": {"kind": "cable_tension", "cable": "c", "segment": 0}},
            {"name": "Tb", "probe": {"kind": "cable_tension", "cable": "c", "segment": 1}}
        ]
    }));
    let mut e = engine(scene);
    set(&mut e, "F", 300.0);
    let report = e.solve();
    assert!(report.converged(), "{}", report.message);
    let l0 = 1.0 / (1.0 + 100.0 / 1e4);
    let u_ref = l0 * (1.0 + 300.0 / 1e4) - 1.0;
    let u = disp(&e, 1);
    println!(
        "(l2) u = {u:?} vs {u_ref:.10}, Ta {} Tb {}",
        get(&e, "Ta"),
        get(&e, "Tb")
    );
    assert!((u.x - u_ref).abs() < 1e-10, "u_x = {} vs {u_ref}", u.x);
    assert!(u.y.abs() < 1e-12 && u.z.abs() < 1e-12);
    assert!(rel(get(&e, "Ta"), 300.0) < 1e-9);
    assert_eq!(get(&e, "Tb"), 0.0, "the slack segment carries nothing");
}

const SPHERE_MU: f64 = 1e5;
const SPHERE_H: f64 = 1e-3;
/// p_max R/(μH) of the incompressible neo-Hookean thin sphere (docs/mechanics.md §4i).
const SPHERE_PMAX: f64 = 1.239463;

/// Neo-Hookean sphere (R = 1 m, H = 1 mm, μ = 100 kPa) under follower pressure, held by its mirror
/// symmetry planes only: nodes on x = 0 held in x, on y = 0 in y, on z = 0 in z.
fn sphere() -> Scene {
    let (nodes, triangles) = octasphere(8, 1.0);
    let on = |c: usize| -> Vec<usize> {
        (0..nodes.len())
            .filter(|&k| nodes[k][c].abs() < 1e-12)
            .collect()
    };
    scene_of(json!({
        "format": 1, "name": "Balloon",
        "geometry": {"nodes": nodes, "triangles": triangles,
                     "node_sets": {"px": on(0), "py": on(1), "pz": on(2)},
                     "triangle_sets": {"all": (0..triangles.len()).collect::<Vec<_>>()}},
        "membranes": [{"name": "rubber", "triangles": "all", "thickness": SPHERE_H,
                       "material": {"kind": "neo_hookean", "mu": SPHERE_MU}}],
        "supports": [{"nodes": "px", "fix": ["x"]}, {"nodes": "py", "fix": ["y"]}, {"nodes": "pz", "fix": ["z"]}],
        "inputs": [{"name": "p", "load": {"kind": "pressure", "membrane": "rubber", "follower": true}}]
    }))
}

/// Mean stretch r/R over the nodes.
fn mean_stretch(e: &Engine) -> f64 {
    let n = e.model().reference.len();
    (0..n).map(|k| pos(e, k).norm()).sum::<f64>() / n as f64
}

/// CASE (l3), docs/solver.md (hard cases) (follower pressure; inflation): the neo-Hookean sphere
/// (`sphere`, octahedral mesh with 8 divisions per edge, 512 CST) inflated to p = 0.7 p_max.
/// REFERENCE: docs/mechanics.md §4i, p R/(μH) = 2(λ⁻¹ − λ⁻⁷) on the stable branch λ < 7^(1/6):
/// λ = 1.116751 at 0.7 p_max (bisection here). Tolerance on the mean nodal stretch: 0.5 %, for
/// the faceting error of a 512-triangle inscribed polyhedron (an O(h²/R²) effect; measured
/// 1.114210, i.e. −0.23 %, on the solver of 79af9e6, which converges here in 6 iterations).
#[test]
fn l3_follower_pressure_inflates_a_rubber_sphere() {
    let mut e = engine(sphere());
    let p = 0.7 * SPHERE_PMAX * SPHERE_MU * SPHERE_H;
    set(&mut e, "p", p);
    let report = e.solve();
    assert!(report.converged(), "{}", report.message);
    let target = 0.7 * SPHERE_PMAX;
    let lambda = bisect(1.0, 7f64.powf(1.0 / 6.0), |l| {
        2.0 * (1.0 / l - l.powi(-7)) - target
    });
    let measured = mean_stretch(&e);
    println!(
        "(l3) λ = {measured:.6} vs {lambda:.6}, {} iterations",
        report.iterations
    );
    assert!(rel(measured, lambda) < 5e-3, "λ = {measured} vs {lambda}");
}

/// CASE (l4), docs/solver.md (hard cases) (limit point under load control): the same sphere,
/// equilibrated at 0.7 p_max, then asked for 1.2 p_max. Beyond p_max = 1.239463 μH/R the
/// pressure-stretch curve of the sphere has no point (docs/mechanics.md §4i; the discrete maximum is
/// within the faceting error of l3, 0.2 %, far below the 20 % asked for): no equilibrium exists under
/// pressure control, so the step must FAIL, commit nothing (state and outputs as before) and say
/// why (a non-empty message).
#[test]
fn l4_beyond_the_limit_point_fails_and_keeps_the_state() {
    let mut e = engine(sphere());
    let pmax = SPHERE_PMAX * SPHERE_MU * SPHERE_H;
    set(&mut e, "p", 0.7 * pmax);
    let first = e.solve();
    assert!(first.converged(), "{}", first.message);
    let before = e.state().clone();
    let outputs = e.outputs();
    set(&mut e, "p", 1.2 * pmax);
    let report = timed("(l4) step beyond the limit point", || e.solve());
    println!(
        "(l4) converged {}, reached {:.4}, message: {}",
        report.converged(),
        report.reached,
        report.message
    );
    assert!(
        !report.converged(),
        "no equilibrium exists beyond p_max; mean λ = {}",
        mean_stretch(&e)
    );
    assert!(!report.message.is_empty());
    let mut kept = e.state().clone();
    kept.inputs = before.inputs.clone();
    assert_eq!(
        kept, before,
        "a failed step must not change the committed state"
    );
    assert_eq!(e.outputs(), outputs);
}

/// Exact position of a node hanging from two tension-only engineering-law segments of unstretched
/// lengths `la`, `lb` from A = (0, 0) and B = (2, 0), under a vertical load P (downwards), by
/// Newton on (x, z) with a finite-difference Jacobian, started from the inextensible point.
fn two_segment_string(ea: f64, la: f64, lb: f64, p: f64) -> [f64; 2] {
    let force = |x: f64, z: f64| -> [f64; 2] {
        let mut f = [0.0, -p];
        for (ax, l0) in [(0.0, la), (2.0, lb)] {
            let (dx, dz) = (ax - x, -z);
            let l = (dx * dx + dz * dz).sqrt();
            let t = ea * ((l - l0) / l0).max(0.0);
            f[0] += t * dx / l;
            f[1] += t * dz / l;
        }
        f
    };
    let x0 = (la * la - lb * lb + 4.0) / 4.0;
    let (mut x, mut z) = (x0, -(la * la - x0 * x0).sqrt() - 1e-6);
    for _ in 0..100 {
        let f = force(x, z);
        let h = 1e-9;
        let (fx, fz) = (force(x + h, z), force(x, z + h));
        let j = [
            [(fx[0] - f[0]) / h, (fz[0] - f[0]) / h],
            [(fx[1] - f[1]) / h, (fz[1] - f[1]) / h],
        ];
        let det = j[0][0] * j[1][1] - j[0][1] * j[1][0];
        let dx = -(j[1][1] * f[0] - j[0][1] * f[1]) / det;
        let dz = -(-j[1][0] * f[0] + j[0][0] * f[1]) / det;
        x += dx;
        z += dz;
        if dx.abs() + dz.abs() < 1e-15 {
            break;
        }
    }
    let f = force(x, z);
    assert!(
        f[0].abs() < 1e-9 && f[1].abs() < 1e-9,
        "reference did not converge: {f:?}"
    );
    [x, z]
}

/// CASE (l5), docs/solver.md (hard cases): an initially slack cable longer than its chord hangs under
/// a point load. A = (0, 0, 0), B = (2, 0, 0), the load node N starts on the chord at x = 0.7;
/// the cable's unstretched length 2.4 m is shared in proportion to the initial lengths (0.84 m and
/// 1.56 m), EA = 1e5 N (engineering), P = 100 N in −z at N. REFERENCE: statics of a two-segment
/// string, T_a e_a + T_b e_b = (0, P), T = EA (l − L0)/L0 (`two_segment_string`, Newton to 1e-15;
/// near the inextensible point x = 0.568, z = −0.6189). Tolerance 1e-8 m (§4g's cable tolerance).
#[test]
fn l5_slack_cable_longer_than_its_chord_hangs() {
    let scene = scene_of(json!({
        "format": 1, "name": "Hang",
        "geometry": {"nodes": [[0.0, 0.0, 0.0], [0.7, 0.0, 0.0], [2.0, 0.0, 0.0]],
                     "node_sets": {"ends": [0, 2], "node": [1]}},
        "cables": [{"name": "c", "nodes": [0, 1, 2], "EA": 1e5, "unstretched_length": 2.4}],
        "supports": [{"nodes": "ends", "fix": ["x", "y", "z"]}],
        "inputs": [{"name": "P", "load": {"kind": "point_force", "nodes": "node", "direction": [0.0, 0.0, -1.0]}}]
    }));
    let mut e = engine(scene);
    set(&mut e, "P", 100.0);
    let report = e.solve();
    assert!(report.converged(), "{}", report.message);
    let [x, z] = two_segment_string(1e5, 0.84, 1.56, 100.0);
    let p = pos(&e, 1);
    println!(
        "(l5) N = ({:.10}, {:.3e}, {:.10}) vs ({x:.10}, 0, {z:.10})",
        p.x, p.y, p.z
    );
    assert!(
        (p.x - x).abs() < 1e-8 && (p.z - z).abs() < 1e-8 && p.y.abs() < 1e-8,
        "N at {p:?} vs ({x}, 0, {z})"
    );
}

/// CASE (l6), docs/solver.md (hard cases) / issue 9 "Bad input": a true mechanism. A pretensioned
/// cable (nodes 0..=11, both ends fixed) and, unconnected to it and unsupported, a membrane square
/// of two triangles (nodes 12..=15) loaded by 1 N in x: no support or load can stop its rigid-body
/// motion, no equilibrium exists. REQUIRED: a failure (at scene check or at the solve) whose
/// message says it is a mechanism / free / rigid-body motion and names the free nodes 12, 13, 14
/// and 15; if the failure comes from the solve, nothing is committed. (Fails today: the solver
/// reports a generic "no equilibrium found".)
#[test]
fn l6_true_mechanism_fails_naming_the_free_nodes() {
    let mut nodes: Vec<[f64; 3]> = (0..12).map(|k| [k as f64 * 0.1, 0.0, 0.0]).collect();
    nodes.extend([
        [0.0, 1.0, 0.0],
        [0.2, 1.0, 0.0],
        [0.2, 1.2, 0.0],
        [0.0, 1.2, 0.0],
    ]);
    let scene = scene_of(json!({
        "format": 1, "name": "Floating",
        "geometry": {"nodes": nodes, "triangles": [[12, 13, 14], [12, 14, 15]],
                     "node_sets": {"ends": [0, 11], "corner": [14]}},
        "membranes": [{"name": "patch", "triangles": [0, 1], "thickness": 1e-4,
                       "material": {"kind": "svk", "E": 2e8, "nu": 0.3}}],
        "cables": [{"name": "c", "nodes": (0..12).collect::<Vec<_>>(), "EA": 1e4, "pretension": 10.0}],
        "supports": [{"nodes": "ends", "fix": ["x", "y", "z"]}],
        "inputs": [{"name": "F", "load": {"kind": "point_force", "nodes": "corner", "direction": [1.0, 0.0, 0.0]}}]
    }));
    let names_free_nodes = |message: &str| {
        let lower = message.to_lowercase();
        let tokens: Vec<&str> = lower
            .split(|c: char| !c.is_ascii_digit())
            .filter(|s| !s.is_empty())
            .collect();
        let says_why = ["mechanism", "rigid", "free", "unconstrained", "unsupported"]
            .iter()
            .any(|w| lower.contains(w));
        assert!(
            says_why,
            "the message must say the structure is a mechanism: {message}"
        );
        for id in ["12", "13", "14", "15"] {
            assert!(
                tokens.contains(&id),
                "the message must name free node {id}: {message}"
            );
        }
    };
    match Engine::try_new(scene) {
        Err(err) => names_free_nodes(&err.to_string()),
        Ok(mut e) => {
            set(&mut e, "F", 1.0);
            let before = e.state().displacement.clone();
            let report = e.solve();
            println!(
                "(l6) converged {}, message: {}",
                report.converged(),
                report.message
            );
            assert!(
                !report.converged(),
                "a floating patch under load has no equilibrium"
            );
            assert_eq!(e.state().displacement, before, "nothing committed");
            names_free_nodes(&report.message);
        }
    }
}

// ---------------------------------------------------------------------------------------------
// (m) A flat square with edge cables inflated from a stress-free start.
// ---------------------------------------------------------------------------------------------

/// (m) The flat, stress-free square with edge cables of `examples/scale.rs` (4 m x 4 m, 1 mm,
/// SVK E 600 MPa, nu 0.3, four edge cables EA 2e6 N, pretension 2 kN, corners pinned) under a
/// follower pressure of 300 Pa in ONE step from flat, 58 x 58 cells (10k DOF). The edges are
/// free in the plane (the cables sag inward as the sheet bulges), the corners wrinkle, and the
/// first Newton steps meet wrinkle-state switches everywhere. Until the slope line search
/// bracketed the line's minimum (docs/solver.md, "Line search") this took 35 iterations here and
/// failed at 100k DOF (cut back to a load fraction of 1e-4).
/// REFERENCE (exact statics): the follower pressure on the triangulated sheet sums to
/// p · A, A = ½ Σ x_k × x_{k+1} the vector area of its deformed boundary polygon (the
/// triangles' area vectors telescope to it), and the cables' and sheet's internal forces sum to
/// zero, so the four corner reactions sum to −p · A. Tolerance 1e-8 of p |A| (measured 1.05e-9):
/// the criterion allows 1e-9 · F per free DOF, F ≈ 7.4e3 N (the largest force carried), so the
/// sum over 3481 nodes could in principle reach 3.5e-6 F, but converged residuals do not add up
/// in one direction; 1e-8 is ten times what is reached and far below any unbalanced load.
/// Also: one increment, no cut-back, at most 30 Newton iterations (measured 26), and the centre
/// rises (the pressure pushes +z on the counter-clockwise sheet).
#[test]
fn m_flat_square_with_edge_cables_inflated_from_a_stress_free_start() {
    let n = 58;
    let scene = inflated_square(n, json!({}));
    let mut e = engine(scene);
    solve(&mut e);
    set(&mut e, "wind", 300.0);
    let report = timed("(m) flat square, 300 Pa from flat", || e.solve());
    println!(
        "(m) {} iterations, {} increments, {} cut-backs, centre {:.6} m",
        report.iterations,
        report.increments,
        report.cutbacks,
        get(&e, "center_uz")
    );
    assert!(report.converged(), "{}", report.message);
    assert_eq!(
        (report.increments, report.cutbacks),
        (1, 0),
        "one increment"
    );
    assert!(report.iterations <= 30, "{} iterations", report.iterations);
    assert!(get(&e, "center_uz") > 0.0, "the sheet bulges up");
    let error = corner_balance(&e, n);
    assert!(error < 1e-8, "corner reactions vs -p A: {error:.2e}");
}

/// (m2) The prestress continuation (docs/solver.md, "Prestress continuation"). The square of
/// (m) with `max_iterations` 16: its direct flat start needs 26 iterations (hard case m), so
/// every increment fails, cut back to 1e-4 of the load, and the step fails (asserted with the
/// continuation switched off: an outcome, nothing committed). With the continuation (default
/// pre-strain 1e-3, then 2.5e-4, ..., 3.9e-6, 0) the failed first increment is solved again
/// through the pre-strained problems, each within its iteration budget (the first stage took
/// 20: a release of frozen states restarts the count, docs/solver.md), and the step converges
/// in one increment.
/// REFERENCES: the exact statics of (m) (corner reactions = −p A, tolerance 1e-8 as there) and
/// the equilibrium of (m)'s direct path: the last problem of the continuation is the scene's
/// own, so only the path differs. Every node's position agrees with the direct path's within
/// 1e-9 m (measured 2.1e-10 m, centre 0.318051488 against 0.318051487 m: both paths stop
/// somewhere within the convergence test's 1e-9 · F of equilibrium, F 7.4e3 N, and the wrinkled
/// corners are soft across their wrinkles, so the two stopping points differ by more than
/// round-off; 1e-9 m is five times what is measured and a millionth of the 0.3 m deflection).
/// Measured: 59 iterations (16 of the failed direct attempt, then 20, 7, 6, 4, 3, 3). The
/// overshoot continuation, which runs before it where it applies, is off in both runs
/// (`solver.overshoot_continuation` 0): this case is the prestress continuation's. So is the
/// coarse start (`solver.coarse_start`, which would start this generated mesh from the answer
/// on coarser ones and take neither path): off in every run.
#[test]
fn m2_the_prestress_continuation_solves_a_flat_start_the_direct_path_cannot() {
    let n = 58;
    let mut direct = engine(inflated_square(n, json!({"coarse_start": "off"})));
    solve(&mut direct);
    set(&mut direct, "wind", 300.0);
    assert!(solve(&mut direct).converged());

    let mut off = engine(inflated_square(
        n,
        json!({"max_iterations": 16, "prestress_continuation": 0.0, "overshoot_continuation": 0.0, "coarse_start": "off"}),
    ));
    solve(&mut off);
    let before = off.state().displacement.clone();
    set(&mut off, "wind", 300.0);
    let report = off.solve();
    println!("(m2) without the continuation: {}", report.message);
    assert!(
        !report.converged(),
        "16 iterations are too few for the direct path"
    );
    assert_eq!(off.state().displacement, before, "nothing committed");

    let mut e = engine(inflated_square(
        n,
        json!({"max_iterations": 16, "overshoot_continuation": 0.0, "coarse_start": "off"}),
    ));
    solve(&mut e);
    set(&mut e, "wind", 300.0);
    let report = timed("(m2) flat square through the continuation", || e.solve());
    let stages: Vec<&String> = report
        .log
        .iter()
        .filter(|l| l.contains("prestress continuation:"))
        .collect();
    println!(
        "(m2) {} iterations, {} increments, {} cut-backs; {stages:?}",
        report.iterations, report.increments, report.cutbacks
    );
    assert!(report.converged(), "{}", report.message);
    assert_eq!((report.increments, report.cutbacks), (1, 0));
    assert_eq!(
        stages.len(),
        6,
        "pre-strain 1e-3 / 4^k for k = 0..4, then 0"
    );
    assert!(stages.last().unwrap().contains("pre-strain 0.00e0"));
    let error = corner_balance(&e, n);
    assert!(error < 1e-8, "corner reactions vs -p A: {error:.2e}");
    let nodes = e.model().reference.len();
    let apart = (0..nodes)
        .map(|k| (pos(&e, k) - pos(&direct, k)).norm())
        .fold(0.0, f64::max);
    println!(
        "(m2) centre {:.9} m vs {:.9} m by the direct path; largest node distance {apart:.2e} m",
        get(&e, "center_uz"),
        get(&direct, "center_uz")
    );
    assert!(
        apart < 1e-9,
        "{apart:e} m from the direct path's equilibrium"
    );
}

/// (m3) No prestress continuation with friction in a sleeve: its stick/slip history would take
/// in the pre-strained problems' slips, so the answer would depend on the continuation, not
/// only on the path (docs/solver.md). The square of (m) at 20 x 20 cells with its edge cables
/// in sleeves and `max_iterations` 16 fails from flat either way (the direct start needs more,
/// and the continuation's first stage too); ASSERTED: with μ = 0.3 the step fails without
/// trying the continuation (its message does not mention it), with μ = 0 (frictionless,
/// conservative) it tries it. Nothing is committed in either case.
#[test]
fn m3_no_prestress_continuation_with_friction_in_a_sleeve() {
    for mu in [0.3, 0.0] {
        let mut scene = inflated_square(20, json!({"max_iterations": 16}));
        for c in &mut scene.cables {
            c.sleeve = Some(serde_json::from_value(json!({ "mu": mu })).unwrap());
        }
        let mut e = engine(scene);
        assert!(e.solve().converged());
        let before = e.state().displacement.clone();
        set(&mut e, "wind", 300.0);
        let report = e.solve();
        println!("(m3) μ = {mu}: {}", report.message);
        assert!(!report.converged(), "μ = {mu}: converged");
        assert_eq!(e.state().displacement, before, "nothing committed");
        let tried = report
            .message
            .contains("the prestress continuation was tried");
        assert_eq!(tried, mu == 0.0, "μ = {mu}: {}", report.message);
    }
}

const SQUARE_CORNERS: [&str; 4] = ["corner_bl", "corner_br", "corner_tr", "corner_tl"];

/// The inflated square of (m) at `n` x `n` cells with the scene's `solver` section.
pub(crate) fn inflated_square(n: usize, solver: serde_json::Value) -> Scene {
    let corners = SQUARE_CORNERS;
    let mut outputs = vec![
        json!({"name": "center_uz", "probe": {"kind": "displacement", "node": "sheet.center", "component": "z"}}),
    ];
    for c in corners {
        for k in ["x", "y", "z"] {
            outputs.push(json!({"name": format!("{c}_{k}"), "probe": {"kind": "reaction", "nodes": format!("sheet.{c}"), "component": k}}));
        }
    }
    let edge = |name: &str| json!({"name": name, "nodes": format!("sheet.{name}"), "EA": 2e6, "pretension": 2000.0});
    scene_of(json!({
        "format": 1, "name": "InflatedSquare",
        "geometry": {"generators": [{"kind": "rectangle", "name": "sheet", "origin": [0, 0, 0], "size": [4.0, 4.0], "divisions": [n, n]}]},
        "membranes": [{"name": "fabric", "triangles": "sheet", "thickness": 1e-3, "material": {"kind": "svk", "E": 6e8, "nu": 0.3}}],
        "cables": [edge("edge_bottom"), edge("edge_right"), edge("edge_top"), edge("edge_left")],
        "supports": corners.iter().map(|c| json!({"nodes": format!("sheet.{c}"), "fix": ["x", "y", "z"]})).collect::<Vec<_>>(),
        "inputs": [{"name": "wind", "load": {"kind": "pressure", "membrane": "fabric", "follower": true}, "start": 0, "min": -1000, "max": 300}],
        "outputs": outputs,
        "solver": solver
    }))
}

/// |corner reactions + p A| / |p A| of the inflated square (`inflated_square`) at 300 Pa: the
/// exact statics of (m).
pub(crate) fn corner_balance(e: &Engine, n: usize) -> f64 {
    let corners = SQUARE_CORNERS;
    let mesh = velarium::scene::generate::resolve(&e.scene().geometry);
    // The boundary nodes in counter-clockwise order around the square's centre.
    let mut boundary: Vec<usize> = ["edge_bottom", "edge_right", "edge_top", "edge_left"]
        .iter()
        .flat_map(|s| mesh.node_sets[&format!("sheet.{s}")].clone())
        .collect();
    boundary.sort_unstable();
    boundary.dedup();
    let angle = |k: usize| {
        let x = mesh.nodes[k];
        (x[1] - 2.0).atan2(x[0] - 2.0)
    };
    boundary.sort_by(|&a, &b| angle(a).total_cmp(&angle(b)));
    assert_eq!(boundary.len(), 4 * n);
    let mut area = Vector3::zeros();
    for (k, &a) in boundary.iter().enumerate() {
        let b = boundary[(k + 1) % boundary.len()];
        area += 0.5 * pos(e, a).cross(&pos(e, b));
    }
    let mut reaction = Vector3::zeros();
    for c in corners {
        for (i, k) in ["x", "y", "z"].iter().enumerate() {
            reaction[i] += get(e, &format!("{c}_{k}"));
        }
    }
    let load = 300.0 * area;
    let error = (reaction + load).norm() / load.norm();
    println!(
        "(m) corner reactions {reaction:?} vs -p A {:?}: {error:.2e}",
        -load
    );
    error
}

/// Keep the `Load` import honest: the tests above build loads through JSON; this checks the
/// one Rust-built variant the suite relies on (HenckyDisc's follower pressure) is what it says.
#[test]
fn shipped_scenes_used_here_are_what_the_headers_say() {
    let disc = read_scene(&shipped("HenckyDisc"));
    assert!(matches!(
        disc.inputs[0].load,
        Load::Pressure { follower: true, .. }
    ));
    let cable = read_scene(&shipped("PrestressedCable"));
    assert_eq!(
        (cable.cables[0].ea, cable.cables[0].pretension),
        (1e5, Some(100.0))
    );
    assert_eq!(cable.cables[0].strain, StrainLaw::Engineering);
}
