//! GOAL: `solver.threads` changes where the work runs, not the answer: the same scene solved
//!       with 1 and with 2 threads takes the same Newton iterations every step and gives the
//!       same outputs to round-off; 2 threads repeat their own answer bit for bit; below the
//!       two-domain threshold (20 000 equations, `SPLIT_MIN_EQUATIONS`) 2 threads change
//!       nothing, bit for bit; and a bad count is a validation error naming `solver.threads`.
//! MESH: HenckyDisc at 50 rings (22 053 free DOF: the two-domain factorization, src/solver/
//!       split.rs, and the two-thread assembly run; the separator is printed), WrinkledShear at
//!       152 x 52 divisions (23 409 free DOF, wrinkled and slack states, prescribed
//!       displacements), CabledSquare at 84 x 84 cells (21 663 free DOF), the shipped
//!       HenckyDisc (2163 DOF) and SlidingCable (18 unknowns) below the threshold.
//! BOUNDARY CONDITIONS / PARAMETERS: the scenes' own; HenckyDisc to q = 40 Pa in one step (the
//!       flat start), WrinkledShear sheared to 3 mm in 5 rows, SlidingCable loaded to P = 200 N,
//!       p = 20 N in 10 rows with mu = 0 and mu = 0.3 (the rows of tests/verification/sliding_cable.rs).
//! REFERENCE: the 1-thread run of the same scene, itself verified against closed forms in
//!       tests/verification/hencky_disc.rs, wrinkled_shear.rs and sliding_cable.rs; here the
//!       2-thread 50-ring deflection is also checked against w0/a = 0.065404 (follower,
//!       docs/mechanics.md 4a) within 1e-3 (the 50-ring mesh's discretisation error: measured
//!       9.0e-5 with either count).
//!       Why round-off and not bits: with 2 threads the tangent is eliminated in another order
//!       (two halves, then their separator: split.rs), so the factor's sums are grouped
//!       differently. Tolerance on every output, relative to the output's size over the whole
//!       run: HenckyDisc 3e-13 (measured 5.6e-14, 6.4e-14 before branch i15u balanced the halves'
//!       flops; 3.7e-15 before the assembly ran on two
//!       threads too: its sums along the cut between the halves are grouped differently,
//!       see below, and the last Newton correction carries that round-off of R through the
//!       tangent's conditioning), WrinkledShear 1e-12 (measured 2.1e-13 after main's wrinkling changes of f040edf, 8.2e-14
//!       with the count-balanced separator: the worse
//!       conditioned tangent of wrinkled elements), CabledSquare 1e-13 (measured 3.6e-15). Below the threshold: 0. The
//!       differences are printed. Iteration counts: equal, step by step.
//!       CabledSquare: the scale example's 4 m square with four edge cables (EA 2 MN,
//!       pretension 2 kN), fabric prestress 1 kN/m, at 84 x 84 cells (21 663 free DOF), follower
//!       pressure 150 then 300 Pa: cable segments next to the two-thread assembly.
//!
//! The assembly on two threads (src/solver/assemble.rs, `Parallel`) is checked on its own too,
//! by assembling the same state with one and with two threads (no solve): the HenckyDisc at 50
//! rings (follower pressure), the WrinkledShear film at 152 x 52 with every third triangle's
//! state frozen, and the SleeveCable sheet at 100 x 100 divisions (20 202 free DOF: cable
//! segments, sleeve ties and point loads next to the triangles), each at a random displacement
//! (deterministic generator, 1e-3 of the model's length). Every triangle is evaluated from
//! the same positions by the same routine, so the evaluations (state, angle, stress, energy)
//! and the largest carried force and smallest area ratio must be equal bit for bit. R and K
//! are sums whose terms meet in another grouping along the cut between the halves: regrouping
//! a sum of at most n terms changes it by at most (n − 1)·ε·Σ|terms| (Higham 2002, Accuracy
//! and Stability of Numerical Algorithms, §4.2). A DOF meets at most 16 terms here (6
//! triangles, their 6 pressures, 2 segments, a tie, a point load), so R's tolerance is 16·ε
//! times the DOF's force magnitude (the sum of |terms| the assembly reports), K's 16·ε times
//! the largest |K| entry of its column (the assembly gives no per-entry magnitude), and the
//! potential's
//! 1e-12 of Σ|element energy|. The worst measured ratios are printed. Two 2-thread assemblies
//! agree bit for bit.
use crate::common;
use common::*;
use std::sync::Arc;
use velarium::model::membrane::Evaluation;
use velarium::model::wrinkling::WrinkleState;
use velarium::model::Model;
use velarium::scene::Generator;
use velarium::solver::assemble::{
    assemble_with, AssemblyInfo, AssemblyScratch, Membranes, Parallel, Pattern,
};
use velarium::solver::threads::Pool;
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
    let halves = e.assembly_halves().expect("assembled on two threads");
    println!(
        "HenckyDisc 50 rings: {} free DOF, split {split:?}, assembly halves {halves:?}",
        e.free_dofs()
    );
    drop(e);
    let one = run(&scene, 1, &hencky_steps());
    let two = run(&scene, 2, &hencky_steps());
    compare("HenckyDisc", &one, &two, 3e-13);
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

/// The SleeveCable scene on an `nx` x `ny` sheet (square cells, 80 mm wide): the sleeve along
/// the whole top edge, the cable's free end 100 mm beyond the top-right corner A.
fn sleeve_sheet(nx: usize, ny: usize) -> Scene {
    let text = std::fs::read_to_string(shipped("SleeveCable")).unwrap();
    let mut v: serde_json::Value = serde_json::from_str(&text).unwrap();
    let height = 0.08 * ny as f64 / nx as f64;
    let g = &mut v["geometry"]["generators"][0];
    g["divisions"] = serde_json::json!([nx, ny]);
    g["size"] = serde_json::json!([0.08, height]);
    // Node 0 is the cable's end; the rectangle's nodes follow row by row from the bottom.
    let top = 1 + ny * (nx + 1);
    let mut cable: Vec<usize> = (top..=top + nx).collect();
    cable.push(0);
    v["cables"][0]["nodes"] = serde_json::json!(cable);
    v["geometry"]["nodes"][0] = serde_json::json!([0.18, height, 0.0]);
    v["geometry"]["node_sets"]["sleeve_start"] = serde_json::json!([top]);
    v["geometry"]["node_sets"]["A"] = serde_json::json!([top + nx]);
    Scene::from_json(&v.to_string()).unwrap_or_else(|e| panic!("{e}"))
}

fn shear_film() -> Scene {
    let mut scene = read_scene(&shipped("WrinkledShear"));
    let Generator::Rectangle { divisions, .. } = &mut scene.geometry.generators[0] else {
        panic!("WrinkledShear is a generated rectangle");
    };
    *divisions = [152, 52];
    scene
}

/// One assembly's outputs.
struct Assembled {
    r: Vec<f64>,
    k: Vec<f64>,
    magnitude: Vec<f64>,
    evaluations: Vec<Evaluation>,
    info: AssemblyInfo,
}

fn assemble_once(
    model: &Model,
    pattern: &Pattern,
    u: &[f64],
    loads: &[f64],
    forced: Option<&[Option<WrinkleState>]>,
    scratch: Option<&mut AssemblyScratch>,
) -> Assembled {
    let mut r = vec![0.0; model.dof_count()];
    let mut k = vec![f64::NAN; pattern.row_idx.len()];
    let mut magnitude = vec![0.0; model.dof_count()];
    let mut evaluations = Vec::new();
    let info = assemble_with(
        model,
        pattern,
        u,
        loads,
        &mut r,
        Some(&mut k),
        Membranes {
            forced,
            out: Some(&mut evaluations),
            magnitude: Some(&mut magnitude),
            scratch,
            ..Default::default()
        },
    );
    Assembled {
        r,
        k,
        magnitude,
        evaluations,
        info,
    }
}

/// Assemble `scene`'s model at a random displacement with one and with two threads and
/// compare (see the header). Returns the worst R and K differences in units of the bounds.
fn one_and_two_assemble(name: &str, scene: &Scene, frozen: bool) -> (f64, f64) {
    let model = Model::build(scene);
    let pattern = Arc::new(Pattern::try_new(&model).unwrap());
    let pool = Arc::new(Pool::try_new(2).unwrap());
    let parallel = Parallel::try_new(pool, &pattern)
        .unwrap()
        .expect("a helper's half");
    let (a, b) = parallel.halves();
    assert_eq!(a + b, model.triangles.len());
    let mut scratch = AssemblyScratch::with_parallel(Some(parallel));
    let mut rng = Rng(0x5e_ed0f_7e4d);
    let mut u = vec![0.0; model.unknown_count()];
    for (d, x) in u.iter_mut().enumerate().take(model.dof_count()) {
        if !model.held[d] {
            *x = 1e-3 * model.length_scale * rng.next();
        }
    }
    let loads: Vec<f64> = (0..model.loads.len()).map(|l| 10.0 + l as f64).collect();
    let states: Vec<Option<WrinkleState>> = (0..model.triangles.len())
        .map(|e| (e % 3 == 0).then_some(WrinkleState::Wrinkled))
        .collect();
    let forced = frozen.then_some(&states[..]);
    let one = assemble_once(&model, &pattern, &u, &loads, forced, None);
    let two = assemble_once(&model, &pattern, &u, &loads, forced, Some(&mut scratch));
    let again = assemble_once(&model, &pattern, &u, &loads, forced, Some(&mut scratch));
    assert_eq!(one.evaluations, two.evaluations, "{name}: evaluations");
    assert_eq!(one.info.carried, two.info.carried, "{name}: carried force");
    assert_eq!(
        one.info.min_area_ratio, two.info.min_area_ratio,
        "{name}: smallest area ratio"
    );
    assert_eq!(one.info.external, two.info.external, "{name}: |f_ext|");
    let eps = f64::EPSILON;
    let mut worst_r: f64 = 0.0;
    let mut differing_r = 0;
    for d in 0..one.r.len() {
        let bound = 16.0 * eps * one.magnitude[d];
        let diff = (one.r[d] - two.r[d]).abs();
        differing_r += usize::from(diff > 0.0);
        assert!(
            diff <= bound,
            "{name}: R[{d}] = {:e} on 1 thread, {:e} on 2 (bound {bound:e})",
            one.r[d],
            two.r[d]
        );
        if bound > 0.0 {
            worst_r = worst_r.max(diff / bound);
        }
        let m = (one.magnitude[d] - two.magnitude[d]).abs();
        assert!(m <= bound, "{name}: magnitude at DOF {d}");
    }
    let mut worst_k: f64 = 0.0;
    let mut differing_k = 0;
    let largest = |column: &[f64]| column.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let cp = &pattern.col_ptr;
    let column_of = |p: usize| cp.partition_point(|&c| c <= p) - 1;
    for (p, (x, y)) in one.k.iter().zip(&two.k).enumerate() {
        let j = column_of(p);
        let kmax = largest(&one.k[cp[j]..cp[j + 1]]);
        assert!(kmax > 0.0 && kmax.is_finite(), "{name}: column {j}");
        let bound = 16.0 * eps * kmax;
        let diff = (x - y).abs();
        assert!(
            diff <= bound,
            "{name}: K value {p} = {x:e} on 1 thread, {y:e} on 2 (bound {bound:e})"
        );
        differing_k += usize::from(diff > 0.0);
        worst_k = worst_k.max(diff / bound);
    }
    let energies: f64 = one.evaluations.iter().map(|e| e.energy.abs()).sum();
    let dp = (one.info.potential - two.info.potential).abs();
    assert!(
        dp <= 64.0 * eps * energies,
        "{name}: potential {:e} on 1 thread, {:e} on 2",
        one.info.potential,
        two.info.potential
    );
    // Deterministic: the same thread count gives the same bits.
    assert_eq!(two.r, again.r, "{name}: two 2-thread residuals");
    assert_eq!(
        two.k.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
        again.k.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
        "{name}: two 2-thread tangents"
    );
    assert_eq!(two.info.potential, again.info.potential);
    // Residual only (the line search's assemblies): the same R.
    let mut r1 = vec![0.0; model.dof_count()];
    let mut r2 = vec![0.0; model.dof_count()];
    let plain = |scratch| Membranes {
        forced,
        scratch,
        ..Default::default()
    };
    assemble_with(&model, &pattern, &u, &loads, &mut r1, None, plain(None));
    assemble_with(
        &model,
        &pattern,
        &u,
        &loads,
        &mut r2,
        None,
        plain(Some(&mut scratch)),
    );
    assert_eq!(
        r2, two.r,
        "{name}: residual-only assembly against the full one"
    );
    for d in 0..r1.len() {
        assert!((r1[d] - r2[d]).abs() <= 16.0 * eps * one.magnitude[d]);
    }
    println!(
        "{name}: {} triangles ({a} + {b}), {} K values; differing: {differing_r} of {} R, \
         {differing_k} of {} K; worst |R1 - R2| = {worst_r:.3} of 16 eps |terms|, worst \
         |K1 - K2| = {worst_k:.3} of 16 eps |K_column|max, potential {:e} against {:e} on 1 \
         thread ({:.3} of 64 eps sum |energy|)",
        model.triangles.len(),
        one.k.len(),
        one.r.len(),
        one.k.len(),
        two.info.potential,
        one.info.potential,
        dp / (64.0 * eps * energies)
    );
    (worst_r, worst_k)
}

#[test]
fn the_two_thread_assembly_agrees_with_one() {
    one_and_two_assemble("HenckyDisc 50 rings", &disc(50), false);
    one_and_two_assemble("WrinkledShear 152 x 52, frozen states", &shear_film(), true);
    let sleeve = sleeve_sheet(100, 100);
    let model = Model::build(&sleeve);
    assert!(!model.segments.is_empty() && !model.ties.is_empty());
    one_and_two_assemble("SleeveCable 100 x 100", &sleeve, false);
}

/// A 4 m square membrane with edge cables at `n` x `n` cells (the scale example's `square`,
/// fabric prestress 1 kN/m), corners fixed, under a follower pressure `wind`.
fn cabled_square(n: usize) -> Scene {
    let text = format!(
        r#"{{"format": 1, "name": "CabledSquare",
  "geometry": {{"generators": [{{"kind": "rectangle", "name": "sheet", "origin": [0, 0, 0], "size": [4.0, 4.0], "divisions": [{n}, {n}]}}]}},
  "membranes": [{{"name": "fabric", "triangles": "sheet", "thickness": 1e-3, "material": {{"kind": "svk", "E": 6e8, "nu": 0.3}}, "prestress": {{"kind": "isotropic", "n": 1e3}}}}],
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
    Scene::from_json(&text).unwrap_or_else(|e| panic!("{e}"))
}

/// The cabled square solved with one and two threads: cable segments alongside the
/// two-thread assembly (follower pressure on both halves) and factorization.
#[test]
fn cabled_square_two_threads_agree_with_one() {
    let scene = cabled_square(84);
    let e = with_threads(scene.clone(), 2);
    let halves = e.assembly_halves().expect("assembled on two threads");
    println!(
        "CabledSquare 84 x 84: {} free DOF, assembly halves {halves:?}, split {:?}",
        e.free_dofs(),
        e.split_sizes()
    );
    assert_eq!(with_threads(scene.clone(), 1).assembly_halves(), None);
    drop(e);
    let steps: Vec<Vec<(&str, f64)>> = vec![vec![], vec![("wind", 150.0)], vec![("wind", 300.0)]];
    let one = run(&scene, 1, &steps);
    let two = run(&scene, 2, &steps);
    compare("CabledSquare 84 x 84", &one, &two, 1e-13);
}
