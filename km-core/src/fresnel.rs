//! Smooth (specular) dielectric interfaces: Snell's law, the unpolarised
//! Fresnel reflectance, total internal reflection, and the hemispherical
//! averages used by two-flux and diffusion models.
//!
//! Conventions: light goes from a medium of index `n_i` into one of index
//! `n_t`; `cos_i` is the cosine of the angle of incidence (`0 < cos_i <= 1`).
//!
//! * Snell: `n_i sin t_i = n_t sin t_t`  (eq. F1)
//! * Fresnel, unpolarised (Born & Wolf §1.5.2):
//!   `r_s = (n_i cos_i - n_t cos_t) / (n_i cos_i + n_t cos_t)`,
//!   `r_p = (n_t cos_i - n_i cos_t) / (n_t cos_i + n_i cos_t)`,
//!   `R = (r_s^2 + r_p^2) / 2`  (eq. F2); `R = 1` beyond the critical angle.
//! * Radiance law: radiance crossing from `n_i` to `n_t` is multiplied by
//!   `(1 - R) (n_t / n_i)^2`  (eq. F3).
//! * Hemispherical (diffuse) reflectance for light incident from the `n_i` side
//!   with a Lambertian (cosine-weighted) distribution:
//!   `R_h = 2 integral_0^1 R(mu) mu dmu`  (eq. F4), computed by Gauss–Legendre
//!   quadrature ([`crate::quadrature`]) on sub-intervals split at the critical cosine.
//! * Egan & Hilgeman (1979) fit of the internal diffuse reflectance, as quoted
//!   by Jensen et al. 2001 eq. 5 (for `eta = n_inside / n_outside`):
//!   `F_dr = -1.440/eta^2 + 0.710/eta + 0.668 + 0.0636 eta`  (eq. F5).
//!   A fit, not an exact formula: compare with [`diffuse_reflectance`].

/// Cosine of the refracted angle by Snell's law (eq. F1), `None` under total
/// internal reflection.
///
/// ```
/// let c = km_core::fresnel::snell_cos_t(1.0, 1.0, 1.5).unwrap();
/// assert!((c - 1.0).abs() < 1e-15);
/// assert!(km_core::fresnel::snell_cos_t(0.1, 1.5, 1.0).is_none());
/// ```
pub fn snell_cos_t(cos_i: f64, n_i: f64, n_t: f64) -> Option<f64> {
    let cos_i = cos_i.abs().min(1.0);
    let eta = n_i / n_t;
    let sin2_t = eta * eta * (1.0 - cos_i * cos_i).max(0.0);
    if sin2_t >= 1.0 { None } else { Some((1.0 - sin2_t).sqrt()) }
}

/// Cosine of the critical angle from `n_i` into `n_t` (0 if there is none,
/// i.e. `n_i <= n_t`).
pub fn critical_cos(n_i: f64, n_t: f64) -> f64 {
    if n_i <= n_t {
        0.0
    } else {
        let s = n_t / n_i;
        (1.0 - s * s).sqrt()
    }
}

/// Unpolarised Fresnel reflectance (eq. F2) for incidence cosine `cos_i`
/// from index `n_i` into `n_t`; 1 under total internal reflection.
///
/// ```
/// // Normal incidence, air to glass: ((1.5 - 1) / (1.5 + 1))^2 = 0.04.
/// let r = km_core::fresnel::reflectance(1.0, 1.0, 1.5);
/// assert!((r - 0.04).abs() < 1e-15);
/// ```
pub fn reflectance(cos_i: f64, n_i: f64, n_t: f64) -> f64 {
    if n_i == n_t {
        return 0.0;
    }
    reflectance_across(cos_i, n_i, n_t)
}

/// [`reflectance`] for `n_i != n_t`, written without branches (total
/// internal reflection as a select: its lanes compute a NaN they then
/// drop), so that loops over many cosines vectorise; the same values bit
/// for bit.
#[inline(always)]
pub fn reflectance_across(cos_i: f64, n_i: f64, n_t: f64) -> f64 {
    let cos_i = cos_i.abs().min(1.0);
    // Snell's law (eq. F1) as in [`snell_cos_t`].
    let eta = n_i / n_t;
    let sin2_t = eta * eta * (1.0 - cos_i * cos_i).max(0.0);
    let cos_t = (1.0 - sin2_t).sqrt();
    let rs = (n_i * cos_i - n_t * cos_t) / (n_i * cos_i + n_t * cos_t);
    let rp = (n_t * cos_i - n_i * cos_t) / (n_t * cos_i + n_i * cos_t);
    let r = (0.5 * (rs * rs + rp * rp)).min(1.0);
    if sin2_t >= 1.0 { 1.0 } else { r }
}

/// The Gauss–Legendre rule and integral, kept here for compatibility: they
/// live in [`crate::quadrature`].
pub use crate::quadrature::{gauss_legendre, integrate_gl};

/// Nodes per sub-interval of [`diffuse_reflectance`] (the rule
/// [`integrate_gl`] keeps for the process).
const DIFFUSE_NODES: usize = crate::quadrature::CACHED_NODES;

/// Hemispherical (diffuse) reflectance `2 integral_0^1 R(mu) mu dmu` (eq. F4)
/// for Lambertian light incident from index `n_i` on an interface to `n_t`.
///
/// For `n_i > n_t` this is the internal diffuse reflectance `F_dr` of diffusion
/// theory with `eta = n_i / n_t` (it includes total internal reflection).
///
/// ```
/// use km_core::fresnel::diffuse_reflectance;
/// assert_eq!(diffuse_reflectance(1.0, 1.0), 0.0);
/// // From inside glass (n = 1.5) to air: about 0.596.
/// assert!((diffuse_reflectance(1.5, 1.0) - 0.596).abs() < 2e-3);
/// ```
pub fn diffuse_reflectance(n_i: f64, n_t: f64) -> f64 {
    if n_i == n_t {
        return 0.0;
    }
    let mu_c = critical_cos(n_i, n_t);
    // Below the critical cosine R = 1 exactly: integral of 2 mu dmu = mu_c^2.
    let tir = mu_c * mu_c;
    // Above it the integrand is smooth except near mu_c (square-root onset):
    // split the interval geometrically towards mu_c.
    let mut sum = tir;
    let mut a = mu_c;
    let span = 1.0 - mu_c;
    let cuts = [1e-6, 1e-4, 1e-3, 1e-2, 0.05, 0.2, 0.5, 1.0];
    for &c in &cuts {
        let b = mu_c + span * c;
        sum += integrate_gl(|mu| 2.0 * mu * reflectance(mu, n_i, n_t), a, b, DIFFUSE_NODES);
        a = b;
    }
    sum
}

/// Egan & Hilgeman (1979) polynomial fit of the internal diffuse Fresnel
/// reflectance `F_dr(eta)` (eq. F5), with `eta = n_inside / n_outside`.
/// A named empirical fit; [`diffuse_reflectance`] is the exact integral.
pub fn egan_hilgeman_fdr(eta: f64) -> f64 {
    -1.440 / (eta * eta) + 0.710 / eta + 0.668 + 0.0636 * eta
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reflectance_limits_and_reciprocity() {
        // Grazing incidence reflects everything.
        assert!((reflectance(1e-9, 1.0, 1.5) - 1.0).abs() < 1e-6);
        // Transmission is the same both ways for matching angles (Stokes relations).
        let cos_i = 0.7;
        let cos_t = snell_cos_t(cos_i, 1.0, 1.33).unwrap();
        let a = reflectance(cos_i, 1.0, 1.33);
        let b = reflectance(cos_t, 1.33, 1.0);
        assert!((a - b).abs() < 1e-14);
        // Brewster angle: r_p = 0, so R = r_s^2 / 2 there.
        let tb = (1.5f64).atan();
        let ci = tb.cos();
        let ct = snell_cos_t(ci, 1.0, 1.5).unwrap();
        let rs = (ci - 1.5 * ct) / (ci + 1.5 * ct);
        assert!((reflectance(ci, 1.0, 1.5) - 0.5 * rs * rs).abs() < 1e-14);
    }

    #[test]
    fn seed_fresnel_at_45_degrees_for_n_1_3() {
        // The seed 000 §4.4 uses "about 0.1" at 45 degrees: that is the inside value.
        let c45 = std::f64::consts::FRAC_1_SQRT_2;
        let outside = reflectance(c45, 1.0, 1.3);
        assert!((outside - 0.0243).abs() < 5e-4, "{outside}");
        // Inside at the refracted angle equals the outside value (Stokes), but at
        // 45 degrees inside it is larger:
        let inside = reflectance(c45, 1.3, 1.0);
        assert!((inside - 0.093).abs() < 2e-3, "{inside}");
    }

    #[test]
    fn diffuse_reflectance_energy_identity() {
        // Conservation across the interface for diffuse light (n^2 law):
        // n_i^2 (1 - R_h(i->t)) = n_t^2 (1 - R_h(t->i)).
        for &n in &[1.1, 1.33, 1.5, 2.5] {
            let out = diffuse_reflectance(1.0, n);
            let inn = diffuse_reflectance(n, 1.0);
            assert!(((1.0 - inn) * n * n - (1.0 - out)).abs() < 1e-10 * n * n, "n={n}");
        }
        // Egan–Hilgeman is a fit: within 1 % of the integral for 1 < eta < 1.5.
        for &n in &[1.2, 1.3, 1.4, 1.5] {
            let exact = diffuse_reflectance(n, 1.0);
            assert!((egan_hilgeman_fdr(n) - exact).abs() < 0.01, "n={n}");
        }
    }
}
