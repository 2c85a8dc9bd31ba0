//! One channel lit by a collimated beam, solved by the four-flux model:
//! the stack as four-flux slabs (the beam's angle in every medium from the
//! Snell invariant), added, and reported as the contract's numbers.

use std::f64::consts::PI;

use crate::error::CoreError;
use crate::fresnel;
use crate::layer::Layer;
use crate::scene::{MonoScene, Substrate};
use crate::solution::ChannelResult;
use crate::two_flux::stack::HemisphericalCache;
use crate::two_flux::{KmMapping, Slab};

use super::stack::{FourSlab, stack_four};
use super::{backscatter_fraction, collimated_layer};

/// The stack of one channel as four-flux slabs.
struct Built {
    slabs: Vec<FourSlab>,
    /// Index of the slab of each layer.
    layer_slab: Vec<usize>,
    /// True when light can leave through the bottom.
    open_bottom: bool,
}

/// The beam's direction cosine in a medium of index `n`, from the Snell
/// invariant `nu = n0 sin theta0`; `None` where the beam cannot exist.
fn beam_cos(nu: f64, n: f64) -> Option<f64> {
    let sin = nu / n;
    (sin < 1.0).then(|| ((1.0 - sin) * (1.0 + sin)).sqrt())
}

/// Fresnel reflectance of the beam at an interface from `n_above` to
/// `n_below`, the beam at cosine `mu_above` above it (1 where it cannot pass
/// or cannot exist above: no beam crosses there).
fn beam_reflectance(mu_above: Option<f64>, n_above: f64, n_below: f64) -> f64 {
    mu_above.map_or(1.0, |mu| fresnel::reflectance(mu, n_above, n_below))
}

/// A layer as a four-flux slab: the mapping's `K`, `S` for the diffuse
/// pair, the layer's own `sigma_a`, `sigma_s` and phase function for the
/// beam at cosine `mu` (none there if the beam cannot exist in the layer).
fn layer_slab(
    layer: &Layer,
    index: usize,
    mapping: KmMapping,
    mu: Option<f64>,
) -> Result<FourSlab, CoreError> {
    let (k, s) = super::super::solve::layer_coefficients(mapping, layer, index)?;
    let diffuse = Slab::layer(k, s, layer.thickness())?;
    let beam = match mu {
        Some(mu) => {
            let back = backscatter_fraction(layer.phase(), mu);
            collimated_layer(k, s, layer.sigma_a(), layer.sigma_s(), back, mu, layer.thickness())?
        }
        // No beam reaches it: any conserving response will do.
        None => super::CollimatedRt { r: 0.0, t: 0.0, direct: 0.0, a: 1.0 },
    };
    Ok(FourSlab::layer(&diffuse, &beam))
}

fn build(
    mono: &MonoScene,
    mapping: KmMapping,
    cache: &mut HemisphericalCache,
) -> Result<Built, CoreError> {
    let nu = mono.beam_invariant().unwrap_or(0.0);
    let n0 = mono.ambient_n();
    let mut slabs = Vec::with_capacity(2 * mono.layers().len() + 2);
    let mut layer_slabs = Vec::with_capacity(mono.layers().len());
    let first_n = mono.layers()[0].n();
    // Saunderson's top interface for the diffuse pair; Fresnel at theta0 for the beam.
    if first_n != n0 {
        let diffuse = cache.saunderson_top(mono.light(), n0, first_n)?;
        let r_beam = mono.light().mu0().map_or(1.0, |mu0| fresnel::reflectance(mu0, n0, first_n));
        slabs.push(FourSlab::interface(r_beam, &diffuse));
    }
    let mut n_above = first_n;
    for (i, layer) in mono.layers().iter().enumerate() {
        if layer.n() != n_above {
            let diffuse = cache.interface(n_above, layer.n())?;
            let r_beam = beam_reflectance(beam_cos(nu, n_above), n_above, layer.n());
            slabs.push(FourSlab::interface(r_beam, &diffuse));
        }
        layer_slabs.push(slabs.len());
        slabs.push(layer_slab(layer, i, mapping, beam_cos(nu, layer.n()))?);
        n_above = layer.n();
        if layer.is_half_space() {
            // Nothing below a half-space matters; only a clear one lets light on.
            let open_bottom = layer.sigma_t() == 0.0;
            return Ok(Built { slabs, layer_slab: layer_slabs, open_bottom });
        }
    }
    let open_bottom = match mono.substrate() {
        Substrate::Transparent { n } => {
            if n != n_above {
                let diffuse = cache.interface(n_above, n)?;
                let r_beam = beam_reflectance(beam_cos(nu, n_above), n_above, n);
                slabs.push(FourSlab::interface(r_beam, &diffuse));
            }
            true
        }
        Substrate::Lambertian { albedo } => {
            slabs.push(FourSlab::ground(albedo)?);
            false
        }
        // Not reached: a conductor floor takes the two-flux model
        // (`solve::four_flux_applies`); absorbing is the safe reading.
        Substrate::Black | Substrate::Conductor { .. } => {
            slabs.push(FourSlab::ground(0.0)?);
            false
        }
    };
    Ok(Built { slabs, layer_slab: layer_slabs, open_bottom })
}

/// Solve one channel lit by a collimated beam by the four-flux model
/// (docs/two-flux.md §12): the contract's numbers with the beam's mirror
/// reflections as `reflectance_specular` and the beam leaving the bottom as
/// `transmittance_direct`; the diffuse parts are Lambertian-equivalent in
/// `brdf`/`btdf`.
pub(in crate::two_flux) fn solve_channel(
    mono: &MonoScene,
    mapping: KmMapping,
    cache: &mut HemisphericalCache,
) -> Result<ChannelResult, CoreError> {
    let b = build(mono, mapping, cache)?;
    let f = stack_four(&b.slabs, [1.0, 0.0]);
    let t = if b.open_bottom { f.t } else { [0.0; 2] };
    let absorptance: f64 = f.absorbed.iter().sum();
    let layers: Vec<f64> = b.layer_slab.iter().map(|&i| f.absorbed[i]).collect();
    let n_dirs = mono.directions_deg().len();
    // No angles for diffuse light: Lambertian-equivalent values of the diffuse parts.
    let (brdf, btdf) = if n_dirs == 0 {
        (Vec::new(), Vec::new())
    } else {
        (vec![f.r[1] / PI; n_dirs], vec![t[1] / PI; n_dirs])
    };
    Ok(ChannelResult {
        reflectance: f.r[0] + f.r[1],
        reflectance_specular: f.r[0],
        transmittance: t[0] + t[1],
        transmittance_direct: t[0],
        absorptance,
        brdf,
        btdf,
        absorptance_layers: Some(layers),
        ..ChannelResult::default()
    })
}
