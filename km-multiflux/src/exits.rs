//! A channel's exit directions in the multi-flux solve: the extra
//! directions carried besides the quadrature nodes (the beam and one probe
//! per exit direction, shared where they coincide), the distinct azimuths
//! with their `cos m(phi - 180 deg)`, and the sum of the Fourier series over
//! them (docs/multiflux.md §5).

use km_core::MonoScene;

use crate::quadrature::mu_of_invariant;
use crate::slab::Extra;

/// Add Fourier order `m` of the exit radiances (`x[ix[k]]` for direction
/// `k`) to `vals`: `I^m cos m(phi - 180 deg)`, the cosine of direction `k`
/// being `cos_m[of[k]]` ([`Azimuths`]); returns the largest `|I^m|`.
pub(crate) fn add_order(
    vals: &mut [f64],
    x: &[f64],
    ix: &[usize],
    of: &[usize],
    cos_m: &[f64],
) -> f64 {
    let mut term = 0.0f64;
    for (k, val) in vals.iter_mut().enumerate() {
        let v = x[ix[k]];
        *val += v * cos_m[of[k]];
        term = term.max(v.abs());
    }
    term
}

/// The distinct azimuths of the exit directions (exit directions on a grid
/// share a few), so that `cos m(phi - 180 deg)` is computed once per azimuth
/// and order rather than once per direction.
pub(crate) struct Azimuths {
    /// The distinct azimuths (degrees), in order of first appearance.
    pub(crate) values: Vec<f64>,
    /// For each exit direction, its azimuth's index in `values`.
    pub(crate) of: Vec<usize>,
}

impl Azimuths {
    pub(crate) fn new(dirs: &[[f64; 2]]) -> Self {
        let mut values: Vec<f64> = Vec::new();
        let of = dirs
            .iter()
            .map(|d| match values.iter().position(|&p| p == d[1]) {
                Some(i) => i,
                None => {
                    values.push(d[1]);
                    values.len() - 1
                }
            })
            .collect();
        Azimuths { values, of }
    }

    /// `cos m(phi - 180 deg)` of every distinct azimuth into `out`.
    pub(crate) fn cos_order(&self, m: usize, out: &mut [f64]) {
        for (c, &phi) in out.iter_mut().zip(&self.values) {
            *c = (m as f64 * (phi - 180.0).to_radians()).cos();
        }
    }
}

/// The extra directions of a channel besides the nodes: the beam, then the
/// probes by Snell invariant `s`, as `(s, is_beam, phi)`; probes share an
/// extra when `s` (and, for the beam's single-scattering correction, `phi`)
/// agree.
pub(crate) struct ChannelExtras {
    pub(crate) ex_s: Vec<(f64, bool, f64)>,
    /// The beam's extra (`None` for diffuse light).
    pub(crate) beam: Option<usize>,
    /// The extra of each exit direction above (BRDF) and below (BTDF).
    pub(crate) brdf_ix: Vec<usize>,
    pub(crate) btdf_ix: Vec<usize>,
}

impl ChannelExtras {
    pub(crate) fn new(scene: &MonoScene, n_sub: Option<f64>, delta_m: bool) -> Self {
        let n0 = scene.ambient_n();
        let mut ex_s: Vec<(f64, bool, f64)> = Vec::new();
        let beam = scene.beam_invariant().map(|s| {
            ex_s.push((s, true, 0.0));
            0
        });
        let tms_on = delta_m && beam.is_some();
        let probe = |s: f64, phi: f64, ex_s: &mut Vec<(f64, bool, f64)>| -> usize {
            let phi = if tms_on { phi } else { 0.0 };
            if let Some(i) = ex_s.iter().position(|&(t, b, p)| !b && t == s && p == phi) {
                return i;
            }
            ex_s.push((s, false, phi));
            ex_s.len() - 1
        };
        let dirs = scene.directions_deg();
        // sin(theta) once per run of equal polar angles (a grid of exit
        // directions lists its azimuths per polar angle).
        let mut last = (f64::NAN, 0.0);
        let sines: Vec<f64> = dirs
            .iter()
            .map(|d| {
                if d[0] != last.0 {
                    last = (d[0], d[0].to_radians().sin());
                }
                last.1
            })
            .collect();
        let brdf_ix: Vec<usize> =
            dirs.iter().zip(&sines).map(|(d, s)| probe(n0 * s, d[1], &mut ex_s)).collect();
        let btdf_ix: Vec<usize> = match n_sub {
            Some(ns) => {
                dirs.iter().zip(&sines).map(|(d, s)| probe(ns * s, d[1], &mut ex_s)).collect()
            }
            None => Vec::new(),
        };
        ChannelExtras { ex_s, beam, brdf_ix, btdf_ix }
    }

    /// The extras as directions in the medium of index `n`.
    pub(crate) fn in_medium(&self, n: f64) -> Vec<Extra> {
        self.ex_s
            .iter()
            .map(|&(s, beam, phi_deg)| Extra { mu: mu_of_invariant(s, n), beam, phi_deg })
            .collect()
    }
}
