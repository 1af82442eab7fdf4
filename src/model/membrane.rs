//! Constant-strain membrane triangle, total Lagrangian, St Venant-Kirchhoff plane stress.
//!
//! ```text
//! X_a        reference node positions (3-D); local orthonormal frame (e1, e2) in their plane
//! ∇N_a       constant reference gradients of the linear shape functions (2-vectors)
//! F = Σ x_a ⊗ ∇N_a            3x2 deformation gradient (current positions x_a)
//! E = ½ (FᵀF − I)             Green-Lagrange strain, Voigt [E11, E22, 2 E12]
//! S = D E                     PK2 stress, Voigt [S11, S22, S12]
//! D = E/(1−ν²) [[1,ν,0],[ν,1,0],[0,0,(1−ν)/2]]
//! f_a = A0 t F S ∇N_a         internal nodal force
//! K_ab = A0 t [ (∇N_a·S ∇N_b) I + B_aᵀ D B_b ]      B_a = [N1 F1ᵀ; N2 F2ᵀ; N2 F1ᵀ + N1 F2ᵀ]
//! W = A0 t ½ Eᵀ D E           stored energy
//! ```
//! The artificial prestress σ0 (Pa) adds `A0 t σa (∇N_a·∇N_b) I` to the tangent only, with
//! `σa = clamp(σ0 − S_min, 0, σ0)` and S_min the minor principal PK2 stress: an isotropic
//! initial-stress stiffness that makes a flat, stress-free membrane loaded normal to its plane
//! solvable without changing the residual, hence without changing the equilibrium. It fills in
//! only the tension that is missing: where the membrane already carries S_min >= σ0 the tangent
//! is exact, so Newton regains quadratic convergence once the membrane is taut.
//!
//! # References
//! Bonet & Wood, *Nonlinear Continuum Mechanics for Finite Element Analysis*, 2nd ed. 2008, ch. 9;
//! Gil 2006 (prestressed SVK membranes); seed paper §3 and Fig. 5 (artificial prestress).

use nalgebra::{Matrix2, Matrix3, SMatrix, SVector, Vector2, Vector3};

pub type Vec9 = SVector<f64, 9>;
pub type Mat9 = SMatrix<f64, 9, 9>;

/// Reference data of one triangle (everything the kernel needs that does not change).
#[derive(Clone, Debug, PartialEq)]
pub struct TriangleRef {
    /// Reference gradients ∇N_a in the element's local frame.
    pub grad: [Vector2<f64>; 3],
    /// Reference area in m².
    pub area: f64,
    /// Unit normal of the reference plane (counter-clockwise node order).
    pub normal: Vector3<f64>,
}

/// Isotropic SVK plane-stress material with thickness.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Svk {
    pub young: f64,
    pub nu: f64,
    pub thickness: f64,
}

impl Svk {
    /// Plane-stress elasticity matrix (Voigt, engineering shear strain).
    pub fn d(&self) -> Matrix3<f64> {
        let c = self.young / (1.0 - self.nu * self.nu);
        Matrix3::new(c, c * self.nu, 0.0, c * self.nu, c, 0.0, 0.0, 0.0, c * (1.0 - self.nu) / 2.0)
    }
}

/// Reference data from three reference positions. None for a degenerate triangle.
pub fn triangle_ref(x: [Vector3<f64>; 3]) -> Option<TriangleRef> {
    let (u, v) = (x[1] - x[0], x[2] - x[0]);
    let n = u.cross(&v);
    let twice_area = n.norm();
    if twice_area <= 1e-300 {
        return None;
    }
    let normal = n / twice_area;
    let e1 = u.normalize();
    let e2 = normal.cross(&e1);
    // Local 2-D coordinates; gradients of linear shape functions: ∇N_a = rot(x_b − x_c)/(2A).
    let p: [Vector2<f64>; 3] = x.map(|xi| Vector2::new((xi - x[0]).dot(&e1), (xi - x[0]).dot(&e2)));
    let grad = [0, 1, 2].map(|a| {
        let (b, c) = ((a + 1) % 3, (a + 2) % 3);
        Vector2::new(p[b].y - p[c].y, p[c].x - p[b].x) / twice_area
    });
    Some(TriangleRef {
        grad,
        area: 0.5 * twice_area,
        normal,
    })
}

/// Deformation gradient F (3x2) from current positions.
#[allow(non_snake_case)]
pub fn deformation_gradient(r: &TriangleRef, x: &[Vector3<f64>; 3]) -> SMatrix<f64, 3, 2> {
    let mut F = SMatrix::<f64, 3, 2>::zeros();
    for a in 0..3 {
        F += x[a] * r.grad[a].transpose();
    }
    F
}

/// Green-Lagrange strain in Voigt form [E11, E22, 2 E12].
#[allow(non_snake_case)]
pub fn green_lagrange(F: &SMatrix<f64, 3, 2>) -> Vector3<f64> {
    let C: Matrix2<f64> = F.transpose() * F;
    Vector3::new(0.5 * (C[(0, 0)] - 1.0), 0.5 * (C[(1, 1)] - 1.0), C[(0, 1)])
}

/// PK2 stress (Voigt) of the SVK law.
pub fn svk_stress(mat: &Svk, strain: &Vector3<f64>) -> Vector3<f64> {
    mat.d() * strain
}

/// Internal force, tangent and stored energy of one SVK triangle at current positions `x`.
/// `prestress` (Pa) enters the tangent only.
#[allow(non_snake_case)]
pub fn svk_triangle(r: &TriangleRef, mat: &Svk, prestress: f64, x: &[Vector3<f64>; 3]) -> (Vec9, Mat9, f64) {
    let F = deformation_gradient(r, x);
    let E = green_lagrange(&F);
    let D = mat.d();
    let S = D * E;
    let vol = r.area * mat.thickness;
    let Smat = Matrix2::new(S[0], S[2], S[2], S[1]);
    let s_min = 0.5 * (S[0] + S[1]) - (0.25 * (S[0] - S[1]).powi(2) + S[2] * S[2]).sqrt();
    let prestress = (prestress - s_min).clamp(0.0, prestress);
    let (F1, F2) = (F.column(0).into_owned(), F.column(1).into_owned());
    let B: [Matrix3<f64>; 3] = [0, 1, 2].map(|a| {
        let (n1, n2) = (r.grad[a].x, r.grad[a].y);
        Matrix3::from_rows(&[
            (F1 * n1).transpose(),
            (F2 * n2).transpose(),
            (F1 * n2 + F2 * n1).transpose(),
        ])
    });
    let mut f = Vec9::zeros();
    let mut K = Mat9::zeros();
    for a in 0..3 {
        let fa = F * (Smat * r.grad[a]) * vol;
        f.fixed_rows_mut::<3>(3 * a).copy_from(&fa);
        for b in 0..3 {
            let geo = r.grad[a].dot(&(Smat * r.grad[b])) + prestress * r.grad[a].dot(&r.grad[b]);
            let kab = (B[a].transpose() * D * B[b] + Matrix3::identity() * geo) * vol;
            K.fixed_view_mut::<3, 3>(3 * a, 3 * b).copy_from(&kab);
        }
    }
    let W = 0.5 * vol * E.dot(&S);
    (f, K, W)
}

/// Internal force and stored energy only (no tangent): the residual-only path of the line
/// search. Same formulas as [`svk_triangle`].
#[allow(non_snake_case)]
pub fn svk_triangle_force(r: &TriangleRef, mat: &Svk, x: &[Vector3<f64>; 3]) -> (Vec9, f64) {
    let F = deformation_gradient(r, x);
    let E = green_lagrange(&F);
    let S = mat.d() * E;
    let vol = r.area * mat.thickness;
    let Smat = Matrix2::new(S[0], S[2], S[2], S[1]);
    let mut f = Vec9::zeros();
    for a in 0..3 {
        f.fixed_rows_mut::<3>(3 * a).copy_from(&(F * (Smat * r.grad[a]) * vol));
    }
    (f, 0.5 * vol * E.dot(&S))
}

/// Current area and unit normal of a triangle.
pub fn current_area_normal(x: &[Vector3<f64>; 3]) -> (f64, Vector3<f64>) {
    let n = (x[1] - x[0]).cross(&(x[2] - x[0]));
    let a = n.norm();
    (0.5 * a, if a > 0.0 { n / a } else { Vector3::zeros() })
}
