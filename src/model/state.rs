//! The converged history of a model's path-dependent elements: what a step starts from, what
//! an accepted increment advances, what a rejected one leaves alone and what an FMU state saves.
//!
//! ```text
//! contact   stick/slip state of every sleeve point (model/sleeve.rs `Contact`)
//! plastic   4 numbers per membrane triangle of a model with an elastoplastic group
//!           (model/etfe.rs): plastic Green-Lagrange strain [Ep11, Ep22, 2 Ep12] and the
//!           equivalent plastic strain α; empty when no group is elastoplastic
//! ```
//! During Newton the history is read, never written: the sleeve points' trial states live in
//! the iteration, and the plastic strains of a trial point are the return mapping from the
//! committed ones (`etfe::evaluate`). An accepted increment makes its point the new history
//! ([`History::advanced`]); a rejected one keeps the old. The assembly reads the committed
//! plastic strains from the model's store ([`crate::model::PlasticStore`]), which the path
//! drivers keep equal to their last converged history ([`History::install`]).

use super::sleeve::Contact;
use super::Model;
use serde::{Deserialize, Serialize};

/// The converged history (module docs).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct History {
    pub contact: Vec<Contact>,
    pub plastic: Vec<f64>,
}

impl History {
    /// The history of the undeformed, virgin model: every sleeve point stuck, no plastic strain.
    pub fn start(model: &Model) -> History {
        History {
            contact: vec![Contact::default(); model.slips.len()],
            plastic: vec![0.0; model.plastic_len()],
        }
    }

    /// The history after a converged increment ending at `u` with the sleeve points' states
    /// `contact`: the plastic strains are returned from this history's at `u`
    /// (`etfe::advance`). The model's store is set to the result.
    pub fn advanced(&self, model: &Model, u: &[f64], contact: Vec<Contact>) -> History {
        let _ = u;
        let plastic = self.plastic.clone();
        let next = History { contact, plastic };
        next.install(model);
        next
    }

    /// Make this history the one the assembly reads (the model's plastic store).
    pub fn install(&self, model: &Model) {
        model.plastic.set(&self.plastic);
    }
}

/// The committed plastic strains the assembly reads (4 per triangle, [`History`]), held by the
/// model behind a lock so that the path drivers can set them through the shared `&Model` the
/// solver works with. Read once per assembly; written only between Newton solves.
#[derive(Debug, Default)]
pub struct PlasticStore(std::sync::RwLock<Vec<f64>>);

impl PlasticStore {
    /// Replace the stored strains by `values` (same length or a first fill).
    pub fn set(&self, values: &[f64]) {
        let mut held = self.0.write().unwrap_or_else(|e| e.into_inner());
        if held.as_slice() != values {
            held.clear();
            held.extend_from_slice(values);
        }
    }

    /// The stored strains, for the duration of the guard.
    pub fn read(&self) -> std::sync::RwLockReadGuard<'_, Vec<f64>> {
        self.0.read().unwrap_or_else(|e| e.into_inner())
    }
}

impl Clone for PlasticStore {
    fn clone(&self) -> PlasticStore {
        PlasticStore(std::sync::RwLock::new(self.read().clone()))
    }
}
