//! # km-multiflux: the multi-flux eigenvalue solver of seed 000 §3
//!
//! * [`adding`]: the Redheffer star product of two layers' reflection and
//!   transmission operators (seed eq. 14) and its truncated Neumann series (eq. 21).
//! * [`MultifluxError`]: every refusal of the solver.
#![deny(missing_docs)]

pub mod adding;
pub mod error;

pub use error::MultifluxError;
