//! Natural frequencies and mode shapes about the committed equilibrium (`velarium modes`,
//! the `natural_frequency` output): the solver's shift-invert Lanczos (`solver/modes.rs`) on
//! the true tangent at the committed state and the model's mass matrix (`solver/mass.rs`,
//! consistent or lumped as the scene's `dynamics` section says; consistent without one).

use super::Engine;
use crate::error::Error;
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
            &mass,
            &s.displacement,
            &s.applied,
            &states,
            count,
        )
    }
}
