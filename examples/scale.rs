//! Scaling benchmark, printed (not asserted; issue 15 item 6):
//! `cargo run --release --example scale -- [RINGS...] [--no-shuffle] [--threads N]`.
//!
//! The Hencky disc (docs/mechanics.md §4a, follower pressure 40 Pa, flat start to full load in
//! one step) at the given ring counts (default 34 and 106 rings: about 10k and 100k free DOF;
//! 183 rings is about 300k, 334 rings about 1M DOF and about 3 GB: run those by hand, never
//! in CI), each in the generator's node numbering and in a shuffled numbering (the same mesh
//! written as explicit nodes and triangles with the node ids permuted by a fixed-seed
//! xorshift generator, as a user's mesher might number it).
//!
//! Printed per case: free DOF, numbering, stored entries of the LDLT factor after faer's AMD, Newton iterations, wall time of the solve, the
//! floor (one assembly + one numeric LDLT factorization and solve at the solution, best of 3,
//! `Engine::time_floor`), seconds per iteration divided by the floor, the process's peak
//! resident set so far (VmHWM from /proc/self/status; it only grows, so run one size per
//! process for a per-size peak), threads (1: faer runs `Par::Seq`), and the relative error of
//! the centre deflection against w0/a = 0.065404 (both numberings must agree).

use std::time::Instant;
use velarium::scene::{Generator, NodeOrder, Scene};
use velarium::Engine;

const W_FOLLOWER: f64 = 0.065404;

/// CPU seconds (user + system) of this process's threads so far, from /proc/self/task/*/stat:
/// (the main thread, which solves; all the others, the solver's helper).
fn cpu_seconds() -> (f64, f64) {
    let me = std::process::id().to_string();
    let (mut main, mut others) = (0.0, 0.0);
    for task in std::fs::read_dir("/proc/self/task")
        .into_iter()
        .flatten()
        .flatten()
    {
        let stat = std::fs::read_to_string(task.path().join("stat")).unwrap_or_default();
        // Fields after the command name (which ends with the last ')'): utime and stime are
        // the 12th and 13th of them, in clock ticks (100 per second on Linux).
        let rest = stat.rsplit_once(')').map_or("", |(_, r)| r);
        let f: Vec<f64> = rest
            .split_whitespace()
            .map(|x| x.parse().unwrap_or(0.0))
            .collect();
        let t = if f.len() > 12 {
            (f[11] + f[12]) / 100.0
        } else {
            0.0
        };
        if task.file_name().to_string_lossy() == me {
            main += t;
        } else {
            others += t;
        }
    }
    (main, others)
}

fn peak_rss_mib() -> f64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("VmHWM:"))
                .and_then(|l| l.split_whitespace().nth(1)?.parse::<f64>().ok())
        })
        .map_or(f64::NAN, |kib| kib / 1024.0)
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

fn run(label: &str, mut engine: Engine, threads: usize) {
    if std::env::args().any(|a| a == "--nnz-only") {
        println!(
            "{:>8} {:>13} {:>11}",
            engine.free_dofs(),
            label,
            engine.factor_nonzeros()
        );
        return;
    }
    let vr = engine
        .variables()
        .iter()
        .find(|v| v.name == "pressure")
        .unwrap()
        .value_reference;
    let out = engine
        .variables()
        .iter()
        .find(|v| v.name == "center_uz")
        .unwrap()
        .value_reference;
    let t = Instant::now();
    let cpu = cpu_seconds();
    engine.set_real(vr, 40.0).unwrap();
    let report = engine.solve();
    let time = t.elapsed().as_secs_f64();
    let (main, helper) = cpu_seconds();
    // The helper is started with the engine and joined when it is dropped: read both now.
    let cpu = format!("{:.2}+{:.2}", main - cpu.0, helper - cpu.1);
    if !report.converged() {
        println!("{label}: did not converge: {}", report.message);
        return;
    }
    let w = engine.get_real(out).unwrap() / 0.5;
    let (assembly, factor) = engine.time_floor(3);
    let floor = assembly + factor;
    println!(
        "{:>8} {:>13} {:>11} {:>6} {:>9.3} {:>11} {:>9.4} {:>9.4} {:>7.2} {:>9.0} {:>3} {:>10.2e}",
        engine.free_dofs(),
        label,
        engine.factor_nonzeros(),
        report.iterations,
        time,
        cpu,
        assembly,
        factor,
        time / report.iterations.max(1) as f64 / floor,
        peak_rss_mib(),
        threads,
        (w - W_FOLLOWER).abs() / W_FOLLOWER
    );
    if let Some((a, b, sep)) = engine.split_sizes() {
        println!(
            "{:>8} two halves of {a} and {b} equations, separator {sep}",
            ""
        );
    }
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let no_shuffle = args.iter().any(|a| a == "--no-shuffle");
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
    let threads = match args.iter().position(|a| a == "--threads") {
        Some(i) => match args.get(i + 1).and_then(|n| n.parse::<usize>().ok()) {
            Some(n) if (1..=64).contains(&n) => n,
            _ => {
                eprintln!("scale: --threads needs a count from 1 to 64");
                std::process::exit(2);
            }
        },
        None => 1,
    };
    let rings: Vec<usize> = args
        .iter()
        .enumerate()
        .filter(|(i, _)| *i == 0 || args[i - 1] != "--threads")
        .filter_map(|(_, a)| a.parse().ok())
        .collect();
    let rings = if rings.is_empty() {
        vec![34, 106]
    } else {
        rings
    };
    if args.iter().any(|a| a == "--scenes") {
        scenes();
        return;
    }
    let path = format!(
        "{}/modelDescription/HenckyDisc/scene.json",
        env!("CARGO_MANIFEST_DIR")
    );
    let base = Scene::from_json(&std::fs::read_to_string(&path).expect("shipped scene"))
        .expect("valid scene");
    println!(
        "Hencky disc, follower pressure 40 Pa, flat start to full load, {threads} thread(s), load average {}",
        std::fs::read_to_string("/proc/loadavg")
            .unwrap_or_default()
            .split_whitespace()
            .take(3)
            .collect::<Vec<_>>()
            .join(" ")
    );
    println!(
        "{:>8} {:>13} {:>11} {:>6} {:>9} {:>11} {:>9} {:>9} {:>7} {:>9} {:>3} {:>10}",
        "DOF",
        "numbering",
        "factor nnz",
        "iters",
        "total s",
        "cpu s m+h",
        "assem s",
        "factor s",
        "ratio",
        "peak MiB",
        "thr",
        "w0 error"
    );
    for n in rings {
        let mut scene = base.clone();
        scene.solver.threads = threads;
        if let Generator::Disc { rings, .. } = &mut scene.geometry.generators[0] {
            *rings = n;
        }
        let shuffled_scene = (!no_shuffle).then(|| {
            let engine = Engine::try_new(scene.clone()).expect("valid scene");
            shuffled(&engine, &scene)
        });
        for &order in &orders {
            let name = format!("{order:?}").to_lowercase();
            scene.solver.node_order = order;
            let engine = Engine::try_new(scene.clone()).expect("valid scene");
            run(&format!("gen/{name}"), engine, threads);
            if let Some(s) = &shuffled_scene {
                let mut s = s.clone();
                s.solver.node_order = order;
                run(
                    &format!("shuf/{name}"),
                    Engine::try_new(s).expect("valid shuffled scene"),
                    threads,
                );
            }
        }
    }
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
