//! Random streams: one xoshiro256++ generator per (run seed, channel, batch).
//!
//! Reproducible parallel Monte Carlo by fixed-size batches, each with its own
//! generator seeded from (run seed, batch index) (the scheme of rand's
//! `examples/rayon-monte-carlo.rs`): the result depends on the seed and the
//! batch size only, never on the number of threads or on which thread runs
//! which batch.

use std::convert::Infallible;

use rand::{Rng, TryRng};

/// SplitMix64 finaliser (Steele, Lea & Flood 2014): a bijective 64-bit mixer.
pub(crate) fn splitmix64(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// xoshiro256++ (Blackman & Vigna 2021, "Scrambled linear pseudorandom
/// number generators", ACM TOMS 47(4)): 256 bits of state, period
/// 2^256 - 1, no multiplication; passes BigCrush and PractRand. One step
/// is a handful of shifts, rotations and additions (docs/montecarlo.md §5,
/// eq. M6).
#[derive(Debug, Clone)]
pub(crate) struct McRng {
    s: [u64; 4],
}

impl TryRng for McRng {
    type Error = Infallible;

    #[inline]
    fn try_next_u32(&mut self) -> Result<u32, Infallible> {
        Ok((self.try_next_u64()? >> 32) as u32)
    }

    #[inline(always)]
    fn try_next_u64(&mut self) -> Result<u64, Infallible> {
        let s = &mut self.s;
        let out = s[0].wrapping_add(s[3]).rotate_left(23).wrapping_add(s[0]);
        let t = s[1] << 17;
        s[2] ^= s[0];
        s[3] ^= s[1];
        s[1] ^= s[2];
        s[0] ^= s[3];
        s[2] ^= t;
        s[3] = s[3].rotate_left(45);
        Ok(out)
    }

    fn try_fill_bytes(&mut self, dest: &mut [u8]) -> Result<(), Infallible> {
        for chunk in dest.chunks_mut(8) {
            let b = self.try_next_u64()?.to_le_bytes();
            chunk.copy_from_slice(&b[..chunk.len()]);
        }
        Ok(())
    }
}

impl McRng {
    /// A generator whose state is the first four outputs of SplitMix64
    /// started at `seed` (the seeding Blackman & Vigna recommend). The
    /// mixer is a bijection and its four inputs differ, so at most one word
    /// is zero: never the all-zero state.
    pub(crate) fn from_u64(seed: u64) -> McRng {
        let mut s = [0u64; 4];
        for (k, w) in s.iter_mut().enumerate() {
            *w = splitmix64(seed.wrapping_add((k as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15)));
        }
        McRng { s }
    }
}

/// The generator of batch `batch` of channel `channel` in a run of seed
/// `seed`: a xoshiro256++ seeded from a hash of the triple.
pub(crate) fn batch_rng(seed: u64, channel: u64, batch: u64) -> McRng {
    McRng::from_u64(splitmix64(splitmix64(splitmix64(seed) ^ channel) ^ batch))
}

/// A uniform variate in `[0, 1)` with 53 random bits.
#[inline]
pub(crate) fn uniform(rng: &mut McRng) -> f64 {
    (rng.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The reference outputs of xoshiro256++ from the state (1, 2, 3, 4):
    /// the first ten values of Blackman & Vigna's C code
    /// (xoshiro256plusplus.c), as the rand_xoshiro crate tests them; the
    /// first two also by hand: `rotl(1 + 4, 23) + 1 = 41943041`, and after
    /// one step `s = (7, 0, 262146, 6 * 2^45)`, `rotl(7 + 6 * 2^45, 23) + 7
    /// = 58720359`.
    #[test]
    fn xoshiro256pp_reproduces_the_reference_sequence() {
        let mut r = McRng { s: [1, 2, 3, 4] };
        let expected: [u64; 10] = [
            41943041,
            58720359,
            3588806011781223,
            3591011842654386,
            9228616714210784205,
            9973669472204895162,
            14011001112246962877,
            12406186145184390807,
            15849039046786891736,
            10450023813501588000,
        ];
        for e in expected {
            assert_eq!(r.next_u64(), e);
        }
    }

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
