//! Rough faces and conductor grounds in the two-flux model (docs/rough.md §6).
//!
//! Saunderson's correction takes a face's reflectances for the light that
//! meets it: the collimated beam at `mu0` (or diffuse light) from outside,
//! diffuse flux from inside. A rough face (Walter et al. 2007) replaces the
//! Fresnel values by the microfacet model's albedos (eq. R7, R8):
//!
//! ```text
//!   r_top = R(mu0) or R_h(n_above),  t_tb = T(mu0) or T_h(n_above),
//!   r_bottom = R_h(n_below),         t_bt = T_h(n_below)                       (R9)
//! ```
//!
//! and the single-scattering loss `1 - r - t` of each side is absorbed in the
//! face. A conductor ground reflects the diffuse flux reaching it with its
//! hemispherical reflectance under the last layer's index (smooth: eq. F4 with
//! the conductor Fresnel reflectance R5; rough: R8).

use crate::error::CoreError;
use crate::microfacet::{Far, Microfacet, conductor_reflectance};
use crate::scene::Light;

use super::stack::Slab;

/// The two-flux slab of a rough face between `n_above` and `n_below` (eq.
/// R9); `light` is the light met from above (`None`: diffuse flux, as every
/// face below the top one meets).
pub(super) fn rough_face(
    mf: &Microfacet,
    light: Option<Light>,
    n_above: f64,
    n_below: f64,
) -> Slab {
    let (r_top, t_tb) = match light.and_then(|l| l.mu0()) {
        Some(mu0) => mf.albedo(mu0, n_above, Far::Dielectric(n_below)),
        None => mf.hemispherical(n_above, Far::Dielectric(n_below)),
    };
    let (r_bottom, t_bt) = mf.hemispherical(n_below, Far::Dielectric(n_above));
    Slab {
        r_top,
        t_tb,
        r_bottom,
        t_bt,
        a_top: (1.0 - r_top - t_tb).max(0.0),
        a_bottom: (1.0 - r_bottom - t_bt).max(0.0),
    }
}

/// An opaque conductor ground of index `n + i k` under a layer of index
/// `n_above`, smooth (`mf = None`) or rough, for diffuse flux.
///
/// # Errors
/// None in practice (the albedo lies in `[0, 1]`); kept for [`Slab::ground`].
pub(super) fn conductor_ground(
    mf: Option<&Microfacet>,
    n_above: f64,
    n: f64,
    k: f64,
) -> Result<Slab, CoreError> {
    let albedo = match mf {
        Some(m) => m.hemispherical(n_above, Far::Conductor(n, k)).0,
        None => {
            // 2 integral_0^1 R(mu) mu dmu; the integrand is smooth (no critical angle).
            let (x, w) = crate::quadrature::gauss_legendre(48);
            x.iter()
                .zip(&w)
                .map(|(xi, wi)| {
                    let mu = 0.5 * (xi + 1.0);
                    wi * mu * conductor_reflectance(mu, n_above, n, k)
                })
                .sum::<f64>()
        }
    };
    Slab::ground(albedo.clamp(0.0, 1.0))
}
