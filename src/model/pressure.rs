//! Pressure on a membrane triangle.
//!
//! ```text
//! follower: f_a = (p/6) (x2 − x1) × (x3 − x1)  for every node a   (p · current area · n / 3)
//!           ∂f_a/∂x1 = (p/6)([b]× − [a]×),  ∂f_a/∂x2 = −(p/6)[b]×,  ∂f_a/∂x3 = (p/6)[a]×
//!           with a = x2 − x1, b = x3 − x1, [v]× w = v × w
//! dead:     f_a = p A0 N / 3  (reference area and normal; no stiffness)
//! volume:   V = Σ x1·(x2 × x3)/6 over a closed group (signed tetrahedra from the origin),
//!           ∂V/∂x1 = (x2 × x3)/6 (cyclic); over a closed surface ∂V/∂x_a = Σ f_a/p
//! snow:     f_a = −(s/6) |c_z| e_z  for every node a, c = (x2 − x1) × (x3 − x1)
//!           (s per current plan area A_xy = |c_z|/2, a third to each node, along −z)
//!           ∂f_a/∂x_j = −(s/6) sgn(c_z) e_z ⊗ (row z of ∂c/∂x_j)
//!           with ∂c/∂x1 = [b]× − [a]×, ∂c/∂x2 = −[b]×, ∂c/∂x3 = [a]×
//! ponding:  depth d_i = max(h − z_i, 0) at the nodes, p = γ_w d linear between them, against
//!           the normal: f_a = −(c/24)(2 p_a + p_b + p_c)   (∫ N_a N_b dA = A (1 + δ_ab)/12,
//!           c/2 = A n), so Σ_a f_a = −(c/2) p̄: the weight of the water column over the
//!           triangle when it is flat.
//!           ∂f_a/∂x_j = −(q_a/24) ∂c/∂x_j − (c/24) ⊗ ∂q_a/∂x_j,  q_a = 2 p_a + p_b + p_c,
//!           ∂p_i/∂z_i = −γ_w where d_i > 0 (0 where dry)
//! ```
//! Snow and ponding follow the shape (they are per current plan area, per current area and
//! normal) but have no potential triangle by triangle; their load stiffness is checked against
//! central differences in `tests/verification/tangent_fd.rs`. The ponding stiffness of a flat
//! sheet, z rows and columns, is −γ_w times the consistent mass matrix ∫ N_a N_b dA: the
//! softening that gives the ponding instability (docs/mechanics.md §3.2).
//!
//! The load stiffness `K_p = −∂f/∂x` of one triangle is not symmetric. Summed over a surface
//! whose boundary is held, the non-symmetric parts cancel on the free DOFs (the pressure then
//! has the potential −p·V), so the assembler uses the symmetric part of each triangle's K_p:
//! exact for clamped or closed surfaces, a small loss of quadratic convergence on free edges.
//!
//! # References
//! Bonet & Wood 2008, §8.4 (follower pressure, load stiffness); Schweizerhof & Ramm 1984.

use nalgebra::{Matrix3, RowVector3, SMatrix, Vector3};

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

/// The shape-following surface loads other than a pressure along the normal: what a snow or
/// ponding input does per unit of its value (snow) or at its value (ponding's level).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SurfaceLaw {
    /// Vertical (−z) load per current plan area: [`snow_forces`].
    Snow,
    /// Hydrostatic pressure of water of unit weight `gamma_w` (N/m³) up to the level:
    /// [`ponding_forces`].
    Ponding { gamma_w: f64 },
}

impl SurfaceLaw {
    /// Nodal forces of the law at `value` (snow load in Pa, water level in m) on a triangle
    /// at `x`.
    pub fn forces(&self, value: f64, x: &[Vector3<f64>; 3]) -> [Vector3<f64>; 3] {
        match *self {
            SurfaceLaw::Snow => [snow_force(value, x); 3],
            SurfaceLaw::Ponding { gamma_w } => ponding_forces(gamma_w, value, x),
        }
    }

    /// Load stiffness −∂f/∂x (9x9, not symmetric) of the law at `value`.
    pub fn stiffness(&self, value: f64, x: &[Vector3<f64>; 3]) -> Mat9 {
        match *self {
            SurfaceLaw::Snow => snow_stiffness(value, x),
            SurfaceLaw::Ponding { gamma_w } => ponding_stiffness(gamma_w, value, x),
        }
    }

    /// ∂f/∂value of the nodal forces: the snow force per Pa, the ponding forces per metre
    /// of level (the wet nodes' pressure rises by γ_w).
    pub fn rate(&self, value: f64, x: &[Vector3<f64>; 3]) -> [Vector3<f64>; 3] {
        match *self {
            SurfaceLaw::Snow => [snow_force(1.0, x); 3],
            SurfaceLaw::Ponding { gamma_w } => {
                let c = (x[1] - x[0]).cross(&(x[2] - x[0]));
                let wet = x.map(|xi| if value > xi.z { gamma_w } else { 0.0 });
                let sum: f64 = wet.iter().sum();
                [0, 1, 2].map(|a| -c * ((wet[a] + sum) / 24.0))
            }
        }
    }
}

/// ∂c/∂x_j of c = (x2 − x1) × (x3 − x1) for j = 1, 2, 3.
fn normal_gradient(x: &[Vector3<f64>; 3]) -> [Matrix3<f64>; 3] {
    let (a, b) = (x[1] - x[0], x[2] - x[0]);
    [skew(&b) - skew(&a), -skew(&b), skew(&a)]
}

/// Snow load `s` (Pa per current plan area) on a triangle: the force on each of its nodes,
/// −(s/6) |c_z| e_z.
pub fn snow_force(s: f64, x: &[Vector3<f64>; 3]) -> Vector3<f64> {
    let c = (x[1] - x[0]).cross(&(x[2] - x[0]));
    Vector3::new(0.0, 0.0, -s * c.z.abs() / 6.0)
}

/// Load stiffness −∂f/∂x of [`snow_force`] (9x9, only the z rows are not zero).
pub fn snow_stiffness(s: f64, x: &[Vector3<f64>; 3]) -> Mat9 {
    let c = (x[1] - x[0]).cross(&(x[2] - x[0]));
    let g = normal_gradient(x);
    let sign = if c.z > 0.0 {
        1.0
    } else if c.z < 0.0 {
        -1.0
    } else {
        0.0
    };
    let mut k = Mat9::zeros();
    for a in 0..3 {
        for (j, gj) in g.iter().enumerate() {
            let row: RowVector3<f64> = gj.row(2).into_owned();
            // −∂f_a,z/∂x_j = (s/6) sgn(c_z) ∂c_z/∂x_j
            k.fixed_view_mut::<1, 3>(3 * a + 2, 3 * j)
                .copy_from(&(row * (s * sign / 6.0)));
        }
    }
    k
}

/// Pressures γ_w max(h − z_i, 0) at the three nodes and their derivatives by z_i.
fn ponding_pressures(gamma_w: f64, h: f64, x: &[Vector3<f64>; 3]) -> ([f64; 3], [f64; 3]) {
    let p = x.map(|xi| gamma_w * (h - xi.z).max(0.0));
    let dp = x.map(|xi| if h > xi.z { -gamma_w } else { 0.0 });
    (p, dp)
}

/// Ponding: water of unit weight `gamma_w` up to level `h` on a triangle at `x`, pressing
/// against its normal: f_a = −(c/24)(2 p_a + p_b + p_c), p_i = γ_w max(h − z_i, 0).
pub fn ponding_forces(gamma_w: f64, h: f64, x: &[Vector3<f64>; 3]) -> [Vector3<f64>; 3] {
    let c = (x[1] - x[0]).cross(&(x[2] - x[0]));
    let (p, _) = ponding_pressures(gamma_w, h, x);
    let sum: f64 = p.iter().sum();
    [0, 1, 2].map(|a| -c * ((p[a] + sum) / 24.0))
}

/// The water [`ponding_forces`] puts on a triangle at `x` up to level `h`, as a volume: its
/// signed plan area c_z/2 times the mean of the nodes' depths d_i = max(h − z_i, 0),
/// V = c_z (d_1 + d_2 + d_3)/6 (so that γ_w V is the vertical resultant of the forces, and
/// V > 0 on a triangle facing up); with ∂V/∂x_i (x: (y_{i+1} − y_{i−1}) D/6, y:
/// (x_{i−1} − x_{i+1}) D/6, z: −c_z w_i/6; D = Σ d, w_i = 1 where wet) and ∂V/∂h = c_z Σ w/6.
/// A water volume's row (`solver/volume.rs`).
pub fn ponding_volume(h: f64, x: &[Vector3<f64>; 3]) -> (f64, [Vector3<f64>; 3], f64) {
    let cz = (x[1] - x[0]).cross(&(x[2] - x[0])).z;
    let depth: f64 = x.iter().map(|xi| (h - xi.z).max(0.0)).sum();
    let wet = x.map(|xi| if h > xi.z { 1.0 } else { 0.0 });
    let grad = [0, 1, 2].map(|i| {
        let (next, prev) = (x[(i + 1) % 3], x[(i + 2) % 3]);
        Vector3::new(
            (next.y - prev.y) * depth / 6.0,
            (prev.x - next.x) * depth / 6.0,
            -cz * wet[i] / 6.0,
        )
    });
    (cz * depth / 6.0, grad, cz * wet.iter().sum::<f64>() / 6.0)
}

/// Load stiffness −∂f/∂x of [`ponding_forces`] (9x9, not symmetric).
pub fn ponding_stiffness(gamma_w: f64, h: f64, x: &[Vector3<f64>; 3]) -> Mat9 {
    let c = (x[1] - x[0]).cross(&(x[2] - x[0]));
    let (p, dp) = ponding_pressures(gamma_w, h, x);
    let sum: f64 = p.iter().sum();
    let g = normal_gradient(x);
    let mut k = Mat9::zeros();
    for (a, pa) in p.iter().enumerate() {
        let q = pa + sum;
        for (j, gj) in g.iter().enumerate() {
            // ∂q_a/∂x_j: only its z component, (1 + δ_aj) ∂p_j/∂z_j.
            let dq = dp[j] * if a == j { 2.0 } else { 1.0 };
            let mut block = gj * (q / 24.0);
            for r in 0..3 {
                block[(r, 2)] += c[r] * dq / 24.0;
            }
            k.fixed_view_mut::<3, 3>(3 * a, 3 * j).copy_from(&block);
        }
    }
    k
}
