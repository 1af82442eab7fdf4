//! Tension-only 2-node cable segment.
//!
//! ```text
//! L0   unstretched length, l = |x_b − x_a| current length, e = (x_b − x_a)/l
//! engineering     T = EA (l − L0)/L0                 k = dT/dl = EA/L0
//! Green-Lagrange  T = EA (l² − L0²) l /(2 L0³)       k = EA (3 l² − L0²)/(2 L0³)
//! slack (l ≤ L0)  T = 0
//! f_b = −f_a = T e
//! K_bb = k e eᵀ + (T/l)(I − e eᵀ),   K = [[K_bb, −K_bb], [−K_bb, K_bb]]
//! W   engineering ½ EA (l − L0)²/L0;  Green-Lagrange ½ EA L0 ((l² − L0²)/(2 L0²))²
//! ```
//! A slack segment has no force and the exact zero tangent: a node held only by slack cables
//! is a mechanism until they tighten, which the solver's damping handles (no tangent-only
//! spring).
//!
//! # References
//! docs/mechanics.md §4g and §6 (strain measures, pretension through the unstretched length).

use nalgebra::{Matrix3, SMatrix, SVector, Vector3};

pub type Vec6 = SVector<f64, 6>;
pub type Mat6 = SMatrix<f64, 6, 6>;

/// Strain law (mirrors the scene's).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Law {
    Engineering,
    GreenLagrange,
}

/// Tension and its derivative dT/dl at current length l.
pub fn tension(law: Law, ea: f64, l0: f64, l: f64) -> (f64, f64) {
    if l <= l0 {
        return (0.0, 0.0);
    }
    match law {
        Law::Engineering => (ea * (l - l0) / l0, ea / l0),
        Law::GreenLagrange => {
            let l03 = l0 * l0 * l0;
            (
                ea * (l * l - l0 * l0) * l / (2.0 * l03),
                ea * (3.0 * l * l - l0 * l0) / (2.0 * l03),
            )
        }
    }
}

/// Derivative dT/dL0 of the tension with respect to the unstretched length at current length
/// `l` (0 when slack): engineering −EA l/L0², Green-Lagrange −EA l (3 l² − L0²)/(2 L0⁴).
pub fn tension_dl0(law: Law, ea: f64, l0: f64, l: f64) -> f64 {
    if l <= l0 {
        return 0.0;
    }
    match law {
        Law::Engineering => -ea * l / (l0 * l0),
        Law::GreenLagrange => -ea * l * (3.0 * l * l - l0 * l0) / (2.0 * l0.powi(4)),
    }
}

/// Unstretched length that gives tension `t0` at length `l`.
pub fn unstretched_length(law: Law, ea: f64, l: f64, t0: f64) -> f64 {
    match law {
        Law::Engineering => l / (1.0 + t0 / ea),
        // T = EA (l² − L0²) l/(2 L0³) has no closed form in L0 for T given at l; solve by
        // Newton on g(L0) = EA (l² − L0²) l − 2 T L0³ (monotone decreasing in L0 on (0, l]).
        Law::GreenLagrange => {
            let mut x = l / (1.0 + 2.0 * t0 / ea).sqrt();
            for _ in 0..60 {
                let g = ea * (l * l - x * x) * l - 2.0 * t0 * x * x * x;
                let dg = -2.0 * ea * x * l - 6.0 * t0 * x * x;
                let dx = g / dg;
                x -= dx;
                if dx.abs() <= 1e-15 * l {
                    break;
                }
            }
            x
        }
    }
}

/// Internal force (a then b), tangent and energy of one segment.
pub fn segment(
    law: Law,
    ea: f64,
    l0: f64,
    xa: &Vector3<f64>,
    xb: &Vector3<f64>,
) -> (Vec6, Mat6, f64) {
    let d = xb - xa;
    let l = d.norm();
    let e = d / l;
    let (t, k) = tension(law, ea, l0, l);
    let mut f = Vec6::zeros();
    f.fixed_rows_mut::<3>(0).copy_from(&(-t * e));
    f.fixed_rows_mut::<3>(3).copy_from(&(t * e));
    let eet = e * e.transpose();
    let kbb = if t > 0.0 {
        eet * k + (Matrix3::identity() - eet) * (t / l)
    } else {
        // Slack: no force and no stiffness (the exact derivative). A node held only by slack
        // cables is a mechanism until they tighten; the solver's damping handles that.
        Matrix3::zeros()
    };
    let mut kk = Mat6::zeros();
    kk.fixed_view_mut::<3, 3>(0, 0).copy_from(&kbb);
    kk.fixed_view_mut::<3, 3>(3, 3).copy_from(&kbb);
    kk.fixed_view_mut::<3, 3>(0, 3).copy_from(&(-kbb));
    kk.fixed_view_mut::<3, 3>(3, 0).copy_from(&(-kbb));
    let w = if l <= l0 {
        0.0
    } else {
        match law {
            Law::Engineering => 0.5 * ea * (l - l0).powi(2) / l0,
            Law::GreenLagrange => 0.5 * ea * l0 * ((l * l - l0 * l0) / (2.0 * l0 * l0)).powi(2),
        }
    };
    (f, kk, w)
}
