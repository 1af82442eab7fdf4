//! Status queries (`fmi2Get*Status`). Only two exist for a synchronous FMU:
//!
//! ```text
//! fmi2GetRealStatus(fmi2LastSuccessfulTime)   the time reached (the step start after a Discard)
//! fmi2GetBooleanStatus(fmi2Terminated)        true after a Discard: the FMU cannot go on
//! ```
//!
//! Every other kind (fmi2DoStepStatus, fmi2PendingStatus, Integer and String status) belongs
//! to asynchronous stepping and is an Error with a message.

use super::Instance;
use crate::error::Error;
use crate::fmi::fmi2_ffi::{
    Status, FMI2_DO_STEP_STATUS, FMI2_LAST_SUCCESSFUL_TIME, FMI2_TERMINATED,
};
use crate::fmi::fsm::Func;

/// A status kind this FMU has not (named in the message).
fn bad_kind(message: String) -> Error {
    Error::Argument {
        argument: "s",
        message,
    }
}

impl Instance {
    /// `fmi2GetStatus`: only fmi2DoStepStatus exists, for asynchronous steps, which this FMU
    /// does not do.
    pub fn get_status(&mut self, kind: i32) -> Status {
        self.call(Func::GetStatus, format!("kind={kind}"), |_| {
            Err(bad_kind(match kind {
                FMI2_DO_STEP_STATUS => {
                    "fmi2DoStepStatus is not available: this FMU never returns fmi2Pending".into()
                }
                _ => format!("status kind {kind} is not a fmi2Status kind"),
            }))
        })
    }

    /// `fmi2GetRealStatus(fmi2LastSuccessfulTime)`.
    pub fn get_real_status(
        &mut self,
        kind: i32,
        store: impl FnOnce(f64) -> Result<(), Error>,
    ) -> Status {
        self.call(Func::GetRealStatus, format!("kind={kind}"), |s| match kind {
            FMI2_LAST_SUCCESSFUL_TIME => store(s.last_successful_time).map(|_| Status::Ok),
            _ => Err(bad_kind(format!("status kind {kind} is not a Real status; only fmi2LastSuccessfulTime ({FMI2_LAST_SUCCESSFUL_TIME}) is"))),
        })
    }

    /// `fmi2GetBooleanStatus(fmi2Terminated)`: true after a discarded step.
    pub fn get_boolean_status(
        &mut self,
        kind: i32,
        store: impl FnOnce(bool) -> Result<(), Error>,
    ) -> Status {
        self.call(Func::GetBooleanStatus, format!("kind={kind}"), |s| match kind {
            FMI2_TERMINATED => store(s.wants_to_terminate).map(|_| Status::Ok),
            _ => Err(bad_kind(format!("status kind {kind} is not a Boolean status; only fmi2Terminated ({FMI2_TERMINATED}) is"))),
        })
    }

    /// `fmi2GetIntegerStatus` / `fmi2GetStringStatus`: no status kind has these types here.
    pub fn no_such_status(&mut self, func: Func, kind: i32) -> Status {
        self.call(func, format!("kind={kind}"), |_| {
            Err(bad_kind(format!(
                "status kind {kind} is not available as this type (no asynchronous steps)"
            )))
        })
    }
}
