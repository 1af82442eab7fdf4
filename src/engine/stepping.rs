//! A step of the engine, one increment at a time: the solver's [`Stepper`] over the committed
//! state, for every driver. [`Engine::solve`] (the CLI, FMI 2) runs it to the end; FMI 3's
//! intermediate update reports each increment and may stop after one (early return).
//!
//! ```text
//! begin_step()        the load change applied → inputs, from the committed equilibrium (the
//!                     model rebuilt if a parameter changed, the step's memory probed)
//! advance(&mut step)  one increment attempt of the stepper (accepted: λ moves; rejected: cut
//!                     back, and below the smallest increment the step has failed)
//! end_step(step)      commit at the λ reached (all of the step, or where the caller stopped);
//!                     a failed step commits nothing
//! ```
//! Both drivers take the same increments, so they reach the same equilibrium bit for bit.

use super::Engine;
use crate::error::Error;
use crate::memory;
use crate::model::state::History;
use crate::solver::{Attempt, Outcome, StepReport, Stepper};

/// One step in progress.
pub struct Step {
    stepper: Stepper,
    /// Why arc length does not apply to this step, for the log (None: it does, or the scene
    /// asks for load control).
    fallback: Option<&'static str>,
    /// What the coarse start did (`coarse.rs`), for the log.
    coarse: Vec<String>,
}

/// What one increment attempt did.
#[derive(Clone, Debug, PartialEq)]
pub struct Increment {
    /// The load fraction of the step reached (after a cut-back: the one still held).
    pub lambda: f64,
    /// The increment converged (else it was cut back, or the step failed).
    pub converged: bool,
    /// The step has failed (the smallest increment did not converge).
    pub failed: bool,
    pub iterations: usize,
}

impl Step {
    /// The load fraction of the step reached so far.
    pub fn lambda(&self) -> f64 {
        self.stepper.lambda()
    }
}

impl Engine {
    /// Why a state under ponding load channel `l` at level `h` is refused.
    fn ponding_reason(&self, l: usize, h: f64, where_: &str) -> String {
        let name = self
            .variables
            .iter()
            .find(|v| {
                matches!(v.binding, crate::variables::Binding::Input(s) if (s..s + v.len().max(1)).contains(&l))
            })
            .map_or("?", |v| v.name.as_str());
        format!(
            "under the ponding input {name} (water level {h} m) the tangent {where_} is not positive definite: the water's weight grows faster with the deflection than the membrane's tension resists it (ponding instability; docs/mechanics.md §3.2)"
        )
    }

    /// Start a step to the current inputs (see the module docs).
    pub fn begin_step(&mut self) -> Step {
        self.tangent = None;
        let rebuilt = if self.model_stale {
            self.rebuild()
        } else {
            Ok(())
        };
        // Probed before the stepper copies the state: those copies are part of what it checks.
        let ready = rebuilt.and_then(|()| self.probe_step());
        let s = &self.state;
        let history = History {
            contact: s.slip_state.clone(),
            plastic: s.plastic.clone(),
        };
        let dynamic = super::integration(&self.scene).filter(|_| self.duration > 0.0);
        let is_dynamic = dynamic.is_some();
        let mut stepper = match dynamic {
            // A step of time integration (docs/dynamics.md).
            Some(integration) => Stepper::begin_dynamic(
                &mut self.solver,
                &self.model,
                &integration,
                self.duration,
                &s.applied,
                &s.inputs,
                &s.displacement,
                (&s.velocity, &s.acceleration),
                &history,
            ),
            None => Stepper::begin(
                &mut self.solver,
                &self.model,
                &s.applied,
                &s.inputs,
                &s.displacement,
                &history,
            ),
        };
        // The coarse start (coarse.rs): Newton on the whole step first from the coarser
        // mesh's answer.
        let mut coarse = Vec::new();
        if ready.is_ok() {
            match self.coarse_guess(is_dynamic) {
                Some(Ok(guess)) => {
                    stepper = stepper.with_guess(guess.start);
                    coarse = guess.log;
                }
                Some(Err(why)) => coarse.push(format!(
                    "coarse start not used ({why}): the step starts from the undeformed state"
                )),
                None => {}
            }
        }
        // Under arc length a step the arc-length corrector cannot take is load-controlled as a
        // whole: the log says so (docs/solver.md, arc length).
        let fallback = if self.scene.solver.path == crate::scene::PathMethod::ArcLength
            && s.applied != s.inputs
        {
            crate::solver::Solver::arc_length_fallback(&self.model, &s.applied, &s.inputs)
        } else {
            None
        };
        if let Err(e) = ready {
            stepper.fail(e.to_string());
        }
        Step {
            stepper,
            fallback,
            coarse,
        }
    }

    /// The step's working memory and the copies kept to undo it, probed before it starts: an
    /// allocation failure inside a step would abort the host.
    fn probe_step(&self) -> Result<(), Error> {
        if self.scene.debug.skip_memory_probes {
            return Ok(());
        }
        let state_bytes = 8
            * (self.state.displacement.len()
                + self.state.slip_state.len()
                + self.state.plastic.len()) as u64
            + 9 * self.state.wrinkle.len() as u64;
        // A step of time integration keeps the end points of up to MAX_CHAIN sub-steps for
        // its derivatives (unknowns and loads each).
        let chain_bytes = if super::integration(&self.scene).is_some() && self.duration > 0.0 {
            8 * (crate::solver::dynamic::MAX_CHAIN
                * (self.state.displacement.len() + self.state.applied.len())) as u64
        } else {
            0
        };
        let step_bytes = self
            .solver
            .step_bytes(&self.model)
            .saturating_add(2 * state_bytes)
            .saturating_add(chain_bytes);
        Ok(memory::probe(step_bytes, "the step's working memory")?)
    }

    /// One increment attempt; None once the step is complete or has failed.
    pub fn advance(&mut self, step: &mut Step) -> Option<Increment> {
        self.tangent = None;
        let attempt = step.stepper.advance(&mut self.solver, &self.model)?;
        Some(match attempt {
            Attempt::Accepted { lambda, iterations } => Increment {
                lambda,
                converged: true,
                failed: false,
                iterations,
            },
            Attempt::Rejected {
                lambda,
                iterations,
                failed,
            } => Increment {
                lambda,
                converged: false,
                failed,
                iterations,
            },
        })
    }

    /// Commit the step at the load fraction it reached (nothing if it failed). The report's
    /// `reached` is that fraction; `outcome` is Converged unless the step failed or its
    /// equilibrium cannot be committed (outputs that cannot be evaluated, a non-finite state).
    pub fn end_step(&mut self, step: Step) -> StepReport {
        self.tangent = None;
        let applied = step.stepper.applied();
        let previous = self.state.clone();
        // A dynamic step's velocities and accelerations; a static solve of a scene with time
        // integration (its initialization) ends at rest.
        let motion = step
            .stepper
            .motion()
            .filter(|_| !step.stepper.has_failed())
            .map(|(v, a)| (v.to_vec(), a.to_vec()));
        // What the state will be the end of (committed below only with the state).
        let mut step = step;
        let last_step = match step.stepper.substeps() {
            Some((substeps, dt)) => super::LastStep::Dynamic {
                substeps,
                dt,
                whole: step.stepper.lambda() >= 1.0,
                // One sub-step's end is the committed state: nothing to keep.
                points: step.stepper.take_points().filter(|_| substeps > 1),
                rest: false,
            },
            None => super::LastStep::Static,
        };
        let s = &mut self.state;
        let mut history = History {
            contact: std::mem::take(&mut s.slip_state),
            plastic: std::mem::take(&mut s.plastic),
        };
        let mut report = step.stepper.finish(&mut s.displacement, &mut history);
        history.install(&self.model);
        (s.slip_state, s.plastic) = (history.contact, history.plastic);
        if report.converged() {
            match motion {
                Some((v, a)) => (s.velocity, s.acceleration) = (v, a),
                None => {
                    s.velocity.fill(0.0);
                    s.acceleration.fill(0.0);
                }
            }
        }
        for (k, line) in std::mem::take(&mut step.coarse).into_iter().enumerate() {
            report.log.insert(k, line);
        }
        if let Some(why) = step.fallback {
            report.log.insert(
                0,
                format!("arc length does not apply ({why}): the step is load-controlled"),
            );
        }
        let ponding = crate::solver::stability::has_ponding(&self.model);
        if !report.converged() {
            // Water past the ponding threshold: say so rather than only that Newton failed.
            if ponding {
                let s = &self.state;
                if let Some(l) = crate::solver::stability::ponding_unstable(
                    &self.model,
                    &s.displacement,
                    &s.inputs,
                ) {
                    report.message = format!(
                        "{}; {}",
                        report.message,
                        self.ponding_reason(l, s.inputs[l], "at the last equilibrium")
                    );
                }
            }
            return report;
        }
        // An equilibrium under ponding water whose tangent is not positive definite is not
        // one the water stays in: refused, with the reason (docs/mechanics.md §3.2).
        if ponding {
            if let Some(l) = crate::solver::stability::ponding_unstable(
                &self.model,
                &self.state.displacement,
                &applied,
            ) {
                let why = self.ponding_reason(l, applied[l], "at the equilibrium found");
                self.state = previous;
                self.model.plastic.set(&self.state.plastic);
                report.outcome = Outcome::Failed;
                report.reached = 0.0;
                report.message = format!("the equilibrium found is unstable: {why}");
                return report;
            }
        }
        // The same under a given water volume: the tangent with the level eliminated
        // (`stability::water_volume_stable`; docs/mechanics.md §3.2).
        if crate::solver::stability::water_volume_stable(
            &self.model,
            &self.state.displacement,
            &applied,
        ) == Some(false)
        {
            self.state = previous;
            self.model.plastic.set(&self.state.plastic);
            report.outcome = Outcome::Failed;
            report.reached = 0.0;
            report.message = "the equilibrium found is unstable: under the given water volume the tangent with the water level eliminated is not positive definite (a ponding instability that moves the water within the volume; docs/mechanics.md §3.2)".into();
            return report;
        }
        self.state.applied = applied;
        self.state.last_iterations = report.iterations as u32;
        if let Err(e) = self.refresh_outputs() {
            // Back to the state the outputs belong to. A failed memory probe changed nothing;
            // a failed natural_frequency output came after the other outputs, which are
            // evaluated again for the previous state.
            self.state = previous;
            self.model.plastic.set(&self.state.plastic);
            if matches!(e, Error::Memory(_)) {
                return StepReport::failed_with(e.to_string());
            }
            let _ = self.refresh_outputs();
            return StepReport::failed_with(e.to_string());
        }
        // A converged answer is never returned non-finite: loads so large that a position, a
        // length or a stress overflows are a failed step, and nothing is committed.
        if let Some(what) = self.non_finite() {
            self.state = previous;
            // The memory of the refresh just made is there again.
            let _ = self.refresh_outputs();
            report.outcome = Outcome::Failed;
            report.reached = 0.0;
            report.message = format!(
                "the equilibrium found is not finite ({what}); the loads overflow the model's numbers"
            );
            return report;
        }
        // Short of the end (early return) the inputs are not yet the applied ones, so the
        // engine is settled only after a whole step.
        self.converged = true;
        self.last_step = last_step;
        report
    }
}

#[cfg(test)]
mod tests {
    use crate::Engine;

    /// A start that Newton cannot take (the coarse start's, here made far off by hand: every
    /// node 0.2 m out of the plane, up and down in turn) costs its attempt and nothing else:
    /// the step goes on from the undeformed state, says so, and reaches the equilibrium the
    /// step without it reaches. TOLERANCE: 1e-12 relative (the same path after the attempt; the
    /// solver's kept factorizations may differ, so round-off, not bits).
    #[test]
    fn a_start_newton_cannot_take_leaves_the_step_as_without_it() {
        let text = include_str!("../../modelDescription/HenckyDisc/scene.json");
        let mut scene = crate::Scene::from_json(text).expect("the shipped scene");
        scene.solver.coarse_start = crate::scene::CoarseStart::Off;
        scene.solver.max_iterations = 12;
        let pressure = |e: &Engine| {
            e.variables()
                .iter()
                .find(|v| v.name == "pressure")
                .expect("input")
                .value_reference
        };
        let mut plain = Engine::try_new(scene.clone()).expect("valid");
        plain.set_real(pressure(&plain), 40.0).expect("set");
        let want = plain.solve();
        assert!(want.converged(), "{}", want.message);

        let mut e = Engine::try_new(scene).expect("valid");
        e.set_real(pressure(&e), 40.0).expect("set");
        let mut step = e.begin_step();
        let bad: Vec<f64> = (0..e.state.displacement.len())
            .map(|i| {
                if i % 3 == 2 {
                    0.2 * (1.0 - 2.0 * ((i / 3) % 2) as f64)
                } else {
                    0.0
                }
            })
            .collect();
        step.stepper = step.stepper.with_guess(bad);
        while e.advance(&mut step).is_some() {}
        let got = e.end_step(step);
        assert!(got.converged(), "{}", got.message);
        for l in got.log.iter().filter(|l| l.starts_with("from the coarse")) {
            println!(
                "{l}; then {} iterations in all, {} without the start",
                got.iterations, want.iterations
            );
        }
        assert!(
            got.log
                .iter()
                .any(|l| l.starts_with("from the coarse mesh's answer:")
                    && l.ends_with("the step goes on from its start")),
            "{:?}",
            got.log
        );
        assert!(
            got.iterations > want.iterations,
            "the attempt's iterations are counted"
        );
        let (a, b) = (&plain.state.displacement, &e.state.displacement);
        let largest = a.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let apart = a
            .iter()
            .zip(b)
            .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
        assert!(apart <= 1e-12 * largest, "{apart:e} of {largest:e}");
    }
}
