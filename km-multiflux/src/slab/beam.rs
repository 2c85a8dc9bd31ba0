//! The collimated beam in one layer and order: its particular solution
//! (eq. S6) and its columns of `R` and `T` at the nodes and the probes.

use super::probe::{Probe, Probes};
use super::{Extra, SlabSolution, Tms, atten, dot};
use crate::workspace::Workspace;

impl SlabSolution {
    /// Particular solution for a beam of unit horizontal irradiance entering
    /// at the top at `mu_b` (eq. S6): `(Z+, Z-)` in radiances at the nodes
    /// (vectors of the workspace).
    pub(super) fn particular(&self, mu_b: f64, ws: &mut Workspace) -> (Vec<f64>, Vec<f64>) {
        let lam_b = self.lam_at(mu_b, ws);
        let z = self.particular_at(mu_b, &lam_b, ws);
        ws.give(lam_b);
        z
    }

    /// [`SlabSolution::particular`] with `lam_b`, the `Lambda_l^m(mu_b)` of
    /// [`SlabSolution::lam_at`], given.
    fn particular_at(&self, mu_b: f64, lam_b: &[f64], ws: &mut Workspace) -> (Vec<f64>, Vec<f64>) {
        let n = self.n;
        let (mut ev, mut od) = self.kernels(lam_b, ws);
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
        let (mut sp, mut sm) = (ws.take_for_overwrite(n), ws.take_for_overwrite(n));
        for i in 0..n {
            sp[i] = (self.w[i] / self.mu[i]).sqrt() * f * ev[i];
            sm[i] = (self.w[i] / self.mu[i]).sqrt() * f * od[i];
        }
        ws.give(ev);
        ws.give(od);
        // rhs = sigma+ / mu_b + H- sigma-.
        let mut rhs = ws.take_for_overwrite(n);
        for i in 0..n {
            // H- is symmetric: row i is column i.
            rhs[i] = sp[i] / mu_b + dot(self.hm.col_as_slice(i), &sm);
        }
        // Delta = sum_j z_j (v_j . rhs) / (k_j^2 - mu_b^-2).
        let lb = 1.0 / (mu_b * mu_b);
        let mut delta = ws.take(n);
        for j in 0..n {
            let c: f64 = dot(self.v.col_as_slice(j), &rhs) / (self.k[j] * self.k[j] - lb);
            for i in 0..n {
                delta[i] += c * self.z[(i, j)];
            }
        }
        // Sigma = mu_b (H+ Delta - sigma-).
        let (mut zp, mut zm) = (ws.take_for_overwrite(n), ws.take_for_overwrite(n));
        for i in 0..n {
            let sigma = mu_b * (dot(self.hp.col_as_slice(i), &delta) - sm[i]);
            zp[i] = 0.5 * (sigma + delta[i]) / self.t[i];
            zm[i] = 0.5 * (sigma - delta[i]) / self.t[i];
        }
        for v in [sp, sm, rhs, delta] {
            ws.give(v);
        }
        (zp, zm)
    }

    /// The beam's source function into the probe `pr` (`±mu_x`): its direct
    /// single scattering plus the scattering of the particular solution
    /// `z = [Z+, Z-]` at the nodes, `(up, down)` (`down` 0 unless asked), to
    /// be multiplied by the path integrals of eq. 14.
    fn beam_source_into(
        &self,
        pr: &Probe<'_>,
        mu_b: f64,
        lam_b: &[f64],
        [zp, zm]: [&[f64]; 2],
        down: bool,
    ) -> (f64, f64) {
        let cm = if self.m == 0 { 1.0 } else { 2.0 } / (2.0 * std::f64::consts::PI);
        let (lam_x, ev, od) = (pr.lam, pr.ev, pr.od);
        // Direct single scattering of the beam into ±mu_x.
        // The l + m even terms into se, the odd into so (each in order of l).
        let (m, nl) = (self.m, self.chi.len());
        let (mut se, mut so) = (0.0, 0.0);
        for l in (m..nl).step_by(2) {
            se += self.chi[l] * lam_x[l] * lam_b[l];
        }
        for l in (m + 1..nl).step_by(2) {
            so += self.chi[l] * lam_x[l] * lam_b[l];
        }
        // p^m(sigma mu_x, mu_b) = 1/2 (se + sigma so).
        let direct_up = self.omega * cm * 0.5 * (se - so) / mu_b;
        let direct_dn = self.omega * cm * 0.5 * (se + so) / mu_b;
        // Scattering of Z± into ±mu_x: omega sum_j w_j [p(sx, mu_j) Z+_j + p(sx, -mu_j) Z-_j].
        let (mut up, mut dn) = (direct_up, direct_dn);
        for j in 0..self.n {
            let f = self.omega * self.w[j] * 0.5;
            // p(-x, mu_j) = (ev - od)/2 ; p(-x, -mu_j) = (ev + od)/2 ; signs flip for +x.
            up += f * ((ev[j] - od[j]) * zp[j] + (ev[j] + od[j]) * zm[j]);
        }
        if down {
            for j in 0..self.n {
                let f = self.omega * self.w[j] * 0.5;
                dn += f * ((ev[j] + od[j]) * zp[j] + (ev[j] - od[j]) * zm[j]);
            }
        }
        (up, dn)
    }

    /// The beam's columns of `R` and `T` (nodes and probes; eq. S6 and eq. 14 of docs/multiflux.md):
    /// particular solution, homogeneous part fixed by the boundary values
    /// `-Z+` at the top and `-Z- e^{-tau/mu_b}` at the bottom, and the source
    /// integral along each probe (vectors of the workspace). Without `down`
    /// the probes' transmitted values (the column of `T`) are left at zero
    /// and not computed (a layer with nothing below it to receive them).
    pub(super) fn beam_columns(
        &self,
        mu_b: f64,
        extras: &[Extra],
        probes: &Probes,
        tms: Option<&Tms>,
        down: bool,
        ws: &mut Workspace,
    ) -> (Vec<f64>, Vec<f64>) {
        let n = self.n;
        let dim = n + extras.len();
        let (mut cr, mut ct) = (ws.take(dim), ws.take(dim));
        let lam_b = self.lam_at(mu_b, ws);
        let (zp, zm) = self.particular_at(mu_b, &lam_b, ws);
        let eb_att = atten(self.tau, mu_b);
        // Homogeneous part: boundary values a = -Z+, b = -Z- e_b.
        let (mut a, mut b) = (ws.take_for_overwrite(n), ws.take_for_overwrite(n));
        for i in 0..n {
            a[i] = -zp[i];
            b[i] = -zm[i] * eb_att;
        }
        let (hs, hd, sp, sm) = self.homogeneous_out(&a, &b, ws);
        for i in 0..n {
            cr[i] = zm[i] + hs[i];
            ct[i] = zp[i] * eb_att + hd[i];
        }
        for v in [a, b, hs, hd] {
            ws.give(v);
        }
        // Beam -> probes: homogeneous rows plus the particular source integral,
        // once per distinct probe cosine (`per`); only the peak correction
        // depends on the azimuth.
        let mut per = ws.take_for_overwrite(4 * probes.len());
        // The peak correction's path factors, once per probe cosine (order 0).
        let peak: Vec<_> = match (tms, self.m) {
            (Some(t), 0) => probes.mu.iter().map(|&mu_x| t.paths(mu_b, mu_x, self.tau)).collect(),
            _ => Vec::new(),
        };
        // phi(1/mu_b + 1/mu_x) and e2(1/mu_b, 1/mu_x) per probe: the same in every order.
        let mut paths = ws.take_for_overwrite(2 * probes.len());
        for (d, s) in paths.chunks_exact_mut(2).zip(ws.beam_paths(self.tau, mu_b, &probes.mu)) {
            d.copy_from_slice(s);
        }
        for (p, out) in per.chunks_exact_mut(4).enumerate() {
            let pr = probes.row(p);
            let (up, dn) = self.beam_source_into(&pr, mu_b, &lam_b, [&zp, &zm], down);
            let beta = 1.0 / pr.mu;
            let (path_up, path_dn) = (paths[2 * p], paths[2 * p + 1]);
            // R_xq a + T_xq b = us . Cp^-1 T (a + b) + uy . Cm^-1 T (a - b).
            out.copy_from_slice(&[
                up * beta * path_up,
                dn * beta * path_dn,
                dot(pr.us, &sp),
                dot(pr.uy, &sm),
            ]);
        }
        for v in [lam_b, sp, sm, zp, zm, paths] {
            ws.give(v);
        }
        for (ex_i, exx) in extras.iter().enumerate() {
            let (Some(p), Some(mu_x)) = (probes.of(ex_i), exx.mu) else { continue };
            let [mut out_up, mut out_dn, hp, hm] =
                [per[4 * p], per[4 * p + 1], per[4 * p + 2], per[4 * p + 3]];
            if let (Some(t), 0) = (tms, self.m) {
                // Eq. 5 and 5a-5h of docs/multiflux.md: exact single scattering
                // (TMS) and the forward peak's second order (IMS), real space.
                debug_assert_eq!(probes.mu[p], mu_x);
                if down {
                    let (du, dd) = t.radiance_along(&peak[p], exx.phi_deg);
                    out_up += du;
                    out_dn += dd;
                } else {
                    out_up += t.radiance_up_along(&peak[p], exx.phi_deg);
                }
            }
            // T_xq a + R_xq b is the same with the sign of the second term
            // flipped (nothing leaves the bottom of a half-space).
            out_up += hp + hm;
            if !self.tau.is_infinite() {
                out_dn += hp - hm;
            }
            cr[n + ex_i] = out_up;
            if down {
                ct[n + ex_i] = out_dn;
            }
        }
        ws.give(per);
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
        crate::workspace::with_workspace(|ws| self.beam_response_in(extras, eb, tms, true, ws))
    }

    /// [`SlabSolution::beam_response`] with the scratch vectors of `ws`
    /// (the two returned vectors are the workspace's too); without `down`
    /// the probes' part of the `T` column is zero, not computed.
    pub(crate) fn beam_response_in(
        &self,
        extras: &[Extra],
        eb: usize,
        tms: Option<&Tms>,
        down: bool,
        ws: &mut Workspace,
    ) -> (Vec<f64>, Vec<f64>) {
        let n = self.n;
        let dim = n + extras.len();
        let (mut cr, mut ct) = (ws.take(dim), ws.take(dim));
        let (true, Some(mu_b)) = (extras[eb].beam, extras[eb].mu) else {
            return (cr, ct);
        };
        let probes = self.probes(extras, ws);
        let (r, t) = self.beam_response_rows(mu_b, extras, &probes, tms, down, ws);
        for i in 0..dim {
            if i < n || probes.of(i - n).is_some() {
                cr[i] = r[i];
                ct[i] = t[i];
            }
        }
        ws.give(r);
        ws.give(t);
        probes.recycle(ws);
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
        down: bool,
        ws: &mut Workspace,
    ) -> (Vec<f64>, Vec<f64>) {
        // Eq. S6 is singular at k_j mu_b = 1 (the full response is not): at
        // an exact resonance (|k mu_b - 1| < 1e-9, a set of measure zero)
        // the response is the mean at mu_b (1 ± 1e-6) (error ~1e-12; one-sided
        // 1e-6 at mu_b = 1). Near it, the cancellation costs only
        // log10(1/|k mu_b - 1|) digits.
        let near = self.k.iter().any(|&k| (k * mu_b - 1.0).abs() < 1e-9);
        if !near {
            self.beam_columns(mu_b, extras, probes, tms, down, ws)
        } else if mu_b * (1.0 + 1e-6) < 1.0 {
            let (a, b) = (
                self.beam_columns(mu_b * (1.0 - 1e-6), extras, probes, tms, down, ws),
                self.beam_columns(mu_b * (1.0 + 1e-6), extras, probes, tms, down, ws),
            );
            let avg = |x: &[f64], y: &[f64]| -> Vec<f64> {
                x.iter().zip(y).map(|(p, q)| 0.5 * (p + q)).collect()
            };
            (avg(&a.0, &b.0), avg(&a.1, &b.1))
        } else {
            self.beam_columns(mu_b * (1.0 - 1e-6), extras, probes, tms, down, ws)
        }
    }
}
