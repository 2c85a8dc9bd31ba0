//! The options of the Fourier–Gauss solver and its default stream counts
//! (measured in `docs/multiflux.md` §8), shared by the solver and its work
//! budget ([`crate::budget`]).

use km_core::{MonoScene, Substrate};

/// Default number of Gauss nodes per hemisphere (per Snell segment): meets
/// the 1e-4 accuracy target on the reference cases (see `docs/multiflux.md`).
pub const DEFAULT_STREAMS: usize = 16;

/// Default for the slow corners of the hard-case grid (`docs/multiflux.md` §8):
/// a strongly peaked phase function (`|g| > 0.8`) inside a layer whose index
/// differs from the ambient's, or incidence beyond 80 degrees.
pub const DEFAULT_STREAMS_HARD: usize = 32;

/// Default for totals with a nearly singular forward peak (`|g| > 0.95`) at
/// incidence beyond 80 degrees on an index-matched stack; see
/// [`default_streams`].
pub const DEFAULT_STREAMS_PEAKED: usize = 128;

/// Default when exit directions are asked for in a layer with `|g| > 0.9`
/// (BRDF/BTDF within 1 % up to g = 0.95; see [`default_streams`]).
pub const DEFAULT_STREAMS_ANGULAR: usize = 48;

/// The stream count used when the options give none: [`DEFAULT_STREAMS`], or
/// [`DEFAULT_STREAMS_HARD`] for the slow corners (measured: |g| = 0.9 in an
/// index of 1.5 or 2.5 is 1.2e-3 from converged at 16 streams, 3e-5 at 32;
/// 89 degrees with g = 0.9, 1e-3 and 7e-6).
///
/// A scattering layer with `|g| > 0.95` needs more (`docs/multiflux.md` §8,
/// measured at g = 0.99 against 256 streams): 32 streams at least (in air
/// up to 75 degrees 16 streams miss by 1.5e-4, 32 by 2e-5), and for totals
/// at incidence beyond 80 degrees on an index-matched stack
/// [`DEFAULT_STREAMS_PEAKED`] (89 degrees: 2e-2 at 16 streams, 2e-3 at 32,
/// 1.5e-3 at 64, 9e-5 at 128 for w = 0.99, 1.5e-4 for w = 0.5; its time
/// in docs/benchmarks.md, "Times behind limits and defaults").
/// With BRDF/BTDF directions the answer is the angular distribution and the
/// rule follows its convergence (measured against DISORT at 256 streams, the
/// worst value of 48 slabs at 30-85 degrees, `docs/multiflux.md` §8): 32
/// streams for `0.8 < |g| <= 0.9`, [`DEFAULT_STREAMS_ANGULAR`] beyond; totals
/// alone keep the rules above. [`DEFAULT_STREAMS_PEAKED`] is not taken with
/// directions (all `2N` Fourier orders are
/// needed there: 1 s at 128 streams), nor with refractive interfaces, where 128 streams (2-4 N
/// nodes per medium) lose energy balance to 1e-8..4e-7, beyond the
/// 1e-9 the solver otherwise keeps (g = 0.99 in n = 1.5 stays ~1e-3 off at
/// 32 streams; ask for `streams` explicitly to trade).
pub fn default_streams(scene: &MonoScene) -> usize {
    let grazing = scene.light().mu0().is_some_and(|mu0| mu0 < 80f64.to_radians().cos());
    streams_rule(scene, grazing, !scene.directions_deg().is_empty())
}

/// The default stream count of the whole BSDF of `scene` at the incidences
/// `theta_i_deg`: [`default_streams`] with exit directions, for the most
/// demanding incidence (one beyond 80 degrees counts as grazing), so that
/// every incidence of one table is solved on the same nodes.
pub fn default_bsdf_streams(scene: &MonoScene, theta_i_deg: &[f64]) -> usize {
    let grazing = theta_i_deg.iter().any(|t| t.to_radians().cos() < 80f64.to_radians().cos());
    streams_rule(scene, grazing, true)
}

/// The rule of [`default_streams`] for an incidence that is `grazing` or not,
/// with or without exit directions (`angles`).
fn streams_rule(scene: &MonoScene, grazing: bool, angles: bool) -> usize {
    let peaked_mismatch = scene
        .layers()
        .iter()
        .any(|l| l.g().abs() > 0.8 && l.albedo() > 0.0 && l.n() != scene.ambient_n());
    let very_peaked = scene.layers().iter().any(|l| l.g().abs() > 0.95 && l.albedo() > 0.0);
    let matched = scene.layers().iter().all(|l| l.n() == scene.ambient_n())
        && !matches!(scene.substrate(), Substrate::Transparent { n } if n != scene.ambient_n());
    // Exit directions asked for (BRDF/BTDF within 1 % or 1e-4 for |g| <= 0.95
    // up to 85 degrees; `docs/multiflux.md` §8, table 8b): 48 streams beyond
    // |g| = 0.9 (g = 0.95: 1.0e-2 worst at 32, 1.2e-3 at 48), 32 beyond 0.8
    // (g = 0.9: 8.3e-4 at 24, 1.0e-4 at 32; g = 0.8: 6.9e-5 at 16).
    let max_g =
        scene.layers().iter().filter(|l| l.albedo() > 0.0).fold(0.0f64, |a, l| a.max(l.g().abs()));
    if angles && max_g > 0.9 {
        DEFAULT_STREAMS_ANGULAR
    } else if very_peaked && grazing && matched && !angles {
        DEFAULT_STREAMS_PEAKED
    } else if grazing || peaked_mismatch || very_peaked || (angles && max_g > 0.8) {
        DEFAULT_STREAMS_HARD
    } else {
        DEFAULT_STREAMS
    }
}

/// Relative size below which two consecutive Fourier orders end the azimuthal
/// series of the BRDF/BTDF (DISORT's azimuthal convergence test, ACCUR): the
/// default of [`MultifluxOptions::fourier_tol`].
pub const FOURIER_TOL: f64 = 1e-9;

/// The largest [`MultifluxOptions::fourier_tol`] accepted.
pub const MAX_FOURIER_TOL: f64 = 0.1;

/// Options of the Fourier–Gauss solver.
#[derive(Debug, Clone, PartialEq)]
pub struct MultifluxOptions {
    /// Gauss nodes per hemisphere and per Snell segment (`None`: [`default_streams`]).
    pub streams: Option<usize>,
    /// Truncate the adding of layers after this many round trips (seed eq. 21);
    /// `None` = exact adding.
    pub neumann_order: Option<usize>,
    /// Upper bound on the Fourier order used for BRDF/BTDF (`None`: as needed).
    pub max_fourier_order: Option<usize>,
    /// The azimuthal series of BRDF/BTDF values stops after two consecutive
    /// orders whose multiply scattered part is at most this fraction of the
    /// largest value (eq. 5i–5k of `docs/multiflux.md`; DISORT's ACCUR);
    /// default [`FOURIER_TOL`], at most [`MAX_FOURIER_TOL`]. The series'
    /// error stays within a few times it (docs/benchmarks.md §9).
    pub fourier_tol: f64,
    /// Delta-M scaling of the phase function (Wiscombe 1977); default true.
    pub delta_m: bool,
    /// With `delta_m`, keep `3N/2` Legendre moments instead of `2N` for a
    /// layer whose phase function is given as data (`legendre`, `table`,
    /// `particles`) and whose moments are still flat at `l = 2N` (a diffraction peak;
    /// eq. 4b of `docs/multiflux.md`, [`crate::legendre::kept_moments`]);
    /// default true. False: `2N` for every layer, as DISORT.
    pub peak_truncation: bool,
    /// Switch the planner ([`km_core::plan::Plan`]) off: build every interface
    /// (also between equal indices, where it is the identity), eigen-solve
    /// every layer (also those that only absorb), compute every Fourier order
    /// the streams resolve (`2N - 1`) even for totals, and never cut a thick
    /// layer (`docs/planner.md`). Default false: the plan is obeyed.
    pub all_effects: bool,
    /// The second-order (IMS) part of the intensity correction at user exit
    /// directions (`docs/multiflux.md` eq. 5a–5e; Nakajima & Tanaka 1988);
    /// default true. The single-scattering part (TMS) comes with `delta_m`.
    pub secondary_correction: bool,
    /// Work budget of one solve (eq. W1 of [`crate::budget`]; `None`:
    /// [`crate::budget::DEFAULT_MAX_WORK`]). A solve estimated above it is refused before
    /// it starts.
    pub max_work: Option<f64>,
}

impl Default for MultifluxOptions {
    fn default() -> Self {
        MultifluxOptions {
            streams: None,
            neumann_order: None,
            max_fourier_order: None,
            fourier_tol: FOURIER_TOL,
            delta_m: true,
            peak_truncation: true,
            all_effects: false,
            secondary_correction: true,
            max_work: None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use km_core::{Layer, Light, Substrate};

    /// The BSDF's default is the largest [`default_streams`] of the channel
    /// lit at each incidence with an exit direction: checked against that
    /// definition over stacks that reach each branch of the rule.
    #[test]
    fn bsdf_default_is_the_largest_default_over_the_incidences() {
        let grids: [&[f64]; 3] = [&[0.0, 30.0, 60.0], &[10.0, 80.0], &[5.0, 80.5, 89.5]];
        for (g, n) in [(0.0, 1.0), (0.5, 1.4), (0.85, 1.0), (0.85, 1.4), (0.93, 1.0), (0.97, 1.0)] {
            let layer = Layer::new(0.1, 1.0, 1.0, g, n).unwrap();
            let scene = MonoScene::new(Light::Diffuse, 1.0, vec![layer], Substrate::Black, vec![])
                .unwrap()
                .with_directions(vec![[0.0, 0.0]])
                .unwrap();
            for grid in grids {
                let by_scene = grid
                    .iter()
                    .map(|&t| {
                        let lit = scene.with_light(Light::collimated(t.min(89.0)).unwrap());
                        default_streams(&lit.unwrap())
                    })
                    .max()
                    .unwrap();
                assert_eq!(default_bsdf_streams(&scene, grid), by_scene, "g = {g}, n = {n}");
            }
        }
    }
}
