//! # km: light in stacks of flat scattering layers
//!
//! The library a user depends on: one scene, five methods, one interface.
//!
//! * [`Method`]: the method registry (`km`, `multiflux`, `direction-set`,
//!   `mc`, `dipole`).
//! * [`Solver`]: what every method implements (capability check, solve,
//!   solve to an accuracy target), by its own option type ([`KmOptions`],
//!   [`MultifluxOptions`], [`DirectionSetOptions`], [`McOptions`],
//!   [`DipoleOptions`]).
//! * [`solve`]: the entry point: applies the plan (docs/planner.md), solves
//!   channels with identical coefficients once, cuts a layer too thick to
//!   transmit anything into a half-space for the dipole, meets an accuracy
//!   target ([`accuracy`]), and attaches the plan to the [`Solution`].
//! * [`cone`]: BRDF/BTDF values as means over cones (`Options::cone_deg`):
//!   Monte Carlo's bins set, the multi-flux values averaged alike.
//! * [`model_error`]: `model_error_estimate` of the two-flux and dipole
//!   answers, from a cheap multi-flux solve of the same scene.
//! * [`profile()`]: the radially resolved reflectance `Rd(r)`.
//! * [`KmError`]: every refusal, in the library's own words.
//! * [`text`]: a solution, a scene and a plan as text for people;
//!   [`sweep_text`], [`Profile::table`] and [`Profile::csv`] likewise.
//! * [`solve_repeated`], [`Options::with_budget`], [`mc_shard`]: repeated
//!   timing, work budgets, Monte Carlo shards; [`settings::SETTINGS`]: every
//!   setting of a solve and the methods it applies to.
//! * [`bsdf_file`]: the whole BSDF as an npz, CSV or Fourier BSDF file.
//! * [`phase_report`]: each layer's phase function, moments and Mie
//!   efficiencies as numbers, and as text; one sphere by Mie theory.
//! * [`mcml_files`]: where an MCML run's files go, and its `.npz`.
//! * `progress` (feature `progress`): a progress bar of a solve on stderr.
//!
//! The crates below: `km-core` (scene, layers, Fresnel, planner, two-flux,
//! [`Solution`]), `km-multiflux`, `km-montecarlo`, `km-dipole`; see
//! docs/architecture.md.
//!
//! ```
//! use km::{Method, Options, Scene};
//! let scene = Scene::from_toml_str("[[layer]]\ntau = 1\nalbedo = 0.9\nn = 1.5\n").unwrap();
//! for method in [Method::Km, Method::Multiflux] {
//!     let sol = km::solve(&scene, &Options::new(method)).unwrap();
//!     let c = &sol.channels[0];
//!     assert!((c.reflectance + c.transmittance + c.absorptance - 1.0).abs() < 1e-9);
//! }
//! ```
#![deny(missing_docs)]

pub mod accuracy;
pub mod bsdf_file;
pub mod cone;
pub mod direction_set;
mod error;
pub mod field;
mod inside;
pub mod mc_field;
pub mod mcml_files;
mod method;
pub mod model_error;
pub mod phase_report;
mod profile;
#[cfg(feature = "progress")]
pub mod progress;
pub mod request_budget;
mod run;
pub mod settings;
mod solver;
pub mod sweep;
pub mod text;

pub use direction_set::DirectionSetOptions;
pub use error::{KmError, Reason, Unsupported};
pub use km_core::Cancel;
/// Output files written atomically, never over devices, links or inputs (`docs/limits.md`).
pub use km_core::atomic_file;
pub use km_core::plan::{Plan, Request, Simplification};
pub use km_core::set::SetEdit;
pub use km_core::solution::{AccuracyReport, Diagnostics, MethodDiagnostics};
pub use km_core::two_flux::{KmMapping, KmModel, KmOptions};
pub use km_core::{
    ChannelResult, CoreError, Layer, Light, MonoScene, Scene, SceneLimits, Solution, Substrate,
    Uncertainty, read_checked_text, read_scene_text,
};
pub use km_dipole::{DipoleModel, DipoleOptions, FdrModel};
pub use km_montecarlo::{Estimator, McOptions, Progress};
pub use km_multiflux::MultifluxOptions;
/// The whole BSDF of a stack from one multi-flux solve, its checks and its
/// files (npz, csv, Fourier BSDF): see `docs/bsdf.md`.
pub use km_multiflux::bsdf;
/// The multi-flux work budget (eq. W1; `docs/limits.md`).
pub use km_multiflux::budget as multiflux_budget;
// The front ends' face beyond solving (the `km` command and the Python
// package depend on no other crate of the solvers): what they read, write
// and match on, named here one by one rather than whole crates.
/// Mie theory: spheres, size distributions, the moments of their phase function.
pub use km_core::mie;
/// Phase functions of a layer (`Phase`, its tables and Legendre moments).
pub use km_core::phase;
pub use km_core::solution::{DEPTH_KEYS, UncertaintyValue};
pub use km_dipole::DipoleError;
/// MCML's `.mci` input and `.mco` output files (`km mc`, docs/mcml.md).
pub use km_montecarlo::mcml;
pub use km_montecarlo::{GridResult, McError, Partial};
/// Monte Carlo shards merged into one run (`km merge`, Python's `km.merge`).
pub use km_montecarlo::{merge as mc_merge, merge_files as mc_merge_files};
pub use km_multiflux::{MultifluxError, default_bsdf_streams};
pub use method::{Method, UnknownMethod};
pub use profile::{Profile, ProfileOptions, profile};
pub use run::{mc_shard, solve_repeated};
pub use solver::{MethodOptions, Options, Solver};
pub use sweep::{
    MAX_POINTS as SWEEP_MAX_POINTS, SweepAxis, SweepFormat, SweepPoint, sweep, sweep_text,
};

/// The README's examples, compiled and run as doctests.
#[doc = include_str!("../../README.md")]
#[cfg(doctest)]
pub struct ReadmeDoctests;

use km_core::plan::{Plan as PlanT, expand_channels, plan_scene, reduce_channels};

/// Solve `scene` with the method and settings of `options`.
///
/// In order: the plan of the scene for the method (docs/planner.md; off
/// with `options.all_effects`); channels with identical coefficients solved
/// once (`duplicate-channels`); for the dipole, a top layer that the
/// `transmission` rule (eq. PL1) makes a half-space in every channel solved
/// as one, with a note giving the bound on the neglected light; the
/// capability check ([`Solver::supports`]); the solve, or the solve to
/// `options.tolerance` ([`Solver::solve_unplanned_to`], eq. E1–E3 of
/// docs/planner.md); then the plan and the output directions are attached.
///
/// # Errors
/// [`KmError::Unsupported`] when the method cannot treat the scene, the
/// accuracy target's errors, and the solver's; a raised cancel flag
/// ([`Options::cancel`]; [`KmError::is_cancelled`]).
///
/// ```
/// let scene = km::Scene::from_toml_str("[[layer]]\ntau = 2\nalbedo = 0.9\ng = 0.5\n").unwrap();
/// let sol = km::solve(&scene, &km::Options::new(km::Method::Multiflux).with_tolerance(1e-5)).unwrap();
/// let acc = sol.accuracy.as_ref().unwrap();
/// assert!(acc.reached && acc.estimate <= 1e-5);
/// let dipole = km::solve(&scene, &km::Options::new(km::Method::Dipole));
/// assert!(matches!(dipole, Err(km::KmError::Unsupported(_))));
/// ```
pub fn solve(scene: &Scene, options: &Options) -> Result<Solution, KmError> {
    if km_core::cancel::cancelled(options.cancel.as_ref()) {
        return Err(KmError::Cancelled);
    }
    let Prepared { plan, solver, reduced, cut } = prepare(scene, options)?;
    let method = options.method();
    let work = reduced.as_ref().map_or(scene, |(r, _)| r);
    let solved = work;
    let work = cut.as_ref().map_or(work, |(half, _)| half);
    let depths = scene.depths();
    // Monte Carlo tallies the depth field in the run that gives the answer
    // (the same photons; docs/field.md §6), when nothing else re-runs it.
    let mut field = None;
    let mut sol = match (options.cone_deg, &solver) {
        (Some(deg), MethodOptions::Multiflux(_)) => {
            cone::solve_mean(&solver, work, deg, options.tolerance)?
        }
        (None, MethodOptions::Mc(o))
            if !depths.is_empty() && options.tolerance.is_none() && reduced.is_none() =>
        {
            let (s, f) = field::mc_solve_with_field(work, depths, scene.inside_directions(), o)?;
            field = Some(f);
            s
        }
        _ => match options.tolerance {
            Some(tol) => solver.solve_unplanned_to(work, tol)?,
            None => solver.solve_unplanned(work)?,
        },
    };
    if let Some((_, bound)) = cut {
        sol.notes.push(format!(
            "the top layer is so thick that the light returning from below it is < {:.1e} of \
             the incident (planner rule `transmission`): solved as a half-space",
            bound.max(f64::MIN_POSITIVE)
        ));
    }
    // A request the solve does not answer is named, not dropped in silence:
    // the radiance inside is given at the depths (docs/field.md §6).
    if !scene.inside_directions().is_empty() && depths.is_empty() {
        sol.notes.push(
            "[output] inside_directions_deg ignored: the radiance inside is given at the \
             scene's [output] depths, and it asks for none"
                .to_string(),
        );
    }
    // The closed forms say how far they are off (eq. K25), on the channels
    // solved (before the dipole's half-space cut: the estimate covers it).
    if matches!(method, Method::Km | Method::Dipole) {
        model_error::attach(&mut sol, solved);
    }
    if method == Method::Mc {
        cone::note_mc(&mut sol);
    }
    if let Some((_, map)) = &reduced {
        sol = expand_channels(sol, map, scene.labels());
    }
    if sol.channels.iter().any(|c| !c.brdf.is_empty() || !c.btdf.is_empty()) {
        sol.directions =
            scene.channels().first().map(|c| c.directions_deg().to_vec()).unwrap_or_default();
    }
    // A spectral scene's JSON `channels` are its wavelengths (numbers, nm).
    if let Some(w) = scene.wavelengths_nm().filter(|w| w.len() > 1) {
        sol.diagnostics.wavelengths_nm = Some(w.to_vec());
    }
    if !depths.is_empty() {
        match field {
            Some(f) => sol.field = Some(f),
            None => field::attach(scene, &solver, &mut sol)?,
        }
    }
    sol.plan = Some(plan);
    Ok(sol)
}

/// What [`solve`] does before any work: the plan, the capability check on
/// the scene as the plan leaves it. `km plan` and `km solve` ask the same
/// question through this one function, so that a plan is shown exactly for
/// the scenes a solve accepts, and a refusal is worded the same way.
///
/// # Errors
/// [`KmError::Unsupported`] when the method cannot treat the scene.
///
/// ```
/// let s = km::Scene::from_toml_str("[[layer]]\ntau = 1\nalbedo = 0.5\n").unwrap();
/// assert!(km::check(&s, &km::Options::new(km::Method::Multiflux)).is_ok());
/// assert!(km::check(&s, &km::Options::new(km::Method::Dipole)).is_err());
/// ```
pub fn check(scene: &Scene, options: &Options) -> Result<PlanT, KmError> {
    Ok(prepare(scene, options)?.plan)
}

/// The scene as [`solve`] works on it, checked.
struct Prepared {
    plan: PlanT,
    solver: MethodOptions,
    /// Channels with identical coefficients merged, and the map back.
    reduced: Option<(Scene, Vec<usize>)>,
    /// The dipole's half-space cut and its bound.
    cut: Option<(Scene, f64)>,
}

fn prepare(scene: &Scene, options: &Options) -> Result<Prepared, KmError> {
    let method = options.method();
    let all_effects = options.all_effects || options.method.all_effects();
    let plan = plan_for(scene, method, all_effects);
    let mut solver =
        cone::with_cone(options.method.with_all_effects(all_effects), options.cone_deg)?;
    if let (MethodOptions::Mc(o), Some(c)) = (&mut solver, &options.cancel) {
        o.cancel.get_or_insert_with(|| c.clone());
    }
    // Channels with identical coefficients are solved once (`duplicate-channels`).
    let reduced = plan.skips(Simplification::DuplicateChannels).then(|| reduce_channels(scene));
    let work = reduced.as_ref().map_or(scene, |(r, _)| r);
    let cut = if method == Method::Dipole { as_half_space(work, all_effects) } else { None };
    let work = cut.as_ref().map_or(work, |(half, _)| half);
    solver.supports(work)?;
    Ok(Prepared { plan, solver, reduced, cut })
}

/// The plan of `scene` for `method`: what the scene calls for and the
/// simplifications the method takes (docs/planner.md).
///
/// ```
/// let s = km::Scene::from_toml_str("[[layer]]\ntau = 1\nalbedo = 0.5\n").unwrap();
/// let p = km::plan_for(&s, km::Method::Mc, false);
/// assert!(p.skips(km::Simplification::AngularTallies));
/// assert!(!p.skips(km::Simplification::Azimuth), "a Fourier matter, not Monte Carlo's");
/// ```
pub fn plan_for(scene: &Scene, method: Method, all_effects: bool) -> PlanT {
    let request = scene.channels().first().map(Request::from_scene).unwrap_or_default();
    plan_scene(scene, request, all_effects).restricted_to(method.simplifications())
}

/// The dipole treats half-spaces only; a finite top layer that the planner's
/// `transmission` rule makes a half-space in every channel is one (with the
/// largest bound of the neglected light).
fn as_half_space(scene: &Scene, all_effects: bool) -> Option<(Scene, f64)> {
    if all_effects {
        return None;
    }
    let mut bound = 0.0f64;
    let mut channels = Vec::with_capacity(scene.channels().len());
    for c in scene.channels() {
        let plan = PlanT::new(c, Request::default(), false);
        let cut = plan.layers.first().and_then(|l| l.cutoff_bound)?;
        bound = bound.max(cut);
        channels.push(c.cut_below(0).ok()?);
    }
    Some((scene.with_channels(channels).ok()?, bound))
}
