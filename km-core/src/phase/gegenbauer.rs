//! The Reynolds–McCormick (Gegenbauer kernel) phase function (Reynolds &
//! McCormick 1980; Yaroslavsky et al. 1999 in tissue optics):
//!
//! ```text
//! p(cos t) = K (1 + g^2 - 2 g cos t)^-(alpha + 1)                                     (P12)
//! K = g alpha (1 - g^2)^(2 alpha) / (pi [(1 + g)^(2 alpha) - (1 - g)^(2 alpha)])
//!   = g (1 + g)^(2 alpha) / (pi E),   E = expm1(2 alpha L) / alpha,  L = ln((1 + g)/(1 - g))
//! ```
//!
//! with `alpha > -1/2`, `0 < |g| < 1` (`E -> 2 L` as `alpha -> 0`; `alpha = 1/2`
//! is Henyey–Greenstein). `g` is a shape parameter, not the mean cosine. Its
//! cumulative distribution inverts in closed form (P13):
//! `cos t = -1 - (1 + g)^2 expm1(-Lambda) / (2 g)`,
//! `Lambda = ln1p(u expm1(2 alpha L)) / alpha` (`2 u L` at `alpha = 0`).
//! The Legendre moments obey (derived from `(1 + g^2 - 2 g mu) h_{a+1} = h_a`
//! and `h_a' = 2 g a h_{a+1}` with `(2l + 1) P_l = P_{l+1}' - P_{l-1}'`, `h_a =
//! (1 + g^2 - 2 g mu)^-a`)
//!
//! ```text
//! 2 g (l + 1 - alpha) chi_{l+1} = (2l + 1)(1 + g^2) chi_l - 2 g (l + alpha) chi_{l-1}   (P14)
//! ```
//!
//! whose wanted solution decays as `g^l` while the other grows as `g^-l`:
//! it is run downwards (Miller's algorithm) from far beyond the last
//! significant moment and normalised by `chi_0 = 1`.

use std::f64::consts::PI;

use crate::error::CoreError;

/// Most moments kept of a Reynolds–McCormick function (they decay as
/// `|g|^l`: 16384 reach 1e-16 for `|g| <= 0.9977`).
pub const MAX_RM_MOMENTS: usize = 16_384;

/// The Reynolds–McCormick phase function (eq. P12) with its moments.
#[derive(Clone, PartialEq)]
pub struct ReynoldsMcCormick {
    g: f64,
    alpha: f64,
    /// `ln((1 + g)/(1 - g))`.
    l: f64,
    /// The normalisation `K`.
    k: f64,
    /// `chi_0 = 1 .. chi_L`, up to the last above 1e-16 (or [`MAX_RM_MOMENTS`]).
    moments: Box<[f64]>,
}

impl std::fmt::Debug for ReynoldsMcCormick {
    /// The parameters and the number of moments held.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "ReynoldsMcCormick {{ g: {}, alpha: {}, moments: {} }}",
            self.g,
            self.alpha,
            self.moments.len()
        )
    }
}

impl ReynoldsMcCormick {
    /// The function of shape `g` (`0 < |g| < 1`) and `alpha > -1/2` (eq. P12).
    ///
    /// # Errors
    /// `g` outside `(-1, 1)` or zero (isotropic: give no phase), `alpha` not
    /// finite or `<= -1/2`, or above 50 (the function then is a spike that
    /// no method of this project resolves).
    ///
    /// ```
    /// use km_core::phase::ReynoldsMcCormick;
    /// // alpha = 1/2 is Henyey–Greenstein: chi_l = g^l.
    /// let p = ReynoldsMcCormick::new(0.6, 0.5).unwrap();
    /// assert!((p.mean_cosine() - 0.6).abs() < 1e-13);
    /// assert!(ReynoldsMcCormick::new(0.6, -0.7).is_err());
    /// ```
    pub fn new(g: f64, alpha: f64) -> Result<ReynoldsMcCormick, CoreError> {
        if !g.is_finite() || g.abs() >= 1.0 || g == 0.0 {
            return Err(CoreError::invalid("g", g, "must satisfy 0 < |g| < 1"));
        }
        if !alpha.is_finite() || alpha <= -0.5 || alpha > 50.0 {
            return Err(CoreError::invalid("alpha", alpha, "must lie in (-0.5, 50]"));
        }
        let l = ((1.0 + g) / (1.0 - g)).ln();
        let e = if alpha == 0.0 { 2.0 * l } else { (2.0 * alpha * l).exp_m1() / alpha };
        let k = g * (1.0 + g).powf(2.0 * alpha) / (PI * e);
        let moments = moments(g, alpha);
        Ok(ReynoldsMcCormick { g, alpha, l, k, moments })
    }

    /// The shape parameter `g`.
    pub fn g(&self) -> f64 {
        self.g
    }

    /// The exponent parameter `alpha`.
    pub fn alpha(&self) -> f64 {
        self.alpha
    }

    /// The mean cosine `chi_1`.
    pub fn mean_cosine(&self) -> f64 {
        self.moment(1)
    }

    /// The stored moments `chi_0 = 1 .. chi_L`.
    pub fn moments(&self) -> &[f64] {
        &self.moments
    }

    /// `p(cos t)` (eq. P12).
    pub(crate) fn eval(&self, c: f64) -> f64 {
        let base = 1.0 + self.g * self.g - 2.0 * self.g * c;
        self.k * (-(self.alpha + 1.0) * base.ln()).exp()
    }

    /// `chi_l` (0 beyond the stored moments).
    pub(crate) fn moment(&self, l: usize) -> f64 {
        self.moments.get(l).copied().unwrap_or(0.0)
    }

    /// The inverse cumulative distribution (eq. P13).
    pub(crate) fn sample(&self, u: f64) -> f64 {
        let (g, a) = (self.g, self.alpha);
        let lambda =
            if a == 0.0 { 2.0 * u * self.l } else { (u * (2.0 * a * self.l).exp_m1()).ln_1p() / a };
        (-1.0 - (1.0 + g) * (1.0 + g) * (-lambda).exp_m1() / (2.0 * g)).clamp(-1.0, 1.0)
    }
}

/// The moments of eq. P14 by Miller's backward recurrence, normalised to
/// `chi_0 = 1`: started at `n` with `(chi_{n+1}, chi_n) = (0, 1e-200)` and
/// rescaled against overflow; `n` doubled until the last moment above 1e-16
/// lies below `n / 2` (so the start's error, of order `g^(2 (n - l))`, is
/// far below rounding), at most [`MAX_RM_MOMENTS`] moments kept.
fn moments(g: f64, alpha: f64) -> Box<[f64]> {
    let mut n = 64usize;
    loop {
        let mut d = vec![0.0f64; n + 2];
        d[n] = 1e-200;
        for l in (1..=n).rev() {
            // chi_{l-1} = [(2l+1)(1+g^2) chi_l - 2g(l+1-alpha) chi_{l+1}] / (2g(l+alpha)).
            let lf = l as f64;
            d[l - 1] = ((2.0 * lf + 1.0) * (1.0 + g * g) * d[l]
                - 2.0 * g * (lf + 1.0 - alpha) * d[l + 1])
                / (2.0 * g * (lf + alpha));
            if d[l - 1].abs() > 1e200 {
                d[l - 1..].iter_mut().for_each(|x| *x *= 1e-200);
            }
        }
        let d0 = d[0];
        let last = d.iter().rposition(|x| (x / d0).abs() > 1e-16).unwrap_or(0);
        if last < n / 2 || n >= 4 * MAX_RM_MOMENTS {
            let keep = (last + 1).min(MAX_RM_MOMENTS);
            return d[..keep].iter().map(|x| x / d0).collect();
        }
        n *= 2;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::quadrature::gauss_legendre;

    /// Normalisation, mean cosine (closed form of Reynolds & McCormick 1980
    /// eq. 8: `<mu> = (2 g alpha Lr - (1 + g^2)) / (2 g (alpha - 1))`,
    /// `Lr = [(1+g)^(2a) + (1-g)^(2a)] / [(1+g)^(2a) - (1-g)^(2a)]`) and the
    /// moments of eq. P14 against Gauss quadrature of eq. P12 (4000 nodes:
    /// the integrands are smooth at these g; 1e-10).
    #[test]
    fn moments_match_quadrature() {
        let (x, w) = gauss_legendre(4000);
        for &(g, alpha) in &[(0.8, 1.2), (0.9, 0.3), (-0.5, 0.8), (0.7, 0.0), (0.95, -0.3)] {
            let p = ReynoldsMcCormick::new(g, alpha).unwrap();
            let q = |l: usize| -> f64 {
                x.iter()
                    .zip(&w)
                    .map(|(&xi, &wi)| {
                        let pl = crate::legendre::legendre_pair(l, xi).0;
                        2.0 * PI * wi * p.eval(xi) * pl
                    })
                    .sum()
            };
            assert!((q(0) - 1.0).abs() < 1e-10, "g {g} a {alpha}: norm {}", q(0));
            for l in [1usize, 2, 5, 20] {
                assert!(
                    (q(l) - p.moment(l)).abs() < 1e-10,
                    "g {g} a {alpha} l {l}: {} vs {}",
                    q(l),
                    p.moment(l)
                );
            }
            if alpha != 1.0 && alpha != 0.0 {
                let (a, b) = ((1.0 + g).powf(2.0 * alpha), (1.0 - g).powf(2.0 * alpha));
                let lr = (a + b) / (a - b);
                let mu = (2.0 * g * alpha * lr - (1.0 + g * g)) / (2.0 * g * (alpha - 1.0));
                assert!(
                    (mu - p.mean_cosine()).abs() < 1e-12,
                    "g {g} a {alpha}: {mu} vs {}",
                    p.mean_cosine()
                );
            }
        }
    }

    /// The inverse cumulative distribution round trip: the mass above the
    /// sampled cosine is `1 - u` (Gauss quadrature, 1e-10).
    #[test]
    fn sampling_inverts_the_cdf() {
        let (x, w) = gauss_legendre(400);
        for &(g, alpha) in &[(0.8, 1.2), (-0.5, 0.8), (0.7, 0.0)] {
            let p = ReynoldsMcCormick::new(g, alpha).unwrap();
            for k in 1..10 {
                let u = k as f64 / 10.0;
                let c = p.sample(u);
                let (h, m) = (0.5 * (1.0 - c), 0.5 * (1.0 + c));
                let upper: f64 =
                    x.iter().zip(&w).map(|(&xi, &wi)| 2.0 * PI * h * wi * p.eval(m + h * xi)).sum();
                assert!((upper - (1.0 - u)).abs() < 1e-10, "g {g} a {alpha} u {u}: {upper}");
            }
        }
    }
}
