//! GOAL: generalized-α time integration (`dynamics.time_integration`, src/solver/dynamic.rs)
//!       is second order in the time step for every ρ∞, conserves energy at ρ∞ = 1 in the
//!       linear regime over 1000 periods, ends a slowly applied, damped load on the static
//!       equilibrium, and gives a membrane's free vibration the period of its modal analysis;
//!       the air's added mass and linear damping per unit area (`dynamics.air`) give the
//!       single mode's closed-form frequency and logarithmic decrement, in `Engine::modes`
//!       and in the time integration.
//! MESH: (1)-(3) a mass m = 1 kg on a taut cable, two segments of 1 m each, pretension
//!       T = 100 N, EA = 1000 N (the transverse motion of the mass is a linear oscillator
//!       with k = 2T/ℓ = 200 N/m up to the cable's stretch, of relative size
//!       (EA/T)(w/ℓ)² ≈ 1e-9 at the amplitudes used); (4) a clamped prestressed rectangle
//!       1 m x 0.7 m, 12 x 8 cells, N = 1000 N/m, ρt = 1 kg/m², under a uniform pressure;
//!       (5) the same rectangle, released from a small pressure; (5)-(6) the rectangle on
//!       20 x 14 and 12 x 8 cells split along one diagonal ("pattern": "right"), ρt = 1 kg/m²,
//!       air m_a = 0.5 kg/m², (6) c for ζ ≈ 0.02, released from 1 Pa, 64 steps per period
//!       over 12 periods.
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
//!   (5) the air's added mass m_a per unit area (`dynamics.air`) acts along the normal: the
//!       transverse frequencies of the prestressed rectangle become
//!       f_mn = ½ √(N/(ρt + m_a)) √((m/a)² + (n/b)²) = f_mn(ρt) √(ρt/(ρt + m_a)) (the
//!       membrane equation with the mass per area ρt + m_a; Graff 1975, *Wave Motion in
//!       Elastic Solids*, §4.3, for f_mn). On a grid with every cell split along the same
//!       diagonal, the linear triangles' stiffness is N times the 5-point Laplacian and the
//!       lumped mass is uniform, whose lowest eigenvalue is exact in closed form:
//!       ω₁₁² = N/(ρt + m_a) [(2/h_x)² sin²(π h_x/2a) + (2/h_y)² sin²(π h_y/2b)] (LeVeque
//!       2007, *Finite Difference Methods for ODEs and PDEs*, §3.4), and the sampled
//!       sin(iπ/n_x) sin(jπ/n_y) is its eigenvector.
//!   (6) with the air's linear damping c per unit area as well, the mode (1,1) is a single
//!       damped oscillator (mass, stiffness and damping all share the mode shape) with
//!       ζ = c / (2 ω (ρt + m_a)): logarithmic decrement δ = 2πζ/√(1 − ζ²) and period
//!       2π/(ω√(1 − ζ²)) (Clough & Penzien 2003, §2-5); ρ∞ = 1 is the trapezoidal rule, which
//!       on that oscillator multiplies the state by λ = (1 + μΔt/2)/(1 − μΔt/2) per step,
//!       μ = −ζω + iω√(1 − ζ²) (Hughes 2000, §9.3), so the discrete period 2πΔt/arg λ and
//!       decrement −2π ln|λ|/arg λ are closed forms too. The mode's amplitude is the
//!       projection Σ sin(iπ/n_x) sin(jπ/n_y) w_ij, exact on that grid.
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

/// ρt of the sheet (kg/m²), its prestress N (N/m), the air's added mass (kg/m²).
const RHO_T: f64 = 1.0;
const N_PRESTRESS: f64 = 1000.0;
const ADDED_MASS: f64 = 0.5;

/// f₁₁ of the continuum, 1 m x 0.7 m, mass per area `mass` (reference (5)).
fn f11_continuum(mass: f64) -> f64 {
    0.5 * (N_PRESTRESS / mass).sqrt() * (1.0f64 + 1.0 / 0.49).sqrt()
}

/// ω₁₁ of the 5-point Laplacian with a lumped mass `mass` per area on nx x ny cells
/// (reference (5)).
fn omega11_grid(mass: f64, nx: usize, ny: usize) -> f64 {
    let (hx, hy) = (1.0 / nx as f64, 0.7 / ny as f64);
    let lx = (2.0 / hx * (PI * hx / 2.0).sin()).powi(2);
    let ly = (2.0 / hy * (PI * hy / (2.0 * 0.7)).sin()).powi(2);
    (N_PRESTRESS / mass * (lx + ly)).sqrt()
}

/// The sheet on nx x ny cells, every cell split along the same diagonal (so that the
/// stiffness is the 5-point Laplacian times N and the lumped mass is uniform), its pressure
/// starting at `p0`, with `dynamics`.
fn sheet_with(nx: usize, ny: usize, p0: f64, dynamics: serde_json::Value) -> Scene {
    let mut json = sheet(p0);
    json["geometry"]["generators"][0]["divisions"] = serde_json::json!([nx, ny]);
    json["geometry"]["generators"][0]["pattern"] = serde_json::json!("right");
    json["dynamics"] = dynamics;
    scene(json)
}

// (5) The air's added mass m_a: f₁₁ = f₁₁(ρt) √(ρt/(ρt + m_a)), from `Engine::modes`.
#[test]
fn added_mass_lowers_the_frequency_by_the_closed_form_factor() {
    let ratio = (RHO_T / (RHO_T + ADDED_MASS)).sqrt();
    // Consistent mass, 20 x 14: against the continuum, and against the same mesh without air.
    let air = serde_json::json!([{"membrane": "m", "added_mass": ADDED_MASS}]);
    let f = |dynamics: serde_json::Value| {
        let mut e = engine(sheet_with(20, 14, 0.0, dynamics));
        solve(&mut e);
        e.modes(1).unwrap().frequencies[0]
    };
    let dry = f(serde_json::json!({}));
    let wet = f(serde_json::json!({"air": air}));
    let closed = f11_continuum(RHO_T) * ratio;
    println!(
        "added mass, consistent 20x14: f11 {wet:.6} Hz, closed form {closed:.6} Hz ({:+.3e}); dry {dry:.6} Hz, wet/dry − √(ρt/(ρt+m_a)) {:+.2e}",
        (wet - closed) / closed,
        wet / dry - ratio
    );
    // The mesh's own error (consistent mass, from above): measured +0.450 %.
    assert!(rel(wet, closed) < 6e-3, "{wet} vs {closed}");
    // On a flat sheet the transverse modes see M_z + (m_a/ρt) M_z: the ratio holds to the
    // eigensolver's round-off (measured 9e-16).
    assert!((wet / dry - ratio).abs() < 1e-12, "{wet} / {dry}");

    // Lumped mass, 12 x 8: the grid's closed form (5-point Laplacian, lumped mass).
    let mut e = engine(sheet_with(
        12,
        8,
        0.0,
        serde_json::json!({"mass": "lumped", "air": air}),
    ));
    solve(&mut e);
    let wet = e.modes(1).unwrap().frequencies[0];
    let grid = omega11_grid(RHO_T + ADDED_MASS, 12, 8) / (2.0 * PI);
    println!(
        "added mass, lumped 12x8: f11 {wet:.9} Hz, grid closed form {grid:.9} Hz ({:+.2e}), continuum {closed:.6} Hz ({:+.3e})",
        (wet - grid) / grid,
        (wet - closed) / closed
    );
    // Measured 2e-14 (the eigensolver's tolerance puts ω² within about 1e-12).
    assert!(rel(wet, grid) < 1e-11, "{wet} vs {grid}");
    // The grid's error against the continuum: measured −0.524 %.
    assert!(rel(wet, closed) < 8e-3, "{wet} vs {closed}");
}

/// The amplitude of the grid's mode (1,1) in the sheet's displacement: Σ sin(iπ/nx)
/// sin(jπ/ny) w_ij over the nodes (an exact eigenvector of K and the lumped M on this grid).
fn mode11_amplitude(e: &Engine, nx: usize, ny: usize) -> f64 {
    let u = &e.state().displacement;
    let mut q = 0.0;
    for j in 0..=ny {
        for i in 0..=nx {
            let s = (PI * i as f64 / nx as f64).sin() * (PI * j as f64 / ny as f64).sin();
            q += s * u[3 * (j * (nx + 1) + i) + 2];
        }
    }
    q
}

// (6) Free decay with the air's added mass and damping c: period and logarithmic decrement of
// the mode (1,1), against the single mode's closed form ζ = c / (2 ω (ρt + m_a)),
// δ = 2πζ/√(1−ζ²), T = 2π/(ω√(1−ζ²)); with the grid's ω (tight) and the continuum's (the
// mesh's error).
#[test]
fn air_damping_gives_the_closed_form_logarithmic_decrement() {
    let (nx, ny) = (12, 8);
    let mass = RHO_T + ADDED_MASS;
    let omega_c = 2.0 * PI * f11_continuum(mass);
    let zeta_target = 0.02;
    let c = 2.0 * zeta_target * omega_c * mass;
    let omega = omega11_grid(mass, nx, ny);
    let per_period = 64.0;
    let dt = 2.0 * PI / omega / per_period;
    let mut e = engine(sheet_with(
        nx,
        ny,
        1.0,
        serde_json::json!({
            "mass": "lumped",
            "air": [{"membrane": "m", "added_mass": ADDED_MASS, "damping": c}],
            "time_integration": {"rho_inf": 1.0}
        }),
    ));
    solve(&mut e);
    let mut q = vec![mode11_amplitude(&e, nx, ny)];
    let periods = 12;
    for _ in 0..periods * per_period as usize {
        step_named(&mut e, "p", 0.0, dt);
        q.push(mode11_amplitude(&e, nx, ny));
    }
    // Peaks by a parabola through the three samples about each maximum; upward zero crossings.
    let mut peaks = Vec::new();
    for k in 2..q.len() - 1 {
        let (a, b, cc) = (q[k - 1], q[k], q[k + 1]);
        if b > a && b >= cc && b > 0.0 {
            let x = 0.5 * (a - cc) / (a - 2.0 * b + cc);
            peaks.push((k as f64 + x, b - 0.25 * (a - cc) * x));
        }
    }
    let times: Vec<f64> = (0..q.len()).map(|k| k as f64 * dt).collect();
    let up = crossings(&times, &q, 0.0);
    let period = (up[up.len() - 1] - up[0]) / (up.len() - 1) as f64;
    let decrement = (peaks[0].1 / peaks[peaks.len() - 1].1).ln() / (peaks.len() - 1) as f64;

    // The single mode's closed forms.
    let closed = |omega: f64| {
        let zeta = c / (2.0 * omega * mass);
        let damped = omega * (1.0 - zeta * zeta).sqrt();
        (
            2.0 * PI / damped,
            2.0 * PI * zeta / (1.0 - zeta * zeta).sqrt(),
        )
    };
    let (t_grid, d_grid) = closed(omega);
    let (t_cont, d_cont) = closed(omega_c);
    // The trapezoidal rule on this mode: x_{n+1} = λ x_n, λ = (1 + μΔt/2)/(1 − μΔt/2), μ the
    // mode's continuous eigenvalue −ζω + iω√(1−ζ²).
    let zeta = c / (2.0 * omega * mass);
    let (mr, mi) = (
        -zeta * omega * dt / 2.0,
        omega * (1.0 - zeta * zeta).sqrt() * dt / 2.0,
    );
    let (nr, ni, dr, di) = (1.0 + mr, mi, 1.0 - mr, -mi);
    let d2 = dr * dr + di * di;
    let (lr, li) = ((nr * dr + ni * di) / d2, (ni * dr - nr * di) / d2);
    let (modulus, angle) = ((lr * lr + li * li).sqrt(), li.atan2(lr));
    let (t_step, d_step) = (2.0 * PI * dt / angle, -2.0 * PI * modulus.ln() / angle);
    println!(
        "air damping, lumped 12x8, ζ {zeta:.5}, {per_period} steps per period, {} peaks: period {period:.6e} s (trapezoidal closed form {t_step:.6e}: {:+.2e}; grid {t_grid:.6e}: {:+.2e}; continuum {t_cont:.6e}: {:+.2e}); decrement {decrement:.6} (trapezoidal {d_step:.6}: {:+.2e}; grid {d_grid:.6}: {:+.2e}; continuum {d_cont:.6}: {:+.2e})",
        peaks.len(),
        (period - t_step) / t_step,
        (period - t_grid) / t_grid,
        (period - t_cont) / t_cont,
        (decrement - d_step) / d_step,
        (decrement - d_grid) / d_grid,
        (decrement - d_cont) / d_cont,
    );
    // Against the trapezoidal rule's closed form on this mode (what the step reaches):
    // period measured −7.8e-7, decrement −6.1e-6 (the peaks' parabolic interpolation).
    assert!(rel(period, t_step) < 5e-6, "{period} vs {t_step}");
    assert!(rel(decrement, d_step) < 3e-5, "{decrement} vs {d_step}");
    // Against the single mode's closed form on the grid (the step's O((ωΔt)²) on both):
    // period measured +8.0e-4 ((ωΔt)²/12 = 8.0e-4), decrement −1.61e-3.
    assert!(rel(period, t_grid) < 1.2e-3, "{period} vs {t_grid}");
    assert!(rel(decrement, d_grid) < 2.5e-3, "{decrement} vs {d_grid}");
    // Against the continuum (the grid's −0.524 % on ω enters the period and ζ): period
    // measured +6.1e-3, decrement +3.7e-3.
    assert!(rel(period, t_cont) < 9e-3, "{period} vs {t_cont}");
    assert!(rel(decrement, d_cont) < 6e-3, "{decrement} vs {d_cont}");
}

// (5) continued: the added mass acts along the normal only. A softer sheet (E t = 5 kN/m, so
// that in-plane modes are among the lowest), its ten lowest modes with and without air: the
// in-plane ones (no z component) keep their frequency, the transverse ones scale by
// √(ρt/(ρt + m_a)); on a flat sheet the two families are uncoupled.
#[test]
fn added_mass_acts_along_the_normal_only() {
    let modes = |dynamics: serde_json::Value| {
        let mut json = sheet(0.0);
        json["geometry"]["generators"][0]["divisions"] = serde_json::json!([12, 8]);
        json["membranes"][0]["material"]["E"] = serde_json::json!(5e6);
        json["dynamics"] = dynamics;
        let mut e = engine(scene(json));
        solve(&mut e);
        e.modes(10).unwrap()
    };
    let dry = modes(serde_json::json!({}));
    let wet = modes(serde_json::json!({"air": [{"membrane": "m", "added_mass": ADDED_MASS}]}));
    let ratio = (RHO_T / (RHO_T + ADDED_MASS)).sqrt();
    // Each mode's share of z motion: 0 (in-plane) or 1 (transverse), to round-off.
    let share = |shape: &[f64]| {
        let z: f64 = shape.iter().skip(2).step_by(3).map(|x| x * x).sum();
        z / shape.iter().map(|x| x * x).sum::<f64>()
    };
    let (mut in_plane, mut transverse) = (Vec::new(), Vec::new());
    for (f, shape) in dry.frequencies.iter().zip(&dry.shapes) {
        let s = share(shape);
        assert!(
            !(1e-9..1.0 - 1e-9).contains(&s),
            "a mixed mode: z share {s}"
        );
        if s < 0.5 {
            in_plane.push(*f);
        } else {
            transverse.push(*f);
        }
    }
    let (mut in_plane_wet, mut transverse_wet) = (Vec::new(), Vec::new());
    for (f, shape) in wet.frequencies.iter().zip(&wet.shapes) {
        if share(shape) < 0.5 {
            in_plane_wet.push(*f);
        } else {
            transverse_wet.push(*f);
        }
    }
    println!(
        "normal only: dry in-plane {in_plane:.4?} Hz, transverse {transverse:.4?} Hz; with air in-plane {in_plane_wet:.4?} Hz, transverse {transverse_wet:.4?} Hz"
    );
    assert!(!in_plane.is_empty() && !in_plane_wet.is_empty());
    // The in-plane frequencies found in both lists are equal, the transverse ones scale, each
    // to the eigensolver's accuracy (measured at most 1.5e-12, on the highest mode asked for).
    for (a, b) in in_plane.iter().zip(&in_plane_wet) {
        assert!(rel(*a, *b) < 1e-11, "in-plane {a} vs {b}");
    }
    for (a, b) in transverse.iter().zip(&transverse_wet) {
        assert!((b / a - ratio).abs() < 1e-11, "transverse {a} -> {b}");
    }
}
