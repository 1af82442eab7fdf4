//! GOAL: frictionless sliding gives equal tensions across every sliding node and a loaded
//!       sliding node runs to the kink; with friction the equilibrium is a distinct one held by
//!       contact forces.
//! MESH: (a) a cable A(−1,0)–N–B(1,0) of two segments through one free sliding node N that starts
//!       off-centre at x = −0.4; (b) the shipped SlidingCable scene (seed Fig. 6: A–7–8–9–B, loads P
//!       on node 8 and p on nodes 7 and 9, soft tethers holding 7 and 9 outward).
//! BOUNDARY CONDITIONS: A and B fixed; all nodes move in the x-y plane only.
//! PARAMETERS: (a) EA = 1e4 N, pretension T0 = 100 N (engineering), P = 100 N on N, μ = 0;
//!       (b) the scene's values, P = 200 N, p = 20 N, μ = 0 and μ = 0.3.
//! REFERENCE: (a) statics of a frictionless pulley: the node sits where both segments make the
//!       same angle, x = 0, with T = EA(l − L)/L, l = 2√(1 + w²), L = 2/(1 + T0/EA), P = 2Tw/√(1+w²)
//!       (w by bisection here, to 1e-14), plus the tie stretch P/k_c of the default penalty
//!       k_c = 100 EA/ℓ_min between the cable's kink and the node; tolerance 1e-8 in x and w, 1e-6 relative on the
//!       tension equality. (b) seed paper §4: "in the first case the nodes 7 and 9 converge to the
//!       node 8" (frictionless); tension equality to 1e-6 relative; nodes 7 and 9 move toward
//!       8; with μ = 0.3 they move less and the tensions differ (bisector Coulomb,
//!       |T_b − T_a| cos(Δθ/2) ≤ μ (T_a + T_b) sin(Δθ/2) at every node, docs/mechanics.md §2.3).

mod common;
use common::*;
use velarium::Scene;

fn pulley_scene(mu: f64) -> Scene {
    let json = serde_json::json!({
        "format": 1, "name": "Pulley",
        "geometry": {"nodes": [[-1.0, 0.0, 0.0], [-0.4, 0.0, 0.0], [1.0, 0.0, 0.0]],
                     "node_sets": {"ends": [0, 2], "node": [1]}},
        "cables": [{"name": "cable", "nodes": [0, 1, 2], "EA": 1e4, "pretension": 100.0,
                    "sleeve": {"mu": mu}}],
        "supports": [{"nodes": "ends", "fix": ["x", "y", "z"]}, {"nodes": "node", "fix": ["z"]}],
        "inputs": [{"name": "P", "load": {"kind": "point_force", "nodes": "node",
                    "direction": [0.0, -1.0, 0.0]}}],
        "outputs": [
            {"name": "x", "probe": {"kind": "position", "node": "node", "component": "x"}},
            {"name": "y", "probe": {"kind": "position", "node": "node", "component": "y"}},
            {"name": "Ta", "probe": {"kind": "cable_tension", "cable": "cable", "segment": 0}},
            {"name": "Tb", "probe": {"kind": "cable_tension", "cable": "cable", "segment": 1}},
            {"name": "contact", "probe": {"kind": "contact_force", "cable": "cable"}}
        ]
    });
    Scene::from_json(&json.to_string()).unwrap()
}

/// Sag of the symmetric frictionless pulley (bisection on P(w) − P).
fn pulley_sag(ea: f64, t0: f64, p: f64) -> (f64, f64) {
    let l0 = 2.0 / (1.0 + t0 / ea);
    let force = |w: f64| {
        let l = 2.0 * (1.0 + w * w).sqrt();
        let t = ea * (l - l0) / l0;
        (2.0 * t * w / (1.0 + w * w).sqrt(), t)
    };
    let (mut lo, mut hi) = (0.0, 1.0);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if force(mid).0 < p {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    (lo, force(lo).1)
}

#[test]
fn frictionless_pulley_node_runs_to_the_kink() {
    let mut e = engine(pulley_scene(0.0));
    set(&mut e, "P", 100.0);
    let report = solve(&mut e);
    let (w, t) = pulley_sag(1e4, 100.0, 100.0);
    // The node hangs below the kink by the tie stretch P/k, k = 100 EA/ℓ_min (ℓ_min = 0.6 m).
    let w = w + 100.0 / (100.0 * 1e4 / 0.6);
    let (x, y) = (get(&e, "x"), get(&e, "y"));
    println!(
        "pulley: x = {x:.3e} (start −0.4), w = {:.10} vs {w:.10}, Ta {:.9} Tb {:.9} T {t:.9}, {} iterations",
        -y,
        get(&e, "Ta"),
        get(&e, "Tb"),
        report.iterations
    );
    assert!(
        x.abs() < 1e-8,
        "the node sits at the symmetric kink x = 0, not {x}"
    );
    assert!((-y - w).abs() < 1e-8);
    assert!(rel(get(&e, "Ta"), get(&e, "Tb")) < 1e-6);
    assert!(rel(get(&e, "Ta"), t) < 1e-6);
}

#[test]
fn pulley_with_friction_stops_off_centre() {
    let mut e = engine(pulley_scene(0.3));
    set(&mut e, "P", 100.0);
    solve(&mut e);
    let (x, ta, tb) = (get(&e, "x"), get(&e, "Ta"), get(&e, "Tb"));
    println!("pulley μ = 0.3: x = {x:.6}, Ta {ta:.6} Tb {tb:.6}");
    assert!(
        x < -0.01,
        "friction holds the node away from the centre (x = {x})"
    );
    assert!(
        rel(ta, tb) > 1e-3,
        "the tensions differ across a sticking or slipping node"
    );
}

fn seed_fig6(mu: f64) -> velarium::Engine {
    let mut e = engine(read_scene(&shipped("SlidingCable")));
    set(&mut e, "mu", mu);
    set(&mut e, "P", 200.0);
    set(&mut e, "p", 20.0);
    solve(&mut e);
    e
}

#[test]
fn seed_fig6_frictionless_equal_tensions_and_nodes_gather_at_8() {
    let e = seed_fig6(0.0);
    let t: Vec<f64> = ["T_A7", "T_78", "T_89", "T_9B"]
        .iter()
        .map(|n| get(&e, n))
        .collect();
    let d79 = (get(&e, "x9") - get(&e, "x7")).abs();
    println!("Fig. 6 frictionless: tensions {t:?}, |x9 − x7| = {d79:.4} (start 2)");
    for k in 1..4 {
        assert!(rel(t[k], t[0]) < 1e-6, "segment {k}: {} vs {}", t[k], t[0]);
    }
    assert!(
        get(&e, "x7") > 1.2 && get(&e, "x9") < 2.8,
        "7 and 9 slide toward 8"
    );
    assert!(get(&e, "contact_gap") < 1e-3);
    let f = seed_fig6(0.3);
    let d79f = (get(&f, "x9") - get(&f, "x7")).abs();
    let tf: Vec<f64> = ["T_A7", "T_78", "T_89", "T_9B"]
        .iter()
        .map(|n| get(&f, n))
        .collect();
    println!("Fig. 6 μ = 0.3: tensions {tf:?}, |x9 − x7| = {d79f:.4}");
    assert!(d79f > d79, "friction keeps 7 and 9 farther from 8");
    assert!(
        rel(tf[1], tf[0]) > 1e-3,
        "friction carries a tension difference"
    );
    assert!(get(&f, "contact7") > 0.0 && get(&f, "contact8") > 0.0);
}
