//! A population of spheres in a host: its scattering and absorption
//! coefficients and phase function by Mie theory, for independent
//! scattering (eq. M14–M17 of `docs/mie.md`).
//!
//! For a number distribution `n(r)` (normalised to one particle) and volume
//! fraction `f_v`, the number density is `f_v / <V>`, `<V> = integral n(r)
//! 4/3 pi r^3 dr`, and
//!
//! ```text
//! sigma_{ext,sca,abs} = f_v <C_{ext,sca,abs}> / <V>,   <C> = integral n(r) pi r^2 Q(x(r)) dr   (M14)
//! p = integral n(r) C_sca(r) p_r dr / <C_sca>                                               (M15)
//! ```
//!
//! A lognormal distribution `n(r) dr = exp(-(ln r - ln r_m)^2 / (2 s^2)) / (sqrt(2 pi) s) d ln r`
//! (`r_m` the number median radius, `s` the standard deviation of `ln r`)
//! has `<V> = 4/3 pi r_m^3 exp(9 s^2 / 2)`, `<pi r^2> = pi r_m^2 exp(2 s^2)`
//! and effective radius `r_eff = <r^3>/<r^2> = r_m exp(5 s^2 / 2)` (M16).
//! Its integrals (M14) are taken by the trapezoidal rule in `ln r`, nested
//! (doubling the points) until the cross sections change by less than
//! [`QUADRATURE_TOL`], over `ln r_m + 2 s^2 +- 7 s` (the area-weighted
//! distribution, whose tails beyond `7 s` hold `2e-12` of it) (M17).

use std::f64::consts::PI;

use super::complex::Complex;
use super::moments::PhaseAccumulator;
use super::sphere::{MAX_SIZE_PARAMETER, MIN_SIZE_PARAMETER, Sphere, series_orders};
use crate::error::CoreError;

/// Relative change of the cross sections between two levels of the nested
/// trapezoidal rule at which a lognormal distribution's integrals stop (M17).
pub const QUADRATURE_TOL: f64 = 1e-7;

/// Largest work of one population's phase function, in amplitude
/// evaluations (one sphere's `S1`, `S2` at one node pair per term): about 5 s
/// on one core. A population over it is refused (narrow the distribution or
/// the sizes).
pub const MAX_AMPLITUDE_WORK: f64 = 1e9;

/// Half-width of the quadrature range in standard deviations of `ln r` (M17).
const RANGE_SIGMAS: f64 = 7.0;

/// The sizes of a population of spheres.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum SizeDistribution {
    /// Every sphere of radius `radius_um` (micrometres, `> 0`).
    Mono {
        /// Radius, micrometres.
        radius_um: f64,
    },
    /// A lognormal distribution by number (M16).
    LogNormal {
        /// Number median radius `r_m`, micrometres, `> 0`.
        median_um: f64,
        /// Standard deviation of `ln r`, `s = ln(geometric standard deviation)`, `> 0`.
        sigma: f64,
    },
}

impl SizeDistribution {
    /// Effective radius `r_eff = <r^3>/<r^2>`, micrometres (M16).
    pub fn effective_radius_um(&self) -> f64 {
        match *self {
            SizeDistribution::Mono { radius_um } => radius_um,
            SizeDistribution::LogNormal { median_um, sigma } => {
                median_um * (2.5 * sigma * sigma).exp()
            }
        }
    }

    /// Mean volume `<V>` of one particle, cubic micrometres (M16).
    pub fn mean_volume_um3(&self) -> f64 {
        match *self {
            SizeDistribution::Mono { radius_um } => 4.0 / 3.0 * PI * radius_um.powi(3),
            SizeDistribution::LogNormal { median_um, sigma } => {
                4.0 / 3.0 * PI * median_um.powi(3) * (4.5 * sigma * sigma).exp()
            }
        }
    }

    /// Mean geometric cross section `<pi r^2>`, square micrometres (M16).
    pub fn mean_area_um2(&self) -> f64 {
        match *self {
            SizeDistribution::Mono { radius_um } => PI * radius_um * radius_um,
            SizeDistribution::LogNormal { median_um, sigma } => {
                PI * median_um * median_um * (2.0 * sigma * sigma).exp()
            }
        }
    }

    /// The largest radius the quadrature reaches, micrometres.
    pub fn max_radius_um(&self) -> f64 {
        match *self {
            SizeDistribution::Mono { radius_um } => radius_um,
            SizeDistribution::LogNormal { median_um, sigma } => {
                median_um * (2.0 * sigma * sigma + RANGE_SIGMAS * sigma).exp()
            }
        }
    }
}

/// A population of spheres of index `n + i k` (`k >= 0`) making up the
/// volume fraction `volume_fraction` of a host.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Particles {
    /// Refractive index of the particles, `n + i k` (`n > 0`, `k >= 0`).
    pub index: Complex,
    /// Volume fraction, in `(0, 1)`.
    pub volume_fraction: f64,
    /// The sizes.
    pub distribution: SizeDistribution,
}

/// The optics of a population in a host at one wavelength (M14–M17).
#[derive(Debug, Clone, PartialEq)]
pub struct ParticleOptics {
    /// Scattering coefficient, 1/micrometre.
    pub sigma_s: f64,
    /// Absorption coefficient, 1/micrometre.
    pub sigma_a: f64,
    /// Extinction efficiency, area-weighted: `<C_ext> / <pi r^2>`.
    pub q_ext: f64,
    /// Scattering efficiency, area-weighted.
    pub q_sca: f64,
    /// Absorption efficiency, area-weighted.
    pub q_abs: f64,
    /// Asymmetry parameter of the population, `chi_1`.
    pub g: f64,
    /// Size parameter of the effective radius, `2 pi r_eff n_host / lambda`.
    pub x_eff: f64,
    /// Relative index `m = (n + i k) / n_host`.
    pub m: Complex,
    /// Terms of the largest sphere's series.
    pub terms: usize,
    /// Radii (quadrature points) summed: 1 for a mono population.
    pub radii: usize,
    /// Last relative change of the cross sections of the nested quadrature
    /// (0 for a mono population).
    pub quadrature_change: f64,
    /// Legendre moments `chi_0 = 1 .. chi_{2N}` of the phase function.
    pub moments: Vec<f64>,
}

/// The optics of `particles` in a host of real index `host_n` at the vacuum
/// wavelength `wavelength_nm` (M14–M17): lengths in micrometres.
///
/// # Errors
/// Values outside their domain (radius, median, `sigma`, volume fraction,
/// index, wavelength), a size parameter above [`MAX_SIZE_PARAMETER`], and a
/// distribution whose phase function would exceed [`MAX_AMPLITUDE_WORK`].
///
/// ```
/// use km_core::mie::{Complex, Particles, SizeDistribution, particle_optics};
/// let p = Particles {
///     index: Complex::new(2.7, 0.0),
///     volume_fraction: 0.1,
///     distribution: SizeDistribution::Mono { radius_um: 0.1 },
/// };
/// let o = particle_optics(&p, 1.5, 550.0).unwrap();
/// // sigma_s = 3 f_v Q_sca / (4 r) for a mono population.
/// assert!((o.sigma_s - 0.75 * o.q_sca).abs() < 1e-12);
/// assert_eq!(o.sigma_a, 0.0);
/// ```
pub fn particle_optics(
    particles: &Particles,
    host_n: f64,
    wavelength_nm: f64,
) -> Result<ParticleOptics, CoreError> {
    check(particles, host_n, wavelength_nm)?;
    let m = Complex::new(particles.index.re / host_n, particles.index.im / host_n);
    // Size parameter per micrometre of radius: 2 pi n_host / lambda.
    let k = 2.0 * PI * host_n / (wavelength_nm * 1e-3);
    let dist = particles.distribution;
    let x_max = k * dist.max_radius_um();
    if x_max > MAX_SIZE_PARAMETER {
        return Err(CoreError::invalid(
            "size parameter",
            x_max,
            &format!(
                "the largest sphere (r = {:.4} um) exceeds the largest size parameter {}",
                dist.max_radius_um(),
                MAX_SIZE_PARAMETER
            ),
        ));
    }
    let sums = match dist {
        SizeDistribution::Mono { radius_um } => mono(m, k, radius_um)?,
        SizeDistribution::LogNormal { median_um, sigma } => lognormal(m, k, median_um, sigma)?,
    };
    let (moments, _) = sums.phase.moments();
    // M14: number density f_v / <V>; the cross sections are per particle.
    let density = particles.volume_fraction / dist.mean_volume_um3();
    let area = dist.mean_area_um2();
    let (c_ext, c_sca) = (sums.c_ext, sums.c_sca);
    let c_abs = if m.im == 0.0 { 0.0 } else { (c_ext - c_sca).max(0.0) };
    let scatters = c_sca > 0.0;
    Ok(ParticleOptics {
        sigma_s: density * c_sca,
        sigma_a: density * c_abs,
        q_ext: c_ext / area,
        q_sca: c_sca / area,
        q_abs: c_abs / area,
        g: if scatters { moments.get(1).copied().unwrap_or(0.0) } else { 0.0 },
        x_eff: k * dist.effective_radius_um(),
        m,
        terms: sums.terms,
        radii: sums.radii,
        quadrature_change: sums.change,
        moments: if scatters { moments } else { vec![1.0] },
    })
}

/// The checks of [`particle_optics`].
fn check(p: &Particles, host_n: f64, wavelength_nm: f64) -> Result<(), CoreError> {
    let positive = |name: &str, v: f64| {
        if v.is_finite() && v > 0.0 {
            Ok(())
        } else {
            Err(CoreError::invalid(name, v, "must be finite and > 0"))
        }
    };
    positive("wavelength_nm", wavelength_nm)?;
    positive("host index", host_n)?;
    positive("particle index n", p.index.re)?;
    if !p.index.im.is_finite() || p.index.im < 0.0 {
        return Err(CoreError::invalid("particle index k", p.index.im, "must be finite and >= 0"));
    }
    if !(p.volume_fraction > 0.0 && p.volume_fraction < 1.0) {
        return Err(CoreError::invalid("volume_fraction", p.volume_fraction, "must lie in (0, 1)"));
    }
    match p.distribution {
        SizeDistribution::Mono { radius_um } => positive("radius_um", radius_um),
        SizeDistribution::LogNormal { median_um, sigma } => {
            positive("median_um", median_um)?;
            positive("sigma", sigma)?;
            if sigma > 2.0 {
                return Err(CoreError::invalid(
                    "sigma",
                    sigma,
                    "the standard deviation of ln r must be <= 2 (a geometric standard deviation of 7.4)",
                ));
            }
            Ok(())
        }
    }
}

/// Cross sections per particle (square micrometres) and the accumulated
/// phase function of a population.
struct Sums {
    c_ext: f64,
    c_sca: f64,
    phase: PhaseAccumulator,
    terms: usize,
    radii: usize,
    change: f64,
}

/// Every sphere of radius `r` (micrometres), `k = 2 pi n_host / lambda`.
fn mono(m: Complex, k: f64, r: f64) -> Result<Sums, CoreError> {
    let s = Sphere::new(m, k * r)?;
    let mut phase = PhaseAccumulator::new(s.terms());
    phase.add(&s, 1.0);
    let area = PI * r * r;
    Ok(Sums {
        c_ext: s.q_ext() * area,
        c_sca: s.q_sca() * area,
        phase,
        terms: s.terms(),
        radii: 1,
        change: 0.0,
    })
}

/// The running sums of a lognormal population's quadrature (M17).
struct Running {
    m: Complex,
    k: f64,
    t_m: f64,
    sigma: f64,
    /// Node pairs of the phase accumulator (work per term).
    half_nodes: f64,
    /// Number-weighted sums of `C_ext`, `C_sca` (without the step `h`).
    sum: [f64; 2],
    work: f64,
    phase: PhaseAccumulator,
}

impl Running {
    /// Add the radius `r = e^t` with trapezoidal end weight when `end`.
    fn add(&mut self, t: f64, end: bool) -> Result<(), CoreError> {
        let r = t.exp();
        if self.k * r < MIN_SIZE_PARAMETER {
            // Q ~ x^4 < 1e-24 there: nothing to add.
            return Ok(());
        }
        let s = Sphere::new(self.m, self.k * r)?;
        let z = (t - self.t_m) / self.sigma;
        let density = (-0.5 * z * z).exp() / ((2.0 * PI).sqrt() * self.sigma);
        let w = density * if end { 0.5 } else { 1.0 };
        let area = PI * r * r;
        self.sum[0] += w * s.q_ext() * area;
        self.sum[1] += w * s.q_sca() * area;
        self.phase.add(&s, w);
        self.work += s.terms() as f64 * self.half_nodes;
        Ok(())
    }
}

/// A lognormal population (M16, M17): nested trapezoidal rule in `t = ln r`
/// over `ln r_m + 2 s^2 +- 7 s`, doubled from 32 intervals until the cross
/// sections change by less than [`QUADRATURE_TOL`] (at least three
/// doublings) or the work bound [`MAX_AMPLITUDE_WORK`] stops it.
fn lognormal(m: Complex, k: f64, median_um: f64, sigma: f64) -> Result<Sums, CoreError> {
    let t_m = median_um.ln();
    let centre = t_m + 2.0 * sigma * sigma;
    let (lo, hi) = (centre - RANGE_SIGMAS * sigma, centre + RANGE_SIGMAS * sigma);
    let terms = series_orders(k * hi.exp());
    let half_nodes = (terms + 1) as f64;
    let mut run = Running {
        m,
        k,
        t_m,
        sigma,
        half_nodes,
        sum: [0.0; 2],
        work: 0.0,
        phase: PhaseAccumulator::new(terms),
    };
    let mut n = 32usize;
    let mut h = (hi - lo) / n as f64;
    let first_work = (n + 1) as f64 * terms as f64 * half_nodes;
    if first_work > MAX_AMPLITUDE_WORK {
        return Err(too_much_work(k * hi.exp(), terms));
    }
    for i in 0..=n {
        run.add(lo + i as f64 * h, i == 0 || i == n)?;
    }
    let mut prev = [run.sum[0] * h, run.sum[1] * h];
    let mut change = f64::INFINITY;
    let mut level = 0;
    // Double while not converged and the next level (n spheres, at most the
    // largest's work each) fits the work bound.
    while !(level >= 3 && change < QUADRATURE_TOL)
        && run.work + n as f64 * terms as f64 * half_nodes <= MAX_AMPLITUDE_WORK
    {
        for i in 0..n {
            run.add(lo + (i as f64 + 0.5) * h, false)?;
        }
        n *= 2;
        h *= 0.5;
        let now = [run.sum[0] * h, run.sum[1] * h];
        change = (0..2)
            .map(|c| if now[c] > 0.0 { ((now[c] - prev[c]) / now[c]).abs() } else { 0.0 })
            .fold(0.0, f64::max);
        prev = now;
        level += 1;
    }
    Ok(Sums { c_ext: prev[0], c_sca: prev[1], phase: run.phase, terms, radii: n + 1, change })
}

/// The refusal of a population whose phase function is too much work.
fn too_much_work(x_max: f64, terms: usize) -> CoreError {
    CoreError::invalid(
        "size distribution",
        x_max,
        &format!(
            "the phase function of this lognormal population (largest size parameter shown, \
             {terms} terms) needs more than {MAX_AMPLITUDE_WORK:e} amplitude evaluations: \
             narrow the distribution (sigma) or use smaller particles"
        ),
    )
}
