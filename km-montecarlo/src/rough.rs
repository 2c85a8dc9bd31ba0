//! Photons at rough faces (docs/rough.md §4): a facet normal drawn from the
//! distribution of visible normals (Heitz 2018 for GGX; `D(h) cos` for
//! Beckmann, Walter et al. 2007 eq. 28), the facet's Fresnel reflectance
//! choosing reflection or refraction (dielectric) or weighting the photon
//! (conductor), and the masking of the exit direction as the photon's weight:
//!
//! ```text
//!   w' = w G1(o, h)                      (GGX, visible normals)             (R17)
//!   w' = w |i.h| G1(i, h) G1(o, h) / (cos_i cos_h)   (Beckmann, D cos)
//! ```
//!
//! so that the expected weight leaving in `dw_o` is `f |cos_o| dw_o` of the
//! model (eq. R3, R4). An exit direction on the wrong side of the face is
//! the model's single-scattering loss: the photon ends there.

use crate::rng::McRng;
use km_core::fresnel;
use km_core::microfacet::{Far, Microfacet, V3, conductor_reflectance};

use crate::rng::uniform;

/// What became of a photon at a rough face.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Outcome {
    /// Reflected into propagation direction `u` (world frame) with the weight factor.
    Reflected([f64; 3], f64),
    /// Refracted into propagation direction `u` with the weight factor.
    Refracted([f64; 3], f64),
    /// Lost (the exit direction lies on the wrong side of the face).
    Lost,
}

/// A photon travelling along `u` (world frame, `z` down, `u[2] != 0`) meets
/// a rough face from the medium of index `n_i`; `far` is what lies beyond.
/// For a conductor the returned weight factor includes the facet's Fresnel
/// reflectance (the rest is absorbed in the metal).
pub(crate) fn meet(mf: &Microfacet, u: [f64; 3], n_i: f64, far: Far, rng: &mut McRng) -> Outcome {
    // Local frame: z along the normal on the photon's side (z_local = sgn z_world).
    let sgn = if u[2] > 0.0 { -1.0 } else { 1.0 };
    let wi: V3 = [-u[0], -u[1], u[2].abs()];
    let (h, w0) = mf.sample_visible(wi, uniform(rng), uniform(rng));
    let ih = wi[0] * h[0] + wi[1] * h[1] + wi[2] * h[2];
    if w0 <= 0.0 || ih <= 0.0 {
        return Outcome::Lost;
    }
    let to_world = |o: V3| [o[0], o[1], sgn * o[2]];
    let (f, n_t) = match far {
        Far::Dielectric(n_t) => (fresnel::reflectance(ih, n_i, n_t), Some(n_t)),
        Far::Conductor(n, k) => (conductor_reflectance(ih, n_i, n, k), None),
    };
    let reflect = match n_t {
        Some(_) => uniform(rng) < f,
        None => true,
    };
    if reflect {
        let o = [2.0 * ih * h[0] - wi[0], 2.0 * ih * h[1] - wi[1], 2.0 * ih * h[2] - wi[2]];
        if o[2] <= 0.0 {
            return Outcome::Lost;
        }
        let oh = ih;
        let g = w0 * mf.g1(o[2], oh) * if n_t.is_none() { f } else { 1.0 };
        return Outcome::Reflected(to_world(o), g);
    }
    // Refraction through the facet (f < 1 here, so it has a solution).
    let eta = n_i / n_t.unwrap_or(n_i);
    let c2 = 1.0 - eta * eta * (1.0 - ih * ih);
    if c2 <= 0.0 {
        return Outcome::Lost;
    }
    let ct = c2.sqrt();
    let k = eta * ih - ct;
    let o = [-eta * wi[0] + k * h[0], -eta * wi[1] + k * h[1], -eta * wi[2] + k * h[2]];
    if o[2] >= 0.0 {
        return Outcome::Lost;
    }
    let oh = o[0] * h[0] + o[1] * h[1] + o[2] * h[2];
    Outcome::Refracted(to_world(o), w0 * mf.g1(o[2], oh))
}

#[cfg(test)]
mod tests {
    use super::*;
    use km_core::microfacet::Distribution;

    /// The photon's mean weight per exit side is the model's directional
    /// albedo (km_core's quadrature, eq. R7), within 4 standard errors.
    #[test]
    fn mean_weights_are_the_model_albedos() {
        let mut rng = McRng::from_u64(7);
        for (dist, alpha, n_i, n_t, theta) in [
            (Distribution::Ggx, 0.3, 1.0, 1.5, 50f64),
            (Distribution::Beckmann, 0.4, 1.5, 1.0, 30.0),
            (Distribution::Ggx, 0.1, 1.33, 1.0, 60.0),
        ] {
            let mf = Microfacet::new(alpha, dist).unwrap();
            let t = theta.to_radians();
            let u = [-t.sin(), 0.0, t.cos()];
            let n = 200_000;
            let (mut r, mut r2, mut tt, mut t2) = (0.0, 0.0, 0.0, 0.0);
            for _ in 0..n {
                match meet(&mf, u, n_i, Far::Dielectric(n_t), &mut rng) {
                    Outcome::Reflected(o, w) => {
                        assert!(o[2] < 0.0);
                        r += w;
                        r2 += w * w;
                    }
                    Outcome::Refracted(o, w) => {
                        assert!(o[2] > 0.0);
                        tt += w;
                        t2 += w * w;
                    }
                    Outcome::Lost => {}
                }
            }
            let nf = n as f64;
            let (rm, tm) = (r / nf, tt / nf);
            let (rs, ts) = (((r2 / nf - rm * rm) / nf).sqrt(), ((t2 / nf - tm * tm) / nf).sqrt());
            let (ra, ta) = mf.albedo(t.cos(), n_i, Far::Dielectric(n_t));
            assert!((rm - ra).abs() < 4.0 * rs + 1e-12, "{dist:?}: R {rm} +- {rs} vs {ra}");
            assert!((tm - ta).abs() < 4.0 * ts + 1e-12, "{dist:?}: T {tm} +- {ts} vs {ta}");
        }
    }
}
