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
//! The tracer's scattering uses a third way, [`AzimuthTable`] (eq. S2;
//! docs/montecarlo.md eq. M4'): a 256-entry table of `(cos, sin)` and short
//! Taylor series for the offset within a table cell, one draw and no
//! branch, the pair again `psi`'s to a few ulp. Rejection's loop exit (taken
//! with probability `pi/4`) was the least predictable branch of the photon
//! loop; without it `km mc` traces 4-7 % faster. The rejection sampler
//! stays for the launch and the Lambertian re-emission (no table at hand).
//!
//! # Reference
//! J. von Neumann, "Various techniques used in connection with random
//! digits", NBS Appl. Math. Series 12, 36–38 (1951); L. Devroye,
//! *Non-Uniform Random Variate Generation*, Springer (1986), §V.4.4.

use km_core::{CoreError, Scene};
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
    let mut bits = 0u64;
    for _ in 0..MAX_TRIES {
        bits = rng.next_u64();
        // Two signed 32-bit halves, shifted to the cell midpoints.
        let x = ((bits as u32 as i32) as f64 + 0.5) * HALF_SCALE;
        let y = (((bits >> 32) as u32 as i32) as f64 + 0.5) * HALF_SCALE;
        let r2 = x * x + y * y;
        if r2 <= 1.0 {
            let inv = 1.0 / r2;
            return ((x * x - y * y) * inv, (2.0 * x * y) * inv);
        }
    }
    let psi = 2.0 * std::f64::consts::PI * ((bits >> 11) as f64 * (1.0 / (1u64 << 53) as f64));
    let (s, c) = psi.sin_cos();
    (c, s)
}

/// Table entries of [`AzimuthTable`]: `2^8`, 4 KiB of `(cos, sin)` pairs.
const TABLE_BITS: u32 = 8;

/// `(cos psi, sin psi)` of a uniform azimuth without a branch (eq. S2): the
/// top [`TABLE_BITS`] bits `k` of one 64-bit draw pick the table angle
/// `psi_k = 2 pi k / 256`, the next 53 bits `f` the offset `b = (2 pi /
/// 256) f 2^-53` in `[0, 2 pi / 256)`, and
/// `cos psi = cos psi_k cos b - sin psi_k sin b`,
/// `sin psi = sin psi_k cos b + cos psi_k sin b`
/// with `sin b`, `cos b` from their Taylor series to `b^7` and `b^6`
/// (`b < 0.0246`: the first omitted terms are below `1e-20` and `4e-18`, so
/// the pair is `psi`'s to a few ulp, as [`azimuth`]'s). `psi = psi_k + b`
/// is uniform on `[0, 2 pi)` on a grid of `2^61` points. One draw and no
/// rejection: the rejection of [`azimuth`] discards `1 - pi/4` of its
/// draws, and its loop's exit is the tracer's least predictable branch.
#[derive(Debug, Clone)]
pub(crate) struct AzimuthTable {
    cs: Box<[[f64; 2]; 1 << TABLE_BITS]>,
}

impl AzimuthTable {
    pub fn new() -> AzimuthTable {
        let mut cs = Box::new([[0.0; 2]; 1 << TABLE_BITS]);
        for (k, e) in cs.iter_mut().enumerate() {
            let (s, c) =
                (2.0 * std::f64::consts::PI * k as f64 / (1 << TABLE_BITS) as f64).sin_cos();
            *e = [c, s];
        }
        AzimuthTable { cs }
    }

    /// The pair of eq. S2 from one draw of `rng`.
    #[inline]
    pub fn sample<R: Rng>(&self, rng: &mut R) -> (f64, f64) {
        self.of_bits(rng.next_u64())
    }

    /// Eq. S2 for the 64 bits `bits` (top 8: the table angle, next 53: the offset).
    #[inline]
    fn of_bits(&self, bits: u64) -> (f64, f64) {
        const STEP: f64 = 2.0 * std::f64::consts::PI / (1u64 << TABLE_BITS) as f64;
        let [ck, sk] = self.cs[(bits >> (64 - TABLE_BITS)) as usize];
        let b = ((bits << TABLE_BITS) >> 11) as f64 * (STEP / (1u64 << 53) as f64);
        // Horner's form with the reciprocal factorials as constants (a
        // division by a constant is not turned into a product by the
        // compiler: five divisions per azimuth otherwise).
        const S3: f64 = 1.0 / 6.0;
        const S5: f64 = 1.0 / 120.0;
        const S7: f64 = 1.0 / 5040.0;
        const C4: f64 = 1.0 / 24.0;
        const C6: f64 = 1.0 / 720.0;
        let b2 = b * b;
        let sb = b * (1.0 - b2 * (S3 - b2 * (S5 - b2 * S7)));
        let cb = 1.0 - b2 * (0.5 - b2 * (C4 - b2 * C6));
        (ck * cb - sk * sb, sk * cb + ck * sb)
    }
}

/// Every scattering layer's phase function must be a probability density to
/// be sampled (`PhaseFunction::sample_cos`: closed-form inversions, or the
/// inverse cumulative table of km-core eq. P18 for a Legendre series and Mie
/// particles, built here on first use): a truncated Legendre series that
/// rings negative is refused, naming the layer, before any photon is traced.
///
/// # Errors
/// A [`CoreError::Scene`] on `layer[i].phase` (1-based) for the first such layer.
pub(crate) fn check_phases(scene: &Scene) -> Result<(), CoreError> {
    for c in scene.channels() {
        for (i, l) in c.layers().iter().enumerate() {
            if l.sigma_s() > 0.0 {
                l.phase().check_density().map_err(|e| {
                    CoreError::scene(format!("layer[{}].phase", i + 1), None, e.to_string())
                })?;
            }
        }
    }
    Ok(())
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

    /// A sampler of `(cos psi, sin psi)`.
    type Sampler = Box<dyn Fn(&mut crate::rng::McRng) -> (f64, f64)>;

    /// The two samplers of a uniform azimuth: rejection (eq. S1) and the
    /// table (eq. S2); every statistical test runs on both.
    fn samplers() -> [Sampler; 2] {
        let t = AzimuthTable::new();
        [Box::new(azimuth), Box::new(move |r| t.sample(r))]
    }

    fn angles(seed: u64, f: &dyn Fn(&mut crate::rng::McRng) -> (f64, f64)) -> Vec<f64> {
        let mut rng = batch_rng(seed, 0, 0);
        (0..N)
            .map(|_| {
                let (c, s) = f(&mut rng);
                let a = s.atan2(c);
                if a < 0.0 { a + 2.0 * std::f64::consts::PI } else { a }
            })
            .collect()
    }

    #[test]
    fn the_pair_is_on_the_unit_circle() {
        for f in samplers() {
            let mut rng = batch_rng(11, 0, 0);
            for _ in 0..100_000 {
                let (c, s) = f(&mut rng);
                // Rounding of eq. S1 / S2: a few ulp.
                assert!((c * c + s * s - 1.0).abs() < 1e-15, "{c} {s}");
            }
        }
    }

    #[test]
    fn the_table_pair_is_the_cosine_and_sine_of_its_angle() {
        // Eq. S2 against libm's sin_cos of psi = 2 pi (k + f 2^-53) / 256
        // decoded from the same bits (psi itself rounded to ~4e-16): a few
        // ulp. Includes both ends of a cell and of the table.
        let t = AzimuthTable::new();
        let mut rng = batch_rng(12, 0, 0);
        let mut bits: Vec<u64> = (0..200_000).map(|_| rng.next_u64()).collect();
        bits.extend([0, u64::MAX, 1 << 56, (1 << 56) - 1, 0x80 << 56, (0x80 << 56) - 1]);
        for b in bits {
            let (c, s) = t.of_bits(b);
            let k = (b >> 56) as f64;
            let f = ((b << 8) >> 11) as f64 / (1u64 << 53) as f64;
            let (ws, wc) = (2.0 * std::f64::consts::PI * (k + f) / 256.0).sin_cos();
            assert!(
                (c - wc).abs() < 2e-15 && (s - ws).abs() < 2e-15,
                "{b:x}: {c} {s} vs {wc} {ws}"
            );
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
        for (f, seed) in samplers().iter().flat_map(|f| [1, 2, 3].map(|seed| (f, seed))) {
            let mut counts = [0usize; K];
            for a in angles(seed, f.as_ref()) {
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
        for sampler in samplers() {
            let mut a = angles(4, sampler.as_ref());
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
    }

    #[test]
    fn moments_of_cos_and_sin() {
        // Uniform psi: E cos = E sin = E cos sin = 0, E cos^2 = E sin^2 = 1/2,
        // E cos^4 = 3/8. Each sample mean has standard deviation
        // sqrt(Var / N) with Var <= 1/2; the bound is 5 of those.
        for f in samplers() {
            let mut rng = batch_rng(5, 0, 0);
            let mut m = [0.0f64; 5];
            for _ in 0..N {
                let (c, s) = f(&mut rng);
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
}
