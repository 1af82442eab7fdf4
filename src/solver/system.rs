//! The System boundary: the equations of one increment at a load factor, the one place that
//! assembles them. For an iterate u it gives the residual R = f_int − f_ext and the tangent K
//! (wrinkle states from the law, or frozen), the force magnitudes of the convergence test, the
//! rows that border K (slips, volume control, and under arc length the load factor's row and
//! column −q), the convergence test itself, and the Newton direction of the bordered system
//! (slip.rs eliminates the rows by Schur). Newton (newton.rs) iterates on these methods only;
//! the drivers (path.rs, arc.rs, stepper.rs) never assemble.
//!
//! # The convergence test
//! `F = max(|f_ext|∞, |reactions|∞, largest nodal force of any element, |Δf_ext|∞ of the
//! step)`: the forces applied to and carried by the structure, never a stiffness. `ρ_d =
//! c·ε·(Σ|f|_d + K_dd·X)` is the round-off floor of DOF d: ε machine epsilon, Σ|f|_d the
//! magnitudes of every force meeting at d (its terms), K_dd the diagonal of the tangent, X the
//! coordinate size (rounding a coordinate by εX moves the forces by about K_dd εX), c the
//! settings' `roundoff_factor`. The floor is local, so a very stiff member raises it only at
//! its own nodes. A point inside the floors but not inside tol·F counts as converged only when
//! the Newton correction from it is within tol·X at every unknown (the coordinates are then
//! accurate to the tolerance although the forces cannot be resolved further): the floors of a stiff
//! member's two nodes could otherwise add up to a net force on a soft part it belongs to. In
//! the first iteration of a step whose loads changed the floor does not count: a load change is
//! never accepted unless it is below tol·F.
//!

use super::assemble::{assemble_with, AssemblyInfo, Membranes, NONE};
use super::core::Solver;
use super::loads::{loads_at, prescribed_rate};
use super::rows::{ArcRow, Border, Increment, Row};
use crate::error::Error;
use crate::model::wrinkling::WrinkleState;
use crate::model::Model;

/// The convergence test at one iterate.
#[derive(Clone, Copy, Debug)]
pub(super) struct Check {
    /// Every row within tolerance · F.
    pub strict: bool,
    /// Every row within tolerance · F plus its round-off floor.
    pub within_floor: bool,
    /// |R|∞ over the free DOFs and over the slip rows.
    pub free: f64,
    pub slip: f64,
    /// The force scale F.
    pub scale: f64,
}

impl Solver {
    /// The arc-length row and column (the border is built at every iteration: the column −q
    /// depends on u through follower loads and prescribed displacements), and whether the
    /// row is met.
    pub(super) fn arc_border(
        &mut self,
        model: &Model,
        a: &ArcRow,
        rows: &[Row],
        u: &[f64],
    ) -> (bool, Border) {
        let h = a.residual(&self.pattern.eq, u);
        let column = self.load_column(model, a.from, a.to, a.lambda, u);
        let mut all = rows.to_vec();
        let at = all.len();
        let rates = super::volume::load_rates(model, a.from, a.to);
        for (row, rate) in all[model.slips.len()..].iter_mut().zip(rates) {
            row.ds.push((at, rate));
        }
        all.push(Row {
            r: h,
            dx: (0..self.pattern.n)
                .filter(|&e| a.t[e] != 0.0)
                .map(|e| (e, a.t[e]))
                .collect(),
            ds: Vec::new(),
            magnitude: a.length,
            damped: false,
        });
        let met = h.abs() <= self.settings.tolerance * a.length;
        (met, (all, column))
    }

    /// The Newton direction with the slip and volume rows, and under arc length with the
    /// bordered arc row and its column (then the last entry of the slip part is Δλ).
    pub(super) fn direction_of(
        &mut self,
        model: &Model,
        u: &[f64],
        rows: &[Row],
        bordered: Option<&Border>,
        damping: f64,
    ) -> Result<(Vec<f64>, Vec<f64>), Error> {
        match bordered {
            Some((all, column)) => self.direction(model, u, all, damping, Some(column)),
            None => self.direction(model, u, rows, damping, None),
        }
    }

    /// The convergence test (module docs) on the last assembly.
    pub(super) fn check(
        &self,
        model: &Model,
        info: &AssemblyInfo,
        rows: &[Row],
        u: &[f64],
        inc: &Increment,
        it: usize,
    ) -> Check {
        let (mut free, mut held) = (0.0f64, 0.0f64);
        for (d, &e) in self.pattern.eq.iter().enumerate() {
            let r = self.residual[d].abs();
            if e == NONE {
                held = held.max(r);
            } else if r.is_nan() {
                free = f64::NAN;
            } else {
                free = free.max(r);
            }
        }
        let slip = rows.iter().fold(0.0f64, |m, r| {
            if r.r.is_nan() {
                f64::NAN
            } else {
                m.max(r.r.abs())
            }
        });
        let scale = info.external.max(held).max(info.carried).max(inc.change);
        let tolerance = self.settings.tolerance * scale;
        let first_of_changed_step = it == 0 && inc.moved;
        let x = self.coordinate_size(model, u);
        let c = self.settings.roundoff_factor * f64::EPSILON;
        let values = self.linear.values();
        let finite = free.is_finite() && slip.is_finite();
        let (mut strict, mut within_floor) = (finite, finite);
        for (d, &e) in self.pattern.eq.iter().enumerate() {
            if e == NONE {
                continue;
            }
            let r = self.residual[d].abs();
            strict &= r <= tolerance;
            let floor = if first_of_changed_step {
                0.0
            } else {
                c * (self.magnitude[d] + values[self.diagonal_positions[e]].abs() * x)
            };
            within_floor &= r <= tolerance + floor;
        }
        for row in rows {
            let r = row.r.abs();
            strict &= r <= tolerance;
            let own = row.ds.first().map_or(0.0, |&(_, v)| v.abs());
            let floor = if first_of_changed_step {
                0.0
            } else {
                c * (row.magnitude + own * x)
            };
            within_floor &= r <= tolerance + floor;
        }
        Check {
            strict,
            within_floor,
            free,
            slip,
            scale,
        }
    }

    /// Largest coordinate magnitude of the current positions, at least the model's length
    /// scale: the X of the round-off floor.
    pub(super) fn coordinate_size(&self, model: &Model, u: &[f64]) -> f64 {
        let n3 = model.dof_count();
        let moved = u[..n3].iter().fold(0.0f64, |m, v| m.max(v.abs()));
        (self.reference_size + moved).max(model.length_scale)
    }

    /// Residual, tangent, force magnitudes and evaluations at `u` (frozen wrinkle states if
    /// any).
    pub(super) fn assemble_at(&mut self, model: &Model, loads: &[f64], u: &[f64]) -> AssemblyInfo {
        let membranes = Membranes {
            forced: self.frozen.as_deref(),
            out: Some(&mut self.evaluations),
            held_step: None,
            prestress_factor: Some(self.prestress_factor),
            pre_strain: self.pre_strain,
            magnitude: Some(&mut self.magnitude),
            scratch: Some(&mut self.work.scratch),
        };
        assemble_with(
            model,
            &self.pattern,
            u,
            loads,
            &mut self.residual,
            Some(self.linear.values_mut()),
            membranes,
        )
    }

    /// The wrinkle states the mixed criterion gives at `u` (no freezing), and whether the
    /// residual with those states also passes the convergence test.
    pub(super) fn natural_states_converged(
        &mut self,
        model: &Model,
        rows: &[Row],
        u: &[f64],
        inc: &Increment,
        it: usize,
    ) -> (Vec<WrinkleState>, bool) {
        let membranes = Membranes {
            forced: None,
            out: Some(&mut self.evaluations),
            magnitude: Some(&mut self.magnitude),
            pre_strain: self.pre_strain,
            scratch: Some(&mut self.work.scratch),
            ..Default::default()
        };
        let info = assemble_with(
            model,
            &self.pattern,
            u,
            inc.loads,
            &mut self.residual,
            None,
            membranes,
        );
        let check = self.check(model, &info, rows, u, inc, it);
        let met = check.strict || check.within_floor;
        (self.evaluations.iter().map(|e| e.state).collect(), met)
    }

    /// |R|∞ over the free DOFs of the last assembly.
    /// Where the residual of a failed iteration sits: the free DOF with the largest |R| (the
    /// scene's node numbering), and whether every triangle at that node is wrinkled or slack
    /// (then only the regularisation resists across the tension there, docs/solver.md, and
    /// without a compressive stiffness the load may have no equilibrium).
    pub(super) fn where_stuck(&self, model: &Model) -> String {
        let Some((d, _)) = self
            .pattern
            .eq
            .iter()
            .zip(&self.residual)
            .enumerate()
            .filter(|(_, (&e, r))| e != NONE && r.is_finite())
            .map(|(d, (_, r))| (d, r.abs()))
            .max_by(|a, b| a.1.total_cmp(&b.1))
        else {
            return String::new();
        };
        let (node, axis) = (d / 3, ["x", "y", "z"][d % 3]);
        let states: Vec<WrinkleState> = model
            .triangles
            .iter()
            .zip(&self.evaluations)
            .filter(|(t, _)| t.nodes.contains(&node))
            .map(|(_, e)| e.state)
            .collect();
        let soft = !states.is_empty() && states.iter().all(|&s| s != WrinkleState::Taut);
        if soft {
            format!("; the largest residual is at node {node} in {axis}, where every triangle is wrinkled or slack: across the tension the film has no stiffness there, so the load may have no equilibrium unless something else holds that node (or the film gets a residual stiffness, membranes[].residual_stiffness)")
        } else {
            format!("; the largest residual is at node {node} in {axis}")
        }
    }

    pub(super) fn free_norm(&self) -> f64 {
        self.pattern
            .eq
            .iter()
            .zip(&self.residual)
            .filter(|(&e, _)| e != NONE)
            .fold(0.0f64, |m, (_, r)| m.max(r.abs()))
    }

    /// q = R(u, from) − R(u, to) on the equations (−∂R/∂λ), with the coupling of moving
    /// prescribed displacements.
    pub(super) fn load_direction(
        &mut self,
        model: &Model,
        from: &[f64],
        to: &[f64],
        lambda: f64,
        u: &[f64],
    ) -> Vec<f64> {
        let mut r0 = vec![0.0; model.dof_count()];
        let mut r1 = vec![0.0; model.dof_count()];
        assemble_with(
            model,
            &self.pattern,
            u,
            from,
            &mut r0,
            None,
            Membranes::default(),
        );
        assemble_with(
            model,
            &self.pattern,
            u,
            to,
            &mut r1,
            None,
            Membranes::default(),
        );
        let mut q = vec![0.0; self.pattern.n];
        for (d, &e) in self.pattern.eq.iter().enumerate() {
            if e != NONE {
                q[e] = r0[d] - r1[d];
            }
        }
        // Prescribed displacements that move with λ: −K_fp du_p/dλ (du_p/dλ by a central
        // difference: exact for translations, to about 1e-10 for rotations), through the held-step
        // coupling of the assembly (the tangent's values are not touched).
        if let Some(rate) = prescribed_rate(model, from, to, lambda, u) {
            let mut coupling = vec![0.0; model.dof_count()];
            let mut r = vec![0.0; model.dof_count()];
            let membranes = Membranes {
                held_step: Some((&rate, &mut coupling)),
                ..Default::default()
            };
            let loads = loads_at(from, to, lambda);
            assemble_with(model, &self.pattern, u, &loads, &mut r, None, membranes);
            for (d, &e) in self.pattern.eq.iter().enumerate() {
                if e != NONE {
                    q[e] -= coupling[d];
                }
            }
        }
        q
    }

    /// The load factor's column of the bordered Newton system, ∂R/∂λ = −q, as (equation,
    /// value) pairs (`newton.rs`).
    pub(super) fn load_column(
        &mut self,
        model: &Model,
        from: &[f64],
        to: &[f64],
        lambda: f64,
        u: &[f64],
    ) -> Vec<(usize, f64)> {
        self.load_direction(model, from, to, lambda, u)
            .iter()
            .enumerate()
            .filter(|(_, v)| **v != 0.0)
            .map(|(e, v)| (e, -v))
            .collect()
    }

    /// Wrinkle states of the membranes at `u` (natural, no freezing).
    pub(super) fn wrinkle_states(
        &mut self,
        model: &Model,
        loads: &[f64],
        u: &[f64],
    ) -> Vec<WrinkleState> {
        self.frozen = None;
        let mut r = vec![0.0; model.dof_count()];
        let membranes = Membranes {
            out: Some(&mut self.evaluations),
            ..Default::default()
        };
        assemble_with(model, &self.pattern, u, loads, &mut r, None, membranes);
        self.evaluations.iter().map(|e| e.state).collect()
    }
}
