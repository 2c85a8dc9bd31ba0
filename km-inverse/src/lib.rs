//! # km-inverse: from measurements to materials
//!
//! The inverse problems of km: what absorbs and scatters inside a sample,
//! given what was measured outside it; and the colour of what km computes.
//!
//! * [`slab`]: Prahl's inverse adding–doubling problem (iad) solved with
//!   km's multi-flux forward model: the albedo `a`, optical thickness `b`
//!   and asymmetry `g` of a slab (between optional glass slides) from its
//!   measured total reflectance `M_R`, total transmittance `M_T` and
//!   optionally unscattered transmittance `M_U`, with the covariance of the
//!   answer ([`slab::fit`], [`slab::FitResult`]).
//! * [`forward`]: the measured stack as a km scene and its totals.
//! * [`stack`]: the same stack with its boundaries cached, the fit's fast forward model.
//! * [`sphere`]: single- and double-integrating-sphere measurement equations.
//! * [`rxt`]: iad's `.rxt` measurement files and a plain CSV of spectra.
//! * [`spectrum`]: the rows of such a file fitted one by one, with the caller's overrides.
//! * [`kubelka`]: the paint engineer's Kubelka–Munk inverse. `K` and `S` of a
//!   film from its reflectance over black and over white grounds (Kubelka
//!   1948), or from `R_inf` and `R_0`; Saunderson's correction between measured
//!   and internal reflectances (Saunderson 1942); single-pigment constants from
//!   masstone and tint and the reflectance of mixtures (Duncan 1940); the
//!   uncertainty of `K`, `S` from that of the readings. Every inverse is the
//!   exact inverse of `km_core::two_flux` (round trips to rounding level).
//!   Errors: [`kubelka::KubelkaError`], naming the value.
//! * [`drawdown`]: one film's readings to `K`, `S` (with Saunderson's
//!   correction and the readings' uncertainty) and its hiding curves: what
//!   `km fit --km` computes.
//! * [`request`]: a fit asked for with plain options (`km fit`'s flags):
//!   the mode, the inputs built and checked, the fit run, its JSON and text.
//! * [`text`]: the fits as text for people (the tables `km fit` prints).
//! * [`colour`]: spectra to CIE 1931 XYZ (2° observer; 1964 10° too), CIELAB
//!   under D65 or D50, sRGB (IEC 61966-2-1), the CIEDE2000 colour difference,
//!   and an SVG swatch. The CIE tables are carried in the crate
//!   (`data/cie_cmf_1nm.csv`, `data/cie_illuminants_5nm.csv`: CIE 015:2018,
//!   extracted from the `colour-science` package).
//!   Errors: [`colour::ColourError`].
//! * [`InverseError`]: every refusal of the slab inverse, naming the offending value.
//!
//! The theory notes are `docs/inverse.md`, `docs/inverse-km.md` and `docs/colour.md`.
#![deny(missing_docs)]

pub mod colour;
mod covariance;
pub mod drawdown;
pub mod error;
pub mod forward;
pub mod kubelka;
pub mod linalg;
mod measurement;
pub mod reflectance;
pub mod request;
pub mod rxt;
mod search;
pub mod slab;
pub mod spectrum;
pub mod sphere;
pub mod stack;
pub mod text;

pub use error::InverseError;
pub use slab::{FitOptions, FitResult, Measurement, Setup, Status, fit};
