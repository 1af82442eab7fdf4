//! The one error type of the library: invalid input or a broken invariant, always with the
//! field, variable or value reference it concerns. Non-convergence is not an error; it is a
//! [`crate::solver::StepReport`] outcome.

use crate::scene::Problem;
use std::fmt;

#[derive(Clone, Debug, PartialEq)]
pub enum Error {
    /// The scene has problems; each names its JSON path.
    Scene(Vec<Problem>),
    /// No variable has this value reference (of this type).
    UnknownValueReference { vr: u32, kind: &'static str },
    /// The variable exists but cannot be set (an output, or a fixed parameter after
    /// initialization).
    NotSettable { vr: u32, name: String, why: String },
    /// NaN or infinite value for a variable.
    NonFinite { vr: u32, name: String, value: f64 },
    /// A value outside the variable's declared [min, max] or physical range.
    OutOfRange {
        vr: u32,
        name: String,
        value: f64,
        why: String,
    },
    /// A file could not be read or written.
    Io { path: String, message: String },
    /// Saved state bytes that do not belong to this model or are damaged.
    State(String),
    /// An allocation that grows with the scene failed (the size limits passed, the process
    /// could not get the memory); nothing was changed.
    Memory(crate::memory::OutOfMemory),
    /// The scene asks for form finding and no equilibrium shape was found (the message says
    /// after how many iterations and why).
    FormFinding(String),
}

impl From<crate::memory::OutOfMemory> for Error {
    fn from(e: crate::memory::OutOfMemory) -> Error {
        Error::Memory(e)
    }
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::Scene(problems) => {
                write!(f, "the scene has {} problem(s):", problems.len())?;
                for p in problems {
                    write!(f, "\n  {p}")?;
                }
                Ok(())
            }
            Error::UnknownValueReference { vr, kind } => {
                write!(f, "no {kind} variable has value reference {vr}")
            }
            Error::NotSettable { vr, name, why } => {
                write!(f, "variable {name} (value reference {vr}) cannot be set: {why}")
            }
            Error::NonFinite { vr, name, value } => write!(
                f,
                "variable {name} (value reference {vr}) was given {value}; only finite values are accepted"
            ),
            Error::OutOfRange {
                vr,
                name,
                value,
                why,
            } => write!(f, "variable {name} (value reference {vr}) = {value} is out of range: {why}"),
            Error::Io { path, message } => {
                // The file path is the user's own and shown whole; the message may echo values.
                write!(f, "{path}: {}", crate::scene::read::clip(message))
            }
            Error::State(m) => write!(f, "FMU state rejected: {}", crate::scene::read::clip(m)),
            Error::Memory(e) => write!(f, "{e}"),
            Error::FormFinding(m) => write!(f, "form finding failed: {m}"),
        }
    }
}

impl std::error::Error for Error {}
