//! Plane-stress basics shared by the membrane laws and the membrane element: principal values
//! of a Voigt strain or stress, the wrinkle state of a membrane point, the response of a law at
//! one strain, and the two small constants every law uses (tangent-only regularisation of
//! wrinkled and slack points, the round-off threshold of the unstrained state).
//!
//! ```text
//! strain   E = [E11, E22, 2E12] (Voigt, engineering shear)   principal E1 >= E2, angle of t (major)
//! stress   S = [S11, S22, S12]                                principal S_max >= S_min
//! ```
//! A leaf: it imports no other model file, so `wrinkling` (isotropic laws), `orthotropic` and
//! `membrane` (the element) all build on it without depending on each other.

use nalgebra::{Matrix3, Vector3};
use serde::{Deserialize, Serialize};

/// Tangent-only stiffness fraction in wrinkled and slack states.
pub const REGULARIZATION: f64 = 1e-6;

/// Principal strains of at most this size count as the unstrained state (round-off of the
/// reference geometry is about 1e-16 times coordinate over element size).
pub const UNSTRAINED: f64 = 1e-12;

/// The state of a membrane point.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
pub enum WrinkleState {
    #[default]
    Taut,
    Wrinkled,
    Slack,
}

/// Stress, tangent and energy density (per reference volume) at one strain.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Response {
    pub stress: Vector3<f64>,
    pub tangent: Matrix3<f64>,
    pub energy: f64,
    pub state: WrinkleState,
    /// Angle of the major principal strain direction t in the element frame, radians in
    /// (−π/2, π/2]: the tension direction of a wrinkled point.
    pub angle: f64,
}

/// Principal strains E1 >= E2 and the angle of t.
pub fn principal(strain: &Vector3<f64>) -> (f64, f64, f64) {
    let (a, b, c) = (strain[0], strain[1], 0.5 * strain[2]);
    let mean = 0.5 * (a + b);
    let radius = (0.25 * (a - b) * (a - b) + c * c).sqrt();
    let angle = 0.5 * (2.0 * c).atan2(a - b);
    (mean + radius, mean - radius, angle)
}

/// Principal values (max, min) of a Voigt stress.
pub fn principal_stresses(s: &Vector3<f64>) -> (f64, f64) {
    let mean = 0.5 * (s[0] + s[1]);
    let radius = (0.25 * (s[0] - s[1]).powi(2) + s[2] * s[2]).sqrt();
    (mean + radius, mean - radius)
}
