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

pub mod check;
pub mod write;

use faer::Mat;
use km_core::phase::PhaseFunction;
use km_core::{Light, MonoScene, Scene, Substrate};

use crate::MultifluxError;
use crate::adding::LayerOperators;
use crate::correction::{e2, phi};
use crate::interface::{fresnel_operators, lambertian_reflection};
use crate::quadrature::{AngularGrid, mu_of_invariant};
use crate::slab::{Extra, SlabOrder, slab_operators};
use crate::solver::{
    FOURIER_TOL, MultifluxOptions, Scaled, default_streams, flux, media_grid, planned_cutoff,
    resolve_streams, scale_layers,
};
use crate::stack::{StackPieces, add_stack, delta_parts};

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
    /// [`default_streams`] over the incidence angles.
    pub solver: MultifluxOptions,
    /// Side of incidence.
    pub side: Side,
}

impl Default for BsdfOptions {
    fn default() -> Self {
        BsdfOptions { solver: MultifluxOptions::default(), side: Side::Above }
    }
}

/// The correction data of one scattering layer (eq. B1, second line).
#[derive(Debug, Clone)]
pub(crate) struct TmsLayer {
    /// Unscaled albedo, truncation fraction, scaled albedo.
    omega_true: f64,
    f: f64,
    omega: f64,
    /// `(2l + 1) chi*_l`, the scaled moments.
    chiw: Vec<f64>,
    /// Legendre recurrence coefficients `((2l - 1)/l, (l - 1)/l)`.
    rec: Vec<(f64, f64)>,
    phase: km_core::phase::Phase,
    /// Cosines in this layer of the beams and of the BRDF / BTDF probes.
    mu_b: Vec<Option<f64>>,
    mu_r: Vec<Option<f64>>,
    mu_t: Vec<Option<f64>>,
    /// Weights `[W_R, W_T, W_I]` per (incidence, exit), for BRDF and BTDF
    /// exits (`W_I`: the second-order peak term, eq. B2).
    w_r: Vec<[f64; 3]>,
    w_t: Vec<[f64; 3]>,
    /// The solver's correction of this layer (its `peak_pspike` is the
    /// angular factor of the `W_I` term).
    corr: crate::correction::PeakCorrection,
}

impl TmsLayer {
    /// `F(cos Theta)` of eq. B1 at two cosines at once (the same sums as the
    /// solver's correction; the Legendre recurrence `P_l = a_l x P_{l-1} -
    /// b_l P_{l-2}` with `a_l = (2l-1)/l`, `b_l = (l-1)/l` from `rec`, two
    /// independent chains for instruction-level parallelism).
    fn fix2(&self, c1: f64, c2: f64, mu_b: f64) -> (f64, f64) {
        let (c1, c2) = (c1.clamp(-1.0, 1.0), c2.clamp(-1.0, 1.0));
        let k = self.omega_true / (1.0 - self.omega_true * self.f);
        let (e1, e2) = (k * self.phase.eval(c1), k * self.phase.eval(c2));
        let (mut s1, mut s2) = (self.chiw[0], self.chiw[0]);
        let (mut p0a, mut p1a, mut p0b, mut p1b) = (1.0, c1, 1.0, c2);
        if self.chiw.len() > 1 {
            s1 += self.chiw[1] * c1;
            s2 += self.chiw[1] * c2;
        }
        for l in 2..self.chiw.len() {
            let (a, b) = self.rec[l];
            let pa = a * c1 * p1a - b * p0a;
            let pb = a * c2 * p1b - b * p0b;
            s1 += self.chiw[l] * pa;
            s2 += self.chiw[l] * pb;
            (p0a, p1a, p0b, p1b) = (p1a, pa, p1b, pb);
        }
        let q = self.omega / (4.0 * std::f64::consts::PI);
        ((e1 - q * s1) / mu_b, (e2 - q * s2) / mu_b)
    }
}

/// The BSDF of one spectral channel.
#[derive(Debug, Clone)]
pub struct ChannelBsdf {
    /// Fourier coefficients of the BRDF, `[(i * n_o + o) * (M + 1) + m]`, 1/sr.
    coef_r: Vec<f64>,
    /// The same for the BTDF (all zero for an opaque substrate).
    coef_t: Vec<f64>,
    orders: usize,
    pub(crate) tms: Vec<TmsLayer>,
    /// Total reflectance and transmittance per incidence (delta parts included).
    pub reflectance: Vec<f64>,
    /// Total transmittance per incidence.
    pub transmittance: Vec<f64>,
    /// Mirror reflectance per incidence (delta part).
    pub reflectance_specular: Vec<f64>,
    /// Unscattered transmittance per incidence (delta part).
    pub transmittance_direct: Vec<f64>,
    /// Stream count used.
    pub streams: usize,
}

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
    let Substrate::Transparent { n } = scene.substrate else {
        return Err(BsdfError::Input {
            name: "side",
            reason: "incidence from below needs a transparent substrate".into(),
        });
    };
    if scene.layers.iter().any(|l| l.is_half_space()) {
        return Err(BsdfError::Input {
            name: "side",
            reason: "incidence from below through a half-space layer".into(),
        });
    }
    let mut s = scene.clone();
    s.ambient_n = n;
    s.layers.reverse();
    s.substrate = Substrate::Transparent { n: scene.ambient_n };
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
    /// Bad angles or options ([`BsdfError::Input`]), the solver's refusals.
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
        faer::set_global_parallelism(faer::Par::Seq);
        let mut channels = Vec::with_capacity(scene.channels.len());
        let (mut transmits, mut n_in, mut n_out) = (false, 1.0, None);
        for ch in &scene.channels {
            ch.validate().map_err(MultifluxError::from)?;
            let mono = match opts.side {
                Side::Above => ch.clone(),
                Side::Below => flipped(ch)?,
            };
            let (c, t) = channel(&mono, theta_i, theta_o, &opts.solver)?;
            transmits = t.is_some();
            n_in = mono.ambient_n;
            n_out = t;
            channels.push(c);
        }
        Ok(Bsdf {
            theta_i: theta_i.to_vec(),
            theta_o: theta_o.to_vec(),
            side: opts.side,
            channels,
            labels: scene.labels.clone(),
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
        let ch = &self.channels[c];
        let k = (i * self.theta_o.len() + o) * ch.orders;
        &ch.coef_r[k..k + ch.orders]
    }

    /// The Fourier coefficients `c_m` of eq. B1 (BTDF) for the pair `(i, o)`.
    pub fn btdf_coefficients(&self, c: usize, i: usize, o: usize) -> &[f64] {
        let ch = &self.channels[c];
        let k = (i * self.theta_o.len() + o) * ch.orders;
        &ch.coef_t[k..k + ch.orders]
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
        let ch = &self.channels[c];
        let no = self.theta_o.len();
        if transmitted && !self.transmits {
            out.iter_mut().for_each(|x| *x = 0.0);
            return;
        }
        let coef = if transmitted {
            self.btdf_coefficients(c, i, o)
        } else {
            self.brdf_coefficients(c, i, o)
        };
        for (k, &p) in phi_deg.iter().enumerate() {
            // cos m x by the Chebyshev recurrence, x = phi - 180 deg.
            let cx = (p - 180.0).to_radians().cos();
            let (mut c_prev, mut c_cur) = (cx, 1.0);
            let mut v = 0.0;
            for &a in coef {
                v += a * c_cur;
                let next = 2.0 * cx * c_cur - c_prev;
                c_prev = c_cur;
                c_cur = next;
            }
            out[k] = v;
        }
        // The single-scattering correction (eq. B1, second line).
        for l in &ch.tms {
            let w = if transmitted { l.w_t[i * no + o] } else { l.w_r[i * no + o] };
            if w == [0.0; 3] {
                continue;
            }
            let mu_x = if transmitted { l.mu_t[o] } else { l.mu_r[o] };
            let (Some(mu_b), Some(mu_x)) = (l.mu_b[i], mu_x) else { continue };
            let (sx, sb) =
                ((1.0 - mu_x * mu_x).max(0.0).sqrt(), (1.0 - mu_b * mu_b).max(0.0).sqrt());
            for (k, &p) in phi_deg.iter().enumerate() {
                let cphi = (p - 180.0).to_radians().cos();
                let c_t = mu_x * mu_b + sx * sb * cphi;
                let (f_r, f_t) = l.fix2(-mu_x * mu_b + sx * sb * cphi, c_t, mu_b);
                out[k] += w[0] * f_r + w[1] * f_t;
                if w[2] != 0.0 {
                    out[k] += w[2] * l.corr.peak_pspike(c_t);
                }
            }
        }
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

/// Kinds of extra directions in the augmented operators.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Kind {
    Beam,
    Probe,
    /// Marker of layer `l`: `slot` 0 for the path integral of the side the
    /// beam entered (`W_R`), 1 for the far side (`W_T`), 2 for the far side's
    /// second-order peak term (`W_I`, eq. B2).
    Marker {
        l: usize,
        slot: usize,
    },
}

/// Zero the rows of the marker extras in the node and beam columns of one
/// operator (a marker receives only its layer's correction path).
fn scrub(mat: &mut Mat<f64>, kinds: &[Kind]) {
    let e = kinds.len();
    if mat.nrows() < e || mat.ncols() < e {
        return;
    }
    let (nr, nc) = (mat.nrows() - e, mat.ncols() - e);
    for (x, k) in kinds.iter().enumerate() {
        if !matches!(k, Kind::Marker { .. }) {
            continue;
        }
        for col in 0..mat.ncols() {
            if col < nc || kinds[col - nc] == Kind::Beam {
                mat[(nr + x, col)] = 0.0;
            }
        }
    }
}

fn scrub_ops(ops: &mut LayerOperators, kinds: &[Kind]) {
    scrub(&mut ops.r_top, kinds);
    scrub(&mut ops.t_down, kinds);
    scrub(&mut ops.r_bottom, kinds);
    scrub(&mut ops.t_up, kinds);
}

/// One channel: returns its BSDF and the far-side index if light leaves there.
fn channel(
    scene: &MonoScene,
    theta_i: &[f64],
    theta_o: &[f64],
    opts: &MultifluxOptions,
) -> Result<(ChannelBsdf, Option<f64>), BsdfError> {
    // Streams: as `km solve` would choose for the most demanding incidence.
    let streams = match opts.streams {
        Some(_) => resolve_streams(scene, opts)?,
        None => {
            let mut s = scene.clone();
            s.directions_deg = vec![[0.0, 0.0]];
            let mut best = 0;
            for &t in theta_i {
                s.light = Light::Collimated { theta_deg: t };
                best = best.max(default_streams(&s));
            }
            best
        }
    };
    let opts = MultifluxOptions { streams: Some(streams), ..opts.clone() };
    let (cut, _) = planned_cutoff(scene, &opts);
    let scene = cut.as_ref().unwrap_or(scene);
    let n0 = scene.ambient_n;
    let (n_sub, grid) = media_grid(scene, streams);
    let layers = scale_layers(scene, &opts, 2 * streams);
    let (ni, no) = (theta_i.len(), theta_o.len());

    // Which layers carry a single-scattering correction: scattering ones
    // whose phase function the kept moments do not represent exactly.
    let tms_layers: Vec<usize> = if opts.delta_m {
        (0..layers.len())
            .filter(|&l| {
                let s = &layers[l];
                s.omega > 0.0
                    && s.tau > 0.0
                    && !matches!(s.phase, km_core::phase::Phase::Isotropic)
                    && !matches!(s.phase, km_core::phase::Phase::HenyeyGreenstein { g } if g == 0.0)
            })
            .collect()
    } else {
        Vec::new()
    };

    // Extras: beams, BRDF probes, BTDF probes, then (for m = 0) markers.
    let mut ex: Vec<(f64, Kind)> = Vec::new();
    for &t in theta_i {
        ex.push((n0 * t.to_radians().sin(), Kind::Beam));
    }
    let r0 = ex.len();
    for &t in theta_o {
        ex.push((n0 * t.to_radians().sin(), Kind::Probe));
    }
    let t0 = ex.len();
    if let Some(ns) = n_sub {
        for &t in theta_o {
            ex.push((ns * t.to_radians().sin(), Kind::Probe));
        }
    }
    let base_len = ex.len();
    // The solver's correction per layer (TMS and IMS, eq. C2-C4 of
    // `docs/multiflux.md`), and whether its IMS term can matter: it scales
    // as (omega f)^2 times Legendre sums of at most ~1e3 (2N terms and the
    // tails beyond them), so below omega f = 1e-8 it is under ~1e-13 of a
    // unit radiance and the layer needs no IMS marker.
    let corr: Vec<Option<crate::correction::PeakCorrection>> = (0..layers.len())
        .map(|l| tms_layers.contains(&l).then(|| layers[l].correction(2 * streams)))
        .collect();
    let ims_on = |l: usize| {
        opts.secondary_correction
            && corr[l].as_ref().is_some_and(|c| layers[l].omega_true * c.f() > 1e-8)
    };
    // The IMS term lives only within the cone around the beam's polar angle
    // (in the layer): its marker is needed where some beam is that close
    // (a margin of 1e-6 rad; inside, the solver's own test decides).
    let in_cone = |p: usize, l: usize| {
        let n = layers[l].n;
        let cone = crate::correction::IMS_CONE_DEG.to_radians() + 1e-6;
        mu_of_invariant(ex[p].0, n).is_some_and(|mx| {
            (0..ni).any(|i| {
                mu_of_invariant(ex[i].0, n).is_some_and(|mb| (mb.acos() - mx.acos()).abs() <= cone)
            })
        })
    };
    // Markers: per probe, per corrected layer, R and T kinds (and I).
    let mut marker_of: Vec<(usize, usize, usize)> = Vec::new(); // (probe extra, layer, slot)
    let slots: Vec<usize> = (r0..base_len)
        .flat_map(|p| tms_layers.iter().map(move |&l| (p, l)))
        .map(|(p, l)| if ims_on(l) && in_cone(p, l) { 3 } else { 2 })
        .collect();
    let mut slots = slots.into_iter();
    for p in r0..base_len {
        for &l in &tms_layers {
            for slot in 0..slots.next().unwrap_or(2) {
                marker_of.push((p, l, slot));
                ex.push((ex[p].0, Kind::Marker { l, slot }));
            }
        }
    }
    let kinds_all: Vec<Kind> = ex.iter().map(|e| e.1).collect();
    let extras_for = |n: f64, count: usize| -> Vec<Extra> {
        ex[..count]
            .iter()
            .map(|&(s, k)| Extra { mu: mu_of_invariant(s, n), beam: k == Kind::Beam, phi_deg: 0.0 })
            .collect()
    };

    // Fourier orders (as the solver: up to the last non-negligible moment).
    let mut m_max = 0;
    for l in &layers {
        if l.omega > 0.0
            && let Some(last) = l.chi.iter().rposition(|c| c.abs() > 1e-12)
        {
            m_max = m_max.max(last);
        }
    }
    let m_max = m_max.min(opts.max_fourier_order.unwrap_or(usize::MAX));

    let nodes0 = grid.medium(n0);
    let na0 = nodes0.mu.len();
    let nodes_sub = n_sub.map(|n| grid.medium(n));
    let nb = nodes_sub.as_ref().map_or(0, |n| n.mu.len());
    let mut coefs_r: Vec<Vec<f64>> = Vec::new(); // per m, [i * no + o]
    let mut coefs_t: Vec<Vec<f64>> = Vec::new();
    let mut out = ChannelBsdf {
        coef_r: Vec::new(),
        coef_t: Vec::new(),
        orders: 0,
        tms: Vec::new(),
        reflectance: vec![0.0; ni],
        transmittance: vec![0.0; ni],
        reflectance_specular: vec![0.0; ni],
        transmittance_direct: vec![0.0; ni],
        streams,
    };
    let mut largest = 0.0f64;
    let mut small_orders = 0;
    for m in 0..=m_max {
        // Markers only where the correction lives (m = 0).
        let count = if m == 0 { ex.len() } else { base_len };
        let kinds = &kinds_all[..count];
        let extras_in = |n: f64| extras_for(n, count);
        let ops =
            stack(scene, &grid, &layers, &corr, n_sub, &extras_in, kinds, m, opts.neumann_order)?;
        let (mut cr, mut ct) = (vec![0.0; ni * no], vec![0.0; ni * no]);
        let mut term = 0.0f64;
        for i in 0..ni {
            for o in 0..no {
                let x = ops.r_top[(na0 + r0 + o, na0 + i)];
                cr[i * no + o] = x;
                term = term.max(x.abs());
                if n_sub.is_some() {
                    let y = ops.t_down[(nb + t0 + o, na0 + i)];
                    ct[i * no + o] = y;
                    term = term.max(y.abs());
                }
            }
        }
        if m == 0 {
            // Totals from the azimuthal mean (nodes) plus the beams' delta parts.
            for i in 0..ni {
                let col: Vec<f64> = (0..na0).map(|q| ops.r_top[(q, na0 + i)]).collect();
                out.reflectance[i] = flux(&nodes0, &col) + ops.r_top[(na0 + i, na0 + i)];
                if let Some(ns) = &nodes_sub {
                    let col: Vec<f64> = (0..nb).map(|q| ops.t_down[(q, na0 + i)]).collect();
                    out.transmittance[i] = flux(ns, &col) + ops.t_down[(nb + i, na0 + i)];
                }
                let (spec, direct) = delta_parts(scene, &layers, n_sub, ex[i].0);
                out.reflectance_specular[i] = spec;
                out.transmittance_direct[i] = direct;
            }
            // Correction weights per layer from the markers.
            for &l in &tms_layers {
                let s = &layers[l];
                let chiw: Vec<f64> =
                    s.chi.iter().enumerate().map(|(k, c)| (2 * k + 1) as f64 * c).collect();
                let mu_in = |a: usize| mu_of_invariant(ex[a].0, s.n);
                let rec = (0..chiw.len())
                    .map(|l| {
                        let lf = l.max(1) as f64;
                        ((2.0 * lf - 1.0) / lf, (lf - 1.0) / lf)
                    })
                    .collect();
                let mut tl = TmsLayer {
                    omega_true: s.omega_true,
                    f: corr[l].as_ref().map_or(0.0, |c| c.f()),
                    omega: s.omega,
                    chiw,
                    rec,
                    phase: s.phase,
                    mu_b: (0..ni).map(mu_in).collect(),
                    mu_r: (r0..r0 + no).map(mu_in).collect(),
                    mu_t: if n_sub.is_some() {
                        (t0..t0 + no).map(mu_in).collect()
                    } else {
                        vec![None; no]
                    },
                    w_r: vec![[0.0; 3]; ni * no],
                    w_t: vec![[0.0; 3]; ni * no],
                    corr: s.correction(2 * streams),
                };
                for (k, &(p, ml, slot)) in marker_of.iter().enumerate() {
                    if ml != l {
                        continue;
                    }
                    let e = base_len + k;
                    for i in 0..ni {
                        if p < t0 {
                            let o = p - r0;
                            tl.w_r[i * no + o][slot] = ops.r_top[(na0 + e, na0 + i)];
                        } else {
                            let o = p - t0;
                            tl.w_t[i * no + o][slot] = ops.t_down[(nb + e, na0 + i)];
                        }
                    }
                }
                out.tms.push(tl);
            }
        }
        coefs_r.push(cr);
        coefs_t.push(ct);
        // Azimuthal convergence, as the solver's (two consecutive small orders).
        largest = largest.max(if m == 0 { term } else { 0.0 });
        if m > 0 {
            small_orders = if term <= FOURIER_TOL * largest { small_orders + 1 } else { 0 };
            if small_orders == 2 {
                break;
            }
        }
    }
    let orders = coefs_r.len();
    out.orders = orders;
    out.coef_r = vec![0.0; ni * no * orders];
    out.coef_t = vec![0.0; ni * no * orders];
    for (m, (cr, ct)) in coefs_r.iter().zip(&coefs_t).enumerate() {
        for k in 0..ni * no {
            out.coef_r[k * orders + m] = cr[k];
            out.coef_t[k * orders + m] = ct[k];
        }
    }
    let finite =
        out.coef_r.iter().chain(&out.coef_t).chain(&out.reflectance).all(|x| x.is_finite());
    if !finite {
        return Err(
            MultifluxError::Numerical { what: "bsdf", detail: "non-finite table".into() }.into()
        );
    }
    Ok((out, n_sub))
}

/// The stack's operators for order `m` on nodes plus extras, with the
/// marker rows of eq. B1 (as the solver's `stack_operators` without the
/// in-place correction, which the markers carry instead).
#[allow(clippy::too_many_arguments)]
fn stack(
    scene: &MonoScene,
    grid: &AngularGrid,
    layers: &[Scaled],
    corr: &[Option<crate::correction::PeakCorrection>],
    n_sub: Option<f64>,
    extras_in: &dyn Fn(f64) -> Vec<Extra>,
    kinds: &[Kind],
    m: usize,
    neumann: Option<usize>,
) -> Result<LayerOperators, MultifluxError> {
    let interface = |na: f64, nb: f64| {
        let mut ops =
            fresnel_operators(&grid.medium(na), &grid.medium(nb), &extras_in(na), &extras_in(nb));
        scrub_ops(&mut ops, kinds);
        ops
    };
    let layer = |li: usize, l: &Scaled| {
        let nodes = grid.medium(l.n);
        let ex = extras_in(l.n);
        let p = SlabOrder { tau: l.tau, omega: l.omega, chi: &l.chi, m };
        let mut ops = slab_operators(&nodes.mu, &nodes.w, &ex, &p, None)?;
        scrub_ops(&mut ops, kinds);
        // This layer's correction paths into its markers (unit F).
        let nn = nodes.mu.len();
        for (x, k) in kinds.iter().enumerate() {
            let Kind::Marker { l: ml, slot } = *k else { continue };
            if ml != li {
                continue;
            }
            let Some(mu_x) = ex[x].mu else { continue };
            let beta = 1.0 / mu_x;
            for (b, kb) in kinds.iter().enumerate() {
                let (Kind::Beam, Some(mu_b)) = (kb, ex[b].mu) else { continue };
                let kb = 1.0 / mu_b;
                if slot == 0 {
                    let v = beta * phi(kb + beta, l.tau);
                    ops.r_top[(nn + x, nn + b)] = v;
                    ops.r_bottom[(nn + x, nn + b)] = v;
                } else {
                    let v = if slot == 1 {
                        beta * e2(kb, beta, l.tau)
                    } else {
                        // Eq. B2: the IMS path factor at the unscaled thickness,
                        // as the solver's `PeakCorrection::radiance`.
                        corr[li].as_ref().map_or(0.0, |c| {
                            c.secondary_path(mu_b, mu_x, l.tau / (1.0 - l.omega_true * c.f()))
                        })
                    };
                    ops.t_down[(nn + x, nn + b)] = v;
                    ops.t_up[(nn + x, nn + b)] = v;
                }
            }
        }
        Ok(ops)
    };
    let lambertian = |n: f64, albedo: f64| {
        let mut g = lambertian_reflection(&grid.medium(n), &extras_in(n), albedo, m);
        scrub(&mut g, kinds);
        g
    };
    let pieces = StackPieces { interface: &interface, layer: &layer, lambertian: &lambertian };
    add_stack(scene, layers, n_sub, neumann, false, &pieces)
}
