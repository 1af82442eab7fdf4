//! The rows that border the tangent of one increment: a slip row of a sleeve point, a
//! volume-control row, the arc-length row, and what an increment knows of its step. Plain data
//! shared by the phases of the iteration (newton.rs, slip.rs, volume.rs, arc.rs,
//! line_search.rs, sensitivity.rs).

use super::assemble::NONE;

/// One slip row: residual and its non-zero couplings.
#[derive(Clone, Debug, Default)]
pub struct Row {
    pub r: f64,
    /// (equation of a free displacement DOF, ∂r/∂x)
    pub dx: Vec<(usize, f64)>,
    /// (slip index, ∂r/∂s)
    pub ds: Vec<(usize, f64)>,
    /// Size of the forces the row balances (N): its round-off scale.
    pub magnitude: f64,
    /// Whether the globalisation's damping applies (not to a closure row, which is linear and
    /// must hold its segment closed exactly).
    pub damped: bool,
}

/// The arc-length constraint of an increment (`arc.rs`): the load factor λ of the step is one
/// more unknown of the loop, held by the row h = t·(u − u_n) − Δs = 0 on the free
/// displacements, whose column is ∂R/∂λ = −q (eliminated with the slip and volume rows).
pub struct ArcRow<'a> {
    pub from: &'a [f64],
    pub to: &'a [f64],
    /// Unit tangent on the equations.
    pub t: &'a [f64],
    /// The last converged displacements (unknown vector).
    pub u_n: &'a [f64],
    /// Δs·√n: the constraint's distance on the equations (m).
    pub length: f64,
    /// The load factor: in, the predictor's; out, the last iterate's (the converged one on
    /// success).
    pub lambda: f64,
}

impl ArcRow<'_> {
    /// h = t·(u − u_n) − Δs·√n.
    pub fn residual(&self, eq: &[usize], u: &[f64]) -> f64 {
        let mut h = -self.length;
        for (d, &e) in eq.iter().enumerate() {
            if e != NONE {
                h += self.t[e] * (u[d] - self.u_n[d]);
            }
        }
        h
    }
}

/// The rows of an arc-length increment (the slip and volume rows, then the arc row) and the
/// load factor's column ∂R/∂λ = −q as (equation, value) pairs.
pub type Border = (Vec<Row>, Vec<(usize, f64)>);

/// Where a Newton loop starts and what it knows of its step.
pub struct Increment<'a> {
    pub loads: &'a [f64],
    /// |Δf_ext|∞ of the whole step (0 when only prescribed displacements or nothing changed).
    pub change: f64,
    /// Whether the loads or prescribed displacements of the step changed at all.
    pub moved: bool,
}
