//! Options of a Monte Carlo run ([`McOptions`]) and their validation.

use serde::{Deserialize, Serialize};

use crate::error::McError;
use crate::grid::McGrid;

/// How absorption is simulated (docs/montecarlo.md §4 states what each tallies).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum Estimator {
    /// Implicit capture (MCML): at each interaction the fraction `1 - albedo`
    /// of the weight is deposited and the photon goes on with the rest; the
    /// first-surface Fresnel reflection is split deterministically; Russian
    /// roulette below [`McOptions::roulette_threshold`].
    #[default]
    #[cfg_attr(
        feature = "clap",
        value(
            name = "survival",
            help = "Survival biasing (implicit capture) with Russian roulette, as MCML"
        )
    )]
    SurvivalBiasing,
    /// Analog: weight 1 throughout; absorption, Fresnel reflection and the
    /// Lambertian albedo are all decided by a random number.
    #[cfg_attr(feature = "clap", value(name = "analog", help = "Analog absorption"))]
    Analog,
}

impl Estimator {
    /// Lower-case name used in JSON output.
    pub fn name(&self) -> &'static str {
        match self {
            Estimator::SurvivalBiasing => "survival-biasing",
            Estimator::Analog => "analog",
        }
    }
}

/// Annuli for the radially resolved diffuse reflectance `Rd(r)` (MCML's `Rd_r`).
///
/// Annulus `i` covers `i dr <= r < (i + 1) dr`, `i < count`; photons escaping
/// beyond `count dr` are counted in an overflow tally.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct RadialBins {
    /// Annulus width, in the length unit of the scene (`> 0`).
    pub dr: f64,
    /// Number of annuli (`>= 1`).
    pub count: usize,
}

/// Planes and directions of the radiance inside the stack (docs/field.md
/// §4a): at each depth, the photons crossing the plane there within a cone
/// of half-angle `half_angle_deg` around each direction score `w / |mu|`,
/// and the tally over the cone's solid angle is the radiance's cone average.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct InsideBins {
    /// Depths of the planes, in the scene's length unit (finite, `>= 0`; a
    /// depth on an interface is the layer above's side).
    pub depths: Vec<f64>,
    /// Directions `[theta, phi]` in degrees: `theta` from the downward normal
    /// (`< 90` down-going, `> 90` up-going, not 90), `phi` with 180 on the
    /// side towards which the beam travels.
    pub directions: Vec<[f64; 2]>,
    /// Half-angle of the cones, degrees (`(0, 45]`; narrowed near the
    /// horizon as the exit cones are, eq. B2').
    pub half_angle_deg: f64,
}

/// Most planes times directions of [`InsideBins`].
pub const MAX_INSIDE_BINS: usize = 100_000;

/// Options of a Monte Carlo run.
///
/// `Default` gives 10^6 photons, seed 1, survival biasing, all cores,
/// 5 degree angular bins, no radial profile, no progress callback, no
/// cancel flag.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct McOptions {
    /// Number of photons per channel (`>= 1`).
    pub samples: u64,
    /// Seed of the run; batch `b` of channel `c` uses a xoshiro256++ generator seeded from `(seed, c, b)`.
    pub seed: u64,
    /// Worker threads (`None`: rayon's default, all cores). Never changes the result.
    pub threads: Option<usize>,
    /// Absorption estimator.
    pub estimator: Estimator,
    /// Photons per batch (`None`: `max(ceil(samples / 1000), min(100, ceil(samples / 2)))`,
    /// i.e. about 1000 batches for large runs). Batches are the unit of
    /// parallel work, of reproducibility and of the standard errors.
    pub batch_size: Option<u64>,
    /// Maximum number of steps (interactions plus interface crossings) of one
    /// photon; a photon that reaches it is stopped and its weight is booked as
    /// `lost_weight`, reported as the bias bound of every total (`>= 1`).
    pub max_steps_per_photon: u64,
    /// Budget of photon steps for the whole run (all channels); the run is
    /// refused with [`McError::TooExpensive`] as soon as the projection from the
    /// completed batches, or the count itself, exceeds it. `None`: no budget.
    pub max_events: Option<u64>,
    /// Survival biasing: Russian roulette is played when the weight falls below this (`(0, 1)`).
    pub roulette_threshold: f64,
    /// Survival biasing: survival probability of the roulette (`(0, 1]`).
    pub roulette_survival: f64,
    /// Half-angle of the cone around each output direction over which the
    /// BRDF/BTDF is averaged, degrees (`(0, 45]`).
    pub bin_half_angle_deg: f64,
    /// Optional edges in `mu = cos(theta)` (increasing, within `[0, 1]`) of
    /// azimuthal rings: the azimuth-averaged BRDF/BTDF per ring, to compare
    /// with a discrete-ordinates solver bin by bin.
    pub ring_mu_edges: Option<Vec<f64>>,
    /// Optional radial bins for `Rd(r)`.
    pub radial: Option<RadialBins>,
    /// Called after each batch with the photons done and the photons of
    /// the run (each traced in every channel; from the worker threads, in
    /// any order); never changes the
    /// result. The library draws nothing itself: a command-line tool turns
    /// this into a progress bar.
    #[serde(skip)]
    pub progress: Option<Progress>,
    /// A flag that stops the run when raised ([`km_core::Cancel`]): read
    /// before each batch and every [`CANCEL_CHECK_PHOTONS`] photons within
    /// one; the run then returns [`McError::Cancelled`]. Never changes a
    /// result that is returned.
    #[serde(skip)]
    pub cancel: Option<km_core::Cancel>,
    /// Switch the planner off (`docs/planner.md`): the Fresnel test is made
    /// at every boundary, also between equal indices (reflectance 0, but the
    /// reflectance is computed and the random draw made), and the angular
    /// rings are tallied even when no direction is asked
    /// ([`crate::bins::gauss_ring_edges`]`(8)` unless `ring_mu_edges` is set).
    /// Default false: the plan is obeyed (no Fresnel test where the indices
    /// match, no angular tallies unless asked). Changes the random stream, not
    /// the expected answer.
    #[serde(default)]
    pub all_effects: bool,
    /// Allow more than [`max_threads`] worker threads (default false: a
    /// larger `threads` is refused). Never changes the result.
    #[serde(default)]
    pub force_threads: bool,
    /// Budget of tally memory, bytes: the run keeps every batch's sums
    /// (batches x channels x (8 + layers + 2 directions + 2 rings + annuli)
    /// `f64`s) for the standard errors, and is refused before it starts when
    /// they would exceed this. Default [`DEFAULT_MAX_TALLY_BYTES`].
    #[serde(default = "default_max_tally_bytes")]
    pub max_tally_bytes: u64,
    /// Optional MCML-style grid ([`McGrid`], docs/montecarlo.md §7):
    /// `A(z)`, `phi(z)`, the net flux, `A(r, z)`, `Rd(r, a)`, `Tt(r, a)`
    /// and their marginals, read with [`crate::solve_grid`]. Its sums
    /// count in the tally memory ([`McOptions::max_tally_bytes`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub grid: Option<McGrid>,
    /// Optional radiance inside the stack ([`InsideBins`]), read with
    /// [`crate::solve_inside`]. Its sums count in the tally memory.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub inside: Option<Box<InsideBins>>,
}

/// Photons traced between two reads of [`McOptions::cancel`] within a batch
/// (about a millisecond for a photon of ten steps).
pub const CANCEL_CHECK_PHOTONS: u64 = 4096;

/// Default [`McOptions::max_events`]: 2 x 10^10 photon steps, about five
/// minutes on one core at the ~7 x 10^7 steps per second measured for the
/// examples.
pub const DEFAULT_MAX_EVENTS: u64 = 20_000_000_000;

/// Default [`McOptions::max_tally_bytes`]: 256 MiB.
pub const DEFAULT_MAX_TALLY_BYTES: u64 = 256 << 20;

/// Largest number of radial annuli ([`RadialBins::count`]): 10^6.
pub const MAX_RADIAL_BINS: usize = 1_000_000;

fn default_max_tally_bytes() -> u64 {
    DEFAULT_MAX_TALLY_BYTES
}

/// The largest thread count accepted without [`McOptions::force_threads`]:
/// four times the cores the system reports (at least 4).
pub fn max_threads() -> usize {
    std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1).saturating_mul(4).max(4)
}

impl Default for McOptions {
    fn default() -> Self {
        McOptions {
            samples: 1_000_000,
            seed: 1,
            threads: None,
            estimator: Estimator::SurvivalBiasing,
            batch_size: None,
            max_steps_per_photon: 1_000_000,
            max_events: Some(DEFAULT_MAX_EVENTS),
            roulette_threshold: 1e-4,
            roulette_survival: 0.1,
            bin_half_angle_deg: 5.0,
            ring_mu_edges: None,
            radial: None,
            progress: None,
            cancel: None,
            all_effects: false,
            force_threads: false,
            max_tally_bytes: DEFAULT_MAX_TALLY_BYTES,
            grid: None,
            inside: None,
        }
    }
}

fn bad(name: &'static str, value: impl ToString, reason: &'static str) -> McError {
    McError::Option { name, value: value.to_string(), reason }
}

impl McOptions {
    /// Check every option against its domain.
    ///
    /// # Errors
    /// [`McError::Option`] naming the first offending option.
    pub fn validate(&self) -> Result<(), McError> {
        if self.samples == 0 {
            return Err(bad("samples", 0, "need at least one photon"));
        }
        if self.threads == Some(0) {
            return Err(bad("threads", 0, "need at least one thread"));
        }
        if let Some(n) = self.threads.filter(|&n| n > max_threads() && !self.force_threads) {
            return Err(bad(
                "threads",
                n,
                "more than 4 x the cores of this machine (set force_threads to insist)",
            ));
        }
        if self.batch_size == Some(0) {
            return Err(bad("batch_size", 0, "need at least one photon per batch"));
        }
        if self.max_steps_per_photon == 0 {
            return Err(bad("max_steps_per_photon", 0, "must be >= 1"));
        }
        let t = self.roulette_threshold;
        if !(t > 0.0 && t < 1.0) {
            return Err(bad("roulette_threshold", t, "must lie in (0, 1)"));
        }
        let p = self.roulette_survival;
        if !(p > 0.0 && p <= 1.0) {
            return Err(bad("roulette_survival", p, "must lie in (0, 1]"));
        }
        let a = self.bin_half_angle_deg;
        if !(a > 0.0 && a <= 45.0) {
            return Err(bad("bin_half_angle_deg", a, "must lie in (0, 45] degrees"));
        }
        if let Some(e) = &self.ring_mu_edges {
            let ok = e.len() >= 2
                && e.iter().all(|x| (0.0..=1.0).contains(x))
                && e.windows(2).all(|w| w[0] < w[1]);
            if !ok {
                return Err(bad(
                    "ring_mu_edges",
                    format!("{e:?}"),
                    "need >= 2 increasing values in [0, 1]",
                ));
            }
        }
        if let Some(r) = self.radial {
            if !(r.dr.is_finite() && r.dr > 0.0) {
                return Err(bad("radial.dr", r.dr, "must be finite and > 0"));
            }
            if r.count == 0 {
                return Err(bad("radial.count", 0, "need at least one annulus"));
            }
            if r.count > MAX_RADIAL_BINS {
                return Err(bad("radial.count", r.count, "more than 10^6 annuli"));
            }
        }
        if let Some(g) = &self.grid {
            g.validate()?;
        }
        if let Some(b) = &self.inside {
            b.validate()?;
        }
        Ok(())
    }

    /// Photons per batch for this run (see [`McOptions::batch_size`]).
    pub fn effective_batch_size(&self) -> u64 {
        self.batch_size.unwrap_or_else(|| {
            let n = self.samples.max(1);
            n.div_ceil(1000).max(100.min(n.div_ceil(2)))
        })
    }

    /// Number of batches `ceil(samples / batch_size)`.
    pub fn batch_count(&self) -> u64 {
        self.samples.div_ceil(self.effective_batch_size())
    }

    /// The options a run actually uses: with [`McOptions::all_effects`] and no
    /// rings given, the 8 Gauss rings of [`crate::bins::gauss_ring_edges`].
    pub fn resolved(&self) -> McOptions {
        let mut o = self.clone();
        if o.all_effects && o.ring_mu_edges.is_none() {
            o.ring_mu_edges = Some(crate::bins::gauss_ring_edges(8));
        }
        o
    }

    /// The options with the fields that never change the result (threads,
    /// progress, cancel flag) cleared: what two runs must share to be merged.
    pub fn result_key(&self) -> McOptions {
        McOptions {
            threads: None,
            progress: None,
            cancel: None,
            force_threads: false,
            max_tally_bytes: DEFAULT_MAX_TALLY_BYTES,
            max_events: Some(DEFAULT_MAX_EVENTS),
            ..self.clone()
        }
    }
}

impl InsideBins {
    /// Check the planes, directions and cone.
    ///
    /// # Errors
    /// [`McError::Option`] naming the field.
    pub fn validate(&self) -> Result<(), McError> {
        if self.depths.is_empty() || self.directions.is_empty() {
            return Err(bad("inside", "[]", "need at least one depth and one direction"));
        }
        if self.depths.len().saturating_mul(self.directions.len()) > MAX_INSIDE_BINS {
            return Err(bad(
                "inside",
                self.depths.len() * self.directions.len(),
                "more than 10^5 depths x directions",
            ));
        }
        if let Some(z) = self.depths.iter().find(|z| !(z.is_finite() && **z >= 0.0)) {
            return Err(bad("inside.depths", z, "every depth must be finite and >= 0"));
        }
        for d in &self.directions {
            if !(d[0] >= 0.0 && d[0] <= 180.0) || d[0] == 90.0 || !d[1].is_finite() {
                return Err(bad(
                    "inside.directions",
                    format!("{d:?}"),
                    "theta must lie in [0, 180] degrees and not be 90, phi be finite",
                ));
            }
        }
        let a = self.half_angle_deg;
        if !(a > 0.0 && a <= 45.0) {
            return Err(bad("inside.half_angle_deg", a, "must lie in (0, 45] degrees"));
        }
        Ok(())
    }

    /// Per direction, the cone's half-angle (radians; narrowed so that the
    /// cone stays within its hemisphere, eq. B2').
    pub fn half_angles(&self) -> Vec<f64> {
        self.directions
            .iter()
            .map(|d| {
                let t = if d[0] > 90.0 { 180.0 - d[0] } else { d[0] };
                crate::bins::cone_half_angle(t.to_radians(), self.half_angle_deg.to_radians())
            })
            .collect()
    }
}

/// A progress callback of a run: `(photons done, photons of the run)`.
///
/// ```
/// use std::sync::atomic::{AtomicU64, Ordering};
/// use std::sync::Arc;
/// let (seen, last) = (Arc::new(AtomicU64::new(0)), Arc::new(AtomicU64::new(0)));
/// let (s, l) = (seen.clone(), last.clone());
/// let p = km_montecarlo::Progress::new(move |done, total| {
///     assert_eq!(total, 1000);
///     s.fetch_add(1, Ordering::Relaxed);
///     l.fetch_max(done, Ordering::Relaxed);
/// });
/// let opts = km_montecarlo::McOptions { samples: 1000, progress: Some(p), ..Default::default() };
/// let scene = km_core::Scene::from_toml_str("[[layer]]\ntau = 1\nalbedo = 0.5\n").unwrap();
/// km_montecarlo::solve(&scene, &opts).unwrap();
/// assert!(seen.load(Ordering::Relaxed) >= 1);
/// // Every photon is counted once.
/// assert_eq!(last.load(Ordering::Relaxed), 1000);
/// ```
#[derive(Clone)]
pub struct Progress(std::sync::Arc<dyn Fn(u64, u64) + Send + Sync>);

impl Progress {
    /// Wrap a callback.
    pub fn new(f: impl Fn(u64, u64) + Send + Sync + 'static) -> Progress {
        Progress(std::sync::Arc::new(f))
    }

    /// Report `done` of `total` photons.
    pub fn report(&self, done: u64, total: u64) {
        (self.0)(done, total);
    }
}

impl std::fmt::Debug for Progress {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Progress(..)")
    }
}

/// Two callbacks are equal when they are the same closure (never compared by result).
impl PartialEq for Progress {
    fn eq(&self, other: &Progress) -> bool {
        std::sync::Arc::ptr_eq(&self.0, &other.0)
    }
}
