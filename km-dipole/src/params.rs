//! The quantities of the diffusion approximation (seed 003; Jensen et al.
//! 2001 §2.4), for one homogeneous medium and one spectral channel.
//!
//! Equation numbers `(Dn)` refer to `docs/diffusion.md`.
//!
//! | symbol | formula | eq. |
//! |---|---|---|
//! | `sigma_s'` | `(1 - g) sigma_s` | D5 |
//! | `sigma_t'` | `sigma_a + sigma_s'` | D5 |
//! | `alpha'` | `sigma_s' / sigma_t'` | D5 |
//! | `D` | `1 / (3 sigma_t')` | D6 |
//! | `sigma_tr` | `sqrt(3 sigma_a sigma_t') = sqrt(sigma_a / D)` | D8 |
//! | `F_dr` | `2 integral_0^1 F_r(eta -> 1, mu) mu dmu`, or the Egan–Hilgeman fit | D9, D10 |
//! | `A` | `(1 + F_dr) / (1 - F_dr)` | D11 |
//! | `z_b` | `2 A D` (extrapolated boundary above the surface) | D12 |
//! | `z_r`, `z_v` | `1 / sigma_t'`, `z_r + 4 A D` (real and virtual sources) | D13 |

use std::fmt;
use std::str::FromStr;

use km_core::phase::Anisotropy;

use std::sync::OnceLock;

use km_core::fresnel::{critical_cos, egan_hilgeman_fdr, reflectance};
use km_core::quadrature::gauss_legendre;

use crate::error::DipoleError;

/// How the internal diffuse Fresnel reflectance `F_dr(eta)` is computed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum FdrModel {
    /// The hemispherical average of the exact unpolarised Fresnel reflectance
    /// seen from inside, `F_dr = 2 integral_0^1 F_r(mu) mu dmu` (eq. D9),
    /// total internal reflection included: the quadrature of
    /// [`km_core::fresnel::diffuse_reflectance`]`(eta, 1)` (same panels, same
    /// 24-point Gauss–Legendre rule, equal to rounding) with the nodes
    /// computed once ([`fresnel_moment`]). Valid for any `eta > 0`.
    #[default]
    #[cfg_attr(
        feature = "clap",
        value(name = "exact", help = "Numerical integral of the exact Fresnel reflectance")
    )]
    Exact,
    /// The Egan & Hilgeman (1979) polynomial fit quoted by Jensen et al. 2001,
    /// `F_dr = -1.440 / eta^2 + 0.710 / eta + 0.668 + 0.0636 eta` (eq. D10).
    /// Defined for `eta >= 1` only (it turns negative below); within 0.1 %
    /// of the exact value for `1.1 <= eta <= 1.5` (it gives 0.0016, not 0, at `eta = 1`).
    #[cfg_attr(
        feature = "clap",
        value(name = "egan-hilgeman", help = "Egan & Hilgeman's polynomial fit")
    )]
    EganHilgeman,
}

impl FdrModel {
    /// Name used in reports and on the command line (`exact`, `egan-hilgeman`).
    pub fn name(&self) -> &'static str {
        match self {
            FdrModel::Exact => "exact",
            FdrModel::EganHilgeman => "egan-hilgeman",
        }
    }

    /// `F_dr(eta)` for `eta = n_inside / n_outside` (eq. D9 or D10).
    ///
    /// # Errors
    /// `eta` not finite or not positive; [`FdrModel::EganHilgeman`] with `eta < 1`.
    ///
    /// ```
    /// use km_dipole::FdrModel;
    /// assert_eq!(FdrModel::Exact.fdr(1.0).unwrap(), 0.0);
    /// let exact = FdrModel::Exact.fdr(1.3).unwrap();
    /// let fit = FdrModel::EganHilgeman.fdr(1.3).unwrap();
    /// assert!((exact - 0.44446).abs() < 1e-5 && (fit - 0.44476).abs() < 1e-5);
    /// ```
    pub fn fdr(&self, eta: f64) -> Result<f64, DipoleError> {
        if !eta.is_finite() || eta <= 0.0 {
            return Err(DipoleError::invalid("eta", eta, "relative index must be finite and > 0"));
        }
        match self {
            FdrModel::Exact => Ok(2.0 * fresnel_moment(eta, 1)),
            FdrModel::EganHilgeman => {
                if eta < 1.0 {
                    return Err(DipoleError::FitOutOfRange { eta });
                }
                Ok(egan_hilgeman_fdr(eta))
            }
        }
    }
}

impl fmt::Display for FdrModel {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for FdrModel {
    type Err = String;
    /// `exact` or `egan-hilgeman` (also `eh`, `egan_hilgeman`).
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s.trim().to_ascii_lowercase().as_str() {
            "exact" => Ok(FdrModel::Exact),
            "egan-hilgeman" | "egan_hilgeman" | "eh" => Ok(FdrModel::EganHilgeman),
            other => {
                Err(format!("unknown F_dr model \"{other}\" (expected exact or egan-hilgeman)"))
            }
        }
    }
}

/// `C_k(eta) = integral_0^1 F_r(mu; eta -> 1) mu^k dmu` (eq. D20): the k-th
/// angular moment of the Fresnel reflectance for light inside a medium of
/// relative index `eta = n_inside / n_outside` meeting its surface
/// (total internal reflection included). `2 C_1` is `F_dr` (eq. D9).
/// Gauss–Legendre on sub-intervals graded towards the critical cosine
/// (as [`km_core::fresnel::diffuse_reflectance`]).
///
/// ```
/// let c1 = km_dipole::params::fresnel_moment(1.3, 1);
/// let fdr = km_core::fresnel::diffuse_reflectance(1.3, 1.0);
/// assert!((2.0 * c1 - fdr).abs() < 1e-13);
/// assert_eq!(km_dipole::params::fresnel_moment(1.0, 2), 0.0);
/// ```
pub fn fresnel_moment(eta: f64, k: i32) -> f64 {
    if eta == 1.0 {
        return 0.0;
    }
    // Below the critical cosine F_r = 1: integral_0^mu_c mu^k dmu.
    let mu_c = critical_cos(eta, 1.0);
    let mut sum = mu_c.powi(k + 1) / f64::from(k + 1);
    // Above it, the square-root onset at mu_c: geometric panels towards it.
    // 24-point Gauss–Legendre nodes, computed once.
    static NODES: OnceLock<(Vec<f64>, Vec<f64>)> = OnceLock::new();
    let (x, w) = NODES.get_or_init(|| gauss_legendre(24));
    let span = 1.0 - mu_c;
    let mut a = mu_c;
    for c in [1e-6, 1e-4, 1e-3, 1e-2, 0.05, 0.2, 0.5, 1.0] {
        let b = mu_c + span * c;
        let (h, m) = (0.5 * (b - a), 0.5 * (b + a));
        let f = |mu: f64| reflectance(mu, eta, 1.0) * mu.powi(k);
        sum += h * x.iter().zip(w).map(|(xi, wi)| wi * f(m + h * xi)).sum::<f64>();
        a = b;
    }
    sum
}

/// The domain of the scattering coefficients.
pub(crate) const NEEDS_SCATTERING: &str =
    "must be finite and > 0 (the diffusion approximation needs scattering)";

/// `A = (1 + F_dr) / (1 - F_dr)` (eq. D11), the boundary mismatch factor of
/// the diffusion boundary condition `phi + 2 A D (n . grad phi) = 0`.
/// `F_dr` must lie in `[0, 1)`.
///
/// ```
/// assert_eq!(km_dipole::params::a_from_fdr(0.0), 1.0);
/// ```
pub fn a_from_fdr(fdr: f64) -> f64 {
    (1.0 + fdr) / (1.0 - fdr)
}

/// The diffusion quantities of one medium (one channel), eq. D5–D13.
///
/// Lengths are in the unit of the coefficients' inverse (e.g. mm for 1/mm).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DiffusionParams {
    /// Absorption coefficient `sigma_a`, 1/length, `>= 0`.
    pub sigma_a: f64,
    /// Reduced scattering coefficient `sigma_s' = (1 - g) sigma_s`, 1/length, `> 0` (D5).
    pub sigma_s_prime: f64,
    /// Reduced extinction coefficient `sigma_t' = sigma_a + sigma_s'`, 1/length (D5).
    pub sigma_t_prime: f64,
    /// Reduced albedo `alpha' = sigma_s' / sigma_t'`, in `(0, 1]` (D5).
    pub alpha_prime: f64,
    /// Diffusion constant `D = 1 / (3 sigma_t')`, length (D6).
    pub d: f64,
    /// Effective transport coefficient `sigma_tr = sqrt(3 sigma_a sigma_t')`, 1/length (D8).
    pub sigma_tr: f64,
    /// Relative index `eta = n_inside / n_outside`.
    pub eta: f64,
    /// Internal diffuse Fresnel reflectance `F_dr(eta)` (D9 or D10).
    pub fdr: f64,
    /// The model that gave `fdr`.
    pub fdr_model: FdrModel,
    /// `A = (1 + F_dr) / (1 - F_dr)` (D11).
    pub a: f64,
    /// Extrapolated boundary distance `z_b = 2 A D` above the surface, length (D12).
    pub z_b: f64,
    /// Depth of the real source `z_r = 1 / sigma_t'`, length (D13).
    pub z_r: f64,
    /// Height of the virtual (negative) source above the surface,
    /// `z_v = z_r + 4 A D = z_r + 2 z_b`, length (D13).
    pub z_v: f64,
}

impl DiffusionParams {
    /// From the transport coefficients `sigma_a`, `sigma_s` (1/length), the
    /// Henyey–Greenstein asymmetry `g` and the relative index `eta = n_inside / n_outside`.
    ///
    /// `g` is checked by its type ([`Anisotropy::new`]: `|g| < 1`).
    ///
    /// # Errors
    /// Negative or non-finite coefficients, `sigma_s = 0` (no diffusion),
    /// and the errors of [`FdrModel::fdr`].
    ///
    /// ```
    /// use km_core::phase::Anisotropy;
    /// use km_dipole::{DiffusionParams, FdrModel};
    /// let g = Anisotropy::new(0.5).unwrap();
    /// let p = DiffusionParams::new(0.1, 2.0, g, 1.0, FdrModel::Exact).unwrap();
    /// assert!((p.sigma_s_prime - 1.0).abs() < 1e-15);
    /// assert!((p.d - 1.0 / 3.3).abs() < 1e-15);
    /// assert_eq!(p.a, 1.0); // matched boundary
    /// ```
    pub fn new(
        sigma_a: f64,
        sigma_s: f64,
        g: Anisotropy,
        eta: f64,
        fdr_model: FdrModel,
    ) -> Result<Self, DipoleError> {
        if !sigma_s.is_finite() || sigma_s <= 0.0 {
            return Err(DipoleError::invalid("sigma_s", sigma_s, NEEDS_SCATTERING));
        }
        Self::from_reduced(sigma_a, g.reduced(sigma_s), eta, fdr_model)
    }

    /// From `sigma_a` and the reduced scattering coefficient `sigma_s'`
    /// directly (the form of measured tables such as Jensen et al. 2001).
    ///
    /// # Errors
    /// As [`DiffusionParams::new`].
    pub fn from_reduced(
        sigma_a: f64,
        sigma_s_prime: f64,
        eta: f64,
        fdr_model: FdrModel,
    ) -> Result<Self, DipoleError> {
        if !sigma_a.is_finite() || sigma_a < 0.0 {
            return Err(DipoleError::invalid("sigma_a", sigma_a, "must be finite and >= 0"));
        }
        if !sigma_s_prime.is_finite() || sigma_s_prime <= 0.0 {
            return Err(DipoleError::invalid("sigma_s'", sigma_s_prime, NEEDS_SCATTERING));
        }
        let fdr = fdr_model.fdr(eta)?;
        Ok(Self::assemble(sigma_a, sigma_s_prime, eta, fdr, fdr_model))
    }

    /// As [`DiffusionParams::from_reduced`] with `F_dr` already computed by
    /// `fdr_model` (the caller caches it per `eta`; arguments already checked).
    pub(crate) fn assemble(
        sigma_a: f64,
        sigma_s_prime: f64,
        eta: f64,
        fdr: f64,
        fdr_model: FdrModel,
    ) -> Self {
        // D5: reduced coefficients (similarity relation of seed 003 eq. 4).
        let sigma_t_prime = sigma_a + sigma_s_prime;
        let alpha_prime = sigma_s_prime / sigma_t_prime;
        // D6, D8: diffusion constant and effective transport coefficient.
        let d = 1.0 / (3.0 * sigma_t_prime);
        let sigma_tr = (3.0 * sigma_a * sigma_t_prime).sqrt();
        // D11-D13: boundary mismatch, extrapolated boundary, dipole positions.
        let a = a_from_fdr(fdr);
        let z_b = 2.0 * a * d;
        let z_r = 1.0 / sigma_t_prime;
        let z_v = z_r + 4.0 * a * d;
        DiffusionParams {
            sigma_a,
            sigma_s_prime,
            sigma_t_prime,
            alpha_prime,
            d,
            sigma_tr,
            eta,
            fdr,
            fdr_model,
            a,
            z_b,
            z_r,
            z_v,
        }
    }

    /// From a `km-core` layer below an ambient medium of index `ambient_n`
    /// (`eta = layer.n / ambient_n`). The layer's thickness is not looked at.
    ///
    /// # Errors
    /// As [`DiffusionParams::new`].
    pub fn from_layer(
        layer: &km_core::Layer,
        ambient_n: f64,
        fdr_model: FdrModel,
    ) -> Result<Self, DipoleError> {
        let eta = layer.n() / ambient_n;
        Self::new(layer.sigma_a(), layer.sigma_s(), layer.anisotropy(), eta, fdr_model)
    }

    /// From the single-scattering albedo `omega = sigma_s / sigma_t` on the
    /// unit length scale `sigma_t = 1` (lengths then in mean free paths).
    ///
    /// # Errors
    /// `omega` outside `(0, 1]`, and those of [`DiffusionParams::new`].
    pub fn from_albedo(
        omega: f64,
        g: Anisotropy,
        eta: f64,
        fdr_model: FdrModel,
    ) -> Result<Self, DipoleError> {
        if !(omega > 0.0 && omega <= 1.0) {
            return Err(DipoleError::invalid("albedo", omega, "must lie in (0, 1]"));
        }
        Self::new(1.0 - omega, omega, g, eta, fdr_model)
    }
}
