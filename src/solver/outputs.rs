//! The outputs of a committed state from one assembly (`Committed`): every membrane
//! triangle's evaluation, the residual (for the reaction outputs) and the stored energy (for
//! the strain-energy output). A file of its own so that the assembly does not depend on the
//! solver (the import-cycle guard, `tests/guards/architecture.rs`).

use super::assemble;
use super::core::Solver;
use crate::model::membrane::Evaluation;
use crate::model::Model;

/// What the outputs of a committed state need from its assembly, from one pass: every
/// membrane triangle's evaluation, the residual R = f_int − f_ext (for the reactions) and the
/// stored energy. Before, the first output evaluation assembled twice or three times (the
/// evaluations, then the residual for a reaction probe, then the energy for a strain-energy
/// probe): the second cost 0.10 s of the 1M disc's setup.
pub struct Committed {
    pub membranes: Vec<Evaluation>,
    pub residual: Vec<f64>,
    pub stored: f64,
}

impl Solver {
    /// [`Committed`] at `u` under `loads`, with the wrinkle states the solver holds
    /// ([`Solver::hold_states`]); the same assembly as [`Solver::evaluate_membranes`],
    /// [`Solver::residual`] and [`Solver::stored_energy`], once.
    pub fn evaluate_committed(&mut self, model: &Model, u: &[f64], loads: &[f64]) -> Committed {
        self.evaluate_committed_into(model, u, loads, Vec::new())
    }

    /// [`Solver::evaluate_committed`] with the evaluations written into `out` (an earlier
    /// committed state's, of this model: its pages are then not touched afresh; every entry
    /// is overwritten).
    pub fn evaluate_committed_into(
        &mut self,
        model: &Model,
        u: &[f64],
        loads: &[f64],
        mut out: Vec<Evaluation>,
    ) -> Committed {
        let mut residual = vec![0.0; model.dof_count()];
        if out.len() != model.triangles.len() {
            out = Vec::with_capacity(model.triangles.len());
        }
        let membranes = assemble::Membranes {
            out: Some(&mut out),
            forced: self.probe_states.as_deref(),
            scratch: Some(&mut self.work.scratch),
            ..Default::default()
        };
        let stored = assemble::assemble_with(
            model,
            &self.pattern,
            u,
            loads,
            &mut residual,
            None,
            membranes,
        )
        .stored;
        Committed {
            membranes: out,
            residual,
            stored,
        }
    }
}
