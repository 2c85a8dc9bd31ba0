//! Rough faces and conductor floors as pieces of the engine's stacks
//! ([`super::OrderPieces`]): the dense operators of [`crate::rough`] on
//! `[nodes, beams, probes]` split into core and probe parts (eq. PA1), and
//! the markers of the single-scattering correction.
//!
//! # Markers at a rough face
//!
//! A marker carries the correction of a beam's single scattering along one
//! exit direction, and a face passes it on by a diagonal factor: the delta
//! path of that direction (a smooth face's Fresnel reflectance or
//! transmittance). A rough face has no delta path: what the correction's
//! peak sends through it leaves spread over the face's lobe, which no
//! diagonal factor describes. A rough face therefore passes no marker (zero
//! rows, zero diagonal), and the engine corrects only the layers above the
//! first rough face ([`super::corrected_layers`]), whose beam arrives
//! collimated: their markers reach the exit through smooth faces only, or
//! not at all (docs/rough.md §3).

use faer::Mat;
use km_core::microfacet::{Far, Microfacet};

use super::OrderPieces;
use crate::MultifluxError;
use crate::adding::LayerOperators;
use crate::adding::probed::{Augmented, ProbeRows};
use crate::rough::{RoughFace, rough_operators_order, smooth_conductor};

impl OrderPieces<'_> {
    /// The rough face from index `na` above to `nb` below.
    pub(super) fn rough_interface(
        &self,
        na: f64,
        nb: f64,
        mf: Microfacet,
    ) -> Result<Augmented, MultifluxError> {
        let (a, b) = (self.grid.shared(na), self.grid.shared(nb));
        let base = self.extras.base_len.min(self.count);
        let (ea, eb) = (self.extras.in_medium(na, base), self.extras.in_medium(nb, base));
        let face = RoughFace { mf, n_above: na, below: Far::Dielectric(nb) };
        let dense = rough_operators_order(face, &a, Some(&b), &ea, &eb, self.m, self.orders);
        let nbeam = self.extras.beams;
        let aug = Augmented::from_dense(&dense, a.mu.len() + nbeam, b.mu.len() + nbeam)?;
        Ok(self.dark_markers(aug))
    }

    /// A conductor floor `n + i k` under index `na`: smooth (its mirror
    /// reflectance on the diagonal, markers included) or rough.
    pub(super) fn conductor(
        &self,
        na: f64,
        n: f64,
        k: f64,
        rough: Option<Microfacet>,
    ) -> Result<Augmented, MultifluxError> {
        let a = self.grid.shared(na);
        let nbeam = self.extras.beams;
        let core_a = a.mu.len() + nbeam;
        let (dense, count) = match rough {
            None => {
                (smooth_conductor(&a, &self.extras.in_medium(na, self.count), n, k), self.count)
            }
            Some(mf) => {
                let base = self.extras.base_len.min(self.count);
                let ea = self.extras.in_medium(na, base);
                let face = RoughFace { mf, n_above: na, below: Far::Conductor(n, k) };
                (rough_operators_order(face, &a, None, &ea, &[], self.m, self.orders).r_top, base)
            }
        };
        let p = count - nbeam;
        let core = LayerOperators {
            r_top: Mat::from_fn(core_a, core_a, |i, j| dense[(i, j)]),
            t_down: Mat::zeros(0, core_a),
            r_bottom: Mat::zeros(0, 0),
            t_up: Mat::zeros(core_a, 0),
        };
        let mut probes = ProbeRows::zeros(p, core_a, 0);
        for e in 0..p {
            for j in 0..core_a {
                probes.r_top[(e, j)] = dense[(core_a + e, j)];
            }
            probes.diag[0][e] = dense[(core_a + e, core_a + e)];
        }
        Ok(self.dark_markers(Augmented { core, probes }))
    }

    /// `aug` with zero rows and diagonals for the markers it lacks (a rough
    /// face passes none, see the module's doc).
    fn dark_markers(&self, mut aug: Augmented) -> Augmented {
        let p = self.count - self.extras.beams;
        let pr = &mut aug.probes;
        if pr.len() >= p {
            return aug;
        }
        let grow = |m: &Mat<f64>| {
            Mat::from_fn(p, m.ncols(), |i, j| if i < m.nrows() { m[(i, j)] } else { 0.0 })
        };
        (pr.r_top, pr.t_down, pr.r_bottom, pr.t_up) =
            (grow(&pr.r_top), grow(&pr.t_down), grow(&pr.r_bottom), grow(&pr.t_up));
        for d in pr.diag.iter_mut() {
            d.resize(p, 0.0);
        }
        aug
    }
}
