//! # km-multiflux: the multi-flux eigenvalue solver of seed 000 §3
//!
//! * [`adding`]: the Redheffer star product of two layers' reflection and
//!   transmission operators (seed eq. 14) and its truncated Neumann series (eq. 21).
//! * [`MultifluxError`]: every refusal of the solver.
#![deny(missing_docs)]

pub mod adding;
pub mod direction_set;
pub mod error;
pub mod flatland;

pub use error::MultifluxError;
