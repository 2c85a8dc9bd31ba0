//! # km-montecarlo: the Monte Carlo reference tracer
//!
//! Photon tracing in a stack of plane-parallel layers in the manner of MCML
//! (Wang, Jacques & Zheng 1995) and Hanrahan & Krueger (1993): exponential
//! free paths with exact crossing of layer boundaries, Henyey–Greenstein
//! scattering, smooth Fresnel interfaces wherever the refractive index
//! changes, Lambertian, black or clear substrates, collimated light at any
//! angle or diffuse light. The theory and the precise definition of every
//! tally are in `docs/montecarlo.md`.
//!
//! The principal items:
//! * [`McOptions`] (samples, seed, threads, [`Estimator`], bins, budget) and
//!   [`solve`]: a [`km_core::Solution`] with standard errors (key `stderr`).
//! * [`run_shard`] / [`merge`] / [`Partial`]: a run split over processes,
//!   merged bit-identically; [`write_atomic`] for their files.
//! * [`radial_profile`]: `Rd(r)` of a pencil beam ([`RadialProfile`]).
//! * [`McError`]: every refusal.
//!
//! A run split in two shards and merged (what `km solve --shard i/N` and
//! `km merge` do, with files in between):
//!
//! ```
//! use km_montecarlo::{McOptions, Partial, merge, run_shard, solve};
//! let scene = km_core::Scene::from_toml_str("[[layer]]\ntau = 1.0\nalbedo = 0.9\n").unwrap();
//! let opts = McOptions { samples: 5_000, seed: 42, ..Default::default() };
//! let files: Vec<String> = (0..2)
//!     .map(|i| serde_json::to_string(&run_shard(&scene, &opts, i, 2).unwrap()).unwrap())
//!     .collect();
//! let parts: Vec<Partial> = files.iter().map(|f| serde_json::from_str(f).unwrap()).collect();
//! let merged = merge(&parts).unwrap();
//! assert_eq!(merged.channels, solve(&scene, &opts).unwrap().channels);
//! ```
//!
//! Reproducibility: batch `b` of channel `c` draws from a xoshiro256++ generator seeded
//! from `(seed, c, b)`; batches are summed in index order, so the result is a
//! function of the seed and the options only, not of the thread count.
#![deny(missing_docs)]

pub mod bins;
pub mod depth;
pub mod error;
pub mod grid;
pub mod mcml;
pub mod options;
mod rng;
mod rough;
pub mod run;
mod sampling;
pub mod shard;
mod stats;
mod tally;
mod transport;

pub use error::McError;
pub use grid::{GridRaw, GridResult, McGrid};
pub use km_core::Cancel;
pub use options::{CANCEL_CHECK_PHOTONS, Estimator, McOptions, Progress, RadialBins};
pub use run::{
    InsideResult, RadialProfile, merge_grid, projected_steps, radial_profile, run_shard, solve,
    solve_grid, solve_grid_inside, solve_inside,
};
pub use shard::{
    Partial, merge, merge_files, parse_partial, read_partial, shard_batches, write_atomic,
};
pub use transport::cone_bins;

/// A standard error at or below this fraction of its value is reported as
/// 0: the number is the same in every batch to 9 digits. For a
/// deterministic part (the mirror reflection of a smooth top surface) what
/// is left is rounding noise, about 1e-16 of the value; a random part that
/// small is below anything a result is read to (docs/montecarlo.md §5).
pub const EXACT_RELATIVE_STDERR: f64 = 1e-9;
