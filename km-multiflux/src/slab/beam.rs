//! The collimated beam in one layer and order: its particular solution
//! (eq. S6) and its columns of `R` and `T` at the nodes and the probes.

use super::probe::Probes;
use super::{Extra, SlabSolution, Tms, atten, dot};
use crate::correction::{e2, phi};

impl SlabSolution {
    /// Particular solution for a beam of unit horizontal irradiance entering
    /// at the top at `mu_b` (eq. S6): `(Z+, Z-)` in radiances at the nodes.
    pub(super) fn particular(&self, mu_b: f64) -> (Vec<f64>, Vec<f64>) {
        let n = self.n;
        let lam_b = self.lam_at(mu_b);
        let (mut ev, mut od) = self.kernels(&lam_b);
        let cm = if self.m == 0 { 1.0 } else { 2.0 } / (2.0 * std::f64::consts::PI);
        if self.renorm_m0 {
            // Make the scattered beam integrate to omega exactly over the nodes.
            let s: f64 = (0..n).map(|j| ev[j] * self.w[j]).sum();
            if s > 0.0 {
                ev.iter_mut().for_each(|x| *x /= s);
                od.iter_mut().for_each(|x| *x /= s);
            }
        }
        // s+ + s- = omega c_m / mu_b * ev ; s+ - s- = omega c_m / mu_b * od.
        let f = self.omega * cm / mu_b;
        // sigma~± = T M^-1 (s+ ± s-) = sqrt(w/mu) (s+ ± s-).
        let sp: Vec<f64> = (0..n).map(|i| (self.w[i] / self.mu[i]).sqrt() * f * ev[i]).collect();
        let sm: Vec<f64> = (0..n).map(|i| (self.w[i] / self.mu[i]).sqrt() * f * od[i]).collect();
        // rhs = sigma+ / mu_b + H- sigma-.
        let rhs: Vec<f64> = (0..n)
            // H- is symmetric: row i is column i.
            .map(|i| sp[i] / mu_b + dot(self.hm.col_as_slice(i), &sm))
            .collect();
        // Delta = sum_j z_j (v_j . rhs) / (k_j^2 - mu_b^-2).
        let lb = 1.0 / (mu_b * mu_b);
        let mut delta = vec![0.0; n];
        for j in 0..n {
            let c: f64 = dot(self.v.col_as_slice(j), &rhs) / (self.k[j] * self.k[j] - lb);
            for i in 0..n {
                delta[i] += c * self.z[(i, j)];
            }
        }
        // Sigma = mu_b (H+ Delta - sigma-).
        let sigma: Vec<f64> =
            (0..n).map(|i| mu_b * (dot(self.hp.col_as_slice(i), &delta) - sm[i])).collect();
        let zp = (0..n).map(|i| 0.5 * (sigma[i] + delta[i]) / self.t[i]).collect();
        let zm = (0..n).map(|i| 0.5 * (sigma[i] - delta[i]) / self.t[i]).collect();
        (zp, zm)
    }

    /// The beam's columns of `R` and `T` (nodes and probes; eq. S6 and eq. 14 of docs/multiflux.md):
    /// particular solution, homogeneous part fixed by the boundary values
    /// `-Z+` at the top and `-Z- e^{-tau/mu_b}` at the bottom, and the source
    /// integral along each probe.
    pub(super) fn beam_columns(
        &self,
        mu_b: f64,
        extras: &[Extra],
        probes: &Probes,
        tms: Option<&Tms>,
    ) -> (Vec<f64>, Vec<f64>) {
        let n = self.n;
        let dim = n + extras.len();
        let (mut cr, mut ct) = (vec![0.0; dim], vec![0.0; dim]);
        let (zp, zm) = self.particular(mu_b);
        let eb_att = atten(self.tau, mu_b);
        // Homogeneous part: boundary values a = -Z+, b = -Z- e_b.
        let a: Vec<f64> = zp.iter().map(|x| -x).collect();
        let b: Vec<f64> = zm.iter().map(|x| -x * eb_att).collect();
        let (hs, hd, sp, sm) = self.homogeneous_out(&a, &b);
        for i in 0..n {
            cr[i] = zm[i] + hs[i];
            ct[i] = zp[i] * eb_att + hd[i];
        }
        // Beam -> probes: homogeneous rows plus the particular source integral,
        // once per distinct probe cosine (`per`); only the peak correction
        // depends on the azimuth.
        let lam_b = self.lam_at(mu_b);
        let cm = if self.m == 0 { 1.0 } else { 2.0 } / (2.0 * std::f64::consts::PI);
        let per: Vec<[f64; 4]> = probes
            .rows
            .iter()
            .map(|pr| {
                let (us, uy, lam_x, ev, od) = (&pr.us, &pr.uy, &pr.lam, &pr.ev, &pr.od);
                // Direct single scattering of the beam into ±mu_x.
                let (mut se, mut so) = (0.0, 0.0);
                for l in self.m..self.chi.len() {
                    let x = self.chi[l] * lam_x[l] * lam_b[l];
                    if (l + self.m).is_multiple_of(2) { se += x } else { so += x }
                }
                // p^m(sigma mu_x, mu_b) = 1/2 (se + sigma so).
                let direct_up = self.omega * cm * 0.5 * (se - so) / mu_b;
                let direct_dn = self.omega * cm * 0.5 * (se + so) / mu_b;
                // Scattering of Z± into ±mu_x: omega sum_j w_j [p(sx, mu_j) Z+_j + p(sx, -mu_j) Z-_j].
                let (mut up, mut dn) = (direct_up, direct_dn);
                for j in 0..n {
                    let f = self.omega * self.w[j] * 0.5;
                    // p(-x, mu_j) = (ev - od)/2 ; p(-x, -mu_j) = (ev + od)/2 ; signs flip for +x.
                    up += f * ((ev[j] - od[j]) * zp[j] + (ev[j] + od[j]) * zm[j]);
                    dn += f * ((ev[j] + od[j]) * zp[j] + (ev[j] - od[j]) * zm[j]);
                }
                let beta = 1.0 / pr.mu;
                let kb = 1.0 / mu_b;
                // R_xq a + T_xq b = us . Cp^-1 T (a + b) + uy . Cm^-1 T (a - b).
                [
                    up * beta * phi(kb + beta, self.tau),
                    dn * beta * e2(kb, beta, self.tau),
                    dot(us, &sp),
                    dot(uy, &sm),
                ]
            })
            .collect();
        for (ex_i, exx) in extras.iter().enumerate() {
            let (Some(p), Some(mu_x)) = (probes.of[ex_i], exx.mu) else { continue };
            let [mut out_up, mut out_dn, hp, hm] = per[p];
            if let (Some(t), 0) = (tms, self.m) {
                // Eq. 5 and 5a-5h of docs/multiflux.md: exact single scattering
                // (TMS) and the forward peak's second order (IMS), real space.
                let (du, dd) = t.radiance(mu_b, mu_x, exx.phi_deg, self.tau);
                out_up += du;
                out_dn += dd;
            }
            // T_xq a + R_xq b is the same with the sign of the second term
            // flipped (nothing leaves the bottom of a half-space).
            out_up += hp + hm;
            if !self.tau.is_infinite() {
                out_dn += hp - hm;
            }
            cr[n + ex_i] = out_up;
            ct[n + ex_i] = out_dn;
        }
        (cr, ct)
    }

    /// The column of the beam `extras[eb]` in the `r_top` and `t_down` of
    /// [`SlabSolution::operators`], computed without the node-to-node
    /// operators: all a layer alone under a collimated beam needs.
    pub fn beam_response(
        &self,
        extras: &[Extra],
        eb: usize,
        tms: Option<&Tms>,
    ) -> (Vec<f64>, Vec<f64>) {
        let n = self.n;
        let dim = n + extras.len();
        let (mut cr, mut ct) = (vec![0.0; dim], vec![0.0; dim]);
        let (true, Some(mu_b)) = (extras[eb].beam, extras[eb].mu) else {
            return (cr, ct);
        };
        let probes = self.probes(extras);
        let (r, t) = self.beam_response_rows(mu_b, extras, &probes, tms);
        for i in 0..dim {
            if i < n || probes.of[i - n].is_some() {
                cr[i] = r[i];
                ct[i] = t[i];
            }
        }
        // The unscattered beam itself.
        ct[n + eb] = atten(self.tau, mu_b);
        (cr, ct)
    }

    /// The beam's columns (nodes and probes) with the resonance guard.
    pub(super) fn beam_response_rows(
        &self,
        mu_b: f64,
        extras: &[Extra],
        probes: &Probes,
        tms: Option<&Tms>,
    ) -> (Vec<f64>, Vec<f64>) {
        // Eq. S6 is singular at k_j mu_b = 1 (the full response is not): at
        // an exact resonance (|k mu_b - 1| < 1e-9, a set of measure zero)
        // the response is the mean at mu_b (1 ± 1e-6) (error ~1e-12; one-sided
        // 1e-6 at mu_b = 1). Near it, the cancellation costs only
        // log10(1/|k mu_b - 1|) digits.
        let near = self.k.iter().any(|&k| (k * mu_b - 1.0).abs() < 1e-9);
        if !near {
            self.beam_columns(mu_b, extras, probes, tms)
        } else if mu_b * (1.0 + 1e-6) < 1.0 {
            let (a, b) = (
                self.beam_columns(mu_b * (1.0 - 1e-6), extras, probes, tms),
                self.beam_columns(mu_b * (1.0 + 1e-6), extras, probes, tms),
            );
            let avg = |x: &[f64], y: &[f64]| -> Vec<f64> {
                x.iter().zip(y).map(|(p, q)| 0.5 * (p + q)).collect()
            };
            (avg(&a.0, &b.0), avg(&a.1, &b.1))
        } else {
            self.beam_columns(mu_b * (1.0 - 1e-6), extras, probes, tms)
        }
    }
}
