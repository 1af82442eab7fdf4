//! Log categories and the per-instance logger.
//!
//! ```text
//! category          status passed    when
//! logStatusWarning  fmi2Warning      recoverable oddities: the scene's plausibility warnings at
//!                                    instantiation (scene/plausibility.rs)
//! logStatusDiscard  fmi2Discard      a DoStep that did not converge (reached fraction, why)
//!                                    (always emitted: a master must learn why a run ended)
//! logStatusError    fmi2Error        every Error: illegal call, bad argument, failed check
//!                                    (always emitted, whatever is enabled)
//! logStatusFatal    fmi2Fatal        reserved (always emitted)
//! logSolver         fmi2OK           the engine's log lines: Newton iterations per increment
//! logCalls          fmi2OK           a trace of the FMI calls with their arguments
//! ```
//!
//! Messages follow the FMI 2 conventions: the C logger is a printf-style variadic function, so
//! it is always called with the format `"%s"` and the message as the argument (a `%` in the
//! message is then printed literally); `#r<vr>#` names a variable reference, so a literal `#`
//! is written `##` (done by [`escape`]); no trailing newline; interior NUL bytes are dropped.

use super::fmi2_ffi::{self, LoggerFn, Status};
use super::fmi3_ffi::{self, Fmi3LoggerFn};
use crate::description::LOG_CATEGORIES;
use crate::error::Error;
use std::ffi::{c_void, CString};

/// A log category (its position in [`LOG_CATEGORIES`], which the modelDescription declares).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Category {
    StatusWarning = 0,
    StatusDiscard = 1,
    StatusError = 2,
    StatusFatal = 3,
    Solver = 4,
    Calls = 5,
}

impl Category {
    pub fn name(self) -> &'static str {
        LOG_CATEGORIES[self as usize].0
    }

    /// The status passed to the logger with a message of this category.
    fn status(self) -> Status {
        match self {
            Category::StatusWarning => Status::Warning,
            Category::StatusDiscard => Status::Discard,
            Category::StatusError => Status::Error,
            Category::StatusFatal => Status::Fatal,
            Category::Solver | Category::Calls => Status::Ok,
        }
    }

    /// Discards and errors are logged whatever the debug-logging settings are: a run that
    /// ends early or fails must say why even when the master did not ask for logging.
    fn always(self) -> bool {
        matches!(
            self,
            Category::StatusDiscard | Category::StatusError | Category::StatusFatal
        )
    }
}

/// Write a literal `#` as `##` (FMI: `#r12#` would name value reference 12).
pub fn escape(text: &str) -> String {
    text.replace('#', "##")
}

/// The master's logger: FMI 2's variadic one, or FMI 3's `fmi3LogMessageCallback` (no instance
/// name, message already formatted; function names in the text are given their FMI 3 form).
#[derive(Clone, Copy)]
pub enum Callback {
    Fmi2(LoggerFn),
    Fmi3(Fmi3LoggerFn),
}

/// The logger of one instance: the master's callback, its environment pointer, the instance
/// name and which categories are enabled.
pub struct Logger {
    callback: Option<Callback>,
    environment: *mut c_void,
    instance_name: CString,
    enabled: [bool; LOG_CATEGORIES.len()],
}

impl Logger {
    /// `callback` None: nothing is ever logged. `on`: every category enabled.
    pub fn new(
        callback: Option<LoggerFn>,
        environment: *mut c_void,
        instance_name: &str,
        on: bool,
    ) -> Logger {
        Logger::with_callback(callback.map(Callback::Fmi2), environment, instance_name, on)
    }

    /// A logger for either FMI version's callback.
    pub fn with_callback(
        callback: Option<Callback>,
        environment: *mut c_void,
        instance_name: &str,
        on: bool,
    ) -> Logger {
        Logger {
            callback,
            environment,
            instance_name: c_string(instance_name),
            enabled: [on; LOG_CATEGORIES.len()],
        }
    }

    /// Whether a message of this category would reach the master.
    pub fn enabled(&self, category: Category) -> bool {
        self.callback.is_some() && (category.always() || self.enabled[category as usize])
    }

    /// Log plain text: `#` is escaped.
    pub fn log(&self, category: Category, text: &str) {
        if self.enabled(category) {
            self.log_formatted(category, &escape(text));
        }
    }

    /// Log a message already in FMI form (`##` for `#`, `#r<vr>#` references).
    pub fn log_formatted(&self, category: Category, message: &str) {
        let Some(callback) = self.callback else {
            return;
        };
        if !self.enabled(category) {
            return;
        }
        let message = message.trim_end_matches(['\n', '\r']);
        let category_name = c_string(category.name());
        match callback {
            Callback::Fmi2(callback) => fmi2_ffi::call_logger(
                callback,
                self.environment,
                &self.instance_name,
                category.status(),
                &category_name,
                &c_string(message),
            ),
            Callback::Fmi3(callback) => fmi3_ffi::call_logger(
                callback,
                self.environment,
                category.status(),
                &category_name,
                &c_string(&fmi3_ffi::fmi3_names(message)),
            ),
        }
    }

    /// `fmi2SetDebugLogging`: no names sets every category; otherwise the named ones. An
    /// unknown name changes nothing and is reported.
    pub fn set(&mut self, on: bool, names: &[&str]) -> Result<(), Error> {
        if names.is_empty() {
            self.enabled = [on; LOG_CATEGORIES.len()];
            return Ok(());
        }
        let mut indices = Vec::with_capacity(names.len());
        for name in names {
            match LOG_CATEGORIES.iter().position(|(n, _)| n == name) {
                Some(i) => indices.push(i),
                None => {
                    return Err(Error::Argument {
                        argument: "categories",
                        message: format!(
                            "unknown log category \"{name}\"; declared: {}",
                            declared()
                        ),
                    })
                }
            }
        }
        for i in indices {
            self.enabled[i] = on;
        }
        Ok(())
    }
}

fn declared() -> String {
    LOG_CATEGORIES
        .iter()
        .map(|(n, _)| *n)
        .collect::<Vec<_>>()
        .join(", ")
}

/// A C string of `text` without its interior NUL bytes.
fn c_string(text: &str) -> CString {
    CString::new(text.replace('\0', "")).unwrap_or_default()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hash_is_doubled() {
        assert_eq!(escape("load #2 at 50%"), "load ##2 at 50%");
    }

    #[test]
    fn unknown_category_changes_nothing() {
        let mut logger = Logger::new(None, std::ptr::null_mut(), "x", false);
        assert!(logger.set(true, &["logSolver", "logNope"]).is_err());
        assert!(!logger.enabled[Category::Solver as usize]);
        logger.set(true, &["logSolver"]).unwrap();
        assert!(logger.enabled[Category::Solver as usize]);
        assert!(!logger.enabled[Category::Calls as usize]);
    }

    #[test]
    fn categories_match_the_enum() {
        assert_eq!(Category::Calls.name(), "logCalls");
        assert_eq!(Category::StatusDiscard.name(), "logStatusDiscard");
    }
}
