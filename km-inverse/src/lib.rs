//! # km-inverse: optical properties from measurements
//!
//! The inverse problems of km: what absorbs and scatters inside a sample,
//! given what was measured outside it.
//!
//! * [`slab`]: Prahl's inverse adding–doubling problem (iad) solved with
//!   km's multi-flux forward model: the albedo `a`, optical thickness `b`
//!   and asymmetry `g` of a slab (between optional glass slides) from its
//!   measured total reflectance `M_R`, total transmittance `M_T` and
//!   optionally unscattered transmittance `M_U`, with the covariance of the
//!   answer ([`slab::fit`], [`slab::FitResult`]).
//! * [`forward`]: the measured stack as a km scene and its totals.
//! * [`sphere`]: single- and double-integrating-sphere measurement equations.
//! * [`rxt`]: iad's `.rxt` measurement files and a plain CSV of spectra.
//! * [`InverseError`]: every refusal, naming the offending value.
//!
//! The theory, with sources, is in `docs/inverse.md`.
#![deny(missing_docs)]

pub mod error;
pub mod forward;
pub mod linalg;
pub mod rxt;
pub mod slab;
pub mod sphere;

pub use error::InverseError;
pub use slab::{FitOptions, FitResult, Measurement, Setup, Status, fit};
