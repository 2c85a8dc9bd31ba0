//! The diffusion field inside the half-space (eq. D24–D27 of
//! `docs/diffusion.md`): the fluence `phi(r, z)` of a pencil beam (the
//! dipole's own, eq. D14, for either model) and, integrated over the plane,
//! the fluence, absorbed power density and net flux `phi(z)`, `A(z)`,
//! `F(z)` of a broad beam, with the collimated beam restored.
//!
//! Both dipoles share the form: a real source of strength `alpha'` at
//! `z_r`, a negative image at `-z_v`, the diffusion coefficient `D`
//! (`1/(3 sigma_t')` for Jensen et al. 2001, Grosjean's `D_G` for the
//! better dipole) and `sigma_tr = sqrt(sigma_a / D)`. Per unit power
//! entering the medium at normal incidence:
//!
//! ```text
//! phi_d(z) = alpha' / (2 D sigma_tr) [exp(-sigma_tr |z - z_r|) - exp(-sigma_tr (z + z_v))]   (D24)
//! F_d(z)   = -D dphi_d/dz = (alpha'/2) [sgn(z - z_r) exp(-sigma_tr |z - z_r|) - exp(-sigma_tr (z + z_v))]  (D25)
//! phi(z)   = phi_d(z) + exp(-sigma_t' z),  F(z) = F_d(z) + exp(-sigma_t' z),  A = sigma_a phi   (D26)
//! integral_0^inf A dz = 1 - E_0,   E_0 = -F_d(0) = (alpha'/2) [exp(-sigma_tr z_r) + exp(-sigma_tr z_v)]  (D27)
//! ```

use std::f64::consts::PI;

use crate::better_dipole::BetterDipole;
use crate::dipole::dipole_difference;
use crate::params::DiffusionParams;

/// The constants of a dipole's diffusion field (module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DipoleField {
    /// Reduced albedo `alpha'` (the real source's strength).
    pub alpha_prime: f64,
    /// Diffusion coefficient `D`, length.
    pub d: f64,
    /// `sigma_tr = sqrt(sigma_a / D)`, 1/length.
    pub sigma_tr: f64,
    /// Depth of the real source, length.
    pub z_r: f64,
    /// Height of the image source above the surface, length.
    pub z_v: f64,
    /// Reduced extinction `sigma_t'` (the collimated beam's), 1/length.
    pub sigma_t_prime: f64,
    /// Absorption coefficient, 1/length.
    pub sigma_a: f64,
}

impl DipoleField {
    /// The field of the dipole of Jensen et al. 2001 (eq. D13–D14).
    pub fn classic(p: &DiffusionParams) -> Self {
        DipoleField {
            alpha_prime: p.alpha_prime,
            d: p.d,
            sigma_tr: p.sigma_tr,
            z_r: p.z_r,
            z_v: p.z_v,
            sigma_t_prime: p.sigma_t_prime,
            sigma_a: p.sigma_a,
        }
    }

    /// The field of d'Eon's better dipole (eq. D19–D21) of a medium of
    /// absorption `sigma_a`.
    pub fn better(b: &BetterDipole, sigma_a: f64) -> Self {
        DipoleField {
            alpha_prime: b.alpha_prime,
            d: b.d_g,
            sigma_tr: b.sigma_tr,
            z_r: b.z_r,
            z_v: b.z_v,
            sigma_t_prime: b.sigma_t_prime,
            sigma_a,
        }
    }

    /// Fluence `phi(r, z)` of a unit-power pencil beam (eq. D14 with this
    /// field's `D`), 1/length^2: the diffuse light only (the collimated
    /// beam is a line on the axis). `r >= 0`, `z >= 0`; singular at the real
    /// source (`r = 0`, `z = z_r`).
    ///
    /// ```
    /// use km_core::phase::Anisotropy;
    /// use km_dipole::{DiffusionParams, FdrModel, field::DipoleField};
    /// let p = DiffusionParams::new(0.01, 1.0, Anisotropy::ISOTROPIC, 1.3, FdrModel::Exact).unwrap();
    /// let f = DipoleField::classic(&p);
    /// assert_eq!(f.fluence_rz(0.5, 2.0), km_dipole::dipole::fluence(&p, 0.5, 2.0));
    /// ```
    pub fn fluence_rz(&self, r: f64, z: f64) -> f64 {
        let d_r = r.hypot(z - self.z_r);
        let d_v = r.hypot(z + self.z_v);
        let diff_sq = (self.z_v + self.z_r) * (2.0 * z + self.z_v - self.z_r);
        self.alpha_prime / (4.0 * PI * self.d) * dipole_difference(self.sigma_tr, d_r, d_v, diff_sq)
    }

    /// The broad beam's diffuse fluence and net diffuse flux at depth
    /// `z >= 0` (eq. D24–D25), per unit power entering per unit area. At
    /// the source plane `z = z_r` the flux is the value just above it (the
    /// source adds `alpha'` across the plane).
    pub fn broad_diffuse(&self, z: f64) -> (f64, f64) {
        let (s, a) = (self.sigma_tr, (z - self.z_r).abs());
        // b - a >= 0: z + z_v - |z - z_r| is z_v + z_r below the source
        // and 2 z + z_v - z_r >= z_v - z_r > 0 above it.
        let b = z + self.z_v;
        let e_a = (-s * a).exp();
        let e_b = (-s * b).exp();
        // (e_a - e_b) / s without cancellation; (b - a) at sigma_tr = 0.
        let diff_over_s = if s > 0.0 { -e_a * (-s * (b - a)).exp_m1() / s } else { b - a };
        let phi = self.alpha_prime / (2.0 * self.d) * diff_over_s;
        let sign = if z > self.z_r { 1.0 } else { -1.0 };
        let flux = 0.5 * self.alpha_prime * (sign * e_a - e_b);
        (phi, flux)
    }

    /// `(phi, A, F)` of the broad beam at depth `z >= 0` (eq. D26), per
    /// unit power entering per unit area: the diffuse part plus the
    /// collimated beam `exp(-sigma_t' z)` that feeds the source.
    pub fn broad(&self, z: f64) -> (f64, f64, f64) {
        let (phi_d, f_d) = self.broad_diffuse(z);
        let c = (-self.sigma_t_prime * z).exp();
        let phi = phi_d + c;
        let a = if self.sigma_a == 0.0 { 0.0 } else { self.sigma_a * phi };
        (phi, a, f_d + c)
    }

    /// `E_0 = -F_d(0)`, the diffuse flux leaving through the surface (eq.
    /// D27): Jensen et al.'s total `Rd` (D16); for the better dipole the
    /// flux part of its exitance (D22 weighs it with the fluence).
    pub fn surface_flux(&self) -> f64 {
        -self.broad_diffuse(0.0).1
    }

    /// `integral_0^inf A dz = 1 - E_0` per unit power entering (eq. D27):
    /// the collimated beam absorbs `1 - alpha'`, the diffuse light
    /// `alpha' - E_0` (the diffusion equation integrated over the half-space).
    pub fn absorbed_total(&self) -> f64 {
        1.0 - self.surface_flux()
    }
}
