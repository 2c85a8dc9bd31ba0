//! Errors of the bindings: one enum; every message names the offending key or value.

use km::CoreError;
use thiserror::Error;

/// An error of a solve, a scene or an option, as `km.KmError` reports it.
#[derive(Debug, Error)]
pub enum Error {
    /// The scene (file or Python values) is invalid; names key and line.
    #[error(transparent)]
    Scene(#[from] CoreError),
    /// The method refused the scene or its options (the solver's message).
    #[error("{0}")]
    Solver(String),
    /// An option of the Python call outside its domain.
    #[error("invalid option {name}: {reason}")]
    Option {
        /// Keyword argument, as in the Python call.
        name: String,
        /// What its domain is.
        reason: String,
    },
    /// A setting of the solve refused (`km::settings`), in the words of the
    /// `km solve` flag of the same name.
    #[error("{message}")]
    Setting {
        /// The setting's name (a keyword argument of `km.solve`).
        name: String,
        /// The library's message.
        message: String,
    },
    /// One point of a batch failed (its index, 0-based, and the error).
    #[error("point {index}: {source}")]
    Point {
        /// Index of the point in the batch.
        index: usize,
        /// The point's error.
        #[source]
        source: Box<Error>,
    },
    /// The work was stopped by its cancel flag ([`crate::engine::Options::cancel`])
    /// before it finished (the bindings raise `KeyboardInterrupt` instead).
    #[error("cancelled: the computation was stopped before it finished (no result)")]
    Cancelled,
    /// A bug: a panic inside a solver, caught at the boundary.
    #[error("internal error (please report it with the scene): {0}")]
    Internal(String),
}

impl Error {
    /// An invalid option.
    pub fn option(name: &str, reason: impl Into<String>) -> Self {
        Error::Option { name: name.into(), reason: reason.into() }
    }

    /// The scene key the error names (`layer[2].sigma_a`, `light.kind`, ...).
    pub fn key(&self) -> Option<&str> {
        match self {
            Error::Scene(CoreError::Scene { key, .. }) => Some(key),
            Error::Scene(CoreError::Invalid { name, .. }) => Some(name),
            Error::Option { name, .. } | Error::Setting { name, .. } => Some(name),
            Error::Point { source, .. } => source.key(),
            _ => None,
        }
    }

    /// The 1-based line of the scene file the error names, when known.
    pub fn line(&self) -> Option<usize> {
        match self {
            Error::Scene(CoreError::Scene { line, .. }) => *line,
            Error::Point { source, .. } => source.line(),
            _ => None,
        }
    }
}

impl From<km::KmError> for Error {
    fn from(e: km::KmError) -> Self {
        if e.is_cancelled() {
            return Error::Cancelled;
        }
        match e {
            km::KmError::Scene(c) => Error::Scene(c),
            km::KmError::Multiflux(e) => e.into(),
            km::KmError::MonteCarlo(e) => e.into(),
            km::KmError::Dipole(e) => e.into(),
            km::KmError::Option { name: "accuracy target", .. } => {
                Error::Option { name: "tolerance".into(), reason: e.to_string() }
            }
            km::KmError::Setting { ref name, .. } => {
                Error::Setting { name: name.clone(), message: e.to_string() }
            }
            km::KmError::NoAccuracySetting { .. }
            | km::KmError::TargetUnreachable { .. }
            | km::KmError::TargetOverBudget { .. } => {
                Error::Option { name: "tolerance".into(), reason: e.to_string() }
            }
            other => Error::Solver(other.to_string()),
        }
    }
}

impl From<km::MultifluxError> for Error {
    fn from(e: km::MultifluxError) -> Self {
        match e {
            km::MultifluxError::Scene(c) => Error::Scene(c),
            other => Error::Solver(other.to_string()),
        }
    }
}

impl From<km::McError> for Error {
    fn from(e: km::McError) -> Self {
        match e {
            km::McError::Scene(c) => Error::Scene(c),
            km::McError::Cancelled => Error::Cancelled,
            other => Error::Solver(other.to_string()),
        }
    }
}

impl From<km::DipoleError> for Error {
    fn from(e: km::DipoleError) -> Self {
        match e {
            km::DipoleError::Scene(c) => Error::Scene(c),
            other => Error::Solver(other.to_string()),
        }
    }
}

impl From<km::bsdf::BsdfError> for Error {
    fn from(e: km::bsdf::BsdfError) -> Self {
        match e {
            km::bsdf::BsdfError::Solver(m) => m.into(),
            km::bsdf::BsdfError::Input { name, reason } => Error::option(name, reason),
            other => Error::Solver(other.to_string()),
        }
    }
}

impl From<km_inverse::InverseError> for Error {
    fn from(e: km_inverse::InverseError) -> Self {
        match e {
            km_inverse::InverseError::Invalid { ref name, .. } => {
                Error::Option { name: name.clone(), reason: e.to_string() }
            }
            other => Error::Solver(other.to_string()),
        }
    }
}
