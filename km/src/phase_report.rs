//! Each layer's phase function as numbers (`km phase`, `km.phase`;
//! docs/phase.md §6), and one sphere by Mie theory (`km.mie`; docs/mie.md).
//!
//! [`phase_report`] gives, per layer and channel, the kind, the
//! coefficients, `g`, the phase function `p(cos t)` at angles (1/sr,
//! normalised as eq. P1: `integral p dw = 1`), its Legendre moments
//! `chi_0 = 1 .. chi_K` (eq. P2, DISORT's `PMOM`), and for a layer of
//! particles each population's Mie efficiencies and their mixture.
//! [`table`] and [`csv`] write a report as text.
//! [`mie_sphere`] gives one sphere's efficiencies, asymmetry, amplitudes
//! `S1`, `S2`, phase function and moments.
//!
//! Every size is bounded before any work: at most [`MAX_ANGLES`] angles,
//! `K <=` [`MAX_MOMENTS`], [`MAX_VALUES`] values in one report and
//! [`MAX_SERIES_WORK`] terms of Legendre series summed.

use std::f64::consts::PI;

use km_core::mie::{
    Complex, MAX_MX, MAX_SIZE_PARAMETER, MIN_SIZE_PARAMETER, SizeDistribution, Sphere,
    phase_moments,
};
use km_core::phase::{MAX_RM_MOMENTS, MAX_TABLE_MOMENTS, Phase, PhaseFunction};
use km_core::{CoreError, Layer, Scene};

mod text;
pub use text::{channel_name, csv, table};

/// The largest `K` of the moments `chi_0 .. chi_K` asked for.
pub const MAX_MOMENTS: usize = 16_384;

/// The most angles of one report.
pub const MAX_ANGLES: usize = 10_000;

/// The most values (`p` and `chi_l`) of one report, over every layer and
/// channel: `2^22` values are about 80 MB of JSON.
pub const MAX_VALUES: usize = 1 << 22;

/// The most terms of Legendre series one report sums (angles times the
/// series' length, over every layer and channel; about 2 s on one core).
pub const MAX_SERIES_WORK: f64 = 1e9;

/// The normalisation of `p`, in words (printed with every report).
pub const NORMALISATION: &str = "p in 1/sr with integral p dOmega = 1 (eq. P1); DISORT's phase \
                                 function, of mean 1 over the sphere, is 4 pi p";

/// Scattering angles in degrees from a list or a range `START:STOP:STEP`
/// over `[0, 180]` ([`crate::bsdf_file::parse_angles`]'s syntax without
/// `gauss:N`, whose nodes lie in one hemisphere).
///
/// # Errors
/// A `gauss:N`, and the refusals of [`crate::bsdf_file::parse_angles`].
pub fn parse_angles(spec: &str) -> Result<Vec<f64>, crate::bsdf_file::AngleListError> {
    if spec.trim().starts_with("gauss:") {
        return Err(crate::bsdf_file::AngleListError::List {
            reason: "gauss:N gives angles in [0, 90) only; give a list or a range \
                     START:STOP:STEP over [0, 180]"
                .into(),
        });
    }
    crate::bsdf_file::parse_angles(spec)
}

/// The default angles, degrees: every 0.05 below 1, every 0.25 from 1 to
/// 10, every degree from 10 to 180 (227 angles, fine near 0 for forward
/// peaks).
///
/// ```
/// let a = km::phase_report::default_angles();
/// assert_eq!((a[0], a[a.len() - 1], a.len()), (0.0, 180.0, 227));
/// ```
pub fn default_angles() -> Vec<f64> {
    let fine = (0..20).map(|k| 0.05 * k as f64);
    let mid = (0..36).map(|k| 1.0 + 0.25 * k as f64);
    let coarse = (10..=180).map(f64::from);
    fine.chain(mid).chain(coarse).collect()
}

/// The settings of [`phase_report`].
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PhaseOptions {
    /// Scattering angles, degrees in `[0, 180]` (`None`: [`default_angles`]).
    pub angles_deg: Option<Vec<f64>>,
    /// `K`: the moments `chi_0 .. chi_K` (`None`: `2N`, `N` the largest
    /// default stream count of the multi-flux solver over the channels,
    /// whose delta-M keeps `chi_0 .. chi_{2N-1}` and truncates at `chi_{2N}`).
    pub moments: Option<usize>,
}

/// One population of spheres of a layer at one channel (docs/mie.md §3).
#[derive(Debug, Clone, PartialEq)]
pub struct PopulationPhase {
    /// The particles' index `n + i k`.
    pub index: Complex,
    /// Volume fraction.
    pub volume_fraction: f64,
    /// The sizes.
    pub distribution: SizeDistribution,
    /// Effective radius `<r^3>/<r^2>`, micrometres (M16).
    pub r_eff_um: f64,
    /// Size parameter of the effective radius, `2 pi r_eff n_host / lambda`.
    pub x_eff: f64,
    /// Relative index `m = (n + i k) / n_host`.
    pub m: Complex,
    /// Extinction, scattering and absorption efficiencies, area-weighted (M14).
    pub q_ext: f64,
    /// Scattering efficiency.
    pub q_sca: f64,
    /// Absorption efficiency.
    pub q_abs: f64,
    /// Asymmetry parameter of the population.
    pub g: f64,
    /// Scattering coefficient, 1/micrometre.
    pub sigma_s: f64,
    /// Absorption coefficient of the particles, 1/micrometre.
    pub sigma_a: f64,
    /// Terms of the largest sphere's series.
    pub terms: usize,
    /// Radii summed (1 for a mono population).
    pub radii: usize,
}

/// The particles of a layer at one channel: each population and the mixture.
#[derive(Debug, Clone, PartialEq)]
pub struct ParticlesPhase {
    /// The populations, in the order given.
    pub populations: Vec<PopulationPhase>,
    /// The mixture's efficiencies: cross sections per unit number density
    /// over the mean geometric cross section of all the particles,
    /// `Q = sum sigma_i / sum_i (f_i <pi r^2>_i / <V>_i)`.
    pub q_ext: f64,
    /// Scattering efficiency of the mixture.
    pub q_sca: f64,
    /// Absorption efficiency of the mixture.
    pub q_abs: f64,
    /// Asymmetry of the mixture (`chi_1` of eq. M15).
    pub g: f64,
    /// Scattering coefficient of all the particles, 1/micrometre.
    pub sigma_s: f64,
    /// Absorption coefficient of all the particles, 1/micrometre.
    pub sigma_a: f64,
    /// Effective radius of all the particles, `<r^3>/<r^2>`, micrometres.
    pub r_eff_um: f64,
    /// Size parameter of that radius.
    pub x_eff: f64,
}

/// One layer at one channel.
#[derive(Debug, Clone, PartialEq)]
pub struct ChannelPhase {
    /// The phase function's kind (`isotropic`, `hg`, `two-term-hg`,
    /// `rayleigh`, `reynolds-mccormick`, `legendre`, `table`, `mie`).
    pub kind: &'static str,
    /// Whether the layer scatters (`sigma_s > 0`); when not, `p` and
    /// `moments` are empty.
    pub scatters: bool,
    /// Absorption coefficient, 1/length.
    pub sigma_a: f64,
    /// Scattering coefficient, 1/length.
    pub sigma_s: f64,
    /// Thickness (infinite for a half-space).
    pub thickness: f64,
    /// Optical thickness.
    pub tau: f64,
    /// Single-scattering albedo.
    pub albedo: f64,
    /// Refractive index.
    pub n: f64,
    /// Asymmetry parameter `g = chi_1`.
    pub g: f64,
    /// Length `L + 1` of a finite Legendre series (`chi_l = 0` for `l > L`),
    /// `None` for the kinds that are not one.
    pub series_length: Option<usize>,
    /// `p(cos t)` at the report's angles, 1/sr (eq. P1).
    pub p: Vec<f64>,
    /// `chi_0 .. chi_K` (eq. P2).
    pub moments: Vec<f64>,
    /// Mie particles: the populations and their mixture.
    pub particles: Option<ParticlesPhase>,
}

/// The phase functions of a scene's layers.
#[derive(Debug, Clone, PartialEq)]
pub struct PhaseReport {
    /// A label per channel.
    pub labels: Vec<String>,
    /// The channels' wavelengths, nm, when the scene gives them.
    pub wavelengths_nm: Option<Vec<f64>>,
    /// The scattering angles, degrees.
    pub angles_deg: Vec<f64>,
    /// Their cosines.
    pub cos_theta: Vec<f64>,
    /// `K` of the moments `chi_0 .. chi_K`.
    pub max_moment: usize,
    /// `N` when `K = 2N` was the default (the multi-flux solver's default streams).
    pub default_streams: Option<usize>,
    /// Per layer (top first), per channel.
    pub layers: Vec<Vec<ChannelPhase>>,
}

/// Check scattering angles: at most [`MAX_ANGLES`], each finite in `[0, 180]`.
fn check_angles(angles: &[f64]) -> Result<(), CoreError> {
    if angles.is_empty() {
        return Err(CoreError::invalid("angles_deg", 0.0, "give at least one angle"));
    }
    if angles.len() > MAX_ANGLES {
        return Err(CoreError::invalid(
            "angles_deg",
            angles.len() as f64,
            &format!("{} angles: at most {MAX_ANGLES}", angles.len()),
        ));
    }
    if let Some(&a) = angles.iter().find(|a| !(a.is_finite() && (0.0..=180.0).contains(*a))) {
        return Err(CoreError::invalid(
            "angles_deg",
            a,
            "scattering angles are degrees in [0, 180]",
        ));
    }
    Ok(())
}

/// Check a requested `K`.
fn check_moments(k: usize) -> Result<(), CoreError> {
    if k > MAX_MOMENTS {
        return Err(CoreError::invalid(
            "moments",
            k as f64,
            &format!("K (the moments chi_0 .. chi_K) must be <= {MAX_MOMENTS}"),
        ));
    }
    Ok(())
}

/// The cosine of an angle in degrees, exact at 0, 90 and 180.
fn cos_deg(t: f64) -> f64 {
    if t == 90.0 { 0.0 } else { t.to_radians().cos().clamp(-1.0, 1.0) }
}

/// The moments known of `phase`: `None` when every `chi_l` is known (closed
/// forms, finite series, a Reynolds–McCormick series that ended below
/// 1e-16), else the count computed (a table's first [`MAX_TABLE_MOMENTS`],
/// a Reynolds–McCormick series cut at [`MAX_RM_MOMENTS`]).
fn known_moments(phase: &Phase) -> Option<usize> {
    match phase {
        Phase::Table(_) => Some(MAX_TABLE_MOMENTS),
        Phase::ReynoldsMcCormick(r) if r.moments().len() >= MAX_RM_MOMENTS => Some(MAX_RM_MOMENTS),
        _ => None,
    }
}

/// The phase function of every layer and channel of `scene`, at the
/// angles and to the moments of `opts`.
///
/// # Errors
/// [`CoreError::Invalid`] naming `angles_deg` (empty, more than
/// [`MAX_ANGLES`], outside `[0, 180]`) or `moments` (`K` over
/// [`MAX_MOMENTS`], beyond the moments a layer's kind has computed, or a
/// report over [`MAX_VALUES`] values or [`MAX_SERIES_WORK`] terms).
///
/// ```
/// use km::phase_report::{PhaseOptions, phase_report};
/// let scene = km::Scene::from_toml_str("[[layer]]\ntau = 1\nalbedo = 0.9\ng = 0.5\n").unwrap();
/// let opts = PhaseOptions { angles_deg: Some(vec![0.0, 90.0]), moments: Some(3) };
/// let r = phase_report(&scene, &opts).unwrap();
/// let c = &r.layers[0][0];
/// assert_eq!((c.kind, c.moments.len()), ("hg", 4));
/// assert!((c.moments[3] - 0.125).abs() < 1e-15);
/// ```
pub fn phase_report(scene: &Scene, opts: &PhaseOptions) -> Result<PhaseReport, CoreError> {
    let angles_deg = opts.angles_deg.clone().unwrap_or_else(default_angles);
    check_angles(&angles_deg)?;
    let (max_moment, default_streams) = match opts.moments {
        Some(k) => {
            check_moments(k)?;
            (k, None)
        }
        None => {
            let n = scene.channels().iter().map(km_multiflux::default_streams).max().unwrap_or(1);
            (2 * n, Some(n))
        }
    };
    let channels = scene.channels();
    let n_layers = channels[0].layers().len();
    // Bound the output and the series sums before any work.
    let values = (channels.len() * n_layers) as f64 * (angles_deg.len() + max_moment + 1) as f64;
    if values > MAX_VALUES as f64 {
        return Err(CoreError::invalid(
            "moments",
            max_moment as f64,
            &format!(
                "{} channels x {n_layers} layers x ({} angles + {} moments) = {values:e} values, \
                 over {MAX_VALUES}: ask for fewer angles or moments",
                channels.len(),
                angles_deg.len(),
                max_moment + 1
            ),
        ));
    }
    let mut work = 0.0;
    for ch in channels {
        for (i, l) in ch.layers().iter().enumerate() {
            if let Some(known) = known_moments(l.phase())
                && max_moment >= known
                && l.sigma_s() > 0.0
            {
                return Err(CoreError::invalid(
                    "moments",
                    max_moment as f64,
                    &format!(
                        "layer {} ({}) has its first {known} moments computed: K must be < {known}",
                        i + 1,
                        l.phase().kind()
                    ),
                ));
            }
            let terms = l.phase().stored_moments().map_or(1, <[f64]>::len);
            work += (angles_deg.len() * terms) as f64;
        }
    }
    if work > MAX_SERIES_WORK {
        return Err(CoreError::invalid(
            "angles_deg",
            angles_deg.len() as f64,
            &format!(
                "{work:e} terms of Legendre series to sum, over {MAX_SERIES_WORK:e}: ask for \
                 fewer angles"
            ),
        ));
    }
    let cos_theta: Vec<f64> = angles_deg.iter().map(|&t| cos_deg(t)).collect();
    let layers = (0..n_layers)
        .map(|i| {
            channels
                .iter()
                .map(|ch| channel_phase(&ch.layers()[i], &cos_theta, max_moment))
                .collect()
        })
        .collect();
    Ok(PhaseReport {
        labels: scene.labels().to_vec(),
        wavelengths_nm: scene.wavelengths_nm().map(<[f64]>::to_vec),
        angles_deg,
        cos_theta,
        max_moment,
        default_streams,
        layers,
    })
}

/// One layer at one channel.
fn channel_phase(l: &Layer, cos_theta: &[f64], k: usize) -> ChannelPhase {
    let phase = l.phase();
    let scatters = l.sigma_s() > 0.0;
    let (p, moments) = if scatters {
        (
            cos_theta.iter().map(|&c| phase.eval(c)).collect(),
            (0..=k).map(|i| phase.legendre_moment(i)).collect(),
        )
    } else {
        (Vec::new(), Vec::new())
    };
    let particles = match phase {
        Phase::Particles(pp) => Some(particles_phase(pp.populations(), phase.g())),
        _ => None,
    };
    ChannelPhase {
        kind: phase.kind(),
        scatters,
        sigma_a: l.sigma_a(),
        sigma_s: l.sigma_s(),
        thickness: l.thickness(),
        tau: l.tau(),
        albedo: l.albedo(),
        n: l.n(),
        g: phase.g(),
        series_length: phase.finite_moments(),
        p,
        moments,
        particles,
    }
}

/// The populations of a layer and their mixture (eq. M14–M16).
fn particles_phase(pops: &[km_core::phase::Population], g: f64) -> ParticlesPhase {
    let mut populations = Vec::with_capacity(pops.len());
    // Mixture: number densities f_i / <V>_i; area, volume fraction, cross sections.
    let (mut area, mut fv, mut sigma_s, mut sigma_a, mut k) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for p in pops {
        let d = p.particles.distribution;
        let o = &p.optics;
        let density = p.particles.volume_fraction / d.mean_volume_um3();
        area += density * d.mean_area_um2();
        fv += p.particles.volume_fraction;
        sigma_s += o.sigma_s;
        sigma_a += o.sigma_a;
        k = 2.0 * PI * p.host_n / (p.wavelength_nm * 1e-3);
        populations.push(PopulationPhase {
            index: p.particles.index,
            volume_fraction: p.particles.volume_fraction,
            distribution: d,
            r_eff_um: d.effective_radius_um(),
            x_eff: o.x_eff,
            m: o.m,
            q_ext: o.q_ext,
            q_sca: o.q_sca,
            q_abs: o.q_abs,
            g: o.g,
            sigma_s: o.sigma_s,
            sigma_a: o.sigma_a,
            terms: o.terms,
            radii: o.radii,
        });
    }
    // <r^3>/<r^2> of all the particles: (3/(4 pi)) sum N_i <V>_i / (sum N_i <pi r^2>_i / pi).
    let r_eff_um = 0.75 * fv / area;
    ParticlesPhase {
        populations,
        q_ext: (sigma_s + sigma_a) / area,
        q_sca: sigma_s / area,
        q_abs: sigma_a / area,
        g,
        sigma_s,
        sigma_a,
        r_eff_um,
        x_eff: k * r_eff_um,
    }
}

/// A number for JSON: finite as is, infinite as `"inf"` (as the scene file).
fn num(x: f64) -> serde_json::Value {
    if x.is_infinite() { serde_json::json!("inf") } else { serde_json::json!(x) }
}

fn complex_json(c: Complex) -> serde_json::Value {
    serde_json::json!([c.re, c.im])
}

fn distribution_json(d: &SizeDistribution) -> serde_json::Value {
    use serde_json::json;
    match *d {
        SizeDistribution::Mono { radius_um } => json!({ "kind": "mono", "radius_um": radius_um }),
        SizeDistribution::LogNormal { median_um, sigma } => {
            json!({ "kind": "lognormal", "median_um": median_um, "sigma": sigma })
        }
    }
}

impl ParticlesPhase {
    /// The particles as JSON (docs/cli.md, `km phase`).
    pub fn to_json(&self) -> serde_json::Value {
        use serde_json::json;
        let pops: Vec<_> = self
            .populations
            .iter()
            .map(|p| {
                json!({
                    "index": complex_json(p.index),
                    "volume_fraction": p.volume_fraction,
                    "distribution": distribution_json(&p.distribution),
                    "r_eff_um": p.r_eff_um,
                    "x_eff": p.x_eff,
                    "m": complex_json(p.m),
                    "q_ext": p.q_ext,
                    "q_sca": p.q_sca,
                    "q_abs": p.q_abs,
                    "g": p.g,
                    "sigma_s": p.sigma_s,
                    "sigma_a": p.sigma_a,
                    "terms": p.terms,
                    "radii": p.radii,
                })
            })
            .collect();
        json!({
            "populations": pops,
            "mixed": {
                "q_ext": self.q_ext,
                "q_sca": self.q_sca,
                "q_abs": self.q_abs,
                "g": self.g,
                "sigma_s": self.sigma_s,
                "sigma_a": self.sigma_a,
                "r_eff_um": self.r_eff_um,
                "x_eff": self.x_eff,
            },
        })
    }
}

impl PhaseReport {
    /// The report as JSON (docs/cli.md, `km phase --format json`): the
    /// angles, `K`, and per layer a list of channels, each with its kind,
    /// coefficients, `g`, `p` and `moments` (`null` when it does not
    /// scatter) and `particles` (`null` but for Mie layers).
    pub fn to_json(&self) -> serde_json::Value {
        use serde_json::json;
        let layers: Vec<_> = self
            .layers
            .iter()
            .enumerate()
            .map(|(i, chans)| {
                let chans: Vec<_> = chans
                    .iter()
                    .enumerate()
                    .map(|(c, ch)| {
                        let data = |v: &Vec<f64>| if ch.scatters { json!(v) } else { json!(null) };
                        json!({
                            "label": self.labels[c],
                            "wavelength_nm": self.wavelengths_nm.as_ref().map(|w| w[c]),
                            "kind": ch.kind,
                            "scatters": ch.scatters,
                            "sigma_a": ch.sigma_a,
                            "sigma_s": ch.sigma_s,
                            "thickness": num(ch.thickness),
                            "tau": num(ch.tau),
                            "albedo": ch.albedo,
                            "n": ch.n,
                            "g": ch.g,
                            "series_length": ch.series_length,
                            "p": data(&ch.p),
                            "moments": data(&ch.moments),
                            "particles": ch.particles.as_ref().map(ParticlesPhase::to_json),
                        })
                    })
                    .collect();
                json!({ "layer": i + 1, "channels": chans })
            })
            .collect();
        json!({
            "normalisation": NORMALISATION,
            "labels": self.labels,
            "wavelengths_nm": self.wavelengths_nm,
            "angles_deg": self.angles_deg,
            "cos_theta": self.cos_theta,
            "max_moment": self.max_moment,
            "default_streams": self.default_streams,
            "layers": layers,
        })
    }
}

/// One homogeneous sphere by Mie theory (docs/mie.md §1, §2).
#[derive(Debug, Clone, PartialEq)]
pub struct MieSphere {
    /// Size parameter `x = 2 pi r n_host / lambda` (M1).
    pub x: f64,
    /// Relative index `m = (n + i k) / n_host` (M1).
    pub m: Complex,
    /// Extinction efficiency (M9).
    pub q_ext: f64,
    /// Scattering efficiency (M9).
    pub q_sca: f64,
    /// Absorption efficiency (M9).
    pub q_abs: f64,
    /// Backscattering efficiency (M10).
    pub q_back: f64,
    /// Asymmetry parameter (M11).
    pub g: f64,
    /// Terms of the series `N` (M7).
    pub terms: usize,
    /// Scattering angles, degrees.
    pub angles_deg: Vec<f64>,
    /// Their cosines.
    pub cos_theta: Vec<f64>,
    /// Amplitude `S1` at the angles (M6, Bohren & Huffman's convention).
    pub s1: Vec<Complex>,
    /// Amplitude `S2` at the angles.
    pub s2: Vec<Complex>,
    /// `p(cos t)` at the angles, 1/sr (M12).
    pub p: Vec<f64>,
    /// `chi_0 .. chi_K` (M13; all `2N + 1` by default, `chi_l = 0` beyond `2N`).
    pub moments: Vec<f64>,
}

/// One sphere of radius `radius_um` (micrometres) and index `n + i k` in a
/// host of real index `n_host` at the vacuum wavelength `wavelength_nm`:
/// efficiencies, asymmetry, and at `angles_deg` (default
/// [`default_angles`]) the amplitudes and the phase function; the moments
/// `chi_0 .. chi_K` (`moments = Some(K)`), or all `2N + 1` of the series
/// (their Gauss quadrature costs `O(N^2)`: `Some(0)` skips it).
///
/// # Errors
/// [`CoreError::Invalid`] naming the argument: `radius_um`,
/// `wavelength_nm`, `n`, `n_host` not finite and `> 0`; `k` not finite and
/// `>= 0`; a size parameter outside `[1e-6, 20 000]` or `|m x|` over
/// 200 000 (named `radius_um`, docs/mie.md M8); `angles_deg` and `moments`
/// as [`phase_report`].
///
/// ```
/// let s = km::phase_report::mie_sphere(0.5, 1.5, 0.0, 628.3185307179587, 1.0, None, None)
///     .unwrap();
/// assert!((s.x - 5.0).abs() < 1e-12 && (s.q_ext - s.q_sca).abs() < 1e-13);
/// assert!((s.moments[1] - s.g).abs() < 1e-12);
/// assert!(km::phase_report::mie_sphere(-1.0, 1.5, 0.0, 550.0, 1.0, None, None).is_err());
/// ```
pub fn mie_sphere(
    radius_um: f64,
    n: f64,
    k: f64,
    wavelength_nm: f64,
    n_host: f64,
    angles_deg: Option<&[f64]>,
    moments: Option<usize>,
) -> Result<MieSphere, CoreError> {
    for (name, v) in
        [("radius_um", radius_um), ("n", n), ("wavelength_nm", wavelength_nm), ("n_host", n_host)]
    {
        if !(v.is_finite() && v > 0.0) {
            return Err(CoreError::invalid(name, v, "must be finite and > 0"));
        }
    }
    if !(k.is_finite() && k >= 0.0) {
        return Err(CoreError::invalid("k", k, "must be finite and >= 0 (m = n + i k absorbs)"));
    }
    let x = 2.0 * PI * radius_um * n_host / (wavelength_nm * 1e-3);
    let m = Complex::new(n / n_host, k / n_host);
    if !(MIN_SIZE_PARAMETER..=MAX_SIZE_PARAMETER).contains(&x) {
        return Err(CoreError::invalid(
            "radius_um",
            radius_um,
            &format!(
                "the size parameter x = 2 pi radius_um n_host / wavelength = {x:e} must lie in \
                 [{MIN_SIZE_PARAMETER:e}, {MAX_SIZE_PARAMETER}] (docs/mie.md M8)"
            ),
        ));
    }
    if m.abs() * x > MAX_MX {
        return Err(CoreError::invalid(
            "radius_um",
            radius_um,
            &format!("|m x| = {:e} must be <= {MAX_MX} (docs/mie.md M8)", m.abs() * x),
        ));
    }
    let angles = angles_deg.map_or_else(default_angles, <[f64]>::to_vec);
    check_angles(&angles)?;
    if let Some(k) = moments {
        check_moments(k)?;
    }
    let sphere = Sphere::new(m, x)?;
    let cos_theta: Vec<f64> = angles.iter().map(|&t| cos_deg(t)).collect();
    let (s1, s2): (Vec<Complex>, Vec<Complex>) =
        cos_theta.iter().map(|&c| sphere.amplitudes(c)).unzip();
    let p = cos_theta.iter().map(|&c| sphere.phase(c)).collect();
    // The moments cost O(x^2) (Gauss quadrature of 2N + 2 nodes): none but chi_0 for K = 0.
    let mut chi = if moments == Some(0) { vec![1.0] } else { phase_moments(&sphere) };
    if let Some(k) = moments {
        chi.resize(k + 1, 0.0);
    }
    Ok(MieSphere {
        x,
        m,
        q_ext: sphere.q_ext(),
        q_sca: sphere.q_sca(),
        q_abs: sphere.q_abs(),
        q_back: sphere.q_back(),
        g: sphere.g(),
        terms: sphere.terms(),
        angles_deg: angles,
        cos_theta,
        s1,
        s2,
        p,
        moments: chi,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Scattering angles span [0, 180]: lists and ranges are read as the
    /// BSDF's angle lists, Gauss nodes (one hemisphere) are refused.
    #[test]
    fn phase_angles_are_lists_and_ranges() {
        assert_eq!(parse_angles("0,90,180").unwrap(), vec![0.0, 90.0, 180.0]);
        assert_eq!(parse_angles("0:180:60").unwrap(), vec![0.0, 60.0, 120.0]);
        assert!(parse_angles("gauss:4").unwrap_err().to_string().contains("[0, 90) only"));
        assert_eq!(parse_angles("0,x").is_err(), crate::bsdf_file::parse_angles("0,x").is_err());
    }

    /// The default grid is increasing, within [0, 180] and within the bound.
    #[test]
    fn default_angles_are_a_grid() {
        let a = default_angles();
        assert!(a.windows(2).all(|w| w[1] > w[0]));
        assert!(check_angles(&a).is_ok());
    }

    /// A mixture of one population is that population.
    #[test]
    fn one_population_mixture_is_the_population() {
        let scene = Scene::from_toml_str(
            "[spectrum]\nwavelengths_nm = [550]\n[[layer]]\nthickness = 100\nn = 1.33\n\
             particles = { n = 1.5, k = 0.01, volume_fraction = 0.01, radius_um = 0.3 }\n",
        )
        .unwrap();
        let r = phase_report(&scene, &PhaseOptions::default()).unwrap();
        let pp = r.layers[0][0].particles.as_ref().unwrap();
        let p0 = &pp.populations[0];
        for (a, b) in [(pp.q_ext, p0.q_ext), (pp.q_sca, p0.q_sca), (pp.x_eff, p0.x_eff)] {
            assert!((a - b).abs() <= 1e-13 * b, "{a} vs {b}");
        }
    }
}
