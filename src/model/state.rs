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
//! committed ones (`etfe::response`). An accepted increment makes its point the new history
//! ([`History::advanced`]); a rejected one keeps the old. The assembly reads the committed
//! plastic strains from the model's store (`etfe::PlasticStore`), which the path
//! drivers keep equal to their last converged history ([`History::install`]).

use super::sleeve::Contact;
use super::{etfe, membrane, Model};
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
    /// ([`advance`]). The model's store is set to the result.
    pub fn advanced(&self, model: &Model, u: &[f64], contact: Vec<Contact>) -> History {
        let plastic = if self.plastic.is_empty() {
            Vec::new()
        } else {
            advance(model, u, &self.plastic)
        };
        let next = History { contact, plastic };
        next.install(model);
        next
    }

    /// Make this history the one the assembly reads (the model's plastic store).
    pub fn install(&self, model: &Model) {
        model.plastic.set(&self.plastic);
    }
}

/// The plastic history at the converged point `u` from the committed one `old` (4 values per
/// triangle): every elastoplastic triangle's return from its committed state (`etfe::response`,
/// the wrinkle state found by the law, not frozen).
pub fn advance(model: &Model, u: &[f64], old: &[f64]) -> Vec<f64> {
    let mut out = old.to_vec();
    for t in &model.triangles {
        let Some(p) = t.material.plastic else {
            continue;
        };
        let x = t.nodes.map(|i| model.position(u, i));
        let f = membrane::deformation_gradient(&t.reference, &x);
        let strain = membrane::green_lagrange(&f) + t.reference.initial_strain;
        let point = etfe::Point::read(old, p.slot);
        let sheet = t.material.sheet();
        let (_, next) = etfe::response(sheet, &p.hardening, &strain, &point, None, 0.0);
        if let Some(slot) = out.get_mut(4 * p.slot..4 * p.slot + 4) {
            next.write(slot);
        }
    }
    out
}
