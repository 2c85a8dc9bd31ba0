//! # km-core: the shared vocabulary of km, and the closed-form models
//!
//! * [`Scene`] / [`MonoScene`]: the scene file (docs/scene-file.md), validated, one
//!   [`MonoScene`] per spectral channel; [`Light`], [`Substrate`].
//! * [`Layer`]: one homogeneous layer (`sigma_a`, `sigma_s`, thickness, phase, `n`).
//! * [`phase`]: phase functions ([`phase::Phase`], [`phase::PhaseFunction`]) and the
//!   checked asymmetry [`phase::Anisotropy`].
//! * [`mie`]: Mie theory (spheres, size distributions, particle optics).
//!
//! `Layer`, `MonoScene` and `Scene` have private fields: they are built only
//! through checked constructors (`Layer::new`, `MonoScene::new`, `Scene::new`
//! and their `with_*` variants), each check written once, so the solvers take
//! them as valid and check nothing again (docs/architecture.md).
//! * [`fresnel`]: Snell, unpolarised Fresnel, total internal reflection,
//!   hemispherical averages.
//! * [`microfacet`]: rough faces (Walter et al. 2007), conductor Fresnel;
//!   [`metals`]: the n, k table of named metals.
//! * [`quadrature`]: Gauss–Legendre and Gauss–Radau rules.
//! * [`legendre`]: Legendre polynomials and normalised associated functions.
//! * [`two_flux`]: Kubelka–Munk (seed 000 §2).
//! * [`presets`]: measured materials (Jensen et al. 2001).
//! * [`plan`]: the planner (docs/planner.md).
//! * [`Solution`]: what every method returns, and its JSON contract (docs/cli.md).
//! * [`CoreError`]: every refusal, naming the offending key or value.
//! * [`atomic_file`]: output files written whole or not at all, never over
//!   a device, a link or an input.
//! * [`Cancel`]: the flag that stops a long computation under way.
#![deny(missing_docs)]

pub mod atomic_file;
pub mod cancel;
pub mod error;
pub mod fresnel;
pub mod layer;
pub mod legendre;
pub mod metals;
pub mod microfacet;
pub mod mie;
pub mod phase;
pub mod plan;
pub mod presets;
pub mod quadrature;
pub mod scene;
pub mod set;
pub mod solution;
pub mod two_flux;

pub use cancel::Cancel;
pub use error::CoreError;
pub use layer::Layer;
pub use scene::{
    Light, MonoScene, Scene, SceneLimits, Substrate, read_checked_text, read_scene_text,
};
pub use solution::{
    AccuracyReport, ChannelResult, DepthOutput, InsideField, Solution, Uncertainty,
};
