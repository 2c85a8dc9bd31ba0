//! Probes: user exit directions of zero quadrature weight (eq. 14 of
//! `docs/multiflux.md`; Stamnes et al. 1988 §3.6). Everything a probe needs
//! from a layer and order depends on its polar angle only, so the exit
//! directions of one polar angle (any azimuths) share one [`Probe`].

use super::{Extra, SlabSolution, dot, dot_every_other};
use crate::correction::{e2, phi};
use crate::workspace::Workspace;

/// What a probe (a user direction of zero weight) needs from one layer and
/// order: the mode coefficients of its rows `R_xq`, `T_xq` and, for the beam's source integral, its
/// Legendre values and the even/odd kernels to the nodes (borrowed from [`Probes`]).
pub(super) struct Probe<'a> {
    /// The probe's cosine in this layer.
    pub(super) mu: f64,
    /// Path integrals per mode (eq. 14): `R_xq = (us Cp^-1 + uy Cm^-1) T`.
    pub(super) us: &'a [f64],
    pub(super) uy: &'a [f64],
    pub(super) lam: &'a [f64],
    pub(super) ev: &'a [f64],
    pub(super) od: &'a [f64],
}

/// The probes of one layer and order, computed once per distinct cosine:
/// everything in a probe's rows depends on its polar angle only, so the exit
/// directions that share one (any number of azimuths) share one [`Probe`].
/// Stored flat, probe after probe (`n` values per probe for `us`, `uy`,
/// `ev`, `od`; `nl` for `lam`), in vectors of the workspace.
pub(super) struct Probes {
    /// One cosine per distinct probe, in order of first appearance.
    pub(super) mu: Vec<f64>,
    n: usize,
    nl: usize,
    us: Vec<f64>,
    uy: Vec<f64>,
    lam: Vec<f64>,
    ev: Vec<f64>,
    od: Vec<f64>,
    /// For each extra: its probe ([`NO_PROBE`] for the beam and for
    /// directions absent from this medium; see [`Probes::of`]).
    of: Vec<usize>,
}

/// The mark of an extra without a probe in [`Probes`]' map.
const NO_PROBE: usize = usize::MAX;

impl Probes {
    /// The number of distinct probes.
    pub(super) fn len(&self) -> usize {
        self.mu.len()
    }

    /// The probe of extra `e` (`None` for the beam and for directions
    /// absent from this medium).
    pub(super) fn of(&self, e: usize) -> Option<usize> {
        Some(self.of[e]).filter(|&p| p != NO_PROBE)
    }

    /// Probe `p`.
    pub(super) fn row(&self, p: usize) -> Probe<'_> {
        let (n, nl) = (self.n, self.nl);
        Probe {
            mu: self.mu[p],
            us: &self.us[p * n..(p + 1) * n],
            uy: &self.uy[p * n..(p + 1) * n],
            lam: &self.lam[p * nl..(p + 1) * nl],
            ev: &self.ev[p * n..(p + 1) * n],
            od: &self.od[p * n..(p + 1) * n],
        }
    }

    /// Hand every vector back to the workspace.
    pub(super) fn recycle(self, ws: &mut Workspace) {
        for v in [self.mu, self.us, self.uy, self.lam, self.ev, self.od] {
            ws.give(v);
        }
        ws.give_idx(self.of);
    }
}

impl SlabSolution {
    /// `Lambda_l^m(mu)` for this order (a vector of the workspace).
    pub(super) fn lam_at(&self, mu: f64, ws: &mut Workspace) -> Vec<f64> {
        // eval writes every element.
        let mut b = ws.take_for_overwrite(self.chi.len());
        self.rec.eval(mu, &mut b);
        b
    }

    /// Even and odd (in l+m) kernels between direction `mu` and every node:
    /// `sum_{l+m even/odd} (2l+1) chi_l Lambda_l(mu) Lambda_l(mu_j)`
    /// (vectors of the workspace).
    pub(super) fn kernels(&self, lam_x: &[f64], ws: &mut Workspace) -> (Vec<f64>, Vec<f64>) {
        // All three are written before they are read (kernels_into).
        let mut wx = ws.take_for_overwrite(self.chi.len());
        let (mut ev, mut od) = (ws.take_for_overwrite(self.n), ws.take_for_overwrite(self.n));
        self.kernels_into(lam_x, &mut wx, &mut ev, &mut od);
        ws.give(wx);
        (ev, od)
    }

    /// [`SlabSolution::kernels`] into `ev`, `od` (`n` values each), with
    /// `wx` a scratch vector of at least `nl` values (overwritten).
    fn kernels_into(&self, lam_x: &[f64], wx: &mut [f64], ev: &mut [f64], od: &mut [f64]) {
        let nl = self.chi.len();
        // The weights chi_l Lambda_l(mu); the even kernel sums the l + m even
        // terms (l = m, m + 2, ...), the odd one the others: each dot product
        // reads its own parity only.
        for l in self.m..nl {
            wx[l] = self.chi[l] * lam_x[l];
        }
        let wx = &wx[..nl];
        for j in 0..self.n {
            let row = &self.lam[j * nl..(j + 1) * nl];
            ev[j] = dot_every_other(wx, row, self.m);
            od[j] = dot_every_other(wx, row, self.m + 1);
        }
    }

    /// Rows for a probe at cosine `mu_x`: `(R_xq, T_xq)`, the up-going radiance
    /// at `mu_x` leaving the top per unit down-going radiance at each node
    /// entering at the top, and the same from the bottom (eq. 14 of docs/multiflux.md).
    /// `eb` is the probe's attenuation `exp(-tau / mu_x)` through the layer;
    /// `out` holds the probe's `[us, uy, lam, ev, od]`; `scratch` three
    /// vectors of at least `nl` values; `ow` is `omega w_i / t_i` per node
    /// (the same for every probe of the order).
    fn probe_rows_into(
        &self,
        (mu_x, eb): (f64, f64),
        ow: &[f64],
        out: [&mut [f64]; 5],
        scratch: &mut [Vec<f64>; 3],
    ) {
        let n = self.n;
        let [us, uy, lam_x, ev, od] = out;
        self.rec.eval(mu_x, lam_x);
        let nl = self.chi.len();
        let [wx, fe, fo] = scratch;
        self.kernels_into(lam_x, &mut wx[..nl], ev, od);
        let beta = 1.0 / mu_x;
        // a_j = omega w ev . v_j ; b_j = -omega w od . z_j (up-going probe), original coords.
        let (fe, fo) = (&mut fe[..n], &mut fo[..n]);
        for i in 0..n {
            fe[i] = ow[i] * ev[i];
            fo[i] = ow[i] * od[i];
        }
        for j in 0..n {
            let a = dot(fe, self.v.col_as_slice(j));
            let b = -dot(fo, self.z.col_as_slice(j));
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
    }

    /// `(R_xq, T_xq)` of every probe: `R_xq = (us Cp^-1 + uy Cm^-1) T`,
    /// `T_xq = (us Cp^-1 - uy Cm^-1) T`, the row vectors by transposed solves
    /// of all probes at once, one call per factor (`Cp^-T [us_1 .. us_P]`,
    /// `Cm^-T [uy_1 .. uy_P]`); the vectors come from `ws` (the caller gives
    /// them back).
    pub(super) fn all_probe_row_vectors(
        &self,
        probes: &Probes,
        ws: &mut Workspace,
    ) -> Vec<(Vec<f64>, Vec<f64>)> {
        let (n, np) = (self.n, probes.len());
        // Row-major n x np: component i of probe p at [i * np + p].
        let (mut p_all, mut q_all) = (ws.take_for_overwrite(n * np), ws.take_for_overwrite(n * np));
        for p in 0..np {
            let row = probes.row(p);
            for i in 0..n {
                p_all[i * np + p] = row.us[i];
                q_all[i * np + p] = row.uy[i];
            }
        }
        self.lu_p.solve_transpose_rows(&mut p_all, np);
        match &self.lu_m {
            Some(lu) => lu.solve_transpose_rows(&mut q_all, np),
            None => q_all.iter_mut().for_each(|x| *x = 0.0),
        }
        let out = (0..np)
            .map(|p| {
                // Every element is written below.
                let mut rx = ws.take_for_overwrite(n);
                let mut tx = ws.take_for_overwrite(n);
                for i in 0..n {
                    let (a, b) = (p_all[i * np + p], q_all[i * np + p]);
                    rx[i] = (a + b) * self.t[i];
                    tx[i] = if self.tau.is_infinite() { 0.0 } else { (a - b) * self.t[i] };
                }
                (rx, tx)
            })
            .collect();
        ws.give(p_all);
        ws.give(q_all);
        out
    }

    /// The probes of `extras`, one [`Probe`] per distinct cosine (the beam
    /// and directions absent from this medium have none).
    pub(super) fn probes(&self, extras: &[Extra], ws: &mut Workspace) -> Probes {
        let mut mu = ws.take(0);
        let mut of = ws.take_idx(extras.len());
        // Distinct cosines by a linear search, or by their bits once there are
        // many (a request of thousands of exit polar angles).
        let mut seen: Option<std::collections::HashMap<u64, usize>> =
            (extras.len() > 64).then(std::collections::HashMap::new);
        for (o, ex) in of.iter_mut().zip(extras) {
            *o = match (ex.beam, ex.mu) {
                (false, Some(mu_x)) => {
                    let found = match &seen {
                        Some(map) => map.get(&mu_x.to_bits()).copied(),
                        None => mu.iter().position(|&p| p == mu_x),
                    };
                    match found {
                        Some(i) => i,
                        None => {
                            mu.push(mu_x);
                            if let Some(map) = &mut seen {
                                map.insert(mu_x.to_bits(), mu.len() - 1);
                            }
                            mu.len() - 1
                        }
                    }
                }
                _ => NO_PROBE,
            };
        }
        let (n, nl, np) = (self.n, self.chi.len(), mu.len());
        if np == 0 {
            // No probe (totals): nothing more to take or compute (the empty
            // vectors allocate nothing and are not kept by `recycle`).
            let none = Vec::new;
            let (us, uy, lam, ev, od) = (none(), none(), none(), none(), none());
            return Probes { n, nl, us, uy, lam, ev, od, mu, of };
        }
        // Every element of the probes' vectors and of the scratch is written
        // before it is read (probe_rows_into).
        let mut pr = Probes {
            n,
            nl,
            us: ws.take_for_overwrite(np * n),
            uy: ws.take_for_overwrite(np * n),
            lam: ws.take_for_overwrite(np * nl),
            ev: ws.take_for_overwrite(np * n),
            od: ws.take_for_overwrite(np * n),
            mu,
            of,
        };
        let w = nl.max(n);
        let mut scratch =
            [ws.take_for_overwrite(w), ws.take_for_overwrite(w), ws.take_for_overwrite(w)];
        // omega w_i / t_i, as `(omega w_i) / t_i` was computed per probe.
        let mut ow = ws.take_for_overwrite(n);
        for i in 0..n {
            ow[i] = self.omega * self.w[i] / self.t[i];
        }
        // The attenuations do not depend on the order: kept in the workspace.
        let mut eb = ws.take_for_overwrite(np);
        for (d, s) in eb.iter_mut().zip(ws.probe_attenuations(self.tau, &pr.mu)) {
            *d = s[0];
        }
        for p in 0..np {
            let out = [
                &mut pr.us[p * n..(p + 1) * n],
                &mut pr.uy[p * n..(p + 1) * n],
                &mut pr.lam[p * nl..(p + 1) * nl],
                &mut pr.ev[p * n..(p + 1) * n],
                &mut pr.od[p * n..(p + 1) * n],
            ];
            self.probe_rows_into((pr.mu[p], eb[p]), &ow, out, &mut scratch);
        }
        for v in scratch {
            ws.give(v);
        }
        ws.give(ow);
        ws.give(eb);
        pr
    }
}
