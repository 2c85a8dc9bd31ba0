//! Two-flux values at any depth (`docs/field.md` §3, eq. D7–D9): the
//! junction fluxes of the stack's adding (eq. K9) fix each layer's two
//! fluxes, given in closed form inside it (seed eq. 9, lit from both faces,
//! eq. K5b).

use crate::error::CoreError;
use crate::scene::MonoScene;

use super::solve::build;
use super::stack::{HemisphericalCache, stack_adding};
use super::{KmModel, KmOptions, profile_two_sided};

/// Two-flux `phi`, `A` and `F` at requested depths of one channel, per unit
/// incident power.
#[derive(Debug, Clone, PartialEq)]
pub struct KmDepthProfile {
    /// The depths, from the top surface.
    pub depths: Vec<f64>,
    /// `phi = 2 (i+ + i-)` (eq. D8: each flux is a diffuse, semi-isotropic
    /// radiance, whose fluence is twice its flux).
    pub fluence: Vec<f64>,
    /// `A = K (i+ + i-)`, the model's own absorption per unit depth (eq. D7;
    /// `= sigma_a phi` when `K = 2 sigma_a`).
    pub absorbed: Vec<f64>,
    /// `F = i+ - i-`.
    pub net_flux: Vec<f64>,
    /// The fraction absorbed in each layer (`integral A dz`, eq. K9).
    pub layer_absorptance: Vec<f64>,
}

/// `phi`, `A` and `F` of the two-flux model at `depths` (finite, `>= 0`,
/// inside the stack; at an interface, the layer above it).
///
/// # Errors
/// A depth outside the stack, those of [`super::solve_mono`], and the
/// four-flux model under a collimated beam (its beam inside the layers is not
/// resolved in depth: ask for [`KmModel::TwoFlux`]).
///
/// ```
/// use km_core::two_flux::{KmOptions, depth_profile, layer_rt};
/// let s = km_core::Scene::from_toml_str(
///     "[[layer]]\nsigma_a = 0.1\nsigma_s = 0.4\nthickness = 2.0\n").unwrap();
/// // The seed's model: two-flux, K = sigma_a, S = sigma_s (as `layer_rt`).
/// let p = depth_profile(&s.channels()[0], &KmOptions::SEED, &[0.0, 2.0]).unwrap();
/// assert!(depth_profile(&s.channels()[0], &KmOptions::default(), &[0.0]).is_err());
/// let rt = layer_rt(0.1, 0.4, 2.0).unwrap();
/// assert!((p.net_flux[0] - (1.0 - rt.r)).abs() < 1e-15);
/// assert!((p.net_flux[1] - rt.t).abs() < 1e-15);
/// ```
pub fn depth_profile(
    mono: &MonoScene,
    opts: &KmOptions,
    depths: &[f64],
) -> Result<KmDepthProfile, CoreError> {
    if opts.model == KmModel::FourFlux
        && mono.light().mu0().is_some()
        && super::solve::four_flux_applies(mono)
    {
        return Err(CoreError::unsupported(
            "km",
            "the depth profile is written for the two-flux model only (km_model = two-flux): \
             the four-flux model's collimated beam inside the layers is not resolved in depth",
        ));
    }
    let b = build(mono, opts.mapping, &mut HemisphericalCache::default())?;
    let f = stack_adding(&b.slabs);
    let mut layers = Vec::with_capacity(b.layer_slab.len());
    let mut z_top = 0.0;
    for (layer, &si) in mono.layers().iter().zip(&b.layer_slab) {
        let (k, s) = opts.mapping.coefficients(layer)?;
        let up_bottom = f.up.get(si + 1).copied().unwrap_or(0.0);
        layers.push((z_top, layer.thickness(), k, s, f.down[si], up_bottom));
        z_top += layer.thickness();
    }
    let mut p = KmDepthProfile {
        depths: depths.to_vec(),
        fluence: Vec::with_capacity(depths.len()),
        absorbed: Vec::with_capacity(depths.len()),
        net_flux: Vec::with_capacity(depths.len()),
        layer_absorptance: b.layer_slab.iter().map(|&i| f.absorbed[i]).collect(),
    };
    for &z in depths {
        let found = layers.iter().find(|l| l.1 > 0.0 && z <= l.0 + l.1);
        let Some(&(top, d, k, s, down, up)) = found.filter(|_| z.is_finite() && z >= 0.0) else {
            return Err(CoreError::invalid(
                "depths",
                z,
                "depth must be finite and lie in the stack",
            ));
        };
        // A half-space is lit from above only.
        let up = if d.is_infinite() { 0.0 } else { up };
        let x = profile_two_sided(k, s, d, (z - top).clamp(0.0, d), down, up)?;
        p.fluence.push(2.0 * (x.down + x.up));
        p.absorbed.push(k * (x.down + x.up));
        p.net_flux.push(x.down - x.up);
    }
    Ok(p)
}
