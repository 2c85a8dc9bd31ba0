//! The "better dipole" of d'Eon (2012): Grosjean's diffusion coefficient,
//! a boundary condition from the first two angular moments of the Fresnel
//! reflectance, and an exitance that weighs the fluence and the flux at the
//! surface (eq. D19–D22 of `docs/diffusion.md`), as in pbrt-v3's
//! photon-beam-diffusion code (`BeamDiffusionMS`, evaluated at the single
//! depth `z_r = 1/sigma_t'` instead of integrated along the beam).
//!
//! * `D_G = (2 sigma_a + sigma_s') / (3 sigma_t'^2)`, `sigma_tr = sqrt(sigma_a / D_G)` (D19)
//! * Fresnel moments (light inside going out, `eta = n_inside / n_outside`):
//!   `C_k = integral_0^1 F_r(mu; eta -> 1) mu^k dmu`, `2 C_1 = F_dr` (D20)
//! * `A = (1 + 3 C_2) / (1 - 2 C_1)`, `z_b = 2 A D_G`, `z_r = 1/sigma_t'`, `z_v = z_r + 2 z_b` (D21)
//! * `R(r) = alpha' (C_phi phi(r) + C_E E(r))`, `C_phi = (1 - 2 C_1)/4`,
//!   `C_E = (1 - 3 C_2)/2` (D22): the exitance of the P1 radiance through the
//!   Fresnel boundary.

use std::f64::consts::PI;

use km_core::phase::Anisotropy;

use crate::error::DipoleError;
use crate::params::NEEDS_SCATTERING;

pub use crate::params::fresnel_moment;

/// The better dipole of one medium (one channel), eq. D19–D22.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BetterDipole {
    /// Reduced albedo `alpha' = sigma_s' / sigma_t'` (D5).
    pub alpha_prime: f64,
    /// Reduced extinction `sigma_t'`, 1/length (D5).
    pub sigma_t_prime: f64,
    /// Grosjean's diffusion coefficient `D_G`, length (D19).
    pub d_g: f64,
    /// `sigma_tr = sqrt(sigma_a / D_G)`, 1/length (D19).
    pub sigma_tr: f64,
    /// First Fresnel moment `C_1` (D20).
    pub c1: f64,
    /// Second Fresnel moment `C_2` (D20).
    pub c2: f64,
    /// `A = (1 + 3 C_2) / (1 - 2 C_1)` (D21).
    pub a: f64,
    /// Extrapolation distance `z_b = 2 A D_G`, length (D21).
    pub z_b: f64,
    /// Depth of the real source `1 / sigma_t'`, length (D21).
    pub z_r: f64,
    /// Height of the virtual source above the surface `z_r + 2 z_b`, length (D21).
    pub z_v: f64,
    /// Weight of the fluence in the exitance, `(1 - 2 C_1) / 4` (D22).
    pub c_phi: f64,
    /// Weight of the flux in the exitance, `(1 - 3 C_2) / 2` (D22).
    pub c_e: f64,
}

impl BetterDipole {
    /// From `sigma_a`, `sigma_s` (1/length), the asymmetry `g` and
    /// `eta = n_inside / n_outside`.
    ///
    /// `g` is checked by its type ([`Anisotropy::new`]: `|g| < 1`).
    ///
    /// # Errors
    /// Negative or non-finite coefficients, `sigma_s = 0`,
    /// `eta` not finite and positive.
    pub fn new(sigma_a: f64, sigma_s: f64, g: Anisotropy, eta: f64) -> Result<Self, DipoleError> {
        if !sigma_s.is_finite() || sigma_s <= 0.0 {
            return Err(DipoleError::invalid("sigma_s", sigma_s, NEEDS_SCATTERING));
        }
        Self::from_reduced(sigma_a, g.reduced(sigma_s), eta)
    }

    /// From `sigma_a` and the reduced scattering coefficient `sigma_s'`.
    ///
    /// # Errors
    /// As [`BetterDipole::new`].
    pub fn from_reduced(sigma_a: f64, sigma_s_prime: f64, eta: f64) -> Result<Self, DipoleError> {
        if !sigma_a.is_finite() || sigma_a < 0.0 {
            return Err(DipoleError::invalid("sigma_a", sigma_a, "must be finite and >= 0"));
        }
        if !sigma_s_prime.is_finite() || sigma_s_prime <= 0.0 {
            return Err(DipoleError::invalid("sigma_s'", sigma_s_prime, NEEDS_SCATTERING));
        }
        if !eta.is_finite() || eta <= 0.0 {
            return Err(DipoleError::invalid("eta", eta, "relative index must be finite and > 0"));
        }
        let (c1, c2) = (fresnel_moment(eta, 1), fresnel_moment(eta, 2));
        Ok(Self::assemble(sigma_a, sigma_s_prime, c1, c2))
    }

    /// As [`BetterDipole::from_reduced`] with the moments `C_1`, `C_2` at
    /// hand (the caller caches them per `eta`; arguments already checked).
    pub(crate) fn assemble(sigma_a: f64, sigma_s_prime: f64, c1: f64, c2: f64) -> Self {
        // D19: Grosjean's diffusion coefficient and the transport coefficient.
        let sigma_t_prime = sigma_a + sigma_s_prime;
        let d_g = (2.0 * sigma_a + sigma_s_prime) / (3.0 * sigma_t_prime * sigma_t_prime);
        let sigma_tr = (sigma_a / d_g).sqrt();
        // D20-D21: boundary from the Fresnel moments, source positions.
        let a = (1.0 + 3.0 * c2) / (1.0 - 2.0 * c1);
        let z_b = 2.0 * a * d_g;
        let z_r = 1.0 / sigma_t_prime;
        BetterDipole {
            alpha_prime: sigma_s_prime / sigma_t_prime,
            sigma_t_prime,
            d_g,
            sigma_tr,
            c1,
            c2,
            a,
            z_b,
            z_r,
            z_v: z_r + 2.0 * z_b,
            c_phi: 0.25 * (1.0 - 2.0 * c1),
            c_e: 0.5 * (1.0 - 3.0 * c2),
        }
    }

    /// Radial exitance `R(r)` per unit power entering at the origin (eq. D22),
    /// 1/length^2, multiple scattering only:
    ///
    /// `R(r) = alpha' [C_phi phi(r) + C_E E(r)]`,
    /// `phi(r) = (1 / (4 pi D_G)) (exp(-sigma_tr d_r)/d_r - exp(-sigma_tr d_v)/d_v)`,
    /// `E(r) = (1 / (4 pi)) (z_r (1 + sigma_tr d_r) exp(-sigma_tr d_r)/d_r^3
    ///                     + z_v (1 + sigma_tr d_v) exp(-sigma_tr d_v)/d_v^3)`.
    ///
    /// # Reference
    /// d'Eon 2012; pbrt-v3 `BeamDiffusionMS` (one depth).
    pub fn rd_radial(&self, r: f64) -> f64 {
        let (s, zr, zv) = (self.sigma_tr, self.z_r, self.z_v);
        let d_r = r.hypot(zr);
        let d_v = r.hypot(zv);
        let (e_r, e_v) = ((-s * d_r).exp(), (-s * d_v).exp());
        // Fluence and normal flux of the dipole at the surface.
        let phi = crate::dipole::dipole_difference(s, d_r, d_v, zv * zv - zr * zr)
            / (4.0 * PI * self.d_g);
        let flux = (zr * (1.0 + s * d_r) * e_r / (d_r * d_r * d_r)
            + zv * (1.0 + s * d_v) * e_v / (d_v * d_v * d_v))
            / (4.0 * PI);
        self.alpha_prime * (self.c_phi * phi + self.c_e * flux)
    }

    /// Total `integral 2 pi r R(r) dr` in closed form:
    /// `alpha' [C_phi (e^{-sigma_tr z_r} - e^{-sigma_tr z_v}) / (2 D_G sigma_tr)
    ///  + (C_E / 2) (e^{-sigma_tr z_r} + e^{-sigma_tr z_v})]`; the first term's
    /// limit for `sigma_tr -> 0` is `C_phi (z_v - z_r) / (2 D_G)`. Equals 1 for
    /// `alpha' = 1` (`2 A C_phi + C_E = 1`).
    pub fn rd_total(&self) -> f64 {
        let (s, zr, zv) = (self.sigma_tr, self.z_r, self.z_v);
        let e_r = (-s * zr).exp();
        let e_v = (-s * zv).exp();
        // (e_r - e_v) / s = e_r (1 - exp(-s (z_v - z_r))) / s, without cancellation.
        let dz = zv - zr;
        let diff_over_s = if s > 0.0 { -e_r * (-s * dz).exp_m1() / s } else { dz };
        self.alpha_prime
            * (self.c_phi * diff_over_s / (2.0 * self.d_g) + 0.5 * self.c_e * (e_r + e_v))
    }
}
