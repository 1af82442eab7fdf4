//! Scaling benchmark, printed (not asserted; issue 15 item 6):
//! `cargo run --release --example scale -- [SIZE...] [--no-shuffle] [--shuffled-only] [--floor-only=N]
//! [--problem=disc,square] [--threads=N] [--order=rings,rcm,hilbert,given] [--inexact=auto,on,off]
//! [--thread-cpu] [--log] [--max-iterations=N] [--min-increment=X] [--artificial-prestress=PA]
//! [--continuation=H] [--timings]`; `[SIZE...] --e2e [--runs=N] [--threads=N]`.
//!
//! `--timings`: no solve; the wall and CPU seconds of each phase of building the engine
//! (`velarium::phases`: mesh generation, the model, renumbering, pattern, ordering, symbolic
//! analyses, allocation) and of the scene validation and variable table (fn `setup_timings`).
//!
//! `--e2e`: what a user waits for, `velarium solve` from the scene file to the CSV as a process
//! of its own (built next to this example: `cargo build --release` first), N runs per size
//! (default 3) with the median and range of the whole process's wall time, the setup and
//! solve it reports (`--timings`), its CPU time and peak resident set, the CPU model and the
//! load average (fn `e2e`).
//!
//! `--log` prints each solve's per-iteration log on stderr; `--max-iterations=N` and
//! `--min-increment=X` set `solver.max_iterations` and `solver.min_increment` (with X = 1 a
//! failed first increment ends the step at once instead of being cut back: to look at one
//! increment of a case that fails); `--artificial-prestress=PA` sets
//! `solver.artificial_prestress` (the tangent-only start, docs/solver.md);
//! `--continuation=H` sets `solver.prestress_continuation` (0: off; docs/solver.md, "Prestress
//! continuation").
//!
//! Two problems, each flat start to full load in one step:
//! - `disc`: the Hencky disc (docs/mechanics.md §4a, follower pressure 40 Pa);
//! - `square`: a flat square membrane 4 m x 4 m, 1 mm, SVK E 600 MPa, nu 0.3, with four edge
//!   cables (EA 2e6 N, 2 kN pretension) along its edges, held at its four corners, follower
//!   pressure 300 Pa (the README's WindSquare kind of scene at a finer mesh).
//!
//! A SIZE is a DOF count with a suffix (`10k`, `300k`, `1M`: the disc's rings and the square's
//! divisions are chosen for about that many free DOF) or a bare ring count of the disc (`334`:
//! the square is then sized to the same DOF). Default `10k 100k`. 300k and 1M DOF (about 1 and
//! 3 GB) are run by hand, never in CI.
//!
//! Each in the generator's node numbering (`gen`) and in a shuffled numbering (`shuf`: the
//! same mesh written as explicit nodes and triangles, node ids and triangle order permuted by
//! a fixed-seed xorshift generator, as a user's mesher might number it), solved in every
//! internal node order asked for (`--order`, default the solver's default).
//!
//! `--thread-cpu` prints, per case on stderr, the CPU seconds of the solve on every thread of
//! the process (the solving thread has the lowest id): on an idle machine the solving
//! thread's share bounds the two-thread wall time from below.
//!
//! `--inexact=` (a list, default `auto`) runs every case with `solver.inexact_newton` set to
//! each value in turn (`on,off,on,off` gives alternating pairs on a shared machine).
//!
//! Printed per case: free DOF, numbering/internal order, stored entries of the LDLT factor,
//! inexact Newton (`inx`: on or off for this tangent), numeric factorizations and Newton
//! iterations of the solve, the directions taken by preconditioned conjugate gradients
//! instead of a factorization and the preconditioner solves they took (`inx/pcg`), the
//! process's CPU seconds of the solve (user + system, all threads), the floor's parts (one assembly,
//! one numeric LDLT factorization, one solve, each the best of 3 at the solution,
//! `Engine::time_floor_parts`), the solve's wall time, the peak resident set of the case
//! (VmHWM from /proc/self/status, reset through /proc/self/clear_refs before each case; the
//! scene's own mesh is built before the reset and not counted), the engine's memory estimate
//! (`Engine::memory_estimate`), threads (1: faer runs `Par::Seq`), the ratio total /
//! (iterations x floor) and the check of the answer: the disc's relative error of the centre
//! deflection against w0/a = 0.065404, the square's centre deflection in mm (both numberings
//! must agree).

use std::time::Instant;
use velarium::scene::generate::resolve;
use velarium::scene::{Generator, Geometry, InexactNewton, NodeOrder, OneNode, Scene};
use velarium::Engine;

const W_FOLLOWER: f64 = 0.065404;

/// The square's fabric prestress by default, N/m (`--square-prestress=` changes it).
const SQUARE_PRESTRESS: f64 = 0.0;

/// CPU seconds (user + system) of the process so far, every thread included.
fn cpu_seconds() -> f64 {
    // SAFETY: getrusage writes one rusage into the zeroed struct it is given.
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    if unsafe { libc::getrusage(libc::RUSAGE_SELF, &mut usage) } != 0 {
        return f64::NAN;
    }
    let secs = |t: libc::timeval| t.tv_sec as f64 + 1e-6 * t.tv_usec as f64;
    secs(usage.ru_utime) + secs(usage.ru_stime)
}

/// CPU seconds (user + system) of every thread of the process, by thread id
/// (/proc/self/task/*/stat; empty where that is missing).
fn thread_cpu() -> Vec<(u64, f64)> {
    let ticks = 100.0; // USER_HZ on Linux
    let mut out = Vec::new();
    let Ok(dir) = std::fs::read_dir("/proc/self/task") else {
        return out;
    };
    for entry in dir.flatten() {
        let Ok(tid) = entry.file_name().to_string_lossy().parse::<u64>() else {
            continue;
        };
        let Ok(stat) = std::fs::read_to_string(entry.path().join("stat")) else {
            continue;
        };
        // Fields after the command name in parentheses: utime and stime are the 12th and 13th.
        let Some(close) = stat.rfind(')') else {
            continue;
        };
        let fields: Vec<&str> = stat[close + 1..].split_whitespace().collect();
        let time = |i: usize| fields.get(i).and_then(|f| f.parse::<f64>().ok());
        if let (Some(u), Some(s)) = (time(11), time(12)) {
            out.push((tid, (u + s) / ticks));
        }
    }
    out.sort_by_key(|&(tid, _)| tid);
    out
}

fn peak_rss_mib() -> f64 {
    velarium::memory::peak_resident().map_or(f64::NAN, |b| b as f64 / (1024.0 * 1024.0))
}

/// A fixed-seed permutation of 0..n (Fisher-Yates on xorshift64*).
fn permutation(n: usize) -> Vec<usize> {
    let mut p: Vec<usize> = (0..n).collect();
    let mut s: u64 = 0x9E37_79B9_7F4A_7C15;
    for i in (1..n).rev() {
        s ^= s >> 12;
        s ^= s << 25;
        s ^= s >> 27;
        let r = s.wrapping_mul(0x2545_F491_4F6C_DD1D);
        p.swap(i, (r % (i as u64 + 1)) as usize);
    }
    p
}

/// The same disc as explicit nodes and triangles with node ids permuted.
fn shuffled(generated: &Engine, base: &Scene) -> Scene {
    let model = generated.model();
    let n = model.reference.len();
    let perm = permutation(n); // old id -> new id
                               // Triangles in a shuffled order too: a mesher's element order is no better than its node
                               // order.
    let tri_perm = permutation(model.triangles.len()); // old position -> new position
    let mut tri_order = vec![0; tri_perm.len()];
    for (old, &new) in tri_perm.iter().enumerate() {
        tri_order[new] = old;
    }
    let mut nodes = vec![[0.0; 3]; n];
    for (old, x) in model.reference.iter().enumerate() {
        nodes[perm[old]] = [x.x, x.y, x.z];
    }
    let triangles: Vec<String> = tri_order
        .iter()
        .map(|&e| &model.triangles[e])
        .map(|t| {
            format!(
                "[{}, {}, {}]",
                perm[t.nodes[0]], perm[t.nodes[1]], perm[t.nodes[2]]
            )
        })
        .collect();
    let rim: Vec<usize> = (0..n)
        .filter(|&i| (model.reference[i].norm() - 0.5).abs() < 1e-9)
        .map(|i| perm[i])
        .collect();
    let center = (0..n)
        .find(|&i| model.reference[i].norm() < 1e-12)
        .map(|i| perm[i])
        .expect("a centre node");
    let nodes_json: Vec<String> = nodes
        .iter()
        .map(|x| format!("[{:e}, {:e}, {:e}]", x[0], x[1], x[2]))
        .collect();
    let mut value = serde_json::to_value(base).expect("scene serializes");
    value["geometry"] = serde_json::from_str(&format!(
        r#"{{"nodes": [{}], "triangles": [{}], "node_sets": {{"rim": {:?}, "center": [{}]}}, "triangle_sets": {{"disc": {:?}}}}}"#,
        nodes_json.join(","),
        triangles.join(","),
        rim,
        center,
        (0..model.triangles.len()).collect::<Vec<_>>()
    ))
    .expect("geometry JSON");
    let text = serde_json::to_string(&value)
        .unwrap()
        .replace("\"disc.rim\"", "\"rim\"")
        .replace("\"disc.center\"", "\"center\"");
    Scene::from_json(&text).expect("valid shuffled scene")
}

/// Reset the process's peak resident set (VmHWM) to its current size (Linux >= 4.0); false
/// where that is not possible (the peak column then runs on from earlier cases).
fn reset_peak_rss() -> bool {
    std::fs::write("/proc/self/clear_refs", "5").is_ok()
}

/// What a problem asks for: its load input, the value, and how its answer is checked.
struct Problem {
    name: &'static str,
    input: &'static str,
    value: f64,
}

const DISC: Problem = Problem {
    name: "disc",
    input: "pressure",
    value: 40.0,
};

const SQUARE: Problem = Problem {
    name: "square",
    input: "wind",
    value: 300.0,
};

fn value_reference(engine: &Engine, name: &str) -> u32 {
    engine
        .variables()
        .iter()
        .find(|v| v.name == name)
        .unwrap_or_else(|| panic!("variable {name}"))
        .value_reference
}

/// `--timings`: the setup's phases (`velarium::phases`) of one `Engine::try_new`, each with
/// its wall and CPU seconds (the process's, every thread) and its own thread's CPU seconds
/// (`[helper]`: a phase on the solver's helper thread, overlapping the solving thread's),
/// indented by nesting; the solving thread's CPU time of the whole `Engine::try_new` is what
/// an idle two-core machine's wall time would be, the helper's work running beside it. Before it, the
/// scene validation and the variable table each timed in a call of their own (the engine
/// repeats both: `Engine::try_new` is `src/engine.rs`), and after it what the engine does
/// besides the model and the solver (the validation, the variable table, the initial state
/// and outputs), as the engine's total less the phases measured inside it.
fn setup_timings(label: &str, scene: &Scene) {
    use velarium::phases;
    let load = load_average();
    phases::enable(true);
    phases::take();
    let timed = |name: &str, f: &mut dyn FnMut()| {
        let (wall, cpu, own) = (Instant::now(), phases::process_cpu(), phases::thread_cpu());
        f();
        let (wall, cpu) = (wall.elapsed().as_secs_f64(), phases::process_cpu() - cpu);
        let own = phases::thread_cpu() - own;
        let inner = phases::take();
        println!("  {name:<52} wall {wall:7.3} s  cpu {cpu:7.3} s  thread cpu {own:7.3} s");
        // A helper's phases are marked; their depth counts on the helper's thread.
        let here = std::thread::current().id();
        for p in &inner {
            let name = match p.thread == here {
                true => p.name.to_string(),
                false => format!("[helper] {}", p.name),
            };
            println!(
                "  {:indent$}{:<width$} wall {:7.3} s  cpu {:7.3} s  thread cpu {:7.3} s",
                "",
                name,
                p.wall,
                p.cpu,
                p.thread_cpu,
                indent = 2 * (p.depth + 1),
                width = 50 - 2 * p.depth
            );
        }
        (wall, cpu, own, inner)
    };
    println!("setup phases of {label} (load average before: {load}):");
    timed(
        "scene validation (validate_sized, separate call)",
        &mut || {
            let (problems, _) = velarium::scene::validate::validate_sized(scene);
            assert!(problems.is_empty(), "{problems:?}");
        },
    );
    timed(
        "variable table (variables::try_table, separate call)",
        &mut || {
            velarium::variables::try_table(scene).expect("variable table");
        },
    );
    let mut engine = None;
    let (wall, cpu, own, inner) = timed("Engine::try_new", &mut || {
        engine = Some(Engine::try_new(scene.clone()).expect("valid scene"));
    });
    // The outermost phases on this thread (a helper's run at the same time).
    let here = std::thread::current().id();
    let outer = inner.iter().filter(|p| p.depth == 0 && p.thread == here);
    let (w, c, t) = outer.fold((0.0, 0.0, 0.0), |(w, c, t), p| {
        (w + p.wall, c + p.cpu, t + p.thread_cpu)
    });
    println!(
        "  {:<52} wall {:7.3} s  cpu {:7.3} s  thread cpu {:7.3} s",
        "  Engine::try_new less the phases above",
        wall - w,
        cpu - c,
        own - t
    );
    let peak = peak_rss_mib();
    drop(engine);
    println!(
        "  peak resident {peak:.0} MiB; load average after: {}",
        load_average()
    );
    phases::enable(false);
}

/// `--solve-timings`: the solve's phases (`velarium::phases`: assembly, factorization, each
/// half's numeric LDLT and S block, the separator, substitutions, inexact Newton), summed by
/// name and thread (the solving thread, `[helper]` the solver's helper), with the number of
/// times each ran, its wall seconds and its own thread's CPU seconds; then the solve's wall
/// time, the process's CPU time and the solving thread's, and the solving thread's CPU time
/// outside every outermost phase (the Newton loop's vector work, relaxation, the line
/// search's bookkeeping, the output evaluation).
fn print_solve_phases(label: &str, wall: f64, cpu: f64, own: f64) {
    let phases = velarium::phases::take();
    let here = std::thread::current().id();
    let mut rows: Vec<(String, usize, usize, f64, f64)> = Vec::new();
    for p in &phases {
        let name = match p.thread == here {
            true => p.name.to_string(),
            false => format!("[helper] {}", p.name),
        };
        match rows.iter_mut().find(|r| r.0 == name) {
            Some(r) => {
                r.2 += 1;
                r.3 += p.wall;
                r.4 += p.thread_cpu;
            }
            None => rows.push((name, p.depth, 1, p.wall, p.thread_cpu)),
        }
    }
    println!("solve phases of {label} (sums over the solve):");
    for (name, depth, count, wall, thread_cpu) in &rows {
        println!(
            "  {:indent$}{:<width$} x{count:<4} wall {wall:8.3} s  thread cpu {thread_cpu:8.3} s",
            "",
            name,
            indent = 2 * depth,
            width = 56 - 2 * depth
        );
    }
    let outer = phases
        .iter()
        .filter(|p| p.depth == 0 && p.thread == here)
        .fold(0.0, |a, p| a + p.thread_cpu);
    println!(
        "  solve: wall {wall:.3} s, process cpu {cpu:.3} s, solving thread cpu {own:.3} s, of it outside the phases {:.3} s",
        own - outer
    );
}

fn run(problem: &Problem, label: &str, scene: Scene) {
    if std::env::args().any(|a| a == "--timings") {
        setup_timings(&format!("{} {label}", problem.name), &scene);
        return;
    }
    let reset = reset_peak_rss();
    let built = Instant::now();
    let mut engine = Engine::try_new(scene).expect("valid scene");
    let setup = built.elapsed().as_secs_f64();
    if std::env::args().any(|a| a == "--nnz-only") {
        println!(
            "{:>7} {:>8} {:>13} {:>11} {:>10.4e} setup {:.3} s split {:?}",
            problem.name,
            engine.free_dofs(),
            label,
            engine.factor_nonzeros(),
            engine.factor_flops(),
            setup,
            engine.split_sizes()
        );
        return;
    }
    let vr = value_reference(&engine, problem.input);
    let out = value_reference(&engine, "center_uz");
    if let Some(repeats) = std::env::args().find_map(|a| {
        a.strip_prefix("--floor-only=")
            .map(|n| n.parse::<usize>().expect("--floor-only=N"))
    }) {
        engine.set_real(vr, problem.value).unwrap();
        let (assembly, factor, solve) = engine.time_floor_parts(repeats);
        println!(
            "{:>7} {:>8} {:>13} floor (best of {repeats}, flat start): assembly {:.4} s, factor {:.4} s, solve {:.4} s",
            problem.name,
            engine.free_dofs(),
            label,
            assembly,
            factor,
            solve
        );
        return;
    }
    let counts = engine.linear_counts();
    let per_thread = std::env::args().any(|a| a == "--thread-cpu");
    let tasks = if per_thread { thread_cpu() } else { Vec::new() };
    let solve_timings = std::env::args().any(|a| a == "--solve-timings");
    if solve_timings {
        velarium::phases::enable(true);
        velarium::phases::take();
    }
    let own = velarium::phases::thread_cpu();
    let cpu = cpu_seconds();
    let t = Instant::now();
    engine.set_real(vr, problem.value).unwrap();
    let report = engine.solve();
    let time = t.elapsed().as_secs_f64();
    if solve_timings {
        let own = velarium::phases::thread_cpu() - own;
        velarium::phases::enable(false);
        print_solve_phases(label, time, cpu_seconds() - cpu, own);
    }
    if std::env::args().any(|a| a == "--log") {
        // The solve's per-iteration log (what an FMU shows on logSolver), on stderr.
        for l in &report.log {
            eprintln!("{label}: {l}");
        }
    }
    if per_thread {
        // Per thread of the process: CPU seconds of this solve (the solving thread first).
        let line: Vec<String> = thread_cpu()
            .iter()
            .map(|(tid, c)| {
                let before = tasks.iter().find(|(t, _)| t == tid).map_or(0.0, |x| x.1);
                format!("{tid} {:.2}", c - before)
            })
            .collect();
        eprintln!(
            "{:>7} {label}: solve CPU s per thread: {}",
            problem.name,
            line.join(", ")
        );
    }
    let cpu = cpu_seconds() - cpu;
    let after = engine.linear_counts();
    let factorizations = after.factorizations - counts.factorizations;
    let inexact = format!(
        "{}/{}",
        after.inexact - counts.inexact,
        after.pcg_solves - counts.pcg_solves
    );
    let peak = peak_rss_mib();
    // The linear solver's work (docs/performance.md, "Mixed-precision factor"): substitutions
    // through the factor, refinement steps of single-precision solves, falls back to double.
    println!(
        "{:>7} {label}: substitutions {}, refinement steps {}, falls back to double {}",
        problem.name,
        after.substitutions - counts.substitutions,
        after.refinements - counts.refinements,
        after.fallbacks - counts.fallbacks
    );
    if !report.converged() {
        println!(
            "{:>7} {label}: did not converge: {}",
            problem.name, report.message
        );
        return;
    }
    let w = engine.get_real(out).unwrap();
    let check = match problem.name {
        "disc" => format!("{:.2e}", (w / 0.5 - W_FOLLOWER).abs() / W_FOLLOWER),
        _ => format!("{:.4} mm", 1e3 * w),
    };
    let (assembly, factor, solve) = engine.time_floor_parts(3);
    let floor = assembly + factor + solve;
    println!(
        "{:>7} {:>8} {:>13} {:>11} {:>3} {:>5} {:>5} {:>7} {:>8.4} {:>8.4} {:>8.4} {:>7.2} {:>8.3} {:>7.2} {:>8.0}{} {:>8.0} {:>3} {:>6.2} {:>11}",
        problem.name,
        engine.free_dofs(),
        label,
        engine.factor_nonzeros(),
        if engine.inexact_newton() { "on" } else { "off" },
        factorizations,
        report.iterations,
        inexact,
        assembly,
        factor,
        solve,
        setup,
        time,
        cpu,
        peak,
        if reset { " " } else { "*" },
        engine.memory_estimate() as f64 / (1024.0 * 1024.0),
        engine.scene().solver.threads,
        time / report.iterations.max(1) as f64 / floor,
        check
    );
}

/// The size arguments as disc ring counts and square divisions: `10k`/`1M` are free DOF, a
/// bare number is the disc's rings (the square then gets the disc's DOF).
fn sizes(args: &[String]) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    for a in args.iter().filter(|a| !a.starts_with("--")) {
        let lower = a.to_ascii_lowercase();
        let (num, mul) = if let Some(n) = lower.strip_suffix('k') {
            (n.to_string(), Some(1e3))
        } else if let Some(n) = lower.strip_suffix('m') {
            (n.to_string(), Some(1e6))
        } else {
            (lower.clone(), None)
        };
        let Ok(x) = num.parse::<f64>() else {
            panic!("not a size: {a} (e.g. 10k, 1M, or a ring count such as 334)")
        };
        // Disc: 1 + 3R(R+1) nodes, the rim's 6R held: 3 (1 + 3R(R-1)) ≈ 9R² free DOF.
        let (rings, dof) = match mul {
            Some(m) => {
                let dof = x * m;
                (((dof / 9.0).sqrt().round() as usize).max(2), dof)
            }
            None => {
                let r = x as usize;
                (r, 3.0 * (1.0 + 3.0 * (r * r.saturating_sub(1)) as f64))
            }
        };
        // Square: (n+1)² nodes, 4 corners held: 3 (n+1)² − 12 free DOF.
        let divisions = ((((dof + 12.0) / 3.0).sqrt() - 1.0).round() as usize).max(2);
        out.push((rings, divisions));
    }
    if out.is_empty() {
        out = sizes(&["10k".to_string(), "100k".to_string()]);
    }
    out
}

/// `--dense-rate`: the rate of faer's dense LDLT (the kernel the sparse factorization's
/// supernodes run) on this thread, `Par::Seq`, for a few sizes: n³/3 flops (the Σ c² the
/// factorization's flop count uses) over the wall and the thread's CPU seconds, best of 3.
fn dense_rate() {
    use faer::dyn_stack::{MemBuffer, MemStack};
    use faer::linalg::cholesky::ldlt::factor::{cholesky_in_place, cholesky_in_place_scratch};
    println!(
        "dense LDLT, 1 thread (load average before: {}):",
        load_average()
    );
    for n in [256usize, 512, 1000, 2000, 4000] {
        let a = faer::Mat::<f64>::from_fn(n, n, |i, j| {
            if i == j {
                n as f64
            } else {
                1.0 / (1.0 + (i + j) as f64)
            }
        });
        let mut mem = MemBuffer::new(cholesky_in_place_scratch::<f64>(
            n,
            faer::Par::Seq,
            Default::default(),
        ));
        let repeats = (4e9 / (n * n * n) as f64).ceil() as usize;
        let (mut wall, mut cpu) = (f64::INFINITY, f64::INFINITY);
        for _ in 0..3 {
            let mut m = a.clone();
            let (t, c) = (Instant::now(), velarium::phases::thread_cpu());
            for _ in 0..repeats {
                m.copy_from(&a);
                cholesky_in_place(
                    m.as_mut(),
                    Default::default(),
                    faer::Par::Seq,
                    MemStack::new(&mut mem),
                    Default::default(),
                )
                .expect("positive definite");
            }
            wall = wall.min(t.elapsed().as_secs_f64() / repeats as f64);
            cpu = cpu.min((velarium::phases::thread_cpu() - c) / repeats as f64);
        }
        let flops = (n * n * n) as f64 / 3.0;
        println!(
            "  n {n:5}: {:6.1} GFlop/s wall, {:6.1} GFlop/s thread CPU",
            flops / wall * 1e-9,
            flops / cpu * 1e-9
        );
    }
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.iter().any(|a| a == "--dense-rate") {
        dense_rate();
        return;
    }
    let no_shuffle = args.iter().any(|a| a == "--no-shuffle");
    // `--shuffled-only`: skip the generator's numbering (to profile the shuffled case alone).
    let shuffled_only = args.iter().any(|a| a == "--shuffled-only");
    // `--threads=N`: the solver's threads (`solver.threads`; 2 or more factor a large tangent
    // in two halves at once, docs/performance.md).
    let threads: usize = args
        .iter()
        .find_map(|a| a.strip_prefix("--threads="))
        .map_or(1, |v| v.parse().expect("--threads=N"));
    let max_iterations: Option<usize> = args
        .iter()
        .find_map(|a| a.strip_prefix("--max-iterations="))
        .map(|v| v.parse().expect("--max-iterations=N"));
    let min_increment: Option<f64> = args
        .iter()
        .find_map(|a| a.strip_prefix("--min-increment="))
        .map(|v| v.parse().expect("--min-increment=X"));
    let continuation: Option<f64> = args
        .iter()
        .find_map(|a| a.strip_prefix("--continuation="))
        .map(|v| v.parse().expect("--continuation=H"));
    let artificial_prestress: Option<f64> = args
        .iter()
        .find_map(|a| a.strip_prefix("--artificial-prestress="))
        .map(|v| v.parse().expect("--artificial-prestress=PA"));
    let mut orders: Vec<NodeOrder> = args
        .iter()
        .filter_map(|a| a.strip_prefix("--order="))
        .flat_map(|list| list.split(','))
        .map(|name| match name {
            "rcm" => NodeOrder::Rcm,
            "hilbert" => NodeOrder::Hilbert,
            "rings" => NodeOrder::Rings,
            "given" => NodeOrder::Given,
            other => panic!("unknown --order {other}: rings, rcm, hilbert or given"),
        })
        .collect();
    if orders.is_empty() {
        orders.push(NodeOrder::default());
    }
    // `--inexact=auto,on,off`: `solver.inexact_newton` for each run in turn.
    let mut inexact: Vec<InexactNewton> = args
        .iter()
        .filter_map(|a| a.strip_prefix("--inexact="))
        .flat_map(|list| list.split(','))
        .map(|name| match name {
            "auto" => InexactNewton::Auto,
            "on" => InexactNewton::On,
            "off" => InexactNewton::Off,
            other => panic!("unknown --inexact {other}: auto, on or off"),
        })
        .collect();
    if inexact.is_empty() {
        inexact.push(InexactNewton::default());
    }
    let problems: Vec<&Problem> = args
        .iter()
        .filter_map(|a| a.strip_prefix("--problem="))
        .flat_map(|list| list.split(','))
        .map(|name| match name {
            "disc" => &DISC,
            "square" => &SQUARE,
            other => panic!("unknown --problem {other}: disc or square"),
        })
        .collect();
    let problems = if problems.is_empty() {
        vec![&DISC, &SQUARE]
    } else {
        problems
    };
    let square_prestress: f64 = args
        .iter()
        .find_map(|a| a.strip_prefix("--square-prestress="))
        .map_or(SQUARE_PRESTRESS, |v| {
            v.parse().expect("--square-prestress=N/m")
        });
    if args.iter().any(|a| a == "--scenes") {
        scenes();
        return;
    }
    if args.iter().any(|a| a == "--e2e") {
        let threads = args
            .iter()
            .find_map(|a| a.strip_prefix("--threads="))
            .map(|v| v.parse().expect("--threads=N"));
        let runs = args
            .iter()
            .find_map(|a| a.strip_prefix("--runs="))
            .map_or(3, |v| v.parse().expect("--runs=N"));
        e2e(&sizes(&args), threads, runs);
        return;
    }
    let path = format!(
        "{}/modelDescription/HenckyDisc/scene.json",
        env!("CARGO_MANIFEST_DIR")
    );
    let disc = Scene::from_json(&std::fs::read_to_string(&path).expect("shipped scene"))
        .expect("valid scene");
    println!(
        "disc: Hencky disc, follower pressure 40 Pa; square: 4 m square with edge cables, follower pressure 300 Pa; flat start to full load, {threads} thread(s), load average {}",
        std::fs::read_to_string("/proc/loadavg").unwrap_or_default().trim()
    );
    println!(
        "{:>7} {:>8} {:>13} {:>11} {:>3} {:>5} {:>5} {:>7} {:>8} {:>8} {:>8} {:>7} {:>8} {:>7} {:>9} {:>8} {:>3} {:>6} {:>11}",
        "problem",
        "DOF",
        "numbering",
        "factor nnz",
        "inx",
        "facts",
        "iters",
        "inx/pcg",
        "assem s",
        "factor s",
        "solve s",
        "setup s",
        "total s",
        "cpu s",
        "peak MiB",
        "est MiB",
        "thr",
        "ratio",
        "check"
    );
    for (rings, divisions) in sizes(&args) {
        for problem in &problems {
            let mut scene = match problem.name {
                "disc" => {
                    let mut scene = disc.clone();
                    if let Generator::Disc { rings: r, .. } = &mut scene.geometry.generators[0] {
                        *r = rings;
                    }
                    scene
                }
                _ => square_scene(divisions, square_prestress),
            };
            // Large meshes are what this benchmark is for: the default size limits would stop
            // a 1M DOF scene on a machine with less free memory than the estimate.
            scene.solver.limits.max_memory_gb = 64.0;
            scene.solver.threads = threads;
            if let Some(n) = max_iterations {
                scene.solver.max_iterations = n;
            }
            if let Some(h) = continuation {
                scene.solver.prestress_continuation = h;
            }
            if artificial_prestress.is_some() {
                scene.solver.artificial_prestress = artificial_prestress;
            }
            if let Some(x) = min_increment {
                scene.solver.min_increment = x;
                scene.solver.initial_increment = scene.solver.initial_increment.max(x);
            }
            let shuffled_scene = (!no_shuffle).then(|| match problem.name {
                "disc" => {
                    let engine = Engine::try_new(scene.clone()).expect("valid scene");
                    shuffled(&engine, &scene)
                }
                _ => shuffled_square(&scene),
            });
            for &order in &orders {
                for &inexact in &inexact {
                    let name = format!("{order:?}").to_lowercase();
                    scene.solver.node_order = order;
                    scene.solver.inexact_newton = inexact;
                    if !shuffled_only {
                        run(problem, &format!("gen/{name}"), scene.clone());
                    }
                    if let Some(s) = &shuffled_scene {
                        let mut s = s.clone();
                        s.solver.node_order = order;
                        s.solver.inexact_newton = inexact;
                        run(problem, &format!("shuf/{name}"), s);
                    }
                }
            }
        }
    }
}

/// The square with edge cables at `n` x `n` cells, its fabric prestressed by `prestress` N/m
/// (isotropic; 0: stress-free).
fn square_scene(n: usize, prestress: f64) -> Scene {
    let prestress = if prestress > 0.0 {
        format!(r#", "prestress": {{"kind": "isotropic", "n": {prestress:e}}}"#)
    } else {
        String::new()
    };
    let text = format!(
        r#"{{"format": 1, "name": "ScaleSquare",
  "geometry": {{"generators": [{{"kind": "rectangle", "name": "sheet", "origin": [0, 0, 0], "size": [4.0, 4.0], "divisions": [{n}, {n}]}}]}},
  "membranes": [{{"name": "fabric", "triangles": "sheet", "thickness": 1e-3, "material": {{"kind": "svk", "E": 6e8, "nu": 0.3}}{prestress}}}],
  "cables": [
    {{"name": "edge_bottom", "nodes": "sheet.edge_bottom", "EA": 2e6, "pretension": 2000}},
    {{"name": "edge_right", "nodes": "sheet.edge_right", "EA": 2e6, "pretension": 2000}},
    {{"name": "edge_top", "nodes": "sheet.edge_top", "EA": 2e6, "pretension": 2000}},
    {{"name": "edge_left", "nodes": "sheet.edge_left", "EA": 2e6, "pretension": 2000}}],
  "supports": [
    {{"nodes": "sheet.corner_bl", "fix": ["x", "y", "z"]}}, {{"nodes": "sheet.corner_br", "fix": ["x", "y", "z"]}},
    {{"nodes": "sheet.corner_tl", "fix": ["x", "y", "z"]}}, {{"nodes": "sheet.corner_tr", "fix": ["x", "y", "z"]}}],
  "inputs": [{{"name": "wind", "load": {{"kind": "pressure", "membrane": "fabric", "follower": true}}, "start": 0, "min": -1000, "max": 300}}],
  "outputs": [{{"name": "center_uz", "probe": {{"kind": "displacement", "node": "sheet.center", "component": "z"}}}}]}}"#
    );
    Scene::from_json(&text).expect("valid scene")
}

/// The square's mesh written explicitly with node ids and triangle order permuted (the same
/// generator as the disc's), every node and triangle set carried over under its name.
fn shuffled_square(scene: &Scene) -> Scene {
    let mesh = resolve(&scene.geometry);
    let perm = permutation(mesh.nodes.len()); // old id -> new id
    let tri_perm = permutation(mesh.triangles.len()); // old position -> new position
    let mut nodes = vec![[0.0; 3]; mesh.nodes.len()];
    for (old, &new) in perm.iter().enumerate() {
        nodes[new] = mesh.nodes[old];
    }
    let mut triangles = vec![[OneNode::Id(0), OneNode::Id(0), OneNode::Id(0)]; tri_perm.len()];
    for (old, &new) in tri_perm.iter().enumerate() {
        triangles[new] = mesh.triangles[old].map(|i| OneNode::Id(perm[i]));
    }
    let mut out = scene.clone();
    out.geometry = Geometry {
        nodes,
        triangles,
        node_sets: mesh
            .node_sets
            .into_iter()
            .map(|(name, set)| (name, set.into_iter().map(|i| perm[i]).collect()))
            .collect(),
        triangle_sets: mesh
            .triangle_sets
            .into_iter()
            .map(|(name, set)| (name, set.into_iter().map(|e| tri_perm[e]).collect()))
            .collect(),
        generators: Vec::new(),
    };
    out
}

/// `--scenes`: the stored entries of the factor of every shipped scene in each internal node
/// order (the symbolic factorization only; no solve).
fn scenes() {
    let root = format!("{}/modelDescription", env!("CARGO_MANIFEST_DIR"));
    let mut dirs: Vec<_> = std::fs::read_dir(&root)
        .expect("modelDescription")
        .filter_map(|e| e.ok().map(|e| e.path()))
        .collect();
    dirs.sort();
    let orders = [
        NodeOrder::Given,
        NodeOrder::Rings,
        NodeOrder::Rcm,
        NodeOrder::Hilbert,
    ];
    println!(
        "{:<24} {:>7} {:>10} {:>10} {:>10} {:>10}",
        "scene", "DOF", "given", "rings", "rcm", "hilbert"
    );
    for dir in dirs {
        let Ok(text) = std::fs::read_to_string(dir.join("scene.json")) else {
            continue;
        };
        let scene = Scene::from_json(&text).expect("a shipped scene is valid");
        let mut line = String::new();
        let mut dofs = 0;
        for order in orders {
            let mut scene = scene.clone();
            scene.solver.node_order = order;
            let engine = Engine::try_new(scene).expect("a shipped scene builds");
            dofs = engine.free_dofs();
            line += &format!(" {:>10}", engine.factor_nonzeros());
        }
        let name = dir.file_name().unwrap().to_string_lossy().into_owned();
        println!("{name:<24} {dofs:>7}{line}");
    }
}

/// The CPU's model name (/proc/cpuinfo), or "unknown".
fn cpu_model() -> String {
    std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|t| {
            t.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split(':').nth(1))
                .map(|m| m.trim().to_string())
        })
        .unwrap_or_else(|| "unknown".into())
}

fn load_average() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .map(|t| t.split_whitespace().take(3).collect::<Vec<_>>().join(" "))
        .unwrap_or_default()
}

/// Median, least and largest of `v`.
fn spread(v: &[f64]) -> (f64, f64, f64) {
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    let m = s.len() / 2;
    let median = if s.len() % 2 == 1 {
        s[m]
    } else {
        0.5 * (s[m - 1] + s[m])
    };
    (median, s[0], s[s.len() - 1])
}

/// One `velarium solve` as a child process: (wall s, CPU s of the child, peak resident MiB of
/// the child, its stderr).
// The child is reaped by libc::wait4 (which also gives its rusage), not by Child::wait.
#[allow(clippy::zombie_processes)]
fn solve_process(velarium: &std::path::Path, args: &[String]) -> (f64, f64, f64, String) {
    use std::io::Read;
    let start = Instant::now();
    let mut child = std::process::Command::new(velarium)
        .args(args)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("velarium starts");
    let mut stderr = String::new();
    child
        .stderr
        .take()
        .expect("piped")
        .read_to_string(&mut stderr)
        .expect("stderr");
    // SAFETY: wait4 writes the child's status and one rusage into the zeroed values given; the
    // child is ours and not yet waited for (std's Child is never waited on after this).
    let mut status = 0;
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    let pid = child.id() as libc::pid_t;
    let waited = unsafe { libc::wait4(pid, &mut status, 0, &mut usage) };
    let wall = start.elapsed().as_secs_f64();
    assert_eq!(waited, pid, "wait4");
    assert!(
        libc::WIFEXITED(status) && libc::WEXITSTATUS(status) == 0,
        "velarium solve failed: {stderr}"
    );
    let secs = |t: libc::timeval| t.tv_sec as f64 + 1e-6 * t.tv_usec as f64;
    let cpu = secs(usage.ru_utime) + secs(usage.ru_stime);
    (wall, cpu, usage.ru_maxrss as f64 / 1024.0, stderr)
}

/// `--e2e`: what a user waits for. For each size, the Hencky disc's scene (the shipped one at
/// that many rings) and a one-row load table (40 Pa) are written to a scratch directory and
/// `velarium solve` (built next to this example: `cargo build --release` first) runs them
/// `runs` times as a process of its own; printed per run and as median [least, largest]: the
/// whole process's wall time, its setup and solve (`--timings`), its CPU time and peak resident
/// set (wait4), with the CPU model and the load average before each run. Threads: `--threads=N`
/// if given, else `velarium solve`'s default (the machine's cores).
fn e2e(sizes: &[(usize, usize)], threads: Option<usize>, runs: usize) {
    let exe = std::env::current_exe().expect("this example's path");
    let velarium = exe
        .parent()
        .and_then(|d| d.parent())
        .map(|d| d.join("velarium"))
        .expect("target/<profile>/velarium");
    assert!(
        velarium.exists(),
        "{} missing: cargo build --release first",
        velarium.display()
    );
    let dir = std::env::temp_dir().join(format!("velarium-e2e-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("scratch directory");
    let path = format!(
        "{}/modelDescription/HenckyDisc/scene.json",
        env!("CARGO_MANIFEST_DIR")
    );
    let text = std::fs::read_to_string(&path).expect("shipped scene");
    println!(
        "e2e: `velarium solve` of the Hencky disc, flat to 40 Pa in one load row, {runs} runs per size; CPU {}, {} cores available",
        cpu_model(),
        std::thread::available_parallelism().map_or(0, |n| n.get())
    );
    for &(rings, _) in sizes {
        let mut value: serde_json::Value = serde_json::from_str(&text).expect("scene JSON");
        value["geometry"]["generators"][0]["rings"] = rings.into();
        let scene = dir.join(format!("disc{rings}.json"));
        std::fs::write(&scene, value.to_string()).expect("scene written");
        let loads = dir.join("loads.csv");
        std::fs::write(&loads, "time,pressure\n0,40\n").expect("loads written");
        let out = dir.join("out.csv");
        let mut args: Vec<String> = vec![
            "solve".into(),
            scene.display().to_string(),
            "--loads".into(),
            loads.display().to_string(),
            "--out".into(),
            out.display().to_string(),
            "--quiet".into(),
            "--timings".into(),
        ];
        if let Some(t) = threads {
            args.push(format!("--threads={t}"));
        }
        let (mut wall, mut setup, mut solve, mut cpu, mut peak) =
            (Vec::new(), Vec::new(), Vec::new(), Vec::new(), Vec::new());
        for run in 0..runs {
            let load = load_average();
            let (w, c, p, stderr) = solve_process(&velarium, &args);
            let line = stderr
                .lines()
                .find(|l| l.contains("timings:"))
                .unwrap_or_else(|| panic!("no timings line in: {stderr}"))
                .to_string();
            let field = |name: &str| -> f64 {
                let rest = &line[line.find(name).expect("field") + name.len()..];
                rest.split_whitespace()
                    .next()
                    .and_then(|v| v.parse().ok())
                    .expect("a number")
            };
            let (su, so) = (field("setup "), field("solve "));
            // What the process spends besides the engine's setup and solve: reading the
            // scene, writing the CSV, and starting and ending the process (the rest of wall).
            let (read, write) = (field("read "), field("write "));
            let rest = w - read - su - so - write;
            let csv = std::fs::read_to_string(&out).expect("result CSV");
            let row = csv.lines().nth(1).expect("one row");
            let w0: f64 = row
                .split(',')
                .nth(1)
                .and_then(|v| v.parse().ok())
                .expect("w0");
            let check = (w0 / 0.5 - W_FOLLOWER).abs() / W_FOLLOWER;
            let used = line.rsplit(", ").next().unwrap_or("").to_string();
            println!(
                "disc {rings} rings, run {}: wall {w:.2} s, setup {su:.2} s, solve {so:.2} s, read {read:.3} s, write {write:.3} s, process start and exit {rest:.3} s, cpu {c:.2} s, peak {p:.0} MiB, {used}, w0 error {check:.2e}, load average before {load}",
                run + 1
            );
            wall.push(w);
            setup.push(su);
            solve.push(so);
            cpu.push(c);
            peak.push(p);
        }
        let show = |name: &str, v: &[f64], unit: &str, digits: usize| {
            let (m, lo, hi) = spread(v);
            format!("{name} {m:.digits$} [{lo:.digits$}, {hi:.digits$}] {unit}")
        };
        println!(
            "disc {rings} rings, median [range] of {runs}: {}, {}, {}, {}, {}; load average now {}",
            show("wall", &wall, "s", 2),
            show("setup", &setup, "s", 2),
            show("solve", &solve, "s", 2),
            show("cpu", &cpu, "s", 2),
            show("peak", &peak, "MiB", 0),
            load_average()
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}
