//! # km-dipole: the diffusion approximation and the dipole BSSRDF
//!
//! The diffusion theory of seed 003 (diffusion equation, boundary
//! condition, diffuse reflectance) and the dipole of Jensen, Marschner,
//! Levoy & Hanrahan (2001) for a semi-infinite homogeneous medium. Theory,
//! equations `(Dn)` and sources: `docs/diffusion.md`.
//!
//! * [`params`]: [`DiffusionParams`] (`sigma_s'`, `sigma_t'`, `alpha'`, `D`,
//!   `sigma_tr`, `F_dr`, `A`, `z_b`, `z_r`, `z_v`) and [`FdrModel`] (exact
//!   Fresnel integral or the Egan–Hilgeman fit).
//! * [`dipole`]: fluence, `Rd(r)`, the closed-form total `Rd`, the BSSRDF
//!   and its two normalisations.
//! * [`better_dipole`]: the improved dipole of d'Eon (2012).
//! * [`field`]: the diffusion field inside: `phi(r, z)` of a pencil beam,
//!   `phi(z)`, `A(z)`, `F(z)` of a broad beam.
//! * [`solve()`] / [`profile()`]: the scene entry points of `km solve --method
//!   dipole` and `km profile` ([`DipoleOptions`]).
//! * [`compare`]: the dipole as a function of (albedo, g, eta) and for the
//!   measured presets, for comparisons with the transport solvers.
//! * [`DipoleError`]: every refusal, naming the problem.
//!
//! The dipole is the multiple-scattering part only: single scattering is
//! not included anywhere in this crate.
#![deny(missing_docs)]

pub mod better_dipole;
pub mod compare;
pub mod dipole;
pub mod error;
pub mod field;
pub mod params;
pub mod solve;

pub use dipole::BssrdfNormalisation;
pub use error::DipoleError;
pub use params::{DiffusionParams, FdrModel};
pub use solve::{
    DipoleDepthField, DipoleModel, DipoleOptions, depth_field, fluence_profile, profile, solve,
};
