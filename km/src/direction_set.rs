//! The direction-set mode of the multi-flux solver as a method of its own
//! (`direction-set`): the seed's discretisation of the sphere into a finite
//! set of directions (seed 000 §3, eq. 18–20; docs/multiflux-direction-set.md),
//! solved by `km_multiflux::direction_set`, behind the one [`Solver`] interface.
//!
//! What it treats: every stack of the scene file (layers, interfaces between
//! media of different index, Lambertian, black or clear substrates) under
//! collimated or diffuse light, for the totals and their delta parts. What it
//! lacks, and so refuses ([`Reason`]): BRDF/BTDF values at the scene's output
//! directions (it has radiances on its own nodes only, docs §5), a clear
//! half-space layer (no medium to put a set in below an interface that
//! nothing crosses back), and sets too large for the memory it may use.

use std::time::Instant;

use km_core::solution::{Diagnostics, DirectionSetDiagnostics, MethodDiagnostics};
use km_core::{ChannelResult, Light, MonoScene, Scene, Solution, Substrate};
use km_multiflux::direction_set::{Combine, Incidence, MatchedSets, brdf_for_incidence, totals};

use crate::error::{KmError, Reason, Unsupported};
use crate::{Method, Solver};

/// The paper's size of the set on the sphere (seed 000 §4.2: 303 directions;
/// the layout of docs/multiflux-direction-set.md §2 gives 302 of them).
pub const DEFAULT_DIRECTIONS: usize = 303;

/// The largest `directions` accepted: twice the 1000 of the measured range of
/// docs/multiflux-direction-set.md Table 1.
pub const MAX_DIRECTIONS: usize = 2000;

/// The smallest `directions` accepted (two rings per hemisphere).
pub const MIN_DIRECTIONS: usize = 4;

/// The largest number of downward directions of one medium's set. A medium
/// holds the mapped rings of every lower-index one plus its own
/// total-internal-reflection cone (docs eq. D4), so each distinct index adds
/// to the sets of the denser media (measured: 1000 downward directions in air
/// become 1560 at n = 1.3, 1818 at n = 2.5; five more indices, 1.2 to 3.0,
/// make 3456). The solver keeps about ten `N x N` matrices of f64 per layer,
/// 320 MB at this bound (the time of one such layer: docs/benchmarks.md,
/// "Times behind limits and defaults").
pub const MAX_SET_DIRECTIONS: usize = 2000;

/// Settings of the direction-set method.
///
/// ```
/// use km::{DirectionSetOptions, Scene, Solver};
/// let scene = Scene::from_toml_str("[[layer]]\ntau = 1\nalbedo = 0.9\n").unwrap();
/// let sol = DirectionSetOptions { directions: 100 }.solve_unplanned(&scene).unwrap();
/// let c = &sol.channels[0];
/// // docs/multiflux-direction-set.md Table 1: R = 0.26741, T = 0.59163 (DISORT), error 4.4e-5 at 100.
/// assert!((c.reflectance - 0.26741).abs() < 1e-4 && (c.transmittance - 0.59163).abs() < 1e-4);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct DirectionSetOptions {
    /// About how many directions (both hemispheres) the set of the medium of
    /// lowest index holds, in `[MIN_DIRECTIONS, MAX_DIRECTIONS]`; the sets of
    /// denser media are larger (docs/multiflux-direction-set.md §2).
    pub directions: usize,
}

impl Default for DirectionSetOptions {
    fn default() -> Self {
        DirectionSetOptions { directions: DEFAULT_DIRECTIONS }
    }
}

impl DirectionSetOptions {
    fn check(&self) -> Result<(), KmError> {
        if (MIN_DIRECTIONS..=MAX_DIRECTIONS).contains(&self.directions) {
            return Ok(());
        }
        Err(KmError::Option {
            name: "directions",
            value: self.directions.to_string(),
            reason: "must lie in [4, 2000]",
        })
    }
}

/// The matched sets of one channel (ambient, every layer, a clear substrate).
fn channel_sets(c: &MonoScene, directions: usize) -> Result<MatchedSets, KmError> {
    let mut media = vec![c.ambient_n()];
    media.extend(c.layers().iter().map(|l| l.n()));
    media.extend(c.substrate_n());
    let incidence = match c.light() {
        Light::Collimated { theta_deg } => Some(Incidence { n: c.ambient_n(), theta_deg }),
        Light::Diffuse => None,
    };
    Ok(MatchedSets::new(directions, &media, incidence)?)
}

/// The same channel without scattering and with a black substrate in place of
/// a Lambertian one: its totals are exactly the delta parts (mirror
/// reflection, unscattered transmission) of the full channel
/// (docs/multiflux-direction-set.md §5, "Beam and BRDF").
fn unscattered(c: &MonoScene) -> Result<MonoScene, KmError> {
    // Extinction kept whole: the unscattered beam decays with sigma_t.
    let layers = c.layers().iter().map(|l| l.with_coefficients(l.sigma_t(), 0.0));
    let d = c.with_layers(layers.collect::<Result<Vec<_>, _>>()?)?;
    Ok(match d.substrate() {
        Substrate::Lambertian { .. } => d.with_substrate(Substrate::Black)?,
        _ => d,
    })
}

/// The totals and delta parts of one channel on sets of about `directions`.
fn solve_channel(c: &MonoScene, directions: usize) -> Result<ChannelResult, KmError> {
    let (r, r_spec, t, t_direct) = match c.light() {
        // The beam on a node: its column of the stack's operators (eq. D13).
        Light::Collimated { .. } => {
            let s = brdf_for_incidence(c, directions, Combine::Exact)?;
            (s.reflectance, s.reflectance_specular, s.transmittance, s.transmittance_direct)
        }
        // Uniform radiance on every downward node; the delta parts from the
        // unscattered stack under the same light.
        Light::Diffuse => {
            let (r, t) = totals(c, directions)?;
            let (r_spec, t_direct) = totals(&unscattered(c)?, directions)?;
            (r, r_spec, t, t_direct)
        }
    };
    Ok(ChannelResult {
        reflectance: r,
        reflectance_specular: r_spec,
        transmittance: t,
        transmittance_direct: t_direct,
        absorptance: 1.0 - r - t,
        ..Default::default()
    })
}

impl Solver for DirectionSetOptions {
    fn method(&self) -> Method {
        Method::DirectionSet
    }

    /// No output directions (values on its own nodes only), no clear
    /// half-space layer, and every medium's set within
    /// [`MAX_SET_DIRECTIONS`] (checked when `directions` is in range; an
    /// out-of-range `directions` is [`Solver::solve_unplanned`]'s error).
    fn supports(&self, scene: &Scene) -> Result<(), Unsupported> {
        let no = |reason| Err(Unsupported { method: Method::DirectionSet, reason });
        for (channel, c) in scene.channels().iter().enumerate() {
            if !c.directions_deg().is_empty() {
                return no(Reason::OutputDirections { directions: c.directions_deg().len() });
            }
            if let Some(i) = c.layers().iter().position(|l| l.is_half_space() && l.sigma_t() == 0.0)
            {
                return no(Reason::ClearHalfSpace { layer: i + 1 });
            }
            if self.check().is_err() {
                continue;
            }
            // The sets alone (rings and weights, no operator) are cheap to build.
            if let Ok(sets) = channel_sets(c, self.directions) {
                let largest = sets.sets().iter().map(|s| s.len()).max().unwrap_or(0);
                if largest > MAX_SET_DIRECTIONS {
                    return no(Reason::SetTooLarge {
                        channel,
                        directions: largest,
                        limit: MAX_SET_DIRECTIONS,
                    });
                }
            }
        }
        Ok(())
    }

    /// Each channel on its matched sets; the totals and delta parts, no
    /// angular values. The diagnostics are [`DirectionSetDiagnostics`] (JSON
    /// `direction_set`: `directions`, the setting, and `nodes`, directions of
    /// the ambient set in both hemispheres, a list over channels for several).
    fn solve_unplanned(&self, scene: &Scene) -> Result<Solution, KmError> {
        self.check()?;
        self.supports(scene)?;
        let start = Instant::now();
        let mut channels = Vec::with_capacity(scene.channels().len());
        let mut nodes = Vec::with_capacity(scene.channels().len());
        for c in scene.channels() {
            channels.push(solve_channel(c, self.directions)?);
            let sets = channel_sets(c, self.directions)?;
            nodes.push(2 * sets.set(c.ambient_n())?.len());
        }
        let diagnostics = Diagnostics {
            method: MethodDiagnostics::DirectionSet(DirectionSetDiagnostics {
                directions: self.directions,
                nodes,
            }),
            ..Default::default()
        };
        Ok(Solution {
            method: Method::DirectionSet.name().into(),
            channels,
            labels: scene.labels().to_vec(),
            seconds: start.elapsed().as_secs_f64(),
            diagnostics,
            ..Default::default()
        })
    }

    /// The direction set has no error estimate to meet a target with: its
    /// error is set by `directions` (docs/multiflux-direction-set.md Table 1).
    fn solve_unplanned_to(&self, _scene: &Scene, tol: f64) -> Result<Solution, KmError> {
        Err(KmError::Option {
            name: "accuracy target",
            value: tol.to_string(),
            reason: "the direction-set method has no error estimate; its accuracy is set by the \
                     number of directions",
        })
    }
}
