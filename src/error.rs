//! The one error type of the library: invalid input or a broken invariant, always with the
//! field, variable or value reference it concerns. Non-convergence is not an error; it is a
//! [`crate::solver::StepReport`] outcome: inside a step the solver turns an error of its linear
//! algebra or an inverted element into the report's message (the step is cut back or fails).
//! The FMI adapter logs an error's text on logStatusError and returns fmi2Error / fmi3Error.

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
    /// A saved state whose values do not belong to this model or are damaged (the checks of
    /// its serialized bytes: [`Error::StateBytes`]).
    State(String),
    /// An allocation that grows with the scene failed (the size limits passed, the process
    /// could not get the memory); nothing was changed.
    Memory(crate::memory::OutOfMemory),
    /// The scene asks for form finding and no equilibrium shape was found (the message says
    /// after how many iterations and why).
    FormFinding(String),
    /// The linear algebra of the tangent broke down (what broke, and where).
    LinearAlgebra(Breakdown),
    /// A solver helper thread could not be started, or its job panicked.
    Thread(ThreadFailure),
    /// An assembly found an inverted or collapsed membrane triangle: the smallest ratio of a
    /// triangle's current to its reference area.
    Inverted { area_ratio: f64 },
    /// A capability this FMU or this scene does not offer (an FMI function outside
    /// Co-Simulation, derivatives of a scene with volume inputs): what and why.
    Unsupported(String),
    /// An arc-length path traced outside a step (`Solver::trace_arc_length`, for verification)
    /// stopped: it does not apply, or an increment found no equilibrium (which, why, the
    /// Newton log). Inside a step the same is a [`crate::solver::StepReport`] outcome.
    PathStopped(String),
    /// A load table (`velarium solve --loads`) that cannot be used: its file, the 1-based line
    /// (None: the file as a whole), the cell or input on that line, and what is wrong.
    LoadTable {
        path: String,
        line: Option<usize>,
        cell: Option<String>,
        message: String,
    },
    /// A file could not be read (the operating system's reason).
    Read { path: String, reason: String },
    /// An error in the contents of a file (the FMU's `resources/scene.json`).
    InFile { path: String, error: Box<Error> },
    /// An FMI host passed NULL for a pointer this call needs; `length` is the array length
    /// that came with it.
    NullPointer {
        argument: String,
        length: Option<usize>,
    },
    /// An FMI function called in a state of the FMI state machine that does not allow it.
    IllegalCall { state: String },
    /// An FMI function called before the one that must come first.
    CallFirst {
        first: &'static str,
        then: &'static str,
    },
    /// An argument value from an FMI host that this FMU cannot accept (a count that does not
    /// match, a time or step size against the stepping rules, a value reference of the wrong
    /// kind, a GUID that is not this FMU's): `argument` names it; `message`, what the host
    /// sees, says what is wrong.
    Argument {
        argument: &'static str,
        message: String,
    },
    /// The FMI 2 resource location is not a local `file:` URI with an absolute path: the URI
    /// and why.
    ResourceUri { uri: String, why: String },
    /// The bytes of a serialized FMU state failed a check (magic, version, length, checksum,
    /// GUID, payload): which, and why.
    StateBytes { check: &'static str, why: String },
    /// The FMU instance cannot be used after an internal error (a caught panic left its
    /// engine half-updated) until the host resets it.
    Poisoned,
    /// An internal failure the host cannot fix (a caught panic, an encoder error): what
    /// happened and what is left.
    Internal(String),
    /// The FMU's initial equilibrium did not converge (how far it got and why); the instance
    /// is in state Error.
    InitialEquilibrium(String),
}

/// What broke in the linear algebra of the tangent ([`Error::LinearAlgebra`]).
#[derive(Clone, Debug, PartialEq)]
pub enum Breakdown {
    /// The tangent's largest diagonal entry is not positive and finite (its value).
    Diagonal(f64),
    /// faer's LDLT of `of` (the tangent, a half of it, the two-domain separator) failed
    /// (faer's reason).
    Factorization { of: &'static str, detail: String },
    /// A dense block of the bordered tangent is singular (which one).
    Singular(&'static str),
    /// A solve gave NaN or infinite values (what was solved for).
    NonFinite(&'static str),
    /// The fixed-point correction of the sensitivity's non-symmetric part did not settle in
    /// this many rounds.
    Unsettled { rounds: usize },
}

/// How a solver helper thread failed ([`Error::Thread`]).
#[derive(Clone, Debug, PartialEq)]
pub enum ThreadFailure {
    /// The operating system refused to start one of `count` threads (its reason).
    Start { count: usize, reason: String },
    /// A helper's job panicked (the helper lives on).
    Panicked,
}

impl fmt::Display for Breakdown {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Breakdown::Diagonal(max) => {
                write!(f, "tangent diagonal is not positive and finite (max {max:e})")
            }
            Breakdown::Factorization { of, detail } => {
                write!(f, "LDLT factorization of {of} failed: {detail}")
            }
            Breakdown::Singular(what) => write!(f, "{what} is singular"),
            Breakdown::NonFinite(what) => write!(f, "{what} is not finite"),
            Breakdown::Unsettled { rounds } => write!(
                f,
                "the tangent's correction (the follower pressure's non-symmetric load stiffness, the wrinkled and slack triangles' regularisation) did not settle in {rounds} rounds: the derivative is not defined to the solve's accuracy here"
            ),
        }
    }
}

impl fmt::Display for ThreadFailure {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ThreadFailure::Start { count, reason } => {
                write!(f, "cannot start {count} solver threads: {reason}")
            }
            ThreadFailure::Panicked => write!(f, "a solver thread failed (panicked)"),
        }
    }
}

impl From<Breakdown> for Error {
    fn from(b: Breakdown) -> Error {
        Error::LinearAlgebra(b)
    }
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
            Error::LinearAlgebra(b) => write!(f, "{b}"),
            Error::Thread(t) => write!(f, "{t}"),
            Error::Inverted { area_ratio } => write!(
                f,
                "a membrane element inverted or collapsed (area ratio {area_ratio:.2e})"
            ),
            Error::Unsupported(why) => write!(f, "not supported: {why}"),
            Error::PathStopped(m) => write!(f, "{m}"),
            Error::LoadTable {
                path,
                line,
                cell,
                message,
            } => {
                // As Io: the path whole, the message (which echoes cells) clipped.
                write!(f, "{path}: ")?;
                match (line, cell) {
                    (Some(l), Some(c)) => write!(f, "line {l}, {}: ", crate::scene::read::clip(c))?,
                    (Some(l), None) => write!(f, "line {l}: ")?,
                    (None, _) => {}
                }
                write!(f, "{}", crate::scene::read::clip(message))
            }
            Error::Read { path, reason } => write!(f, "cannot read {path}: {reason}"),
            Error::InFile { path, error } => write!(f, "{path}: {error}"),
            Error::NullPointer { argument, length } => {
                write!(f, "argument {argument} is NULL")?;
                match length {
                    Some(n) => write!(f, " but its length is {n}"),
                    None => Ok(()),
                }
            }
            Error::IllegalCall { state } => write!(f, "illegal call in state {state}"),
            Error::CallFirst { first, then } => write!(f, "{first} must be called before {then}"),
            Error::Argument { message, .. } => write!(f, "{message}"),
            Error::ResourceUri { uri, why } => write!(f, "fmuResourceLocation: \"{uri}\" {why}"),
            Error::StateBytes { check, why } => write!(f, "{check} check failed: {why}"),
            Error::Poisoned => write!(
                f,
                "the engine is unusable after an internal error; call fmi2Reset"
            ),
            Error::Internal(m) => write!(f, "{m}"),
            Error::InitialEquilibrium(m) => write!(
                f,
                "the initial equilibrium did not converge: {m}; the instance is now in state Error"
            ),
        }
    }
}

impl std::error::Error for Error {}
