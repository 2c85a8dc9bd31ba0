//! Sampling of a uniform azimuth without trigonometric functions.
//!
//! The scattering azimuth `psi` is uniform on `[0, 2 pi)`; the tracer needs
//! only `cos psi` and `sin psi` (MCML eq. 3.24). Calling libm's `sin`/`cos`
//! for them took about a quarter of the tracing time. Von Neumann's rejection
//! method (von Neumann 1951; Devroye 1986, §V.4.4) gives the pair exactly,
//! with a product, a division and no square root:
//!
//! 1. Draw a point `(x, y)` uniform in the square `(-1, 1)^2`; keep it if
//!    `r^2 = x^2 + y^2 <= 1` (probability `pi / 4`), otherwise draw again.
//!    The kept point is uniform in the unit disc, so its polar angle `theta`
//!    is uniform on `[0, 2 pi)`.
//! 2. Return the doubled angle (eq. S1):
//!    `cos psi = (x^2 - y^2) / r^2`, `sin psi = 2 x y / r^2`,  `psi = 2 theta`.
//!    Doubling maps a uniform angle mod `2 pi` to a uniform angle mod `2 pi`
//!    (each `psi` has the two pre-images `psi/2` and `psi/2 + pi`).
//!
//! Both coordinates come from one 64-bit draw (32 bits each, at the
//! midpoints `(i + 1/2) 2^-31`, `i = -2^31 .. 2^31 - 1`, a grid symmetric
//! under `x -> -x`, `y -> -y` and `x <-> y` that never holds the origin):
//! on average `4 / pi = 1.27` draws per azimuth instead of one draw and a
//! `sin_cos`. The angular resolution of the grid (~`2^-31` rad) is far below
//! any tally's. The pair is exact up to rounding (`cos^2 + sin^2 = 1` to a few
//! ulp), which a polynomial `sin_cos` matches only after range reduction and
//! degree ~13 polynomials; rejection was chosen as the simpler exact method.
//!
//! # Reference
//! J. von Neumann, "Various techniques used in connection with random
//! digits", NBS Appl. Math. Series 12, 36–38 (1951); L. Devroye,
//! *Non-Uniform Random Variate Generation*, Springer (1986), §V.4.4.

use rand::Rng;

/// Scale of one signed 32-bit half: `2^-31`.
const HALF_SCALE: f64 = 1.0 / 2_147_483_648.0;

/// Rejections after which [`azimuth`] stops drawing: the chance of reaching
/// it is `(1 - pi/4)^64 ~ 1e-43`, so it only bounds the loop.
const MAX_TRIES: usize = 64;

/// `(cos psi, sin psi)` of an azimuth `psi` uniform on `[0, 2 pi)`, by
/// rejection in the unit disc and angle doubling (eq. S1 of the module note).
///
/// Uses on average `4 / pi` draws of `rng`. After [`MAX_TRIES`] rejections
/// (probability ~1e-43) it falls back to `sin_cos` of the last draw's
/// uniform, which keeps the loop bounded and the result uniform.
#[inline]
pub(crate) fn azimuth<R: Rng>(rng: &mut R) -> (f64, f64) {
    let (c, s, r2) = azimuth_unscaled(rng);
    let inv = 1.0 / r2;
    (c * inv, s * inv)
}

/// The azimuth of [`azimuth`] before its division: `(r^2 cos psi,
/// r^2 sin psi, r^2)` with `r^2` in `(0, 1]` (eq. S1 without `/ r^2`), so
/// that a caller can fold the division into one of its own (the scattering
/// rotation, eq. M3').
#[inline]
pub(crate) fn azimuth_unscaled<R: Rng>(rng: &mut R) -> (f64, f64, f64) {
    let mut bits = 0u64;
    for _ in 0..MAX_TRIES {
        bits = rng.next_u64();
        // Two signed 32-bit halves, shifted to the cell midpoints.
        let x = ((bits as u32 as i32) as f64 + 0.5) * HALF_SCALE;
        let y = (((bits >> 32) as u32 as i32) as f64 + 0.5) * HALF_SCALE;
        let r2 = x * x + y * y;
        if r2 <= 1.0 {
            return (x * x - y * y, 2.0 * x * y, r2);
        }
    }
    let psi = 2.0 * std::f64::consts::PI * ((bits >> 11) as f64 * (1.0 / (1u64 << 53) as f64));
    let (s, c) = psi.sin_cos();
    (c, s, 1.0)
}

#[cfg(test)]
mod tests {
    //! Statistical tests of [`azimuth`]: the pair lies on the unit circle,
    //! the angle is uniform (chi-square over 64 sectors and Kolmogorov–
    //! Smirnov), and the moments of cos and sin are those of a uniform angle.
    use super::*;
    use crate::rng::batch_rng;
    use statrs::distribution::{ChiSquared, ContinuousCDF};

    const N: usize = 400_000;

    fn angles(seed: u64) -> Vec<f64> {
        let mut rng = batch_rng(seed, 0, 0);
        (0..N)
            .map(|_| {
                let (c, s) = azimuth(&mut rng);
                let a = s.atan2(c);
                if a < 0.0 { a + 2.0 * std::f64::consts::PI } else { a }
            })
            .collect()
    }

    #[test]
    fn the_pair_is_on_the_unit_circle() {
        let mut rng = batch_rng(11, 0, 0);
        for _ in 0..100_000 {
            let (c, s) = azimuth(&mut rng);
            // Rounding of eq. S1: a few ulp.
            assert!((c * c + s * s - 1.0).abs() < 1e-15, "{c} {s}");
        }
    }

    #[test]
    fn chi_square_over_sectors() {
        // 64 equal sectors, N = 4e5 draws: the statistic follows chi^2(63).
        // The test rejects at p < 1e-4 (so a correct sampler fails about once
        // in 1e4 seeds; the seeds are fixed, so the test is deterministic).
        // A sampler without the doubling step, or one drawing from the
        // square without rejection, gives statistics in the thousands.
        const K: usize = 64;
        for seed in [1, 2, 3] {
            let mut counts = [0usize; K];
            for a in angles(seed) {
                let k = ((a / (2.0 * std::f64::consts::PI)) * K as f64) as usize;
                counts[k.min(K - 1)] += 1;
            }
            let e = N as f64 / K as f64;
            let stat: f64 = counts.iter().map(|&o| (o as f64 - e).powi(2) / e).sum();
            let p = 1.0 - ChiSquared::new((K - 1) as f64).unwrap().cdf(stat);
            assert!(p > 1e-4, "seed {seed}: chi^2 = {stat}, p = {p}");
        }
    }

    #[test]
    fn kolmogorov_smirnov() {
        // D_n sqrt(n) has the Kolmogorov distribution; P(> 1.95) ~ 1e-3.
        let mut a = angles(4);
        a.sort_by(f64::total_cmp);
        let n = a.len() as f64;
        let d = a
            .iter()
            .enumerate()
            .map(|(i, &x)| {
                let f = x / (2.0 * std::f64::consts::PI);
                (f - i as f64 / n).abs().max(((i + 1) as f64 / n - f).abs())
            })
            .fold(0.0, f64::max);
        assert!(d * n.sqrt() < 1.95, "KS D sqrt(n) = {}", d * n.sqrt());
    }

    #[test]
    fn moments_of_cos_and_sin() {
        // Uniform psi: E cos = E sin = E cos sin = 0, E cos^2 = E sin^2 = 1/2,
        // E cos^4 = 3/8. Each sample mean has standard deviation
        // sqrt(Var / N) with Var <= 1/2; the bound is 5 of those.
        let mut rng = batch_rng(5, 0, 0);
        let mut m = [0.0f64; 5];
        for _ in 0..N {
            let (c, s) = azimuth(&mut rng);
            m[0] += c;
            m[1] += s;
            m[2] += c * s;
            m[3] += c * c;
            m[4] += c.powi(4);
        }
        let want = [0.0, 0.0, 0.0, 0.5, 0.375];
        let tol = 5.0 * (0.5 / N as f64).sqrt();
        for (k, (&got, &w)) in m.iter().zip(&want).enumerate() {
            let got = got / N as f64;
            assert!((got - w).abs() < tol, "moment {k}: {got} vs {w} (tol {tol})");
        }
    }
}
