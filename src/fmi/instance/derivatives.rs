//! `fmi2GetDirectionalDerivative`, `fmi3GetDirectionalDerivative` and
//! `fmi3GetAdjointDerivative`: value references to the engine's output and input slots, the
//! counts checked, then [`Engine::directional_derivative`] / [`Engine::adjoint_derivative`]
//! on the instance's worker thread.
//!
//! ```text
//! unknowns   Real outputs (FMI 3: Float64 outputs, arrays by all their elements)
//! knowns     inputs and parameters (tunable or fixed)
//! FMI 2      one value per value reference (array elements are scalars there)
//! FMI 3      nSeed / nSensitivity = the element counts of knowns / unknowns (forward) or of
//!            unknowns / knowns (adjoint)
//! states     Initialization Mode (the initial equilibrium is solved first), Step Mode,
//!            StepFailed (the last converged equilibrium), Terminated
//! ```

use super::Instance;
use crate::engine::derivatives::Known;
use crate::error::Error;
use crate::fmi::fmi2_ffi::Status;
use crate::fmi::fsm::Func;
use crate::variables::{Binding, Causality, VarType, Variable};

/// Which table the value references are in.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Table {
    /// FMI 2: scalars.
    Scalars,
    /// FMI 3: variables with their arrays.
    Arrays,
}

impl Instance {
    /// `fmi2GetDirectionalDerivative`: dvUnknown = J · dvKnown.
    pub fn directional_derivative_fmi2(
        &mut self,
        unknowns: Result<&[u32], Error>,
        knowns: Result<&[u32], Error>,
        seed: Result<&[f64], Error>,
        sensitivity: Result<&mut [f64], Error>,
    ) -> Status {
        let args = self.args(|| {
            format!(
                "vUnknown_ref={:?}, vKnown_ref={:?}",
                unknowns.as_deref().unwrap_or_default(),
                knowns.as_deref().unwrap_or_default()
            )
        });
        self.call(Func::GetDirectionalDerivative, args, |s| {
            let (unknowns, knowns, seed, out) = (unknowns?, knowns?, seed?, sensitivity?);
            s.derivative(Table::Scalars, false, unknowns, knowns, seed, out)
        })
    }

    /// `fmi3GetDirectionalDerivative` (`adjoint` false) and `fmi3GetAdjointDerivative`.
    pub fn derivative_fmi3(
        &mut self,
        adjoint: bool,
        unknowns: Result<&[u32], Error>,
        knowns: Result<&[u32], Error>,
        seed: Result<&[f64], Error>,
        sensitivity: Result<&mut [f64], Error>,
    ) -> Status {
        let name = if adjoint {
            "fmi3GetAdjointDerivative"
        } else {
            "fmi3GetDirectionalDerivative"
        };
        let args = self.args(|| {
            format!(
                "unknowns={:?}, knowns={:?}",
                unknowns.as_deref().unwrap_or_default(),
                knowns.as_deref().unwrap_or_default()
            )
        });
        self.call_as(name, Func::GetDirectionalDerivative, args, |s| {
            let (unknowns, knowns, seed, out) = (unknowns?, knowns?, seed?, sensitivity?);
            s.derivative(Table::Arrays, adjoint, unknowns, knowns, seed, out)
        })
    }

    fn derivative(
        &mut self,
        table: Table,
        adjoint: bool,
        unknowns: &[u32],
        knowns: &[u32],
        seed: &[f64],
        out: &mut [f64],
    ) -> Result<Status, Error> {
        let outputs = self.unknown_slots(table, unknowns)?;
        let inputs = self.known_slots(table, knowns)?;
        let (n_seed, n_out) = if adjoint {
            (outputs.len(), inputs.len())
        } else {
            (inputs.len(), outputs.len())
        };
        let counts = |what: &'static str, given: usize, expected: usize| {
            if given == expected {
                Ok(())
            } else {
                Err(Error::Argument {
                    argument: what,
                    message: format!(
                        "{what} has {given} values, expected {expected} (the element count of the {})",
                        if (what == "seed") != adjoint { "knowns" } else { "unknowns" }
                    ),
                })
            }
        };
        counts("seed", seed.len(), n_seed)?;
        counts("sensitivity", out.len(), n_out)?;
        if outputs.is_empty() || inputs.is_empty() {
            out.fill(0.0);
            return Ok(Status::Ok);
        }
        if self.fsm == crate::fmi::fsm::FsmState::InitializationMode {
            self.solve_initial()?;
        }
        if self.poisoned {
            return Err(Error::Poisoned);
        }
        let engine = &mut self.engine;
        let result = self.worker.run(|| {
            if adjoint {
                engine.adjoint_derivative(&outputs, seed, &inputs)
            } else {
                engine.directional_derivative(&inputs, seed, &outputs)
            }
        });
        let values = result?;
        out.copy_from_slice(&values);
        Ok(Status::Ok)
    }

    /// The variable of a value reference in the table, named in errors.
    fn derivative_variable(
        &self,
        table: Table,
        argument: &'static str,
        vr: u32,
    ) -> Result<Variable, Error> {
        let vars = match table {
            Table::Scalars => self.engine.variables(),
            Table::Arrays => self.engine.arrays(),
        };
        vars.iter()
            .find(|v| v.value_reference == vr)
            .cloned()
            .ok_or_else(|| Error::Argument {
                argument,
                message: format!("no variable has value reference {vr}"),
            })
    }

    /// Output slots of the unknowns (every element of an array).
    fn unknown_slots(&self, table: Table, vr: &[u32]) -> Result<Vec<usize>, Error> {
        let mut slots = Vec::new();
        for &r in vr {
            let v = self.derivative_variable(table, "unknowns", r)?;
            match v.binding {
                Binding::Output(k) if v.var_type == VarType::Real => slots.extend(k..k + v.len()),
                _ => {
                    return Err(Error::Argument {
                        argument: "unknowns",
                        message: format!(
                            "unknown {} (value reference {r}) is not a continuous Real output",
                            v.name
                        ),
                    })
                }
            }
        }
        Ok(slots)
    }

    /// Inputs (every element of an array) and parameters of the knowns.
    fn known_slots(&self, table: Table, vr: &[u32]) -> Result<Vec<Known>, Error> {
        let mut slots = Vec::new();
        for &r in vr {
            let v = self.derivative_variable(table, "knowns", r)?;
            match v.binding {
                Binding::Input(k) => slots.extend((k..k + v.len()).map(Known::Input)),
                Binding::Parameter(i) => slots.push(Known::Parameter(i)),
                Binding::Output(_) => {
                    debug_assert_eq!(v.causality, Causality::Output);
                    return Err(Error::Argument {
                        argument: "knowns",
                        message: format!(
                            "known {} (value reference {r}) is an output; knowns are inputs and parameters",
                            v.name
                        ),
                    });
                }
            }
        }
        Ok(slots)
    }
}
