//! GOAL: the tension-field membrane laws at single material points: states, stresses, tension
//!       angles, consistent tangents, and the neo-Hookean closed forms.
//! MESH: none (constitutive point tests).
//! BOUNDARY CONDITIONS: none; strains are given.
//! PARAMETERS: SVK E = 1, ν = 0.3 (the table's units); neo-Hookean μ = 1.
//! REFERENCE: docs/mechanics.md §4c constitutive table (8 strain states; checked to the table's
//!            5 printed digits, and to 1e-12 against the closed forms S = D E (taut),
//!            S = E·E1 t⊗t (wrinkled), S = 0 (slack)); docs/mechanics.md §1.2 consistent tangent
//!            (central differences, 1e-6 relative); docs/mechanics.md §6 neo-Hookean nominal
//!            stresses P = μ(λ − λ⁻²) uniaxial, μ(λ − λ⁻⁵) equibiaxial, μ(λ − λ⁻³) pure shear
//!            (1e-12 relative). The orthotropic law (E_warp = 3, E_fill = 1, nu_wf = 0.6,
//!            G = 0.2, warp at 0.4 rad) against central differences too, and at
//!            E_warp = E_fill the table reproduced to the same 1e-12.

use nalgebra::{Matrix2, Vector3};
use velarium::model::orthotropic::Orthotropic;
use velarium::model::wrinkling::{principal, Law, WrinkleState, REGULARIZATION};

const SVK: Law = Law::Svk {
    young: 1.0,
    nu: 0.3,
};

/// (strain, state, S/E printed in the table, tension angle in degrees if wrinkled)
#[allow(clippy::type_complexity)]
const TABLE: [([f64; 3], WrinkleState, [f64; 3], Option<f64>); 8] = [
    (
        [1e-3, -3e-4, 0.0],
        WrinkleState::Taut,
        [1.0000e-3, 0.0, 0.0],
        None,
    ),
    (
        [1e-3, 0.0, 0.0],
        WrinkleState::Taut,
        [1.0989e-3, 3.2967e-4, 0.0],
        None,
    ),
    (
        [1e-3, -5e-4, 0.0],
        WrinkleState::Wrinkled,
        [1.0000e-3, 0.0, 0.0],
        Some(0.0),
    ),
    (
        [-1e-3, -1e-3, 0.0],
        WrinkleState::Slack,
        [0.0, 0.0, 0.0],
        None,
    ),
    (
        [0.0, 0.0, 1e-3],
        WrinkleState::Wrinkled,
        [2.5e-4, 2.5e-4, 2.5e-4],
        Some(45.0),
    ),
    (
        [0.0, 1e-3, 1e-3],
        WrinkleState::Taut,
        [3.2967e-4, 1.0989e-3, 3.8462e-4],
        None,
    ),
    (
        [0.0, 1e-3, 2e-3],
        WrinkleState::Wrinkled,
        [4.4721e-4, 1.1708e-3, 7.2361e-4],
        Some(58.28),
    ),
    (
        [0.0, 1e-3, 1e-2],
        WrinkleState::Wrinkled,
        [2.4876e-3, 3.0373e-3, 2.7488e-3],
        Some(47.86),
    ),
];

/// Closed-form reference, written independently of the implementation: the major
/// eigenvector from (E − E2 I), not from an angle.
fn closed_form(e: [f64; 3], state: WrinkleState) -> [f64; 3] {
    let (young, nu) = (1.0, 0.3);
    match state {
        WrinkleState::Slack => [0.0; 3],
        WrinkleState::Taut => {
            let c = young / (1.0 - nu * nu);
            [
                c * (e[0] + nu * e[1]),
                c * (nu * e[0] + e[1]),
                c * (1.0 - nu) / 2.0 * e[2],
            ]
        }
        WrinkleState::Wrinkled => {
            let m = Matrix2::new(e[0], e[2] / 2.0, e[2] / 2.0, e[1]);
            let eig = m.symmetric_eigen();
            let k = if eig.eigenvalues[0] >= eig.eigenvalues[1] {
                0
            } else {
                1
            };
            let (e1, t) = (eig.eigenvalues[k], eig.eigenvectors.column(k));
            [
                young * e1 * t[0] * t[0],
                young * e1 * t[1] * t[1],
                young * e1 * t[0] * t[1],
            ]
        }
    }
}

#[test]
fn svk_tension_field_table() {
    for (strain, state, printed, angle) in TABLE {
        let r = SVK.response(&Vector3::from(strain), None);
        assert_eq!(r.state, state, "{strain:?}");
        let exact = closed_form(strain, state);
        let scale = exact.iter().fold(0.0f64, |m, v| m.max(v.abs())).max(1e-300);
        for i in 0..3 {
            assert!(
                (r.stress[i] - exact[i]).abs() <= 1e-12 * scale,
                "{strain:?} S[{i}] {} vs {}",
                r.stress[i],
                exact[i]
            );
            // The table prints 5 significant digits.
            assert!(
                (r.stress[i] - printed[i]).abs() <= 5e-5 * scale,
                "{strain:?} S[{i}] {} vs table {}",
                r.stress[i],
                printed[i]
            );
        }
        if let Some(deg) = angle {
            let got = r.angle.to_degrees();
            assert!((got - deg).abs() < 0.005, "{strain:?} angle {got} vs {deg}");
        }
    }
}

/// Central differences of S(E) against the tangent, in random states away from the switch
/// (the state is the same at E ± h). The tangent-only ε·D0 of wrinkled and slack points is
/// subtracted before comparing: it is not part of ∂S/∂E by design.
fn check_tangent(law: Law, strain_scale: f64, seed: u64) -> [usize; 3] {
    let mut x = seed;
    let mut rnd = || {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        (x >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    };
    let mut counts = [0usize; 3];
    for _ in 0..3000 {
        let e = Vector3::new(rnd(), rnd(), 2.0 * rnd()) * strain_scale;
        let r = law.response(&e, None);
        let h = 1e-7 * strain_scale;
        let mut fd = nalgebra::Matrix3::zeros();
        let mut same_state = true;
        for j in 0..3 {
            let (mut ep, mut em) = (e, e);
            ep[j] += h;
            em[j] -= h;
            let (rp, rm) = (law.response(&ep, None), law.response(&em, None));
            same_state &= rp.state == r.state && rm.state == r.state;
            fd.set_column(j, &((rp.stress - rm.stress) / (2.0 * h)));
        }
        let (e1, e2, _) = principal(&e);
        if !same_state || (e1 - e2).abs() < 1e-3 * strain_scale {
            continue; // at or near the switching surface or a repeated eigenvalue
        }
        let mut tangent = r.tangent;
        if r.state != WrinkleState::Taut {
            tangent -= law.small_strain() * REGULARIZATION;
        }
        let scale = law.small_strain().abs().max();
        let err = (tangent - fd).abs().max() / scale;
        assert!(
            err < 1e-6,
            "{law:?} {:?} at {e:?}: tangent error {err:e}",
            r.state
        );
        counts[r.state as usize] += 1;
    }
    counts
}

/// The orthotropic law with E_warp = E_fill = E, nu_wf = ν, G = E/(2(1+ν)), its warp at any
/// angle to the element frame, is the isotropic SVK law: the table's states, the closed-form
/// stresses to 1e-12 and the tension angles to 0.005°.
#[test]
fn equal_warp_and_fill_reproduces_the_table() {
    for warp in [0.0, 0.5, 1.3, -2.2] {
        let law = Law::Orthotropic(Orthotropic::new(1.0, 1.0, 0.3, 1.0 / 2.6, warp));
        for (strain, state, _, angle) in TABLE {
            let r = law.response(&Vector3::from(strain), None);
            assert_eq!(r.state, state, "warp {warp}: {strain:?}");
            let exact = closed_form(strain, state);
            let scale = exact.iter().fold(0.0f64, |m, v| m.max(v.abs())).max(1e-300);
            for (i, (&s_i, &e_i)) in r.stress.iter().zip(&exact).enumerate() {
                assert!(
                    (s_i - e_i).abs() <= 1e-12 * scale,
                    "warp {warp}: {strain:?} S[{i}] {s_i} vs {e_i}"
                );
            }
            if let Some(deg) = angle {
                let got = r.angle.to_degrees();
                assert!((got - deg).abs() < 0.005, "{strain:?} angle {got} vs {deg}");
            }
        }
    }
}

#[test]
fn consistent_tangents_match_finite_differences_in_every_state() {
    let fabric = Law::Orthotropic(Orthotropic::new(3.0, 1.0, 0.6, 0.2, 0.4));
    for (law, scale) in [
        (SVK, 1e-2),
        (Law::NeoHookean { mu: 1.0 }, 0.3),
        (fabric, 1e-2),
    ] {
        let counts = check_tangent(law, scale, 0x2545F4914F6CDD1D);
        assert!(
            counts.iter().all(|&c| c > 100),
            "{law:?}: too few samples per state {counts:?}"
        );
    }
}

#[test]
fn neo_hookean_closed_forms() {
    let mu = 1.0;
    let law = Law::NeoHookean { mu };
    let strain = |l1: f64, l2: f64| Vector3::new(0.5 * (l1 * l1 - 1.0), 0.5 * (l2 * l2 - 1.0), 0.0);
    for lambda in [1.1f64, 1.5, 2.0, 3.0] {
        // Uniaxial: lateral stretch λ^(-1/2) (S2 = 0); the relaxed law gives the same P for any
        // narrower width (wrinkled).
        for l2 in [lambda.powf(-0.5), 0.5 * lambda.powf(-0.5)] {
            let r = law.response(&strain(lambda, l2), None);
            let p = lambda * r.stress[0];
            let exact = mu * (lambda - lambda.powi(-2));
            assert!(
                (p - exact).abs() <= 1e-12 * exact,
                "uniaxial λ {lambda} λ2 {l2}: {p} vs {exact}"
            );
            assert!(r.stress[1].abs() <= 1e-12 * exact);
        }
        let r = law.response(&strain(lambda, lambda), None);
        let exact = mu * (lambda - lambda.powi(-5));
        assert_eq!(r.state, WrinkleState::Taut);
        assert!(
            (lambda * r.stress[0] - exact).abs() <= 1e-12 * exact,
            "equibiaxial λ {lambda}"
        );
        let r = law.response(&strain(lambda, 1.0), None);
        let exact = mu * (lambda - lambda.powi(-3));
        assert!(
            (lambda * r.stress[0] - exact).abs() <= 1e-12 * exact,
            "pure shear λ {lambda}"
        );
    }
    // Slack: both stretches below 1.
    let r = law.response(&strain(0.9, 0.8), None);
    assert_eq!((r.state, r.stress), (WrinkleState::Slack, Vector3::zeros()));
}

#[test]
fn wrinkled_energy_is_continuous_at_the_state_boundaries() {
    // Taut/wrinkled boundary of neo-Hookean: λ2 = λ1^(-1/2); the two energies agree there.
    let law = Law::NeoHookean { mu: 1.0 };
    let l1: f64 = 1.7;
    let l2 = l1.powf(-0.5);
    let e = Vector3::new(0.5 * (l1 * l1 - 1.0), 0.5 * (l2 * l2 - 1.0), 0.0);
    let taut = law.response(&e, Some(WrinkleState::Taut)).energy;
    let wrinkled = law.response(&e, Some(WrinkleState::Wrinkled)).energy;
    assert!((taut - wrinkled).abs() < 1e-12, "{taut} vs {wrinkled}");
    // SVK: taut/wrinkled boundary E2 = −ν E1.
    let e = Vector3::new(1e-3, -3e-4, 0.0);
    let a = SVK.response(&e, Some(WrinkleState::Taut));
    let b = SVK.response(&e, Some(WrinkleState::Wrinkled));
    assert!((a.energy - b.energy).abs() < 1e-18 && (a.stress - b.stress).norm() < 1e-15);
}

/// The orthotropic fabric law (E_warp = 3, E_fill = 1, nu_wf = 0.6, G = 0.2, warp at 0.4 rad)
/// has a continuous stress across both state borders: along 40 straight strain paths through
/// each border (taut → wrinkled, wrinkled → slack), the border found by bisection to 1e-15 of
/// the path, the stresses on its two sides agree within 1e-14 of the elastic stress scale
/// |D| |E| (measured 3.8e-16: what a Lipschitz-continuous stress leaves over a 1e-18 step,
/// plus round-off).
#[test]
fn orthotropic_stress_is_continuous_at_the_state_boundaries() {
    let law = Law::Orthotropic(Orthotropic::new(3.0, 1.0, 0.6, 0.2, 0.4));
    let mut x = 0x9E3779B97F4A7C15u64;
    let mut rnd = || {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        (x >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    };
    let mut found = [0usize; 2];
    let mut worst = 0.0f64;
    for _ in 0..400 {
        let a = Vector3::new(rnd(), rnd(), 2.0 * rnd()) * 1e-2;
        let b = Vector3::new(rnd(), rnd(), 2.0 * rnd()) * 1e-2;
        let state = |s: f64| law.response(&(a + (b - a) * s), None).state;
        let (sa, sb) = (state(0.0), state(1.0));
        let kind = match (sa, sb) {
            (WrinkleState::Taut, WrinkleState::Wrinkled) => 0,
            (WrinkleState::Wrinkled, WrinkleState::Slack) => 1,
            _ => continue,
        };
        if found[kind] >= 40 {
            continue;
        }
        let (mut lo, mut hi) = (0.0f64, 1.0f64);
        for _ in 0..60 {
            let mid = 0.5 * (lo + hi);
            if state(mid) == sa {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        let (ea, eb) = (a + (b - a) * lo, a + (b - a) * hi);
        let (ra, rb) = (law.response(&ea, None), law.response(&eb, None));
        if ra.state == rb.state {
            continue; // more than one border on the path
        }
        let scale = law.small_strain().abs().max() * ea.abs().max();
        let jump = (ra.stress - rb.stress).abs().max() / scale;
        worst = worst.max(jump);
        assert!(
            jump < 1e-12,
            "{:?} -> {:?} at {ea:?}: jump {jump:e}",
            ra.state,
            rb.state
        );
        found[kind] += 1;
    }
    println!("borders checked (taut/wrinkled, wrinkled/slack) {found:?}, worst jump {worst:e}");
    assert!(found.iter().all(|&n| n >= 20), "{found:?}");
}
