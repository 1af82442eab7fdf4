//! The non-smooth states inside one load increment: wrinkle states of the membranes and
//! stick/slip states of the sleeve points, with one chatter policy for both.
//!
//! ```text
//! iterations < freeze_after        states follow the laws (mixed wrinkling criterion, return map)
//! still changing at freeze_after   the states are frozen until the residual converges
//! converged with frozen states     re-check with the laws' own states: accept when they agree,
//!                                  or when the laws' residual also meets the tolerance (an
//!                                  element on a state border, where stress is continuous);
//!                                  otherwise unfreeze and iterate on (at most max_unfreeze
//!                                  times, then the increment fails with "chatter")
//! ```
//! Stick/slip states start every increment from the last converged ones (trial state of the
//! return map); the path follower keeps the last converged ones, so a failed increment
//! restores them.

use super::slip::return_map;
use super::{push_log, Settings};
use crate::model::sleeve::Contact;
use crate::model::wrinkling::WrinkleState;
use crate::model::Model;

pub(super) struct ActiveSet {
    /// Wrinkle states frozen against chatter (None: the mixed criterion decides).
    pub wrinkle_frozen: Option<Vec<WrinkleState>>,
    previous: Vec<WrinkleState>,
    /// Trial stick/slip state of every sleeve point.
    pub contact: Vec<Contact>,
    contact_frozen: bool,
    freeze_at: usize,
    freeze_after: usize,
    unfreezes: usize,
    max_unfreeze: usize,
    merge_gap: f64,
}

/// What the re-check at a converged point decided.
pub(super) enum Recheck {
    /// The states are the laws' own (or indistinguishable at the tolerance): converged.
    Accept,
    /// The frozen states were wrong: iterate on with the laws' states.
    IterateOn,
}

impl ActiveSet {
    pub fn new(contact: Vec<Contact>, settings: &Settings) -> ActiveSet {
        ActiveSet {
            wrinkle_frozen: None,
            previous: Vec::new(),
            contact,
            contact_frozen: false,
            freeze_at: settings.freeze_after,
            freeze_after: settings.freeze_after,
            unfreezes: 0,
            max_unfreeze: settings.max_unfreeze,
            merge_gap: settings.merge_gap,
        }
    }

    /// Record the wrinkle states of this iteration's assembly; freeze them when they still
    /// change at or after the freeze iteration.
    pub fn observe_wrinkles(
        &mut self,
        it: usize,
        states: Vec<WrinkleState>,
        log: &mut Vec<String>,
    ) {
        if self.wrinkle_frozen.is_none() && it >= self.freeze_at && states != self.previous {
            let changed = states
                .iter()
                .zip(&self.previous)
                .filter(|(a, b)| a != b)
                .count();
            push_log(log, format!("  wrinkle states still changing ({changed} elements): frozen until convergence"));
            self.wrinkle_frozen = Some(states.clone());
        }
        self.previous = states;
    }

    /// Return map of every sleeve point at `u` (unless frozen); returns how many states
    /// changed, and freezes them when they still change at or after the freeze iteration.
    pub fn update_contact(
        &mut self,
        it: usize,
        model: &Model,
        u: &mut [f64],
        committed: &[f64],
        log: &mut Vec<String>,
    ) -> usize {
        if self.contact.is_empty() {
            return 0;
        }
        // Sleeve points that reach their neighbour merge, frozen or not (`order.rs`).
        let merged = super::order::close_gaps(model, u, &mut self.contact, self.merge_gap);
        if merged > 0 {
            push_log(
                log,
                format!("  {merged} sleeve points reached their neighbour: merged"),
            );
        }
        if self.contact_frozen {
            return merged;
        }
        let changed = return_map(model, u, committed, &mut self.contact, 0.0);
        if changed > 0 && it >= self.freeze_at {
            push_log(log, format!("  stick/slip states still changing ({changed} points): frozen until convergence"));
            self.contact_frozen = true;
        }
        changed + merged
    }

    /// At a point that meets the tolerance: are the states the laws' own? `natural_wrinkles`
    /// gives the laws' wrinkle states and the free residual with them (called only when
    /// wrinkle states are frozen); `tol_f` is the force tolerance of the cone test.
    pub fn recheck(
        &mut self,
        it: usize,
        model: &Model,
        u: &[f64],
        committed: &[f64],
        tol_f: f64,
        tolerance_met: impl FnOnce() -> (Vec<WrinkleState>, bool),
        log: &mut Vec<String>,
    ) -> Result<Recheck, String> {
        let contact_ok = {
            let mut check = self.contact.clone();
            return_map(model, u, committed, &mut check, tol_f) == 0
        };
        let wrinkle_ok = match self.wrinkle_frozen.take() {
            None => true,
            Some(frozen) => {
                let (natural, met) = tolerance_met();
                natural == frozen || met
            }
        };
        if contact_ok && wrinkle_ok {
            return Ok(Recheck::Accept);
        }
        self.unfreezes += 1;
        if self.unfreezes > self.max_unfreeze {
            return Err(if wrinkle_ok {
                "stick/slip states keep changing (chatter)".into()
            } else {
                "wrinkle states keep changing (chatter)".into()
            });
        }
        push_log(
            log,
            "  frozen states were wrong at convergence: iterating on".into(),
        );
        self.contact_frozen = false;
        self.wrinkle_frozen = None;
        self.freeze_at = it + self.freeze_after;
        Ok(Recheck::IterateOn)
    }
}
