//! Direction quadratures per medium that map onto each other under Snell's law.
//!
//! # Construction
//!
//! Snell's law keeps `s = n sin(theta)` across every interface. Sort the
//! distinct refractive indices of a stack, `n_(1) < n_(2) < ... < n_(K)`,
//! and cut the range of `s` into segments `[n_(k-1), n_(k)]` (`n_(0) = 0`).
//! Segment `k` is "born" in the media of index `n_(k)`: there it covers the
//! grazing cosines `0 < mu < mu_top = sqrt(1 - (n_(k-1)/n_(k))^2)`, and it
//! gets `N` Gauss–Legendre nodes on `[0, mu_top]` (double-Gauss style: no
//! node at `mu = 0`, Sykes 1951; Stamnes et al. 1988 §4). A medium of index
//! `n_(K_i)` carries the segments `1..=K_i`: the nodes of lower segments are
//! the refracted images of the nodes where they were born,
//!
//! ```text
//!   mu_i^2 = 1 - (n_d / n_i)^2 (1 - mu_d^2)                          (Q1)
//!   w_i = w_d mu_d n_d^2 / (mu_i n_i^2)   (n^2 mu dmu is invariant)     (Q2)
//! ```
//!
//! so a node of one medium is exactly a node of every other medium in which
//! it propagates (no interpolation at interfaces), and the directions that
//! are totally reflected at an interface are those of the segments the
//! other medium lacks. The node list of a medium is a *prefix* of the global
//! list: medium `i` has the first `N K_i` nodes.
//!
//! # References
//! - K. Stamnes, S.-C. Tsay, W. Wiscombe, K. Jayaweera, Appl. Opt. 27 (1988) 2502 (DISORT), §4.
//! - S. A. Prahl, "The adding-doubling method", in *Optical-Thermal Response of
//!   Laser-Irradiated Tissue* (1995) §5.3: quadrature split at the critical angle.

use std::cell::RefCell;
use std::rc::Rc;
use std::sync::Arc;

use km_core::quadrature::gauss_legendre;

/// Stream counts whose Gauss–Legendre rule a thread keeps (the oldest goes).
const RULES_KEPT: usize = 8;

/// A Gauss–Legendre rule: nodes and weights on `[-1, 1]`.
type Rule = Rc<(Vec<f64>, Vec<f64>)>;

thread_local! {
    /// Gauss–Legendre rules by point count, most recent last.
    static RULES: RefCell<Vec<(usize, Rule)>> =
        const { RefCell::new(Vec::new()) };
}

/// Grids a thread keeps (the oldest goes).
const GRIDS_KEPT: usize = 4;

/// Largest grid a thread keeps, in node cosines and weights over its media
/// (`2 N K (K + 1) / 2` for `K` indices: 512 KiB; 16 streams and 50 distinct
/// indices fit). A larger grid is built for its solve alone.
const GRID_KEPT_VALUES: usize = 65_536;

thread_local! {
    /// Grids built by [`AngularGrid::kept`], most recent last.
    static GRIDS: RefCell<Vec<Arc<AngularGrid>>> = const { RefCell::new(Vec::new()) };
}

/// The `n`-point Gauss–Legendre rule on `[-1, 1]` (nodes, weights), computed
/// once per thread and point count: the rule is a pure function of `n`, so
/// a repeated solve, channel or Fourier pass does not rebuild it (the
/// values are those of [`gauss_legendre`], bit for bit).
fn rule(n: usize) -> Rule {
    RULES.with(|cell| {
        let mut rules = cell.borrow_mut();
        if let Some((_, r)) = rules.iter().find(|(k, _)| *k == n) {
            return Rc::clone(r);
        }
        let r = Rc::new(gauss_legendre(n));
        if rules.len() >= RULES_KEPT {
            rules.remove(0);
        }
        rules.push((n, Rc::clone(&r)));
        r
    })
}

/// The global direction grid of a stack (see the module doc).
#[derive(Debug, Clone, PartialEq)]
pub struct AngularGrid {
    /// Distinct refractive indices, ascending.
    pub indices: Vec<f64>,
    /// Nodes per segment (streams per hemisphere in an index-matched stack).
    pub streams: usize,
    /// Cosine of each global node in the medium where its segment was born.
    mu_birth: Vec<f64>,
    /// Weight of each global node there.
    w_birth: Vec<f64>,
    /// Index of the medium where each node's segment was born.
    n_birth: Vec<f64>,
    /// The nodes of each medium of `indices` (eq. Q1, Q2), in that order.
    media: Vec<Arc<MediumNodes>>,
}

/// The nodes of one medium.
#[derive(Debug, Clone, PartialEq)]
pub struct MediumNodes {
    /// Refractive index of the medium.
    pub n: f64,
    /// Direction cosines `mu > 0` (one hemisphere).
    pub mu: Vec<f64>,
    /// Weights for `integral_0^1 f(mu) dmu` (eq. Q2).
    pub w: Vec<f64>,
}

impl AngularGrid {
    /// The grid for the media of indices `indices` (any order, repeats allowed)
    /// with `streams` nodes per segment.
    pub fn new(indices: &[f64], streams: usize) -> Self {
        Self::of_distinct(distinct(indices.iter().copied()), streams)
    }

    /// [`AngularGrid::new`] of the distinct indices `idx`, ascending.
    fn of_distinct(idx: Vec<f64>, streams: usize) -> Self {
        let gl = rule(streams);
        let (x, wx) = (&gl.0, &gl.1);
        let mut mu_birth = Vec::with_capacity(streams * idx.len());
        let mut w_birth = Vec::with_capacity(streams * idx.len());
        let mut n_birth = Vec::with_capacity(streams * idx.len());
        let mut prev = 0.0;
        for &nk in &idx {
            // Segment [prev, nk] in s, i.e. mu in (0, mu_top] in the medium of index nk.
            let r = prev / nk;
            let mu_top = (1.0 - r * r).sqrt();
            for (xi, wi) in x.iter().zip(wx) {
                mu_birth.push(0.5 * (xi + 1.0) * mu_top);
                w_birth.push(0.5 * wi * mu_top);
                n_birth.push(nk);
            }
            prev = nk;
        }
        let mut grid =
            AngularGrid { indices: idx, streams, mu_birth, w_birth, n_birth, media: Vec::new() };
        grid.media = grid.indices.iter().map(|&n| Arc::new(grid.nodes_of(n))).collect();
        grid
    }

    /// [`AngularGrid::new`] of the media `media` (any order, repeats
    /// allowed), kept per thread: a solve of the same media and streams as
    /// one of the last few on this thread (the repeats of a timing, the
    /// points of a sweep, the channels of a spectrum) shares that grid and
    /// its nodes instead of building them again. The grid is a pure
    /// function of the distinct indices and `streams`, so the values are
    /// those of a new one, bit for bit.
    pub(crate) fn kept(media: impl IntoIterator<Item = f64>, streams: usize) -> Arc<Self> {
        let idx = distinct(media);
        GRIDS.with(|cell| {
            let mut grids = cell.borrow_mut();
            if let Some(g) = grids.iter().rev().find(|g| g.streams == streams && g.indices == idx) {
                return Arc::clone(g);
            }
            let g = Arc::new(AngularGrid::of_distinct(idx, streams));
            let values: usize = g.media.iter().map(|m| 2 * m.mu.len()).sum();
            if values <= GRID_KEPT_VALUES {
                if grids.len() >= GRIDS_KEPT {
                    grids.remove(0);
                }
                grids.push(Arc::clone(&g));
            }
            g
        })
    }

    /// Number of nodes of a medium of index `n` (one hemisphere).
    pub fn count(&self, n: f64) -> usize {
        self.streams * self.indices.iter().filter(|&&x| x <= n).count()
    }

    /// The nodes of the medium of index `n` (eq. Q1, Q2).
    pub fn medium(&self, n: f64) -> MediumNodes {
        Arc::unwrap_or_clone(self.shared(n))
    }

    /// [`AngularGrid::medium`], shared: the nodes kept for a medium of
    /// the grid, computed for any other index.
    pub(crate) fn shared(&self, n: f64) -> Arc<MediumNodes> {
        match self.indices.iter().position(|&x| x == n) {
            Some(i) => Arc::clone(&self.media[i]),
            None => Arc::new(self.nodes_of(n)),
        }
    }

    /// The nodes of the medium of index `n` (eq. Q1, Q2), computed.
    fn nodes_of(&self, n: f64) -> MediumNodes {
        let count = self.count(n);
        let mut mu = Vec::with_capacity(count);
        let mut w = Vec::with_capacity(count);
        for g in 0..count {
            let (md, wd, nd) = (self.mu_birth[g], self.w_birth[g], self.n_birth[g]);
            if nd == n {
                mu.push(md);
                w.push(wd);
            } else {
                let r2 = (nd / n) * (nd / n);
                let mi = ((1.0 - r2) + r2 * md * md).sqrt();
                mu.push(mi);
                w.push(wd * md * nd * nd / (mi * n * n));
            }
        }
        MediumNodes { n, mu, w }
    }
}

/// The distinct values of `indices`, ascending.
fn distinct(indices: impl IntoIterator<Item = f64>) -> Vec<f64> {
    let mut idx: Vec<f64> = indices.into_iter().collect();
    idx.sort_by(f64::total_cmp);
    idx.dedup();
    idx
}

/// Cosine in a medium of index `n` of a direction of Snell invariant `s = n sin(theta)`,
/// `None` when it cannot propagate there (`s >= n`).
pub fn mu_of_invariant(s: f64, n: f64) -> Option<f64> {
    if s >= n {
        return None;
    }
    let r = s / n;
    Some(((1.0 - r) * (1.0 + r)).sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_kept_grid_is_the_new_one_shared_by_the_same_media_only() {
        let media = [1.0, 1.5, 1.33, 1.0];
        let g = AngularGrid::kept(media.iter().copied(), 7);
        // The same values as a grid built afresh, bit for bit, nodes included.
        assert_eq!(*g, AngularGrid::new(&media, 7));
        for n in [1.0, 1.33, 1.5] {
            assert_eq!(*g.shared(n), AngularGrid::new(&media, 7).medium(n));
        }
        // The same distinct indices in another order: the kept grid itself.
        let again = AngularGrid::kept([1.33, 1.5, 1.0], 7);
        assert!(Arc::ptr_eq(&g, &again));
        // Another stream count, another index or one index fewer: not it.
        for (m, s) in [(&[1.0, 1.5, 1.33][..], 8), (&[1.0, 1.5, 1.34], 7), (&[1.0, 1.5], 7)] {
            let other = AngularGrid::kept(m.iter().copied(), s);
            assert!(!Arc::ptr_eq(&g, &other), "{m:?}, {s}");
            assert_eq!(*other, AngularGrid::new(m, s));
        }
        // An index outside the grid gets its nodes computed (`count` of the
        // indices below it), not a kept medium's.
        assert_eq!(g.shared(1.4).mu.len(), 2 * 7);
        // A grid above the kept size (32 x 50 x 51 values) is built for its
        // caller alone.
        let many: Vec<f64> = (0..50).map(|i| 1.0 + 0.01 * f64::from(i)).collect();
        let big = AngularGrid::kept(many.iter().copied(), 32);
        assert!(!Arc::ptr_eq(&big, &AngularGrid::kept(many.iter().copied(), 32)));
        assert_eq!(*big, AngularGrid::new(&many, 32));
    }

    #[test]
    fn every_medium_integrates_mu_exactly_and_nodes_map_under_snell() {
        let g = AngularGrid::new(&[1.0, 1.5, 1.33, 1.0], 8);
        assert_eq!(g.indices, vec![1.0, 1.33, 1.5]);
        for n in [1.0, 1.33, 1.5] {
            let m = g.medium(n);
            // Full hemisphere of the medium: integral_0^1 2 mu dmu = 1. The
            // étendue weights make the sum exact in every medium (rounding only).
            let flux: f64 = m.mu.iter().zip(&m.w).map(|(u, w)| 2.0 * u * w).sum();
            assert!((flux - 1.0).abs() < 1e-13, "n = {n}: {flux}");
            assert!(m.mu.iter().all(|&u| u > 0.0 && u <= 1.0));
        }
        // A node of air and its image in glass share s = n sin(theta).
        let (a, b) = (g.medium(1.0), g.medium(1.5));
        for i in 0..a.mu.len() {
            let sa = (1.0 - a.mu[i] * a.mu[i]).sqrt();
            let sb = 1.5 * (1.0 - b.mu[i] * b.mu[i]).sqrt();
            assert!((sa - sb).abs() < 1e-13);
        }
    }
}
