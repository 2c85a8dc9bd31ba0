//! The radiance field inside one layer at any depth (seed eq. 19 in the
//! scaled form S4).

use super::{SlabSolution, atten, phi};
use crate::MultifluxError;

impl SlabSolution {
    /// The radiance field inside the layer at optical depth `tau` (seed 000
    /// eq. 19, in the scaled form S4): down-going `I+` and up-going `I-` at
    /// the nodes, for down-going radiances `top_in` entering at the top,
    /// up-going `bottom_in` entering at the bottom, and optionally a beam
    /// `(mu_b, F)` of horizontal irradiance `F` entering at the top. Radiances
    /// are the Fourier component of order `m` of this solution.
    ///
    /// ```text
    ///   I~± = 1/2 v [s (e1+e2)/2 + y D/2] ± 1/2 z [s k (e1-e2)/2 + y (e1+e2)/2]
    ///   e1 = e^{-k tau}, e2 = e^{-k (tau0 - tau)}, D = (e1 - e2)/k (-> tau0 - 2 tau)
    /// ```
    ///
    /// plus the particular solution `Z± F e^{-tau/mu_b}` (eq. S6).
    ///
    /// # Errors
    /// [`MultifluxError::Shape`] if the inputs do not have one value per node,
    /// [`MultifluxError::Option`] if `tau` lies outside `[0, tau0]`.
    pub fn field(
        &self,
        tau: f64,
        top_in: &[f64],
        bottom_in: &[f64],
        beam: Option<(f64, f64)>,
    ) -> Result<(Vec<f64>, Vec<f64>), MultifluxError> {
        let n = self.n;
        if top_in.len() != n || bottom_in.len() != n {
            return Err(MultifluxError::Shape {
                what: "field",
                detail: format!("{n} nodes, inputs {} and {}", top_in.len(), bottom_in.len()),
            });
        }
        if !(0.0..=self.tau).contains(&tau) || tau.is_infinite() {
            return Err(MultifluxError::Option {
                name: "tau",
                value: tau,
                reason: "depth must lie in [0, tau0] and be finite",
            });
        }
        let modes = self.field_modes(top_in, bottom_in, beam);
        let (mut dn, mut up) = (vec![0.0; n], vec![0.0; n]);
        for j in 0..n {
            let (cv, cz) = self.mode_factors(&modes, j, tau);
            for i in 0..n {
                dn[i] += cv * self.v[(i, j)] + cz * self.z[(i, j)];
                up[i] += cv * self.v[(i, j)] - cz * self.z[(i, j)];
            }
        }
        for i in 0..n {
            dn[i] /= self.t[i];
            up[i] /= self.t[i];
        }
        if let Some((mu_b, f, zp, zm)) = &modes.beam {
            let e = (-tau / mu_b).exp() * f;
            for i in 0..n {
                dn[i] += zp[i] * e;
                up[i] += zm[i] * e;
            }
        }
        Ok((dn, up))
    }

    /// The mode coefficients `s`, `y` of eq. S4 for the inputs of
    /// [`SlabSolution::field`] (one value per node each, not checked here),
    /// and the beam's particular solution: computed once, the field at any
    /// depth then costs `O(N^2)` ([`SlabSolution::field`]) and its angular
    /// moments `O(N)` ([`SlabSolution::field_moments`]).
    pub fn field_modes(
        &self,
        top_in: &[f64],
        bottom_in: &[f64],
        beam: Option<(f64, f64)>,
    ) -> FieldModes {
        let n = self.n;
        // Boundary values of the homogeneous part (transformed coordinates).
        let (mut a, mut b) = (top_in.to_vec(), bottom_in.to_vec());
        let mut part = None;
        if let Some((mu_b, f)) = beam {
            let (zp, zm) = crate::workspace::with_workspace(|ws| self.particular(mu_b, ws));
            let eb = atten(self.tau, mu_b);
            for i in 0..n {
                a[i] -= f * zp[i];
                b[i] -= f * zm[i] * eb;
            }
            part = Some((mu_b, f, zp, zm));
        }
        let at: Vec<f64> = (0..n).map(|i| a[i] * self.t[i]).collect();
        let bt: Vec<f64> = (0..n).map(|i| b[i] * self.t[i]).collect();
        let half = self.tau.is_infinite();
        // s = Cp^-1 (a~ + b~), y = Cm^-1 (a~ - b~) (eq. S4).
        let mut s: Vec<f64> = (0..n).map(|i| at[i] + if half { 0.0 } else { bt[i] }).collect();
        self.lu_p.solve(&mut s);
        let mut y: Vec<f64> = (0..n).map(|i| at[i] - bt[i]).collect();
        match &self.lu_m {
            Some(lu) => lu.solve(&mut y),
            None => y.iter_mut().for_each(|x| *x = 0.0),
        }
        FieldModes { s, y, beam: part }
    }

    /// The factors `(cv_j, cz_j)` of mode `j` at optical depth `tau` in
    /// eq. 13: `I~± = sum_j cv_j v~_j ± cz_j z~_j`.
    fn mode_factors(&self, modes: &FieldModes, j: usize, tau: f64) -> (f64, f64) {
        let (k, s, y) = (self.k[j], modes.s[j], modes.y[j]);
        let e1 = (-k * tau).exp();
        if self.tau.is_infinite() {
            // Only top-anchored modes: c = s.
            return (0.5 * s * e1, 0.5 * s * k * e1);
        }
        let e2 = (-k * (self.tau - tau)).exp();
        let d = if k > 0.0 { (e1 - e2) / k } else { self.tau - 2.0 * tau };
        (
            0.5 * (0.5 * s * (e1 + e2) + 0.5 * y * d),
            0.5 * (0.5 * s * k * (e1 - e2) + 0.5 * y * (e1 + e2)),
        )
    }

    /// The angular moments of the field at optical depth `tau` (in `[0,
    /// tau0]`, not checked), `(sum_i w_i (I+_i + I-_i), sum_i w_i mu_i (I+_i
    /// - I-_i))`, diffuse part and beam's particular solution, in `O(N)` per
    /// depth with [`FieldWeights`] of these nodes.
    pub fn field_moments(&self, modes: &FieldModes, fw: &FieldWeights, tau: f64) -> (f64, f64) {
        let (mut sum, mut diff) = (0.0, 0.0);
        for j in 0..self.n {
            let (cv, cz) = self.mode_factors(modes, j, tau);
            sum += 2.0 * cv * fw.v[j];
            diff += 2.0 * cz * fw.z[j];
        }
        if let Some((mu_b, f, _, _)) = &modes.beam {
            let e = (-tau / mu_b).exp() * f;
            sum += e * fw.beam_sum;
            diff += e * fw.beam_diff;
        }
        (sum, diff)
    }

    /// [`SlabSolution::field_moments`] of `modes` at `tau` plus those of the
    /// mirrored field of `mirror` (lit from the bottom: its moments at
    /// `tau0 - tau`, the net flux with the sign turned), in one pass over
    /// the modes: the mirror's mode factors take the same two exponentials
    /// with their roles swapped (`e1 <-> e2`, `D -> -D`).
    pub fn field_moments_mirrored(
        &self,
        (modes, fw): (&FieldModes, &FieldWeights),
        (mirror, mw): (&FieldModes, &FieldWeights),
        tau: f64,
    ) -> (f64, f64) {
        if self.tau.is_infinite() {
            // No bottom to light a half-space from.
            return self.field_moments(modes, fw, tau);
        }
        let (mut sum, mut diff) = (0.0, 0.0);
        for j in 0..self.n {
            let k = self.k[j];
            let e1 = (-k * tau).exp();
            let e2 = (-k * (self.tau - tau)).exp();
            let d = if k > 0.0 { (e1 - e2) / k } else { self.tau - 2.0 * tau };
            let (ep, em) = (e1 + e2, e1 - e2);
            let (s, y) = (modes.s[j], modes.y[j]);
            let (sm, ym) = (mirror.s[j], mirror.y[j]);
            // 2 cv = (s ep + y D)/2 and 2 cz = (s k em + y ep)/2 (eq. 13);
            // the mirror's: D -> -D, em -> -em, its flux counted upwards.
            sum += 0.5 * ((s * ep + y * d) * fw.v[j] + (sm * ep - ym * d) * mw.v[j]);
            diff += 0.5 * ((s * k * em + y * ep) * fw.z[j] - (-sm * k * em + ym * ep) * mw.z[j]);
        }
        for (m, w, t, sign) in [(modes, fw, tau, 1.0), (mirror, mw, self.tau - tau, -1.0)] {
            if let Some((mu_b, f, _, _)) = &m.beam {
                let e = (-t / mu_b).exp() * f;
                sum += e * w.beam_sum;
                diff += sign * e * w.beam_diff;
            }
        }
        (sum, diff)
    }

    /// The weights of [`SlabSolution::field_moments`] for `modes`:
    /// `sum_i w_i v~_ij / t_i`, `sum_i w_i mu_i z~_ij / t_i` per mode and the
    /// moments of the beam's particular solution.
    pub fn field_weights(&self, modes: &FieldModes) -> FieldWeights {
        let n = self.n;
        let v =
            (0..n).map(|j| (0..n).map(|i| self.w[i] * self.v[(i, j)] / self.t[i]).sum()).collect();
        let z = (0..n)
            .map(|j| (0..n).map(|i| self.w[i] * self.mu[i] * self.z[(i, j)] / self.t[i]).sum())
            .collect();
        let (beam_sum, beam_diff) = modes.beam.as_ref().map_or((0.0, 0.0), |(_, _, zp, zm)| {
            (
                (0..n).map(|i| self.w[i] * (zp[i] + zm[i])).sum(),
                (0..n).map(|i| self.w[i] * self.mu[i] * (zp[i] - zm[i])).sum(),
            )
        });
        FieldWeights { v, z, beam_sum, beam_diff }
    }

    /// `integral_0^tau0 sum_i w_i (I+_i + I-_i) dtau` of the field of `modes`
    /// (eq. 13 integrated term by term: `int e1 = int e2 = (1 - e^{-k tau0})/k`,
    /// `int D = 0`, `int e^{-tau/mu_b} = mu_b (1 - e^{-tau0/mu_b})`); infinite
    /// for a conservative half-space.
    pub fn field_moment_integral(&self, modes: &FieldModes, fw: &FieldWeights) -> f64 {
        let mut total = 0.0;
        for j in 0..self.n {
            // int cv_j = 1/2 s_j phi(k_j, tau0) (the y term integrates to 0).
            total += modes.s[j] * phi(self.k[j], self.tau) * fw.v[j];
        }
        if let Some((mu_b, f, _, _)) = &modes.beam {
            total += f * phi(1.0 / mu_b, self.tau) * fw.beam_sum;
        }
        total
    }
}

/// The mode coefficients of a layer's field for given inputs
/// ([`SlabSolution::field_modes`]).
#[derive(Debug, Clone)]
pub struct FieldModes {
    s: Vec<f64>,
    y: Vec<f64>,
    /// The beam `(mu_b, F, Z+, Z-)`.
    beam: Option<(f64, f64, Vec<f64>, Vec<f64>)>,
}

/// Per-mode angular weights of [`SlabSolution::field_moments`].
#[derive(Debug, Clone)]
pub struct FieldWeights {
    v: Vec<f64>,
    z: Vec<f64>,
    beam_sum: f64,
    beam_diff: f64,
}
