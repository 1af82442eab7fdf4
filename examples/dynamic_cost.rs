//! The cost of a time step against a static Newton iteration, printed (not asserted; issue 31's
//! target: one dynamic time step of the Hencky disc, 32 rings, at most 1.5 static Newton
//! iterations on average): `cargo run --release --example dynamic_cost -- [RINGS] [STEPS]`.
//!
//! The shipped Hencky disc (radius 0.5 m, 0.1 mm film, E 200 MPa, follower pressure) with a
//! density of 1400 kg/m³, RINGS rings (default 32), one solver thread. Static: the equilibrium
//! under 400 Pa, then steps of ±10 % (400 → 440 → 400 → 360 → 400, three times), each timed; their time per
//! Newton iteration is the unit. Dynamic (generalized-α, ρ∞ = 0.9, no damping):
//! from the static equilibrium under 400 Pa at rest, STEPS time steps (default 200) of
//! Δt = 1/(20 f₁), f₁ the lowest natural frequency there, under a pressure
//! 400 (1 + 0.1 sin(2π f₁ t / 3)) Pa. Printed: the CPU time per time step (the process's CPU
//! time, so a shared machine's load does not enter), Newton iterations per time step, and the
//! ratio to the CPU time of a static iteration.
//!
//! `--phases` runs the same again with the solver's phases recorded (`velarium::phases`:
//! assemblies with and without the tangent, factorizations, substitutions) and prints, per
//! static iteration and per time step, how many of each ran and their thread CPU time. The
//! recording itself costs time (it reads /proc at every phase), so the ratio printed first,
//! from the run without it, is the measure.

use velarium::{Engine, Scene};

/// CPU time of the process (s): the solver runs on one thread, and the machine may be shared.
fn cpu() -> f64 {
    let mut t = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: clock_gettime writes the timespec it is given.
    unsafe { libc::clock_gettime(libc::CLOCK_PROCESS_CPUTIME_ID, &mut t) };
    t.tv_sec as f64 + 1e-9 * t.tv_nsec as f64
}

fn scene(rings: usize, dynamic: bool) -> Scene {
    let mut json = serde_json::json!({
        "format": 1, "name": "HenckyDynamic",
        "geometry": {"generators": [{"kind": "disc", "name": "disc", "center": [0, 0, 0],
                                     "radius": 0.5, "rings": rings}]},
        "membranes": [{"name": "film", "triangles": "disc", "thickness": 1e-4, "density": 1400.0,
                       "material": {"kind": "svk", "E": 2e8, "nu": 0.3}}],
        "supports": [{"nodes": "disc.rim", "fix": ["x", "y", "z"]}],
        "inputs": [{"name": "pressure", "load": {"kind": "pressure", "membrane": "film",
                                                 "follower": true}, "start": 400}],
        "outputs": [{"name": "w0", "probe": {"kind": "displacement", "node": "disc.center",
                                             "component": "z"}}],
        "solver": {"threads": 1}
    });
    if dynamic {
        json["dynamics"] = serde_json::json!({"time_integration": {"rho_inf": 0.9}});
    }
    Scene::from_json(&json.to_string()).expect("the benchmark scene")
}

/// Count and thread CPU seconds of each solver phase recorded since the last call, by name.
fn phase_sums() -> Vec<(&'static str, usize, f64)> {
    let mut sums: Vec<(&'static str, usize, f64)> = Vec::new();
    for p in velarium::phases::take() {
        match sums.iter_mut().find(|s| s.0 == p.name) {
            Some(s) => {
                s.1 += 1;
                s.2 += p.thread_cpu;
            }
            None => sums.push((p.name, 1, p.thread_cpu)),
        }
    }
    sums
}

fn print_phases(what: &str, per: usize, unit: &str) {
    println!("  {what}, per {unit}:");
    for (name, count, cpu) in phase_sums() {
        println!(
            "    {name:<45} {:>5.2} x  {:>7.3} ms",
            count as f64 / per as f64,
            1e3 * cpu / per as f64
        );
    }
}

fn main() {
    let mut positional = Vec::new();
    let mut phases = false;
    for a in std::env::args().skip(1) {
        if a == "--phases" {
            phases = true;
        } else {
            positional.push(a);
        }
    }
    let mut args = positional.into_iter();
    let rings: usize = args.next().map_or(32, |a| a.parse().expect("RINGS"));
    let steps: usize = args.next().map_or(200, |a| a.parse().expect("STEPS"));
    let load = std::fs::read_to_string("/proc/loadavg").unwrap_or_default();
    println!(
        "load average {}",
        load.split_whitespace()
            .take(3)
            .collect::<Vec<_>>()
            .join(" ")
    );
    run(rings, steps, false);
    if phases {
        println!("again, with the solver's phases recorded (thread CPU time):");
        run(rings, steps, true);
    }
}

fn run(rings: usize, steps: usize, phases: bool) {
    let mut e = Engine::try_new(scene(rings, false)).expect("engine");
    assert!(e.solve().converged());
    let vr = e
        .variables()
        .iter()
        .find(|v| v.name == "pressure")
        .unwrap()
        .value_reference;
    let (mut static_time, mut static_iterations) = (0.0, 0usize);
    let static_factorizations = e.factorizations();
    velarium::phases::enable(phases);
    velarium::phases::take();
    for p in [440.0, 400.0, 360.0, 400.0].repeat(3) {
        e.set_real(vr, p).unwrap();
        let start = cpu();
        let report = e.solve();
        static_time += cpu() - start;
        assert!(report.converged(), "{}", report.message);
        static_iterations += report.iterations;
    }
    velarium::phases::enable(false);
    if phases {
        print_phases("static", static_iterations, "Newton iteration");
    }
    let per_iteration = static_time / static_iterations as f64;
    let static_factorizations = e.factorizations() - static_factorizations;
    let f1 = e.modes(1).expect("modes").frequencies[0];
    let dt = 1.0 / (20.0 * f1);

    let mut d = Engine::try_new(scene(rings, true)).expect("engine");
    assert!(d.solve().converged());
    let dynamic_factorizations = d.factorizations();
    let (mut time, mut iterations) = (0.0, 0usize);
    velarium::phases::enable(phases);
    velarium::phases::take();
    for k in 1..=steps {
        let t = k as f64 * dt;
        let p = 400.0 * (1.0 + 0.1 * (2.0 * std::f64::consts::PI * f1 * t / 3.0).sin());
        d.set_real(vr, p).unwrap();
        d.set_step_duration(dt);
        let start = cpu();
        let report = d.solve();
        time += cpu() - start;
        assert!(report.converged(), "step {k}: {}", report.message);
        iterations += report.iterations;
    }
    velarium::phases::enable(false);
    if phases {
        print_phases("dynamic", steps, "time step");
    }
    let per_step = time / steps as f64;
    // The end state, to compare runs of different builds: the centre's deflection and a
    // checksum of every displacement's and velocity's bits.
    let state = d.state();
    let checksum = state
        .displacement
        .iter()
        .chain(&state.velocity)
        .fold(0u64, |h, x| h.rotate_left(5) ^ x.to_bits());
    let w0 = d
        .outputs()
        .iter()
        .find(|o| o.0 == "w0")
        .map_or(f64::NAN, |o| o.1);
    let dynamic_factorizations = d.factorizations() - dynamic_factorizations;
    println!(
        "Hencky disc, {rings} rings, {} free DOF, f1 = {f1:.3} Hz, dt = {dt:.4e} s",
        d.state().displacement.len()
    );
    println!(
        "static: {static_iterations} Newton iterations ({static_factorizations} factorizations) in 12 steps of 10 %, {:.3} ms CPU per iteration",
        1e3 * per_iteration
    );
    println!(
        "dynamic: {steps} time steps, {:.2} Newton iterations ({:.2} factorizations) per step, {:.3} ms CPU per step = {:.2} static iterations",
        iterations as f64 / steps as f64,
        dynamic_factorizations as f64 / steps as f64,
        1e3 * per_step,
        per_step / per_iteration
    );
    println!("end state: w0 = {w0:.17e} m, checksum of u and v bits {checksum:016x}");
}
