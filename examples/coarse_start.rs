//! The coarse start measured (`solver.coarse_start`, docs/solver.md "The coarse start"):
//! `cargo run --release --example coarse_start -- [SIZE]... [--problem=disc,square]
//! [--runs=N] [--threads=N] [--explicit]`.
//!
//! Each problem at each size is solved from flat to full load with `coarse_start: off` and
//! `on`, in turn (`--runs` times each, default 1), on `--threads` threads (default 1). SIZE is
//! the number of divisions: the disc's rings (Hencky disc, 40 Pa follower pressure,
//! modelDescription/HenckyDisc) or the square's cells a side (4 m square with edge cables,
//! 300 Pa follower pressure, the `scale` example's). Default sizes: 16 32 64 (disc) and 24 48
//! 96 (square). Printed per run: free DOF, the setting, Newton iterations and numeric
//! factorizations on this mesh, the coarse meshes' free DOF and iterations (from the log), the
//! wall time of the solve (coarse meshes included), the centre deflection and, for `on`, its
//! difference from `off`'s, and the process's peak resident set from the engine's build on
//! (Linux; the scene's own text before it is not counted). `--explicit` writes each generated
//! mesh out as explicit nodes, triangles and sets first (what a user's own mesher gives), so
//! that its coarser meshes come from edge collapses instead of halved divisions.

use std::time::Instant;
use velarium::scene::{CoarseStart, Generator};
use velarium::{Engine, Scene};

fn square(n: usize) -> Scene {
    let text = format!(
        r#"{{"format": 1, "name": "Square",
  "geometry": {{"generators": [{{"kind": "rectangle", "name": "sheet", "origin": [0, 0, 0], "size": [4.0, 4.0], "divisions": [{n}, {n}]}}]}},
  "membranes": [{{"name": "fabric", "triangles": "sheet", "thickness": 1e-3, "material": {{"kind": "svk", "E": 6e8, "nu": 0.3}}}}],
  "cables": [
    {{"name": "edge_bottom", "nodes": "sheet.edge_bottom", "EA": 2e6, "pretension": 2000}},
    {{"name": "edge_right", "nodes": "sheet.edge_right", "EA": 2e6, "pretension": 2000}},
    {{"name": "edge_top", "nodes": "sheet.edge_top", "EA": 2e6, "pretension": 2000}},
    {{"name": "edge_left", "nodes": "sheet.edge_left", "EA": 2e6, "pretension": 2000}}],
  "supports": [
    {{"nodes": "sheet.corner_bl", "fix": ["x", "y", "z"]}}, {{"nodes": "sheet.corner_br", "fix": ["x", "y", "z"]}},
    {{"nodes": "sheet.corner_tl", "fix": ["x", "y", "z"]}}, {{"nodes": "sheet.corner_tr", "fix": ["x", "y", "z"]}}],
  "inputs": [{{"name": "load", "load": {{"kind": "pressure", "membrane": "fabric", "follower": true}}, "start": 0, "min": -1000, "max": 300}}],
  "outputs": [{{"name": "center_uz", "probe": {{"kind": "displacement", "node": "sheet.center", "component": "z"}}}}]}}"#
    );
    Scene::from_json(&text).expect("valid scene")
}

fn disc(rings: usize) -> Scene {
    let path = format!(
        "{}/modelDescription/HenckyDisc/scene.json",
        env!("CARGO_MANIFEST_DIR")
    );
    let text = std::fs::read_to_string(path).expect("the shipped Hencky disc");
    let mut scene = Scene::from_json(&text).expect("valid");
    if let Generator::Disc { rings: r, .. } = &mut scene.geometry.generators[0] {
        *r = rings;
    }
    scene
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let value = |flag: &str| {
        args.iter()
            .find_map(|a| a.strip_prefix(flag))
            .map(|v| v.to_string())
    };
    let problems: Vec<String> = value("--problem=")
        .map_or(vec!["disc".into(), "square".into()], |v| {
            v.split(',').map(String::from).collect()
        });
    let runs: usize = value("--runs=").map_or(1, |v| v.parse().expect("--runs=N"));
    let threads: usize = value("--threads=").map_or(1, |v| v.parse().expect("--threads=N"));
    let explicit = args.iter().any(|a| a == "--explicit");
    let sizes: Vec<usize> = args
        .iter()
        .filter(|a| !a.starts_with("--"))
        .map(|a| a.parse().expect("SIZE: divisions"))
        .collect();
    println!(
        "coarse start: flat to full load, {threads} thread(s), {} meshes, load average {}",
        if explicit { "explicit" } else { "generated" },
        std::fs::read_to_string("/proc/loadavg")
            .unwrap_or_default()
            .trim()
    );
    println!(
        "{:>7} {:>5} {:>9} {:>5} {:>5} {:>5}  {:<34} {:>8} {:>14} {:>10} {:>8}",
        "problem",
        "size",
        "DOF",
        "start",
        "iters",
        "facts",
        "coarse meshes (DOF: iterations)",
        "wall s",
        "centre mm",
        "difference",
        "peak MiB"
    );
    for problem in &problems {
        let defaults = if problem == "disc" {
            vec![16, 32, 64]
        } else {
            vec![24, 48, 96]
        };
        for &n in if sizes.is_empty() { &defaults } else { &sizes } {
            for _ in 0..runs {
                let mut off_answer = f64::NAN;
                for setting in [CoarseStart::Off, CoarseStart::On] {
                    let mut scene = if problem == "disc" {
                        disc(n)
                    } else {
                        square(n)
                    };
                    if explicit {
                        scene.geometry = velarium::scene::generate::written_out(&scene.geometry)
                            .expect("the mesh written out");
                    }
                    scene.solver.coarse_start = setting;
                    scene.solver.threads = threads;
                    scene.solver.limits.max_memory_gb = 64.0;
                    // The peak resident set from here (VmHWM reset, Linux >= 4.0).
                    let _ = std::fs::write("/proc/self/clear_refs", "5");
                    let mut engine = Engine::try_new(scene).expect("valid scene");
                    let vr = |name: &str| {
                        engine
                            .variables()
                            .iter()
                            .find(|v| v.name == name)
                            .expect("variable")
                            .value_reference
                    };
                    let input = if problem == "disc" {
                        "pressure"
                    } else {
                        "load"
                    };
                    let (load, out) = (vr(input), vr("center_uz"));
                    let q = if problem == "disc" { 40.0 } else { 300.0 };
                    engine.set_real(load, q).expect("load");
                    let before = engine.factorizations();
                    let start = Instant::now();
                    let report = engine.solve();
                    let wall = start.elapsed().as_secs_f64();
                    assert!(report.converged(), "{problem} {n}: {}", report.message);
                    let answer = 1e3 * engine.get_real(out).expect("output");
                    let coarse: Vec<String> = report
                        .log
                        .iter()
                        .filter_map(|l| {
                            l.strip_prefix("coarse start: the mesh with half the divisions (")
                                .or_else(|| {
                                    l.strip_prefix("coarse start: the mesh with edges collapsed (")
                                })
                        })
                        .map(|l| {
                            let dof = l.split(' ').next().unwrap_or("?");
                            let its = l
                                .split("converged in ")
                                .nth(1)
                                .and_then(|r| r.split(' ').next())
                                .unwrap_or("?");
                            format!("{dof}: {its}")
                        })
                        .collect();
                    let difference = if setting == CoarseStart::Off {
                        off_answer = answer;
                        String::new()
                    } else {
                        format!("{:.2e}", (answer - off_answer).abs() / off_answer.abs())
                    };
                    let peak = velarium::memory::peak_resident()
                        .map_or(f64::NAN, |b| b as f64 / (1024.0 * 1024.0));
                    println!(
                        "{:>7} {:>5} {:>9} {:>5} {:>5} {:>5}  {:<34} {:>8.3} {:>14.9} {:>10} {:>8.0}",
                        problem,
                        n,
                        engine.free_dofs(),
                        if setting == CoarseStart::Off { "off" } else { "on" },
                        report.iterations,
                        engine.factorizations() - before,
                        coarse.join(", "),
                        wall,
                        answer,
                        difference,
                        peak
                    );
                }
            }
        }
    }
}
