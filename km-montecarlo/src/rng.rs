//! Random streams: one PCG-64 generator per (run seed, channel, batch).
//!
//! Reproducible parallel Monte Carlo by fixed-size batches, each with its own
//! generator seeded from (run seed, batch index) (the scheme of rand's
//! `examples/rayon-monte-carlo.rs`): the result depends on the seed and the
//! batch size only, never on the number of threads or on which thread runs
//! which batch.

use rand::Rng;
use rand_pcg::Pcg64;

/// SplitMix64 finaliser (Steele, Lea & Flood 2014): a bijective 64-bit mixer.
pub(crate) fn splitmix64(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// The generator of batch `batch` of channel `channel` in a run of seed `seed`:
/// a PCG-64 (O'Neill 2014) whose 128-bit state is hashed from the triple and
/// whose stream (increment) is the batch index.
pub(crate) fn batch_rng(seed: u64, channel: u64, batch: u64) -> Pcg64 {
    let h0 = splitmix64(splitmix64(splitmix64(seed) ^ channel) ^ batch);
    let h1 = splitmix64(h0 ^ 0x5851_F42D_4C95_7F2D);
    let state = ((h0 as u128) << 64) | h1 as u128;
    let stream = ((channel as u128) << 64) | batch as u128;
    Pcg64::new(state, stream)
}

/// A uniform variate in `[0, 1)` with 53 random bits.
#[inline]
pub(crate) fn uniform(rng: &mut Pcg64) -> f64 {
    (rng.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn streams_differ_and_repeat() {
        let a: Vec<f64> = {
            let mut r = batch_rng(1, 0, 0);
            (0..4).map(|_| uniform(&mut r)).collect()
        };
        let b: Vec<f64> = {
            let mut r = batch_rng(1, 0, 0);
            (0..4).map(|_| uniform(&mut r)).collect()
        };
        let c: Vec<f64> = {
            let mut r = batch_rng(1, 0, 1);
            (0..4).map(|_| uniform(&mut r)).collect()
        };
        assert_eq!(a, b);
        assert_ne!(a, c);
        assert!(a.iter().all(|&u| (0.0..1.0).contains(&u)));
    }
}
