//! Nodal relaxation as a phase of the Newton loop (newton.rs): when the iteration stalls, the
//! few nodes that carry the residual are relaxed one at a time with all others held, and a
//! small patch of them by a dense patch Newton near equilibrium (relax.rs holds the local
//! kernels; this file picks the nodes and runs the rounds).

use super::assemble::{assemble_with, Membranes, NONE};
use super::core::Solver;
use super::relax::{relax_nodes, relax_patch, Frozen};
use crate::model::Model;

impl Solver {
    /// Relax, one at a time with all others held, the nodes with a free DOF whose residual is
    /// at least `relax_share` · |R|∞ (`free`), when they are few (at most `relax_max_share` of
    /// the nodes); returns how many moved and the patch Newton's iterations.
    pub(super) fn relax(
        &mut self,
        model: &Model,
        loads: &[f64],
        u: &mut [f64],
        free: f64,
        tolerance: f64,
    ) -> (usize, usize) {
        let s = self.settings.clone();
        let (mut free, mut moved_total, mut patch_iterations) = (free, 0, 0);
        // The patch and its node list in reused buffers (`work.rs`).
        let mut patch = std::mem::take(&mut self.work.patch);
        patch.clear();
        patch.resize(model.reference.len(), false);
        let mut nodes = std::mem::take(&mut self.work.nodes);
        // Elements in one assembly (the unit of the relaxation's work below).
        let elements = model.triangles.len()
            + model.segments.len()
            + model.ties.len()
            + model.contact_pairs.len()
            + model.contact_points.len();
        for _ in 0..s.relax_rounds {
            // The patch grows by the nodes that now carry the residual (the neighbours the last
            // round passed it on to) and is relaxed as a whole: block Gauss-Seidel on it.
            for (i, p) in patch.iter_mut().enumerate() {
                *p |= (0..3).any(|c| {
                    let d = 3 * i + c;
                    self.pattern.eq[d] != NONE && self.residual[d].abs() >= s.relax_share * free
                });
            }
            nodes.clear();
            nodes.extend((0..patch.len()).filter(|&i| patch[i]));
            if nodes.len() as f64 > s.relax_max_share * model.reference.len() as f64 {
                // The residual is spread over the mesh: a global, not a local, difficulty.
                break;
            }
            self.pattern.sweep_order(model, &mut nodes);
            let forced = Frozen {
                states: self.frozen.as_deref(),
                pre_strain: self.pre_strain,
            };
            let mut moved = 0;
            let mut evaluated = 0;
            for _ in 0..s.relax_sweeps {
                moved = moved.max(relax_nodes(
                    model,
                    &self.adjacency,
                    u,
                    loads,
                    &nodes,
                    forced,
                    0.1 * tolerance,
                    &mut evaluated,
                ));
            }
            // Near equilibrium, the patch as a whole (relax.rs: neighbours that drift together
            // under Gauss-Seidel). Far from it, the patch's long steps along its nearly
            // stress-free directions may lead away (the corner-pulled rubber sheet, hard case j).
            let near = free <= s.relax_patch_below * (tolerance / s.tolerance);
            if near && nodes.len() <= s.relax_patch_nodes {
                self.work.patch_newton.reserve(s.relax_patch_nodes);
                let outcome = relax_patch(
                    model,
                    &self.adjacency,
                    u,
                    loads,
                    &nodes,
                    forced,
                    0.1 * tolerance,
                    s.relax_patch_iterations,
                    s.relax_patch_regularization,
                    &mut self.work.patch_newton,
                );
                patch_iterations += outcome.iterations;
                evaluated += outcome.evaluated;
                if outcome.iterations > 0 {
                    moved = moved.max(nodes.len());
                }
            }
            if moved == 0 {
                break;
            }
            moved_total += moved;
            // The round's work: one iteration in the step's budget (core.rs, step_work, in
            // halves), and what it cost beyond that in `relax_extra`, which with step_work is
            // bounded by COST_BOUND times the budget: the global residual evaluation that ends
            // the round (an assembly without the tangent, one half, as a line-search trial)
            // and the relaxation's element evaluations in assemblies' worth (one half per
            // evaluation of as many elements as the model has). Local Newton steps, their
            // slope searches and the patch Newton can evaluate hundreds of assemblies' worth in
            // a round: without the bound a frictional drawstring (16x16, 392 counted
            // iterations) took 10.5 times `check`'s announced cost of a failing step, 67 % of
            // it in the patch Newton (docs/robustness.md, fourteenth session). Counting the
            // rounds at that cost in the budget itself ends steps that converge (measured
            // there), so the bound is 20 times the budget (core.rs, COST_BOUND).
            let assemblies = evaluated.div_ceil(elements.max(1));
            self.step_work += super::core::WORK_ITERATION;
            self.relax_extra += (1 + assemblies).saturating_sub(super::core::WORK_ITERATION);
            let membranes = Membranes {
                forced: forced.states,
                pre_strain: self.pre_strain,
                scratch: Some(&mut self.work.scratch),
                ..Default::default()
            };
            assemble_with(
                model,
                &self.pattern,
                u,
                loads,
                &mut self.residual,
                None,
                membranes,
            );
            let before = free;
            free = self.free_norm();
            // No further round once the step's work is spent (it gives up at the Newton
            // loop's next check).
            if free <= tolerance || free > 0.9 * before || self.work_spent() {
                break;
            }
        }
        self.work.patch = patch;
        self.work.nodes = nodes;
        (moved_total, patch_iterations)
    }
}
