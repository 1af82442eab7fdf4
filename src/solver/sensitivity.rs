//! Sensitivities of a converged equilibrium: the consistent tangent at that state, factored
//! once, and solves with it (and with its transpose) per seed.
//!
//! ```text
//! equilibrium   R(z; v) = 0,  z = (x free displacements, s slips),  v load values
//! tangent       J = ∂R/∂z = [A + N   B]   A  symmetric: membranes, cables, ties, follower
//!                           [C       D]      pressure's symmetric part (what Newton factors)
//!                                         N  the follower pressure's skew part (zero where the
//!                                            loaded surface is held at its boundary)
//!                                         B, C, D  the slip columns and rows (slip.rs)
//! states        wrinkle states and stick/slip states frozen as converged; no damping, no
//!               artificial prestress (both are tangent-only devices of the iteration); the
//!               wrinkled and slack triangles' tangent-only regularisation Reg (ε·D0) is in the
//!               factored matrix and is taken out again by the fixed point below
//! forward       J dz = g          g = −∂R/∂v · dv  (load sensitivity, [`Solver::load_rhs`])
//! adjoint       Jᵀ λ = w
//! sleeve ties   closed at the equilibrium by their multipliers μ (model/sleeve.rs): the
//!               derivative keeps them closed, the bordered system
//!               [J Gᵀ] [dz]   [g]     G dz = dz_cable − dz_node per tie, Gᵀ dμ its force
//!               [G 0 ] [dμ] = [b]     (+dμ on the cable point, −dμ on the node); b = 0
//!               forward, the seed's multiplier part in the adjoint (the matrix is its own
//!               transpose's pattern); solved by the same Uzawa rounds as the equilibrium,
//!               dμ ← dμ + k G dz, until |G dz − b| ≤ 1e-13 of |dz|: one solve per round,
//!               each round dividing the constraint's error by 1 + C k; dμ is returned at the
//!               multipliers' places of the unknown vector
//! solves        the symmetric part J₀ = J − N by the Schur path of slip.rs:
//!               y0 = A⁻¹ g_x, (D − C Y) s = g_s − C y0, x = y0 − Y s   (Y = A⁻¹ B, once)
//!               transposed: (D − C Y)ᵀ μ = w_s − Yᵀ w_x, λ_x = A⁻¹ (w_x − Cᵀ μ)
//!               then the skew part and the regularisation by the fixed point
//!               z ← J₀⁻¹ (g − (N − Reg) z), the held DOFs' coupling corrected likewise: one back-substitution
//!               per round; the first round's N z is round-off when the surface is held (Hencky),
//!               so a seed costs one back-substitution (plus m for the slips' Schur)
//! ```
//! A switch of a frozen state inside the perturbation is not seen: the derivative is that of
//! the branch the equilibrium is on (one-sided at a switch; see docs/fmu.md, derivatives).
//!
//! # References
//! Golub & Van Loan 2013, §3.2 (block elimination), §3.5.3 (iterative refinement); Haftka &
//! Gürdal 1992, ch. 7 (direct and adjoint sensitivity of static equilibria).

use super::assemble::{self, Membranes, NONE};
use super::core::Solver;
use super::rows::Row;
use super::slip::slip_rows;
use crate::error::{Breakdown, Error};
use crate::model::membrane::{self, Mat9};
use crate::model::sleeve::Contact;
use crate::model::wrinkling::WrinkleState;
use crate::model::wrinkling::REGULARIZATION;
use crate::model::{pressure, ElementKind, LoadModel, Model};
use nalgebra::{DMatrix, DVector};

/// Rounds of the skew fixed point before the solve is declared failed.
const MAX_ROUNDS: usize = 60;
/// Uzawa rounds of the tie-bordered solve before it is declared failed (module docs).
const MAX_TIE_ROUNDS: usize = 400;
/// The tie-bordered solve stops when |G dz − b|∞ ≤ this · max(|dz|∞, |b|∞).
const TIE_TOLERANCE: f64 = 1e-13;
/// The fixed point stops when a round changes the answer by at most this, relative.
const ROUND_TOLERANCE: f64 = 1e-15;
/// |N z|∞ ≤ this · |g|∞: the skew part is round-off (4 ε).
const SKEW_NEGLIGIBLE: f64 = 4.0 * f64::EPSILON;

/// The factored tangent at one converged state (valid until the solver factors again).
pub struct Tangent {
    /// Slip rows with the stick/slip states frozen (committed slips = the state's).
    rows: Vec<Row>,
    /// Y = A⁻¹ B, one column per slip.
    y: Vec<Vec<f64>>,
    /// The Schur complement D − C Y and its transpose, factored.
    schur: Option<nalgebra::LU<f64, nalgebra::Dyn, nalgebra::Dyn>>,
    schur_t: Option<nalgebra::LU<f64, nalgebra::Dyn, nalgebra::Dyn>>,
    /// Skew parts (K_p − K_pᵀ)/2 of the follower-pressure triangles: (nodes, 9×9).
    skew: Vec<([usize; 3], Mat9)>,
    /// The tangent-only regularisation ε·D0 of the wrinkled and slack triangles, as element
    /// matrices vol·Bᵀ ε D0 B (nodes, 9×9): in the factored J₀, not in the true J.
    regularisation: Vec<([usize; 3], Mat9)>,
    /// Equation of every DOF (NONE: held).
    eq: Vec<usize>,
    n: usize,
    m: usize,
    /// Sleeve ties: (cable point, node), penalty, index of the multiplier's first component.
    ties: Vec<([usize; 2], f64, usize)>,
    /// Length of the unknown vector (`Model::unknown_count`).
    unknowns: usize,
}

impl Solver {
    /// Assemble the consistent tangent at the converged state `u` (wrinkle states `wrinkle`,
    /// stick/slip states `slip_states`, both frozen) and factor it once.
    pub fn factor_tangent(
        &mut self,
        model: &Model,
        u: &[f64],
        loads: &[f64],
        wrinkle: &[WrinkleState],
        slip_states: &[Contact],
    ) -> Result<Tangent, Error> {
        if model.volumes > 0 {
            return Err(Error::Unsupported("derivatives of scenes with volume or gas inputs (their pressure unknowns are not in the sensitivity's border yet)".into()));
        }
        let forced: Vec<Option<WrinkleState>> = wrinkle.iter().copied().map(Some).collect();
        let membranes = Membranes {
            forced: Some(&forced),
            prestress_factor: Some(0.0),
            ..Default::default()
        };
        let mut r = vec![0.0; model.dof_count()];
        assemble::assemble_with(
            model,
            &self.pattern,
            u,
            loads,
            &mut r,
            Some(self.linear.values_mut()),
            membranes,
        );
        self.linear.factor()?;
        let (n, m) = (self.pattern.n, model.slips.len());
        let n3 = model.dof_count();
        let rows = slip_rows(model, &self.pattern.eq, u, &u[n3..], slip_states);
        let mut y = Vec::with_capacity(m);
        for col in super::slip::slip_columns(model, &self.pattern.eq, u) {
            let mut v = vec![0.0; n];
            for (e, b) in col {
                v[e] += b;
            }
            self.linear.solve(&mut v)?;
            y.push(v);
        }
        let (schur, schur_t) = if m == 0 {
            (None, None)
        } else {
            let s = schur_matrix(&rows, &y);
            (Some(s.clone().lu()), Some(s.transpose().lu()))
        };
        Ok(Tangent {
            rows,
            y,
            schur,
            schur_t,
            skew: skew_parts(model, u, loads),
            regularisation: regularisation_parts(model, u, wrinkle),
            eq: self.pattern.eq.clone(),
            n,
            m,
            ties: (0..model.ties.len())
                .map(|t| {
                    (
                        model.ties[t].nodes,
                        model.ties[t].k,
                        model.multiplier_index(t),
                    )
                })
                .collect(),
            unknowns: model.unknown_count(),
        })
    }

    /// Solve J dz = g. `g` per unknown of the model (DOFs, then slips; held DOFs ignored);
    /// returns dz per unknown (held DOFs 0).
    pub fn tangent_solve(&mut self, t: &Tangent, g: &[f64]) -> Result<Vec<f64>, Error> {
        self.tie_bordered(t, g, false)
    }

    /// Solve Jᵀ λ = w, `w` and the result per unknown as in [`Solver::tangent_solve`].
    pub fn tangent_solve_transposed(&mut self, t: &Tangent, w: &[f64]) -> Result<Vec<f64>, Error> {
        self.tie_bordered(t, w, true)
    }

    /// The solve with the sleeve ties kept closed (module docs): `g` per unknown, its
    /// multiplier entries the constraint's right-hand side b; returns dz per unknown with dμ at
    /// the multipliers' places. Without ties, the plain fixed point.
    fn tie_bordered(
        &mut self,
        t: &Tangent,
        g: &[f64],
        transposed: bool,
    ) -> Result<Vec<f64>, Error> {
        if t.ties.is_empty() {
            return self.fixed_point(t, g, transposed);
        }
        let at = |v: &[f64], i: usize| v.get(i).copied().unwrap_or(0.0);
        let mut mu = vec![0.0; 3 * t.ties.len()];
        let mut rhs = g.to_vec();
        let mut error = vec![0.0; mu.len()];
        for _ in 0..MAX_TIE_ROUNDS {
            rhs.copy_from_slice(g);
            for (k, &([c, m], _, _)) in t.ties.iter().enumerate() {
                for i in 0..3 {
                    rhs[3 * c + i] -= mu[3 * k + i];
                    rhs[3 * m + i] += mu[3 * k + i];
                }
            }
            let mut z = self.fixed_point(t, &rhs, transposed)?;
            let size = z.iter().fold(0.0f64, |a, v| a.max(v.abs()));
            let mut b_size = 0.0f64;
            for (k, &([c, m], _, index)) in t.ties.iter().enumerate() {
                for i in 0..3 {
                    let b = at(g, index + i);
                    b_size = b_size.max(b.abs());
                    error[3 * k + i] = at(&z, 3 * c + i) - at(&z, 3 * m + i) - b;
                }
            }
            let largest = error.iter().fold(0.0f64, |a, v| a.max(v.abs()));
            if largest <= TIE_TOLERANCE * size.max(b_size) {
                z.resize(t.unknowns, 0.0);
                for (k, &(_, _, index)) in t.ties.iter().enumerate() {
                    z[index..index + 3].copy_from_slice(&mu[3 * k..3 * k + 3]);
                }
                return Ok(z);
            }
            for (k, &(_, penalty, _)) in t.ties.iter().enumerate() {
                for i in 0..3 {
                    mu[3 * k + i] += penalty * error[3 * k + i];
                }
            }
        }
        Err(Breakdown::Unsettled {
            rounds: MAX_TIE_ROUNDS,
        }
        .into())
    }

    /// z ← J₀⁻¹ (g − N z) (transposed: N → Nᵀ = −N) until a round changes nothing.
    fn fixed_point(&mut self, t: &Tangent, g: &[f64], transposed: bool) -> Result<Vec<f64>, Error> {
        let mut z = self.symmetric_solve(t, g, transposed)?;
        if t.skew.is_empty() && t.regularisation.is_empty() {
            return Ok(z);
        }
        for _ in 0..MAX_ROUNDS {
            let nz = skew_product(t, &z, transposed);
            // A skew residual below round-off of g changes z by less than the solve's own
            // backward error: stop without another back-substitution (the clamped Hencky disc:
            // |N z| ~ 1e-16 |g|, so a seed costs one solve).
            let residual = nz.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            let size = g.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            if residual <= SKEW_NEGLIGIBLE * size {
                return Ok(z);
            }
            let rhs: Vec<f64> = g.iter().zip(&nz).map(|(a, b)| a - b).collect();
            let next = self.symmetric_solve(t, &rhs, transposed)?;
            let size = next.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            let change = next
                .iter()
                .zip(&z)
                .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
            z = next;
            if change <= ROUND_TOLERANCE * size {
                return Ok(z);
            }
        }
        Err(Breakdown::Unsettled { rounds: MAX_ROUNDS }.into())
    }

    /// Solve with J₀ (or J₀ᵀ) by the Schur path.
    fn symmetric_solve(
        &mut self,
        t: &Tangent,
        g: &[f64],
        transposed: bool,
    ) -> Result<Vec<f64>, Error> {
        let n3 = t.eq.len();
        let mut x = vec![0.0; t.n];
        for (d, &e) in t.eq.iter().enumerate() {
            if e != NONE {
                x[e] = g[d];
            }
        }
        let gs = &g[n3..n3 + t.m];
        let s = if t.m == 0 {
            self.linear.solve(&mut x)?;
            Vec::new()
        } else if !transposed {
            self.linear.solve(&mut x)?;
            let rhs = DVector::from_iterator(
                t.m,
                t.rows
                    .iter()
                    .zip(gs)
                    .map(|(row, g)| g - row.dx.iter().map(|&(e, c)| c * x[e]).sum::<f64>()),
            );
            let s = solve_lu(t.schur.as_ref(), &rhs)?;
            for (j, yj) in t.y.iter().enumerate() {
                for (e, v) in x.iter_mut().enumerate() {
                    *v -= yj[e] * s[j];
                }
            }
            s.iter().copied().collect()
        } else {
            let rhs = DVector::from_iterator(
                t.m,
                t.y.iter()
                    .zip(gs)
                    .map(|(yj, g)| g - yj.iter().zip(&x).map(|(a, b)| a * b).sum::<f64>()),
            );
            let mu = solve_lu(t.schur_t.as_ref(), &rhs)?;
            for (row, mu) in t.rows.iter().zip(mu.iter()) {
                for &(e, c) in &row.dx {
                    x[e] -= c * mu;
                }
            }
            self.linear.solve(&mut x)?;
            mu.iter().copied().collect()
        };
        let mut z = vec![0.0; n3 + t.m];
        for (d, &e) in t.eq.iter().enumerate() {
            if e != NONE {
                z[d] = x[e];
            }
        }
        z[n3..].copy_from_slice(&s);
        if z.iter().all(|v| v.is_finite()) {
            Ok(z)
        } else {
            Err(Breakdown::NonFinite("the sensitivity (singular tangent)").into())
        }
    }

    /// g = −∂R/∂v_k for a unit change of load channel `k` at `u`, per unknown, and the change
    /// of the held DOFs it prescribes (per DOF). Force loads: the external force per unit
    /// value (follower pressure on the current geometry). Prescribed displacements: the held
    /// DOFs move by 1 and drag the free ones through the tangent's coupling (and the slip rows
    /// through theirs, by a central difference of the rows, which are cheap).
    #[allow(clippy::too_many_arguments)]
    pub fn load_rhs(
        &mut self,
        model: &Model,
        u: &[f64],
        loads: &[f64],
        t: &Tangent,
        wrinkle: &[WrinkleState],
        slip_states: &[Contact],
        k: usize,
    ) -> (Vec<f64>, Vec<f64>) {
        let n3 = model.dof_count();
        let mut g = vec![0.0; model.unknown_count()];
        let mut held = vec![0.0; n3];
        match &model.loads[k] {
            LoadModel::PointForce(dofs) => {
                for &(d, f) in dofs {
                    g[d] += f;
                }
            }
            LoadModel::Pressure {
                triangles,
                follower,
            } => {
                for &e in triangles {
                    let (f, _) =
                        assemble::pressure_contribution(model, e, u, 1.0, *follower, false);
                    for &i in &model.triangles[e].nodes {
                        for c in 0..3 {
                            g[3 * i + c] += f[c];
                        }
                    }
                }
            }
            // Refused by factor_tangent: no tangent exists for these.
            LoadModel::Volume { .. } => {}
            LoadModel::Displacement(prescribed) => {
                // d(prescribed displacement)/d(value): exact for a component or a direction
                // (linear in the value), a central difference for a rotation (smooth).
                let value = loads[k];
                let h = 1e-6 * value.abs().max(1.0);
                let (mut plus, mut minus) = (vec![0.0; n3], vec![0.0; n3]);
                prescribed.add(&model.reference, value + h, &mut plus);
                prescribed.add(&model.reference, value - h, &mut minus);
                for &d in &prescribed.dofs {
                    held[d] = (plus[d] - minus[d]) / (2.0 * h);
                }
                let mut coupling = vec![0.0; n3];
                let forced: Vec<Option<WrinkleState>> = wrinkle.iter().copied().map(Some).collect();
                let membranes = Membranes {
                    forced: Some(&forced),
                    prestress_factor: Some(0.0),
                    held_step: Some((&held, &mut coupling)),
                    ..Default::default()
                };
                let mut r = vec![0.0; n3];
                assemble::assemble_with(model, &self.pattern, u, loads, &mut r, None, membranes);
                // The true coupling: the element tangents' (regularised where wrinkled or
                // slack, as factored) plus the follower pressure's skew part minus that
                // regularisation.
                let skew = skew_product_dofs(&t.skew, &held, false);
                let reg = skew_product_dofs(&t.regularisation, &held, false);
                for d in 0..n3 {
                    g[d] = -(coupling[d] + skew[d] - reg[d]);
                }
                if t.m > 0 {
                    let dr = slip_rows_derivative(model, &self.pattern.eq, u, &held, slip_states);
                    for (j, v) in dr.iter().enumerate() {
                        g[n3 + j] = -v;
                    }
                }
                // A tie whose node is prescribed to move stays closed: G dz_free = −G held.
                for &([c, m], _, index) in &t.ties {
                    for i in 0..3 {
                        g[index + i] = -(held[3 * c + i] - held[3 * m + i]);
                    }
                }
            }
        }
        (g, held)
    }
}

impl Solver {
    /// ∂R/∂x · dx on every DOF row (held rows included) for a change `dx` of the DOFs (held
    /// ones included), with the states of the tangent `t` frozen: the element tangents as
    /// factored (one assembly pass that multiplies instead of scattering), plus the follower
    /// pressure's skew part, minus the wrinkled and slack triangles' regularisation. The
    /// reactions' exact change along a solution (`engine/derivatives.rs`). `dx` per unknown:
    /// its slip entries change the sliding segments' unstretched lengths (the slip columns B,
    /// here on every DOF row, held ones included).
    pub fn tangent_product(
        &mut self,
        model: &Model,
        u: &[f64],
        loads: &[f64],
        t: &Tangent,
        wrinkle: &[WrinkleState],
        dx: &[f64],
    ) -> Vec<f64> {
        let n3 = model.dof_count();
        let dx_all = dx;
        let (dx, ds) = dx.split_at(n3);
        let mut product = vec![0.0; n3];
        let forced: Vec<Option<WrinkleState>> = wrinkle.iter().copied().map(Some).collect();
        let membranes = Membranes {
            forced: Some(&forced),
            prestress_factor: Some(0.0),
            held_step: Some((dx, &mut product)),
            ..Default::default()
        };
        let mut r = vec![0.0; n3];
        assemble::assemble_with(model, &self.pattern, u, loads, &mut r, None, membranes);
        let skew = skew_product_dofs(&t.skew, dx, false);
        let reg = skew_product_dofs(&t.regularisation, dx, false);
        for d in 0..n3 {
            product[d] += skew[d] - reg[d];
        }
        if t.m > 0 {
            let every_dof: Vec<usize> = (0..n3).collect();
            let columns = super::slip::slip_columns(model, &every_dof, u);
            for (column, &dsj) in columns.iter().zip(ds) {
                for &(d, b) in column {
                    product[d] += b * dsj;
                }
            }
        }
        // The ties' multipliers: +dμ on the cable point, −dμ on the node.
        for &([c, m], _, index) in &t.ties {
            for i in 0..3 {
                let dm = dx_all.get(index + i).copied().unwrap_or(0.0);
                product[3 * c + i] += dm;
                product[3 * m + i] -= dm;
            }
        }
        product
    }
}

/// D − C Y.
fn schur_matrix(rows: &[Row], y: &[Vec<f64>]) -> DMatrix<f64> {
    let m = rows.len();
    let mut s = DMatrix::<f64>::zeros(m, m);
    for (i, row) in rows.iter().enumerate() {
        for &(j, d) in &row.ds {
            s[(i, j)] += d;
        }
        for (j, yj) in y.iter().enumerate() {
            s[(i, j)] -= row.dx.iter().map(|&(e, c)| c * yj[e]).sum::<f64>();
        }
    }
    s
}

fn solve_lu(
    lu: Option<&nalgebra::LU<f64, nalgebra::Dyn, nalgebra::Dyn>>,
    rhs: &DVector<f64>,
) -> Result<DVector<f64>, Error> {
    lu.and_then(|lu| lu.solve(rhs))
        .ok_or(Error::LinearAlgebra(Breakdown::Singular(
            "the slip block of the tangent (no stiffness against some slip, to first order)",
        )))
}

/// (K_p − K_pᵀ)/2 of every follower-pressure triangle under the loads (summed over the
/// channels that load it).
fn skew_parts(model: &Model, u: &[f64], loads: &[f64]) -> Vec<([usize; 3], Mat9)> {
    let mut out = Vec::new();
    for (load, &value) in model.loads.iter().zip(loads) {
        let LoadModel::Pressure {
            triangles,
            follower: true,
        } = load
        else {
            continue;
        };
        if value == 0.0 {
            continue;
        }
        for &e in triangles {
            let nodes = model.triangles[e].nodes;
            let x = nodes.map(|i| model.position(u, i));
            let k = pressure::follower_stiffness(value, &x);
            out.push((nodes, (k - k.transpose()) * 0.5));
        }
    }
    out
}

/// The tangent-only parts that the factored tangent holds and the true one lacks, per element
/// kind: the regularisation ε·D0 of the wrinkled and slack triangles.
fn regularisation_parts(
    model: &Model,
    u: &[f64],
    wrinkle: &[WrinkleState],
) -> Vec<([usize; 3], Mat9)> {
    let mut out = Vec::new();
    for kind in ElementKind::ALL {
        match kind {
            ElementKind::Membrane => triangle_regularisation(model, u, wrinkle, &mut out),
            // The exact tangent: a slack segment has none (`cable::segment`), a closed
            // segment's link and a tie are linear springs.
            ElementKind::Cable | ElementKind::Tie => {}
        }
    }
    out
}

/// The regularisation ε·D0 that the wrinkled and slack triangles add to the factored tangent
/// (`wrinkling::REGULARIZATION`, tangent only): vol·Bᵀ ε D0 B per triangle, B the variation of
/// the Green-Lagrange strain at the current deformation (the material part of
/// `membrane::triangle`'s tangent).
fn triangle_regularisation(
    model: &Model,
    u: &[f64],
    wrinkle: &[WrinkleState],
    out: &mut Vec<([usize; 3], Mat9)>,
) {
    for (t, state) in model.triangles.iter().zip(wrinkle) {
        if !t.material.wrinkling || t.material.residual > 0.0 || *state == WrinkleState::Taut {
            continue;
        }
        let r = &t.reference;
        let x = t.nodes.map(|i| model.position(u, i));
        let f = membrane::deformation_gradient(r, &x);
        let (f1, f2) = (f.column(0).into_owned(), f.column(1).into_owned());
        let mut b = nalgebra::SMatrix::<f64, 3, 9>::zeros();
        for a in 0..3 {
            let g = r.grad[a];
            b.fixed_view_mut::<1, 3>(0, 3 * a)
                .copy_from(&(f1 * g[0]).transpose());
            b.fixed_view_mut::<1, 3>(1, 3 * a)
                .copy_from(&(f2 * g[1]).transpose());
            b.fixed_view_mut::<1, 3>(2, 3 * a)
                .copy_from(&(f1 * g[1] + f2 * g[0]).transpose());
        }
        let d = t.material.law.small_strain() * REGULARIZATION;
        let vol = r.area * t.material.thickness;
        out.push((t.nodes, b.transpose() * d * b * vol));
    }
}

/// (N − Reg) z on the free DOFs (per unknown; transposed: Nᵀ z = −N z, Reg symmetric): the
/// part of the true tangent J = J₀ + N − Reg that the factored J₀ lacks or has too much of.
fn skew_product(t: &Tangent, z: &[f64], transposed: bool) -> Vec<f64> {
    let n3 = t.eq.len();
    let mut free = z[..n3].to_vec();
    for (d, &e) in t.eq.iter().enumerate() {
        if e == NONE {
            free[d] = 0.0;
        }
    }
    let mut out = skew_product_dofs(&t.skew, &free, transposed);
    let reg = skew_product_dofs(&t.regularisation, &free, false);
    for (o, r) in out.iter_mut().zip(&reg) {
        *o -= r;
    }
    for (d, &e) in t.eq.iter().enumerate() {
        if e == NONE {
            out[d] = 0.0;
        }
    }
    out.resize(z.len(), 0.0);
    out
}

/// Σ skew_e · v_e over the triangles, per DOF.
fn skew_product_dofs(skew: &[([usize; 3], Mat9)], v: &[f64], transposed: bool) -> Vec<f64> {
    let sign = if transposed { -1.0 } else { 1.0 };
    let mut out = vec![0.0; v.len()];
    for (nodes, k) in skew {
        let dof = |a: usize| 3 * nodes[a / 3] + a % 3;
        for b in 0..9 {
            let vb = v[dof(b)];
            if vb == 0.0 {
                continue;
            }
            for a in 0..9 {
                out[dof(a)] += sign * k[(a, b)] * vb;
            }
        }
    }
    out
}

/// ∂r/∂x · dx of the slip rows for a change `dx` of DOFs (any, held included), by a central
/// difference of the rows with their states frozen.
fn slip_rows_derivative(
    model: &Model,
    eq: &[usize],
    u: &[f64],
    dx: &[f64],
    slip_states: &[Contact],
) -> Vec<f64> {
    let n3 = model.dof_count();
    let h = 1e-6 * model.length_scale / dx.iter().fold(0.0f64, |m, v| m.max(v.abs())).max(1e-300);
    let at = |sign: f64| {
        let mut v = u.to_vec();
        for (a, d) in v.iter_mut().zip(dx) {
            *a += sign * h * d;
        }
        slip_rows(model, eq, &v, &u[n3..], slip_states)
    };
    let (plus, minus) = (at(1.0), at(-1.0));
    plus.iter()
        .zip(&minus)
        .map(|(a, b)| (a.r - b.r) / (2.0 * h))
        .collect()
}

/// The slip residuals r at `u` with the stick/slip states given and the committed slips the
/// state's own (a stuck point's row is then 0).
pub fn slip_residuals(model: &Model, u: &[f64], slip_states: &[Contact]) -> Vec<f64> {
    let n3 = model.dof_count();
    let eq = vec![NONE; n3];
    slip_rows(model, &eq, u, &u[n3..], slip_states)
        .iter()
        .map(|r| r.r)
        .collect()
}
