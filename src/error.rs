//! The library's one error type.
//!
//! Every variant carries the structured facts a user needs to fix the input: the file, the line or
//! field, and what was expected. The binary prints the chain and exits with code 2.

use std::path::PathBuf;

/// Result alias used throughout the library.
pub type Result<T, E = Error> = std::result::Result<T, E>;

/// Errors raised by lumifit's library code.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// Reading or writing a file failed.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file that could not be read or written.
        path: PathBuf,
        /// The operating-system error.
        #[source]
        source: std::io::Error,
    },

    /// A text input could not be parsed.
    #[error("{file}: line {line}: {message}")]
    Parse {
        /// File name (or `<stdin>`, or a description of an embedded table).
        file: String,
        /// 1-based line number (0 when the problem concerns the whole file).
        line: usize,
        /// What was found and what was expected.
        message: String,
    },

    /// A spectral distribution violates an invariant (wavelengths strictly increasing, finite values …).
    #[error("invalid spectral data '{name}': {reason}")]
    InvalidSpectrum {
        /// Name of the distribution (usually the file it came from).
        name: String,
        /// What is wrong and what was expected.
        reason: String,
    },

    /// Two arrays or tables that must agree in size do not.
    #[error("shape mismatch in {what}: expected {expected}, got {got}")]
    ShapeMismatch {
        /// What was being combined.
        what: String,
        /// The expected size.
        expected: usize,
        /// The size found.
        got: usize,
    },

    /// A wavelength is outside the range a table covers.
    #[error("wavelength {lambda_nm} nm is outside the range {start_nm}–{end_nm} nm of {what}")]
    WavelengthOutOfRange {
        /// The offending wavelength.
        lambda_nm: f64,
        /// First wavelength covered.
        start_nm: f64,
        /// Last wavelength covered.
        end_nm: f64,
        /// The table that was queried.
        what: String,
    },

    /// A name (illuminant, observer, colour space …) is not known.
    #[error("unknown {kind} '{name}'; expected one of: {expected}")]
    UnknownName {
        /// The kind of thing named.
        kind: &'static str,
        /// The name given.
        name: String,
        /// The accepted names.
        expected: String,
    },

    /// Quantities computed with different standard observers were combined.
    #[error("observer mismatch: {what} uses '{found}' but '{expected}' was expected; convert with one observer throughout")]
    ObserverMismatch {
        /// What was combined.
        what: String,
        /// Observer of the first operand.
        expected: String,
        /// Observer of the second operand.
        found: String,
    },

    /// An argument is outside its valid domain.
    #[error("invalid {field}: {message}")]
    InvalidArgument {
        /// The argument or field.
        field: String,
        /// What was given and what was expected.
        message: String,
    },

    /// A command-line flag's value is not what the flag takes (the message names what was given
    /// and what was expected); `source` is the parse error behind it, if any.
    #[error("{flag}: {message}")]
    Flag {
        /// The flag (`--rect`, `--out`, …).
        flag: String,
        /// What was given and what was expected.
        message: String,
        /// The underlying parse error.
        #[source]
        source: Option<Box<dyn std::error::Error + Send + Sync>>,
    },

    /// A preset declares a schema this version does not read.
    #[error("{file}: unsupported schema '{found}'; this lumifit reads {expected}")]
    UnsupportedSchema {
        /// The preset file.
        file: String,
        /// The schema string found.
        found: String,
        /// The schema strings understood.
        expected: String,
    },

    /// A preset does not satisfy the JSON Schema.
    #[error("{file}: does not match the preset schema:\n{details}")]
    SchemaViolation {
        /// The preset file.
        file: String,
        /// One line per violation: JSON pointer and message.
        details: String,
    },

    /// An output path names a file the command reads; refused before any work.
    #[error("{flag}: output '{}' is the input '{}'; choose another output path (inputs are never replaced)", output.display(), input.display())]
    OutputIsInput {
        /// The option naming the output (`--out`, `--plot` …).
        flag: String,
        /// The output path as given.
        output: PathBuf,
        /// The input it equals, as given.
        input: PathBuf,
    },

    /// A size a user asked for would need more memory (or work) than the limit allows.
    #[error("{what}: {requested} would need about {needed_mib} MiB, over the limit of {limit_mib} MiB; {hint}")]
    TooLarge {
        /// The flag or field that set the size.
        what: String,
        /// The size as requested (e.g. `20000x20000 px`).
        requested: String,
        /// Estimated allocation in MiB.
        needed_mib: u64,
        /// The limit in MiB.
        limit_mib: u64,
        /// What to do instead.
        hint: String,
    },

    /// A computation produced a non-finite number (overflow, 0/0) from an input.
    #[error("{what} is not finite (overflow or 0/0) for input {input}; expected values whose result fits in f64")]
    NonFinite {
        /// The quantity that became non-finite.
        what: String,
        /// The input (file, field or value) that produced it.
        input: String,
    },

    /// A step of a command failed: `what` names the step and its input (`FILE: excitation fit`,
    /// `--plot FILE`) or, without a source, says what was wrong and what was expected; `source`
    /// is the error behind it. The binary prints `what` and then the source as `caused by:`, as
    /// it prints any error chain.
    #[error("{what}")]
    Context {
        /// The step and its input, or the whole message.
        what: String,
        /// The error behind it.
        #[source]
        source: Option<Box<Error>>,
    },

    /// A numerical method could not produce a result (singular matrix, no convergence where
    /// a result is required).
    #[error("numerical failure in {what}: {reason}")]
    Numerical {
        /// The computation.
        what: String,
        /// Why it failed.
        reason: String,
    },
}

impl Error {
    /// Shorthand for [`Error::InvalidArgument`].
    pub fn invalid(field: impl Into<String>, message: impl Into<String>) -> Self {
        Error::InvalidArgument {
            field: field.into(),
            message: message.into(),
        }
    }

    /// Shorthand for [`Error::Flag`] without a cause.
    pub fn flag(flag: impl Into<String>, message: impl Into<String>) -> Self {
        Error::Flag {
            flag: flag.into(),
            message: message.into(),
            source: None,
        }
    }

    /// Wraps `self` in [`Error::Context`] naming the step that failed.
    pub fn context(self, what: impl Into<String>) -> Self {
        Error::Context {
            what: what.into(),
            source: Some(Box::new(self)),
        }
    }

    /// [`Error::Context`] without a source: a message that names the input and what was
    /// expected, printed as it is.
    pub fn message(what: impl Into<String>) -> Self {
        Error::Context {
            what: what.into(),
            source: None,
        }
    }

    /// Shorthand for [`Error::Parse`].
    pub fn parse(file: impl Into<String>, line: usize, message: impl Into<String>) -> Self {
        Error::Parse {
            file: file.into(),
            line,
            message: message.into(),
        }
    }

    /// Shorthand for [`Error::Io`].
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        Error::Io {
            path: path.into(),
            source,
        }
    }
}

/// `Ok(())` when every value is finite, else [`Error::NonFinite`] naming `what` and the `input`
/// that produced it. Commands call this on results before writing them, so an overflow is an
/// error and never a `null` in JSON.
pub fn ensure_finite(what: &str, input: &str, values: &[f64]) -> Result<()> {
    if values.iter().all(|v| v.is_finite()) {
        Ok(())
    } else {
        Err(Error::NonFinite {
            what: what.to_string(),
            input: input.to_string(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn context_prints_its_step_and_keeps_the_error_behind_it_as_source() {
        let inner = Error::parse("m.json", 3, "expected a number");
        let e = inner.context("m.json: dispersion.model");
        assert_eq!(e.to_string(), "m.json: dispersion.model");
        let source = std::error::Error::source(&e).map(|s| s.to_string());
        assert_eq!(source.as_deref(), Some("m.json: line 3: expected a number"));
        let bare = Error::message("m.json: dispersion: missing");
        assert_eq!(bare.to_string(), "m.json: dispersion: missing");
        assert!(std::error::Error::source(&bare).is_none());
    }
}
