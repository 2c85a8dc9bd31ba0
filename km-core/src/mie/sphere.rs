//! One homogeneous sphere: the Mie coefficients `a_n`, `b_n` by Wiscombe's
//! algorithm, and what follows from them (efficiencies, asymmetry,
//! amplitudes, the phase function). Equations M1–M12 of `docs/mie.md`.

use std::f64::consts::PI;

use super::complex::Complex;
use crate::error::CoreError;

/// Largest size parameter accepted, `x = 2 pi r n_host / lambda`. Wiscombe's
/// algorithm is tested to `x = 20 000` (Wiscombe 1979, table of test cases);
/// the cost grows as `x` (coefficients) and `x^2` (phase-function moments).
pub const MAX_SIZE_PARAMETER: f64 = 20_000.0;

/// Largest `|m x|`: the downward recurrence of `D_n(m x)` starts above it,
/// so it bounds the work and the memory (one complex per order).
pub const MAX_MX: f64 = 200_000.0;

/// Smallest size parameter accepted: below it the Rayleigh limit holds to
/// rounding and `chi_n(x) ~ (2n - 1)!! / x^n` nears overflow.
pub const MIN_SIZE_PARAMETER: f64 = 1e-6;

/// Orders computed of the Mie series for size parameter `x` before the
/// negligible ones are dropped (eq. M7 of docs/mie.md): `x + 10 x^(1/3) + 4`.
/// Wiscombe's (1980, eq. 4) `x + 4.05 x^(1/3) + 2` bounds the sums to about
/// 1e-6..1e-8, but the alternating backscatter sums (`S(180)`, `Q_back`)
/// still carry terms of `1e-8` of the sum there (measured at `x = 1000`:
/// `(2n + 1) |a_n|` is `6e-5` at `n = x + 4 x^(1/3)`); the coefficients decay
/// super-exponentially over a width `~ x^(1/3)`, so 10 such widths leave
/// terms far below rounding, at a cost of 6 more orders per `x^(1/3)`.
pub fn series_orders(x: f64) -> usize {
    (x + 10.0 * x.cbrt() + 4.0).ceil() as usize
}

/// Relative size below which the last orders are dropped: an order `n` is
/// kept up to the last one whose `(2n + 1)(|a_n| + |b_n|)` exceeds this
/// fraction of the largest (so every sum of the series is complete to
/// rounding).
const NEGLIGIBLE: f64 = 1e-17;

/// A sphere of relative refractive index `m` (`m.im >= 0`: absorbing) and
/// size parameter `x`, with its Mie coefficients.
///
/// Convention: time dependence `exp(-i omega t)` (Bohren & Huffman 1983), so
/// an absorbing particle has `m = n + i k`, `k >= 0`; `a_n`, `b_n` are those
/// of Bohren & Huffman eq. 4.53 (miepython, which takes `m = n - i k`,
/// returns their conjugates internally and the same efficiencies).
#[derive(Debug, Clone, PartialEq)]
pub struct Sphere {
    m: Complex,
    x: f64,
    /// `a_n`, `n = 1..=N` at index `n - 1`.
    a: Vec<Complex>,
    /// `b_n`, `n = 1..=N` at index `n - 1`.
    b: Vec<Complex>,
}

impl Sphere {
    /// The Mie coefficients of a sphere (eq. M4–M8 of `docs/mie.md`).
    ///
    /// # Errors
    /// `x` not finite, `<= 0` or above [`MAX_SIZE_PARAMETER`]; `m` not
    /// finite, `m.re <= 0`, `m.im < 0`, or `|m x|` above [`MAX_MX`]
    /// ([`CoreError::Invalid`] naming the value).
    ///
    /// # Reference
    /// Wiscombe (1979, 1980), "Mie scattering calculations" (NCAR/TN-140+STR)
    /// and "Improved Mie scattering algorithms", Appl. Opt. 19, 1505;
    /// Bohren & Huffman (1983) §4.4 and §4.8.
    ///
    /// ```
    /// use km_core::mie::{Complex, Sphere};
    /// let s = Sphere::new(Complex::new(1.5, 0.0), 1.0).unwrap();
    /// // A non-absorbing sphere: extinction is scattering.
    /// assert!((s.q_ext() - s.q_sca()).abs() < 1e-14);
    /// assert!(Sphere::new(Complex::new(1.5, -0.1), 1.0).is_err());
    /// ```
    pub fn new(m: Complex, x: f64) -> Result<Sphere, CoreError> {
        check(m, x)?;
        let (mut a, mut b) = coefficients(m, x, series_orders(x));
        // Drop the negligible last orders (eq. M7).
        let size = |i: usize| (2 * i + 3) as f64 * (a[i].abs() + b[i].abs());
        let largest = (0..a.len()).map(size).fold(0.0, f64::max);
        let keep = (0..a.len()).rposition(|i| size(i) > NEGLIGIBLE * largest).map_or(1, |i| i + 1);
        a.truncate(keep);
        b.truncate(keep);
        if a.iter().chain(&b).any(|c| !c.is_finite()) {
            return Err(CoreError::invalid(
                "size parameter",
                x,
                "the Mie series did not stay finite",
            ));
        }
        Ok(Sphere { m, x, a, b })
    }

    /// The relative refractive index `m`.
    pub fn m(&self) -> Complex {
        self.m
    }

    /// The size parameter `x`.
    pub fn x(&self) -> f64 {
        self.x
    }

    /// The number of terms `N` of the series.
    pub fn terms(&self) -> usize {
        self.a.len()
    }

    /// The coefficients `(a_n, b_n)`, `n = 1..=N` at index `n - 1`.
    pub fn coefficients(&self) -> (&[Complex], &[Complex]) {
        (&self.a, &self.b)
    }

    /// Extinction efficiency `Q_ext = 2/x^2 sum (2n+1) Re(a_n + b_n)` (eq. M9).
    pub fn q_ext(&self) -> f64 {
        let s: f64 =
            (0..self.a.len()).map(|i| (2 * i + 3) as f64 * (self.a[i].re + self.b[i].re)).sum();
        2.0 * s / (self.x * self.x)
    }

    /// Scattering efficiency `Q_sca = 2/x^2 sum (2n+1)(|a_n|^2 + |b_n|^2)` (eq. M9).
    pub fn q_sca(&self) -> f64 {
        let s: f64 = (0..self.a.len())
            .map(|i| (2 * i + 3) as f64 * (self.a[i].norm_sqr() + self.b[i].norm_sqr()))
            .sum();
        2.0 * s / (self.x * self.x)
    }

    /// Absorption efficiency `Q_abs = Q_ext - Q_sca` (0 for `m.im = 0`, where
    /// the difference is rounding only).
    pub fn q_abs(&self) -> f64 {
        if self.m.im == 0.0 { 0.0 } else { (self.q_ext() - self.q_sca()).max(0.0) }
    }

    /// Backscattering efficiency `Q_back = |sum (2n+1)(-1)^n (a_n - b_n)|^2 / x^2` (eq. M10).
    pub fn q_back(&self) -> f64 {
        let mut s = Complex::default();
        for i in 0..self.a.len() {
            let sign = if i % 2 == 0 { -1.0 } else { 1.0 };
            s = s + (self.a[i] - self.b[i]).scale(sign * (2 * i + 3) as f64);
        }
        s.norm_sqr() / (self.x * self.x)
    }

    /// Asymmetry parameter `g = <cos Theta>` (eq. M11, Bohren & Huffman eq. 4.74);
    /// 0 for a sphere that scatters nothing.
    pub fn g(&self) -> f64 {
        let (a, b) = (&self.a, &self.b);
        let mut s = 0.0;
        for i in 0..a.len() {
            let n = (i + 1) as f64;
            if i + 1 < a.len() {
                let c = a[i] * a[i + 1].conj() + b[i] * b[i + 1].conj();
                s += n * (n + 2.0) / (n + 1.0) * c.re;
            }
            s += (2.0 * n + 1.0) / (n * (n + 1.0)) * (a[i] * b[i].conj()).re;
        }
        let q = self.q_sca();
        if q > 0.0 { 4.0 * s / (self.x * self.x * q) } else { 0.0 }
    }

    /// The amplitudes `(S1(mu), S2(mu))` at the scattering cosine `mu` (eq. M6,
    /// Bohren & Huffman eq. 4.74), dimensionless, with
    /// `integral (|S1|^2 + |S2|^2)/2 dw = pi x^2 Q_sca`.
    ///
    /// ```
    /// use km_core::mie::{Complex, Sphere};
    /// let s = Sphere::new(Complex::new(1.33, 0.0), 3.0).unwrap();
    /// // Forward: S1(1) = S2(1) and Q_ext = 4/x^2 Re S(1) (optical theorem).
    /// let (s1, s2) = s.amplitudes(1.0);
    /// assert!((s1 - s2).abs() < 1e-12);
    /// assert!((4.0 * s1.re / 9.0 - s.q_ext()).abs() < 1e-12);
    /// ```
    pub fn amplitudes(&self, mu: f64) -> (Complex, Complex) {
        let mut sums = Amplitudes::default();
        amplitude_sums(&self.a, &self.b, mu, &mut sums);
        (sums.s1_plus, sums.s2_plus)
    }

    /// The phase function `p(mu) = (|S1|^2 + |S2|^2) / (2 pi x^2 Q_sca)` in
    /// 1/sr, normalised over the sphere (eq. M12).
    pub fn phase(&self, mu: f64) -> f64 {
        let (s1, s2) = self.amplitudes(mu);
        (s1.norm_sqr() + s2.norm_sqr()) / (2.0 * PI * self.x * self.x * self.q_sca())
    }
}

/// The checks of [`Sphere::new`].
fn check(m: Complex, x: f64) -> Result<(), CoreError> {
    if !x.is_finite() || !(MIN_SIZE_PARAMETER..=MAX_SIZE_PARAMETER).contains(&x) {
        return Err(CoreError::invalid(
            "size parameter",
            x,
            &format!(
                "must lie in [{MIN_SIZE_PARAMETER:e}, {MAX_SIZE_PARAMETER}] \
                 (x = 2 pi r n_host / wavelength)"
            ),
        ));
    }
    if !m.is_finite() || m.re <= 0.0 {
        return Err(CoreError::invalid(
            "relative index",
            m.re,
            "the real part must be finite and > 0",
        ));
    }
    if m.im < 0.0 {
        return Err(CoreError::invalid(
            "relative index",
            m.im,
            "the imaginary part k must be >= 0 (m = n + i k, absorbing for k > 0)",
        ));
    }
    if m.abs() * x > MAX_MX {
        return Err(CoreError::invalid(
            "|m x|",
            m.abs() * x,
            &format!("must be <= {MAX_MX} (the recurrence of D_n(m x) starts above it)"),
        ));
    }
    Ok(())
}

/// `D_n(z) = psi_n'(z)/psi_n(z)` for `n = 0..=n_max` by the downward
/// recurrence `D_{n-1} = n/z - 1/(D_n + n/z)` (eq. M5) from `D_{n_start}`
/// given by Lentz's continued fraction, `n_start = max(n_max, |z|) + 16`
/// (Wiscombe 1979 §4; Lentz 1976).
fn log_derivative(z: Complex, n_max: usize) -> Vec<Complex> {
    let n_start = n_max.max(z.abs().ceil() as usize) + 16;
    let mut d = lentz_log_derivative(z, n_start);
    let mut out = vec![Complex::default(); n_max + 1];
    let zi = z.recip();
    for n in (1..=n_start).rev() {
        if n <= n_max {
            out[n] = d;
        }
        // D_{n-1} = n/z - 1/(D_n + n/z); a zero denominator (psi_{n-1} = 0,
        // a set of measure zero) is nudged so the recurrence goes on.
        let nz = zi * n as f64;
        let mut den = d + nz;
        if den.norm_sqr() == 0.0 {
            den = Complex::real(1e-300);
        }
        d = nz - den.recip();
    }
    out[0] = d;
    out
}

/// `D_n(z)` by Lentz's continued fraction for `psi_{n-1}/psi_n`
/// (`r_n = (2n+1)/z - 1/r_{n+1}`), evaluated by the modified Lentz
/// algorithm (Thompson & Barnett 1986), then `D_n = r_n - n/z`.
fn lentz_log_derivative(z: Complex, n: usize) -> Complex {
    const TINY: f64 = 1e-300;
    let zi = z.recip();
    let b = |k: usize| zi * (2 * (n + k) + 1) as f64;
    let mut f = b(0);
    if f.norm_sqr() == 0.0 {
        f = Complex::real(TINY);
    }
    let (mut c, mut d) = (f, Complex::default());
    for k in 1..100_000 {
        // a_k = -1 for every k.
        d = b(k) - d;
        if d.norm_sqr() == 0.0 {
            d = Complex::real(TINY);
        }
        c = b(k) - c.recip();
        if c.norm_sqr() == 0.0 {
            c = Complex::real(TINY);
        }
        d = d.recip();
        let delta = c * d;
        f = f * delta;
        if (delta - 1.0).abs() < 1e-16 {
            break;
        }
    }
    f - zi * n as f64
}

/// The Mie coefficients `a_n`, `b_n`, `n = 1..=n_terms` (eq. M4): `psi_n(x)`
/// from the ratio `psi_{n-1}/psi_n = D_n(x) + n/x` (downward `D_n(x)`, stable
/// where `n > x`), `chi_n(x)` by the upward recurrence (its growing solution),
/// `xi_n = psi_n - i chi_n`, and `D_n(m x)` downward (eq. M5).
fn coefficients(m: Complex, x: f64, n_terms: usize) -> (Vec<Complex>, Vec<Complex>) {
    let dmx = log_derivative(m * x, n_terms);
    let dx = log_derivative(Complex::real(x), n_terms);
    let mi = m.recip();
    let xi_inv = 1.0 / x;
    let (mut a, mut b) = (Vec::with_capacity(n_terms), Vec::with_capacity(n_terms));
    // psi_0 = sin x, chi_0 = cos x, chi_1 = cos x / x + sin x (Bohren & Huffman §4.8).
    let (sin, cos) = x.sin_cos();
    let mut psi_prev = sin;
    let (mut chi_prev, mut chi) = (cos, cos * xi_inv + sin);
    for n in 1..=n_terms {
        let nx = n as f64 * xi_inv;
        // psi_n = psi_{n-1} / (D_n(x) + n/x).
        let psi = psi_prev / (dx[n].re + nx);
        let xi = Complex::new(psi, -chi);
        let xi_prev = Complex::new(psi_prev, -chi_prev);
        // a_n = [(D_n(mx)/m + n/x) psi_n - psi_{n-1}] / [(D_n(mx)/m + n/x) xi_n - xi_{n-1}].
        let da = dmx[n] * mi + nx;
        a.push((da * psi - psi_prev) / (da * xi - xi_prev));
        // b_n = [(m D_n(mx) + n/x) psi_n - psi_{n-1}] / [(m D_n(mx) + n/x) xi_n - xi_{n-1}].
        let db = m * dmx[n] + nx;
        b.push((db * psi - psi_prev) / (db * xi - xi_prev));
        // chi_{n+1} = (2n+1)/x chi_n - chi_{n-1}.
        let chi_next = (2 * n + 1) as f64 * xi_inv * chi - chi_prev;
        (psi_prev, chi_prev, chi) = (psi, chi, chi_next);
    }
    (a, b)
}

/// The amplitudes at `mu` and at `-mu` from one pass of the `pi_n`, `tau_n`
/// recurrences (parity `pi_n(-mu) = (-1)^(n-1) pi_n(mu)`,
/// `tau_n(-mu) = (-1)^n tau_n(mu)`).
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct Amplitudes {
    pub(crate) s1_plus: Complex,
    pub(crate) s2_plus: Complex,
    pub(crate) s1_minus: Complex,
    pub(crate) s2_minus: Complex,
}

/// The coefficients of the amplitude sums prepared once per sphere for
/// many cosines: `c_n a_n`, `c_n b_n` with `c_n = (2n+1)/(n(n+1))`, and the
/// recurrence factors of `pi_n`, so the inner loop has no division.
#[derive(Debug, Clone)]
pub(crate) struct AmplitudeTerms {
    ca: Vec<Complex>,
    cb: Vec<Complex>,
    /// `((2n+1)/n, (n+1)/n)`: `pi_{n+1} = f1 mu pi_n - f2 pi_{n-1}`.
    rec: Vec<(f64, f64)>,
}

impl AmplitudeTerms {
    pub(crate) fn new(a: &[Complex], b: &[Complex]) -> AmplitudeTerms {
        let c = |i: usize| {
            let n = (i + 1) as f64;
            (2.0 * n + 1.0) / (n * (n + 1.0))
        };
        AmplitudeTerms {
            ca: a.iter().enumerate().map(|(i, x)| x.scale(c(i))).collect(),
            cb: b.iter().enumerate().map(|(i, x)| x.scale(c(i))).collect(),
            rec: (0..a.len())
                .map(|i| {
                    let n = (i + 1) as f64;
                    ((2.0 * n + 1.0) / n, (n + 1.0) / n)
                })
                .collect(),
        }
    }

    /// `S1`, `S2` at `mu` and `-mu` (eq. M6): `pi_1 = 1`,
    /// `pi_{n+1} = ((2n+1) mu pi_n - (n+1) pi_{n-1}) / n`,
    /// `tau_n = n mu pi_n - (n+1) pi_{n-1}`; the terms even in `mu` and odd
    /// in `mu` are summed apart (`pi_n` has parity `(-1)^(n-1)`, `tau_n`
    /// `(-1)^n`), so `S(-mu)` is their difference.
    pub(crate) fn sums(&self, mu: f64, out: &mut Amplitudes) {
        let (mut pi_prev, mut pi) = (0.0, 1.0);
        let (mut s1e, mut s1o, mut s2e, mut s2o) =
            (Complex::default(), Complex::default(), Complex::default(), Complex::default());
        for i in 0..self.ca.len() {
            let n = (i + 1) as f64;
            let tau = n * mu * pi - (n + 1.0) * pi_prev;
            let (ca, cb) = (self.ca[i], self.cb[i]);
            // (S1, S2) terms (a pi + b tau, a tau + b pi): for odd n "pi" is
            // even in mu and "tau" odd; for even n the other way round.
            let (even_1, odd_1, even_2, odd_2) = if i % 2 == 0 {
                (ca.scale(pi), cb.scale(tau), cb.scale(pi), ca.scale(tau))
            } else {
                (cb.scale(tau), ca.scale(pi), ca.scale(tau), cb.scale(pi))
            };
            s1e = s1e + even_1;
            s1o = s1o + odd_1;
            s2e = s2e + even_2;
            s2o = s2o + odd_2;
            let (f1, f2) = self.rec[i];
            (pi_prev, pi) = (pi, f1 * mu * pi - f2 * pi_prev);
        }
        out.s1_plus = s1e + s1o;
        out.s2_plus = s2e + s2o;
        out.s1_minus = s1e - s1o;
        out.s2_minus = s2e - s2o;
    }
}

/// `S1`, `S2` at `mu` and `-mu` of the coefficients `a`, `b` (eq. M6; one
/// evaluation: [`AmplitudeTerms`] prepares the coefficients for many).
pub(crate) fn amplitude_sums(a: &[Complex], b: &[Complex], mu: f64, out: &mut Amplitudes) {
    AmplitudeTerms::new(a, b).sums(mu, out);
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Lentz's continued fraction against the downward recurrence started far
    /// above (where the start value no longer matters): 1e-13 relative.
    #[test]
    fn lentz_agrees_with_a_long_downward_recurrence() {
        for z in [Complex::new(1.5, 0.0), Complex::new(30.0, 2.0), Complex::new(0.75, 0.0)] {
            let n = 40;
            let cf = lentz_log_derivative(z, n);
            // Downward from 400 orders above with D = 0.
            let mut d = Complex::default();
            for k in ((n + 1)..=(n + 400)).rev() {
                let nz = z.recip() * k as f64;
                d = nz - (d + nz).recip();
            }
            assert!((cf - d).abs() < 1e-13 * d.abs(), "{z:?}: {cf:?} vs {d:?}");
        }
    }

    /// The series has converged: more orders (40; 8 below x = 0.1, where
    /// `chi_n(x)` would overflow beyond) change no efficiency, nor the
    /// backscatter amplitude, by more than 1e-14 relative (x = 1e-6 .. 10 000).
    #[test]
    fn series_orders_are_enough() {
        for &x in &[1e-6, 0.01, 0.3, 5.0, 60.0, 1000.0, 10_000.0] {
            for m in [Complex::new(1.33, 0.0), Complex::new(1.7, 0.1), Complex::new(0.75, 0.0)] {
                let s = Sphere::new(m, x).unwrap();
                let extra = if x < 0.1 { 8 } else { 40 };
                let (a, b) = coefficients(m, x, s.terms() + extra);
                let long = Sphere { m, x, a, b };
                let (b1, b2) = (s.amplitudes(-1.0).0, long.amplitudes(-1.0).0);
                for (u, v) in [
                    (s.q_ext(), long.q_ext()),
                    (s.q_sca(), long.q_sca()),
                    (s.g(), long.g()),
                    (s.q_back(), long.q_back()),
                    (b1.abs(), b2.abs()),
                ] {
                    assert!((u - v).abs() <= 1e-14 * v.abs(), "x = {x}, m = {m:?}: {u} vs {v}");
                }
            }
        }
    }

    /// The amplitudes' parity pass: S at -mu from the split sums equals a
    /// direct evaluation at -mu.
    #[test]
    fn parity_split_matches_direct_evaluation() {
        let s = Sphere::new(Complex::new(1.5, 0.01), 7.0).unwrap();
        let mut both = Amplitudes::default();
        amplitude_sums(&s.a, &s.b, 0.3, &mut both);
        let (d1, d2) = s.amplitudes(-0.3);
        assert!((both.s1_minus - d1).abs() < 1e-12 * d1.abs());
        assert!((both.s2_minus - d2).abs() < 1e-12 * d2.abs());
    }
}
