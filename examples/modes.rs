//! Natural-frequency benchmark, printed (not asserted; issue 31's target: ten modes of a
//! 100k-DOF membrane in at most the time of five factorizations):
//! `cargo run --release --example modes -- [DIVISIONS] [--count=N]`.
//!
//! A flat rectangular membrane 1 m x 0.7 m, 1 mm, SVK E 1 GPa, nu 0.3, isotropic prestress
//! 1 kN/m, density 1000 kg/m3, clamped on its boundary (tests/verification/
//! natural_frequencies.rs's case), DIVISIONS x round(0.7 DIVISIONS) cells (default 230: about
//! 100k free DOF), one solver thread. Printed: free DOF, the factor's entries, the time of one numeric factorization
//! and one solve of the tangent at the equilibrium (best of 3, `Engine::time_floor_parts`), the
//! wall time of `Engine::modes` (its assembly, mass, one factorization of K - sigma M, the
//! block Lanczos's solves and reorthogonalisation), its solves, the ratio
//! to one factorization, and the lowest frequencies against the closed form. Also in thread CPU
//! time: the least over the 3 analyses of the whole, the solves and the orthogonalisation, and
//! each analysis's ratio to its own factorization of K - sigma M in run order (the first
//! allocates the solver's kept work space, the later ones reuse it), and each analysis's
//! factorization and whole in seconds, and its minor page faults (fresh pages the system
//! zeroes at their first write: the first analysis's buffers are new, the later ones' kept).

use std::time::Instant;
use velarium::{Engine, Scene};

fn main() {
    let mut divisions = 230usize;
    let mut count = 10usize;
    for arg in std::env::args().skip(1) {
        if let Some(n) = arg.strip_prefix("--count=") {
            count = n.parse().expect("--count=N");
        } else {
            divisions = arg.parse().expect("DIVISIONS: a whole number");
        }
    }
    let ny = ((0.7 * divisions as f64).round() as usize).max(1);
    let text = serde_json::json!({
        "format": 1, "name": "ModesBenchmark",
        "geometry": {"generators": [{"kind": "rectangle", "name": "s", "origin": [0, 0, 0],
                                     "size": [1.0, 0.7], "divisions": [divisions, ny]}]},
        "membranes": [{"name": "m", "triangles": "s", "thickness": 0.001, "density": 1000.0,
                       "material": {"kind": "svk", "E": 1e9, "nu": 0.3},
                       "prestress": {"kind": "isotropic", "n": 1000.0}}],
        "supports": [{"nodes": "s.boundary", "fix": ["x", "y", "z"]}],
        "solver": {"threads": 1}
    })
    .to_string();
    let scene = Scene::from_json(&text).expect("the benchmark scene");
    let mut engine = Engine::try_new(scene).expect("the benchmark engine");
    let report = engine.solve();
    assert!(report.converged(), "{}", report.message);
    let (_, factor, solve) = engine.time_floor_parts(3);
    // Best of 3, as the factorization's time; CPU time of the process beside the wall time.
    let mut runs = Vec::new();
    let mut faults = Vec::new();
    for _ in 0..3 {
        let (started, cpu) = (Instant::now(), velarium::phases::process_cpu());
        let before = minor_faults();
        let modes = engine.modes(count).expect("the modes");
        faults.push(minor_faults() - before);
        runs.push((
            started.elapsed().as_secs_f64(),
            velarium::phases::process_cpu() - cpu,
            modes,
        ));
    }
    // Thread CPU time of each run (robust to the machine's load): the least over the runs of
    // the whole, the solves and the orthogonalisation, and each run's ratio to its own
    // factorization of K - sigma M.
    let least = |f: &dyn Fn(&velarium::solver::modes::Seconds) -> f64| {
        runs.iter()
            .map(|r| f(&r.2.seconds))
            .fold(f64::INFINITY, f64::min)
    };
    let (total_cpu, solves_cpu, orthogonalisation_cpu, factor_cpu) = (
        least(&|s| s.total_cpu),
        least(&|s| s.solves_cpu),
        least(&|s| s.orthogonalisation_cpu),
        least(&|s| s.factor_cpu),
    );
    let ratios: Vec<String> = runs
        .iter()
        .map(|r| format!("{:.2}", r.2.seconds.total_cpu / r.2.seconds.factor_cpu))
        .collect();
    // Each run's own factorization and whole analysis (thread CPU), in run order.
    let parts: Vec<String> = runs
        .iter()
        .map(|r| {
            format!(
                "{:.3} / {:.3}",
                r.2.seconds.factor_cpu, r.2.seconds.total_cpu
            )
        })
        .collect();
    runs.sort_by(|a, b| a.0.total_cmp(&b.0));
    let (seconds, cpu, modes) = runs.swap_remove(0);
    let load = std::fs::read_to_string("/proc/loadavg").unwrap_or_default();
    println!(
        "free DOF {}, factor entries {} ({:.3} GFlop), one factorization {factor:.3} s, one solve {solve:.4} s (best of 3); load average {}",
        engine.free_dofs(),
        engine.factor_nonzeros(),
        engine.factor_flops() * 1e-9,
        load.split_whitespace().take(3).collect::<Vec<_>>().join(" ")
    );
    println!(
        "{} modes in {seconds:.3} s (best of 3; CPU {cpu:.3} s) = {:.2} factorizations ({} right-hand sides solved, {} passes, {} blocks reorthogonalised against the whole basis)",
        modes.frequencies.len(),
        seconds / factor,
        modes.solves,
        modes.passes,
        modes.reorthogonalisations
    );
    let s = modes.seconds;
    println!(
        "  in thread CPU time within the run: {:.3} s = {:.2} times its own factorization of K - sigma M ({:.3} s)",
        s.total_cpu,
        s.total_cpu / s.factor_cpu,
        s.factor_cpu
    );
    println!(
        "  thread CPU, least of the 3 runs: whole {total_cpu:.3} s, factorization of K - sigma M {factor_cpu:.3} s, solves {solves_cpu:.3} s, orthogonalisation {orthogonalisation_cpu:.3} s; whole / own factorization per run: {}",
        ratios.join(", ")
    );
    println!(
        "  thread CPU per run, factorization of K - sigma M / whole analysis (s): {}",
        parts.join(", ")
    );
    println!(
        "  minor page faults per run (this thread): {}",
        faults
            .iter()
            .map(|f| f.to_string())
            .collect::<Vec<_>>()
            .join(", ")
    );
    println!(
        "  of which: assembly and factorization of K - sigma M {:.3} s, solves {:.3} s, M products {:.3} s, orthogonalisation {:.3} s, Ritz pairs and shapes {:.3} s, other {:.3} s",
        s.factorization,
        s.solves,
        s.mass_products,
        s.orthogonalisation,
        s.ritz,
        seconds - s.total()
    );
    let c = (1000.0f64 / 1.0).sqrt();
    let mut exact: Vec<f64> = (1..12)
        .flat_map(|m| (1..12).map(move |n| (m as f64, n as f64)))
        .map(|(m, n)| 0.5 * c * (m * m + (n / 0.7) * (n / 0.7)).sqrt())
        .collect();
    exact.sort_by(f64::total_cmp);
    for (k, f) in modes.frequencies.iter().enumerate() {
        println!(
            "  f{} = {f:.12} Hz, closed form {:.4} Hz, {:+.4} %",
            k + 1,
            exact[k],
            100.0 * (f - exact[k]) / exact[k]
        );
    }
}

/// Minor page faults of the calling thread so far (`/proc/thread-self/stat`'s tenth field;
/// 0 where it cannot be read).
fn minor_faults() -> i64 {
    let Ok(text) = std::fs::read_to_string("/proc/thread-self/stat") else {
        return 0;
    };
    // After the command name in parentheses: state, ppid, pgrp, session, tty, tpgid, flags,
    // minflt.
    text.rsplit_once(')')
        .and_then(|(_, rest)| rest.split_whitespace().nth(7))
        .and_then(|v| v.parse().ok())
        .unwrap_or(0)
}
