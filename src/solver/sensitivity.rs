//! Sensitivities of a converged equilibrium: the consistent tangent at that state, factored
//! once, and solves with it (and with its transpose) per seed.
//!
//! ```text
//! equilibrium   R(z; v) = 0,  z = (x free displacements, s slips),  v load values
//! tangent       J = ∂R/∂z = [A + N − Reg   B]   A  symmetric as Newton assembles it: membranes,
//!                           [C             D]      cables, ties, follower pressure's symmetric
//!                                                  part, and the wrinkled and slack triangles'
//!                                                  tangent-only regularisation Reg (ε·D0)
//!                                               N  the follower pressure's skew part (zero where
//!                                                  the loaded surface is held at its boundary)
//!                                               B, C, D  the slip columns and rows (slip.rs),
//!                                                  then one per volume or gas input: its
//!                                                  pressure's column −f_p and its row, the
//!                                                  volume or the gas law (volume.rs)
//! states        wrinkle states and stick/slip states frozen as converged; no damping, no
//!               artificial prestress (both are tangent-only devices of the iteration)
//! time step     the end state of a step of time integration (one sub-step, dynamic.rs):
//!               A gains the step's K_d = [(1−αm)/(βΔt²) M + (1−αf)γ/(βΔt) C]/(1−αf) on the
//!               free DOFs (symmetric; the start state held), so every solve below is that
//!               of R + g = 0 at the step's end with respect to its end inputs
//! forward       J dz = g          g = −∂R/∂v · dv  (load sensitivity, [`Solver::load_rhs`])
//! adjoint       Jᵀ λ = w
//! sleeve ties   closed at the equilibrium by their multipliers μ (model/sleeve.rs): the
//!               derivative keeps them closed, the bordered system
//!               [J Gᵀ] [dz]   [g]     G dz = dz_cable − dz_node per tie, Gᵀ dμ its force
//!               [G 0 ] [dμ] = [b]     (+dμ on the cable point, −dμ on the node); b = 0
//!               forward, the seed's multiplier part in the adjoint (the matrix is its own
//!               transpose's pattern); solved by the same Uzawa rounds as the equilibrium (each round's
//!               inner solve the one below),
//!               dμ ← dμ + k G dz, until |G dz − b| ≤ 1e-13 of |dz|: one solve per round,
//!               each round dividing the constraint's error by 1 + C k; dμ is returned at the
//!               multipliers' places of the unknown vector
//! solve         GMRES on the true J (or Jᵀ), right-preconditioned by M = J − N + Reg, the
//!               matrix Newton factors (LDLT of A, the slips by the Schur path of slip.rs:
//!               y0 = A⁻¹ g_x, (D − C Y) s = g_s − C y0, x = y0 − Y s, Y = A⁻¹ B once;
//!               transposed: (D − C Y)ᵀ μ = w_s − Yᵀ w_x, λ_x = A⁻¹ (w_x − Cᵀ μ)), its rows
//!               equilibrated node by node, D = 1 / (the largest row sum of |J| among the
//!               node's rows; a slip's own) (the operator D J M⁻¹ D⁻¹, similar to J M⁻¹).
//!               z0 = M⁻¹ g is accepted when its backward error
//!                   ω = ‖D (g − J z)‖∞ / (‖z‖∞ + ‖D g‖∞) ≤ BACKWARD_ERROR
//!               (a taut scene without follower pressure: one back-substitution and one
//!               product, as before); else GMRES cycles from it, each ended on the same test of
//!               the true residual. GMRES needs no contraction: it minimises the residual over
//!               its Krylov space (never increases it) and ends for any nonsingular J, quickly
//!               when the spectrum of J M⁻¹ = I − (Reg − N + the LDLT's pivot replacements) M⁻¹
//!               clusters at 1 (measured: 0 to 4 iterations per seed on the shipped scenes at
//!               the operating points of tests/fmi/derivatives.rs, up to 14 at the wrinkled
//!               films with slack triangles of tests/fmi/derivative_states.rs)
//! fallback      a sparse LU (partial pivoting) of the true J, formed at the first seed that
//!               GMRES does not settle within its budget (CYCLES × KRYLOV iterations) and kept
//!               with the tangent, with iterative refinement on the same test
//! singular      the one error, Singular (named): J singular to working precision in a
//!               direction the seed moves, a mechanism at this state (a force on a fully slack
//!               sheet): no solve reaches the backward error (zero pivots of the LU), or the
//!               answer is larger than MAX_AMPLIFICATION times D g (J near singular along it)
//! ```
//! A J that is singular only in directions no seed moves (the free out-of-plane DOFs of a
//! flat sheet held by nothing across its wrinkles, a node among slack triangles only) is solved
//! by GMRES: the residual is met on the rest, and the answer's component along those
//! directions is not determined by J (it is the preconditioner's, through Newton's
//! regularisation): an output that reads only such a direction has no derivative. The LU
//! cannot solve such a J (zero pivots): where GMRES has not settled, it is reported singular.
//!
//! The fixed point z ← M⁻¹ (g − (N − Reg) z) that this replaces converged only where the
//! spectral radius of M⁻¹ (N − Reg) is below 1 and stopped only at a change of 1e-15 relative,
//! below what the round-off of an ill-conditioned M lets the rounds reach: "did not settle in 60
//! rounds" at wrinkled states (WrinkledShear at a shear of 3 mm, every seed) and in the
//! transposed solve of FourPointSail's `max_cable_tension` at 150 Pa (rounds changing the
//! answer by 2.6e-15 for ever).
//!
//! A switch of a frozen state inside the perturbation is not seen: the derivative is that of
//! the branch the equilibrium is on (one-sided at a switch; see docs/fmu.md, derivatives).
//!
//! # References
//! Saad & Schultz 1986 (GMRES); Saad 2003, §6.5 and §9.3 (GMRES, right preconditioning);
//! Higham 2002, §7.1 (normwise backward error), §12.1 (iterative refinement); Golub & Van Loan
//! 2013, §3.2 (block elimination); Haftka & Gürdal 1992, ch. 7 (direct and adjoint sensitivity
//! of static equilibria).

use super::assemble::{self, Membranes, NONE};
use super::core::Solver;
use super::rows::Row;
use super::slip::slip_rows;
use crate::error::{Breakdown, Error};
use crate::memory;
use crate::model::membrane::{self, Mat9};
use crate::model::sleeve::Contact;
use crate::model::wrinkling::WrinkleState;
use crate::model::wrinkling::REGULARIZATION;
use crate::model::{pressure, ElementKind, LoadModel, Model};
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::sparse::linalg::lu::{factorize_symbolic_lu, LuRef, NumericLu, SymbolicLu};
use faer::sparse::linalg::LuError;
use faer::sparse::{SparseColMat, SymbolicSparseColMat, Triplet};
use faer::{Conj, MatMut, Par};
use nalgebra::{DMatrix, DVector};
use std::cell::{Cell, OnceCell};

/// Uzawa rounds of the tie-bordered solve before it is declared failed (module docs).
const MAX_TIE_ROUNDS: usize = 400;
/// The tie-bordered solve stops when |G dz − b|∞ ≤ this · max(|dz|∞, |b|∞).
const TIE_TOLERANCE: f64 = 1e-13;
/// Normwise backward error of the equilibrated system at which a solve is accepted (module
/// docs).
const BACKWARD_ERROR: f64 = 1e-14;
/// Largest accepted ‖z‖∞ / ‖D g‖∞ (the answer against the seed's load over its nodes'
/// stiffness, a lower bound of ‖(D J)⁻¹‖∞): beyond it a relative change of ε in J's entries may
/// move the answer by more than 1 %, J is singular to working precision in a direction the
/// seed moves (module docs).
const MAX_AMPLIFICATION: f64 = 1e-2 / f64::EPSILON;
/// Krylov dimension of one GMRES cycle (vectors of the equations' length kept).
const KRYLOV: usize = 30;
/// GMRES cycles before the LU.
const CYCLES: usize = 3;
/// Steps of iterative refinement with the LU.
const REFINEMENTS: usize = 3;
/// What a singular tangent names.
const MECHANISM: &str = "the consistent tangent at this state (a mechanism that the seed moves: the equilibrium has no unique derivative along it)";

/// The factored tangent at one converged state (valid until the solver factors again).
pub struct Tangent {
    /// Slip rows with the stick/slip states frozen (committed slips = the state's): C, D.
    rows: Vec<Row>,
    /// The slip columns B, one per slip: (equation, value).
    columns: Vec<Vec<(usize, f64)>>,
    /// Y = A⁻¹ B, one column per slip.
    y: Vec<Vec<f64>>,
    /// The Schur complement D − C Y and its transpose, factored.
    schur: Option<nalgebra::LU<f64, nalgebra::Dyn, nalgebra::Dyn>>,
    schur_t: Option<nalgebra::LU<f64, nalgebra::Dyn, nalgebra::Dyn>>,
    /// Whether the preconditioner M exists (Newton's LDLT of A succeeded).
    factored: bool,
    /// A as assembled (upper triangle, CSC over the equations).
    upper: SparseColMat<usize, f64>,
    /// Skew parts (K_p − K_pᵀ)/2 of the follower-pressure triangles: (nodes, 9×9).
    skew: Vec<([usize; 3], Mat9)>,
    /// The tangent-only regularisation ε·D0 of the wrinkled and slack triangles, as element
    /// matrices vol·Bᵀ ε D0 B (nodes, 9×9): in the factored J₀, not in the true J.
    regularisation: Vec<([usize; 3], Mat9)>,
    /// Equilibration of J and of Jᵀ: 1 / (largest row sum of |J| among the rows of the
    /// equation's node), per equation and slip.
    scale: [Vec<f64>; 2],
    /// The LU of the true J, formed at the first solve that needs it.
    lu: OnceCell<Result<Lu, Error>>,
    /// Every solve by the LU alone ([`Tangent::set_direct`]).
    direct: bool,
    counts: Cell<SolveCounts>,
    /// Equation of every DOF (NONE: held).
    eq: Vec<usize>,
    n: usize,
    m: usize,
    /// Sleeve ties: (cable point, node), penalty, index of the multiplier's first component.
    ties: Vec<([usize; 2], f64, usize)>,
    /// Length of the unknown vector (`Model::unknown_count`).
    unknowns: usize,
}

/// What the solves with one tangent did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SolveCounts {
    /// Solves (forward and transposed).
    pub solves: usize,
    /// GMRES iterations over them (a preconditioner solve and a product each).
    pub iterations: usize,
    /// Solves that ended with the LU.
    pub direct: usize,
}

impl Tangent {
    /// Solve by the LU of the true tangent alone (`true`), or GMRES first (`false`, the
    /// default): the check of one against the other.
    pub fn set_direct(&mut self, direct: bool) {
        self.direct = direct;
    }

    /// What the solves so far did.
    pub fn counts(&self) -> SolveCounts {
        self.counts.get()
    }

    fn count(&self, f: impl FnOnce(&mut SolveCounts)) {
        let mut c = self.counts.get();
        f(&mut c);
        self.counts.set(c);
    }
}

/// A sparse LU of the true tangent.
struct Lu {
    symbolic: SymbolicLu<usize>,
    numeric: NumericLu<usize, f64>,
}

impl Solver {
    /// The true tangent at the converged state `u` into the linear solver's values: the wrinkle
    /// states `wrinkle` frozen, no artificial prestress (the regularisation of wrinkled and
    /// slack triangles is still in; `remove_regularisation` takes it out). Shared by the
    /// sensitivities and the natural frequencies (modes.rs).
    pub(super) fn assemble_true_tangent(
        &mut self,
        model: &Model,
        u: &[f64],
        loads: &[f64],
        wrinkle: &[WrinkleState],
    ) {
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
    }

    /// Assemble the consistent tangent at the converged state `u` (wrinkle states `wrinkle`,
    /// stick/slip states `slip_states`, both frozen) and factor it once. `inertia`: values on
    /// the tangent's pattern added to it (a time step's K_d, `Solver::step_stiffness`: the
    /// tangent of the step's end state, module docs), or empty (a static equilibrium).
    pub fn factor_tangent(
        &mut self,
        model: &Model,
        u: &[f64],
        loads: &[f64],
        wrinkle: &[WrinkleState],
        slip_states: &[Contact],
        inertia: &[f64],
    ) -> Result<Tangent, Error> {
        self.assemble_true_tangent(model, u, loads, wrinkle);
        if !inertia.is_empty() {
            let values = self.linear.values_mut();
            if values.len() != inertia.len() {
                return Err(Error::Unsupported(format!(
                    "internal: the step's inertia has {} values on a tangent pattern of {}",
                    inertia.len(),
                    values.len()
                )));
            }
            values.iter_mut().zip(inertia).for_each(|(a, k)| *a += k);
        }
        let upper = {
            let a = self.linear.matrix();
            let what = "the sensitivity's copy of the tangent";
            let symbolic = SymbolicSparseColMat::new_checked(
                a.nrows(),
                a.ncols(),
                memory::copy(a.symbolic().col_ptr(), what)?,
                None,
                memory::copy(a.symbolic().row_idx(), what)?,
            );
            SparseColMat::new(symbolic, memory::copy(a.val(), what)?)
        };
        // Without M every solve goes to the LU.
        let mut factored = self.linear.factor().is_ok();
        // The border: the slips, then one pressure per volume or gas input (volume.rs), in the
        // unknowns' order.
        let (n, m) = (self.pattern.n, model.slips.len() + model.volumes);
        let n3 = model.dof_count();
        let mut rows = slip_rows(model, &self.pattern.eq, u, &u[n3..], slip_states);
        rows.extend(super::volume::rows(model, &self.pattern.eq, u, loads));
        let mut columns = super::slip::slip_columns(model, &self.pattern.eq, u);
        columns.extend(super::volume::columns(model, &self.pattern.eq, u));
        let mut y = Vec::with_capacity(m);
        if factored {
            for col in &columns {
                let mut v = memory::zeros(n, "the sensitivity's slip columns")?;
                for &(e, b) in col {
                    v[e] += b;
                }
                if self.linear.solve(&mut v).is_err() {
                    factored = false;
                    break;
                }
                y.push(v);
            }
        }
        let (schur, schur_t) = if m == 0 || !factored {
            (None, None)
        } else {
            let s = schur_matrix(&rows, &y);
            (Some(s.clone().lu()), Some(s.transpose().lu()))
        };
        let mut t = Tangent {
            rows,
            columns,
            y,
            schur,
            schur_t,
            factored,
            upper,
            skew: skew_parts(model, u, loads),
            regularisation: regularisation_parts(model, u, wrinkle),
            scale: [Vec::new(), Vec::new()],
            lu: OnceCell::new(),
            direct: false,
            counts: Cell::new(SolveCounts::default()),
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
        };
        // The equilibration by node (a node's three rows share one factor, as in Newton's
        // node-scaled factorization: a row far softer than its node's others, the out-of-plane
        // row of a flat unstressed sheet, stays as soft as it is), every slip its own.
        let nodes = n3 / 3;
        let mut group = memory::zeros(n + m, "the sensitivity's work vectors")?;
        for (d, &e) in t.eq.iter().enumerate() {
            if e != NONE {
                group[e] = d / 3;
            }
        }
        for (j, g) in group[n..].iter_mut().enumerate() {
            *g = nodes + j;
        }
        let ones = memory::filled(n + m, 1.0, "the sensitivity's work vectors")?;
        let mut largest = memory::zeros(nodes + m, "the sensitivity's work vectors")?;
        for transposed in [false, true] {
            let mut sums = memory::zeros(n + m, "the sensitivity's work vectors")?;
            product(&t, &ones, &mut sums, transposed, true);
            largest.fill(0.0);
            for (&g, &v) in group.iter().zip(&sums) {
                largest[g] = f64::max(largest[g], v);
            }
            // A node with no stiffness at all takes the stiffest node's scale.
            let stiffest = largest.iter().copied().fold(0.0, f64::max);
            for (v, &g) in sums.iter_mut().zip(&group) {
                let l = largest[g];
                let l = if l > 0.0 && l.is_finite() {
                    l
                } else {
                    stiffest
                };
                *v = if l > 0.0 && l.is_finite() {
                    1.0 / l
                } else {
                    1.0
                };
            }
            t.scale[transposed as usize] = sums;
        }
        Ok(t)
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
    /// the multipliers' places. Without ties, the plain solve.
    fn tie_bordered(
        &mut self,
        t: &Tangent,
        g: &[f64],
        transposed: bool,
    ) -> Result<Vec<f64>, Error> {
        if t.ties.is_empty() {
            return self.solve_true(t, g, transposed);
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
            let mut z = self.solve_true(t, &rhs, transposed)?;
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

    /// J z = g (transposed: Jᵀ z = g) per unknown: to the equations, solved, back.
    fn solve_true(&mut self, t: &Tangent, g: &[f64], transposed: bool) -> Result<Vec<f64>, Error> {
        let n3 = t.eq.len();
        let mut b = memory::zeros(t.n + t.m, "the sensitivity's work vectors")?;
        for (d, &e) in t.eq.iter().enumerate() {
            if e != NONE {
                b[e] = g[d];
            }
        }
        b[t.n..].copy_from_slice(&g[n3..n3 + t.m]);
        let x = self.krylov(t, &b, transposed)?;
        let mut z = memory::zeros(n3 + t.m, "the sensitivity's work vectors")?;
        for (d, &e) in t.eq.iter().enumerate() {
            if e != NONE {
                z[d] = x[e];
            }
        }
        z[n3..].copy_from_slice(&x[t.n..]);
        Ok(z)
    }

    /// GMRES on J (Jᵀ) right-preconditioned by M (Mᵀ), rows equilibrated, from z0 = M⁻¹ b;
    /// the LU when its cycles do not reach [`BACKWARD_ERROR`] (module docs).
    fn krylov(&mut self, t: &Tangent, b: &[f64], transposed: bool) -> Result<Vec<f64>, Error> {
        let size = b.len();
        let d = &t.scale[transposed as usize];
        let db = b
            .iter()
            .zip(d)
            .fold(0.0f64, |a, (v, s)| a.max((v * s).abs()));
        if db == 0.0 {
            return memory::zeros(size, "the sensitivity's work vectors").map_err(Into::into);
        }
        t.count(|c| c.solves += 1);
        let mut x = memory::copy(b, "the sensitivity's work vectors")?;
        if t.direct || !t.factored || self.precondition(t, &mut x, transposed).is_err() {
            return self.lu_solve(t, b, db, transposed);
        }
        let mut r = memory::zeros(size, "the sensitivity's work vectors")?;
        let mut w = memory::zeros(size, "the sensitivity's work vectors")?;
        let mut basis: Vec<Vec<f64>> = Vec::new();
        for cycle in 0..=CYCLES {
            let omega = backward_error(t, b, &x, &mut r, transposed);
            if omega <= BACKWARD_ERROR {
                return accept(x, db);
            }
            if cycle == CYCLES || !omega.is_finite() {
                break;
            }
            let xnorm = x.iter().fold(0.0f64, |a, v| a.max(v.abs()));
            // ‖·‖∞ ≤ ‖·‖₂: the estimate below the target puts ω below it (up to round-off,
            // which the true residual above checks at the next cycle).
            let target = BACKWARD_ERROR * (xnorm + db);
            let beta = norm2(&r);
            basis.truncate(0);
            if basis.try_reserve_exact(KRYLOV + 1).is_err() {
                return Err(memory::OutOfMemory {
                    what: "the sensitivity's Krylov basis",
                    bytes: ((KRYLOV + 1) * size * 8) as u64,
                }
                .into());
            }
            let mut v0 = memory::copy(&r, "the sensitivity's Krylov basis")?;
            v0.iter_mut().for_each(|v| *v /= beta);
            basis.push(v0);
            // Columns of the Hessenberg matrix rotated to R, the rotations, and βe₁ rotated.
            let mut hessenberg: Vec<Vec<f64>> = Vec::new();
            let mut rotations: Vec<(f64, f64)> = Vec::new();
            let mut rhs = vec![beta];
            for k in 0..KRYLOV {
                // D J M⁻¹ D⁻¹: similar to J M⁻¹, whose spectrum clusters at 1.
                w.iter_mut()
                    .zip(&basis[k])
                    .zip(d)
                    .for_each(|((a, v), s)| *a = v / s);
                self.precondition(t, &mut w, transposed)?;
                t.count(|c| c.iterations += 1);
                let mut jw = memory::zeros(size, "the sensitivity's Krylov basis")?;
                product(t, &w, &mut jw, transposed, false);
                jw.iter_mut().zip(d).for_each(|(v, s)| *v *= s);
                // Modified Gram-Schmidt, twice (the second pass restores orthogonality lost
                // to cancellation).
                let mut column = vec![0.0; k + 2];
                for _ in 0..2 {
                    for (i, v) in basis.iter().enumerate() {
                        let c = dot(&jw, v);
                        column[i] += c;
                        jw.iter_mut().zip(v).for_each(|(a, b)| *a -= c * b);
                    }
                }
                let h = norm2(&jw);
                column[k + 1] = h;
                for (i, &(c, s)) in rotations.iter().enumerate() {
                    let (a, b) = (column[i], column[i + 1]);
                    column[i] = c * a + s * b;
                    column[i + 1] = -s * a + c * b;
                }
                let (a, b) = (column[k], column[k + 1]);
                // Not f64::hypot: it needs glibc 2.35, above the FMU baseline. Scaled by the
                // larger magnitude so the squares neither overflow nor underflow.
                let big = a.abs().max(b.abs());
                let radius = if big == 0.0 {
                    0.0
                } else {
                    big * ((a / big).powi(2) + (b / big).powi(2)).sqrt()
                };
                let (c, s) = if radius == 0.0 {
                    (1.0, 0.0)
                } else {
                    (a / radius, b / radius)
                };
                column[k] = radius;
                column[k + 1] = 0.0;
                rotations.push((c, s));
                rhs.push(-s * rhs[k]);
                rhs[k] *= c;
                hessenberg.push(column);
                if rhs[k + 1].abs() <= target || !(h > 0.0 && h.is_finite()) {
                    break;
                }
                jw.iter_mut().for_each(|v| *v /= h);
                basis.push(jw);
            }
            // y = R⁻¹ (rotated βe₁); x += M⁻¹ V y.
            let k = hessenberg.len();
            let mut coef = vec![0.0; k];
            for i in (0..k).rev() {
                let sum: f64 = (i + 1..k).map(|j| hessenberg[j][i] * coef[j]).sum();
                coef[i] = (rhs[i] - sum) / hessenberg[i][i];
            }
            if !coef.iter().all(|c| c.is_finite()) {
                break;
            }
            w.fill(0.0);
            for (v, c) in basis.iter().zip(&coef) {
                w.iter_mut().zip(v).for_each(|(a, b)| *a += c * b);
            }
            w.iter_mut().zip(d).for_each(|(a, s)| *a /= s);
            self.precondition(t, &mut w, transposed)?;
            x.iter_mut().zip(&w).for_each(|(a, b)| *a += b);
        }
        drop(basis);
        self.lu_solve(t, b, db, transposed)
    }

    /// M⁻¹ v (Mᵀ⁻¹ v) in place, over the equations and slips: the LDLT of A and the slips by
    /// the Schur path (module docs).
    fn precondition(&mut self, t: &Tangent, v: &mut [f64], transposed: bool) -> Result<(), Error> {
        let (x, s) = v.split_at_mut(t.n);
        if t.m == 0 {
            self.linear.solve(x)?;
        } else if !transposed {
            self.linear.solve(x)?;
            let rhs = DVector::from_iterator(
                t.m,
                t.rows
                    .iter()
                    .zip(s.iter())
                    .map(|(row, g)| g - row.dx.iter().map(|&(e, c)| c * x[e]).sum::<f64>()),
            );
            let sol = solve_lu(t.schur.as_ref(), &rhs)?;
            for (j, yj) in t.y.iter().enumerate() {
                for (e, v) in x.iter_mut().enumerate() {
                    *v -= yj[e] * sol[j];
                }
            }
            s.copy_from_slice(sol.as_slice());
        } else {
            let rhs = DVector::from_iterator(
                t.m,
                t.y.iter()
                    .zip(s.iter())
                    .map(|(yj, g)| g - yj.iter().zip(x.iter()).map(|(a, b)| a * b).sum::<f64>()),
            );
            let mu = solve_lu(t.schur_t.as_ref(), &rhs)?;
            for (row, mu) in t.rows.iter().zip(mu.iter()) {
                for &(e, c) in &row.dx {
                    x[e] -= c * mu;
                }
            }
            self.linear.solve(x)?;
            s.copy_from_slice(mu.as_slice());
        }
        if v.iter().all(|v| v.is_finite()) {
            Ok(())
        } else {
            Err(Breakdown::NonFinite("the sensitivity's preconditioner").into())
        }
    }

    /// The LU of the true J, refined to [`BACKWARD_ERROR`]; Singular when it does not get
    /// there (module docs).
    fn lu_solve(
        &mut self,
        t: &Tangent,
        b: &[f64],
        db: f64,
        transposed: bool,
    ) -> Result<Vec<f64>, Error> {
        t.count(|c| c.direct += 1);
        let lu =
            t.lu.get_or_init(|| true_lu(t))
                .as_ref()
                .map_err(Clone::clone)?;
        let size = b.len();
        let mut x = memory::copy(b, "the sensitivity's work vectors")?;
        lu.solve(&mut x, transposed)?;
        let mut r = memory::zeros(size, "the sensitivity's work vectors")?;
        for _ in 0..=REFINEMENTS {
            if !x.iter().all(|v| v.is_finite()) {
                break;
            }
            let omega = backward_error(t, b, &x, &mut r, transposed);
            if omega <= BACKWARD_ERROR {
                return accept(x, db);
            }
            // r is scaled: the correction solves with the unscaled residual.
            let d = &t.scale[transposed as usize];
            r.iter_mut().zip(d).for_each(|(a, s)| *a /= s);
            lu.solve(&mut r, transposed)?;
            x.iter_mut().zip(&r).for_each(|(a, c)| *a += c);
        }
        Err(Breakdown::Singular(MECHANISM).into())
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
            // Snow per Pa, ponding per metre of level, on the current geometry.
            LoadModel::Surface { triangles, law } => {
                let value = loads[k];
                for &e in triangles {
                    let nodes = model.triangles[e].nodes;
                    let x = nodes.map(|i| model.position(u, i));
                    for (&i, f) in nodes.iter().zip(&law.rate(value, &x)) {
                        for c in 0..3 {
                            g[3 * i + c] += f[c];
                        }
                    }
                }
            }
            // The row h = k_V (V or (p + p_atm) V/p_atm − V⁰ − value) moves by −k_V per unit
            // value (volume.rs): g = −∂h/∂v = k_V on the input's pressure unknown.
            LoadModel::Volume {
                stiffness, unknown, ..
            } => {
                g[model.volume_unknown(*unknown)] = *stiffness;
            }
            // The row h = γ_w (V_w − value) (volume.rs) likewise moves by −γ_w per m³.
            LoadModel::Water {
                gamma_w, unknown, ..
            } => {
                g[model.volume_unknown(*unknown)] = *gamma_w;
            }
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
                    let dv = volume_rows_derivative(model, &self.pattern.eq, u, loads, &held);
                    for (j, v) in dr.iter().chain(&dv).enumerate() {
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
            let mut columns = super::slip::slip_columns(model, &every_dof, u);
            columns.extend(super::volume::columns(model, &every_dof, u));
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

/// (K_p − K_pᵀ)/2 of every follower-pressure, snow and ponding triangle under the loads
/// (summed over the channels that load it).
fn skew_parts(model: &Model, u: &[f64], loads: &[f64]) -> Vec<([usize; 3], Mat9)> {
    let mut out = Vec::new();
    for (l, (load, &value)) in model.loads.iter().zip(loads).enumerate() {
        let (triangles, law, value) = match load {
            LoadModel::Pressure {
                triangles,
                follower: true,
            } => (triangles, None, value),
            LoadModel::Surface { triangles, law } => (triangles, Some(*law), value),
            // A volume or gas input's follower pressure is its unknown.
            LoadModel::Volume {
                triangles, unknown, ..
            } => (triangles, None, u[model.volume_unknown(*unknown)]),
            // A water volume's ponding at the level its unknown gives.
            LoadModel::Water {
                triangles, gamma_w, ..
            } => (
                triangles,
                Some(pressure::SurfaceLaw::Ponding { gamma_w: *gamma_w }),
                model.load_value(l, u, loads),
            ),
            _ => continue,
        };
        if value == 0.0 && law.is_none() {
            continue;
        }
        for &e in triangles {
            let nodes = model.triangles[e].nodes;
            let x = nodes.map(|i| model.position(u, i));
            let k = match law {
                None => pressure::follower_stiffness(value, &x),
                Some(law) => law.stiffness(value, &x),
            };
            out.push((nodes, (k - k.transpose()) * 0.5));
        }
    }
    out
}

/// The tangent-only parts that the factored tangent holds and the true one lacks, per element
/// kind: the regularisation ε·D0 of the wrinkled and slack triangles.
pub(super) fn regularisation_parts(
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
            ElementKind::Cable
            | ElementKind::Tie
            | ElementKind::ContactPair
            | ElementKind::ContactPoint => {}
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

/// y = J x (transposed: Jᵀ x) over the equations and slips; `abs`: |J| x, with |A| + |N| +
/// |Reg| for the triangles' parts (a bound of |J|, for the equilibration).
fn product(t: &Tangent, x: &[f64], y: &mut [f64], transposed: bool, abs: bool) {
    let f = |v: f64| if abs { v.abs() } else { v };
    let n = t.n;
    let (xx, xs) = x.split_at(n);
    y.fill(0.0);
    let a = t.upper.as_ref();
    let (cp, ri, v) = (a.symbolic().col_ptr(), a.symbolic().row_idx(), a.val());
    for j in 0..n {
        let (mut acc, xj) = (0.0, xx[j]);
        for k in cp[j]..cp[j + 1] {
            let (i, c) = (ri[k], f(v[k]));
            acc += c * xx[i];
            if i != j {
                y[i] += c * xj;
            }
        }
        y[j] += acc;
    }
    let skew_sign = if transposed { -1.0 } else { 1.0 };
    for (blocks, sign) in [(&t.skew, skew_sign), (&t.regularisation, -1.0)] {
        for (nodes, k) in blocks.iter() {
            let eq = |a: usize| t.eq[3 * nodes[a / 3] + a % 3];
            for b in 0..9 {
                let eb = eq(b);
                if eb == NONE || xx[eb] == 0.0 {
                    continue;
                }
                for a in 0..9 {
                    let ea = eq(a);
                    if ea != NONE {
                        y[ea] += f(sign * k[(a, b)]) * xx[eb];
                    }
                }
            }
        }
    }
    let (yx, ys) = y.split_at_mut(n);
    if !transposed {
        for (column, &s) in t.columns.iter().zip(xs) {
            for &(e, b) in column {
                yx[e] += f(b) * s;
            }
        }
        for (row, out) in t.rows.iter().zip(ys.iter_mut()) {
            *out = row.dx.iter().map(|&(e, c)| f(c) * xx[e]).sum::<f64>()
                + row.ds.iter().map(|&(j, d)| f(d) * xs[j]).sum::<f64>();
        }
    } else {
        for (column, out) in t.columns.iter().zip(ys.iter_mut()) {
            *out = column.iter().map(|&(e, b)| f(b) * xx[e]).sum();
        }
        for (row, &s) in t.rows.iter().zip(xs) {
            for &(e, c) in &row.dx {
                yx[e] += f(c) * s;
            }
            for &(j, d) in &row.ds {
                ys[j] += f(d) * s;
            }
        }
    }
}

/// x when it is not larger than [`MAX_AMPLIFICATION`] times the equilibrated load ‖D b‖∞;
/// else Singular.
fn accept(x: Vec<f64>, db: f64) -> Result<Vec<f64>, Error> {
    let size = x.iter().fold(0.0f64, |a, v| a.max(v.abs()));
    if size <= MAX_AMPLIFICATION * db {
        Ok(x)
    } else {
        Err(Breakdown::Singular(MECHANISM).into())
    }
}

/// ω = ‖D (b − J x)‖∞ / (‖x‖∞ + ‖D b‖∞), D the equilibration of J (of Jᵀ): the normwise
/// backward error of x in the equilibrated system, whose |D J| has row sums of at most 1.
/// `r` receives D (b − J x).
fn backward_error(t: &Tangent, b: &[f64], x: &[f64], r: &mut [f64], transposed: bool) -> f64 {
    let d = &t.scale[transposed as usize];
    product(t, x, r, transposed, false);
    let (mut rn, mut bn, mut xn) = (0.0f64, 0.0f64, 0.0f64);
    for i in 0..b.len() {
        r[i] = d[i] * (b[i] - r[i]);
        rn = rn.max(r[i].abs());
        bn = bn.max((d[i] * b[i]).abs());
        xn = xn.max(x[i].abs());
    }
    let omega = rn / (xn + bn);
    if omega.is_nan() {
        f64::INFINITY
    } else {
        omega
    }
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

fn norm2(a: &[f64]) -> f64 {
    dot(a, a).sqrt()
}

/// The sparse LU of the true J over the equations and slips (module docs).
fn true_lu(t: &Tangent) -> Result<Lu, Error> {
    let size = t.n + t.m;
    let failed = |detail: String| -> Error {
        Breakdown::Factorization {
            of: "the sensitivity's true tangent (LU)",
            detail,
        }
        .into()
    };
    let a = t.upper.as_ref();
    let (cp, ri, v) = (a.symbolic().col_ptr(), a.symbolic().row_idx(), a.val());
    let count = 2 * v.len()
        + 81 * (t.skew.len() + t.regularisation.len())
        + t.columns.iter().map(Vec::len).sum::<usize>()
        + t.rows
            .iter()
            .map(|r| r.dx.len() + r.ds.len())
            .sum::<usize>();
    let mut entries = memory::with_capacity(count, "the sensitivity's LU")?;
    for j in 0..t.n {
        for k in cp[j]..cp[j + 1] {
            entries.push(Triplet::new(ri[k], j, v[k]));
            if ri[k] != j {
                entries.push(Triplet::new(j, ri[k], v[k]));
            }
        }
    }
    for (blocks, sign) in [(&t.skew, 1.0), (&t.regularisation, -1.0)] {
        for (nodes, k) in blocks.iter() {
            let eq = |a: usize| t.eq[3 * nodes[a / 3] + a % 3];
            for a in 0..9 {
                for b in 0..9 {
                    let (ea, eb) = (eq(a), eq(b));
                    if ea != NONE && eb != NONE {
                        entries.push(Triplet::new(ea, eb, sign * k[(a, b)]));
                    }
                }
            }
        }
    }
    for (j, column) in t.columns.iter().enumerate() {
        for &(e, b) in column {
            entries.push(Triplet::new(e, t.n + j, b));
        }
    }
    for (i, row) in t.rows.iter().enumerate() {
        for &(e, c) in &row.dx {
            entries.push(Triplet::new(t.n + i, e, c));
        }
        for &(j, d) in &row.ds {
            entries.push(Triplet::new(t.n + i, t.n + j, d));
        }
    }
    let matrix = SparseColMat::<usize, f64>::try_new_from_triplets(size, size, &entries)
        .map_err(|e| failed(format!("{e:?}")))?;
    drop(entries);
    let symbolic = factorize_symbolic_lu(matrix.symbolic(), Default::default())
        .map_err(|e| failed(format!("{e:?}")))?;
    let mut numeric = NumericLu::new();
    let req = symbolic.factorize_numeric_lu_scratch::<f64>(Par::Seq, Default::default());
    let mut mem = MemBuffer::try_new(req).map_err(|_| memory::OutOfMemory {
        what: "the sensitivity's LU",
        bytes: req.size_bytes() as u64,
    })?;
    match symbolic.factorize_numeric_lu(
        &mut numeric,
        matrix.as_ref(),
        Par::Seq,
        MemStack::new(&mut mem),
        Default::default(),
    ) {
        Ok(_) => {}
        Err(LuError::SymbolicSingular { .. }) => return Err(Breakdown::Singular(MECHANISM).into()),
        Err(e) => return Err(failed(format!("{e:?}"))),
    }
    Ok(Lu { symbolic, numeric })
}

impl Lu {
    /// x ← J⁻¹ x (transposed: J⁻ᵀ x).
    fn solve(&self, x: &mut [f64], transposed: bool) -> Result<(), Error> {
        let n = x.len();
        let req = self.symbolic.solve_in_place_scratch::<f64>(1, Par::Seq);
        let mut mem = MemBuffer::try_new(req).map_err(|_| memory::OutOfMemory {
            what: "the sensitivity's LU",
            bytes: req.size_bytes() as u64,
        })?;
        let lu = LuRef::new_unchecked(&self.symbolic, &self.numeric);
        let rhs = MatMut::from_column_major_slice_mut(x, n, 1);
        if transposed {
            lu.solve_transpose_in_place_with_conj(Conj::No, rhs, Par::Seq, MemStack::new(&mut mem));
        } else {
            lu.solve_in_place_with_conj(Conj::No, rhs, Par::Seq, MemStack::new(&mut mem));
        }
        Ok(())
    }
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

/// ∂h/∂x · dx of the volume rows (volume.rs) for a change `dx` of DOFs (any, held included),
/// by a central difference of the rows (the enclosed volume is a cubic in the positions).
fn volume_rows_derivative(
    model: &Model,
    eq: &[usize],
    u: &[f64],
    loads: &[f64],
    dx: &[f64],
) -> Vec<f64> {
    if model.volumes == 0 {
        return Vec::new();
    }
    let h = 1e-6 * model.length_scale / dx.iter().fold(0.0f64, |m, v| m.max(v.abs())).max(1e-300);
    let at = |sign: f64| {
        let mut v = u.to_vec();
        for (a, d) in v.iter_mut().zip(dx) {
            *a += sign * h * d;
        }
        super::volume::rows(model, eq, &v, loads)
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
