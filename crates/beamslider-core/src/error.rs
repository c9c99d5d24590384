//! The one error type of the core.

use thiserror::Error;

/// Everything that can go wrong in the core, reported to callers (never a panic).
#[derive(Debug, Error)]
pub enum Error {
    /// A parameter or run input is outside its allowed range.
    #[error("invalid parameter `{field}` = {value}: {allowed}")]
    InvalidParameter {
        /// Name of the field (as in the TOML file).
        field: String,
        /// The offending value, printed.
        value: String,
        /// What is allowed.
        allowed: String,
    },
    /// A TOML file could not be parsed into parameters.
    #[error("cannot read parameters{}: {message}", .path.as_ref().map(|p| format!(" from {p}")).unwrap_or_default())]
    Toml {
        /// File the text came from, if any.
        path: Option<String>,
        /// Parser message (names the key and line).
        message: String,
    },
    /// Reading or writing a file failed.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
    /// A numerical procedure failed (e.g. no eigenvalue found).
    #[error("numerical failure: {0}")]
    Numerical(String),
    /// Another process holds the results file (one writer per results file).
    #[error("{folder}: {file} is being written by another process{}: wait for it or stop it, or use another folder", .pid.map(|p| format!(" (PID {p})")).unwrap_or_default())]
    Busy {
        /// The folder of the results file.
        folder: String,
        /// The results file's name.
        file: String,
        /// Process id of the holder, when it could be read.
        pid: Option<u32>,
    },
    /// The run was interrupted by the caller (cancellation flag).
    #[error("interrupted at t = {t_s} s")]
    Interrupted {
        /// Simulated time reached.
        t_s: f64,
    },
}

/// Result alias of the core.
pub type Result<T> = std::result::Result<T, Error>;

impl Error {
    /// Whether the input was bad (an invalid parameter or unreadable TOML), not the computation.
    pub fn is_input(&self) -> bool {
        matches!(self, Error::InvalidParameter { .. } | Error::Toml { .. })
    }

    /// Shorthand for [`Error::InvalidParameter`].
    pub fn invalid(field: &str, value: impl std::fmt::Display, allowed: &str) -> Self {
        Error::InvalidParameter { field: field.to_string(), value: short_value(value.to_string()), allowed: allowed.to_string() }
    }
}

/// A number for a message in short form (see [`short_value`]): `5e-303`, not 303 digits.
pub fn short_number(x: f64) -> String {
    short_value(x.to_string())
}

/// A value for a message in short form: a number printed with more than 17 digits (`1e300` as
/// 301 digits) is written as `1e300`.
fn short_value(text: String) -> String {
    if text.len() > 24
        && let Ok(x) = text.parse::<f64>()
    {
        return format!("{x:e}");
    }
    text
}

/// The text of a panic payload (`&str` or `String`; "unknown panic" otherwise).
pub fn panic_message(payload: &(dyn std::any::Any + Send)) -> String {
    payload.downcast_ref::<&str>().map(|s| s.to_string()).or_else(|| payload.downcast_ref::<String>().cloned()).unwrap_or_else(|| "unknown panic".into())
}
