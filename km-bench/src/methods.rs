//! "A method at a setting" for the recipes, run through the library's one
//! solver interface ([`km::Solver`]), so that the studies can compare the
//! answers; the seed's direction-set mode included
//! ([`km::Method::DirectionSet`], [`km::DirectionSetOptions`]).

use std::fmt;

use km::Solver;
use km_core::{Scene, Solution};

/// The studies' name for [`Setting`].
pub use self::Setting as Method;

/// A method of the library ([`km::Method`]) at one accuracy setting.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Setting {
    /// Two-flux Kubelka–Munk (km-core, seed 000 §2), the seed's identity mapping.
    TwoFlux,
    /// Multi-flux, Fourier–Gauss mode (km-multiflux) with `streams` Gauss
    /// nodes per hemisphere, exact adding.
    Multiflux {
        /// Gauss nodes per hemisphere.
        streams: usize,
    },
    /// Multi-flux, Fourier–Gauss mode at the default streams, layers added
    /// by the Neumann series of seed eq. 21 truncated after `order` round trips.
    Neumann {
        /// Truncation order `k` (0 = no round trip).
        order: usize,
    },
    /// Multi-flux, the seed's direction-set mode on about `directions`
    /// directions of the sphere (totals only: BRDF values live on its nodes).
    DirectionSet {
        /// Number of directions (both hemispheres).
        directions: usize,
    },
    /// Monte Carlo (km-montecarlo), survival biasing, `samples` photons.
    MonteCarlo {
        /// Photons.
        samples: u64,
        /// Seed.
        seed: u64,
    },
    /// The diffusion dipole (semi-infinite media only; km-dipole).
    Dipole,
}

impl fmt::Display for Setting {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Method::TwoFlux => write!(f, "two-flux KM"),
            Method::Multiflux { streams } => write!(f, "multi-flux {streams} streams"),
            Method::Neumann { order } => write!(f, "adding, Neumann order {order}"),
            Method::DirectionSet { directions } => write!(f, "direction set {directions}"),
            Method::MonteCarlo { samples, .. } => write!(f, "Monte Carlo {samples:.0e}"),
            Method::Dipole => write!(f, "dipole"),
        }
    }
}

impl Setting {
    /// The library's method.
    pub fn method(&self) -> km::Method {
        match self {
            Method::TwoFlux => km::Method::Km,
            Method::Multiflux { .. } | Method::Neumann { .. } => km::Method::Multiflux,
            Method::MonteCarlo { .. } => km::Method::Mc,
            Method::Dipole => km::Method::Dipole,
            Method::DirectionSet { .. } => km::Method::DirectionSet,
        }
    }

    /// The library options of this setting.
    pub fn options(&self) -> km::MethodOptions {
        use km::MethodOptions as O;
        match *self {
            Method::TwoFlux => O::Km(km::KmOptions::default()),
            Method::Multiflux { streams } => {
                O::Multiflux(km::MultifluxOptions { streams: Some(streams), ..Default::default() })
            }
            Method::Neumann { order } => O::Multiflux(km::MultifluxOptions {
                neumann_order: Some(order),
                ..Default::default()
            }),
            Method::MonteCarlo { samples, seed } => O::Mc(mc_options(samples, seed)),
            Method::Dipole => O::Dipole(km::DipoleOptions::default()),
            Method::DirectionSet { directions } => {
                O::DirectionSet(km::DirectionSetOptions { directions })
            }
        }
    }

    /// The family name (one Pareto curve per family).
    pub fn family(&self) -> &'static str {
        match self {
            Method::TwoFlux => "km",
            Method::Multiflux { .. } => "multiflux",
            Method::Neumann { .. } => "neumann",
            Method::DirectionSet { .. } => "direction-set",
            Method::MonteCarlo { .. } => "montecarlo",
            Method::Dipole => "dipole",
        }
    }

    /// The setting as a number (streams, order, directions, samples; 0 otherwise).
    pub fn setting(&self) -> f64 {
        match *self {
            Method::Multiflux { streams } => streams as f64,
            Method::Neumann { order } => order as f64,
            Method::DirectionSet { directions } => directions as f64,
            Method::MonteCarlo { samples, .. } => samples as f64,
            Method::TwoFlux | Method::Dipole => 0.0,
        }
    }

    /// Whether the method gives BRDF values at the scene's output directions.
    pub fn has_brdf(&self) -> bool {
        matches!(
            self,
            Method::Multiflux { .. } | Method::Neumann { .. } | Method::MonteCarlo { .. }
        )
    }
}

/// Options of the Monte Carlo runs of the benchmarks: 5 degree cones, a
/// per-photon step cap and a run budget so that hard cases are refused
/// rather than run for hours (the tracer reports the lost weight).
pub fn mc_options(samples: u64, seed: u64) -> km_montecarlo::McOptions {
    km_montecarlo::McOptions {
        samples,
        seed,
        max_events: Some(2_000_000_000),
        ..Default::default()
    }
}

/// Solve `scene` with `method`.
///
/// # Errors
/// The solver's refusal (e.g. the dipole on a finite slab), as text.
pub fn solve(method: Method, scene: &Scene) -> anyhow::Result<Solution> {
    if let Method::DirectionSet { .. } = method {
        // The direction set gives totals only (its angular values live on its
        // own nodes) and refuses output directions: the studies compare its
        // totals, so the scene is solved without them.
        let channels = scene.channels().iter().map(|c| c.with_directions(Vec::new()));
        let totals_only = scene.with_channels(channels.collect::<Result<_, _>>()?)?;
        return Ok(method.options().solve_unplanned(&totals_only)?);
    }
    Ok(method.options().solve_unplanned(scene)?)
}

/// As [`solve`], with the Monte Carlo work bounded: at most `max_steps`
/// steps per photon (the rest of its weight is reported as lost) and a run
/// budget of `max_events` steps (beyond it the run is refused). Other
/// methods are solved as by [`solve`].
///
/// # Errors
/// Those of [`solve`], and the tracer's refusal of an over-budget run.
pub fn solve_bounded(
    method: Method,
    scene: &Scene,
    max_steps: u64,
    max_events: u64,
) -> anyhow::Result<Solution> {
    match method {
        Method::MonteCarlo { samples, seed } => {
            let opts = km::McOptions {
                max_steps_per_photon: max_steps,
                max_events: Some(max_events),
                ..mc_options(samples, seed)
            };
            Ok(opts.solve_unplanned(scene)?)
        }
        _ => solve(method, scene),
    }
}

/// Time a solve: the best of `repeats` runs of the solver's own wall time
/// (`Solution::seconds`), at least one run; returns the last solution and
/// that time.
///
/// # Errors
/// Those of [`solve`].
pub fn timed(method: Method, scene: &Scene, repeats: usize) -> anyhow::Result<(Solution, f64)> {
    let mut sol = solve(method, scene)?;
    let mut best = sol.seconds;
    for _ in 1..repeats.max(1) {
        sol = solve(method, scene)?;
        best = best.min(sol.seconds);
    }
    Ok((sol, best))
}

/// Repeats for timing a method: enough runs of a fast solver for a stable
/// best-of time, one run of a slow one.
pub fn repeats(method: Method) -> usize {
    match method {
        Method::MonteCarlo { .. } => 1,
        Method::DirectionSet { directions } if directions > 400 => 1,
        Method::Multiflux { streams } if streams >= 64 => 2,
        _ => 5,
    }
}

/// The standard error of a Monte Carlo number (`key` in the first channel's `stderr`).
pub fn stderr_of(sol: &Solution, key: &str) -> Option<f64> {
    sol.channels.first()?.stderr.as_ref()?.get(key)
}

/// The standard errors of a Monte Carlo list (`brdf`, `btdf`).
pub fn stderr_list(sol: &Solution, key: &str) -> Option<Vec<f64>> {
    Some(sol.channels.first()?.stderr.as_ref()?.get_list(key)?.to_vec())
}

/// Streams of the converged reference of the studies.
pub fn reference_streams(size: crate::context::Size) -> usize {
    size.pick(32, 64, 192)
}

/// The converged reference used for deviations.
pub fn reference() -> Option<Method> {
    Some(Method::Multiflux { streams: 32 })
}

/// The methods mapped by the stability study at this size.
pub fn stability_methods(size: crate::context::Size) -> Vec<Method> {
    vec![
        Method::TwoFlux,
        Method::Multiflux { streams: km_multiflux::DEFAULT_STREAMS },
        Method::DirectionSet { directions: size.pick(40, 100, 303) },
        Method::MonteCarlo { samples: size.pick(200, 1000, 10_000), seed: 1 },
        Method::Dipole,
    ]
}
