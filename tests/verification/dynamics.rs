//! GOAL: generalized-α time integration (`dynamics.time_integration`, src/solver/dynamic.rs)
//!       is second order in the time step for every ρ∞, conserves energy at ρ∞ = 1 in the
//!       linear regime over 1000 periods, ends a slowly applied, damped load on the static
//!       equilibrium, and gives a membrane's free vibration the period of its modal analysis.
//! MESH: (1)-(3) a mass m = 1 kg on a taut cable, two segments of 1 m each, pretension
//!       T = 100 N, EA = 1000 N (the transverse motion of the mass is a linear oscillator
//!       with k = 2T/ℓ = 200 N/m up to the cable's stretch, of relative size
//!       (EA/T)(w/ℓ)² ≈ 1e-9 at the amplitudes used); (4) a clamped prestressed rectangle
//!       1 m x 0.7 m, 12 x 8 cells, N = 1000 N/m, ρt = 1 kg/m², under a uniform pressure;
//!       (5) the same rectangle, released from a small pressure.
//! BOUNDARY CONDITIONS: cable ends pinned, the mass held in x and y; rectangle clamped.
//! PARAMETERS: per case below; solver.tolerance 1e-14 in (1)-(3) so that the Newton
//!       residual (relative to the cable's 100 N) stays below the inertia forces' 1e-3 N by
//!       far more than the discretisation error.
//! REFERENCE:
//!   (1) the linear oscillator m ẅ + k w = F(t), at rest at t = 0, under the ramp
//!       F = P t/τ (t ≤ τ), P (t ≥ τ) (Duhamel's integral; Clough & Penzien 2003, *Dynamics of
//!       Structures*, §6-2 and §4-4):  w = (P/k)(t/τ − sin ωt/(ωτ)) for t ≤ τ,
//!       w = (P/k)(1 − (sin ωt − sin ω(t−τ))/(ωτ)) after, ω = √(k/m);
//!       generalized-α is second order (Chung & Hulbert 1993, J. Appl. Mech. 60:371-375):
//!       the error at a fixed time falls by 4x per halved step.
//!   (2) the trapezoidal rule (ρ∞ = 1) conserves the energy of a linear system exactly
//!       (Hughes 2000, *The Finite Element Method*, §9.3.2): kinetic plus strain energy
//!       constant over 1000 periods.
//!   (3) loaded over many periods with mass-proportional damping, the end state is the
//!       static equilibrium under the final load (the inertia and damping forces vanish).
//!   (4) a membrane's free vibration released from a pressure has the period 1/f₁₁ of the
//!       modal analysis of the same mesh (`Engine::modes`, verified against the closed form
//!       in natural_frequencies.rs); measured from the zero crossings of the centre's
//!       displacement about the equilibrium.
//! TOLERANCE: stated at each assertion, a small multiple of what was measured (printed with
//!   `cargo test --release --test verification dynamics -- --nocapture`).

use crate::common::*;
use std::f64::consts::PI;
use velarium::{Engine, Scene};

const T0: f64 = 100.0;
const MASS: f64 = 1.0;
/// k = 2 T0 / ℓ with ℓ = 1 m.
const K: f64 = 2.0 * T0;

fn omega() -> f64 {
    (K / MASS).sqrt()
}

fn period() -> f64 {
    2.0 * PI / omega()
}

fn scene(json: serde_json::Value) -> Scene {
    Scene::from_json(&json.to_string()).unwrap_or_else(|p| panic!("{p}"))
}

/// The mass on the taut cable, with generalized-α of `rho_inf` and sub-steps of at most `dt`.
fn oscillator(rho_inf: f64, dt: f64, alpha: f64) -> Engine {
    engine(scene(serde_json::json!({
        "format": 1, "name": "Oscillator",
        "geometry": {"nodes": [[0, 0, 0], [1, 0, 0], [2, 0, 0]],
                     "node_sets": {"ends": [0, 2], "mid": [1]}},
        "cables": [{"name": "c", "nodes": [0, 1, 2], "EA": 1000.0, "strain": "engineering",
                    "pretension": T0}],
        "supports": [{"nodes": "ends", "fix": ["x", "y", "z"]},
                     {"nodes": "mid", "fix": ["x", "y"]}],
        "inputs": [{"name": "P", "load": {"kind": "point_force", "nodes": "mid",
                                          "direction": [0, 0, 1]}, "start": 0}],
        "outputs": [
            {"name": "w", "probe": {"kind": "displacement", "node": "mid", "component": "z"}},
            {"name": "v", "probe": {"kind": "velocity", "node": "mid", "component": "z"}},
            {"name": "a", "probe": {"kind": "acceleration", "node": "mid", "component": "z"}},
            {"name": "ke", "probe": {"kind": "kinetic_energy"}},
            {"name": "se", "probe": {"kind": "strain_energy"}}
        ],
        "solver": {"tolerance": 1e-14},
        "dynamics": {"point_masses": [{"nodes": "mid", "mass": MASS}],
                     "rayleigh_alpha": alpha,
                     "time_integration": {"rho_inf": rho_inf, "max_time_step": dt}}
    })))
}

/// One step of length `h` to the input value `p`.
fn step(e: &mut Engine, p: f64, h: f64) {
    set(e, "P", p);
    e.set_step_duration(h);
    let report = e.solve();
    assert!(report.converged(), "{}", report.message);
}

/// Duhamel's w(t) of the ramp to P over τ (module docs).
fn ramp_response(p: f64, tau: f64, t: f64) -> f64 {
    let w = omega();
    if t <= tau {
        p / K * (t / tau - (w * t).sin() / (w * tau))
    } else {
        p / K * (1.0 - ((w * t).sin() - (w * (t - tau)).sin()) / (w * tau))
    }
}

// (1) The ramp P = 2e-3 N (static deflection 1e-5 m) over τ = T/4, then held to t = 1.5 T;
// sub-steps T/32 ... T/256; w(1.5 T) against Duhamel's closed form, for ρ∞ = 1, 0.8 and 0.
#[test]
fn ramp_response_converges_at_second_order() {
    let p = 2e-3;
    let (tau, end) = (0.25 * period(), 1.5 * period());
    let exact = ramp_response(p, tau, end);
    for rho in [1.0, 0.8, 0.0] {
        let mut errors = Vec::new();
        for n in [32.0, 64.0, 128.0, 256.0] {
            let mut e = oscillator(rho, period() / n, 0.0);
            solve(&mut e);
            step(&mut e, p, tau);
            step(&mut e, p, end - tau);
            errors.push((get(&e, "w") - exact) / (p / K));
        }
        let orders: Vec<f64> = errors.windows(2).map(|w| (w[0] / w[1]).log2()).collect();
        println!("ramp, rho_inf {rho}: errors / (P/k) {errors:.3?}, orders {orders:.3?}");
        // Measured orders 1.97-2.02 (ρ∞ = 0), 2.00-2.005 (ρ∞ = 1, 0.8).
        for o in &orders {
            assert!((1.9..2.1).contains(o), "rho_inf {rho}: order {o}");
        }
    }
}

// (2) Released from the static deflection under P = 2e-3 N (the load removed over one sub-step
// of T/20), then 1000 periods free at 20 sub-steps per period with ρ∞ = 1: the oscillator's
// energy ½ m v² + ½ k w², sampled once per period (from the outputs w and v: the strain energy
// output holds the cable's pretension energy, 1e5 times larger, whose round-off would hide the
// comparison; the kinetic energy output is checked against ½ m v² on the way).
#[test]
fn trapezoidal_rule_conserves_energy_over_1000_periods() {
    let p = 2e-3;
    let dt = period() / 20.0;
    let mut e = oscillator(1.0, dt, 0.0);
    set(&mut e, "P", p);
    solve(&mut e);
    step(&mut e, 0.0, dt);
    let energy = |e: &Engine| {
        let (w, v) = (get(e, "w"), get(e, "v"));
        assert!(rel(get(e, "ke"), 0.5 * MASS * v * v) < 1e-12);
        0.5 * MASS * v * v + 0.5 * K * w * w
    };
    let mut energies = vec![energy(&e)];
    for _ in 0..1000 {
        step(&mut e, 0.0, period());
        energies.push(energy(&e));
    }
    let (lo, hi) = energies
        .iter()
        .fold((f64::INFINITY, 0.0f64), |(l, h), &x| (l.min(x), h.max(x)));
    // The exact release (Duhamel, the ramp from P to 0 over dt): w = P/k − r(t), r the ramp
    // response, at t = dt.
    let r = ramp_response(p, dt, dt);
    let v = {
        let w = omega();
        p / K * (1.0 - (w * dt).cos()) / dt
    };
    let exact = 0.5 * K * (p / K - r).powi(2) + 0.5 * MASS * v * v;
    println!(
        "energy over 1000 periods: {lo:.9e} .. {hi:.9e} J (exact release {exact:.9e}), spread {:.2e}",
        (hi - lo) / hi
    );
    assert!(rel(hi, exact) < 0.05, "energy {hi} vs {exact}");
    assert!((hi - lo) / hi < 1e-9, "spread {}", (hi - lo) / hi);
}

// ρ∞ < 1 dissipates: the same release at ρ∞ = 0.5 loses energy period by period (the highest
// frequencies most; at ωΔt = 2π/20 a few per cent per period).
#[test]
fn high_frequency_dissipation_below_one() {
    let p = 2e-3;
    let dt = period() / 20.0;
    let mut e = oscillator(0.5, dt, 0.0);
    let rest = get(&e, "se");
    set(&mut e, "P", p);
    solve(&mut e);
    step(&mut e, 0.0, dt);
    step(&mut e, 0.0, period());
    let first = get(&e, "ke") + get(&e, "se") - rest;
    step(&mut e, 0.0, 10.0 * period());
    let later = get(&e, "ke") + get(&e, "se") - rest;
    println!("rho_inf 0.5: energy {first:.6e} -> {later:.6e} J over 10 periods");
    assert!(later < 0.99 * first, "{later} vs {first}");
    assert!(later > 0.0);
}

// (3) The membrane under a pressure ramped to 200 Pa over 20 of its first periods, damped by
// Rayleigh α = 2ζω₁₁ (ζ = 0.2), then held for 20 more: the centre's deflection (nonlinear:
// about 13 mm) against the static solve under 200 Pa.
#[test]
fn slow_damped_loading_ends_on_the_static_equilibrium() {
    let json = |dynamic: bool| {
        let mut s = sheet(0.0);
        if dynamic {
            let f11 = 0.5 * 1000f64.sqrt() * (1.0f64 + 1.0 / 0.49).sqrt();
            s["dynamics"] = serde_json::json!({
                "rayleigh_alpha": 2.0 * 0.2 * 2.0 * PI * f11,
                "time_integration": {"rho_inf": 0.8, "max_time_step": 0.1 / f11}
            });
        }
        scene(s)
    };
    let mut quasi = engine(json(false));
    solve(&mut quasi);
    set(&mut quasi, "p", 200.0);
    solve(&mut quasi);
    let target = get(&quasi, "w");

    let mut e = engine(json(true));
    solve(&mut e);
    let f11 = 0.5 * 1000f64.sqrt() * (1.0f64 + 1.0 / 0.49).sqrt();
    step_named(&mut e, "p", 200.0, 20.0 / f11);
    let ramped = get(&e, "w");
    step_named(&mut e, "p", 200.0, 20.0 / f11);
    let w = get(&e, "w");
    println!(
        "slow loading: w {w:.9e} m (after the ramp {ramped:.6e}), static {target:.9e}, relative {:.2e}",
        rel(w, target)
    );
    // Measured 1e-9 (the decay of the residual motion, e^{-ζω·20T} ≈ 1e-11, and the tolerance).
    assert!(rel(w, target) < 1e-7, "{w} vs {target}");
    assert!(target.abs() > 5e-3);
}

/// The clamped prestressed rectangle of (3) and (4): 1 m x 0.7 m, 12 x 8 cells, N = 1 kN/m,
/// ρt = 1 kg/m², its pressure `p` starting at `p0` and the centre's deflection `w`.
fn sheet(p0: f64) -> serde_json::Value {
    serde_json::json!({
        "format": 1, "name": "Sheet",
        "geometry": {"generators": [{"kind": "rectangle", "name": "s", "origin": [0, 0, 0],
                                     "size": [1.0, 0.7], "divisions": [12, 8]}]},
        "membranes": [{"name": "m", "triangles": "s", "thickness": 0.001, "density": 1000.0,
                       "material": {"kind": "svk", "E": 1e9, "nu": 0.3},
                       "prestress": {"kind": "isotropic", "n": 1000.0}}],
        "supports": [{"nodes": "s.boundary", "fix": ["x", "y", "z"]}],
        "inputs": [{"name": "p", "load": {"kind": "pressure", "membrane": "m"}, "start": p0}],
        "outputs": [{"name": "w", "probe": {"kind": "displacement", "node": "s.center",
                                            "component": "z"}}]
    })
}

fn step_named(e: &mut Engine, name: &str, value: f64, h: f64) {
    set(e, name, value);
    e.set_step_duration(h);
    let report = e.solve();
    assert!(report.converged(), "{}", report.message);
}

/// Times of the upward zero crossings of `w - mean` (linear interpolation).
fn crossings(times: &[f64], w: &[f64], mean: f64) -> Vec<f64> {
    let mut out = Vec::new();
    for k in 1..w.len() {
        let (a, b) = (w[k - 1] - mean, w[k] - mean);
        if a < 0.0 && b >= 0.0 {
            out.push(times[k - 1] + (times[k] - times[k - 1]) * a / (a - b));
        }
    }
    out
}

// (4) The rectangle released from 1 Pa (deflection about 0.1 mm, the linear regime), ρ∞ = 1,
// 128 sub-steps per period of f₁₁, sampled at every sub-step over 40 periods: the mean period
// between upward zero crossings of the centre's deflection against 1/f₁₁ of `Engine::modes` on
// the same mesh. The trapezoidal rule lengthens the period by (ωΔt)²/12 = 0.02 % at this step
// (Hughes 2000, §9.3.2), and higher symmetric modes (f₃₁, f₁₃) move the crossings a little.
#[test]
fn free_vibration_period_equals_the_modal_period() {
    let mut json = sheet(1.0);
    json["dynamics"] = serde_json::json!({"time_integration": {"rho_inf": 1.0}});
    let s = scene(json);
    let mut e = engine(s);
    solve(&mut e);
    let f11 = e.modes(1).unwrap().frequencies[0];
    let dt = 1.0 / f11 / 128.0;
    let (mut times, mut w) = (vec![0.0], vec![get(&e, "w")]);
    step_named(&mut e, "p", 0.0, dt);
    times.push(dt);
    w.push(get(&e, "w"));
    for k in 2..=5120 {
        step_named(&mut e, "p", 0.0, dt);
        times.push(k as f64 * dt);
        w.push(get(&e, "w"));
    }
    let c = crossings(&times, &w, 0.0);
    let measured = (c[c.len() - 1] - c[0]) / (c.len() - 1) as f64;
    let expected = 1.0 / f11;
    println!(
        "free vibration: period {measured:.6e} s from {} crossings, 1/f11 {expected:.6e} s, relative {:+.3e}",
        c.len(),
        (measured - expected) / expected
    );
    // Measured −2.0e-4 (over 10 periods +1.0e-3: the higher symmetric modes shift single
    // crossings, and their effect on the mean falls with the number of periods).
    assert!(rel(measured, expected) < 1e-3, "{measured} vs {expected}");
}
