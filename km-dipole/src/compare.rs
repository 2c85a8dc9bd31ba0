//! The dipole in the forms the comparisons with the transport solvers need
//! (`km-bench`): totals as functions of (albedo, g, eta) on the unit length
//! scale `sigma_t = 1`, and radial profiles for the measured presets.

use km_core::fresnel::reflectance;
use km_core::phase::Anisotropy;
use km_core::presets;

use crate::dipole::{rd_radial, rd_total};
use crate::error::DipoleError;
use crate::params::{DiffusionParams, FdrModel};

/// The dipole's total diffuse reflectance `Rd` (eq. D16) of a half-space
/// with single-scattering albedo `albedo` in `(0, 1]`, Henyey–Greenstein
/// `g` in `(-1, 1)` and relative index `eta = n_inside / n_outside`:
/// the fraction of the power *entering* the medium that leaves it after
/// multiple scattering. The reduced albedo is
/// `alpha' = (1 - g) albedo / (1 - g albedo)` (eq. D5 with `sigma_t = 1`).
///
/// # Errors
/// `albedo` outside `(0, 1]`, `|g| >= 1`, and those of [`FdrModel::fdr`].
///
/// ```
/// let rd = km_dipole::compare::total_diffuse_reflectance(1.0, 0.9, 1.3, Default::default());
/// assert!((rd.unwrap() - 1.0).abs() < 1e-15);
/// ```
pub fn total_diffuse_reflectance(
    albedo: f64,
    g: f64,
    eta: f64,
    fdr: FdrModel,
) -> Result<f64, DipoleError> {
    let g = Anisotropy::new(g)?;
    Ok(rd_total(&DiffusionParams::from_albedo(albedo, g, eta, fdr)?))
}

/// The dipole's diffuse reflectance for a collimated beam at `mu0 = cos theta`
/// from an ambient of index 1 onto a half-space of index `eta`, as a fraction
/// of the incident power (eq. D18 without the specular part):
/// `(1 - F_r(mu0)) Rd`. This is the quantity to compare with the diffuse
/// (non-specular) reflectance of a transport solver for the same scene.
///
/// # Errors
/// `mu0` outside `(0, 1]`, and those of [`total_diffuse_reflectance`].
pub fn diffuse_reflectance_collimated(
    albedo: f64,
    g: f64,
    eta: f64,
    mu0: f64,
    fdr: FdrModel,
) -> Result<f64, DipoleError> {
    if !(mu0 > 0.0 && mu0 <= 1.0) {
        return Err(DipoleError::invalid("mu0", mu0, "must lie in (0, 1]"));
    }
    let rd = total_diffuse_reflectance(albedo, g, eta, fdr)?;
    Ok((1.0 - reflectance(mu0, 1.0, eta)) * rd)
}

/// The diffusion quantities of a measured preset (`km_core::presets`,
/// Jensen et al. 2001), one per channel (R, G, B), lengths in mm, with the
/// preset's relative index.
///
/// # Errors
/// Unknown name; a channel without scattering; those of [`FdrModel::fdr`].
pub fn preset_params(name: &str, fdr: FdrModel) -> Result<[DiffusionParams; 3], DipoleError> {
    let m = presets::lookup(name).ok_or_else(|| DipoleError::UnknownPreset {
        name: name.to_string(),
        known: presets::names().join(", "),
    })?;
    let ch = |c: usize| DiffusionParams::from_reduced(m.sigma_a[c], m.sigma_s_prime[c], m.eta, fdr);
    Ok([ch(0)?, ch(1)?, ch(2)?])
}

/// `Rd(r)` (eq. D15, 1/mm^2) of a measured preset on the grid `r` (mm), per
/// channel R, G, B.
///
/// # Errors
/// Those of [`preset_params`]; a negative or non-finite `r`.
///
/// ```
/// let rd = km_dipole::compare::preset_profile("marble", &[0.0, 1.0], Default::default()).unwrap();
/// assert!(rd[0][0] > rd[0][1]);
/// ```
pub fn preset_profile(name: &str, r: &[f64], fdr: FdrModel) -> Result<[Vec<f64>; 3], DipoleError> {
    if let Some(&bad) = r.iter().find(|x| !x.is_finite() || **x < 0.0) {
        return Err(DipoleError::invalid("r", bad, "distances must be finite and >= 0"));
    }
    let p = preset_params(name, fdr)?;
    Ok(p.map(|p| r.iter().map(|&x| rd_radial(&p, x)).collect()))
}

/// The dipole's total `Rd` (eq. D16) of a measured preset, per channel R, G, B.
///
/// # Errors
/// Those of [`preset_params`].
pub fn preset_rd_total(name: &str, fdr: FdrModel) -> Result<[f64; 3], DipoleError> {
    Ok(preset_params(name, fdr)?.map(|p| rd_total(&p)))
}
