//! Errors of the multi-flux solver: one enum, every message names the offending value.

use thiserror::Error;

/// An error of the multi-flux solver.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum MultifluxError {
    /// Operators whose shapes do not fit together (a programming error of the caller).
    #[error("shape mismatch in {what}: {detail}")]
    Shape {
        /// Which operation.
        what: &'static str,
        /// The offending shapes.
        detail: String,
    },
    /// An option outside its domain (e.g. `streams = 0`).
    #[error("invalid option {name} = {value}: {reason}")]
    Option {
        /// Option name.
        name: &'static str,
        /// The offending value.
        value: f64,
        /// What the domain is.
        reason: &'static str,
    },
    /// A linear-algebra step failed (singular system, eigen-solver failure).
    #[error("numerical failure in {what}: {detail}")]
    Numerical {
        /// Which step.
        what: &'static str,
        /// Details (sizes, parameters of the layer).
        detail: String,
    },
    /// The solve's estimated work exceeds its budget (`MultifluxOptions::max_work`,
    /// [`crate::budget`]).
    #[error("refused: this solve needs about {work:.3e} work units (budget {budget:.3e}): {hint}")]
    TooExpensive {
        /// The estimate of eq. W1.
        work: f64,
        /// The budget.
        budget: f64,
        /// Where the work comes from and what to change.
        hint: String,
    },
    /// The scene is invalid or the method cannot treat it.
    #[error(transparent)]
    Scene(#[from] km_core::CoreError),
}
