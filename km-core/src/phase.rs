//! Phase functions: the angular distribution of single scattering.
//!
//! Every phase function is normalised over the unit sphere,
//! `integral p(cos t) dw = 1` (eq. P1), and is described by the operations
//! that the solvers need:
//!
//! * [`PhaseFunction::eval`]: `p(cos t)` in 1/sr,
//! * [`PhaseFunction::sample_cos`]: a cosine drawn with density
//!   `2 pi p(cos t)` on `[-1, 1]`, as a pure function of a uniform `u` in `[0, 1)`,
//! * [`PhaseFunction::legendre_moment`]: `chi_l = 2 pi integral_{-1}^{1} p(x) P_l(x) dx`
//!   (eq. P2), so that `p(x) = sum_l (2l + 1) / (4 pi) chi_l P_l(x)` and `chi_1 = g`
//!   (DISORT's `PMOM`, with `chi_0 = 1`).
//!
//! Henyey–Greenstein (Henyey & Greenstein 1941), with the exponent 3/2 and the
//! sign `- 2 g cos t` (the seed 000 prints 2/3 and `+`: both are misprints):
//!
//! `p(cos t) = (1 - g^2) / (4 pi (1 + g^2 - 2 g cos t)^(3/2))`   (eq. P3)
//!
//! Its Legendre moments are `chi_l = g^l` (eq. P4).
//!
//! The kinds of [`Phase`] (docs/phase.md for every equation):
//!
//! | kind | type | eval | sampling | moments |
//! |---|---|---|---|---|
//! | isotropic, Henyey–Greenstein | closed forms P3, P4 | closed | closed | `g^l` |
//! | two-term HG | [`TwoTermHg`] (P6–P8) | closed | closed (lobe choice) | closed |
//! | Rayleigh | [`Rayleigh`] (P9–P11) | closed | cubic, closed | `chi_2` only |
//! | Reynolds–McCormick | [`ReynoldsMcCormick`] (P12–P14) | closed | closed | recurrence |
//! | Legendre moments | [`LegendreSeries`] | series | interpolant (P18) | given |
//! | table | [`PhaseTable`] (P15–P17) | linear | exact for the table | exact |
//! | Mie particles | [`ParticlePhase`] (docs/mie.md) | series | interpolant (P18) | Mie |
//!
//! The variants with data hold it behind an [`Arc`], so a [`Phase`] clones in
//! constant time. Henyey–Greenstein keeps its closed forms on every path.

use std::f64::consts::PI;
use std::sync::Arc;

use crate::error::CoreError;

mod gegenbauer;
mod particles;
mod rayleigh;
mod table;
mod two_term;

pub use gegenbauer::{MAX_RM_MOMENTS, ReynoldsMcCormick};
pub use particles::{ParticlePhase, Population};
pub use rayleigh::Rayleigh;
pub use table::{LegendreSeries, MAX_TABLE_MOMENTS, PhaseTable, Piecewise};
pub use two_term::TwoTermHg;

/// What every phase function offers to the solvers.
pub trait PhaseFunction {
    /// `p(cos t)` in 1/sr, normalised over the sphere (eq. P1).
    fn eval(&self, cos_theta: f64) -> f64;
    /// A scattering cosine with density `2 pi p(cos t)` from a uniform `u` in `[0, 1)`.
    fn sample_cos(&self, u: f64) -> f64;
    /// Legendre moment `chi_l` (eq. P2); `chi_0 = 1`, `chi_1 = g`.
    fn legendre_moment(&self, l: usize) -> f64;
    /// Mean cosine `g = chi_1`.
    fn mean_cosine(&self) -> f64 {
        self.legendre_moment(1)
    }
}

/// A Henyey–Greenstein asymmetry parameter (mean cosine of scattering),
/// checked once: finite with `|g| < 1` (the only place this check is written).
///
/// At `|g| = 1` eq. P3 degenerates to a delta in the forward (or backward)
/// direction, `sigma_s (1 - g) = 0`, and no method of this project treats it.
#[derive(Debug, Clone, Copy, PartialEq, PartialOrd)]
pub struct Anisotropy(f64);

impl Anisotropy {
    /// No anisotropy, `g = 0`.
    pub const ISOTROPIC: Anisotropy = Anisotropy(0.0);

    /// A checked asymmetry parameter.
    ///
    /// # Errors
    /// `g` must be finite with `|g| < 1` ([`CoreError::Invalid`] on `g`).
    ///
    /// ```
    /// use km_core::phase::Anisotropy;
    /// assert_eq!(Anisotropy::new(0.5).unwrap().get(), 0.5);
    /// assert!(Anisotropy::new(-1.0).is_err() && Anisotropy::new(f64::NAN).is_err());
    /// ```
    pub fn new(g: f64) -> Result<Anisotropy, CoreError> {
        if !Anisotropy::admits(g) {
            return Err(CoreError::invalid("g", g, "must satisfy |g| < 1"));
        }
        Ok(Anisotropy(g))
    }

    /// True when `g` is a valid asymmetry parameter (finite, `|g| < 1`): the
    /// test of [`Anisotropy::new`], for callers that word their own message.
    pub fn admits(g: f64) -> bool {
        g.is_finite() && g.abs() < 1.0
    }

    /// The value `g`.
    pub fn get(self) -> f64 {
        self.0
    }

    /// The reduced scattering coefficient `sigma_s' = sigma_s (1 - g)` of a
    /// scattering coefficient `sigma_s` (docs/diffusion.md eq. D5; Jensen et
    /// al. 2001, §2.3).
    ///
    /// ```
    /// let g = km_core::phase::Anisotropy::new(0.5).unwrap();
    /// assert_eq!(g.reduced(2.0), 1.0);
    /// ```
    pub fn reduced(self, sigma_s: f64) -> f64 {
        sigma_s * (1.0 - self.0)
    }

    /// `g^2`, again a valid asymmetry (in `[0, 1)`).
    pub fn squared(self) -> Anisotropy {
        Anisotropy(self.0 * self.0)
    }
}

impl PartialEq<f64> for Anisotropy {
    fn eq(&self, other: &f64) -> bool {
        self.0 == *other
    }
}

/// The phase functions the project knows (docs/phase.md).
#[derive(Debug, Clone, PartialEq)]
pub enum Phase {
    /// `p = 1 / (4 pi)`.
    Isotropic,
    /// Henyey–Greenstein with asymmetry `g` in `(-1, 1)` (eq. P3).
    HenyeyGreenstein {
        /// Mean cosine of scattering, dimensionless, `-1 < g < 1`.
        g: Anisotropy,
    },
    /// Two-term Henyey–Greenstein (eq. P6).
    TwoTermHg(TwoTermHg),
    /// Rayleigh scattering with a depolarisation factor (eq. P9).
    Rayleigh(Rayleigh),
    /// Reynolds–McCormick, the Gegenbauer kernel (eq. P12).
    ReynoldsMcCormick(Arc<ReynoldsMcCormick>),
    /// Given Legendre moments (DISORT's `PMOM`).
    Legendre(Arc<LegendreSeries>),
    /// A table of `(cos t, p)`, linear between its nodes (eq. P16).
    Table(Arc<PhaseTable>),
    /// Particles by Mie theory (docs/mie.md).
    Particles(Arc<ParticlePhase>),
}

impl Phase {
    /// Henyey–Greenstein with asymmetry `g`; `g = 0` gives [`Phase::Isotropic`].
    ///
    /// # Errors
    /// `g` must be finite with `|g| < 1`.
    ///
    /// ```
    /// use km_core::phase::{Phase, PhaseFunction};
    /// let p = Phase::henyey_greenstein(0.5).unwrap();
    /// assert!((p.mean_cosine() - 0.5).abs() < 1e-15);
    /// assert!(Phase::henyey_greenstein(1.0).is_err());
    /// ```
    pub fn henyey_greenstein(g: f64) -> Result<Phase, CoreError> {
        Ok(Phase::from_anisotropy(Anisotropy::new(g)?))
    }

    /// Henyey–Greenstein with a checked asymmetry; `g = 0` gives [`Phase::Isotropic`].
    pub fn from_anisotropy(g: Anisotropy) -> Phase {
        if g == 0.0 { Phase::Isotropic } else { Phase::HenyeyGreenstein { g } }
    }

    /// Asymmetry parameter (mean cosine `chi_1`).
    pub fn g(&self) -> f64 {
        self.anisotropy().get()
    }

    /// Asymmetry parameter as the checked type (every kind has `|chi_1| < 1`,
    /// checked at its construction).
    pub fn anisotropy(&self) -> Anisotropy {
        match self {
            Phase::Isotropic => Anisotropy::ISOTROPIC,
            Phase::HenyeyGreenstein { g } => *g,
            // |chi_1| < 1 for every kind (checked by its constructor).
            other => Anisotropy(other.legendre_moment(1)),
        }
    }

    /// The kind's name as in the scene file: `isotropic`, `hg`,
    /// `two-term-hg`, `rayleigh`, `reynolds-mccormick`, `legendre`, `table`, `mie`.
    pub fn kind(&self) -> &'static str {
        match self {
            Phase::Isotropic => "isotropic",
            Phase::HenyeyGreenstein { .. } => "hg",
            Phase::TwoTermHg(_) => "two-term-hg",
            Phase::Rayleigh(_) => "rayleigh",
            Phase::ReynoldsMcCormick(_) => "reynolds-mccormick",
            Phase::Legendre(_) => "legendre",
            Phase::Table(_) => "table",
            Phase::Particles(_) => "mie",
        }
    }

    /// True for isotropic scattering (no kind but [`Phase::Isotropic`]: a
    /// Henyey–Greenstein of `g = 0` is built as isotropic; Rayleigh has
    /// `g = 0` but is not isotropic).
    pub fn is_isotropic(&self) -> bool {
        matches!(self, Phase::Isotropic)
    }

    /// The number of moments `L + 1` after which every `chi_l` vanishes, for
    /// the kinds that are a finite Legendre series (isotropic 1, Rayleigh 3,
    /// given moments, Mie); `None` for the others. A layer whose series fits
    /// within the moments a solver keeps needs no delta-M truncation and no
    /// single-scattering correction.
    pub fn finite_moments(&self) -> Option<usize> {
        match self {
            Phase::Isotropic => Some(1),
            Phase::Rayleigh(r) => Some(if r.chi2() == 0.0 { 1 } else { 3 }),
            Phase::Legendre(s) => Some(s.moments().len()),
            Phase::Particles(p) => Some(p.series().moments().len()),
            _ => None,
        }
    }

    /// The moments the project holds explicitly (`chi_0 = 1 .. chi_L`): all
    /// of a finite series, the stored ones of a Reynolds–McCormick function or
    /// a table; `None` for the closed forms (HG, two-term HG), whose moments
    /// [`PhaseFunction::legendre_moment`] gives for any `l`.
    pub fn stored_moments(&self) -> Option<&[f64]> {
        match self {
            Phase::ReynoldsMcCormick(r) => Some(r.moments()),
            Phase::Legendre(s) => Some(s.moments()),
            Phase::Table(t) => Some(t.moments()),
            Phase::Particles(p) => Some(p.series().moments()),
            _ => None,
        }
    }

    /// The phase function of two successive scatterings, `p * p` on the
    /// sphere, whose moments are `chi_l^2` (1/sr): what the second-order
    /// intensity correction needs (docs/multiflux.md eq. 5e). Closed forms
    /// for Henyey–Greenstein (HG of `g^2`), two-term HG (eq. P8), Rayleigh
    /// and isotropic; the series of the stored moments otherwise (for a
    /// table, its first [`MAX_TABLE_MOMENTS`]).
    pub fn eval_convolved(&self, c: f64) -> f64 {
        match self {
            Phase::Isotropic => 1.0 / (4.0 * PI),
            Phase::HenyeyGreenstein { g } => hg_eval(g.get() * g.get(), c),
            Phase::TwoTermHg(t) => t.eval_convolved(c),
            Phase::Rayleigh(r) => r.eval_convolved(c),
            Phase::ReynoldsMcCormick(r) => {
                table::series_sum(r.moments(), c, |x| x * x) / (4.0 * PI)
            }
            Phase::Legendre(s) => s.eval_convolved(c),
            Phase::Table(t) => table::series_sum(t.moments(), c, |x| x * x) / (4.0 * PI),
            Phase::Particles(p) => p.series().eval_convolved(c),
        }
    }

    /// `p(c)` from a piecewise-linear interpolant where the kind has no
    /// closed form (given moments, Mie: eq. P18, within 1e-5 of the value or
    /// 1e-10 in probability per interval), exact otherwise: for solvers that
    /// evaluate the phase function between many pairs of directions.
    pub fn eval_tabulated(&self, c: f64) -> f64 {
        match self {
            Phase::Legendre(s) => s.lookup().0.eval(c),
            Phase::Particles(p) => p.series().lookup().0.eval(c),
            other => other.eval(c),
        }
    }

    /// Whether the phase function can be sampled as a probability density:
    /// a Legendre series (given moments, Mie) that is negative somewhere
    /// (a truncated series rings) cannot.
    ///
    /// # Errors
    /// [`CoreError::Invalid`] naming the least value and where it is, when
    /// the series falls below `-1e-9` of its largest value.
    pub fn check_density(&self) -> Result<(), CoreError> {
        let series = match self {
            Phase::Legendre(s) => s.as_ref(),
            Phase::Particles(p) => p.series(),
            _ => return Ok(()),
        };
        let (table, min) = series.lookup();
        let max = table.values().iter().copied().fold(0.0, f64::max);
        if *min < -1e-9 * max {
            return Err(CoreError::invalid(
                "phase function",
                *min,
                "the Legendre series is negative somewhere (its truncation rings); a \
                 probability density is needed: give more moments, or a table",
            ));
        }
        Ok(())
    }
}

/// Henyey–Greenstein `p(c)` (eq. P3) for any `|g| < 1`.
#[inline]
pub(crate) fn hg_eval(g: f64, c: f64) -> f64 {
    let denom = 1.0 + g * g - 2.0 * g * c;
    (1.0 - g * g) / (4.0 * PI * denom * denom.sqrt())
}

/// Henyey–Greenstein inverse cumulative distribution (Henyey & Greenstein
/// 1941; pbrt-v4), `u = 0` at `cos = -1`.
#[inline]
pub(crate) fn hg_sample(g: f64, u: f64) -> f64 {
    if g.abs() < 1e-6 {
        return 1.0 - 2.0 * u;
    }
    let s = (1.0 - g * g) / (1.0 - g + 2.0 * g * u);
    ((1.0 + g * g - s * s) / (2.0 * g)).clamp(-1.0, 1.0)
}

impl PhaseFunction for Phase {
    #[inline]
    fn eval(&self, cos_theta: f64) -> f64 {
        match self {
            Phase::Isotropic => 1.0 / (4.0 * PI),
            Phase::HenyeyGreenstein { g } => hg_eval(g.get(), cos_theta),
            Phase::TwoTermHg(t) => t.eval(cos_theta),
            Phase::Rayleigh(r) => r.eval(cos_theta),
            Phase::ReynoldsMcCormick(r) => r.eval(cos_theta),
            Phase::Legendre(s) => s.eval(cos_theta),
            Phase::Table(t) => t.eval(cos_theta),
            Phase::Particles(p) => p.series().eval(cos_theta),
        }
    }

    #[inline]
    fn sample_cos(&self, u: f64) -> f64 {
        match self {
            Phase::Isotropic => 1.0 - 2.0 * u,
            Phase::HenyeyGreenstein { g } => hg_sample(g.get(), u),
            Phase::TwoTermHg(t) => t.sample(u),
            Phase::Rayleigh(r) => r.sample(u),
            Phase::ReynoldsMcCormick(r) => r.sample(u),
            // Sampled from the interpolant of eq. P18 (built on first use).
            Phase::Legendre(s) => s.lookup().0.sample(u),
            Phase::Table(t) => t.table().sample(u),
            Phase::Particles(p) => p.series().lookup().0.sample(u),
        }
    }

    #[inline]
    fn legendre_moment(&self, l: usize) -> f64 {
        match self {
            Phase::Isotropic => {
                if l == 0 {
                    1.0
                } else {
                    0.0
                }
            }
            Phase::HenyeyGreenstein { g } => g.get().powi(l as i32),
            Phase::TwoTermHg(t) => t.moment(l),
            Phase::Rayleigh(r) => r.moment(l),
            Phase::ReynoldsMcCormick(r) => r.moment(l),
            Phase::Legendre(s) => s.moments().get(l).copied().unwrap_or(0.0),
            Phase::Table(t) => t.moments().get(l).copied().unwrap_or(0.0),
            Phase::Particles(p) => p.series().moments().get(l).copied().unwrap_or(0.0),
        }
    }
}

/// The 2-D ("flatland") Henyey–Greenstein function on the circle, normalised so
/// that `integral_0^{2 pi} p2(cos t) dt = 1`:
///
/// `p2(cos t) = (1 - g^2) / (2 pi (1 + g^2 - 2 g cos t))`   (eq. P5)
///
/// Used by the seed 000's 2-D figures 3 and 4. Its Fourier coefficients are `g^m`.
pub fn henyey_greenstein_2d(g: f64, cos_theta: f64) -> f64 {
    (1.0 - g * g) / (2.0 * PI * (1.0 + g * g - 2.0 * g * cos_theta))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Gauss–Legendre-free check: composite Simpson on [-1, 1] with many panels.
    fn integrate(f: impl Fn(f64) -> f64, n: usize) -> f64 {
        let h = 2.0 / n as f64;
        let mut s = f(-1.0) + f(1.0);
        for i in 1..n {
            let x = -1.0 + i as f64 * h;
            s += if i % 2 == 1 { 4.0 } else { 2.0 } * f(x);
        }
        s * h / 3.0
    }

    #[test]
    fn hg_is_normalised_and_has_mean_cosine_g() {
        for &g in &[-0.7, -0.2, 0.0, 0.3, 0.8] {
            let p = Phase::henyey_greenstein(g).unwrap();
            let norm = 2.0 * PI * integrate(|x| p.eval(x), 20_000);
            let mean = 2.0 * PI * integrate(|x| x * p.eval(x), 20_000);
            assert!((norm - 1.0).abs() < 1e-8, "g={g} norm={norm}");
            assert!((mean - g).abs() < 1e-8, "g={g} mean={mean}");
            // chi_2 from the definition (eq. P2) equals g^2 (eq. P4).
            let chi2 = 2.0 * PI * integrate(|x| 0.5 * (3.0 * x * x - 1.0) * p.eval(x), 20_000);
            assert!((chi2 - p.legendre_moment(2)).abs() < 1e-8);
        }
    }

    #[test]
    fn hg_sampling_inverts_the_cdf() {
        // The CDF of the sampled cosine at the sample equals u (round trip).
        let g = 0.6;
        let p = Phase::henyey_greenstein(g).unwrap();
        for k in 1..20 {
            let u = k as f64 / 20.0;
            let x = p.sample_cos(u);
            // CDF from +1 downwards: P(cos >= x) = 2 pi integral_x^1 p.
            let n = 4000;
            let h = (1.0 - x) / n as f64;
            let mut s = 0.0;
            for i in 0..n {
                let t = x + (i as f64 + 0.5) * h;
                s += p.eval(t) * h;
            }
            let upper = 2.0 * PI * s;
            // sample_cos maps u = 0 to cos = -1 and u -> 1 to cos = +1.
            assert!((upper - (1.0 - u)).abs() < 1e-6, "u={u} x={x} upper={upper}");
        }
    }

    #[test]
    fn bad_g_is_refused() {
        assert!(Phase::henyey_greenstein(f64::NAN).is_err());
        assert!(Phase::henyey_greenstein(-1.0).is_err());
    }
}
