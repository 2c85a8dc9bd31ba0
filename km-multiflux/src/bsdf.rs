//! The whole BSDF of a stack from one set of operators per Fourier order
//! (`docs/bsdf.md`).
//!
//! For every Fourier order `m` the stack's operators are built once on the
//! quadrature nodes plus one extra column per incidence angle (a collimated
//! beam) and one extra row per exit polar angle (a probe of zero weight whose
//! value is the source-function integral along the exit path, Stamnes et al.
//! 1988 §3.6): the same operators `km solve` builds for one direction,
//! shared by every pair. The smooth part of the BRDF/BTDF is then
//!
//! ```text
//!   f(mu_i, mu_o, phi) = sum_{m=0}^{M} c_m(mu_i, mu_o) cos m (phi - 180 deg)      (B1)
//!                      + sum_l [W_R,l(mu_i, mu_o) F_l(c_R) + W_T,l(mu_i, mu_o) F_l(c_T)]
//! ```
//!
//! the second line being the exact single-scattering correction of
//! Nakajima & Tanaka (1988) that the solver applies at `m = 0` (eq. 5 of
//! `docs/multiflux.md`):
//! `F_l(cos Theta) = [omega p(cos Theta) / (1 - omega f) - omega* p*(cos Theta)] / mu_b`
//! in layer `l`, at the scattering cosines
//! `c_R = -mu_x mu_b + s_x s_b cos(phi - 180)` (exit on the side the beam
//! entered) and `c_T = mu_x mu_b + s_x s_b cos(phi - 180)` (the other side).
//! The stack answer is linear in each layer's beam-to-probe entries, so the
//! weights `W` are obtained once per polar pair by carrying, per layer, two
//! "marker" probes whose only source is that layer's path integral of the
//! correction, `beta phi(1/mu_b + beta, tau)` (same side) resp.
//! `beta e2(1/mu_b, beta, tau)` (far side); the correction then costs a few
//! Legendre sums per azimuth.
//!
//! For transmitted exits within 10 degrees of the beam's polar angle the
//! solver also adds the second-order peak term (IMS, eq. C3 of
//! `docs/multiflux.md`), `-(omega f)^2 P(c_T) xi / (4 pi mu_b (1 - omega f))`:
//! a third marker per layer carries its azimuth-free factor
//! ([`crate::correction::PeakCorrection::secondary_path`]) through the same
//! paths, and the evaluation multiplies its weight `W_I` by
//! `(omega f)^2 P(c_T)` (eq. B1a of `docs/bsdf.md`).
//!
//! Per polar pair: `M + 1` coefficients and up to `6 L` weights; per azimuth: a
//! cosine sum. The delta parts (mirror reflection, unscattered beam) are kept
//! apart, as in `km solve`.
//!
//! # Reference
//! Stamnes, Tsay, Wiscombe & Jayaweera 1988 (DISORT; azimuthal series eq. 6,
//! user angles §3.6); Nakajima & Tanaka 1988 (eq. 5 of `docs/multiflux.md`);
//! Jakob et al. 2014 (the BSDF as Fourier coefficients per pair of cosines).

mod build;
pub mod check;
pub mod write;

use km_core::{MonoScene, Scene, Substrate};

use crate::MultifluxError;
use crate::engine::last_moment;
use crate::prepare::resolve_streams;
use crate::quadrature::AngularGrid;
use crate::solver::{MultifluxOptions, default_bsdf_streams};
use build::channel;

/// An error of the BSDF table or its files.
#[derive(Debug, thiserror::Error)]
pub enum BsdfError {
    /// The solver refused the scene or failed.
    #[error(transparent)]
    Solver(#[from] MultifluxError),
    /// A grid value or option outside its domain.
    #[error("invalid {name}: {reason}")]
    Input {
        /// Which input.
        name: &'static str,
        /// What is wrong with it.
        reason: String,
    },
    /// Reading or writing a file failed.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// The cause.
        source: std::io::Error,
    },
}

/// Which side of the stack the light comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Side {
    /// From the ambient medium above (the scene's light side).
    Above,
    /// From the transparent substrate below (the stack turned upside down).
    Below,
}

/// Options of the BSDF table: the solver's options (streams, delta-M,
/// Neumann order, Fourier-order bound) and the side of incidence.
#[derive(Debug, Clone, PartialEq)]
pub struct BsdfOptions {
    /// The solver's options; `streams: None` takes the largest
    /// [`crate::default_streams`] over the incidence angles ([`crate::default_bsdf_streams`]).
    pub solver: MultifluxOptions,
    /// Side of incidence.
    pub side: Side,
}

impl Default for BsdfOptions {
    fn default() -> Self {
        BsdfOptions { solver: MultifluxOptions::default(), side: Side::Above }
    }
}

pub use crate::engine::ChannelBsdf;

/// The BSDF of a stack on a grid of incidence and exit polar angles, any azimuth.
#[derive(Debug, Clone)]
pub struct Bsdf {
    /// Incidence polar angles, degrees, in the medium of incidence.
    pub theta_i: Vec<f64>,
    /// Exit polar angles, degrees, from the normal on each exit side.
    pub theta_o: Vec<f64>,
    /// Side of incidence.
    pub side: Side,
    /// Per channel.
    pub channels: Vec<ChannelBsdf>,
    /// Channel labels of the scene.
    pub labels: Vec<String>,
    /// Whether light leaves through the far side (a transparent substrate
    /// and no half-space).
    pub transmits: bool,
    /// Index of the medium of incidence over that of the far side (`eta` of
    /// the Fourier file is its inverse for incidence from above).
    pub n_in: f64,
    /// Index of the far-side medium (`None` if opaque).
    pub n_out: Option<f64>,
}

/// Check a list of polar angles: finite, in `[0, 90)` degrees, not empty.
fn check_angles(name: &'static str, a: &[f64]) -> Result<(), BsdfError> {
    if a.is_empty() {
        return Err(BsdfError::Input { name, reason: "the list is empty".into() });
    }
    if let Some(x) = a.iter().find(|x| !(x.is_finite() && **x >= 0.0 && **x < 90.0)) {
        return Err(BsdfError::Input { name, reason: format!("{x} is outside [0, 90) degrees") });
    }
    if a.len() > 4096 {
        return Err(BsdfError::Input {
            name,
            reason: format!("{} angles (at most 4096)", a.len()),
        });
    }
    Ok(())
}

/// The scene seen from below: ambient and substrate swapped, layers reversed.
fn flipped(scene: &MonoScene) -> Result<MonoScene, BsdfError> {
    let Substrate::Transparent { n } = scene.substrate() else {
        return Err(BsdfError::Input {
            name: "side",
            reason: "incidence from below needs a transparent substrate".into(),
        });
    };
    if scene.layers().iter().any(|l| l.is_half_space()) {
        return Err(BsdfError::Input {
            name: "side",
            reason: "incidence from below through a half-space layer".into(),
        });
    }
    let mut layers = scene.layers().to_vec();
    layers.reverse();
    let below = Substrate::transparent(scene.ambient_n()).map_err(MultifluxError::from)?;
    let s = MonoScene::new(scene.light(), n, layers, below, scene.directions_deg().to_vec())
        .map_err(MultifluxError::from)?;
    Ok(s)
}

/// Default polar angles (degrees, ascending): the arccosines of the `n`-point
/// Gauss–Legendre nodes on `mu in (0, 1)`, so that hemispherical integrals of
/// the table are Gauss quadratures ([`check::energy`]).
pub fn gauss_angles(n: usize) -> (Vec<f64>, Vec<f64>) {
    let nodes = AngularGrid::new(&[1.0], n.max(1)).medium(1.0);
    let mut pairs: Vec<(f64, f64)> =
        nodes.mu.iter().zip(&nodes.w).map(|(m, w)| (m.acos().to_degrees(), *w)).collect();
    pairs.sort_by(|a, b| a.0.total_cmp(&b.0));
    pairs.into_iter().unzip()
}

impl Bsdf {
    /// Compute the BSDF of every channel of `scene` at incidence angles
    /// `theta_i` and exit polar angles `theta_o` (degrees, `[0, 90)`): the
    /// Fourier coefficients of eq. B1 for every pair, the correction weights,
    /// the totals and the delta parts per incidence. The scene's own light and
    /// `[output]` directions are ignored.
    ///
    /// # Errors
    /// Bad angles or options ([`BsdfError::Input`]), the solver's refusals,
    /// a table over its work budget ([`crate::budget::check_bsdf`]), before
    /// any operator is built.
    ///
    /// ```
    /// use km_multiflux::bsdf::{Bsdf, BsdfOptions};
    /// let scene = km_core::Scene::from_toml_str("[[layer]]\ntau = 1.0\nalbedo = 0.9\ng = 0.5\n").unwrap();
    /// let b = Bsdf::new(&scene, &[30.0], &[0.0, 45.0], &BsdfOptions::default()).unwrap();
    /// assert!(b.brdf(0, 0, 1, 180.0) > b.brdf(0, 0, 1, 0.0));
    /// ```
    pub fn new(
        scene: &Scene,
        theta_i: &[f64],
        theta_o: &[f64],
        opts: &BsdfOptions,
    ) -> Result<Bsdf, BsdfError> {
        check_angles("theta_i", theta_i)?;
        check_angles("theta_o", theta_o)?;
        if opts.solver.all_effects {
            return Err(BsdfError::Input {
                name: "all_effects",
                reason: "the BSDF table always obeys the plan".into(),
            });
        }
        // The work, before any operator is built (eq. W1 with a beam per
        // incidence angle: `crate::budget::estimate_bsdf`).
        crate::budget::check_bsdf(scene, &opts.solver, theta_i, theta_o)?;
        faer::set_global_parallelism(faer::Par::Seq);
        let mut channels = Vec::with_capacity(scene.channels().len());
        let (mut transmits, mut n_in, mut n_out) = (false, 1.0, None);
        for ch in scene.channels() {
            let mono = match opts.side {
                Side::Above => ch.clone(),
                Side::Below => flipped(ch)?,
            };
            let (c, t) = channel(&mono, theta_i, theta_o, &opts.solver)?;
            transmits = t.is_some();
            n_in = mono.ambient_n();
            n_out = t;
            channels.push(c);
        }
        Ok(Bsdf {
            theta_i: theta_i.to_vec(),
            theta_o: theta_o.to_vec(),
            side: opts.side,
            channels,
            labels: scene.labels().to_vec(),
            transmits,
            n_in,
            n_out,
        })
    }

    /// Number of Fourier orders stored for channel `c` (`M + 1`).
    pub fn orders(&self, c: usize) -> usize {
        self.channels[c].orders
    }

    /// The Fourier coefficients `c_m` of eq. B1 (BRDF) for the pair `(i, o)`.
    pub fn brdf_coefficients(&self, c: usize, i: usize, o: usize) -> &[f64] {
        self.channels[c].coefficients(i, o, false)
    }

    /// The Fourier coefficients `c_m` of eq. B1 (BTDF) for the pair `(i, o)`.
    pub fn btdf_coefficients(&self, c: usize, i: usize, o: usize) -> &[f64] {
        self.channels[c].coefficients(i, o, true)
    }

    /// BRDF (smooth part, 1/sr) of channel `c` for incidence `theta_i[i]`,
    /// exit `theta_o[o]` and azimuth `phi_deg` (180 = mirror side): eq. B1.
    pub fn brdf(&self, c: usize, i: usize, o: usize, phi_deg: f64) -> f64 {
        let mut out = [0.0];
        self.eval_into(c, i, o, &[phi_deg], false, &mut out);
        out[0]
    }

    /// BTDF (smooth part, 1/sr): eq. B1 for exits on the far side; 0 when opaque.
    pub fn btdf(&self, c: usize, i: usize, o: usize, phi_deg: f64) -> f64 {
        let mut out = [0.0];
        self.eval_into(c, i, o, &[phi_deg], true, &mut out);
        out[0]
    }

    /// Eq. B1 for one polar pair at every azimuth of `phi_deg` into `out`
    /// (the per-pair data are read once; each azimuth costs a cosine
    /// recurrence of `M` steps and, with a peaked phase function, two
    /// Legendre sums per scattering layer).
    pub fn eval_into(
        &self,
        c: usize,
        i: usize,
        o: usize,
        phi_deg: &[f64],
        transmitted: bool,
        out: &mut [f64],
    ) {
        self.channels[c].eval_into(i, o, phi_deg, transmitted, out);
    }

    /// [`Bsdf::eval_into`] without the exact single rough path (eq. R18 of
    /// docs/rough.md): the series of eq. B1 alone. The path's exact value
    /// minus its series has no azimuthal mean (the series holds its order 0
    /// exactly), so this integrates over azimuth to the same totals as
    /// [`Bsdf::eval_into`] while a grid coarser than a narrow lobe cannot.
    pub fn eval_series_into(
        &self,
        c: usize,
        i: usize,
        o: usize,
        phi_deg: &[f64],
        transmitted: bool,
        out: &mut [f64],
    ) {
        self.channels[c].eval_series_into(i, o, phi_deg, transmitted, out);
    }

    /// Keep the series of eq. B1 alone from now on: through a rough face
    /// the exact single path (eq. R18 of docs/rough.md), which a table
    /// evaluates by default, is dropped. The series is band-limited to the
    /// table's orders, as a renderer interpolating a coarse grid wants; the
    /// exact path is a lobe as narrow as the face's, which such a grid
    /// cannot hold.
    pub fn drop_exact_paths(&mut self) {
        self.channels.iter_mut().for_each(ChannelBsdf::drop_exact_paths);
    }

    /// The table of eq. B1 at every azimuth of `phi_deg`:
    /// `(brdf, btdf)`, each `[((c * n_i + i) * n_o + o) * n_phi + p]`, 1/sr.
    pub fn table(&self, phi_deg: &[f64]) -> (Vec<f64>, Vec<f64>) {
        let (ni, no, np) = (self.theta_i.len(), self.theta_o.len(), phi_deg.len());
        let size = self.channels.len() * ni * no * np;
        let (mut r, mut t) = (vec![0.0; size], vec![0.0; size]);
        for c in 0..self.channels.len() {
            for i in 0..ni {
                for o in 0..no {
                    let k = ((c * ni + i) * no + o) * np;
                    self.eval_into(c, i, o, phi_deg, false, &mut r[k..k + np]);
                    if self.transmits {
                        self.eval_into(c, i, o, phi_deg, true, &mut t[k..k + np]);
                    }
                }
            }
        }
        (r, t)
    }
}
