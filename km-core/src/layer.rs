//! One homogeneous layer of a stack, for one spectral channel.
//!
//! A layer is `sigma_a`, `sigma_s` (1/length), a thickness (length, possibly
//! infinite: a half-space), a phase function and a refractive index.
//! Derived quantities (the conventions of docs/scene-file.md):
//! `sigma_t = sigma_a + sigma_s`, `albedo = sigma_s / sigma_t`,
//! `tau = sigma_t * thickness`.

use crate::error::CoreError;
use crate::phase::Phase;

/// A validated homogeneous layer (one channel).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Layer {
    /// Absorption coefficient, 1/length, `>= 0`.
    pub sigma_a: f64,
    /// Scattering coefficient, 1/length, `>= 0`.
    pub sigma_s: f64,
    /// Thickness, length, `>= 0`; `f64::INFINITY` for a half-space.
    pub thickness: f64,
    /// Phase function of single scattering.
    pub phase: Phase,
    /// Refractive index, `>= 1`.
    pub n: f64,
}

impl Layer {
    /// A validated layer.
    ///
    /// # Errors
    /// Negative or non-finite coefficients, negative or NaN thickness,
    /// `|g| >= 1`, `n < 1` or non-finite `n`.
    ///
    /// ```
    /// let l = km_core::Layer::new(0.1, 0.4, 1.0, 0.0, 1.3).unwrap();
    /// assert!((l.albedo() - 0.8).abs() < 1e-15);
    /// assert!(km_core::Layer::new(-0.1, 0.4, 1.0, 0.0, 1.3).is_err());
    /// ```
    pub fn new(
        sigma_a: f64,
        sigma_s: f64,
        thickness: f64,
        g: f64,
        n: f64,
    ) -> Result<Self, CoreError> {
        check_coefficient("sigma_a", sigma_a)?;
        check_coefficient("sigma_s", sigma_s)?;
        if thickness.is_nan() || thickness < 0.0 {
            return Err(CoreError::invalid("thickness", thickness, "must be >= 0 or inf"));
        }
        check_index("n", n)?;
        let phase = Phase::henyey_greenstein(g)?;
        Ok(Layer { sigma_a, sigma_s, thickness, phase, n })
    }

    /// A layer from optical thickness and single-scattering albedo, on a unit
    /// length scale (`thickness = 1`, or infinite when `tau` is).
    ///
    /// # Errors
    /// `tau < 0` or NaN, albedo outside `[0, 1]`, and the checks of [`Layer::new`].
    pub fn from_tau_albedo(tau: f64, albedo: f64, g: f64, n: f64) -> Result<Self, CoreError> {
        if tau.is_nan() || tau < 0.0 {
            return Err(CoreError::invalid("tau", tau, "must be >= 0 or inf"));
        }
        if !(0.0..=1.0).contains(&albedo) {
            return Err(CoreError::invalid("albedo", albedo, "must lie in [0, 1]"));
        }
        if tau.is_infinite() {
            // Half-space: unit extinction, infinite thickness.
            return Layer::new(1.0 - albedo, albedo, f64::INFINITY, g, n);
        }
        Layer::new(tau * (1.0 - albedo), tau * albedo, 1.0, g, n)
    }

    /// Extinction coefficient `sigma_t = sigma_a + sigma_s`.
    pub fn sigma_t(&self) -> f64 {
        self.sigma_a + self.sigma_s
    }

    /// Single-scattering albedo `sigma_s / sigma_t` (0 for a clear layer).
    pub fn albedo(&self) -> f64 {
        let t = self.sigma_t();
        if t > 0.0 { self.sigma_s / t } else { 0.0 }
    }

    /// Optical thickness `sigma_t * thickness` (infinite for a half-space with
    /// `sigma_t > 0`, 0 for a clear layer of any thickness).
    pub fn tau(&self) -> f64 {
        let t = self.sigma_t();
        if t == 0.0 { 0.0 } else { t * self.thickness }
    }

    /// Asymmetry parameter of the phase function.
    pub fn g(&self) -> f64 {
        self.phase.g()
    }

    /// True for a half-space (`thickness = inf`).
    pub fn is_half_space(&self) -> bool {
        self.thickness.is_infinite()
    }
}

pub(crate) fn check_coefficient(name: &str, v: f64) -> Result<(), CoreError> {
    if !v.is_finite() || v < 0.0 {
        return Err(CoreError::invalid(name, v, "must be finite and >= 0"));
    }
    Ok(())
}

pub(crate) fn check_index(name: &str, n: f64) -> Result<(), CoreError> {
    if !n.is_finite() || n < 1.0 {
        return Err(CoreError::invalid(name, n, "refractive index must be finite and >= 1"));
    }
    Ok(())
}
