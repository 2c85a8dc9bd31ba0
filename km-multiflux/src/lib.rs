//! # km-multiflux: the multi-flux eigenvalue solver of seed 000 §3
//!
//! The radiative transfer equation of a stack of flat homogeneous layers,
//! discretised in direction and solved exactly in depth by eigen-decomposition
//! (discrete ordinates), in the Fourier–Gauss mode: Gauss nodes per hemisphere
//! that map onto each other under Snell's law, a Fourier series in azimuth,
//! delta-M scaling, and adding of layers, interfaces and substrates.
//!
//! * [`solve`] / [`MultifluxOptions`]: the scene entry point (docs/scene-file.md, docs/cli.md).
//! * [`bsdf`]: the whole BSDF of a stack from one set of operators per Fourier
//!   order, its checks and its files (npz, csv, Fourier BSDF).
//! * [`adding`]: the Redheffer star product of two layers' reflection and
//!   transmission operators (seed eq. 14) and its truncated Neumann series (eq. 21).
//! * [`slab`]: one homogeneous layer and Fourier order (seed eq. 17–20): the
//!   half-size symmetric eigenproblem, scaled so no exponential grows, the
//!   collimated beam's particular solution, exit directions of any angle.
//! * [`eigen`]: the half-size symmetric eigen-solution of a slab (seed eq. 18–19),
//!   shared by both discretisations; `phase_matrix` builds the phase matrix of
//!   each discretisation and renormalises it (one Sinkhorn–Knopp scaling).
//! * [`inside`]: radiance at user directions at any depth inside the stack.
//! * [`correction`]: the intensity correction for peaked phase functions at
//!   exit directions (TMS and IMS, Nakajima & Tanaka 1988).
//! * [`interface`]: Fresnel interfaces and Lambertian substrates as layers (seed §3.4).
//! * [`quadrature`]: double-Gauss quadratures per medium, mapped under Snell.
//! * [`legendre`]: Fourier components of the phase function, delta-M.
//! * [`MultifluxError`]: every refusal of the solver.
#![deny(missing_docs)]
#![allow(clippy::needless_range_loop)]

pub mod adding;
pub mod bsdf;
pub mod budget;
pub mod correction;
pub mod depth;
pub mod direction_set;
pub mod eigen;
mod engine;
pub mod error;
mod exits;
pub mod field;
pub mod flatland;
pub mod inside;
pub mod interface;
pub mod legendre;
pub mod options;
mod phase_matrix;
mod prepare;
pub mod quadrature;
pub mod rough;
pub mod slab;
pub mod solver;
mod stack;
mod symmetric_eigen;
mod workspace;

pub use error::MultifluxError;
pub use solver::{
    ChannelPart, DEFAULT_STREAMS, DEFAULT_STREAMS_ANGULAR, DEFAULT_STREAMS_HARD,
    DEFAULT_STREAMS_PEAKED, InternalField, MultifluxOptions, assemble, default_bsdf_streams,
    default_streams, internal_field, solve, solve_channel, solve_mono,
};
