//! Phase functions: the angular distribution of single scattering.
//!
//! Every phase function is normalised over the unit sphere,
//! `integral p(cos t) dw = 1` (eq. P1), and is described by three operations
//! that the solvers need:
//!
//! * [`PhaseFunction::eval`]: `p(cos t)` in 1/sr,
//! * [`PhaseFunction::sample_cos`]: a cosine drawn with density
//!   `2 pi p(cos t)` on `[-1, 1]`, as a pure function of a uniform `u` in `[0, 1)`,
//! * [`PhaseFunction::legendre_moment`]: `chi_l = 2 pi integral_{-1}^{1} p(x) P_l(x) dx`
//!   (eq. P2), so that `p(x) = sum_l (2l + 1) / (4 pi) chi_l P_l(x)` and `chi_1 = g`.
//!
//! Henyey–Greenstein (Henyey & Greenstein 1941), with the exponent 3/2 and the
//! sign `- 2 g cos t` (the seed 000 prints 2/3 and `+`: both are misprints):
//!
//! `p(cos t) = (1 - g^2) / (4 pi (1 + g^2 - 2 g cos t)^(3/2))`   (eq. P3)
//!
//! Its Legendre moments are `chi_l = g^l` (eq. P4).
//!
//! New phase functions are added as new variants of [`Phase`] (which keeps the
//! solvers free of dynamic dispatch) implementing the three operations.

use std::f64::consts::PI;

use crate::error::CoreError;

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

/// The phase functions the project knows.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Phase {
    /// `p = 1 / (4 pi)`.
    Isotropic,
    /// Henyey–Greenstein with asymmetry `g` in `(-1, 1)` (eq. P3).
    HenyeyGreenstein {
        /// Mean cosine of scattering, dimensionless, `-1 < g < 1`.
        g: Anisotropy,
    },
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

    /// Asymmetry parameter (mean cosine).
    pub fn g(&self) -> f64 {
        self.anisotropy().get()
    }

    /// Asymmetry parameter as the checked type.
    pub fn anisotropy(&self) -> Anisotropy {
        match *self {
            Phase::Isotropic => Anisotropy::ISOTROPIC,
            Phase::HenyeyGreenstein { g } => g,
        }
    }
}

impl PhaseFunction for Phase {
    fn eval(&self, cos_theta: f64) -> f64 {
        match *self {
            Phase::Isotropic => 1.0 / (4.0 * PI),
            Phase::HenyeyGreenstein { g } => {
                let g = g.get();
                let denom = 1.0 + g * g - 2.0 * g * cos_theta;
                (1.0 - g * g) / (4.0 * PI * denom * denom.sqrt())
            }
        }
    }

    fn sample_cos(&self, u: f64) -> f64 {
        match *self {
            Phase::Isotropic => 1.0 - 2.0 * u,
            Phase::HenyeyGreenstein { g } => {
                let g = g.get();
                // Inverse of the HG cumulative distribution (Henyey & Greenstein 1941; pbrt-v4).
                if g.abs() < 1e-6 {
                    return 1.0 - 2.0 * u;
                }
                let s = (1.0 - g * g) / (1.0 - g + 2.0 * g * u);
                ((1.0 + g * g - s * s) / (2.0 * g)).clamp(-1.0, 1.0)
            }
        }
    }

    fn legendre_moment(&self, l: usize) -> f64 {
        match *self {
            Phase::Isotropic => {
                if l == 0 {
                    1.0
                } else {
                    0.0
                }
            }
            Phase::HenyeyGreenstein { g } => g.get().powi(l as i32),
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
