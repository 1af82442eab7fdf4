//! The augmented-Lagrangian (Uzawa) closure of the contacts (`model::contact`), called at
//! every converged Newton solve before the sleeve ties' (`slip.rs`, `close_ties`, which shares
//! its round count and its outcome type):
//!
//! ```text
//! measure   the widest |p − λ|/k over the contacts, p = max(0, λ − k g): the gap of a
//!           pressed contact (its penetration or its opening), λ/k of an open one that
//!           still pushes
//! closed    widest <= GAP_TOLERANCE × the model's length scale: nothing to do
//! update    λ ← p at every contact; the residual at u takes the change of the contact
//!           forces, −(p_new − p_old) ∇g, exactly (the active set may change with λ); the
//!           potential changes by Σ (W_new − W_old)
//! open      still wider after MAX_UZAWA_ROUNDS rounds: the increment fails, naming the
//!           contact, its node and its gap
//! ```

use super::core::Solver;
use super::report::push_log;
use super::slip::{Ties, MAX_UZAWA_ROUNDS};
use crate::model::contact::{pressure, GAP_TOLERANCE};
use crate::model::Model;

impl Solver {
    /// The contacts' multiplier update at the converged iterate `u` (module docs): None when
    /// every contact is closed (the ties are next), else the update made or the failure.
    pub(super) fn close_contacts(
        &mut self,
        model: &Model,
        u: &mut [f64],
        rounds: &mut usize,
        log: &mut Vec<String>,
    ) -> Option<Ties> {
        if model.contact_pairs.is_empty() && model.contact_points.is_empty() {
            return None;
        }
        let tolerance = GAP_TOLERANCE * model.length_scale;
        let widest = model
            .contact_states(u)
            .map(|c| ((c.pressure() - c.lambda).abs() / c.k, c))
            .fold(None, |w: Option<(f64, _)>, (d, c)| match w {
                Some((wd, _)) if wd >= d => w,
                _ => Some((d, c)),
            });
        let (gap, worst) = widest?;
        if gap <= tolerance {
            if *rounds > 0 {
                push_log(
                    log,
                    format!("  contacts closed to {gap:.2e} m after {rounds} multiplier updates"),
                );
            }
            return None;
        }
        let which = format!(
            "contact {} (node {}, gap {:.3e} m)",
            model.contacts[worst.set].name, worst.nodes[0], worst.gap
        );
        if *rounds >= MAX_UZAWA_ROUNDS {
            return Some(Ties::Open(format!(
                "{which}: still {gap:.2e} m from closed after {rounds} multiplier updates (tolerance {tolerance:.1e} m); a stiffer contacts[].penalty closes it faster"
            )));
        }
        let mut potential = 0.0;
        let states: Vec<_> = model.contact_states(u).collect();
        for c in states {
            let old = c.pressure();
            let new = pressure(old, c.k, c.gap);
            potential += (new * new - old * old) / (2.0 * c.k)
                - (old * old - c.lambda * c.lambda) / (2.0 * c.k);
            u[c.index] = old;
            let change = new - old;
            if change != 0.0 {
                for (a, &i) in c.nodes.iter().enumerate() {
                    for k in 0..3 {
                        self.residual[3 * i + k] -= change * c.grad[a][k];
                    }
                }
            }
        }
        *rounds += 1;
        push_log(
            log,
            format!("  {which}: {gap:.2e} m from closed (tolerance {tolerance:.1e} m): multipliers updated ({rounds} of at most {MAX_UZAWA_ROUNDS})"),
        );
        Some(Ties::Updated(potential))
    }
}
