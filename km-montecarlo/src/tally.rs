//! Tallies: the layout of the per-batch sums, and the batch statistics that
//! turn them into means and standard errors.
//!
//! Every tally of a batch is a plain sum of photon weights, in photon order.
//! For a quantity with batch sums `S_b` over `n_b` photons (`N = sum n_b`,
//! `B` batches) the estimate and its standard error are the ratio estimator
//!
//! `x = sum_b S_b / N`,
//! `se^2 = B / (B - 1) * sum_b (S_b - x n_b)^2 / N^2`   (eq. T1)
//!
//! which for equal batches is the textbook `s^2 / B` of the batch means
//! (batch statistics: every tally, including BRDF bins, gets an error bar
//! from the same formula). With a single batch `se` is undefined (NaN, null in JSON).

use crate::grid::{GridDims, GridOffsets};

/// Indices of the tallies of one channel in a batch's vector of sums.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Layout {
    /// Number of layers.
    pub layers: usize,
    /// Number of output directions.
    pub dirs: usize,
    /// Number of azimuthal rings.
    pub rings: usize,
    /// Number of radial annuli.
    pub radial: usize,
    /// The grid's bin counts (all zero without a grid).
    pub grid: GridDims,
    /// Planes times directions of the radiance inside (0: none).
    pub inside: usize,
}

impl Layout {
    /// All reflected weight (specular included).
    pub const R: usize = 0;
    /// Reflected weight that never scattered (delta part).
    pub const R_SPEC: usize = 1;
    /// All transmitted weight (direct included).
    pub const T: usize = 2;
    /// Transmitted weight that never scattered (delta part).
    pub const T_DIRECT: usize = 3;
    /// All absorbed weight (layers and substrate).
    pub const A: usize = 4;
    /// Weight absorbed by an opaque substrate.
    pub const A_SUB: usize = 5;
    /// Weight of photons stopped at `max_steps_per_photon`.
    pub const LOST: usize = 6;
    /// Scattered reflected weight escaping beyond the last annulus.
    pub const RD_OVERFLOW: usize = 7;
    const BASE: usize = 8;

    /// Absorbed weight of layer `i`.
    pub fn a_layer(&self, i: usize) -> usize {
        Self::BASE + i
    }
    /// Scattered reflected weight in the cone of output direction `k`.
    pub fn brdf(&self, k: usize) -> usize {
        Self::BASE + self.layers + k
    }
    /// Scattered transmitted weight in the cone of output direction `k`.
    pub fn btdf(&self, k: usize) -> usize {
        Self::BASE + self.layers + self.dirs + k
    }
    /// Scattered reflected weight in ring `k`.
    pub fn ring_r(&self, k: usize) -> usize {
        Self::BASE + self.layers + 2 * self.dirs + k
    }
    /// Scattered transmitted weight in ring `k`.
    pub fn ring_t(&self, k: usize) -> usize {
        Self::BASE + self.layers + 2 * self.dirs + self.rings + k
    }
    /// Scattered reflected weight in annulus `k`.
    pub fn radial(&self, k: usize) -> usize {
        Self::BASE + self.layers + 2 * self.dirs + 2 * self.rings + k
    }
    /// Offsets of the grid's sums (after the annuli).
    pub fn grid(&self) -> GridOffsets {
        GridOffsets::new(self.radial(self.radial), self.grid)
    }
    /// Weight over `|mu|` crossing plane `k / dirs` in the cone of direction
    /// `k % dirs` of the radiance inside (after the grid).
    pub fn inside(&self, k: usize) -> usize {
        Self::BASE
            + self.layers
            + 2 * self.dirs
            + 2 * self.rings
            + self.radial
            + self.grid.len()
            + k
    }
    /// Length of the vector of sums.
    pub fn len(&self) -> usize {
        self.inside(self.inside)
    }
}

/// Running batch statistics of one channel: the sums of eq. T1 accumulated
/// batch by batch in batch-index order (so the result is a deterministic
/// function of the batch sums).
#[derive(Debug, Clone)]
pub(crate) struct BatchStats {
    /// Photons so far.
    pub n: u64,
    /// Batches so far.
    pub batches: u64,
    /// Sum over batches of `S_b` per tally.
    pub sum: Vec<f64>,
    /// Per batch, the sums (kept for the second pass of eq. T1).
    per_batch: Vec<(u64, Vec<f64>)>,
}

impl BatchStats {
    pub fn new(len: usize) -> Self {
        BatchStats { n: 0, batches: 0, sum: vec![0.0; len], per_batch: Vec::new() }
    }

    /// Add one batch (call in batch-index order).
    pub fn push(&mut self, photons: u64, sums: &[f64]) {
        self.n += photons;
        self.batches += 1;
        for (a, b) in self.sum.iter_mut().zip(sums) {
            *a += *b;
        }
        self.per_batch.push((photons, sums.to_vec()));
    }

    /// Mean per photon of tally `j` (eq. T1).
    pub fn mean(&self, j: usize) -> f64 {
        self.sum[j] / self.n as f64
    }

    /// Mean and standard error (eq. T1) of a quantity derived from each
    /// batch's sums, `f(sums, photons)`, linear in the sums (so that its
    /// batch values are the `S_b` of eq. T1).
    pub fn derived(&self, f: impl Fn(&[f64], f64) -> f64) -> (f64, f64) {
        let vals: Vec<(f64, f64)> =
            self.per_batch.iter().map(|(nb, s)| (*nb as f64, f(s, *nb as f64))).collect();
        let n = self.n as f64;
        let x = vals.iter().map(|v| v.1).sum::<f64>() / n;
        if self.batches < 2 {
            return (x, f64::NAN);
        }
        let ss: f64 = vals.iter().map(|(nb, v)| (v - x * nb).powi(2)).sum();
        let b = self.batches as f64;
        (x, (b / (b - 1.0) * ss).sqrt() / n)
    }

    /// Standard error of the mean of tally `j` (eq. T1); NaN with one batch.
    pub fn stderr(&self, j: usize) -> f64 {
        if self.batches < 2 {
            return f64::NAN;
        }
        let x = self.mean(j);
        let ss: f64 = self
            .per_batch
            .iter()
            .map(|(nb, s)| {
                let d = s[j] - x * *nb as f64;
                d * d
            })
            .sum();
        let b = self.batches as f64;
        (b / (b - 1.0) * ss).sqrt() / self.n as f64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn equal_batches_give_textbook_standard_error() {
        // Batch means 1, 2, 3, 4 of 10 photons each: s^2 = 5/3, se = sqrt(5/3 / 4).
        let mut s = BatchStats::new(1);
        for m in [1.0, 2.0, 3.0, 4.0] {
            s.push(10, &[10.0 * m]);
        }
        assert!((s.mean(0) - 2.5).abs() < 1e-15);
        assert!((s.stderr(0) - (5.0f64 / 3.0 / 4.0).sqrt()).abs() < 1e-15);
    }

    #[test]
    fn layout_is_contiguous() {
        let l = Layout {
            layers: 3,
            dirs: 2,
            rings: 4,
            radial: 5,
            grid: GridDims::default(),
            inside: 0,
        };
        assert_eq!(l.brdf(0), l.a_layer(2) + 1);
        assert_eq!(l.btdf(0), l.brdf(1) + 1);
        assert_eq!(l.ring_r(0), l.btdf(1) + 1);
        assert_eq!(l.ring_t(0), l.ring_r(3) + 1);
        assert_eq!(l.radial(0), l.ring_t(3) + 1);
        assert_eq!(l.len(), l.radial(4) + 1);
    }
}
