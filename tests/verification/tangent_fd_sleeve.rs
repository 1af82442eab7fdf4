//! GOAL: the sleeve tangents equal central finite differences: the slip row r = f_t − σμ f_n
//!       with respect to the three cable points and the two unstretched lengths, dT/dL0 of the
//!       cable law (the B block of the sliding Newton), and the penalty tie.
//! MESH: one sleeve point with random neighbours (kinks from a few degrees to ~120°), both
//!       strain laws, σμ ∈ {0, 0.3, −0.3}; the assembled blocks B, C, D of the shipped
//!       SlidingCable model (μ = 0.3) in a deformed, slipped state.
//! REFERENCE: docs/mechanics.md §5 (every tangent against central differences, relative error
//!            < 1e-6); step h = 1e-6 times the segment length.

use crate::common;
use common::Rng;
use nalgebra::Vector3;
use velarium::model::cable::{self, Law};
use velarium::model::sleeve::{self, SegmentLaw};

#[test]
fn slip_row_matches_finite_differences() {
    let mut rng = Rng(0x5EED_51EE);
    let mut worst = 0.0f64;
    for case in 0..60 {
        let law = if case % 2 == 0 {
            Law::Engineering
        } else {
            Law::GreenLagrange
        };
        let sigma_mu = [0.0, 0.3, -0.3][case % 3];
        let ea = 1e4;
        let turn = 0.05 + 2.0 * (rng.next() + 1.0) / 2.0 * 1.0;
        let xp = Vector3::new(-1.0, 0.1 * rng.next(), 0.1 * rng.next());
        let xc = Vector3::new(0.0, 0.0, 0.0);
        let xq = Vector3::new(turn.cos(), turn.sin(), 0.2 * rng.next());
        let (la, lb) = ((xc - xp).norm(), (xq - xc).norm());
        // Taut segments: strain between 1e-3 and 2e-2.
        let la0 = la / (1.0 + 1e-3 + 0.01 * (rng.next() + 1.0));
        let lb0 = lb / (1.0 + 1e-3 + 0.01 * (rng.next() + 1.0));
        let seg = SegmentLaw { law, ea };
        let row = |p: &[Vector3<f64>; 3], l: [f64; 2]| {
            sleeve::slip_row(seg, seg, l[0], l[1], &p[0], &p[1], &p[2], sigma_mu)
        };
        let x = [xp, xc, xq];
        let (r0, dx, dl) = row(&x, [la0, lb0]);
        let h = 1e-6;
        let scale = dx
            .iter()
            .map(|v| v.amax())
            .fold(0.0f64, f64::max)
            .max(dl[0].abs())
            .max(dl[1].abs());
        for node in 0..3 {
            for c in 0..3 {
                let (mut plus, mut minus) = (x, x);
                plus[node][c] += h;
                minus[node][c] -= h;
                let fd = (row(&plus, [la0, lb0]).0 - row(&minus, [la0, lb0]).0) / (2.0 * h);
                worst = worst.max((fd - dx[node][c]).abs() / scale);
            }
        }
        for k in 0..2 {
            let (mut plus, mut minus) = ([la0, lb0], [la0, lb0]);
            plus[k] += h;
            minus[k] -= h;
            let fd = (row(&x, plus).0 - row(&x, minus).0) / (2.0 * h);
            worst = worst.max((fd - dl[k]).abs() / scale);
        }
        assert!(r0.is_finite());
    }
    println!("slip row: worst relative FD error {worst:.2e}");
    assert!(worst < 1e-6, "worst {worst:e}");
}

#[test]
fn tension_dl0_matches_finite_differences() {
    for law in [Law::Engineering, Law::GreenLagrange] {
        for (l0, l) in [(1.0, 1.01), (0.5, 0.52), (2.0, 2.0005)] {
            let h = 1e-7 * l0;
            let fd = (cable::tension(law, 1e5, l0 + h, l).0
                - cable::tension(law, 1e5, l0 - h, l).0)
                / (2.0 * h);
            let exact = cable::tension_dl0(law, 1e5, l0, l);
            assert!(
                (fd - exact).abs() <= 1e-6 * exact.abs(),
                "{law:?}: {fd} vs {exact}"
            );
        }
        assert_eq!(cable::tension_dl0(law, 1e5, 1.0, 0.99), 0.0, "slack");
    }
}

#[test]
fn tie_stiffness_matches_finite_differences() {
    let k = 3.7e6;
    let (xc, xm) = (
        Vector3::new(0.1, -0.2, 0.3),
        Vector3::new(0.1003, -0.2001, 0.2998),
    );
    let km = sleeve::tie_stiffness(k);
    let force = |xc: Vector3<f64>, xm: Vector3<f64>| {
        let (f, _) = sleeve::tie_force(k, &xc, &xm);
        [f.x, f.y, f.z, -f.x, -f.y, -f.z]
    };
    let h = 1e-7;
    for j in 0..6 {
        let (mut p, mut m) = ([xc, xm], [xc, xm]);
        p[j / 3][j % 3] += h;
        m[j / 3][j % 3] -= h;
        let (fp, fm) = (force(p[0], p[1]), force(m[0], m[1]));
        for i in 0..6 {
            let fd = (fp[i] - fm[i]) / (2.0 * h);
            assert!(
                (fd - km[(i, j)]).abs() <= 1e-6 * k,
                "({i},{j}): {fd} vs {}",
                km[(i, j)]
            );
        }
    }
}

#[test]
fn assembled_slip_blocks_match_finite_differences() {
    use velarium::model::sleeve::Contact::{Backward, Forward};
    use velarium::solver::assemble::{assemble, Pattern, NONE};
    use velarium::solver::slip::slip_blocks;
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/modelDescription/SlidingCable/scene.json"
    ))
    .unwrap();
    let mut scene = velarium::Scene::from_json(&text).unwrap();
    scene.cables[0].sleeve.as_mut().unwrap().mu = 0.3;
    let model = velarium::model::Model::build(&scene);
    let pattern = Pattern::try_new(&model).unwrap();
    let n3 = model.dof_count();
    let m = model.slips.len();
    let mut u = vec![0.0; model.unknown_count()];
    for (d, v) in u.iter_mut().enumerate().take(n3) {
        if !model.held[d] {
            *v = 0.05 * ((d as f64) * 1.7).sin();
        }
    }
    for j in 0..m {
        u[n3 + j] = 0.01 * (j as f64 + 1.0) * if j % 2 == 0 { 1.0 } else { -1.0 };
    }
    let committed = vec![0.0; m];
    let states = vec![Forward, Backward, Forward];
    let loads = vec![0.0; model.loads.len()];
    let (_, b, c, d) = slip_blocks(&model, &pattern.eq, &u, &committed, &states);
    let residual = |u: &[f64]| {
        let mut r = vec![0.0; n3];
        assemble(&model, &pattern, u, &loads, &mut r, None);
        (
            r,
            slip_blocks(&model, &pattern.eq, u, &committed, &states).0,
        )
    };
    let h = 1e-7;
    let scale = b.amax().max(c.amax()).max(d.amax());
    let mut worst = 0.0f64;
    for j in 0..m {
        let (mut p, mut q) = (u.clone(), u.clone());
        p[n3 + j] += h;
        q[n3 + j] -= h;
        let ((rp, sp), (rq, sq)) = (residual(&p), residual(&q));
        for (dof, &e) in pattern.eq.iter().enumerate() {
            if e != NONE {
                worst = worst.max(((rp[dof] - rq[dof]) / (2.0 * h) - b[(e, j)]).abs() / scale);
            }
        }
        for i in 0..m {
            worst = worst.max(((sp[i] - sq[i]) / (2.0 * h) - d[(i, j)]).abs() / scale);
        }
    }
    for (dof, &e) in pattern.eq.iter().enumerate() {
        if e == NONE {
            continue;
        }
        let (mut p, mut q) = (u.clone(), u.clone());
        p[dof] += h;
        q[dof] -= h;
        let ((_, sp), (_, sq)) = (residual(&p), residual(&q));
        for i in 0..m {
            worst = worst.max(((sp[i] - sq[i]) / (2.0 * h) - c[(i, e)]).abs() / scale);
        }
    }
    println!("assembled slip blocks: worst relative FD error {worst:.2e}");
    assert!(worst < 1e-6, "worst {worst:e}");
}
