//! The measured stack with everything that does not change during a fit
//! computed once: the forward model of the search (`docs/inverse.md` §1, §4.5).
//!
//! A fit evaluates the same stack (air | slide | sample | slide | air) for
//! 20–40 values of `(a, b, g)`. Only the sample changes; its boundaries
//! (the air–slide–sample interfaces, and the slides, clear and so of no
//! thickness that matters) do not. The quadrature of km's multi-flux solver
//! maps each node of one medium onto the node of the next with the same Snell
//! invariant, so every boundary operator is **diagonal**: one scalar star
//! product per direction (`km_multiflux::interface`, eq. F1). [`StackModel`]
//! builds those scalars once per (sample, streams); each evaluation then costs
//! one eigen-solve of the sample (`km_multiflux::slab::slab_operators`, order
//! `m = 0`, delta-M scaled) and two adding steps against diagonal boundaries:
//!
//! ```text
//! X = I - R' P,  Y = X^-1 T,  R_SB = R + T' P Y                      (ST1)
//! (I - P R_SB) z = t_in a,    up = r_air a + t_out (R_SB z),  down = t_out (Y z)   (ST2)
//! ```
//!
//! with `R, T, R', T'` the sample's operators on `[nodes, beam]`, `P` the
//! diagonal reflectance of a boundary seen from inside the sample, `t_in`,
//! `t_out` its transmittances into and out of the sample and `a` the incident
//! radiance in air (the unit beam, or `1/pi` on every node for diffuse light).
//! These are the adding equations (seed 000 eq. 14; Redheffer 1962) with the
//! top and bottom boundaries, which are mirror images of each other, written
//! out. The result equals `km_multiflux::solve_mono` of the same scene to
//! rounding (test `stack_model_matches_solve_mono`), at a fraction of the cost.

use km_core::Layer;
use km_core::phase::PhaseFunction;
use km_multiflux::legendre::delta_m;
use km_multiflux::quadrature::{AngularGrid, mu_of_invariant};
use km_multiflux::slab::{Extra, SlabOrder, slab_operators};

use crate::InverseError;
use crate::forward::{Optical, Sample, Totals};
use crate::linalg;

/// Scalar operators of a boundary for one direction: `(r_top, t_down,
/// r_bottom, t_up)` (reflection from above, transmission downward,
/// reflection from below, transmission upward).
type Op = (f64, f64, f64, f64);

/// Star product of two scalar operators (the 1 x 1 case of the adding
/// equations, seed 000 eq. 14): facing total reflections with nothing
/// between them let nothing through.
fn star((r1, t1, r1p, t1p): Op, (r2, t2, r2p, t2p): Op) -> Op {
    let x = 1.0 - r1p * r2;
    if x == 0.0 {
        return (r1, 0.0, r2p, 0.0);
    }
    (r1 + t1p * r2 * t1 / x, t2 * t1 / x, r2p + t2 * r1p * t2p / x, t1p * t2p / x)
}

/// The smooth Fresnel interface from index `na` (above) to `nb` (below) for
/// the direction of Snell invariant `s` (`km_multiflux::interface` eq. F1):
/// radiances carry the `n^2` law, the collimated beam (an irradiance) does not;
/// a direction that exists on one side only is totally reflected there.
fn interface(s: f64, na: f64, nb: f64, radiance: bool) -> Op {
    match (mu_of_invariant(s, na), mu_of_invariant(s, nb)) {
        (Some(a), Some(b)) => {
            let ra = km_core::fresnel::reflectance(a, na, nb);
            let rb = km_core::fresnel::reflectance(b, nb, na);
            let f = if radiance { (nb / na) * (nb / na) } else { 1.0 };
            (ra, (1.0 - ra) * f, rb, (1.0 - rb) / f)
        }
        (Some(_), None) => (1.0, 0.0, 0.0, 0.0),
        (None, Some(_)) => (0.0, 0.0, 1.0, 0.0),
        (None, None) => (0.0, 0.0, 0.0, 0.0),
    }
}

/// The top boundary (air, slide, sample) for the direction of invariant `s`.
fn boundary_op(sample: &Sample, s: f64, radiance: bool) -> Op {
    match sample.n_slide {
        Some(ng) => {
            star(interface(s, 1.0, ng, radiance), interface(s, ng, sample.n_sample, radiance))
        }
        None => interface(s, 1.0, sample.n_sample, radiance),
    }
}

/// The forward model of one sample at one stream count, with the boundaries,
/// quadrature and beam direction computed once (module doc).
#[derive(Debug, Clone)]
pub struct StackModel {
    sample: Sample,
    streams: usize,
    /// Sample-medium node cosines and weights.
    mu: Vec<f64>,
    w: Vec<f64>,
    /// `2 pi w mu` of the air nodes (flux of a radiance vector).
    air_flux: Vec<f64>,
    /// The beam as an extra direction of the sample medium.
    beam: Extra,
    /// Per sample direction `[nodes, beam]`: reflectance of a boundary seen
    /// from inside the sample (`P` of ST1).
    p_in: Vec<f64>,
    /// Per sample direction: transmittance out of the sample into air.
    t_out: Vec<f64>,
    /// Per air direction `[nodes, beam]`: transmittance into the sample.
    t_in: Vec<f64>,
    /// Per air direction: reflectance of the top boundary from above.
    r_air: Vec<f64>,
    /// Snell invariant of the beam.
    s_beam: f64,
}

impl StackModel {
    /// The model of `sample` at `streams` Gauss nodes per hemisphere and
    /// index segment (as `km_multiflux::MultifluxOptions::streams`).
    ///
    /// # Errors
    /// [`InverseError::Invalid`] for `streams` outside `[1, 512]`.
    ///
    /// ```
    /// use km_inverse::forward::{Optical, Sample};
    /// use km_inverse::stack::StackModel;
    /// let m = StackModel::new(&Sample::new(1.0, 1.4, Some(1.5)).unwrap(), 8).unwrap();
    /// let t = m.totals(&Optical { albedo: 0.9, tau: 1.0, g: 0.0 }, false).unwrap();
    /// assert!(t.r_total > t.r_specular && t.t_total > t.t_unscattered);
    /// ```
    pub fn new(sample: &Sample, streams: usize) -> Result<Self, InverseError> {
        if !(1..=512).contains(&streams) {
            return Err(InverseError::invalid("streams", streams as f64, "must lie in [1, 512]"));
        }
        let n_s = sample.n_sample;
        let mut indices = vec![1.0, n_s];
        indices.extend(sample.n_slide);
        let grid = AngularGrid::new(&indices, streams);
        let (nodes, air) = (grid.medium(n_s), grid.medium(1.0));
        let s_beam = sample.theta_deg.to_radians().sin();
        let beam = Extra { mu: mu_of_invariant(s_beam, n_s), beam: true, phi_deg: 0.0 };
        // The boundary of each sample direction: nodes (radiances), then the beam.
        let mut ops: Vec<Op> = nodes
            .mu
            .iter()
            .map(|&m| boundary_op(sample, n_s * ((1.0 - m) * (1.0 + m)).max(0.0).sqrt(), true))
            .collect();
        ops.push(boundary_op(sample, s_beam, false));
        let n_air = air.mu.len();
        let air_flux: Vec<f64> =
            (0..n_air).map(|i| 2.0 * std::f64::consts::PI * air.w[i] * air.mu[i]).collect();
        // Air directions are the first n_air sample directions, then the beam.
        let n_nodes = nodes.mu.len();
        let air_ix = |i: usize| if i < n_air { i } else { n_nodes };
        Ok(StackModel {
            sample: *sample,
            streams,
            mu: nodes.mu,
            w: nodes.w,
            air_flux,
            beam,
            p_in: ops.iter().map(|o| o.2).collect(),
            t_out: ops.iter().map(|o| o.3).collect(),
            t_in: (0..=n_air).map(|i| ops[air_ix(i)].1).collect(),
            r_air: (0..=n_air).map(|i| ops[air_ix(i)].0).collect(),
            s_beam,
        })
    }

    /// Stream count of the model.
    pub fn streams(&self) -> usize {
        self.streams
    }

    /// The sample the model was built for.
    pub fn sample(&self) -> &Sample {
        &self.sample
    }

    /// The totals of the sample with properties `p` (the same numbers as
    /// [`crate::forward::totals`] to rounding): one eigen-solve and the
    /// adding of eq. ST1–ST2; with `diffuse` also `URU`, `UTU` from the same
    /// operators.
    ///
    /// # Reference
    /// Seed 000 eq. 14 and 17–21 (adding, the slab's eigen-solution);
    /// delta-M: Wiscombe 1977; the quantities are iad's `UR1`, `UT1`, `URU`,
    /// `UTU` (Prahl, iad manual).
    ///
    /// # Errors
    /// Properties outside their domain, or a solver failure.
    pub fn totals(&self, p: &Optical, diffuse: bool) -> Result<Totals, InverseError> {
        let layer = Layer::from_tau_albedo(p.tau, p.albedo, p.g, self.sample.n_sample)?;
        // Delta-M scaling, keeping 2N moments as the multi-flux solver does.
        let n_keep = 2 * self.streams;
        let chi: Vec<f64> = (0..=n_keep).map(|l| layer.phase().legendre_moment(l)).collect();
        let (omega, tau) = (layer.albedo(), layer.tau());
        let (chi_s, omega_s, factor) = delta_m(&chi, omega, n_keep);
        let order = SlabOrder { tau: tau * factor, omega: omega_s, chi: &chi_s, m: 0 };
        let ops = slab_operators(&self.mu, &self.w, &[self.beam], &order, None)?;
        let dim = self.mu.len() + 1;
        let flat = |m: &dyn Fn(usize, usize) -> f64| -> Vec<f64> {
            (0..dim * dim).map(|ix| m(ix / dim, ix % dim)).collect()
        };
        let r = flat(&|i, j| ops.r_top[(i, j)]);
        let t = flat(&|i, j| ops.t_down[(i, j)]);
        let rp = flat(&|i, j| ops.r_bottom[(i, j)]);
        let tp = flat(&|i, j| ops.t_up[(i, j)]);

        // ST1: the sample on the bottom boundary, X = I - R' P, Y = X^-1 T.
        let pd = &self.p_in;
        let mut x = flat(&|i, j| if i == j { 1.0 } else { 0.0 });
        for i in 0..dim {
            for j in 0..dim {
                x[i * dim + j] -= rp[i * dim + j] * pd[j];
            }
        }
        let y = linalg::solve_many(&x, &t, dim, dim).ok_or_else(singular)?;
        // R_SB = R + T' P Y.
        let mut r_sb = r;
        for i in 0..dim {
            for k in 0..dim {
                let f = tp[i * dim + k] * pd[k];
                if f != 0.0 {
                    for j in 0..dim {
                        r_sb[i * dim + j] += f * y[k * dim + j];
                    }
                }
            }
        }
        // ST2: the top boundary; Z = I - P R_SB, factored once for both inputs.
        let mut z = flat(&|i, j| if i == j { 1.0 } else { 0.0 });
        for i in 0..dim {
            for j in 0..dim {
                z[i * dim + j] -= pd[i] * r_sb[i * dim + j];
            }
        }
        let n_air = self.air_flux.len();
        let beam_in = {
            let mut a = vec![0.0; n_air + 1];
            a[n_air] = 1.0;
            a
        };
        let (r_total, t_total) = self.respond(&z, &r_sb, &y, &beam_in)?;
        let (r_specular, t_unscattered) = self.delta_parts(tau);
        let lossless = omega == 1.0 || tau == 0.0;
        let (r_total, t_total) = conserve(r_total, t_total, lossless);
        let mut out = Totals {
            r_total,
            r_specular,
            t_total,
            t_unscattered,
            r_diffuse: f64::NAN,
            t_diffuse: f64::NAN,
        };
        if diffuse {
            // Uniform radiance 1/pi (unit irradiance) on every air node.
            let mut a = vec![1.0 / std::f64::consts::PI; n_air + 1];
            a[n_air] = 0.0;
            let (rd, td) = self.respond(&z, &r_sb, &y, &a)?;
            (out.r_diffuse, out.t_diffuse) = conserve(rd, td, lossless);
        }
        Ok(out)
    }

    /// Reflected and transmitted flux for the incident air radiance `a`
    /// (`[air nodes, beam]`), eq. ST2.
    fn respond(
        &self,
        z: &[f64],
        r_sb: &[f64],
        y: &[f64],
        a: &[f64],
    ) -> Result<(f64, f64), InverseError> {
        let dim = self.mu.len() + 1;
        let n_air = self.air_flux.len();
        // Into the sample: air node i is sample direction i; the beam is last.
        let mut v = vec![0.0; dim];
        for (i, &ai) in a.iter().enumerate() {
            let k = if i < n_air { i } else { dim - 1 };
            v[k] = self.t_in[i] * ai;
        }
        let down = linalg::solve_many(z, &v, dim, 1).ok_or_else(singular)?;
        let mat_vec = |m: &[f64], x: &[f64]| -> Vec<f64> {
            (0..dim).map(|i| (0..dim).map(|j| m[i * dim + j] * x[j]).sum()).collect()
        };
        let (up, bottom) = (mat_vec(r_sb, &down), mat_vec(y, &down));
        // Out into air, then to fluxes: nodes weighted by 2 pi w mu, the beam as it is.
        let out = |inside: &[f64], k: usize| self.t_out[k] * inside[k];
        let mut r = self.r_air[n_air] * a[n_air] + out(&up, dim - 1);
        let mut t = out(&bottom, dim - 1);
        for (i, (&f, &ai)) in self.air_flux.iter().zip(a).enumerate() {
            r += f * (self.r_air[i] * ai + out(&up, i));
            t += f * out(&bottom, i);
        }
        Ok((r, t))
    }

    /// Specular reflectance and unscattered transmittance of the beam with
    /// the true (unscaled) optical thickness: boundary, Beer–Lambert
    /// attenuation along the beam's cosine, boundary (scalar adding).
    fn delta_parts(&self, tau: f64) -> (f64, f64) {
        let top = boundary_op(&self.sample, self.s_beam, false);
        let Some(mu_b) = self.beam.mu else {
            return (top.0, 0.0);
        };
        let att = (-tau / mu_b).exp();
        let bottom = (top.2, top.3, top.0, top.1);
        let (r, t, _, _) = star(star(top, (0.0, att, 0.0, att)), bottom);
        (r, t)
    }
}

fn singular() -> InverseError {
    InverseError::Forward("adding: the round-trip operator is singular".into())
}

/// Totals that obey the bounds exactly, as the multi-flux solver reports
/// them (`docs/multiflux.md` eq. 18a): in a lossless sample `R = 1 - T`;
/// otherwise both clamped to `[0, 1]` and divided by `R + T` should rounding
/// make it exceed 1.
fn conserve(r: f64, t: f64, lossless: bool) -> (f64, f64) {
    if lossless {
        let t = t.clamp(0.0, 1.0);
        return (1.0 - t, t);
    }
    let (rc, tc) = (r.clamp(0.0, 1.0), t.clamp(0.0, 1.0));
    let sum = rc + tc;
    if sum > 1.0 { (rc / sum, tc / sum) } else { (rc, tc) }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::forward::totals;

    /// The cached model against the general solver on the same scene: the
    /// same equations in another order, so they agree to rounding (1e-12,
    /// a few hundred ulps of the adding's round trips).
    #[test]
    fn stack_model_matches_solve_mono() {
        let samples = [
            Sample::new(1.0, 1.4, Some(1.5)).unwrap(),
            Sample::new(2.0, 1.4, None).unwrap(),
            Sample::new(1.0, 1.0, None).unwrap(),
            Sample::new(1.0, 1.5, Some(1.4)).unwrap(),
            Sample::new(1.0, 1.33, Some(1.5)).unwrap().with_incidence(8.0).unwrap(),
        ];
        for s in &samples {
            for streams in [4, 8, 16] {
                let model = StackModel::new(s, streams).unwrap();
                for (a, b, g) in
                    [(0.9, 1.0, 0.0), (0.99, 8.0, 0.5), (0.3, 0.1, 0.9), (1.0, 2.0, 0.0)]
                {
                    let p = Optical { albedo: a, tau: b, g };
                    let want = totals(s, &p, streams, true).unwrap();
                    let got = model.totals(&p, true).unwrap();
                    for (w, v, what) in [
                        (want.r_total, got.r_total, "UR1"),
                        (want.t_total, got.t_total, "UT1"),
                        (want.r_specular, got.r_specular, "R_u"),
                        (want.t_unscattered, got.t_unscattered, "T_u"),
                        (want.r_diffuse, got.r_diffuse, "URU"),
                        (want.t_diffuse, got.t_diffuse, "UTU"),
                    ] {
                        assert!(
                            (w - v).abs() < 1e-12,
                            "{what} {s:?} N={streams} {p:?}: solve_mono {w} cached {v}"
                        );
                    }
                }
            }
        }
    }
}
