//! Errors of the inverse library: one enum, every message names the offending value.

use thiserror::Error;

/// An error of the inverse problems.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum InverseError {
    /// A parameter or measurement outside its domain.
    #[error("invalid {name} = {value}: {reason}")]
    Invalid {
        /// Parameter name, as on the command line.
        name: String,
        /// The offending value.
        value: f64,
        /// What the domain is.
        reason: String,
    },
    /// A measurement file that cannot be read; `line` is 1-based when known.
    #[error("{}", parse_message(*.line, .message))]
    Parse {
        /// 1-based line in the file, when known.
        line: Option<usize>,
        /// What is wrong.
        message: String,
    },
    /// The forward model refused or failed.
    #[error("forward model: {0}")]
    Forward(String),
}

fn parse_message(line: Option<usize>, message: &str) -> String {
    match line {
        Some(l) => format!("line {l}: {message}"),
        None => message.to_string(),
    }
}

impl InverseError {
    /// A parameter outside its domain.
    pub fn invalid(name: &str, value: f64, reason: &str) -> Self {
        InverseError::Invalid { name: name.into(), value, reason: reason.into() }
    }
    /// A file error at a line.
    pub fn parse(line: Option<usize>, message: impl Into<String>) -> Self {
        InverseError::Parse { line, message: message.into() }
    }
}

impl From<km_multiflux::MultifluxError> for InverseError {
    fn from(e: km_multiflux::MultifluxError) -> Self {
        InverseError::Forward(e.to_string())
    }
}

impl From<km_core::CoreError> for InverseError {
    fn from(e: km_core::CoreError) -> Self {
        InverseError::Forward(e.to_string())
    }
}
