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

#[cfg(test)]
mod tests {
    use super::*;

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
