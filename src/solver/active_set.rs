//! The non-smooth states inside one load increment: wrinkle states of the membranes and
//! stick/slip states of the sleeve points, with one chatter policy for both.
//!
//! ```text
//! iterations < freeze_after        states follow the laws (mixed wrinkling criterion, return map)
//! from freeze_after on             wrinkles: a triangle back in the state it had two
//!                                  iterations ago after leaving it (A → B → A: chatter, not
//!                                  evolution) is frozen in that state until the residual
//!                                  converges; the others keep following the law
//! from 2 · freeze_after on         every triangle that still changes is frozen as well
//!                                  stick/slip: all frozen when any still changes (from
//!                                  freeze_after on)
//! converged with frozen states     re-check with the laws' own states: accept when they agree,
//!                                  or when the laws' residual also meets the tolerance (an
//!                                  element on a state border, where stress is continuous);
//!                                  otherwise unfreeze and iterate on (at most max_unfreeze
//!                                  times, then the increment fails with "chatter"); wrinkle
//!                                  states found wrong follow the law for the rest of the
//!                                  increment (refreezing them leads back to the same wrong
//!                                  equilibrium: hard case j)
//! ```
//! Freezing only the chattering triangles matters: a frozen state is evaluated outside its own
//! region (a frozen wrinkled triangle then carries compression along its tension direction, a
//! frozen slack one ignores its stretch), so freezing triangles that were only evolving towards
//! their final state sends Newton towards the equilibrium of a wrong law. Measured on the
//! sheared film at 0.1 mm separation: median 143 → 13 iterations per step against freezing
//! every changing triangle at iteration 6 (docs/solver.md).
//!
//! Stick/slip states start every increment from the last converged ones (trial state of the
//! return map); the path follower keeps the last converged ones, so a failed increment
//! restores them.

use super::report::push_log;
use super::settings::Settings;
use super::slip::return_map;
use crate::model::sleeve::Contact;
use crate::model::wrinkling::WrinkleState;
use crate::model::Model;

pub(super) struct ActiveSet {
    /// Wrinkle states frozen against chatter (None: the mixed criterion decides everywhere;
    /// per element, None: the law decides).
    pub wrinkle_frozen: Option<Vec<Option<WrinkleState>>>,
    previous: Vec<WrinkleState>,
    /// Wrinkle states of the iteration before `previous`.
    before: Vec<WrinkleState>,
    /// This iteration's wrinkle states (the three buffers rotate: no allocation per
    /// iteration once they have their size).
    current: Vec<WrinkleState>,
    /// The storage of `wrinkle_frozen` while it is None (reused when states freeze again).
    spare_frozen: Vec<Option<WrinkleState>>,
    /// Trial stick/slip state of every sleeve point.
    pub contact: Vec<Contact>,
    contact_frozen: bool,
    freeze_at: usize,
    freeze_after: usize,
    unfreezes: usize,
    max_unfreeze: usize,
    /// Wrinkle states follow the law for the rest of the increment: set when frozen wrinkle
    /// states turned out wrong at a converged point.
    wrinkles_released: bool,
    merge_gap: f64,
}

/// What the re-check at a converged point decided.
pub(super) enum Recheck {
    /// The states are the laws' own (or indistinguishable at the tolerance): converged.
    Accept,
    /// The frozen states were wrong: iterate on with the laws' states.
    IterateOn,
    /// The frozen states were wrong once too often: the increment fails (why: which states
    /// keep changing).
    Chatter(&'static str),
}

impl ActiveSet {
    pub fn new(contact: Vec<Contact>, settings: &Settings) -> ActiveSet {
        ActiveSet {
            wrinkle_frozen: None,
            previous: Vec::new(),
            before: Vec::new(),
            current: Vec::new(),
            spare_frozen: Vec::new(),
            contact,
            contact_frozen: false,
            freeze_at: settings.freeze_after,
            freeze_after: settings.freeze_after,
            unfreezes: 0,
            max_unfreeze: settings.max_unfreeze,
            wrinkles_released: false,
            merge_gap: settings.merge_gap,
        }
    }

    /// Record the wrinkle states of this iteration's assembly; at or after the freeze
    /// iteration, freeze the elements that are chattering: back in the state they had two
    /// iterations ago after leaving it (A → B → A), in their current state.
    pub fn observe_wrinkles(
        &mut self,
        it: usize,
        states: impl Iterator<Item = WrinkleState>,
        log: &mut Vec<String>,
    ) {
        self.current.clear();
        self.current.extend(states);
        if self.wrinkle_frozen.is_none() {
            // The frozen states' storage, had at the increment's first iteration rather than
            // at the freeze iteration (the same allocation, once per increment).
            let n = self.current.len();
            self.spare_frozen
                .reserve_exact(n.saturating_sub(self.spare_frozen.len()));
        }
        let states = &self.current;
        if it >= self.freeze_at
            && !self.wrinkles_released
            && self.previous.len() == states.len()
            && self.before.len() == states.len()
        {
            let spare = &mut self.spare_frozen;
            let frozen = self.wrinkle_frozen.get_or_insert_with(|| {
                let mut v = std::mem::take(spare);
                v.clear();
                v.resize(states.len(), None);
                v
            });
            let mut newly = 0;
            // Past twice the freeze iteration every element still changing is frozen too.
            let late = it >= self.freeze_at + self.freeze_after;
            for (e, f) in frozen.iter_mut().enumerate() {
                let chatter = states[e] == self.before[e] && states[e] != self.previous[e];
                let changing = late && states[e] != self.previous[e];
                if f.is_none() && (chatter || changing) {
                    *f = Some(states[e]);
                    newly += 1;
                }
            }
            if newly > 0 {
                push_log(
                    log,
                    format!(
                        "  wrinkle states of {newly} elements chatter: frozen until convergence"
                    ),
                );
            }
            if frozen.iter().all(Option::is_none) {
                if let Some(v) = self.wrinkle_frozen.take() {
                    self.spare_frozen = v;
                }
            }
        }
        // before <- previous <- current; the old `before` buffer is the next `current`.
        std::mem::swap(&mut self.before, &mut self.previous);
        std::mem::swap(&mut self.previous, &mut self.current);
    }

    /// Return map of every sleeve point at `u` (unless frozen); returns how many states
    /// changed, and freezes them when they still change at or after the freeze iteration.
    pub fn update_contact(
        &mut self,
        it: usize,
        model: &Model,
        u: &mut [f64],
        committed: &mut [f64],
        settled: bool,
        log: &mut Vec<String>,
    ) -> usize {
        if self.contact.is_empty() {
            return 0;
        }
        // Sleeve points that reach their neighbour merge, frozen or not (`order.rs`).
        let merged =
            super::order::close_gaps(model, u, &mut self.contact, committed, self.merge_gap);
        if merged > 0 {
            push_log(
                log,
                format!("  {merged} sleeve points reached their neighbour: merged"),
            );
        }
        if self.contact_frozen || !settled {
            return merged;
        }
        let changed = return_map(model, u, committed, &mut self.contact, 0.0);
        if changed > 0 && it >= self.freeze_at {
            push_log(log, format!("  stick/slip states still changing ({changed} points): frozen until convergence"));
            self.contact_frozen = true;
        }
        changed + merged
    }

    /// Merge now the touching pairs the Newton step `ds` predicts (`order::predicted_closures`);
    /// returns how many merged.
    pub fn close_predicted(
        &mut self,
        model: &Model,
        u: &mut [f64],
        committed: &mut [f64],
        ds: &[f64],
        log: &mut Vec<String>,
    ) -> usize {
        if self.contact.is_empty() || self.contact_frozen {
            return 0;
        }
        let close = super::order::predicted_closures(model, u, &self.contact, ds, self.merge_gap);
        if !close.contains(&true) {
            return 0;
        }
        let merged =
            super::order::close_where(model, u, &mut self.contact, committed, |e, _| close[e]);
        if merged > 0 {
            push_log(
                log,
                format!(
                    "  {merged} sleeve points the Newton step carries onto their neighbour: merged"
                ),
            );
        }
        merged
    }

    /// At a point that meets the tolerance: are the states the laws' own? `natural_wrinkles`
    /// gives the laws' wrinkle states and the free residual with them (called only when
    /// wrinkle states are frozen); `tol_f` is the force tolerance of the cone test.
    #[allow(clippy::too_many_arguments)] // the re-check needs the whole iterate and its closure
    pub fn recheck(
        &mut self,
        it: usize,
        model: &Model,
        u: &[f64],
        committed: &[f64],
        tol_f: f64,
        tolerance_met: impl FnOnce() -> (Vec<WrinkleState>, bool),
        log: &mut Vec<String>,
    ) -> Recheck {
        let contact_ok = {
            let mut check = self.contact.clone();
            return_map(model, u, committed, &mut check, tol_f) == 0
        };
        let wrinkle_ok = match self.wrinkle_frozen.take() {
            None => true,
            Some(frozen) => {
                let (natural, met) = tolerance_met();
                let agree = frozen
                    .iter()
                    .zip(&natural)
                    .all(|(f, n)| f.is_none_or(|s| s == *n));
                agree || met
            }
        };
        if contact_ok && wrinkle_ok {
            return Recheck::Accept;
        }
        self.unfreezes += 1;
        if self.unfreezes > self.max_unfreeze {
            return Recheck::Chatter(if wrinkle_ok {
                "stick/slip states keep changing (chatter)"
            } else {
                "wrinkle states keep changing (chatter)"
            });
        }
        push_log(
            log,
            "  frozen states were wrong at convergence: iterating on".into(),
        );
        self.contact_frozen = false;
        self.wrinkle_frozen = None;
        self.wrinkles_released |= !wrinkle_ok;
        self.freeze_at = it + self.freeze_after;
        Recheck::IterateOn
    }
}
