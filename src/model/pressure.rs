//! Pressure on a membrane triangle.
//!
//! ```text
//! follower: f_a = (p/6) (x2 − x1) × (x3 − x1)  for every node a   (p · current area · n / 3)
//!           ∂f_a/∂x1 = (p/6)([b]× − [a]×),  ∂f_a/∂x2 = −(p/6)[b]×,  ∂f_a/∂x3 = (p/6)[a]×
//!           with a = x2 − x1, b = x3 − x1, [v]× w = v × w
//! dead:     f_a = p A0 N / 3  (reference area and normal; no stiffness)
//! volume:   V = Σ x1·(x2 × x3)/6 over a closed group (signed tetrahedra from the origin),
//!           ∂V/∂x1 = (x2 × x3)/6 (cyclic); over a closed surface ∂V/∂x_a = Σ f_a/p
//! ```
//! The load stiffness `K_p = −∂f/∂x` of one triangle is not symmetric. Summed over a surface
//! whose boundary is held, the non-symmetric parts cancel on the free DOFs (the pressure then
//! has the potential −p·V), so the assembler uses the symmetric part of each triangle's K_p:
//! exact for clamped or closed surfaces, a small loss of quadratic convergence on free edges.
//!
//! # References
//! Bonet & Wood 2008, §8.4 (follower pressure, load stiffness); Schweizerhof & Ramm 1984.

use nalgebra::{Matrix3, SMatrix, Vector3};

pub type Mat9 = SMatrix<f64, 9, 9>;

fn skew(v: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, -v.z, v.y, v.z, 0.0, -v.x, -v.y, v.x, 0.0)
}

/// Follower-pressure nodal force (the same on the three nodes).
pub fn follower_force(p: f64, x: &[Vector3<f64>; 3]) -> Vector3<f64> {
    (x[1] - x[0]).cross(&(x[2] - x[0])) * (p / 6.0)
}

/// Signed volume of the tetrahedron (origin, x1, x2, x3): a closed outward surface's triangles
/// sum to the volume it encloses, V = Σ x1·(x2 × x3)/6.
pub fn enclosed_volume(x: &[Vector3<f64>; 3]) -> f64 {
    x[0].dot(&x[1].cross(&x[2])) / 6.0
}

/// ∂V/∂x_a of [`enclosed_volume`] for a = 1, 2, 3: (x2 × x3, x3 × x1, x1 × x2)/6. Summed over a
/// closed surface it equals the follower force per unit pressure at every node.
pub fn enclosed_volume_gradient(x: &[Vector3<f64>; 3]) -> [Vector3<f64>; 3] {
    [
        x[1].cross(&x[2]) / 6.0,
        x[2].cross(&x[0]) / 6.0,
        x[0].cross(&x[1]) / 6.0,
    ]
}

/// Load stiffness −∂f/∂x of a follower-pressure triangle (9x9, not symmetric).
pub fn follower_stiffness(p: f64, x: &[Vector3<f64>; 3]) -> Mat9 {
    let (a, b) = (x[1] - x[0], x[2] - x[0]);
    let c = p / 6.0;
    let d = [(skew(&b) - skew(&a)) * c, -skew(&b) * c, skew(&a) * c];
    let mut k = Mat9::zeros();
    for row in 0..3 {
        for (col, block) in d.iter().enumerate() {
            k.fixed_view_mut::<3, 3>(3 * row, 3 * col)
                .copy_from(&(-block));
        }
    }
    k
}
