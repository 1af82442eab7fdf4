//! Natural frequencies and mode shapes about the committed equilibrium (`velarium modes`,
//! the `natural_frequency` output): the solver's shift-invert Lanczos (`solver/modes.rs`) on
//! the true tangent at the committed state and the model's mass matrix (`solver/mass.rs`,
//! consistent or lumped as the scene's `dynamics` section says; consistent without one).

use super::Engine;
use crate::error::Error;
use crate::model::ProbeModel;
use crate::solver::modes::Modes;

impl Engine {
    /// The lowest `count` natural frequencies and M-normalised mode shapes at the committed
    /// equilibrium. The factorization the sensitivities kept is dropped (the solver's LDLT
    /// now holds K − σM).
    pub fn modes(&mut self, count: usize) -> Result<Modes, Error> {
        if self.model_stale {
            return Err(Error::State(
                "a parameter changed since the last equilibrium: step first, then ask for natural frequencies".into(),
            ));
        }
        let mass = self.solver.mass(&self.model, self.model.mass_kind)?;
        let states: Vec<_> = self.membranes.iter().map(|e| e.state).collect();
        self.tangent = None;
        let s = &self.state;
        self.solver.modes(
            &self.model,
            mass,
            &s.displacement,
            &s.applied,
            &states,
            count,
        )
    }
}

impl Engine {
    /// The `natural_frequency` outputs of the committed state (`Engine::refresh_outputs`):
    /// one modal analysis for the highest mode asked for. Nothing to do without such outputs.
    pub(super) fn natural_frequency_outputs(&mut self) -> Result<(), Error> {
        let wanted: Vec<(usize, usize)> = self
            .model
            .probes
            .iter()
            .enumerate()
            .filter_map(|(slot, p)| match p {
                ProbeModel::NaturalFrequency { mode } => Some((slot, *mode)),
                _ => None,
            })
            .collect();
        let Some(count) = wanted.iter().map(|&(_, k)| k).max() else {
            return Ok(());
        };
        let modes = self.modes(count)?;
        for (slot, k) in wanted {
            self.outputs[slot] = modes.frequencies.get(k - 1).copied().ok_or_else(|| {
                Error::Unsupported(format!(
                    "natural frequency {k}: only {} converged at this state",
                    modes.frequencies.len()
                ))
            })?;
        }
        Ok(())
    }
}
