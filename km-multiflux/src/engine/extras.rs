//! The extra directions of one channel besides the quadrature nodes: beams,
//! probes (exit polar angles) and markers (eq. B1–B2 of `docs/bsdf.md`), in
//! the order the augmented operators use: beams first (they belong to the
//! core, [`crate::adding::probed`]), then the BRDF probes, the BTDF probes,
//! and (order 0 only) the markers of the single-scattering correction.

use crate::correction::PeakCorrection;
use crate::quadrature::mu_of_invariant;
use crate::slab::Extra;
use crate::stack::Scaled;

/// Kinds of extra directions.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Kind {
    Beam,
    Probe,
    /// Marker of layer `l`: `slot` 0 for the path integral of the side the
    /// beam entered (`W_R`), 1 for the far side (`W_T`), 2 for the far side's
    /// second-order peak term (`W_I`, eq. B2).
    Marker {
        l: usize,
        slot: usize,
    },
}

/// The extra directions of one channel, each as `(Snell invariant, kind)`.
#[derive(Clone)]
pub(crate) struct Extras {
    pub(crate) ex: Vec<(f64, Kind)>,
    /// Number of beams (the first extras).
    pub(crate) beams: usize,
    /// First BRDF probe, first BTDF probe, end of beams and probes.
    pub(crate) r0: usize,
    pub(crate) t0: usize,
    pub(crate) base_len: usize,
    /// Per marker (in the order of `ex[base_len..]`): (probe extra, layer, slot).
    pub(crate) marker_of: Vec<(usize, usize, usize)>,
}

/// What one channel's extras need to know of its layers.
pub(crate) struct ExtraSetup<'a> {
    pub(crate) n0: f64,
    pub(crate) n_sub: Option<f64>,
    pub(crate) layers: &'a [Scaled],
    pub(crate) tms_layers: &'a [usize],
    pub(crate) corr: &'a [Option<PeakCorrection>],
    pub(crate) secondary: bool,
}

impl Extras {
    /// Beams of Snell invariants `beams`, probes at the exit polar angles
    /// `theta_o` (degrees; above, and below if light leaves there), and per
    /// probe and corrected layer the markers R and T (and I where the
    /// second-order term can matter, eq. B2).
    pub(crate) fn new(beams: &[f64], theta_o: &[f64], c: &ExtraSetup<'_>) -> Self {
        let ni = beams.len();
        let probes = theta_o.len() * (1 + usize::from(c.n_sub.is_some()));
        // At most three markers per probe and corrected layer, none without a beam.
        let markers = if ni > 0 { 3 * probes * c.tms_layers.len() } else { 0 };
        let mut ex: Vec<(f64, Kind)> = Vec::with_capacity(ni + probes + markers);
        ex.extend(beams.iter().map(|&s| (s, Kind::Beam)));
        let r0 = ex.len();
        // sin(theta) once per angle, shared by the probes above and below.
        let sines: Vec<f64> = theta_o.iter().map(|t| t.to_radians().sin()).collect();
        ex.extend(sines.iter().map(|s| (c.n0 * s, Kind::Probe)));
        let t0 = ex.len();
        if let Some(ns) = c.n_sub {
            ex.extend(sines.iter().map(|s| (ns * s, Kind::Probe)));
        }
        let base_len = ex.len();
        // Whether a layer's IMS term can matter: it scales as (omega f)^2 times
        // Legendre sums of at most ~1e3 (2N terms and the tails beyond them), so
        // below omega f = 1e-8 it is under ~1e-13 of a unit radiance and the
        // layer needs no IMS marker.
        let ims_on = |l: usize| {
            c.secondary && c.corr[l].as_ref().is_some_and(|k| c.layers[l].omega_true * k.f() > 1e-8)
        };
        // The IMS term lives only within the cone around the beam's polar angle
        // (in the layer): its marker is needed where some beam is that close
        // (a margin of 1e-6 rad; inside, the correction's own test decides).
        // The beams' polar angles in each corrected layer whose IMS term can
        // matter, once per layer.
        let cone = crate::correction::IMS_CONE_DEG.to_radians() + 1e-6;
        let beam_angles: Vec<Option<Vec<f64>>> = if markers == 0 {
            Vec::new()
        } else {
            c.tms_layers
                .iter()
                .map(|&l| {
                    let n = c.layers[l].n;
                    ims_on(l).then(|| {
                        beams.iter().filter_map(|&s| mu_of_invariant(s, n).map(f64::acos)).collect()
                    })
                })
                .collect()
        };
        // Markers: per probe, per corrected layer, R and T kinds (and I); none
        // without a beam (the correction is the beam's single scattering).
        let mut marker_of = Vec::with_capacity(markers);
        if ni > 0 {
            for p in r0..base_len {
                for (&l, angles) in c.tms_layers.iter().zip(&beam_angles) {
                    let in_cone = angles.as_ref().is_some_and(|a| {
                        mu_of_invariant(ex[p].0, c.layers[l].n).is_some_and(|mx| {
                            let x = mx.acos();
                            a.iter().any(|&b| (b - x).abs() <= cone)
                        })
                    });
                    for slot in 0..if in_cone { 3 } else { 2 } {
                        marker_of.push((p, l, slot));
                        ex.push((ex[p].0, Kind::Marker { l, slot }));
                    }
                }
            }
        }
        Extras { ex, beams: ni, r0, t0, base_len, marker_of }
    }

    /// The first `count` extras as [`Extra`]s in the medium of index `n`.
    pub(crate) fn in_medium(&self, n: f64, count: usize) -> Vec<Extra> {
        self.ex[..count]
            .iter()
            .map(|&(s, k)| Extra { mu: mu_of_invariant(s, n), beam: k == Kind::Beam, phi_deg: 0.0 })
            .collect()
    }
}
