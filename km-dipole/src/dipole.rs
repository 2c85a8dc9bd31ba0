//! The dipole of Jensen, Marschner, Levoy & Hanrahan (2001, §2.4–2.5) for a
//! semi-infinite medium lit by a pencil beam at normal incidence:
//! fluence, radial diffuse reflectance `Rd(r)`, its closed-form total, and
//! the BSSRDF with its Fresnel transmission factors.
//!
//! Geometry: `z` grows downward, the surface is `z = 0`, the pencil beam
//! enters at the origin. The real (positive) source sits at depth `z_r`, the
//! virtual (negative) one at height `z_v` above the surface, its mirror
//! image in the extrapolated boundary `z = -z_b` (eq. D12–D13), so the
//! fluence vanishes on that plane (the boundary condition D11 of seed 003).
//! Every function takes the [`DiffusionParams`] of the medium.

use std::f64::consts::PI;

use km_core::fresnel::reflectance;

use crate::params::DiffusionParams;

/// Fluence `phi(r, z)` of the dipole per unit incident power (eq. D14),
/// 1/length^2:
///
/// `phi = alpha' / (4 pi D) [exp(-sigma_tr d_r) / d_r - exp(-sigma_tr d_v) / d_v]`,
/// `d_r = sqrt(r^2 + (z - z_r)^2)`, `d_v = sqrt(r^2 + (z + z_v)^2)`.
///
/// `r >= 0` is the distance from the beam axis, `z` the depth (valid for
/// `z >= -z_b`; exactly 0 on the extrapolated boundary `z = -z_b`). Singular
/// at the real source (`r = 0`, `z = z_r`).
///
/// # Reference
/// Jensen et al. 2001 §2.4 (point-source fluence and the dipole); seed 003,
/// diffusion equation and boundary condition.
///
/// ```
/// use km_core::phase::Anisotropy;
/// use km_dipole::{DiffusionParams, FdrModel, dipole::fluence};
/// let p = DiffusionParams::new(0.01, 1.0, Anisotropy::ISOTROPIC, 1.3, FdrModel::Exact).unwrap();
/// assert!(fluence(&p, 0.7, -p.z_b).abs() < 1e-15);
/// ```
pub fn fluence(p: &DiffusionParams, r: f64, z: f64) -> f64 {
    let d_r = r.hypot(z - p.z_r);
    let d_v = r.hypot(z + p.z_v);
    // d_v^2 - d_r^2 = (z + z_v)^2 - (z - z_r)^2 = (z_v + z_r) (2 z + z_v - z_r).
    let diff_sq = (p.z_v + p.z_r) * (2.0 * z + p.z_v - p.z_r);
    p.alpha_prime / (4.0 * PI * p.d) * dipole_difference(p.sigma_tr, d_r, d_v, diff_sq)
}

/// `exp(-s d_r) / d_r - exp(-s d_v) / d_v` without cancellation when `d_r`
/// and `d_v` are close (far from the sources), given `diff_sq = d_v^2 - d_r^2`:
/// `e_r (d_v - d_r) / (d_r d_v) + e_r (1 - exp(-s (d_v - d_r))) / d_v`,
/// `d_v - d_r = diff_sq / (d_v + d_r)`.
pub(crate) fn dipole_difference(s: f64, d_r: f64, d_v: f64, diff_sq: f64) -> f64 {
    let e_r = (-s * d_r).exp();
    let dd = diff_sq / (d_v + d_r);
    e_r * (dd / (d_r * d_v) - (-s * dd).exp_m1() / d_v)
}

/// Radial diffuse reflectance `Rd(r)` of the dipole (eq. D15), 1/length^2:
/// the exitance at distance `r` from a unit-power pencil beam, multiple
/// scattering only,
///
/// `Rd(r) = alpha' / (4 pi) [z_r (1 + sigma_tr d_r) exp(-sigma_tr d_r) / d_r^3
///                          + z_v (1 + sigma_tr d_v) exp(-sigma_tr d_v) / d_v^3]`,
/// `d_r = sqrt(r^2 + z_r^2)`, `d_v = sqrt(r^2 + z_v^2)`.
///
/// It is `D dphi/dz` at `z = 0` for the fluence of [`fluence`].
/// `r` is a distance (its sign is ignored). Every exponential decays; no
/// overflow for any finite `r`.
///
/// # Reference
/// Jensen et al. 2001 §2.4, the dipole diffuse reflectance.
///
/// ```
/// use km_core::phase::Anisotropy;
/// use km_dipole::{DiffusionParams, FdrModel, dipole::rd_radial};
/// let p = DiffusionParams::new(0.01, 1.0, Anisotropy::ISOTROPIC, 1.3, FdrModel::Exact).unwrap();
/// assert!(rd_radial(&p, 0.0) > rd_radial(&p, 1.0));
/// assert_eq!(rd_radial(&p, 1e300), 0.0);
/// ```
#[inline]
pub fn rd_radial(p: &DiffusionParams, r: f64) -> f64 {
    // Distances from the exit point to the real and virtual sources.
    let d_r = r.hypot(p.z_r);
    let d_v = r.hypot(p.z_v);
    // Each source's contribution: z (1 + sigma_tr d) exp(-sigma_tr d) / d^3.
    let real = p.z_r * (1.0 + p.sigma_tr * d_r) * (-p.sigma_tr * d_r).exp() / (d_r * d_r * d_r);
    let virt = p.z_v * (1.0 + p.sigma_tr * d_v) * (-p.sigma_tr * d_v).exp() / (d_v * d_v * d_v);
    p.alpha_prime / (4.0 * PI) * (real + virt)
}

/// Total diffuse reflectance of the dipole, `Rd = integral_0^inf 2 pi r Rd(r) dr`,
/// in closed form (eq. D16):
///
/// `Rd = (alpha' / 2) (1 + exp(-(4/3) A sqrt(3 (1 - alpha')))) exp(-sqrt(3 (1 - alpha')))`.
///
/// A fraction of the power that entered the medium; multiple scattering
/// only. Depends on `alpha'` and `A` alone.
///
/// # Reference
/// Jensen et al. 2001 §2.5 (total diffuse reflectance, used to invert
/// measured reflectance for `alpha'`).
///
/// ```
/// // Conservative medium: everything comes back out.
/// assert!((km_dipole::dipole::rd_total_from(1.0, 2.6) - 1.0).abs() < 1e-15);
/// ```
pub fn rd_total_from(alpha_prime: f64, a: f64) -> f64 {
    let s = (3.0 * (1.0 - alpha_prime).max(0.0)).sqrt();
    0.5 * alpha_prime * (1.0 + (-4.0 / 3.0 * a * s).exp()) * (-s).exp()
}

/// [`rd_total_from`] for the medium `p` (eq. D16).
pub fn rd_total(p: &DiffusionParams) -> f64 {
    rd_total_from(p.alpha_prime, p.a)
}

/// Fresnel transmittance `F_t(eta, w) = 1 - F_r(cos_theta)` for a direction
/// outside the medium at `cos_theta` from the normal (eq. D17), with the
/// relative index `eta = n_inside / n_outside`. By reciprocity it equals the
/// transmittance from inside at the refracted angle. `cos_theta` in `(0, 1]`.
///
/// ```
/// let t = km_dipole::dipole::fresnel_transmittance(1.5, 1.0);
/// assert!((t - 0.96).abs() < 1e-15);
/// ```
pub fn fresnel_transmittance(eta: f64, cos_theta: f64) -> f64 {
    1.0 - reflectance(cos_theta, 1.0, eta)
}

/// The normalisation constant `C = 1 - F_ext(eta) = (1/pi) integral F_t(eta, w) cos dw`
/// over the outer hemisphere (eq. D17), with `F_ext` the hemispherical
/// reflectance of the interface for diffuse light from outside
/// ([`km_core::fresnel::diffuse_reflectance`]`(1, eta)`). Equivalently
/// `C = eta^2 (1 - F_dr)` with the exact `F_dr`.
///
/// ```
/// let c = km_dipole::dipole::exit_constant(1.3);
/// assert!((c - 0.9389).abs() < 1e-4);
/// ```
pub fn exit_constant(eta: f64) -> f64 {
    exit_constant_from_fdr(eta, 2.0 * crate::params::fresnel_moment(eta, 1))
}

/// [`exit_constant`] from the exact `F_dr(eta)` already at hand:
/// `C = eta^2 (1 - F_dr)`, the flux balance of diffuse light across the
/// interface (`n_i^2 (1 - R_h(i -> t)) = n_t^2 (1 - R_h(t -> i))`). Only
/// valid with the exact `F_dr` ([`crate::FdrModel::Exact`]), not with a fit.
pub fn exit_constant_from_fdr(eta: f64, fdr_exact: f64) -> f64 {
    eta * eta * (1.0 - fdr_exact)
}

/// How the BSSRDF's angular factors are normalised (eq. D17).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum BssrdfNormalisation {
    /// `S = (1 / (pi C)) F_t(w_i) Rd(r) F_t(w_o)`, `C =` [`exit_constant`]:
    /// the exit factor `F_t(w_o) / (pi C)` integrates (with `cos`) to 1 over
    /// the hemisphere, so the exitance equals the diffusion flux `Rd(r)`
    /// times the transmitted fraction `F_t(w_i)` (as pbrt-v3 normalises).
    #[default]
    EnergyConserving,
    /// `S = (1 / pi) F_t(w_i) Rd(r) F_t(w_o)`, as printed by Jensen et al.
    /// 2001: the exitance is then `C F_t(w_i) Rd(r)`, i.e. `1 - F_ext(eta)`
    /// (6 % at `eta = 1.3`) below the flux the dipole predicts.
    Jensen2001,
}

/// The diffusion BSSRDF `S_d(x_i, w_i; x_o, w_o)` of a semi-infinite medium
/// (eq. D17), 1/(length^2 sr): outgoing radiance at `x_o` in direction `w_o`
/// per unit incident flux at `x_i` from direction `w_i`, multiple
/// scattering only,
///
/// `S_d = (1 / (pi C)) F_t(eta, w_i) Rd(|x_i - x_o|) F_t(eta, w_o)`,
///
/// with `C = 1` for [`BssrdfNormalisation::Jensen2001`] and
/// `C = 1 - F_ext(eta)` for [`BssrdfNormalisation::EnergyConserving`].
/// `r = |x_i - x_o|`; `cos_i`, `cos_o` are the cosines of the incident and
/// exit directions outside the medium, in `(0, 1]`. Symmetric in
/// (`cos_i`, `cos_o`) (reciprocity).
///
/// # Reference
/// Jensen et al. 2001 §2.4 (the diffusion term of the BSSRDF); the energy
/// normalisation as in pbrt-v3 (`SeparableBSSRDF::Sw`, `c = 1 - 2 FresnelMoment1(1/eta)`).
///
/// ```
/// use km_core::phase::Anisotropy;
/// use km_dipole::{DiffusionParams, FdrModel, dipole::*};
/// let p = DiffusionParams::new(0.01, 1.0, Anisotropy::ISOTROPIC, 1.3, FdrModel::Exact).unwrap();
/// let a = bssrdf(&p, 0.5, 0.9, 0.3, BssrdfNormalisation::EnergyConserving);
/// let b = bssrdf(&p, 0.5, 0.3, 0.9, BssrdfNormalisation::EnergyConserving);
/// assert!((a - b).abs() < 1e-15 * a);
/// ```
pub fn bssrdf(
    p: &DiffusionParams,
    r: f64,
    cos_i: f64,
    cos_o: f64,
    norm: BssrdfNormalisation,
) -> f64 {
    let c = match norm {
        BssrdfNormalisation::EnergyConserving => exit_constant(p.eta),
        BssrdfNormalisation::Jensen2001 => 1.0,
    };
    fresnel_transmittance(p.eta, cos_i) * rd_radial(p, r) * fresnel_transmittance(p.eta, cos_o)
        / (PI * c)
}
