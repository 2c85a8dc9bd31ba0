//! The once-scattered light of the scaled problem, order by order (eq. 5i
//! of `docs/multiflux.md`): what the discrete-ordinate solution of order
//! `m` holds of the beam scattered once by the truncated phase function
//! `p*`, in closed form. The azimuthal stopping rule tests what is left
//! (the light scattered more than once, smooth in azimuth), and the orders
//! after the stop are this closed form alone.

use km_core::legendre::LegendreRecurrence;

use super::TmsLayer;

impl TmsLayer {
    /// Add order `m` of this layer's scaled single scattering (eq. 5i) to
    /// `sr` (reflected exits) and `st` (transmitted), `[i * no + o]`:
    /// `(2 - delta_m0) omega*/(4 pi mu_b) sum_l (2l + 1) chi*_l
    /// Lambda_l^m(mu_b) Lambda_l^m(mu_x) [W_R (-1)^(l-m) + W_T]`, the
    /// Fourier coefficient of `W_R q p*(c_R) + W_T q p*(c_T)` (the
    /// addition theorem of the Legendre polynomials; `Lambda(-mu_x) =
    /// (-1)^(l-m) Lambda(mu_x)` in `c_R`).
    fn add_once_order(&self, m: usize, [sr, st]: [&mut [f64]; 2], scratch: &mut Scratch) {
        let nl = self.chiw.len();
        if m >= nl || self.omega == 0.0 {
            return;
        }
        let (ni, no) = (self.mu_b.len(), self.mu_r.len());
        // Lambda_l^m at every cosine: the beams, then the reflected and the
        // transmitted exits (zeros where a direction does not exist here).
        let (a, b) = (std::mem::take(&mut scratch.a), std::mem::take(&mut scratch.b));
        let rec = LegendreRecurrence::new_in(m, nl, a, b);
        let lam = &mut scratch.lam;
        lam.clear();
        lam.resize((ni + 2 * no) * nl, 0.0);
        let cosines = self.mu_b.iter().chain(&self.mu_r).chain(&self.mu_t);
        for (c, mu) in cosines.enumerate() {
            if let Some(mu) = *mu {
                rec.eval(mu, &mut lam[c * nl..(c + 1) * nl]);
            }
        }
        let q = (if m == 0 { 1.0 } else { 2.0 }) * self.omega / (4.0 * std::f64::consts::PI);
        for (i, mu_b) in self.mu_b.iter().enumerate() {
            let Some(mu_b) = *mu_b else { continue };
            let lb = &lam[i * nl..(i + 1) * nl];
            for (side, out) in [(0, &mut *sr), (1, &mut *st)] {
                let weights = if side == 0 { &self.w_r } else { &self.w_t };
                for o in 0..no {
                    let w = weights[i * no + o];
                    if w[0] == 0.0 && w[1] == 0.0 {
                        continue;
                    }
                    let c = ni + side * no + o;
                    let lx = &lam[c * nl..(c + 1) * nl];
                    // The terms of even and odd l - m apart (the sign of c_R).
                    let term = |l: usize| self.chiw[l] * lb[l] * lx[l];
                    let even: f64 = (m..nl).step_by(2).map(term).sum();
                    let odd: f64 = (m + 1..nl).step_by(2).map(term).sum();
                    out[i * no + o] += q / mu_b * (w[0] * (even - odd) + w[1] * (even + odd));
                }
            }
        }
        (scratch.a, scratch.b) = rec.into_buffers();
    }
}

/// The buffers of [`TmsLayer::add_once_order`], kept over the orders: the
/// Legendre values and the recurrence's coefficients.
#[derive(Default)]
struct Scratch {
    lam: Vec<f64>,
    a: Vec<f64>,
    b: Vec<f64>,
}

/// The once-scattered part of each order of a request (eq. 5i), summed
/// over its corrected layers, for the stopping rule and the tail.
#[derive(Default)]
pub(super) struct OnceOrders {
    /// Order `m`'s coefficients, reflected and transmitted, `[i * no + o]`.
    pub(super) sr: Vec<f64>,
    pub(super) st: Vec<f64>,
    scratch: Scratch,
}

impl OnceOrders {
    /// Order `m` of the layers `tms` into `sr`, `st` (`pairs` values each).
    pub(super) fn order(&mut self, tms: &[TmsLayer], m: usize, pairs: usize) {
        for v in [&mut self.sr, &mut self.st] {
            v.clear();
            v.resize(pairs, 0.0);
        }
        for l in tms {
            l.add_once_order(m, [&mut self.sr, &mut self.st], &mut self.scratch);
        }
    }

    /// The largest difference between an order's coefficients `cr`, `ct`
    /// and its once-scattered part (after [`OnceOrders::order`]): the
    /// light scattered more than once in that order. (Without light below,
    /// `ct` and `st` are both zero: no transmitted exit has a cosine.)
    pub(super) fn rest(&self, cr: &[f64], ct: &[f64]) -> f64 {
        let r = cr.iter().zip(&self.sr).map(|(a, b)| (a - b).abs());
        let t = ct.iter().zip(&self.st).map(|(a, b)| (a - b).abs());
        r.chain(t).fold(0.0, f64::max)
    }
}
