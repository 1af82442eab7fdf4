//! The FMI 2.0 co-simulation calling sequence (docs/fmu.md, the conformance checklist) as one mask of legal states per
//! function, after `modelica/Reference-FMUs` (`MASK_fmi2*`).
//!
//! ```text
//!                SetupExperiment        Enter          Exit (converged)
//! Instantiated ───────────────▶ (same) ───────▶ InitializationMode ───────▶ StepComplete
//!                                                   │ Exit not converged        │  ▲ DoStep OK
//!                                                   ▼                           ▼  │ SetFMUstate
//!                                                 Error        DoStep Discard  StepFailed
//! Terminate (StepComplete, StepFailed) ──▶ Terminated;  Reset (any) ──▶ Instantiated
//! ```
//!
//! There is no stepInProgress / stepCanceled (no asynchronous DoStep) and no fatal state (no
//! error affects other instances).

use serde::{Deserialize, Serialize};
use std::fmt;

/// State of an instance in the calling sequence.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum FsmState {
    Instantiated,
    InitializationMode,
    StepComplete,
    StepFailed,
    Terminated,
    Error,
}

impl FsmState {
    fn bit(self) -> u8 {
        1 << self as u8
    }
}

impl fmt::Display for FsmState {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        fmt::Debug::fmt(self, f)
    }
}

const I: u8 = 1 << FsmState::Instantiated as u8;
const N: u8 = 1 << FsmState::InitializationMode as u8;
const C: u8 = 1 << FsmState::StepComplete as u8;
const F: u8 = 1 << FsmState::StepFailed as u8;
const T: u8 = 1 << FsmState::Terminated as u8;
const E: u8 = 1 << FsmState::Error as u8;
const ANY: u8 = I | N | C | F | T | E;

/// The FMI functions that take an instance, with the states they are legal in.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Func {
    SetDebugLogging,
    SetupExperiment,
    EnterInitializationMode,
    ExitInitializationMode,
    Terminate,
    Reset,
    GetReal,
    GetInteger,
    GetBoolean,
    GetString,
    SetReal,
    SetInteger,
    SetBoolean,
    SetString,
    GetFmuState,
    SetFmuState,
    FreeFmuState,
    SerializedFmuStateSize,
    SerializeFmuState,
    DeSerializeFmuState,
    GetDirectionalDerivative,
    SetRealInputDerivatives,
    GetRealOutputDerivatives,
    DoStep,
    CancelStep,
    GetStatus,
    GetRealStatus,
    GetIntegerStatus,
    GetBooleanStatus,
    GetStringStatus,
}

impl Func {
    /// The C name, used to prefix every message about the call.
    pub fn name(self) -> &'static str {
        use Func::*;
        match self {
            SetDebugLogging => "fmi2SetDebugLogging",
            SetupExperiment => "fmi2SetupExperiment",
            EnterInitializationMode => "fmi2EnterInitializationMode",
            ExitInitializationMode => "fmi2ExitInitializationMode",
            Terminate => "fmi2Terminate",
            Reset => "fmi2Reset",
            GetReal => "fmi2GetReal",
            GetInteger => "fmi2GetInteger",
            GetBoolean => "fmi2GetBoolean",
            GetString => "fmi2GetString",
            SetReal => "fmi2SetReal",
            SetInteger => "fmi2SetInteger",
            SetBoolean => "fmi2SetBoolean",
            SetString => "fmi2SetString",
            GetFmuState => "fmi2GetFMUstate",
            SetFmuState => "fmi2SetFMUstate",
            FreeFmuState => "fmi2FreeFMUstate",
            SerializedFmuStateSize => "fmi2SerializedFMUstateSize",
            SerializeFmuState => "fmi2SerializeFMUstate",
            DeSerializeFmuState => "fmi2DeSerializeFMUstate",
            GetDirectionalDerivative => "fmi2GetDirectionalDerivative",
            SetRealInputDerivatives => "fmi2SetRealInputDerivatives",
            GetRealOutputDerivatives => "fmi2GetRealOutputDerivatives",
            DoStep => "fmi2DoStep",
            CancelStep => "fmi2CancelStep",
            GetStatus => "fmi2GetStatus",
            GetRealStatus => "fmi2GetRealStatus",
            GetIntegerStatus => "fmi2GetIntegerStatus",
            GetBooleanStatus => "fmi2GetBooleanStatus",
            GetStringStatus => "fmi2GetStringStatus",
        }
    }

    /// The states in which the call is legal. Unsupported functions are legal nowhere they
    /// could do something; their bodies report that they are unsupported.
    fn mask(self) -> u8 {
        use Func::*;
        match self {
            SetDebugLogging | Reset => ANY,
            SetupExperiment | EnterInitializationMode => I,
            ExitInitializationMode => N,
            Terminate => C | F,
            GetReal | GetInteger | GetBoolean | GetString => N | C | F | T | E,
            SetReal | SetInteger | SetBoolean | SetString => I | N | C,
            GetFmuState | SetFmuState | FreeFmuState => ANY,
            SerializedFmuStateSize | SerializeFmuState | DeSerializeFmuState => ANY,
            GetDirectionalDerivative => N | C | F | T,
            SetRealInputDerivatives | GetRealOutputDerivatives => ANY,
            DoStep => C,
            CancelStep => ANY,
            GetStatus | GetRealStatus | GetIntegerStatus | GetBooleanStatus | GetStringStatus => {
                C | F | T
            }
        }
    }

    /// Whether the call is legal in `state`.
    pub fn allowed_in(self, state: FsmState) -> bool {
        self.mask() & state.bit() != 0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn do_step_only_at_a_communication_point() {
        assert!(Func::DoStep.allowed_in(FsmState::StepComplete));
        for s in [
            FsmState::Instantiated,
            FsmState::InitializationMode,
            FsmState::StepFailed,
            FsmState::Error,
        ] {
            assert!(!Func::DoStep.allowed_in(s), "{s}");
        }
    }

    #[test]
    fn reset_everywhere_terminate_not_after_error() {
        assert!(Func::Reset.allowed_in(FsmState::Error));
        assert!(!Func::Terminate.allowed_in(FsmState::Error));
        assert!(!Func::Terminate.allowed_in(FsmState::Terminated));
        assert!(Func::Terminate.allowed_in(FsmState::StepFailed));
    }
}
