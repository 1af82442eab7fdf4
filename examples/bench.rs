//! Speed against error, printed (not asserted): `cargo run --release --example bench`.
//!
//! For the Hencky disc (MECHANICS.md §4a, follower pressure, qa/(Eh) = 1e-3, reference
//! w0/a = 0.065404) at several mesh sizes: free DOF, relative error of the centre deflection,
//! wall time of the whole solve (flat start to full load, one step), Newton iterations, time
//! per iteration, and that time divided by the floor (one assembly + one numeric LDLT
//! factorization and solve, measured at the solution). One core (faer runs `Par::Seq`).

use std::time::Instant;
use velarium::scene::{Generator, Scene};
use velarium::Engine;

const W_FOLLOWER: f64 = 0.065404;

fn main() {
    let path = format!(
        "{}/modelDescription/HenckyDisc/scene.json",
        env!("CARGO_MANIFEST_DIR")
    );
    let base = Scene::from_json(&std::fs::read_to_string(&path).expect("shipped scene"))
        .expect("valid scene");
    let rings: Vec<usize> = std::env::args()
        .skip(1)
        .filter_map(|a| a.parse().ok())
        .collect();
    let rings = if rings.is_empty() {
        vec![8, 16, 32, 64]
    } else {
        rings
    };
    println!("Hencky disc, follower pressure, qa/(Eh) = 1e-3, reference w0/a = {W_FOLLOWER}");
    println!(
        "{:>6} {:>8} {:>11} {:>9} {:>6} {:>12} {:>12} {:>8}",
        "rings", "DOF", "error", "time s", "iters", "s/iter", "floor s", "ratio"
    );
    for n in rings {
        let mut scene = base.clone();
        if let Generator::Disc { rings, .. } = &mut scene.geometry.generators[0] {
            *rings = n;
        }
        let mut engine = Engine::try_new(scene).expect("valid scene");
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
        engine.set_real(vr, 40.0).unwrap();
        let report = engine.solve();
        let time = t.elapsed().as_secs_f64();
        assert!(report.converged(), "{}", report.message);
        let w = engine.get_real(out).unwrap() / 0.5;
        let error = (w - W_FOLLOWER).abs() / W_FOLLOWER;
        let (assembly, factor) = engine.time_floor(5);
        let per_iter = time / report.iterations.max(1) as f64;
        let floor = assembly + factor;
        println!(
            "{n:>6} {:>8} {error:>11.3e} {time:>9.4} {:>6} {per_iter:>12.3e} {floor:>12.3e} {:>8.2}",
            engine.free_dofs(),
            report.iterations,
            per_iter / floor
        );
    }
}
