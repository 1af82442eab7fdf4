//! The robustness corpus of issue 27, printed (the CI slice is asserted by
//! tests/solver/robustness.rs): `cargo run --release --example robustness -- [--quick]
//! [--family NAME]... [--seed N] [--list] [--verbose]`.
//!
//! Seeded families of scenes (examples/robustness/corpus.rs, docs/robustness.md), each member
//! solved loaded and then unloaded at default solver settings on one thread. Printed per
//! family: runs (load rows), the shares that converged right, failed honestly and came back
//! wrong (plus failures that were not honest, and rows skipped after a failure), the median and
//! largest Newton iterations and wall time of a row; then a total line, the failure messages
//! grouped, and every wrong or dishonest run with its reason.
//!
//! `--quick`: only the CI slice. `--family NAME` (repeatable, or comma-separated): only those
//! families. `--member TEXT`: only the members whose label contains TEXT. `--seed N`: another corpus (default 27). `--list`: the families and their member
//! counts, nothing solved. `--verbose`: one line per run as it finishes (stderr); with the
//! environment variable CORPUS_LOG set, also every solve's message and iteration log.
//! `--dump DIR`: write every selected member as DIR/<family>-<k>.json (the scene as solved:
//! form-found, sleeves added) and DIR/<family>-<k>-loads.csv (start, loaded, unloaded), for
//! `velarium solve DIR/<family>-<k>.json --loads DIR/<family>-<k>-loads.csv`; nothing solved.

#[path = "robustness/corpus.rs"]
mod corpus;

use corpus::Run;
use std::collections::BTreeMap;

fn main() {
    let mut quick = false;
    let mut list = false;
    let mut verbose = false;
    let mut dump: Option<String> = None;
    let mut seed = 27u64;
    let mut families: Vec<String> = Vec::new();
    let mut only: Option<String> = None;
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        let mut value = |flag: &str| {
            args.next()
                .unwrap_or_else(|| fail(&format!("{flag} needs a value")))
        };
        match a.as_str() {
            "--quick" => quick = true,
            "--list" => list = true,
            "--verbose" => verbose = true,
            "--seed" => {
                seed = value("--seed")
                    .parse()
                    .unwrap_or_else(|_| fail("--seed takes an unsigned integer"))
            }
            "--family" => families.extend(value("--family").split(',').map(String::from)),
            "--dump" => dump = Some(value("--dump")),
            "--member" => only = Some(value("--member")),
            "--help" | "-h" => {
                println!("cargo run --release --example robustness -- [--quick] [--family NAME]... [--seed N] [--list] [--verbose] [--dump DIR] [--member TEXT]");
                return;
            }
            other => fail(&format!("unknown argument {other} (try --help)")),
        }
    }
    for f in &families {
        if !corpus::FAMILIES.iter().any(|(n, _)| n == f) {
            fail(&format!("no family {f} (--list names them)"));
        }
    }
    let members: Vec<corpus::Member> = corpus::members(seed)
        .into_iter()
        .filter(|m| !quick || m.quick)
        .filter(|m| families.is_empty() || families.iter().any(|f| f == m.family))
        .filter(|m| only.as_ref().is_none_or(|t| m.label.contains(t.as_str())))
        .collect();
    if let Some(dir) = dump {
        write_scenes(&dir, &members);
        return;
    }
    if list {
        println!("{:<16} {:>8} {:>6}  what", "family", "members", "quick");
        for (name, what) in corpus::FAMILIES {
            let all = corpus::members(seed);
            let of: Vec<_> = all.iter().filter(|m| m.family == *name).collect();
            println!(
                "{name:<16} {:>8} {:>6}  {what}",
                of.len(),
                of.iter().filter(|m| m.quick).count()
            );
        }
        return;
    }
    println!(
        "robustness corpus: seed {seed}, {} members{}",
        members.len(),
        if quick { " (quick slice)" } else { "" }
    );
    let start = std::time::Instant::now();
    let mut runs: Vec<Run> = Vec::new();
    for m in &members {
        let t = std::time::Instant::now();
        let done = corpus::run_member(m);
        if verbose {
            for r in &done {
                eprintln!(
                    "{:<16} {:<8} {:>4} it {:>8.3} s  {}  [{}]  {}",
                    r.family,
                    r.row,
                    r.iterations,
                    r.seconds,
                    corpus::short(&r.verdict),
                    r.notes.join(", "),
                    r.member
                );
            }
            eprintln!("  member total {:.2} s", t.elapsed().as_secs_f64());
        }
        runs.extend(done);
    }
    print!("{}", corpus::table(&runs));
    println!(
        "wall time {:.1} s on one thread",
        start.elapsed().as_secs_f64()
    );
}

fn fail(why: &str) -> ! {
    eprintln!("robustness: {why}");
    std::process::exit(2)
}

/// The scenes and load tables of `members` for `velarium solve`.
fn write_scenes(dir: &str, members: &[corpus::Member]) {
    std::fs::create_dir_all(dir).unwrap_or_else(|e| fail(&format!("{dir}: {e}")));
    let mut count: BTreeMap<&str, usize> = BTreeMap::new();
    for m in members {
        let k = count.entry(m.family).or_default();
        let stem = format!("{dir}/{}-{k}", m.family);
        *k += 1;
        let scene = match corpus::solved_scene(m) {
            Ok(s) => s,
            Err(e) => {
                eprintln!("{stem}: {e} (the scene as built is written)");
                m.scene.clone()
            }
        };
        let mut names: Vec<&str> = Vec::new();
        for r in &m.rows {
            for (n, _) in &r.set {
                if !names.contains(n) {
                    names.push(n);
                }
            }
        }
        let start = |n: &str| {
            scene
                .inputs
                .iter()
                .find(|i| i.name == n)
                .map_or(0.0, |i| i.start)
        };
        let mut csv = format!("# {} {}\ntime,{}\n", m.family, m.label, names.join(","));
        let mut values: Vec<f64> = names.iter().map(|n| start(n)).collect();
        let line = |t: usize, v: &[f64]| {
            let cells: Vec<String> = v.iter().map(|x| format!("{x:e}")).collect();
            format!("{t},{}\n", cells.join(","))
        };
        csv.push_str(&line(0, &values));
        for (t, r) in m.rows.iter().enumerate() {
            for (n, v) in &r.set {
                let i = names.iter().position(|x| x == n).unwrap();
                values[i] = *v;
            }
            csv.push_str(&line(t + 1, &values));
        }
        let write = |path: String, text: String| {
            std::fs::write(&path, text).unwrap_or_else(|e| fail(&format!("{path}: {e}")))
        };
        write(format!("{stem}.json"), scene.to_json());
        write(format!("{stem}-loads.csv"), csv);
    }
    println!("{} members written to {dir}", members.len());
}
