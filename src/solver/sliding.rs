//! Newton iterations of one load increment for a model with sleeves (slip unknowns).
//!
//! ```text
//! unknowns      x (displacements, free DOFs) and s (one slip per sleeve point)
//! system        [A B] [Δx]     [R_x]      A = ∂R_x/∂x  (symmetric: membranes, cables at fixed
//!               [C D] [Δs] = − [r  ]                     L, ties; stored upper, faer LDLT)
//!                                          B = ∂R_x/∂s  (cable forces through L = l0 + Δs)
//!                                          C = ∂r/∂x, D = ∂r/∂s (slip rows, model/sleeve.rs)
//! Schur         y0 = −A⁻¹ R_x,  Y = A⁻¹ B   (m + 1 solves with one LDLT factorization)
//!               (D − C Y) Δs = −r − C y0    (dense m×m LU, m = number of sleeve points)
//!               Δx = y0 − Y Δs
//! step          u ← u + α Δ with α ≤ 1 keeping every sleeved segment's L above 10 % of its
//!               current value
//! converged     |R_x|∞ and |r|∞ ≤ tol · scale (+ floor) and no stick/slip state changed
//! ```
//! The consistent tangent is non-symmetric only in the slip rows and columns, so the large
//! symmetric block keeps the LDLT of the rest of the solver; the price is m extra triangular
//! solves and an m×m dense LU per iteration (small against the factorization for sleeves of
//! tens of points). No line search: the friction law has no potential.
//!
//! # References
//! Wriggers 2006, §5.2 and §6.3 (return mapping, non-symmetric friction tangent); Golub & Van
//! Loan 2013, §3.2 (block elimination / Schur complement).

use super::assemble::{assemble_with, Membranes, NONE};
use super::{push_log, Solver};
use crate::model::sleeve::{self, SegmentLaw, SLIP_BACKWARD, SLIP_FORWARD, STICK};
use crate::model::wrinkling::WrinkleState;
use crate::model::Model;
use nalgebra::{DMatrix, DVector};

/// Iterations with stick/slip or wrinkle changes before the states are frozen.
const FREEZE_AFTER: usize = 8;
/// Times frozen states may turn out wrong at convergence before the increment is cut back.
const MAX_UNFREEZE: usize = 3;
/// Smallest fraction of its current unstretched length a sleeved segment may keep in one step.
const KEEP_LENGTH: f64 = 0.1;
/// Largest tie gap, relative to the shorter adjacent segment, before the log warns
/// (MECHANICS.md §2.3: penetration below 1e-3 of the element size).
pub const MAX_GAP: f64 = 1e-3;
/// Backtracking halvings per Newton step.
const LS_MAX_TRIES: usize = 6;

/// One slip row: residual and its non-zero couplings.
struct Row {
    r: f64,
    /// (equation of a free displacement DOF, ∂r/∂x)
    dx: Vec<(usize, f64)>,
    /// (slip index, ∂r/∂s)
    ds: Vec<(usize, f64)>,
}

impl Solver {
    /// Iterate to equilibrium at fixed `loads`; `u` holds displacements and slips, `states` the
    /// stick/slip state of every sleeve point (in: last converged, out: this increment's).
    pub(super) fn newton_sliding(
        &mut self,
        model: &Model,
        loads: &[f64],
        u: &mut [f64],
        states: &mut [u8],
        log: &mut Vec<String>,
    ) -> Result<usize, (usize, String)> {
        let n3 = model.dof_count();
        let committed: Vec<f64> = u[n3..].to_vec();
        let floor = 1e-12 * model.force_scale.max(f64::MIN_POSITIVE);
        self.frozen = None;
        // The prestress fade of `newton` is not used here: full artificial prestress.
        self.prestress_factor = 1.0;
        let mut previous: Vec<WrinkleState> = Vec::new();
        let (mut frozen_slip, mut freeze_at, mut unfreezes) = (false, FREEZE_AFTER, 0);
        for it in 0..=self.settings.max_iterations {
            let info = self.assemble_at(model, loads, u);
            let wrinkle: Vec<WrinkleState> = self.evaluations.iter().map(|e| e.state).collect();
            if self.frozen.is_none() && it >= freeze_at && wrinkle != previous {
                push_log(
                    log,
                    "  wrinkle states still changing: frozen until convergence".into(),
                );
                self.frozen = Some(wrinkle.clone());
            }
            previous = wrinkle;
            super::check_inversion(model, &info).map_err(|why| (it, why))?;
            let changed = if frozen_slip {
                0
            } else {
                return_map(model, u, &committed, states, 0.0)
            };
            if changed > 0 && it >= freeze_at {
                push_log(log, format!("  stick/slip states still changing ({changed} points): frozen until convergence"));
                frozen_slip = true;
            }
            let rows = slip_rows(model, &self.pattern.eq, u, &committed, states);
            let (free, held) = self.norms();
            let slip_res = rows.iter().fold(0.0f64, |a, r| a.max(r.r.abs()));
            if !(free.is_finite() && slip_res.is_finite()) {
                return Err((it, "the residual is not finite".into()));
            }
            let scale = info.external.max(held);
            let limit = self.settings.tolerance * scale + floor;
            if changed == 0 && free <= limit && slip_res <= limit {
                let natural_ok = {
                    let mut check = states.to_vec();
                    return_map(model, u, &committed, &mut check, limit) == 0
                };
                let wrinkle_ok = match self.frozen.take() {
                    None => true,
                    Some(frozen) => {
                        let (natural, natural_free) = self.natural_states(model, loads, u);
                        natural == frozen || natural_free <= limit
                    }
                };
                if natural_ok && wrinkle_ok {
                    let gap = largest_gap(model, u);
                    if gap > MAX_GAP {
                        push_log(log, format!("  warning: a sleeve tie opened by {gap:.2e} of its segment length (more than {MAX_GAP:.0e}): the penalty is too soft for this load; set cables[].sleeve.penalty higher"));
                    }
                    push_log(log, format!("  converged: |R| = {free:.3e}, |r_slip| = {slip_res:.3e} (scale {scale:.3e})"));
                    return Ok(it);
                }
                unfreezes += 1;
                if unfreezes > MAX_UNFREEZE {
                    return Err((
                        it,
                        "stick/slip or wrinkle states keep changing (chatter)".into(),
                    ));
                }
                push_log(
                    log,
                    "  frozen states were wrong at convergence: iterating on".into(),
                );
                frozen_slip = false;
                self.frozen = None;
                freeze_at = it + FREEZE_AFTER;
                continue;
            }
            if it == self.settings.max_iterations {
                return Err((it, format!("no convergence in {it} iterations (|R| = {free:.3e}, |r_slip| = {slip_res:.3e}, scale {scale:.3e})")));
            }
            let (dx, ds) = self
                .schur_solve(model, u, &rows)
                .map_err(|why| (it + 1, why))?;
            let alpha = self.damped_step(
                model,
                loads,
                u,
                &dx,
                &ds,
                states,
                &committed,
                free.max(slip_res),
            );
            push_log(log, format!("  iteration {}: |R| = {free:.3e}, |r_slip| = {slip_res:.3e} (scale {scale:.3e}), α = {alpha:.3}", it + 1));
        }
        let n = self.settings.max_iterations;
        Err((
            n,
            format!("no convergence in {n} iterations (states changed at the end)"),
        ))
    }

    /// Take the Newton step, backtracking (halving α from the fraction-to-boundary limit) while
    /// the residual norm max(|R_x|∞, |r|∞) does not fall below `before`; the friction law has no
    /// potential, so the residual norm is the merit function. Returns the α taken.
    #[allow(clippy::too_many_arguments)]
    fn damped_step(
        &mut self,
        model: &Model,
        loads: &[f64],
        u: &mut [f64],
        dx: &[f64],
        ds: &[f64],
        states: &[u8],
        committed: &[f64],
        before: f64,
    ) -> f64 {
        let n3 = model.dof_count();
        let start = u.to_vec();
        let mut alpha = step_limit(model, u, ds);
        for _ in 0..LS_MAX_TRIES {
            u.copy_from_slice(&start);
            for (d, &e) in self.pattern.eq.iter().enumerate() {
                if e != NONE {
                    u[d] += alpha * dx[e];
                }
            }
            for (j, d) in ds.iter().enumerate() {
                u[n3 + j] += alpha * d;
            }
            assemble_with(
                model,
                &self.pattern,
                u,
                loads,
                &mut self.residual,
                None,
                Membranes {
                    forced: self.frozen.as_deref(),
                    out: None,
                    held_step: None,
                    prestress_factor: None,
                },
            );
            let (free, _) = self.norms();
            let rows = slip_rows(model, &self.pattern.eq, u, committed, states);
            let slip = rows.iter().fold(0.0f64, |a, r| a.max(r.r.abs()));
            let now = free.max(slip);
            if now.is_finite() && now < before {
                return alpha;
            }
            alpha *= 0.5;
        }
        alpha * 2.0
    }

    /// Newton direction (Δx on equations, Δs) by block elimination of the slip unknowns.
    fn schur_solve(
        &mut self,
        model: &Model,
        u: &[f64],
        rows: &[Row],
    ) -> Result<(Vec<f64>, Vec<f64>), String> {
        let n = self.pattern.n;
        let m = model.slips.len();
        self.linear.factor()?;
        let mut y0 = vec![0.0; n];
        for (d, &e) in self.pattern.eq.iter().enumerate() {
            if e != NONE {
                y0[e] = -self.residual[d];
            }
        }
        self.linear.solve(&mut y0)?;
        let columns = slip_columns(model, &self.pattern.eq, u);
        let mut y = Vec::with_capacity(m);
        for col in &columns {
            let mut v = vec![0.0; n];
            for &(e, b) in col {
                v[e] += b;
            }
            if !col.is_empty() {
                self.linear.solve(&mut v)?;
            }
            y.push(v);
        }
        let mut schur = DMatrix::<f64>::zeros(m, m);
        let mut rhs = DVector::<f64>::zeros(m);
        for (i, row) in rows.iter().enumerate() {
            for &(j, d) in &row.ds {
                schur[(i, j)] += d;
            }
            for (j, yj) in y.iter().enumerate() {
                schur[(i, j)] -= row.dx.iter().map(|&(e, c)| c * yj[e]).sum::<f64>();
            }
            rhs[i] = -row.r - row.dx.iter().map(|&(e, c)| c * y0[e]).sum::<f64>();
        }
        // A zero pivot is a sliding mechanism (frictionless point on a straight or slack cable):
        // a tiny spring on the slip, in the tangent only.
        let big = (0..m).map(|i| schur[(i, i)].abs()).fold(0.0, f64::max);
        for i in 0..m {
            if schur[(i, i)].abs() <= 1e-12 * big {
                schur[(i, i)] += 1e-9 * big.max(f64::MIN_POSITIVE);
            }
        }
        let ds = schur
            .lu()
            .solve(&rhs)
            .ok_or_else(|| "the slip block of the tangent is singular".to_string())?;
        let mut dx = y0;
        for (j, yj) in y.iter().enumerate() {
            for (e, v) in dx.iter_mut().enumerate() {
                *v -= yj[e] * ds[j];
            }
        }
        if !(dx.iter().all(|v| v.is_finite()) && ds.iter().all(|v| v.is_finite())) {
            return Err("the Newton direction is not finite".into());
        }
        Ok((dx, ds.iter().copied().collect()))
    }
}

/// Return mapping of every sleeve point at `u`; returns how many states changed.
/// `tol_f` (N) is the force tolerance of the cone test (0 inside the iterations, the
/// convergence tolerance when a converged point's states are checked).
pub(crate) fn return_map(
    model: &Model,
    u: &[f64],
    committed: &[f64],
    states: &mut [u8],
    tol_f: f64,
) -> usize {
    let n3 = model.dof_count();
    let mut changed = 0;
    for (j, p) in model.slips.iter().enumerate() {
        let (ta, tb) = tensions(model, u, p);
        let (ft, fnormal) = sleeve::contact_forces(
            &model.position(u, p.prev),
            &model.position(u, p.node),
            &model.position(u, p.next),
            ta,
            tb,
        );
        let direction = if ft >= 0.0 {
            SLIP_FORWARD
        } else {
            SLIP_BACKWARD
        };
        let new = if ta + tb == 0.0 {
            // Slack on both sides: nothing drives or resists a slip; hold the material.
            STICK
        } else if p.mu == 0.0 {
            SLIP_FORWARD
        } else if states[j] == STICK {
            let tiny = 1e-12 * (ta + tb) + tol_f;
            if ft.abs() > p.mu * fnormal + tiny {
                direction
            } else {
                STICK
            }
        } else {
            // A slipping point stays slipping while its slip runs with σ (σ Δs ≤ 0).
            let sigma = sleeve::sigma(states[j]);
            let back = sigma * (u[n3 + j] - committed[j]);
            let tiny = 1e-14 * model.length_scale;
            if back > tiny {
                STICK
            } else {
                states[j]
            }
        };
        if new != states[j] {
            states[j] = new;
            changed += 1;
        }
    }
    changed
}

fn tensions(model: &Model, u: &[f64], p: &sleeve::SlipPoint) -> (f64, f64) {
    let [a, b] = p.segments;
    (model.segment_tension(u, a), model.segment_tension(u, b))
}

/// Slip rows: r = f_t − σμ f_n for slipping points, k_ref (s − s^n) for stuck ones.
fn slip_rows(model: &Model, eq: &[usize], u: &[f64], committed: &[f64], states: &[u8]) -> Vec<Row> {
    let n3 = model.dof_count();
    model
        .slips
        .iter()
        .enumerate()
        .map(|(j, p)| {
            let [a, b] = p.segments;
            let (sa, sb) = (&model.segments[a], &model.segments[b]);
            if states[j] == STICK {
                let k_ref = sa.ea / sa.l0;
                return Row {
                    r: k_ref * (u[n3 + j] - committed[j]),
                    dx: Vec::new(),
                    ds: vec![(j, k_ref)],
                };
            }
            let sigma_mu = sleeve::sigma(states[j]) * p.mu;
            let (r, dxs, dl) = sleeve::slip_row(
                SegmentLaw {
                    law: sa.law,
                    ea: sa.ea,
                },
                SegmentLaw {
                    law: sb.law,
                    ea: sb.ea,
                },
                model.segment_l0(u, a),
                model.segment_l0(u, b),
                &model.position(u, p.prev),
                &model.position(u, p.node),
                &model.position(u, p.next),
                sigma_mu,
            );
            let mut dx = Vec::new();
            for (node, g) in [p.prev, p.node, p.next].iter().zip(&dxs) {
                for c in 0..3 {
                    let e = eq[3 * node + c];
                    if e != NONE {
                        dx.push((e, g[c]));
                    }
                }
            }
            // L_a = l0_a + s_j − s_prev,  L_b = l0_b + s_next − s_j.
            let mut ds = vec![(j, dl[0] - dl[1])];
            if let Some(i) = sa.slip[0] {
                ds.push((i, -dl[0]));
            }
            if let Some(i) = sb.slip[1] {
                ds.push((i, dl[1]));
            }
            Row { r, dx, ds }
        })
        .collect()
}

/// Columns of B = ∂R_x/∂s: per slip, (equation, value) pairs.
fn slip_columns(model: &Model, eq: &[usize], u: &[f64]) -> Vec<Vec<(usize, f64)>> {
    let mut cols = vec![Vec::new(); model.slips.len()];
    for (e, s) in model.segments.iter().enumerate() {
        if s.slip == [None, None] {
            continue;
        }
        let (xa, xb) = (model.position(u, s.nodes[0]), model.position(u, s.nodes[1]));
        let d = xb - xa;
        let l = d.norm();
        let dir = d / l;
        let m = crate::model::cable::tension_dl0(s.law, s.ea, model.segment_l0(u, e), l);
        // Forces −T e on the start node, T e on the end node; L = l0 + s_end − s_start.
        for (end, sign) in [(1usize, 1.0), (0usize, -1.0)] {
            let Some(j) = s.slip[end] else { continue };
            for (node, f) in [(s.nodes[0], -1.0), (s.nodes[1], 1.0)] {
                for c in 0..3 {
                    let q = eq[3 * node + c];
                    if q != NONE {
                        cols[j].push((q, sign * f * m * dir[c]));
                    }
                }
            }
        }
    }
    cols
}

/// Largest tie gap |x_c − x_m| over the shorter adjacent segment length.
fn largest_gap(model: &Model, u: &[f64]) -> f64 {
    let length = |e: usize| {
        let s = &model.segments[e];
        (model.position(u, s.nodes[1]) - model.position(u, s.nodes[0])).norm()
    };
    model
        .slips
        .iter()
        .map(|p| {
            let [c, m] = model.ties[p.tie].nodes;
            let gap = (model.position(u, c) - model.position(u, m)).norm();
            gap / length(p.segments[0]).min(length(p.segments[1]))
        })
        .fold(0.0, f64::max)
}

/// Largest α ≤ 1 keeping every sleeved segment's unstretched length above KEEP_LENGTH of its
/// current value.
fn step_limit(model: &Model, u: &[f64], ds: &[f64]) -> f64 {
    let mut alpha = 1.0f64;
    for (e, s) in model.segments.iter().enumerate() {
        let d = |k: Option<usize>| k.map_or(0.0, |j| ds[j]);
        let dl = d(s.slip[1]) - d(s.slip[0]);
        let l = model.segment_l0(u, e);
        if l > 0.0 && dl < 0.0 && l + dl < KEEP_LENGTH * l {
            alpha = alpha.min((1.0 - KEEP_LENGTH) * l / -dl);
        }
    }
    alpha
}

/// The slip blocks at `u` as dense matrices, for finite-difference tests: slip residuals r,
/// B = ∂R_x/∂s (free equations × slips), C = ∂r/∂x (slips × free equations), D = ∂r/∂s.
pub fn slip_blocks(
    model: &Model,
    eq: &[usize],
    u: &[f64],
    committed: &[f64],
    states: &[u8],
) -> (Vec<f64>, DMatrix<f64>, DMatrix<f64>, DMatrix<f64>) {
    let n = eq.iter().filter(|&&e| e != NONE).count();
    let m = model.slips.len();
    let rows = slip_rows(model, eq, u, committed, states);
    let (mut b, mut c, mut d) = (
        DMatrix::zeros(n, m),
        DMatrix::zeros(m, n),
        DMatrix::zeros(m, m),
    );
    for (j, col) in slip_columns(model, eq, u).iter().enumerate() {
        for &(e, v) in col {
            b[(e, j)] += v;
        }
    }
    for (i, row) in rows.iter().enumerate() {
        for &(e, v) in &row.dx {
            c[(i, e)] += v;
        }
        for &(j, v) in &row.ds {
            d[(i, j)] += v;
        }
    }
    (rows.iter().map(|r| r.r).collect(), b, c, d)
}
