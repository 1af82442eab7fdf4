//! GOAL: `solver.threads` changes where the work runs, not the answer: the same scene solved
//!       with 1 and with 2 threads takes the same Newton iterations every step and gives the
//!       same outputs to round-off; 2 threads repeat their own answer bit for bit; below the
//!       two-domain threshold (20 000 equations, `SPLIT_MIN_EQUATIONS`) 2 threads change
//!       nothing, bit for bit; and a bad count is a validation error naming `solver.threads`.
//! MESH: HenckyDisc at 50 rings (22 053 free DOF: the two-domain factorization, src/solver/
//!       split.rs, runs; the separator is printed), WrinkledShear at 152 x 52 divisions
//!       (23 409 free DOF, wrinkled and slack states, prescribed displacements), the shipped
//!       HenckyDisc (2163 DOF) and SlidingCable (18 unknowns) below the threshold.
//! BOUNDARY CONDITIONS / PARAMETERS: the scenes' own; HenckyDisc to q = 40 Pa in one step (the
//!       flat start), WrinkledShear sheared to 3 mm in 5 rows, SlidingCable loaded to P = 200 N,
//!       p = 20 N in 10 rows with mu = 0 and mu = 0.3 (the rows of verify_sliding_cable.rs).
//! REFERENCE: the 1-thread run of the same scene, itself verified against closed forms in
//!       verify_hencky_disc.rs, verify_wrinkled_shear.rs and verify_sliding_cable.rs; here the
//!       2-thread 50-ring deflection is also checked against w0/a = 0.065404 (follower,
//!       docs/mechanics.md 4a) within 1e-3 (the 50-ring mesh's discretisation error: measured
//!       9.0e-5 with either count).
//!       Why round-off and not bits: with 2 threads the tangent is eliminated in another order
//!       (two halves, then their separator: split.rs), so the factor's sums are grouped
//!       differently. Tolerance on every output, relative to the output's size over the whole
//!       run: HenckyDisc 1e-13 (measured 3.7e-15), WrinkledShear 1e-12 (measured 1.5e-13: the
//!       worse conditioned tangent of wrinkled elements). Below the threshold: 0. The
//!       differences are printed. Iteration counts: equal, step by step.
mod common;
use common::*;
use velarium::scene::Generator;
use velarium::{Engine, Scene};

/// One run: per step the Newton iterations and every output.
type Run = Vec<(usize, Vec<(String, f64)>)>;

fn with_threads(mut scene: Scene, threads: usize) -> Engine {
    scene.solver.threads = threads;
    engine(scene)
}

fn run(scene: &Scene, threads: usize, steps: &[Vec<(&str, f64)>]) -> Run {
    let mut e = with_threads(scene.clone(), threads);
    let mut out = Vec::new();
    for step in steps {
        for &(name, value) in step {
            set(&mut e, name, value);
        }
        let report = solve(&mut e);
        out.push((report.iterations, e.outputs()));
    }
    out
}

/// Largest difference between the two runs relative to each output's size over the run.
fn compare(name: &str, one: &Run, two: &Run, tolerance: f64) -> f64 {
    assert_eq!(one.len(), two.len());
    let iterations = |r: &Run| r.iter().map(|s| s.0).collect::<Vec<_>>();
    assert_eq!(
        iterations(one),
        iterations(two),
        "{name}: Newton iterations per step, 1 thread vs 2"
    );
    let outputs = one[0].1.len();
    let mut worst: f64 = 0.0;
    for k in 0..outputs {
        let scale = one
            .iter()
            .map(|s| s.1[k].1.abs())
            .fold(0.0f64, f64::max)
            .max(f64::MIN_POSITIVE);
        for (a, b) in one.iter().zip(two) {
            let (label, x) = &a.1[k];
            let y = b.1[k].1;
            let d = (x - y).abs();
            assert!(
                d <= tolerance * scale,
                "{name}: {label} = {x:e} on 1 thread, {y:e} on 2 (difference {d:e}, scale {scale:e})"
            );
            worst = worst.max(d / scale);
        }
    }
    println!(
        "{name}: iterations {:?}, largest relative difference 1 vs 2 threads {worst:.2e}",
        iterations(one)
    );
    worst
}

fn hencky_steps() -> Vec<Vec<(&'static str, f64)>> {
    vec![vec![], vec![("pressure", 40.0)]]
}

fn disc(rings: usize) -> Scene {
    let mut scene = read_scene(&shipped("HenckyDisc"));
    let Generator::Disc { rings: r, .. } = &mut scene.geometry.generators[0] else {
        panic!("HenckyDisc is a generated disc");
    };
    *r = rings;
    scene
}

#[test]
fn hencky_disc_two_threads_agree_with_one() {
    let scene = disc(50);
    let e = with_threads(scene.clone(), 2);
    let split = e.split_sizes().expect("factored in two halves");
    println!(
        "HenckyDisc 50 rings: {} free DOF, split {split:?}",
        e.free_dofs()
    );
    drop(e);
    let one = run(&scene, 1, &hencky_steps());
    let two = run(&scene, 2, &hencky_steps());
    compare("HenckyDisc", &one, &two, 1e-13);
    let w = two[1].1.iter().find(|o| o.0 == "center_uz").unwrap().1 / 0.5;
    let error = rel(w, 0.065404);
    println!("HenckyDisc 2 threads: w0/a = {w:.6}, error {error:.2e}");
    assert!(error < 1e-3, "w0/a = {w} against 0.065404: {error:e}");
    // A fixed split: a second 2-thread run repeats the first bit for bit.
    let again = run(&scene, 2, &hencky_steps());
    assert_eq!(two, again, "two 2-thread runs differ");
}

#[test]
fn wrinkled_shear_two_threads_agree_with_one() {
    let mut scene = read_scene(&shipped("WrinkledShear"));
    let Generator::Rectangle { divisions, .. } = &mut scene.geometry.generators[0] else {
        panic!("WrinkledShear is a generated rectangle");
    };
    *divisions = [152, 52];
    let e = with_threads(scene.clone(), 2);
    let split = e.split_sizes().expect("factored in two halves");
    println!(
        "WrinkledShear 152 x 52: {} free DOF, split {split:?}",
        e.free_dofs()
    );
    drop(e);
    let mut steps = vec![vec![]];
    for k in 1..=5 {
        steps.push(vec![("shear", 3e-3 * k as f64 / 5.0)]);
    }
    let one = run(&scene, 1, &steps);
    let two = run(&scene, 2, &steps);
    compare("WrinkledShear", &one, &two, 1e-12);
    let wrinkled = two[5]
        .1
        .iter()
        .find(|o| o.0 == "wrinkled_fraction")
        .unwrap()
        .1;
    assert!(wrinkled > 0.5, "the sheared film wrinkles: {wrinkled}");
}

#[test]
fn below_the_threshold_two_threads_change_nothing() {
    let scene = read_scene(&shipped("HenckyDisc"));
    let one = run(&scene, 1, &hencky_steps());
    let two = run(&scene, 2, &hencky_steps());
    assert_eq!(one, two, "HenckyDisc (2163 DOF)");
    assert_eq!(with_threads(scene, 2).split_sizes(), None);
    for mu in [0.0, 0.3] {
        let scene = read_scene(&shipped("SlidingCable"));
        let mut steps = vec![vec![("mu", mu)]];
        for k in 1..=10 {
            steps.push(vec![("P", 20.0 * k as f64), ("p", 2.0 * k as f64)]);
        }
        let one = run(&scene, 1, &steps);
        let two = run(&scene, 2, &steps);
        assert_eq!(one, two, "SlidingCable mu = {mu}");
    }
}

#[test]
fn a_bad_thread_count_names_the_field() {
    for bad in [0usize, 65] {
        let mut scene = read_scene(&shipped("HenckyDisc"));
        scene.solver.threads = bad;
        let message = match Engine::try_new(scene) {
            Ok(_) => panic!("threads = {bad} was accepted"),
            Err(e) => e.to_string(),
        };
        assert!(
            message.contains("solver.threads") && message.contains(&bad.to_string()),
            "{message}"
        );
    }
    // From JSON: a negative or fractional count is a type error at the same path.
    let text = std::fs::read_to_string(shipped("HenckyDisc")).unwrap();
    let mut value: serde_json::Value = serde_json::from_str(&text).unwrap();
    value["solver"] = serde_json::json!({"threads": 1.5});
    let message = match Scene::from_json(&value.to_string()) {
        Ok(_) => panic!("threads = 1.5 was accepted"),
        Err(e) => e.to_string(),
    };
    assert!(message.contains("solver.threads"), "{message}");
}

/// `velarium solve --threads N`: 0 is refused by the argument parser naming the flag; on the
/// shipped HenckyDisc (below the two-domain threshold) 2 writes exactly the rows of 1.
#[test]
fn the_cli_flag() {
    let dir = std::env::temp_dir().join(format!("velarium-threads-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let loads = dir.join("loads.csv");
    std::fs::write(&loads, "time,pressure\n0,0\n1,20\n2,40\n").unwrap();
    let solve = |threads: &str| {
        std::process::Command::new(env!("CARGO_BIN_EXE_velarium"))
            .args(["solve", &shipped("HenckyDisc"), "--loads"])
            .arg(&loads)
            .args(["--quiet", "--threads", threads])
            .output()
            .unwrap()
    };
    let refused = solve("0");
    assert!(!refused.status.success());
    let message = String::from_utf8_lossy(&refused.stderr);
    assert!(message.contains("--threads"), "{message}");
    let table = |threads: &str| -> Vec<Vec<String>> {
        let out = solve(threads);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        String::from_utf8(out.stdout)
            .unwrap()
            .lines()
            .map(|l| l.split(',').map(str::to_string).collect())
            .collect()
    };
    let (one, two) = (table("1"), table("2"));
    assert_eq!(one.len(), 4, "header and 3 rows");
    assert_eq!(one, two);
    let _ = std::fs::remove_dir_all(&dir);
}
