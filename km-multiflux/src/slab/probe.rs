//! Probes: user exit directions of zero quadrature weight (eq. 14 of
//! `docs/multiflux.md`; Stamnes et al. 1988 §3.6). Everything a probe needs
//! from a layer and order depends on its polar angle only, so the exit
//! directions of one polar angle (any azimuths) share one [`Probe`].

use super::{Extra, SlabSolution, atten, dot};
use crate::correction::{e2, phi};

/// What a probe (a user direction of zero weight) needs from one layer and
/// order: the mode coefficients of its rows `R_xq`, `T_xq` and, for the beam's source integral, its
/// Legendre values and the even/odd kernels to the nodes.
pub(super) struct Probe {
    /// The probe's cosine in this layer.
    pub(super) mu: f64,
    /// Path integrals per mode (eq. 14): `R_xq = (us Cp^-1 + uy Cm^-1) T`.
    pub(super) us: Vec<f64>,
    pub(super) uy: Vec<f64>,
    pub(super) lam: Vec<f64>,
    pub(super) ev: Vec<f64>,
    pub(super) od: Vec<f64>,
}

/// The probes of one layer and order, computed once per distinct cosine:
/// everything in a probe's rows depends on its polar angle only, so the exit
/// directions that share one (any number of azimuths) share one [`Probe`].
pub(super) struct Probes {
    /// One entry per distinct probe cosine, in order of first appearance.
    pub(super) rows: Vec<Probe>,
    /// For each extra: its entry in `rows` (`None` for the beam and for
    /// directions absent from this medium).
    pub(super) of: Vec<Option<usize>>,
}

impl SlabSolution {
    /// `Lambda_l^m(mu)` for this order.
    pub(super) fn lam_at(&self, mu: f64) -> Vec<f64> {
        let mut b = vec![0.0; self.chi.len()];
        self.rec.eval(mu, &mut b);
        b
    }

    /// Even and odd (in l+m) kernels between direction `mu` and every node:
    /// `sum_{l+m even/odd} (2l+1) chi_l Lambda_l(mu) Lambda_l(mu_j)`.
    pub(super) fn kernels(&self, lam_x: &[f64]) -> (Vec<f64>, Vec<f64>) {
        let nl = self.chi.len();
        // The weights split by parity of l + m (zero elsewhere), then dot products.
        let (mut we, mut wo) = (vec![0.0; nl], vec![0.0; nl]);
        for l in self.m..nl {
            let x = self.chi[l] * lam_x[l];
            if (l + self.m).is_multiple_of(2) { we[l] = x } else { wo[l] = x }
        }
        let (mut ev, mut od) = (vec![0.0; self.n], vec![0.0; self.n]);
        for j in 0..self.n {
            let row = &self.lam[j * nl..(j + 1) * nl];
            ev[j] = dot(&we, row);
            od[j] = dot(&wo, row);
        }
        (ev, od)
    }

    /// Rows for a probe at cosine `mu_x`: `(R_xq, T_xq)`, the up-going radiance
    /// at `mu_x` leaving the top per unit down-going radiance at each node
    /// entering at the top, and the same from the bottom (eq. 14 of docs/multiflux.md).
    pub(super) fn probe_rows(&self, mu_x: f64) -> Probe {
        let n = self.n;
        let lam_x = self.lam_at(mu_x);
        let (ev, od) = self.kernels(&lam_x);
        let beta = 1.0 / mu_x;
        let eb = atten(self.tau, mu_x);
        // a_j = omega w ev . v_j ; b_j = -omega w od . z_j (up-going probe), original coords.
        let fe: Vec<f64> = (0..n).map(|i| self.omega * self.w[i] / self.t[i] * ev[i]).collect();
        let fo: Vec<f64> = (0..n).map(|i| self.omega * self.w[i] / self.t[i] * od[i]).collect();
        let mut us = vec![0.0; n];
        let mut uy = vec![0.0; n];
        for j in 0..n {
            let a = dot(&fe, self.v.col_as_slice(j));
            let b = -dot(&fo, self.z.col_as_slice(j));
            let k = self.k[j];
            if self.tau.is_infinite() {
                // Only top-anchored modes: out = 1/2 (a + b k) beta/(k + beta) c, c = s.
                us[j] = 0.5 * (a + b * k) * beta / (k + beta);
                continue;
            }
            let t0 = self.tau;
            // phi(k + beta) and e2(k, beta) of the path integral, from the
            // exponentials of the mode and of the probe when no cancellation
            // threatens (exponent differences above 1/2: at most ~4 ulp lost),
            // else by expm1.
            let ek = self.ek[j];
            let k1 = if (k + beta) * t0 > 0.5 {
                beta * (1.0 - ek * eb) / (k + beta)
            } else {
                beta * phi(k + beta, t0)
            };
            let k2 = if (beta - k).abs() * t0 > 0.5 {
                beta * (ek - eb) / (beta - k)
            } else {
                beta * e2(k, beta, t0)
            };
            let kd = if k > 0.0 {
                (k1 - k2) / k
            } else {
                // limit: beta int_0^t0 e^{-beta t} (t0 - 2 t) dt
                let x = beta * t0;
                let om = -(-x).exp_m1();
                t0 * om - 2.0 * (om - x * (-x).exp()) / beta
            };
            us[j] = 0.25 * (a * (k1 + k2) + b * k * (k1 - k2));
            uy[j] = 0.25 * (a * kd + b * (k1 + k2));
        }
        if self.tau.is_infinite() {
            uy.iter_mut().for_each(|x| *x = 0.0);
        }
        Probe { mu: mu_x, us, uy, lam: lam_x, ev, od }
    }

    /// `(R_xq, T_xq)` of a probe: `R_xq = (us Cp^-1 + uy Cm^-1) T`,
    /// `T_xq = (us Cp^-1 - uy Cm^-1) T`, the row vectors by transposed solves
    /// `Cp^-T us`, `Cm^-T uy`.
    pub(super) fn probe_row_vectors(&self, pr: &Probe) -> (Vec<f64>, Vec<f64>) {
        let n = self.n;
        let (mut p, mut q) = (pr.us.clone(), pr.uy.clone());
        self.lu_p.solve_transpose(&mut p);
        match &self.lu_m {
            Some(lu) => lu.solve_transpose(&mut q),
            None => q.iter_mut().for_each(|x| *x = 0.0),
        }
        let mut rx = vec![0.0; n];
        let mut tx = vec![0.0; n];
        for i in 0..n {
            rx[i] = (p[i] + q[i]) * self.t[i];
            tx[i] = (p[i] - q[i]) * self.t[i];
        }
        if self.tau.is_infinite() {
            tx.iter_mut().for_each(|x| *x = 0.0);
        }
        (rx, tx)
    }

    /// The probes of `extras`, one [`Probe`] per distinct cosine (the beam
    /// and directions absent from this medium have none).
    pub(super) fn probes(&self, extras: &[Extra]) -> Probes {
        let mut rows: Vec<Probe> = Vec::new();
        let of = extras
            .iter()
            .map(|ex| match (ex.beam, ex.mu) {
                (false, Some(mu_x)) => Some(match rows.iter().position(|p| p.mu == mu_x) {
                    Some(i) => i,
                    None => {
                        rows.push(self.probe_rows(mu_x));
                        rows.len() - 1
                    }
                }),
                _ => None,
            })
            .collect();
        Probes { rows, of }
    }
}
