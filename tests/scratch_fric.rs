mod common;
use common::*;
#[test]
fn scan() {
    let mus: Vec<f64> = std::env::var("MUS")
        .unwrap_or("0.05 0.1 0.15 0.2 0.25 0.3".into())
        .split_whitespace()
        .map(|s| s.parse().unwrap())
        .collect();
    let verbose = std::env::var("VERBOSE").is_ok();
    for mu in mus {
        let mut e = engine(read_scene(&shipped("SlidingCable")));
        set(&mut e, "mu", mu);
        let mut its = Vec::new();
        let mut ok = true;
        for k in 1..=10 {
            set(&mut e, "P", 20.0 * k as f64);
            set(&mut e, "p", 2.0 * k as f64);
            let r = e.solve();
            if verbose {
                println!("row {k}:\n{}", r.log.join("\n"));
            }
            if !r.converged() {
                println!("mu {mu} row {k} FAILED: {}", r.message);
                ok = false;
                break;
            }
            its.push(r.iterations);
            println!(
                "mu {mu} row {k}: x7 {:.6} x8 {:.6} x9 {:.6} s7 {:.4} s8 {:.4} s9 {:.4} its {}",
                get(&e, "x7"),
                get(&e, "x8"),
                get(&e, "x9"),
                get(&e, "slip7"),
                get(&e, "slip8"),
                get(&e, "slip9"),
                r.iterations
            );
        }
        println!("mu {mu}: ok {ok} its {its:?}");
    }
}
