//! The System boundary: the equations of one increment at a load factor, the one place that
//! assembles them. For an iterate u it gives the residual R = f_int − f_ext and the tangent K
//! (wrinkle states from the law, or frozen), the force magnitudes of the convergence test, the
//! rows that border K (slips, volume control, and under arc length the load factor's row and
//! column −q), the convergence test itself, and the Newton direction of the bordered system
//! (slip.rs eliminates the rows by Schur). Newton (newton.rs) iterates on these methods only;
//! the drivers (path.rs, arc.rs, stepper.rs) never assemble.
//!
//! # The convergence test
//! Local, node by node: the residual of every free DOF of node n must be within
//! `tol·S_n + ε_F`, S_n the largest over the node's three directions of the magnitudes of
//! every force meeting there (its external load and each element force acting on it), and
//! `ε_F = tol·G` an absolute floor from the scene's own load scale: G the lower quartile over
//! the nodes of the nonzero nodal loads at free DOFs; when no free DOF is loaded, of the loads
//! applied at held DOFs (a drawstring unloaded to its pretension, whose end pulls go straight
//! into the ends' supports); when nothing is loaded at all, of the reactions at held DOFs (a
//! scene driven by prescribed displacements). A force below the
//! tolerance of a typical load is none: a bead resting unloaded on a cable, or a node inside a
//! wrinkled region where the tension field leaves the displacement across the tension
//! undetermined, carries only round-off. The quartile moves only when three quarters of the
//! loaded nodes are another member's. A slip,
//! closure or volume row is held to `tol·M`, M the size of the forces it balances (its own
//! scale: a volume or gas law row is not a nodal force, so ε_F does not apply to it). No
//! global scale enters the verdict: a member elsewhere, however large its force, neither
//! loosens nor tightens the test at a node it does not touch (before, F = the largest force
//! anywhere made a disc beside an unconnected 1e9 N stay converge in 0 iterations at w = 0).
//! F, the largest force anywhere (external, reactions, element forces, the step's load change),
//! remains the scale of the heuristics (the artificial prestress's fade, the relaxation's
//! target, stall detection) and of the messages.
//!
//! `ρ_d = c·ε·(Σ|f|_d + K_dd·X)` is the round-off floor of DOF d: ε machine epsilon, Σ|f|_d the
//! magnitudes of every force meeting at d (its terms), K_dd the diagonal of the tangent, X the
//! coordinate size (rounding a coordinate by εX moves the forces by about K_dd εX), c the
//! settings' `roundoff_factor`. The floor is local, so a very stiff member raises it only at
//! its own nodes. A point inside the floors but not inside the local tolerance counts as
//! converged only when the Newton correction from it is within tol·X at every unknown (the
//! coordinates are then accurate to the tolerance although the forces cannot be resolved
//! further): the floors of a stiff member's two nodes could otherwise add up to a net force on
//! a soft part it belongs to. In the first iteration of a step whose loads changed the floor
//! does not count: a load change is accepted only where it is below the local tolerance.
//!
//! Unloaded to nothing, a membrane or cable returns to a stress-free state where its tangent is
//! singular (a flat membrane: w³ ∝ q), so the residual falls as the cube of the displacement
//! error: only a residual test relative to the element forces, which vanish there too, gives
//! the displacement to the tolerance. Measured (2026-11-27, the robustness corpus): taking G at
//! an unloaded state from the loads the step removed brought a Hencky disc back to flat in 45
//! iterations instead of 408, but left 8 of its 16 rows, 4 cable rows and 3 cushion rows
//! farther than 1e-6 of their size from the start: rejected.
//!

use super::assemble::{assemble_with, AssemblyInfo, Membranes, NONE};

/// Which nodal forces G of the convergence test is taken from (module docs), in this order.
#[derive(Clone, Copy)]
enum Scale {
    /// The loads at free DOFs.
    FreeLoads,
    /// The loads applied at held DOFs (a scene whose every load goes straight into a support).
    HeldLoads,
    /// The reactions (a scene driven by prescribed displacements).
    Reactions,
}
use super::core::Solver;
use super::loads::{loads_at, prescribed_rate};
use super::rows::{ArcRow, Border, Increment, Row};
use crate::error::Error;
use crate::model::wrinkling::WrinkleState;
use crate::model::Model;

/// The convergence test at one iterate.
#[derive(Clone, Copy, Debug)]
pub(super) struct Check {
    /// Every row within its local tolerance (module docs).
    pub strict: bool,
    /// Every row within its local tolerance plus its round-off floor.
    pub within_floor: bool,
    /// |R|∞ over the free DOFs and over the slip rows.
    pub free: f64,
    pub slip: f64,
    /// The largest force anywhere, F (heuristics and messages only).
    pub scale: f64,
    /// Largest ratio of a residual to its local tolerance plus its round-off floor (≤ 1 where
    /// the test is met).
    pub worst: f64,
    /// The smallest signed area ratio of a membrane triangle (infinite without triangles): a
    /// point with a triangle at or below `MIN_AREA_RATIO` is not an answer, whatever its
    /// residual.
    pub min_area_ratio: f64,
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
        // F of the heuristics (fading prestress, relaxation, stall) and of the messages: the
        // largest force anywhere. The verdict below never uses it.
        let scale = info.external.max(held).max(info.carried).max(inc.change);
        let tol = self.settings.tolerance;
        let first_of_changed_step = it == 0 && inc.moved;
        let x = self.coordinate_size(model, u);
        let c = self.settings.roundoff_factor * f64::EPSILON;
        let values = self.linear.values();
        let finite = free.is_finite() && slip.is_finite();
        // A wrinkled or slack triangle may fold while the iteration moves the sheet (the
        // guard, assemble.rs `min_guard_ratio`), but a converged point has none folded.
        let unfolded =
            model.triangles.is_empty() || info.min_area_ratio > super::settings::MIN_AREA_RATIO;
        let (mut strict, mut within_floor) = (finite && unfolded, finite && unfolded);
        let mut worst = 0.0f64;
        for (d, &e) in self.pattern.eq.iter().enumerate() {
            if e == NONE {
                continue;
            }
            let r = self.residual[d].abs();
            let local = self.local_tolerance(d);
            strict &= r <= local;
            let floor = if first_of_changed_step {
                0.0
            } else {
                c * (self.magnitude[d] + values[self.diagonal_positions[e]].abs() * x)
            };
            within_floor &= r <= local + floor;
            worst = worst.max(r / (local + floor).max(f64::MIN_POSITIVE));
        }
        for row in rows {
            let r = row.r.abs();
            let local = tol * row.magnitude;
            strict &= r <= local;
            let own = row.ds.first().map_or(0.0, |&(_, v)| v.abs());
            let floor = if first_of_changed_step {
                0.0
            } else {
                c * (row.magnitude + own * x)
            };
            within_floor &= r <= local + floor;
            worst = worst.max(r / (local + floor).max(f64::MIN_POSITIVE));
        }
        Check {
            strict,
            within_floor,
            free,
            slip,
            scale,
            worst,
            min_area_ratio: info.min_area_ratio,
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
        let info = self.assemble_only(model, loads, u);
        self.measure_load_scale(model);
        info
    }

    /// G of the convergence test (module docs) from the last assembly: the lower quartile of
    /// the nonzero nodal loads at free DOFs, else of the loads at held DOFs, else of the
    /// reactions. In the solver's buffer (no allocation). Measured (2026-11-28, the robustness
    /// corpus): the held DOFs' loads as the second choice brought four of the five frictionless
    /// drawstrings unloaded to their pretension back right in 45-123 iterations; with the
    /// reactions (which vanish with the stress-free sheet) they spent the step's work budget at
    /// |R| of 6e-12 to 4e-5 of the force scale. No other row of the corpus changed.
    pub(super) fn measure_load_scale(&mut self, model: &Model) {
        self.load_scale = self.quartile_of(model, Scale::FreeLoads);
        if self.load_scale == 0.0 {
            self.load_scale = self.quartile_of(model, Scale::HeldLoads);
        }
        if self.load_scale == 0.0 {
            self.load_scale = self.quartile_of(model, Scale::Reactions);
        }
    }

    /// The lower quartile of the nonzero nodal forces `of` (module docs); 0 when there are
    /// none.
    fn quartile_of(&mut self, model: &Model, of: Scale) -> f64 {
        let fext = self.work.scratch.external();
        let loads = &mut self.loads_seen;
        loads.clear();
        for (node, (f, r)) in fext
            .chunks_exact(3)
            .zip(self.residual.chunks_exact(3))
            .enumerate()
        {
            let mut sum = 0.0;
            for c in 0..3 {
                let held = model.held[3 * node + c];
                let v = match (of, held) {
                    (Scale::FreeLoads, false) | (Scale::HeldLoads, true) => f[c],
                    (Scale::Reactions, true) => r[c],
                    _ => 0.0,
                };
                sum += v * v;
            }
            if sum > 0.0 && sum.is_finite() && loads.len() < loads.capacity() {
                loads.push(sum.sqrt());
            }
        }
        if loads.is_empty() {
            return 0.0;
        }
        let quarter = loads.len() / 4;
        *loads.select_nth_unstable_by(quarter, f64::total_cmp).1
    }

    /// Residual, tangent, force magnitudes and evaluations at `u`, without the load scale.
    fn assemble_only(&mut self, model: &Model, loads: &[f64], u: &[f64]) -> AssemblyInfo {
        let membranes = Membranes {
            forced: self.frozen.as_deref(),
            out: Some(&mut self.evaluations),
            held_step: None,
            prestress_factor: Some(self.prestress_factor),
            pre_strain: self.pre_strain,
            magnitude: Some(&mut self.magnitude),
            scratch: Some(&mut self.work.scratch),
        };
        let mut info = assemble_with(
            model,
            &self.pattern,
            u,
            loads,
            &mut self.residual,
            Some(self.linear.values_mut()),
            membranes,
        );
        // A time sub-step's inertia force and its tangent (dynamic.rs).
        info.potential += self.add_inertia(u, true, true);
        info
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
        // An assembly without the tangent: half an iteration of the step's work budget
        // (core.rs, step_work).
        self.step_work += 1;
        let membranes = Membranes {
            forced: None,
            out: Some(&mut self.evaluations),
            magnitude: Some(&mut self.magnitude),
            pre_strain: self.pre_strain,
            scratch: Some(&mut self.work.scratch),
            ..Default::default()
        };
        let mut info = assemble_with(
            model,
            &self.pattern,
            u,
            inc.loads,
            &mut self.residual,
            None,
            membranes,
        );
        info.potential += self.add_inertia(u, false, true);
        self.measure_load_scale(model);
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
            .map(|(d, (_, r))| (d, r.abs() / self.local_tolerance(d)))
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
            format!("; the residual farthest above its tolerance is at node {node} in {axis}, where every triangle is wrinkled or slack: across the tension the film has no stiffness there, so the load may have no equilibrium unless something else holds that node (or the film gets a residual stiffness, membranes[].residual_stiffness)")
        } else {
            format!("; the residual farthest above its tolerance is at node {node} in {axis}")
        }
    }

    /// Where the last assembly's most turned-over membrane triangle is (the failure message of
    /// an increment whose residuals all met their tolerance but whose iterate has a folded
    /// triangle, newton.rs).
    pub(super) fn where_folded(&self, model: &Model, u: &[f64]) -> String {
        let Some((t, e, ratio)) = model
            .triangles
            .iter()
            .zip(&self.evaluations)
            .map(|(t, e)| {
                let x = t.nodes.map(|n| model.position(u, n));
                (
                    t,
                    e,
                    crate::model::membrane::signed_area_ratio(&t.reference, &x),
                )
            })
            .min_by(|a, b| a.2.total_cmp(&b.2))
        else {
            return String::new();
        };
        let state = match e.state {
            WrinkleState::Taut => "taut",
            WrinkleState::Wrinkled => "wrinkled",
            WrinkleState::Slack => "slack",
        };
        format!(
            "; the most turned-over triangle is triangle {} (nodes {}, {}, {}; {state}, area ratio {:.1e})",
            t.id, t.nodes[0], t.nodes[1], t.nodes[2], ratio
        )
    }

    /// tol·S_n + ε_F of DOF `d` at the last assembly (module docs; never 0).
    fn local_tolerance(&self, d: usize) -> f64 {
        let node = 3 * (d / 3);
        let forces = self.magnitude[node..node + 3]
            .iter()
            .fold(0.0f64, |m, &f| m.max(f));
        (self.settings.tolerance * (forces + self.load_scale)).max(f64::MIN_POSITIVE)
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
