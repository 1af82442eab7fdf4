//! ETFE foil: plane-stress elastoplasticity (von Mises, isotropic multilinear hardening) on
//! the St Venant-Kirchhoff membrane, with the tension-field law acting on the elastoplastic
//! stress.
//!
//! ```text
//! split        E = Ee + Ep  (Green-Lagrange, Voigt [E11, E22, 2 E12]);  S = D Ee  (PK2)
//! yield        f = ½ Sᵀ P S − ⅓ σy(α)²,  P = ⅓ [[2, −1, 0], [−1, 2, 0], [0, 0, 6]]
//!              (½ Sᵀ P S = ⅓ σvm², σvm² = S11² − S11 S22 + S22² + 3 S12²)
//! hardening    σy(α) = σ1 + H1 α            α <= α2 = ε2 − σ2/E
//!                      σ2 + H2 (α − α2)     α >  α2
//!              from the uniaxial curve through (σ1/E, σ1), (ε2, σ2), then the tangent
//!              modulus Et3: Et12 = (σ2 − σ1)/(ε2 − σ1/E), H = E Et/(E − Et)
//! flow         ΔEp = Δγ P S,  Δα = √(⅔ SᵀPS) Δγ   (associative; α the equivalent plastic strain)
//! return       (backward Euler from the committed Ep_n, α_n): in the coordinates
//!              a1 = S11 + S22, a2 = S22 − S11, a3 = S12 (eigenvectors of D and P)
//!              a1 = a1tr/(1 + E Δγ/(3(1 − ν))),  (a2, a3) = (a2tr, a3tr)/(1 + 2 G Δγ)
//!              Δγ from σvm(Δγ) = σy(α_n + √(⅔) Δγ f̄(Δγ)), f̄² = a1²/6 + a2²/2 + 2 a3²
//!              (one unknown, monotone: safeguarded Newton)
//! tangent      Cep = Ξ − Ξn (Ξn)ᵀ / (nᵀΞn + β),  Ξ = (D⁻¹ + Δγ P)⁻¹,  n = P S,
//!              β = ⅔ H f̄² / (1 − ⅔ H Δγ)  (the consistent linearisation of the return)
//! energy       W = ½ Eeᵀ D Ee + ∫ σy dα over [α_n, α_n+1]   (the incremental potential: its
//!              derivative is S, so the line search's potential stays exact)
//! ```
//! # Wrinkling on the total stress
//! The tension-field check acts on the elastoplastic stress, not on an elastic trial: the
//! return above is made first as if the point were taut; if the returned S has a negative
//! principal value, the point is wrinkled. A wrinkled point carries uniaxial tension σ along t,
//! the major principal direction of the trial elastic strain E − Ep_n (t is also principal for
//! the taut return, whose S is coaxial with it), with the uniaxial return
//! σ = E (Ee1tr − Δ) = σy(α_n + Δ), ΔEp = Δ (t⊗t − ½ m⊗m) (plastic incompressibility; the
//! wrinkle strain takes the rest across m). Both branches give the same S where the taut one
//! has S_min = 0, so the stress is continuous across the border. Slack (Ee1tr <= 0 or σ <= 0):
//! S = 0, no plastic flow. Residual stiffness of wrinkled states is not offered with this law
//! (the scene validation refuses it).
//!
//! An elastic trial check (wrinkled where D (E − Ep_n) has a negative principal value) would be
//! wrong: a strip yielding in uniaxial tension contracts plastically across, so its elastic
//! trial is compressed across and it would be called wrinkled and stop yielding.
//!
//! The committed (Ep, α) of every triangle are the history (`state.rs`); a trial point never
//! writes them. `state::advance` returns them at a converged point.
//!
//! # References
//! Simo & Hughes 1998, *Computational Inelasticity*, §3.3-3.4 (plane-stress return in the
//! spectral coordinates of P, the consistent tangent); Ortiz & Stainier 1999, CMAME 171:419-444
//! (the incremental potential); Galliot & Luchsinger 2011, Polymer Testing 30:356-365, and
//! the ETFE design literature (Lehnert & Schiemann; Moritz 2007) for the bilinear-with-two-yield-
//! points description of ETFE foil.

use super::plane_stress::{principal, principal_stresses, Response, WrinkleState};
use nalgebra::{Matrix3, Vector3};

/// Multilinear isotropic hardening in the equivalent plastic strain α (module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hardening {
    /// First yield stress σ1, Pa.
    pub s1: f64,
    /// Plastic modulus between the yield points, Pa.
    pub h1: f64,
    /// α at the second yield point.
    pub a2: f64,
    /// Plastic modulus beyond the second yield point, Pa.
    pub h2: f64,
}

impl Hardening {
    /// From the uniaxial curve: E, the first yield stress σ1 (at strain σ1/E), the second yield
    /// point (ε2, σ2) and the tangent modulus Et3 beyond it. The scene validation guarantees
    /// 0 < σ1 < σ2, σ1/E < ε2 with Et12 < E, and 0 <= Et3 < E.
    pub fn from_curve(young: f64, s1: f64, (e2, s2): (f64, f64), et3: f64) -> Hardening {
        let et12 = (s2 - s1) / (e2 - s1 / young);
        let plastic = |et: f64| young * et / (young - et);
        Hardening {
            s1,
            h1: plastic(et12),
            a2: e2 - s2 / young,
            h2: plastic(et3),
        }
    }

    /// σy(α) and its slope H (the slope of the segment α lies in; beyond α2 at α2 itself).
    pub fn yield_stress(&self, alpha: f64) -> (f64, f64) {
        if alpha < self.a2 {
            (self.s1 + self.h1 * alpha, self.h1)
        } else {
            (
                self.s1 + self.h1 * self.a2 + self.h2 * (alpha - self.a2),
                self.h2,
            )
        }
    }

    /// ∫₀^α σy: the plastic work per volume to reach α.
    pub fn work(&self, alpha: f64) -> f64 {
        let first = alpha.min(self.a2);
        let mut w = self.s1 * first + 0.5 * self.h1 * first * first;
        if alpha > self.a2 {
            let d = alpha - self.a2;
            w += (self.s1 + self.h1 * self.a2) * d + 0.5 * self.h2 * d * d;
        }
        w
    }
}

/// An elastoplastic membrane group's hardening, and the triangle's place in the plastic
/// history (4 values from `4 slot`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Etfe {
    pub hardening: Hardening,
    pub slot: usize,
}

/// The plastic state of one triangle: plastic strain (Voigt, engineering shear) and α.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Point {
    pub ep: Vector3<f64>,
    pub alpha: f64,
}

impl Point {
    /// Triangle `slot`'s state in a history (virgin when the history is empty).
    pub fn read(plastic: &[f64], slot: usize) -> Point {
        match plastic.get(4 * slot..4 * slot + 4) {
            Some(p) => Point {
                ep: Vector3::new(p[0], p[1], p[2]),
                alpha: p[3],
            },
            None => Point::default(),
        }
    }

    /// Write the state to its 4 values of a history.
    pub fn write(&self, out: &mut [f64]) {
        out[..3].copy_from_slice(self.ep.as_slice());
        out[3] = self.alpha;
    }
}

/// Relative tolerance of the return's scalar equation (in units of the yield stress).
const RETURN_TOL: f64 = 1e-13;

/// The taut (plane-stress) return from `point` at total strain `strain`: stress, consistent
/// tangent, incremental energy and the new point.
pub fn taut(
    young: f64,
    nu: f64,
    h: &Hardening,
    strain: &Vector3<f64>,
    point: &Point,
) -> (Vector3<f64>, Matrix3<f64>, f64, Point) {
    let d = isotropic(young, nu);
    let ee = strain - point.ep;
    let s_tr = d * ee;
    let (a1, a2, a3) = (s_tr[0] + s_tr[1], s_tr[1] - s_tr[0], s_tr[2]);
    let vm = |f2: f64| (1.5 * f2).max(0.0).sqrt();
    let f2_at = |g: f64| {
        let (c1, c2) = (
            1.0 + young * g / (3.0 * (1.0 - nu)),
            1.0 + young * g / (1.0 + nu),
        );
        a1 * a1 / (6.0 * c1 * c1) + (0.5 * a2 * a2 + 2.0 * a3 * a3) / (c2 * c2)
    };
    let f2_tr = f2_at(0.0);
    let (sy0, _) = h.yield_stress(point.alpha);
    if vm(f2_tr) <= sy0 * (1.0 + RETURN_TOL) {
        return (s_tr, d, 0.5 * ee.dot(&s_tr), *point);
    }
    // g(Δγ) = σvm(Δγ) − σy(α_n + √(⅔) Δγ f̄(Δγ)): decreasing, g(0) > 0.
    let g_of = |g: f64| {
        let f2 = f2_at(g);
        let alpha = point.alpha + (2.0f64 / 3.0).sqrt() * g * f2.sqrt();
        vm(f2) - h.yield_stress(alpha).0
    };
    let (mut lo, mut hi) = (0.0, 1.0 / young);
    while g_of(hi) > 0.0 && hi < 1e6 / young {
        lo = hi;
        hi *= 4.0;
    }
    let mut x = lo;
    for _ in 0..200 {
        let gx = g_of(x);
        if gx.abs() <= RETURN_TOL * sy0 {
            break;
        }
        if gx > 0.0 {
            lo = x;
        } else {
            hi = x;
        }
        // The slope (a forward difference) only steers the bracketed iteration: the root's
        // accuracy comes from the test on g above; bisection where Newton leaves the bracket.
        let dx = 1e-7 * (hi - lo).max(1e-300);
        let slope = (g_of(x + dx) - gx) / dx;
        let next = x - gx / slope;
        x = if slope < 0.0 && next > lo && next < hi {
            next
        } else {
            0.5 * (lo + hi)
        };
        if hi - lo <= 1e-16 * hi {
            break;
        }
    }
    let dg = x;
    let c1 = 1.0 + young * dg / (3.0 * (1.0 - nu));
    let c2 = 1.0 + young * dg / (1.0 + nu);
    let (b1, b2, b3) = (a1 / c1, a2 / c2, a3 / c2);
    let s = Vector3::new(0.5 * (b1 - b2), 0.5 * (b1 + b2), b3);
    let p = flow_matrix();
    let n = p * s;
    let f2 = s.dot(&n);
    let alpha = point.alpha + (2.0f64 / 3.0).sqrt() * dg * f2.sqrt();
    let next = Point {
        ep: point.ep + n * dg,
        alpha,
    };
    let (_, hh) = h.yield_stress(alpha);
    let xi = (d.try_inverse().unwrap_or_else(Matrix3::zeros) + p * dg)
        .try_inverse()
        .unwrap_or_else(Matrix3::zeros);
    let xn = xi * n;
    let beta = (2.0 / 3.0) * hh * f2 / (1.0 - (2.0 / 3.0) * hh * dg).max(1e-12);
    let tangent = xi - xn * xn.transpose() / (n.dot(&xn) + beta);
    let ee = strain - next.ep;
    let energy = 0.5 * ee.dot(&(d * ee)) + h.work(alpha) - h.work(point.alpha);
    (s, tangent, energy, next)
}

/// P of the module docs.
fn flow_matrix() -> Matrix3<f64> {
    Matrix3::new(2.0, -1.0, 0.0, -1.0, 2.0, 0.0, 0.0, 0.0, 6.0) / 3.0
}

/// The isotropic plane-stress D: the SVK law's small-strain matrix.
fn isotropic(young: f64, nu: f64) -> Matrix3<f64> {
    super::wrinkling::Law::Svk { young, nu }.small_strain()
}

/// The elastic constants and the wrinkling switch of an elastoplastic sheet.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sheet {
    pub young: f64,
    pub nu: f64,
    /// The tension-field law on (module docs); off: taut always.
    pub wrinkling: bool,
}

/// The law at total strain `strain` from the committed `point` (module docs): the response
/// (tangent-only regularisation `eps` D in wrinkled and slack states, as the elastic laws) and
/// the point the return reaches. `forced` fixes the state as for the elastic laws.
pub fn response(
    sheet: Sheet,
    h: &Hardening,
    strain: &Vector3<f64>,
    point: &Point,
    forced: Option<WrinkleState>,
    eps: f64,
) -> (Response, Point) {
    let Sheet { young, nu, .. } = sheet;
    let (_, _, angle) = principal(strain);
    let taut_response = || {
        let (stress, tangent, energy, next) = taut(young, nu, h, strain, point);
        let r = Response {
            stress,
            tangent,
            energy,
            state: WrinkleState::Taut,
            angle,
        };
        (r, next)
    };
    if !sheet.wrinkling {
        return taut_response();
    }
    let ee_tr = strain - point.ep;
    let (e1, e2, t_angle) = principal(&ee_tr);
    let state = match forced {
        Some(s) => s,
        None if e1 <= 0.0 => WrinkleState::Slack,
        None => {
            let (r, next) = taut_response();
            if principal_stresses(&r.stress).1 >= 0.0 {
                return (r, next);
            }
            WrinkleState::Wrinkled
        }
    };
    let reg = isotropic(young, nu) * eps;
    let slack = |angle| {
        let r = Response {
            stress: Vector3::zeros(),
            tangent: reg,
            energy: 0.0,
            state: WrinkleState::Slack,
            angle,
        };
        (r, *point)
    };
    match state {
        WrinkleState::Taut => taut_response(),
        WrinkleState::Slack => slack(t_angle),
        WrinkleState::Wrinkled => {
            let s_tr = young * e1;
            if s_tr <= 0.0 && forced.is_none() {
                return slack(t_angle);
            }
            let (c, s) = (t_angle.cos(), t_angle.sin());
            // t⊗t as a stress (Voigt) and the rotation direction of the elastic law.
            let v = Vector3::new(c * c, s * s, c * s);
            let w = Vector3::new(-2.0 * c * s, 2.0 * c * s, c * c - s * s) * 0.5;
            let (sy0, _) = h.yield_stress(point.alpha);
            let (sigma, ratio, next) = if s_tr > sy0 {
                // σ = E (Ee1tr − Δ) = σy(α_n + Δ): linear on each hardening segment.
                let solve = |sy: f64, hh: f64| (s_tr - sy) / (young + hh);
                let (sy, hh) = h.yield_stress(point.alpha);
                let mut delta = solve(sy, hh);
                if point.alpha < h.a2 && point.alpha + delta > h.a2 {
                    let (sy2, hh2) = h.yield_stress(h.a2);
                    delta = h.a2 - point.alpha + solve(sy2, hh2);
                }
                let alpha = point.alpha + delta;
                let (_, hh) = h.yield_stress(alpha);
                // t⊗t − ½ m⊗m as a strain (Voigt, engineering shear).
                let dir = Vector3::new(c * c - 0.5 * s * s, s * s - 0.5 * c * c, 3.0 * c * s);
                let next = Point {
                    ep: point.ep + dir * delta,
                    alpha,
                };
                (s_tr - young * delta, hh / (young + hh), next)
            } else {
                (s_tr, 1.0, *point)
            };
            let gap = (e1 - e2).max(f64::MIN_POSITIVE);
            let tangent =
                v * v.transpose() * (young * ratio) + w * w.transpose() * (2.0 * sigma / gap) + reg;
            let el = sigma / young;
            let energy = 0.5 * young * el * el + h.work(next.alpha) - h.work(point.alpha);
            let r = Response {
                stress: v * sigma,
                tangent,
                energy,
                state: WrinkleState::Wrinkled,
                angle: t_angle,
            };
            (r, next)
        }
    }
}

/// The committed plastic strains the assembly reads (4 per triangle, `state::History`), held
/// by the model behind a lock so that the path drivers can set them through the shared
/// `&Model` the solver works with. Read once per assembly; written only between Newton solves.
#[derive(Debug, Default)]
pub struct PlasticStore(std::sync::RwLock<Vec<f64>>);

impl PlasticStore {
    /// Replace the stored strains by `values`.
    pub fn set(&self, values: &[f64]) {
        let mut held = self.0.write().unwrap_or_else(|e| e.into_inner());
        if held.as_slice() != values {
            held.clear();
            held.extend_from_slice(values);
        }
    }

    /// The stored strains, for the duration of the guard.
    pub fn read(&self) -> std::sync::RwLockReadGuard<'_, Vec<f64>> {
        self.0.read().unwrap_or_else(|e| e.into_inner())
    }
}

impl Clone for PlasticStore {
    fn clone(&self) -> PlasticStore {
        PlasticStore(std::sync::RwLock::new(self.read().clone()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const E: f64 = 1.0e9;
    const NU: f64 = 0.43;

    fn hardening() -> Hardening {
        Hardening::from_curve(E, 16e6, (0.10, 24e6), 10e6)
    }

    fn material(wrinkling: bool) -> Sheet {
        Sheet {
            young: E,
            nu: NU,
            wrinkling,
        }
    }

    /// Central differences of the stress (tangent) and of the energy (stress), relative to
    /// their size.
    fn fd_errors(mat: &Sheet, strain: Vector3<f64>, point: &Point) -> (f64, f64, Response) {
        let h = hardening();
        let (r, _) = response(*mat, &h, &strain, point, None, 0.0);
        let step = 1e-7;
        let mut fd = Matrix3::zeros();
        let mut ds = Vector3::zeros();
        for j in 0..3 {
            let mut d = Vector3::zeros();
            d[j] = step;
            let (p, _) = response(*mat, &h, &(strain + d), point, Some(r.state), 0.0);
            let (m, _) = response(*mat, &h, &(strain - d), point, Some(r.state), 0.0);
            fd.set_column(j, &((p.stress - m.stress) / (2.0 * step)));
            ds[j] = (p.energy - m.energy) / (2.0 * step);
        }
        let tangent = (r.tangent - fd).norm() / fd.norm();
        let stress = (r.stress - ds).norm() / r.stress.norm().max(1.0);
        (tangent, stress, r)
    }

    /// GOAL: the consistent tangent equals the finite-difference derivative of the returned
    /// stress, and the stress the derivative of the incremental energy, on every branch: taut
    /// elastic, taut on each hardening segment, from a committed plastic state, wrinkled and
    /// yielding. REFERENCE: central differences, step 1e-7 on strains of 1e-2..1e-1.
    /// TOLERANCE: 1e-8 relative (the differences' round-off, about ε |S| / step: measured
    /// 8e-10 at most; segment kinks, where the tangent jumps, are avoided by the strains
    /// chosen).
    #[test]
    fn tangent_and_stress_match_finite_differences_on_every_branch() {
        let taut = material(true);
        let committed = Point {
            ep: Vector3::new(0.02, -0.004, 0.003),
            alpha: 0.025,
        };
        let cases = [
            (
                "elastic",
                Vector3::new(0.008, 0.006, 0.002),
                Point::default(),
                WrinkleState::Taut,
            ),
            (
                "first segment",
                Vector3::new(0.03, 0.02, 0.004),
                Point::default(),
                WrinkleState::Taut,
            ),
            (
                "second segment",
                Vector3::new(0.16, 0.12, 0.01),
                Point::default(),
                WrinkleState::Taut,
            ),
            (
                "committed",
                Vector3::new(0.06, 0.03, 0.01),
                committed,
                WrinkleState::Taut,
            ),
            (
                "wrinkled, yielding",
                Vector3::new(0.05, -0.04, 0.01),
                Point::default(),
                WrinkleState::Wrinkled,
            ),
            (
                "wrinkled, elastic",
                Vector3::new(0.01, -0.03, 0.004),
                Point::default(),
                WrinkleState::Wrinkled,
            ),
        ];
        for (what, strain, point, state) in cases {
            let (t, s, r) = fd_errors(&taut, strain, &point);
            println!(
                "{what}: tangent {t:.2e}, stress {s:.2e}, state {:?}",
                r.state
            );
            assert_eq!(r.state, state, "{what}");
            assert!(t < 1e-8, "{what}: tangent error {t:e}");
            assert!(s < 1e-8, "{what}: stress vs energy error {s:e}");
        }
    }

    /// GOAL: the returned stress lies on the yield surface of the new α, the return is
    /// idempotent (the new point returns to itself, elastically), and the stress is continuous
    /// across the taut/wrinkled border (uniaxial tension along x, lateral strain at the plastic
    /// contraction). REFERENCE: f = 0; the closed-form uniaxial return σ = σy(α), α from
    /// σ = E (E11 − α). TOLERANCE: on the surface and idempotent 1e-13 relative (the return's
    /// own stopping test, 1e-13 of σy: measured 1.7e-16 and 3.6e-16),
    /// across the border 2e-7 (a lateral strain change of 1e-9 moves S11 by about
    /// E 1e-9 / σ = 5e-8 of it).
    #[test]
    fn the_return_is_on_the_surface_idempotent_and_continuous() {
        let h = hardening();
        let mat = material(true);
        let strain = Vector3::new(0.05, 0.03, 0.01);
        let (r, next) = response(mat, &h, &strain, &Point::default(), None, 0.0);
        let s = r.stress;
        let vm = (s[0] * s[0] - s[0] * s[1] + s[1] * s[1] + 3.0 * s[2] * s[2]).sqrt();
        let sy = h.yield_stress(next.alpha).0;
        println!("on the surface: {:.1e}", (vm - sy).abs() / sy);
        assert!((vm - sy).abs() < 1e-13 * sy, "{vm} vs {sy}");
        let (again, same) = response(mat, &h, &strain, &next, None, 0.0);
        println!("idempotent: {:.1e}", (again.stress - s).norm() / s.norm());
        assert!((again.stress - s).norm() < 1e-13 * s.norm());
        assert!((same.alpha - next.alpha).abs() < 1e-12);
        // Uniaxial: E11 = 0.05 total; α solves E (E11 − α) = σ1 + H1 α (first segment).
        let alpha = (E * 0.05 - h.s1) / (E + h.h1);
        let sigma = h.s1 + h.h1 * alpha;
        // The lateral strain of that state: elastic −ν σ/E, plastic −α/2.
        let lateral = -NU * sigma / E - 0.5 * alpha;
        for bump in [-1e-9, 0.0, 1e-9] {
            let e = Vector3::new(0.05, lateral + bump, 0.0);
            let (r, _) = response(mat, &h, &e, &Point::default(), None, 0.0);
            println!("lateral bump {bump:e}: {:?}, S {:?}", r.state, r.stress);
            assert!(
                (r.stress[0] - sigma).abs() < 2e-7 * sigma,
                "{} vs {sigma}",
                r.stress[0]
            );
        }
    }
}
