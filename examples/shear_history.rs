//! Reproducer for open work on wrinkling (issue 3): the Wong & Pellegrino shear test
//! (`examples/wrinkled_shear.json`: Kapton 380 x 128 mm, 25 µm, clamped long edges, free short
//! edges) pretensioned by 0.1 mm separation, then sheared in 10 steps of 0.3 mm. Prints, per
//! step, the outcome, Newton iterations and increments, and the outputs.
//! `cargo run --release --example shear_history [log]` (`log` prints the solver log).
//!
//! Known state: the 0.3 mm step converges in about 23 iterations, the 0.6 mm step in about 2300
//! (115 increments); from 0.9 mm on the steps fail. Near the free-edge corners the film carries
//! almost nothing (1e3-1e4 Pa against 1.7e7 Pa elsewhere): nodes there are held by wrinkled
//! triangles with nearly parallel tension directions, a near-mechanism on which Newton converges
//! only linearly, and triangles on the slack/wrinkled border flip state in nearly every
//! increment.

use velarium::{Engine, Scene};

fn main() {
    let path = format!(
        "{}/examples/wrinkled_shear.json",
        env!("CARGO_MANIFEST_DIR")
    );
    let scene = Scene::from_json(&std::fs::read_to_string(&path).expect("scene file"))
        .expect("valid scene");
    let mut e = Engine::try_new(scene).expect("valid scene");
    let show_log = std::env::args().nth(1).is_some();
    let vr = |e: &Engine, n: &str| {
        e.variables()
            .iter()
            .find(|v| v.name == n)
            .expect("variable")
            .value_reference
    };
    let (separation, shear) = (vr(&e, "separation"), vr(&e, "shear"));
    e.solve();
    e.set_real(separation, 1e-4).expect("in range");
    let r = e.solve();
    println!(
        "separation 0.1 mm: {:?}, {} iterations",
        r.outcome, r.iterations
    );
    for k in 1..=10 {
        let delta = 3e-4 * k as f64;
        e.set_real(shear, delta).expect("in range");
        let r = e.solve();
        let outputs: Vec<String> = e
            .outputs()
            .iter()
            .map(|(n, v)| format!("{n} = {v:.4e}"))
            .collect();
        println!(
            "shear {:.1} mm: {:?}, {} iterations, {} increments | {}",
            delta * 1e3,
            r.outcome,
            r.iterations,
            r.increments,
            outputs.join(", ")
        );
        if show_log {
            r.log.iter().for_each(|l| println!("{l}"));
        }
    }
}
