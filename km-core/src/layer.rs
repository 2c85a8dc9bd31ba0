//! One homogeneous layer of a stack, for one spectral channel.
//!
//! A layer is `sigma_a`, `sigma_s` (1/length), a thickness (length, possibly
//! infinite: a half-space), a phase function and a refractive index.
//! Derived quantities (the conventions of docs/scene-file.md):
//! `sigma_t = sigma_a + sigma_s`, `albedo = sigma_s / sigma_t`,
//! `tau = sigma_t * thickness`, `sigma_s' = sigma_s (1 - g)`.
//!
//! The fields are private: a [`Layer`] exists only through its checked
//! constructors ([`Layer::new`], [`Layer::from_tau_albedo`], [`Layer::from_phase`]
//! and the `with_*` variants), so every solver receives a valid one.

use crate::error::CoreError;
use crate::microfacet::Microfacet;
use crate::phase::{Anisotropy, Phase};

/// A validated homogeneous layer (one channel). It clones in constant time
/// (a phase function's data is shared, [`Phase`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Layer {
    /// Absorption coefficient, 1/length, `>= 0`.
    sigma_a: f64,
    /// Scattering coefficient, 1/length, `>= 0`.
    sigma_s: f64,
    /// Thickness, length, `>= 0`; `f64::INFINITY` for a half-space.
    thickness: f64,
    /// Phase function of single scattering.
    phase: Phase,
    /// Refractive index, `>= 1`.
    n: f64,
    /// Roughness of the layer's top face (`None`: smooth), docs/rough.md.
    roughness: Option<Microfacet>,
}

impl Layer {
    /// A validated layer.
    ///
    /// # Errors
    /// Negative or non-finite coefficients, `sigma_a + sigma_s` or
    /// `(sigma_a + sigma_s) * thickness` not representable (overflow),
    /// negative or NaN thickness, `|g| >= 1`, `n < 1` or non-finite `n`.
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
        check_fields(sigma_a, sigma_s, thickness, n)?;
        let phase = Phase::henyey_greenstein(g)?;
        Ok(Layer { sigma_a, sigma_s, thickness, phase, n, roughness: None })
    }

    /// A validated layer with a given phase function: every check of a layer
    /// is written here, once.
    ///
    /// # Errors
    /// Those of [`Layer::new`] except `g` (a [`Phase`] is valid by construction).
    pub fn from_phase(
        sigma_a: f64,
        sigma_s: f64,
        thickness: f64,
        phase: Phase,
        n: f64,
    ) -> Result<Self, CoreError> {
        check_fields(sigma_a, sigma_s, thickness, n)?;
        Ok(Layer { sigma_a, sigma_s, thickness, phase, n, roughness: None })
    }

    /// This layer with another thickness (checked as in [`Layer::new`]).
    ///
    /// # Errors
    /// A negative or NaN thickness, or an optical thickness that overflows.
    pub fn with_thickness(&self, thickness: f64) -> Result<Self, CoreError> {
        Layer::from_phase(self.sigma_a, self.sigma_s, thickness, self.phase.clone(), self.n)
            .map(|l| l.with_roughness(self.roughness))
    }

    /// This layer with another refractive index.
    ///
    /// # Errors
    /// `n < 1` or non-finite.
    pub fn with_n(&self, n: f64) -> Result<Self, CoreError> {
        Layer::from_phase(self.sigma_a, self.sigma_s, self.thickness, self.phase.clone(), n)
            .map(|l| l.with_roughness(self.roughness))
    }

    /// This layer with other coefficients `sigma_a`, `sigma_s`.
    ///
    /// # Errors
    /// Those of [`Layer::new`] on the coefficients.
    pub fn with_coefficients(&self, sigma_a: f64, sigma_s: f64) -> Result<Self, CoreError> {
        Layer::from_phase(sigma_a, sigma_s, self.thickness, self.phase.clone(), self.n)
            .map(|l| l.with_roughness(self.roughness))
    }

    /// This layer with another phase function (always valid).
    pub fn with_phase(&self, phase: Phase) -> Self {
        Layer { phase, ..self.clone() }
    }

    /// This layer with another top face: `None` smooth, or a rough face
    /// (docs/rough.md; a face between equal indices has no effect).
    pub fn with_roughness(&self, roughness: Option<Microfacet>) -> Self {
        Layer { roughness, ..self.clone() }
    }

    /// The roughness of the layer's top face, `None` when smooth.
    pub fn roughness(&self) -> Option<Microfacet> {
        self.roughness
    }

    /// Absorption coefficient `sigma_a`, 1/length, `>= 0`.
    pub fn sigma_a(&self) -> f64 {
        self.sigma_a
    }

    /// Scattering coefficient `sigma_s`, 1/length, `>= 0`.
    pub fn sigma_s(&self) -> f64 {
        self.sigma_s
    }

    /// Thickness, length, `>= 0`; `f64::INFINITY` for a half-space.
    pub fn thickness(&self) -> f64 {
        self.thickness
    }

    /// Phase function of single scattering.
    pub fn phase(&self) -> &Phase {
        &self.phase
    }

    /// Refractive index, finite and `>= 1`.
    pub fn n(&self) -> f64 {
        self.n
    }

    /// Reduced scattering coefficient `sigma_s' = sigma_s (1 - g)`, 1/length
    /// ([`Anisotropy::reduced`]).
    pub fn sigma_s_reduced(&self) -> f64 {
        self.anisotropy().reduced(self.sigma_s)
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

    /// Asymmetry parameter as the checked type.
    pub fn anisotropy(&self) -> Anisotropy {
        self.phase.anisotropy()
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

/// Every check of a layer's numbers, once (the phase function is checked by its type).
fn check_fields(sigma_a: f64, sigma_s: f64, thickness: f64, n: f64) -> Result<(), CoreError> {
    check_coefficient("sigma_a", sigma_a)?;
    check_coefficient("sigma_s", sigma_s)?;
    if thickness.is_nan() || thickness < 0.0 {
        return Err(CoreError::invalid("thickness", thickness, "must be >= 0 or inf"));
    }
    check_index("n", n)?;
    // sigma_t and tau must be representable: 1e308 + 1e308 overflows, and
    // the methods then disagree (R = 0 or R = 1) instead of failing.
    let sigma_t = sigma_a + sigma_s;
    if !sigma_t.is_finite() {
        return Err(CoreError::invalid("sigma_a + sigma_s", sigma_t, "overflows"));
    }
    if thickness.is_finite() && !(sigma_t * thickness).is_finite() {
        return Err(CoreError::invalid(
            "thickness",
            thickness,
            "the optical thickness (sigma_a + sigma_s) * thickness overflows",
        ));
    }
    Ok(())
}

/// True when `n` is a refractive index this project accepts: finite and `>= 1`
/// (the one place this test is written; callers with their own message use it).
pub fn is_refractive_index(n: f64) -> bool {
    n.is_finite() && n >= 1.0
}

/// Check a refractive index (see [`is_refractive_index`]).
///
/// # Errors
/// [`CoreError::Invalid`] on `name` when `n` is not finite or `n < 1`.
///
/// ```
/// assert!(km_core::layer::check_index("n", 1.5).is_ok());
/// assert!(km_core::layer::check_index("n", 0.9).is_err());
/// ```
pub fn check_index(name: &str, n: f64) -> Result<(), CoreError> {
    if !is_refractive_index(n) {
        return Err(CoreError::invalid(name, n, "refractive index must be finite and >= 1"));
    }
    Ok(())
}
