//! Constant-strain membrane triangle, total Lagrangian; the material law (SVK or neo-Hookean,
//! with or without wrinkling) comes from `super::wrinkling`.
//!
//! ```text
//! X_a        reference node positions (3-D); local orthonormal frame (e1, e2) in their plane
//! ∇N_a       constant reference gradients of the linear shape functions (2-vectors)
//! F = Σ x_a ⊗ ∇N_a            3x2 deformation gradient (current positions x_a)
//! E = ½ (FᵀF − I)             Green-Lagrange strain, Voigt [E11, E22, 2 E12]
//! S(E), D = ∂S/∂E            PK2 stress (Voigt [S11, S22, S12]) and tangent of the law
//! f_a = A0 t F S ∇N_a         internal nodal force
//! K_ab = A0 t [ (∇N_a·S ∇N_b) I + B_aᵀ D B_b ]      B_a = [N1 F1ᵀ; N2 F2ᵀ; N2 F1ᵀ + N1 F2ᵀ]
//! W = A0 t ψ(E)               stored energy
//! ```
//! A membrane prestress (an initial PK2 stress S0, from the scene's `prestress` in N/m divided
//! by the thickness) is a state, not a tangent aid: the law is evaluated at E + E0 with
//! S(E0) = S0, so `f`, `K` (its geometric part `∇N_a·S ∇N_b` carries S0) and the wrinkling
//! criterion all see the total stress. For SVK this is exactly S = S0 + D E.
//!
//! The artificial prestress σ0 (Pa) adds `A0 t σa (∇N_a·∇N_b) n nᵀ` (n the current unit
//! normal: out of plane only) to the tangent only, with
//! `σa = clamp(σ0 − S_min, 0, σ0)` and S_min the minor principal PK2 stress: an isotropic
//! initial-stress stiffness that makes a flat, stress-free membrane loaded normal to its plane
//! solvable without changing the residual, hence without changing the equilibrium. It fills in
//! only the tension that is missing: where the membrane already carries S_min >= σ0 the tangent
//! is exact, so Newton regains quadratic convergence once the membrane is taut.
//!
//! # References
//! Bonet & Wood, *Nonlinear Continuum Mechanics for Finite Element Analysis*, 2nd ed. 2008, ch. 9;
//! Gil 2006 (prestressed SVK membranes); seed paper §3 and Fig. 5 (artificial prestress).

pub use super::plane_stress::principal_stresses;
use super::plane_stress::{principal, Response, WrinkleState, REGULARIZATION};
use super::wrinkling::Law;
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
    /// The element frame: e1 along the first edge, e2 = normal × e1. Stresses, strains and
    /// tension angles of the element are expressed in it.
    pub frame: [Vector3<f64>; 2],
    /// Equivalent initial strain E0 (Voigt, element frame) of the membrane prestress: the law
    /// is evaluated at E + E0, with E0 chosen so that its stress at E = 0 is the prescribed
    /// initial PK2 stress S0 ([`initial_strain`]). Zero without prestress.
    pub initial_strain: Vector3<f64>,
}

impl TriangleRef {
    /// A Voigt stress of the element frame as a 3x3 tensor in global axes.
    pub fn to_global(&self, s: &Vector3<f64>) -> Matrix3<f64> {
        let [e1, e2] = self.frame;
        (e1 * e1.transpose()) * s[0]
            + (e2 * e2.transpose()) * s[1]
            + (e1 * e2.transpose() + e2 * e1.transpose()) * s[2]
    }

    /// Unit direction (global, reference configuration) at `angle` in the element frame.
    pub fn direction(&self, angle: f64) -> Vector3<f64> {
        self.frame[0] * angle.cos() + self.frame[1] * angle.sin()
    }
}

/// A membrane group's material: law, thickness and whether it wrinkles.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Material {
    pub law: Law,
    pub thickness: f64,
    /// Tension-field law on (compression impossible); off: the plain elastic sheet.
    pub wrinkling: bool,
    /// Residual stiffness ρ of wrinkled and slack states (0: the pure tension-field law).
    pub residual: f64,
    /// Elastoplastic (ETFE foil, `super::etfe`) on the SVK law: the hardening and the
    /// triangle's place in the plastic history. None: elastic.
    pub plastic: Option<super::etfe::Etfe>,
}

impl Material {
    /// Stress, tangent and energy density at a strain; `forced` overrides the wrinkle state.
    pub fn response(&self, strain: &Vector3<f64>, forced: Option<WrinkleState>) -> Response {
        self.response_with(strain, forced, REGULARIZATION)
    }

    /// [`Material::response`] with the tangent-only regularisation `eps` of wrinkled and slack
    /// states in place of [`REGULARIZATION`] (`Law::response_with`).
    pub fn response_with(
        &self,
        strain: &Vector3<f64>,
        forced: Option<WrinkleState>,
        eps: f64,
    ) -> Response {
        if self.wrinkling {
            let r = self.law.response_with(strain, forced, eps);
            if self.residual > 0.0 && r.state != WrinkleState::Taut {
                // W = (1 − ρ) W_tf + ρ ½ Eᵀ D0 E: the law's tangent-only ε·D0 is replaced by
                // the consistent ρ·D0 (the blend is continuous at the slack border, and at the
                // taut border for the laws whose taut stress is D0 E).
                let rho = self.residual;
                let d0 = self.law.small_strain();
                let linear = d0 * strain;
                Response {
                    stress: r.stress * (1.0 - rho) + linear * rho,
                    tangent: (r.tangent - d0 * eps) * (1.0 - rho) + d0 * rho,
                    energy: r.energy * (1.0 - rho) + 0.5 * rho * strain.dot(&linear),
                    ..r
                }
            } else {
                r
            }
        } else {
            let (stress, tangent, energy) = self.law.elastic(strain);
            let (_, _, angle) = principal(strain);
            Response {
                stress,
                tangent,
                energy,
                state: WrinkleState::Taut,
                angle,
            }
        }
    }

    /// The elastic constants of an elastoplastic group's SVK law and its wrinkling switch
    /// (`super::etfe`; the model builds those groups on the SVK law only).
    pub fn sheet(&self) -> super::etfe::Sheet {
        let d = self.law.small_strain();
        let (young, nu) = match self.law {
            Law::Svk { young, nu } => (young, nu),
            _ => (d[(0, 0)], 0.0),
        };
        super::etfe::Sheet {
            young,
            nu,
            wrinkling: self.wrinkling,
        }
    }

    /// A modulus for force scales: E (SVK) or 3μ (neo-Hookean).
    pub fn modulus(&self) -> f64 {
        match self.law {
            Law::Svk { young, .. } => young,
            Law::NeoHookean { mu } => 3.0 * mu,
            Law::Orthotropic(o) => o.e_warp.max(o.e_fill),
        }
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
        frame: [e1, e2],
        initial_strain: Vector3::zeros(),
    })
}

/// Deformation gradient F (3x2) from current positions.
#[allow(non_snake_case)]
pub fn deformation_gradient(r: &TriangleRef, x: &[Vector3<f64>; 3]) -> SMatrix<f64, 3, 2> {
    let mut F = SMatrix::<f64, 3, 2>::zeros();
    for (xa, ga) in x.iter().zip(&r.grad) {
        F += xa * ga.transpose();
    }
    F
}

/// Green-Lagrange strain in Voigt form [E11, E22, 2 E12].
#[allow(non_snake_case)]
pub fn green_lagrange(F: &SMatrix<f64, 3, 2>) -> Vector3<f64> {
    let C: Matrix2<f64> = F.transpose() * F;
    Vector3::new(0.5 * (C[(0, 0)] - 1.0), 0.5 * (C[(1, 1)] - 1.0), C[(0, 1)])
}

/// What one element evaluation gives besides force and tangent.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Evaluation {
    /// Stored energy, J.
    pub energy: f64,
    pub state: WrinkleState,
    /// Tension direction angle in the element frame.
    pub angle: f64,
    /// PK2 stress (Voigt).
    pub stress: Vector3<f64>,
    /// Principal Cauchy stresses (major, minor) in Pa: σ = F S Fᵀ / j with j the area ratio
    /// (thickness taken as unchanged) for SVK, j = 1 for the incompressible neo-Hookean law.
    pub cauchy: (f64, f64),
    /// Current area / reference area.
    pub area_ratio: f64,
}

/// Internal force, tangent (if `tangent` is given, written there) and evaluation of one
/// triangle at current positions `x`. `prestress` (Pa) enters the tangent only; `forced`
/// freezes the wrinkle state.
pub fn triangle(
    r: &TriangleRef,
    mat: &Material,
    prestress: f64,
    x: &[Vector3<f64>; 3],
    forced: Option<WrinkleState>,
    tangent: Option<&mut Mat9>,
) -> (Vec9, Evaluation) {
    triangle_with(r, mat, prestress, x, forced, tangent, REGULARIZATION, 0.0)
}

/// [`triangle`] with the tangent-only regularisation `eps` of wrinkled and slack states in
/// place of [`REGULARIZATION`] (`Material::response_with`; force and evaluation do not
/// depend on it) and an isotropic pre-strain `pre_strain` added to the strain the law sees:
/// E + E0 + h (1, 1, 0). The pre-strain is the solver's prestress continuation (a real,
/// energy-consistent prestress of an intermediate problem, `solver/path.rs`), 0 otherwise.
#[allow(clippy::too_many_arguments)]
pub fn triangle_with(
    r: &TriangleRef,
    mat: &Material,
    prestress: f64,
    x: &[Vector3<f64>; 3],
    forced: Option<WrinkleState>,
    tangent: Option<&mut Mat9>,
    eps: f64,
    pre_strain: f64,
) -> (Vec9, Evaluation) {
    triangle_plastic(r, mat, prestress, x, forced, tangent, eps, pre_strain, &[])
}

/// [`triangle_with`] with the committed plastic history `plastic` (`state::History`, read at
/// the material's slot; empty: no plastic strain) for an elastoplastic material: the law is
/// the return from it (`etfe::response`), which the element never writes back.
#[allow(non_snake_case, clippy::too_many_arguments)]
pub fn triangle_plastic(
    r: &TriangleRef,
    mat: &Material,
    prestress: f64,
    x: &[Vector3<f64>; 3],
    forced: Option<WrinkleState>,
    tangent: Option<&mut Mat9>,
    eps: f64,
    pre_strain: f64,
    plastic: &[f64],
) -> (Vec9, Evaluation) {
    let F = deformation_gradient(r, x);
    // The prestress enters here, and only here: the law (wrinkling included) sees the total
    // strain E + E0, so the stress is the total stress S0 + ΔS and the tension-field criterion
    // acts on it. The same holds for the continuation's pre-strain.
    let E = green_lagrange(&F) + r.initial_strain + Vector3::new(pre_strain, pre_strain, 0.0);
    let resp = match &mat.plastic {
        None => mat.response_with(&E, forced, eps),
        Some(p) => {
            let point = super::etfe::Point::read(plastic, p.slot);
            super::etfe::response(mat.sheet(), &p.hardening, &E, &point, forced, eps).0
        }
    };
    let S = resp.stress;
    let vol = r.area * mat.thickness;
    let Smat = Matrix2::new(S[0], S[2], S[2], S[1]);
    let mut f = Vec9::zeros();
    for a in 0..3 {
        f.fixed_rows_mut::<3>(3 * a)
            .copy_from(&(F * (Smat * r.grad[a]) * vol));
    }
    if let Some(K) = tangent {
        // Fill in only the tension the element lacks: its minor principal stress if taut, its
        // tension if wrinkled, nothing if slack.
        let (s_max, s_min) = principal_stresses(&S);
        let carried = if resp.state == WrinkleState::Wrinkled {
            s_max
        } else {
            s_min
        };
        let prestress = (prestress - carried).clamp(0.0, prestress);
        let (F1, F2) = (F.column(0).into_owned(), F.column(1).into_owned());
        let B: [Matrix3<f64>; 3] = [0, 1, 2].map(|a| {
            let (n1, n2) = (r.grad[a].x, r.grad[a].y);
            Matrix3::from_rows(&[
                (F1 * n1).transpose(),
                (F2 * n2).transpose(),
                (F1 * n2 + F2 * n1).transpose(),
            ])
        });
        let D = resp.tangent;
        // The artificial prestress acts out of the current plane only: that is the direction
        // a flat, stress-free sheet lacks; in plane the material tangent is already there and a
        // fictitious stress would only slow convergence.
        let normal = F1.cross(&F2);
        let nn = if normal.norm() > 0.0 {
            let n = normal.normalize();
            n * n.transpose()
        } else {
            Matrix3::identity()
        };
        for a in 0..3 {
            for b in 0..3 {
                let geo = r.grad[a].dot(&(Smat * r.grad[b]));
                let fill = prestress * r.grad[a].dot(&r.grad[b]);
                let kab =
                    (B[a].transpose() * D * B[b] + Matrix3::identity() * geo + nn * fill) * vol;
                K.fixed_view_mut::<3, 3>(3 * a, 3 * b).copy_from(&kab);
            }
        }
    }
    // Eigenvalues of S C equal the nonzero eigenvalues of F S Fᵀ.
    let C = F.transpose() * F;
    let area_ratio = C.determinant().max(0.0).sqrt();
    let j = match mat.law {
        Law::Svk { .. } | Law::Orthotropic(_) => area_ratio.max(f64::MIN_POSITIVE),
        Law::NeoHookean { .. } => 1.0,
    };
    let M = Smat * C;
    let (half_tr, det) = (0.5 * M.trace(), M.determinant());
    let root = (half_tr * half_tr - det).max(0.0).sqrt();
    let eval = Evaluation {
        energy: resp.energy * vol,
        state: resp.state,
        angle: resp.angle,
        stress: S,
        cauchy: ((half_tr + root) / j, (half_tr - root) / j),
        area_ratio,
    };
    (f, eval)
}

/// Initial PK2 stress (Pa, Voigt, element frame) of membrane forces `warp` and `fill` (N/m)
/// along a warp direction and its in-plane perpendicular, in a sheet of `thickness`. The warp
/// direction is `warp_direction` (global) projected on the element plane; None when it is
/// within about 0.6° of the normal (no usable projection). Isotropic prestress: warp = fill,
/// any direction.
pub fn initial_stress(
    r: &TriangleRef,
    warp: f64,
    fill: f64,
    warp_direction: &Vector3<f64>,
    thickness: f64,
) -> Option<Vector3<f64>> {
    let (c, s) = if warp == fill {
        (1.0, 0.0)
    } else {
        let d = warp_direction.normalize();
        let (c, s) = (d.dot(&r.frame[0]), d.dot(&r.frame[1]));
        // Not f64::hypot: it needs glibc 2.35, above the FMU baseline.
        let in_plane = (c * c + s * s).sqrt();
        if !(in_plane > 1e-2) {
            return None;
        }
        (c / in_plane, s / in_plane)
    };
    let (w, f) = (warp / thickness, fill / thickness);
    Some(Vector3::new(
        w * c * c + f * s * s,
        w * s * s + f * c * c,
        (w - f) * c * s,
    ))
}

/// Initial PK2 stress (Pa, Voigt, element frame) of a membrane force tensor given in global
/// components [n_xx, n_yy, n_zz, n_xy, n_yz, n_xz] (N/m): its in-plane part over the thickness.
pub fn field_stress(r: &TriangleRef, n: &[f64; 6], thickness: f64) -> Vector3<f64> {
    let t = Matrix3::new(n[0], n[3], n[5], n[3], n[1], n[4], n[5], n[4], n[2]);
    let [e1, e2] = r.frame;
    Vector3::new(e1.dot(&(t * e1)), e2.dot(&(t * e2)), e1.dot(&(t * e2))) / thickness
}

/// The strain E0 at which the material's elastic law gives the stress `s0`: the equivalent
/// initial strain of a prestress (exact in one step for SVK, where E0 = D⁻¹ S0; Newton on
/// S(E0) = S0 for neo-Hookean). None when the law cannot carry `s0` (a neo-Hookean principal
/// stress at or above μ) or Newton does not reach round-off.
#[allow(non_snake_case)]
pub fn initial_strain(mat: &Material, s0: &Vector3<f64>) -> Option<Vector3<f64>> {
    let scale = mat.modulus();
    let mut E = mat.law.small_strain().try_inverse()? * s0;
    for _ in 0..50 {
        let (S, D, _) = mat.law.elastic(&E);
        let gap = s0 - S;
        if !gap.iter().all(|g| g.is_finite()) {
            return None;
        }
        if gap.amax() <= 1e-14 * scale.max(s0.amax()) {
            return Some(E);
        }
        let step = D.try_inverse()? * gap;
        E += step;
        // Keep C = I + 2E positive definite (the law's domain).
        if 1.0 + 2.0 * E[0].min(E[1]) <= 0.0 {
            return None;
        }
    }
    None
}

/// Current area over reference area, negative when the triangle has turned over: its current
/// normal points against its reference normal (an in-plane inversion, or a fold). A converged
/// answer has no triangle turned over or collapsed; while iterating, a wrinkled or slack one
/// may fold (the solver's inversion guard, `solver::assemble::FOLD_LIMIT`).
pub fn signed_area_ratio(r: &TriangleRef, x: &[Vector3<f64>; 3]) -> f64 {
    (x[1] - x[0]).cross(&(x[2] - x[0])).dot(&r.normal) / (2.0 * r.area)
}
