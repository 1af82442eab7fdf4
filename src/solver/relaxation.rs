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
            for _ in 0..s.relax_sweeps {
                moved = moved.max(relax_nodes(
                    model,
                    &self.adjacency,
                    u,
                    loads,
                    &nodes,
                    forced,
                    0.1 * tolerance,
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
                if outcome.iterations > 0 {
                    moved = moved.max(nodes.len());
                }
            }
            if moved == 0 {
                break;
            }
            moved_total += moved;
            // A global residual evaluation and the relaxation it ends (at most the patch's
            // share of the nodes, each relaxed `relax_sweeps` times: within one more
            // assembly's worth): two assemblies, an iteration's worth of the step's work
            // budget (core.rs, step_work).
            self.step_work += super::core::WORK_ITERATION;
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
            if free <= tolerance || free > 0.9 * before {
                break;
            }
        }
        self.work.patch = patch;
        self.work.nodes = nodes;
        (moved_total, patch_iterations)
    }
}
