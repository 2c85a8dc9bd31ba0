//! # km-python: km from Python
//!
//! The Rust side of the Python package `km` (PyO3; the extension module is
//! `km._km`). Without the `python` feature this crate is plain Rust, so that
//! what it adds to the solver crates is tested by `cargo test --workspace`
//! on a machine with no Python:
//!
//! * [`engine`]: [`engine::Options`] (method and its knobs, as keyword
//!   arguments of `km.solve`) and [`engine::solve`], the one call through
//!   which every solve of the package goes.
//! * [`build`]: scenes from Python values, by way of the scene file
//!   ([`build::scene_from_table`]), so that validation and messages are the
//!   scene file's own.
//! * [`sweep`]: the binding of parameter sweeps (`km::sweep`: typed keys,
//!   [`sweep::solve_sweep`]) and batch solves on all cores ([`sweep::solve_many`]).
//! * [`Error`]: every refusal, with the scene key and line when it has them.
//!
//! The bindings themselves (feature `python`) are in the private module
//! `python`; the user documentation is `docs/python.md`.
#![deny(missing_docs)]

pub mod build;
pub mod engine;
pub mod error;
pub mod sweep;

#[cfg(feature = "python")]
mod python;

pub use error::Error;
