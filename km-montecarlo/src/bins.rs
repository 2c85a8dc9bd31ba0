//! Angular bins: cones around the output directions and azimuthal rings.
//!
//! A BRDF (or BTDF) is `f = dR / (cos(theta) dw)` (docs/montecarlo.md). A Monte Carlo
//! tally can only estimate an average of `f` over a finite bin `B`.
//!
//! * Cone bins (the output directions): all exit directions within the
//!   half-angle `alpha` of the output direction `d`. Each photon of weight `w`
//!   leaving through the cone with `mu = cos(theta)` scores `w / mu`, and
//!
//!   `f_B = sum_B (w / mu) / (N * Omega_B)`,  `Omega_B = 2 pi (1 - cos alpha)`   (eq. B1)
//!
//!   is the solid-angle mean of `f` over the cone. A spherical cap's centroid
//!   lies on its axis, so the bias `f_B - f(d)` is of second order,
//!   `(alpha^2 / 8) Laplacian f` for small caps (the mean value over a disc).
//!   The cosine-weighted mean `sum w / (N integral_B mu dw)` would have a
//!   first-order bias near grazing directions, where `mu` changes by a factor
//!   of 15 across a 5 degree cone at 84 degrees (measured: -2.5 %).
//!   To keep the variance of `w / mu` finite the cone must stay clear of the
//!   horizon: `alpha_d = min(alpha, (90 deg - theta_d) / 2)` (eq. B2), so
//!   `mu >= sin((90 deg - theta_d) / 2)` in the bin. Likewise it stays on one
//!   side of the critical angle of refraction into a denser exit medium,
//!   where the BRDF/BTDF drops to zero (eq. B2', [`cone_half_angle_with_edge`]).
//! * Rings: `mu_lo <= cos(theta) < mu_hi`, all azimuths; each photon scores
//!   `w`, normalised by the projected solid angle `P = pi (mu_hi^2 - mu_lo^2)`
//!   (eq. B3): the flux per projected solid angle, as a discrete-ordinates
//!   solver's angular bin.

use std::f64::consts::PI;

/// Unit vector of an exit direction `[theta_deg, phi_deg]` in the frame of its
/// hemisphere (`z` along the outward normal of the exit side).
pub fn direction_vector(theta_deg: f64, phi_deg: f64) -> [f64; 3] {
    let (t, p) = (theta_deg.to_radians(), phi_deg.to_radians());
    [t.sin() * p.cos(), t.sin() * p.sin(), t.cos()]
}

/// Half-angle of the cone bin of a direction at polar angle `theta_d`
/// (radians) for a requested half-angle `alpha` (eq. B2), with no edge
/// other than the horizon.
///
/// ```
/// let a = km_montecarlo::bins::cone_half_angle(89f64.to_radians(), 5f64.to_radians());
/// assert!((a - 0.5f64.to_radians()).abs() < 1e-12);
/// ```
pub fn cone_half_angle(theta_d: f64, alpha: f64) -> f64 {
    cone_half_angle_with_edge(theta_d, alpha, PI / 2.0)
}

/// Half-angle of the cone bin when exit directions can only reach polar
/// angles below `theta_edge` (radians): the critical angle of refraction
/// into a denser medium, `asin(n_inside / n_outside)`, beyond which the
/// BRDF/BTDF is exactly zero. The cone stays on one side of the edge and
/// of the horizon (eq. B2'):
/// `alpha_d = min(alpha, (90 deg - theta_d) / 2, |theta_edge - theta_d| / 2)`,
/// but at least 0.05 degree (a direction on the edge itself).
///
/// ```
/// use km_montecarlo::bins::cone_half_angle_with_edge;
/// let edge = (1.2f64 / 1.5).asin(); // 53.13 degrees
/// let a = cone_half_angle_with_edge(50f64.to_radians(), 5f64.to_radians(), edge);
/// assert!((a - 0.5 * (edge - 50f64.to_radians())).abs() < 1e-12);
/// ```
pub fn cone_half_angle_with_edge(theta_d: f64, alpha: f64, theta_edge: f64) -> f64 {
    let mut a = alpha.min(0.5 * (PI / 2.0 - theta_d));
    if theta_edge < PI / 2.0 {
        a = a.min(0.5 * (theta_edge - theta_d).abs());
    }
    a.max(0.05f64.to_radians())
}

/// Solid angle of a cone of half-angle `alpha`, `2 pi (1 - cos alpha)` (eq. B1),
/// written as `4 pi sin^2(alpha / 2)` to keep its digits for small `alpha`.
pub fn cone_solid_angle(alpha: f64) -> f64 {
    4.0 * PI * (0.5 * alpha).sin().powi(2)
}

/// Half-angle in degrees of a cone of solid angle `omega` (the inverse of
/// [`cone_solid_angle`]: `alpha = 2 asin(sqrt(omega / (4 pi)))`).
///
/// ```
/// use km_montecarlo::bins::{cone_half_angle_deg, cone_solid_angle};
/// let a = cone_half_angle_deg(cone_solid_angle(5f64.to_radians()));
/// assert!((a - 5.0).abs() < 1e-12);
/// ```
pub fn cone_half_angle_deg(omega: f64) -> f64 {
    (2.0 * (omega / (4.0 * PI)).sqrt().asin()).to_degrees()
}

/// Projected solid angle `P = integral_B mu dw` of the cone of half-angle `alpha`
/// (radians) around a direction of polar angle `theta_d` (radians), counting
/// only the part above the horizon: eq. B2 when the cone lies inside the
/// hemisphere, otherwise a midpoint rule on a 400 x 800 grid of the cone
/// (relative error below 1e-5, checked against eq. B2 in the tests).
///
/// ```
/// let p = km_montecarlo::bins::cone_projected_solid_angle(0.0, 0.1);
/// assert!((p - std::f64::consts::PI * 0.1f64.sin().powi(2)).abs() < 1e-15);
/// ```
pub fn cone_projected_solid_angle(theta_d: f64, alpha: f64) -> f64 {
    if theta_d + alpha <= PI / 2.0 {
        return PI * alpha.sin().powi(2) * theta_d.cos();
    }
    cone_projected_numeric(theta_d, alpha)
}

/// Numerical `P` of eq. B1 for a cone: in cone coordinates (beta from the
/// axis, psi around it) a direction has `cos(theta) = cos(theta_d) cos(beta)
/// + sin(theta_d) sin(beta) cos(psi)` and `dw = sin(beta) dbeta dpsi`.
pub(crate) fn cone_projected_numeric(theta_d: f64, alpha: f64) -> f64 {
    let (nb, np) = (400, 800);
    let (db, dp) = (alpha / nb as f64, 2.0 * PI / np as f64);
    let (ct, st) = (theta_d.cos(), theta_d.sin());
    let mut sum = 0.0;
    for i in 0..nb {
        let b = (i as f64 + 0.5) * db;
        let (cb, sb) = (b.cos(), b.sin());
        let mut ring = 0.0;
        for j in 0..np {
            let psi = (j as f64 + 0.5) * dp;
            let mu = ct * cb + st * sb * psi.cos();
            if mu > 0.0 {
                ring += mu;
            }
        }
        sum += ring * sb;
    }
    sum * db * dp
}

/// Projected solid angle of the ring `mu_lo <= mu < mu_hi` (eq. B3).
pub fn ring_projected_solid_angle(mu_lo: f64, mu_hi: f64) -> f64 {
    PI * (mu_hi * mu_hi - mu_lo * mu_lo)
}

/// Ring edges in `mu` matching a discrete-ordinates ("double Gauss")
/// quadrature of `n` nodes per hemisphere: the Gauss–Legendre rule mapped
/// to `[0, 1]` (nodes `mu_i`, weights `w_i`, `sum w_i = 1`), each node owning
/// the cell `[e_i, e_i + w_i)` with `e_0 = 0` (eq. B4). The ring tallies
/// (eq. B3) on these cells are the Monte Carlo counterpart of the solver's
/// radiance at node `i` averaged over its cell, for a bin-by-bin comparison.
///
/// ```
/// let e = km_montecarlo::bins::gauss_ring_edges(8);
/// assert_eq!(e.len(), 9);
/// assert!((e[8] - 1.0).abs() < 1e-14);
/// ```
pub fn gauss_ring_edges(n: usize) -> Vec<f64> {
    let (x, w) = km_core::quadrature::gauss_legendre(n);
    // Ascending nodes on [-1, 1] mapped to [0, 1]: mu = (x + 1) / 2, weight w / 2.
    let mut pairs: Vec<(f64, f64)> =
        x.iter().zip(&w).map(|(x, w)| (0.5 * (x + 1.0), 0.5 * w)).collect();
    pairs.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut edges = Vec::with_capacity(n + 1);
    let mut e = 0.0;
    edges.push(e);
    for (_, w) in pairs {
        e += w;
        edges.push(e);
    }
    // The weights sum to 1 up to rounding; pin the last edge.
    if let Some(last) = edges.last_mut() {
        *last = 1.0;
    }
    edges
}

#[cfg(test)]
mod tests {
    #[test]
    fn gauss_cells_hold_their_nodes() {
        for n in [1, 2, 8, 32] {
            let e = gauss_ring_edges(n);
            let (x, _) = km_core::quadrature::gauss_legendre(n);
            let mut mu: Vec<f64> = x.iter().map(|x| 0.5 * (x + 1.0)).collect();
            mu.sort_by(f64::total_cmp);
            for (i, m) in mu.iter().enumerate() {
                assert!(e[i] < *m && *m < e[i + 1], "n={n} i={i}");
            }
            assert!(e.windows(2).all(|w| w[0] < w[1]));
        }
    }

    use super::*;

    #[test]
    fn numeric_cone_matches_ellipse_area() {
        // Inside the hemisphere eq. B2 is exact; the midpoint rule must agree
        // to its own discretisation error (O(1/400^2) ~ 1e-5 relative).
        for &(t, a) in &[(0.0, 0.1), (0.6, 0.2), (1.2, 0.3)] {
            let exact = PI * f64::sin(a).powi(2) * f64::cos(t);
            let num = cone_projected_numeric(t, a);
            assert!((num / exact - 1.0).abs() < 1e-5, "t={t} a={a} {num} {exact}");
        }
    }

    #[test]
    fn cone_crossing_horizon_is_smaller_than_ellipse_formula_says() {
        // At theta_d = 89 deg a 5 deg cone is half below the horizon: the
        // integrand mu > 0 only, so P is positive and below the full-cone value
        // of |mu|-weighted area pi sin^2(a) (an upper bound).
        let (t, a) = (89f64.to_radians(), 5f64.to_radians());
        let p = cone_projected_solid_angle(t, a);
        assert!(p > 0.0 && p < PI * a.sin().powi(2));
    }
}
