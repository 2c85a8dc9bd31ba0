//! Legendre moments of the Mie phase function (eq. M13 of `docs/mie.md`),
//! exact by Gauss–Legendre quadrature: `S1`, `S2` of a series of `N` terms
//! are polynomials of degree `N` in `mu`, so `|S1|^2 + |S2|^2` has degree
//! `2N`, its moments vanish beyond `l = 2N`, and `2N + 2` Gauss nodes
//! integrate `(|S1|^2 + |S2|^2) P_l` exactly for every `l <= 2N`.
//! A size distribution adds its spheres' `|S1|^2 + |S2|^2` on one set of
//! nodes (sized for its largest sphere), weighted by number: the moments of
//! the scattering-weighted mean phase function (eq. M15).

use std::f64::consts::PI;

use super::sphere::{AmplitudeTerms, Amplitudes, Sphere};
use crate::legendre::legendre_coefficients;

/// `sum_r w_r (|S1|^2 + |S2|^2)(+-mu_j)` on the positive Gauss nodes `mu_j`.
#[derive(Debug, Clone)]
pub(crate) struct PhaseAccumulator {
    /// Positive Gauss nodes, and their weights.
    mu: Vec<f64>,
    w: Vec<f64>,
    /// Accumulated `|S1|^2 + |S2|^2` at `+mu_j` and `-mu_j`.
    plus: Vec<f64>,
    minus: Vec<f64>,
    /// The largest series (terms) the nodes integrate exactly.
    max_terms: usize,
}

impl PhaseAccumulator {
    /// Nodes for spheres of up to `max_terms` terms: `2 max_terms + 2` Gauss
    /// nodes on `[-1, 1]`, kept as `max_terms + 1` symmetric pairs.
    pub(crate) fn new(max_terms: usize) -> Self {
        let (mu, w) = gauss_half(max_terms + 1);
        PhaseAccumulator { plus: vec![0.0; mu.len()], minus: vec![0.0; mu.len()], mu, w, max_terms }
    }

    /// Add a sphere's `|S1|^2 + |S2|^2` with weight `weight` (a number
    /// density; the sphere's series must fit the nodes).
    pub(crate) fn add(&mut self, sphere: &Sphere, weight: f64) {
        debug_assert!(sphere.terms() <= self.max_terms);
        let (a, b) = sphere.coefficients();
        let terms = AmplitudeTerms::new(a, b);
        let mut s = Amplitudes::default();
        for j in 0..self.mu.len() {
            terms.sums(self.mu[j], &mut s);
            self.plus[j] += weight * (s.s1_plus.norm_sqr() + s.s2_plus.norm_sqr());
            self.minus[j] += weight * (s.s1_minus.norm_sqr() + s.s2_minus.norm_sqr());
        }
    }

    /// The moments `chi_0 .. chi_{2N}` of the accumulated phase function,
    /// normalised to `chi_0 = 1` (eq. M13), and the unnormalised `chi_0`
    /// (`integral (|S1|^2 + |S2|^2) dmu` summed with the weights: `x^2 Q_sca`
    /// for one sphere of weight 1, a check of the coefficients).
    pub(crate) fn moments(&self) -> (Vec<f64>, f64) {
        let nl = 2 * self.max_terms + 1;
        let mut chi = vec![0.0; nl];
        let coef = crate::legendre::legendre_coefficients(nl);
        for j in 0..self.mu.len() {
            let (x, wp, wm) = (self.mu[j], self.w[j] * self.plus[j], self.w[j] * self.minus[j]);
            // P_l(-x) = (-1)^l P_l(x): even l take the sum, odd l the difference.
            let (even, odd) = (wp + wm, wp - wm);
            let (mut p0, mut p1) = (1.0, x);
            chi[0] += even;
            if nl > 1 {
                chi[1] += odd * x;
            }
            for (l, c) in chi.iter_mut().enumerate().skip(2) {
                let (al, bl) = coef[l];
                let p = al * x * p1 - bl * p0;
                *c += if l % 2 == 0 { even } else { odd } * p;
                (p0, p1) = (p1, p);
            }
        }
        let norm = chi[0];
        if norm > 0.0 {
            chi.iter_mut().for_each(|c| *c /= norm);
            chi[0] = 1.0;
        }
        (chi, norm)
    }
}

/// The positive half (`m` nodes, ascending, with weights) of the
/// Gauss–Legendre rule of `2m` nodes (Abramowitz & Stegun 25.4.29): Newton
/// on `P_2m` from Tricomi's initial guess with its `1/n^2` correction
/// (Abramowitz & Stegun 22.16.6; error `O(n^-4)`), stopped one step after
/// the step falls below 1e-15 (at most 12 steps), the recurrence without
/// divisions: at the `2m ~ 20 000` nodes of `x = 10^4` the rule of
/// [`crate::quadrature::gauss_legendre`] (which iterates to 1e-16, not always
/// reachable, up to 100 steps) takes seconds.
fn gauss_half(m: usize) -> (Vec<f64>, Vec<f64>) {
    let n = 2 * m;
    let nf = n as f64;
    let coef = legendre_coefficients(n + 1);
    // (P_n(z), P_{n-1}(z)) by recurrence LG1 with precomputed factors.
    let pair = |z: f64| {
        let (mut p0, mut p1) = (1.0, z);
        for &(al, bl) in &coef[2..=n] {
            (p0, p1) = (p1, al * z * p1 - bl * p0);
        }
        (p1, p0)
    };
    let (mut x, mut w) = (vec![0.0; m], vec![0.0; m]);
    for i in 0..m {
        let t = PI * (i as f64 + 0.75) / (nf + 0.5);
        let mut z = (1.0 - 1.0 / (8.0 * nf * nf) + 1.0 / (8.0 * nf * nf * nf)) * t.cos();
        let mut dp = 1.0;
        let mut done = false;
        for _ in 0..12 {
            let (p1, p0) = pair(z);
            dp = n as f64 * (z * p1 - p0) / (z * z - 1.0);
            let dz = p1 / dp;
            z -= dz;
            if done {
                break;
            }
            done = dz.abs() < 1e-15;
        }
        // Root i counts down from the largest node.
        x[m - 1 - i] = z;
        w[m - 1 - i] = 2.0 / ((1.0 - z * z) * dp * dp);
    }
    (x, w)
}

/// The Legendre moments `chi_0 .. chi_{2N}` of one sphere's phase function,
/// `chi_0 = 1`, `chi_1 = g` (eq. M13).
///
/// ```
/// use km_core::mie::{Complex, Sphere, phase_moments};
/// let s = Sphere::new(Complex::new(1.5, 0.001), 10.0).unwrap();
/// let chi = phase_moments(&s);
/// assert_eq!(chi.len(), 2 * s.terms() + 1);
/// assert!((chi[1] - s.g()).abs() < 1e-12);
/// ```
pub fn phase_moments(sphere: &Sphere) -> Vec<f64> {
    let mut acc = PhaseAccumulator::new(sphere.terms());
    acc.add(sphere, 1.0);
    acc.moments().0
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mie::Complex;

    /// The half rule is the positive half of the full Gauss–Legendre rule.
    #[test]
    fn half_rule_matches_the_full_rule() {
        let (x, w) = crate::quadrature::gauss_legendre(40);
        let (xh, wh) = gauss_half(20);
        for i in 0..20 {
            assert!((x[20 + i] - xh[i]).abs() < 1e-15 && (w[20 + i] - wh[i]).abs() < 1e-14);
        }
    }

    /// chi_0 before normalisation is `x^2 Q_sca` (the Gauss rule integrates
    /// `|S1|^2 + |S2|^2` exactly), and the series of the moments gives back
    /// the phase function from the amplitudes (1e-10 relative).
    #[test]
    fn moments_reproduce_the_phase_function() {
        let s = Sphere::new(Complex::new(1.33, 1e-4), 25.0).unwrap();
        let mut acc = PhaseAccumulator::new(s.terms());
        acc.add(&s, 1.0);
        let (chi, norm) = acc.moments();
        let want = s.x() * s.x() * s.q_sca();
        assert!((norm - want).abs() < 1e-11 * want, "{norm} vs {want}");
        for mu in [-1.0, -0.4, 0.0, 0.7, 0.99, 1.0] {
            let mut sum = 0.0;
            for (l, p) in crate::legendre::legendre_polynomials(mu).take(chi.len()).enumerate() {
                sum += (2 * l + 1) as f64 * chi[l] * p;
            }
            let p = sum / (4.0 * std::f64::consts::PI);
            let direct = s.phase(mu);
            assert!((p - direct).abs() < 1e-10 * direct.max(1e-3), "mu = {mu}: {p} vs {direct}");
        }
    }
}
