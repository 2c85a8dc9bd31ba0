//! Rayleigh scattering by small (or anisotropic) molecules, with the
//! depolarisation factor `rho` (Chandrasekhar 1950 §18; Hansen & Travis
//! 1974 eq. 2.15, written with `gamma = rho / (2 - rho)`):
//!
//! ```text
//! p(cos t) = 3 / (8 pi (2 + rho)) [(1 + rho) + (1 - rho) cos^2 t]              (P9)
//! chi_1 = 0,  chi_2 = (1 - rho) / (5 (2 + rho)),  chi_l = 0 (l > 2)           (P10)
//! ```
//!
//! `rho = 0` is the classical `3/(16 pi) (1 + cos^2 t)` with `chi_2 = 0.1`
//! (DISORT's `GETMOM` Rayleigh); air has `rho ~ 0.028` (Young 1980;
//! Bodhaine et al. 1999). The cumulative distribution is a cubic in
//! `cos t`, inverted in closed form (Cardano, written without cancellation)
//! and polished by one Newton step (P11).

use std::f64::consts::PI;

use crate::error::CoreError;

/// Rayleigh scattering with a depolarisation factor (eq. P9).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rayleigh {
    rho: f64,
}

impl Rayleigh {
    /// Rayleigh scattering with depolarisation factor `rho` in `[0, 1]`
    /// (`rho = 1` is isotropic).
    ///
    /// # Errors
    /// `rho` outside `[0, 1]` or not finite.
    ///
    /// ```
    /// use km_core::phase::Rayleigh;
    /// assert!(Rayleigh::new(0.0279).is_ok());
    /// assert!(Rayleigh::new(-0.1).is_err());
    /// ```
    pub fn new(rho: f64) -> Result<Rayleigh, CoreError> {
        if !(0.0..=1.0).contains(&rho) {
            return Err(CoreError::invalid("depolarisation", rho, "must lie in [0, 1]"));
        }
        Ok(Rayleigh { rho })
    }

    /// The depolarisation factor `rho`.
    pub fn depolarisation(&self) -> f64 {
        self.rho
    }

    /// `chi_2` (eq. P10).
    pub fn chi2(&self) -> f64 {
        (1.0 - self.rho) / (5.0 * (2.0 + self.rho))
    }

    /// `p(cos t)` (eq. P9).
    pub(crate) fn eval(&self, c: f64) -> f64 {
        let r = self.rho;
        3.0 / (8.0 * PI * (2.0 + r)) * ((1.0 + r) + (1.0 - r) * c * c)
    }

    /// `chi_l` (eq. P10).
    pub(crate) fn moment(&self, l: usize) -> f64 {
        match l {
            0 => 1.0,
            2 => self.chi2(),
            _ => 0.0,
        }
    }

    /// The phase function of moments `chi_l^2`: `(1 + 5 chi_2^2 P_2) / (4 pi)`.
    pub(crate) fn eval_convolved(&self, c: f64) -> f64 {
        let chi2 = self.chi2();
        (1.0 + 5.0 * chi2 * chi2 * 0.5 * (3.0 * c * c - 1.0)) / (4.0 * PI)
    }

    /// The inverse of the cumulative distribution from `cos t = -1` (eq. P11):
    /// `B mu^3 / 3 + A mu = (A + B/3)(2u - 1)`, `A = 1 + rho`, `B = 1 - rho`.
    pub(crate) fn sample(&self, u: f64) -> f64 {
        let (a, b) = (1.0 + self.rho, 1.0 - self.rho);
        let c = (a + b / 3.0) * (2.0 * u - 1.0);
        let mut mu = if b < 1e-12 {
            c / a
        } else {
            // mu^3 + p mu = q, one real root; t = cbrt(|q|/2 + D), mu = sgn(q)(t - p/(3t)).
            let (p, q) = (3.0 * a / b, 3.0 * c / b);
            let d = (0.25 * q * q + p * p * p / 27.0).sqrt();
            let t = (0.5 * q.abs() + d).cbrt();
            if t == 0.0 { 0.0 } else { q.signum() * (t - p / (3.0 * t)) }
        };
        // One Newton step on f(mu) = B mu^3/3 + A mu - c (f' = B mu^2 + A >= A > 0).
        mu -= (b * mu * mu * mu / 3.0 + a * mu - c) / (b * mu * mu + a);
        mu.clamp(-1.0, 1.0)
    }
}
