//! Legendre polynomials and normalised associated Legendre functions: the one
//! place their recurrences are written.
//!
//! * Plain polynomials by the three-term recurrence (Abramowitz & Stegun 8.5.3):
//!
//!   ```text
//!   P_0 = 1,  P_1 = x,  l P_l(x) = (2l - 1) x P_{l-1}(x) - (l - 1) P_{l-2}(x)   (LG1)
//!   ```
//!
//!   used by the Gauss rules ([`crate::quadrature`]) and the phase-function
//!   series of the multi-flux intensity correction.
//! * Normalised associated functions `Lambda_l^m(mu) = sqrt((l-m)!/(l+m)!) P_l^m(mu)`
//!   by the upward recurrence of DISORT's `LEPOLY` (Dave & Armstrong 1970;
//!   Stamnes et al. 1988 eq. 2–4 for the normalisation):
//!
//!   ```text
//!   Lambda_m^m     = prod_{i<=m} sqrt((2i-1)/(2i)) (1 - mu^2)^(m/2)
//!   Lambda_{m+1}^m = sqrt(2m+1) mu Lambda_m^m
//!   Lambda_l^m     = ((2l-1) mu Lambda_{l-1}^m - sqrt((l-1)^2 - m^2) Lambda_{l-2}^m)
//!                    / sqrt(l^2 - m^2)                                           (LG2)
//!   ```
//!
//!   used by the Fourier–Gauss phase matrix of the multi-flux solver (the
//!   addition theorem) and its probes. `Lambda_l^m(-mu) = (-1)^(l+m) Lambda_l^m(mu)`.

/// The Legendre polynomials `P_0(x), P_1(x), P_2(x), ...` by the recurrence
/// LG1, as an endless iterator (take as many degrees as needed).
///
/// # Reference
/// Abramowitz & Stegun (1964) 8.5.3.
///
/// Domain: any finite `x` (the polynomials; `|x| <= 1` keeps `|P_l| <= 1`).
///
/// ```
/// let p: Vec<f64> = km_core::legendre::legendre_polynomials(0.5).take(3).collect();
/// assert_eq!(p, vec![1.0, 0.5, -0.125]);
/// ```
pub fn legendre_polynomials(x: f64) -> impl Iterator<Item = f64> {
    let (mut p0, mut p1) = (1.0f64, x);
    (0usize..).map(move |l| match l {
        0 => 1.0,
        1 => x,
        _ => {
            let p2 = ((2 * l - 1) as f64 * x * p1 - (l - 1) as f64 * p0) / l as f64;
            p0 = p1;
            p1 = p2;
            p2
        }
    })
}

/// `(P_n(x), P_{n-1}(x))` by the recurrence LG1 (`(1, 0)` for `n = 0`): the
/// pair the Newton iterations of the Gauss rules need (`P_n'` follows from
/// `(x^2 - 1) P_n' = n (x P_n - P_{n-1})`).
///
/// # Reference
/// Abramowitz & Stegun (1964) 8.5.3 and 8.5.4.
///
/// Domain: any finite `x`, any `n`.
///
/// ```
/// let (p2, p1) = km_core::legendre::legendre_pair(2, 0.5);
/// assert_eq!((p2, p1), (-0.125, 0.5));
/// ```
pub fn legendre_pair(n: usize, x: f64) -> (f64, f64) {
    if n == 0 {
        return (1.0, 0.0);
    }
    let (mut p0, mut p1) = (1.0, x);
    for k in 2..=n {
        let p2 = ((2 * k - 1) as f64 * x * p1 - (k - 1) as f64 * p0) / k as f64;
        p0 = p1;
        p1 = p2;
    }
    (p1, p0)
}

/// The coefficients `(a_l, b_l) = ((2l-1)/l, (l-1)/l)` of the recurrence
/// LG1 divided through by `l`, `P_l = a_l x P_{l-1} - b_l P_{l-2}`, for
/// `l = 0..nl` (entries 0 and 1 are `(1, 0)`, unused): for hot loops that
/// evaluate the series at many cosines without a division per term (the
/// values differ from LG1 in the last bits only).
///
/// # Reference
/// Abramowitz & Stegun (1964) 8.5.3.
///
/// ```
/// let c = km_core::legendre::legendre_coefficients(3);
/// assert_eq!(c[2], (1.5, 0.5));
/// ```
pub fn legendre_coefficients(nl: usize) -> Vec<(f64, f64)> {
    (0..nl)
        .map(|l| {
            let lf = l.max(1) as f64;
            ((2.0 * lf - 1.0) / lf, (lf - 1.0) / lf)
        })
        .collect()
}

/// `Lambda_l^m(mu)` for `l = 0..out.len()` (zero for `l < m`) by the
/// recurrence LG2, its coefficients computed on the way
/// ([`LegendreRecurrence`] keeps them for many cosines).
///
/// # Reference
/// Dave & Armstrong (1970); Stamnes et al. (1988) eq. 2–4 (DISORT `LEPOLY`).
///
/// Domain: `-1 <= mu <= 1`, any `m`.
///
/// ```
/// let mut out = [0.0; 3];
/// km_core::legendre::normalized_legendre(1, 0.0, &mut out);
/// // Lambda_1^1(0) = sqrt(1/2) (1 - 0)^(1/2).
/// assert!((out[1] - 0.5f64.sqrt()).abs() < 1e-15 && out[0] == 0.0);
/// ```
pub fn normalized_legendre(m: usize, mu: f64, out: &mut [f64]) {
    out.iter_mut().for_each(|x| *x = 0.0);
    if m >= out.len() {
        return;
    }
    let sin = ((1.0 - mu) * (1.0 + mu)).max(0.0).sqrt();
    let mut pmm = 1.0;
    for i in 1..=m {
        pmm *= ((2 * i - 1) as f64 / (2 * i) as f64).sqrt() * sin;
    }
    out[m] = pmm;
    if m + 1 < out.len() {
        out[m + 1] = ((2 * m + 1) as f64).sqrt() * mu * pmm;
    }
    let mf = m as f64;
    for l in m + 2..out.len() {
        let lf = l as f64;
        out[l] = ((2.0 * lf - 1.0) * mu * out[l - 1]
            - ((lf - 1.0) * (lf - 1.0) - mf * mf).sqrt() * out[l - 2])
            / (lf * lf - mf * mf).sqrt();
    }
}

/// The recurrence LG2 for one order `m` and `nl` degrees with its
/// coefficients computed once (no square root per value):
/// `Lambda_m^m = c0 (1-mu^2)^(m/2)`, `Lambda_{m+1}^m = c1 mu Lambda_m^m`,
/// `Lambda_l^m = a_l mu Lambda_{l-1}^m - b_l Lambda_{l-2}^m`.
///
/// # Reference
/// Dave & Armstrong (1970); Stamnes et al. (1988) eq. 2–4.
///
/// ```
/// use km_core::legendre::{LegendreRecurrence, normalized_legendre};
/// let (mut a, mut b) = ([0.0; 8], [0.0; 8]);
/// LegendreRecurrence::new(2, 8).eval(0.3, &mut a);
/// normalized_legendre(2, 0.3, &mut b);
/// assert!(a.iter().zip(&b).all(|(x, y)| (x - y).abs() < 1e-15));
/// ```
#[derive(Debug, Clone)]
pub struct LegendreRecurrence {
    m: usize,
    a: Vec<f64>,
    b: Vec<f64>,
    c0: f64,
    c1: f64,
}

impl LegendreRecurrence {
    /// The coefficients for order `m` and degrees `l = 0..nl`.
    pub fn new(m: usize, nl: usize) -> Self {
        Self::new_in(m, nl, Vec::new(), Vec::new())
    }

    /// [`LegendreRecurrence::new`] in the vectors `a` and `b` (emptied and
    /// refilled: a caller that solves many orders reuses their allocations,
    /// see [`LegendreRecurrence::into_buffers`]).
    pub fn new_in(m: usize, nl: usize, mut a: Vec<f64>, mut b: Vec<f64>) -> Self {
        let mf = m as f64;
        a.clear();
        a.resize(nl, 0.0);
        b.clear();
        b.resize(nl, 0.0);
        for l in (m + 2).min(nl)..nl {
            let lf = l as f64;
            let d = (lf * lf - mf * mf).sqrt();
            a[l] = (2.0 * lf - 1.0) / d;
            b[l] = ((lf - 1.0) * (lf - 1.0) - mf * mf).sqrt() / d;
        }
        let c0: f64 = (1..=m).map(|i| ((2 * i - 1) as f64 / (2 * i) as f64).sqrt()).product();
        let c1 = ((2 * m + 1) as f64).sqrt();
        LegendreRecurrence { m, a, b, c0, c1 }
    }

    /// The coefficient vectors, for reuse by [`LegendreRecurrence::new_in`].
    pub fn into_buffers(self) -> (Vec<f64>, Vec<f64>) {
        (self.a, self.b)
    }

    /// `Lambda_l^m(mu)` for `l = 0..nl` into `out` (`nl` long; zero for `l < m`).
    pub fn eval(&self, mu: f64, out: &mut [f64]) {
        let (m, nl) = (self.m, self.a.len());
        if m >= nl {
            out.iter_mut().for_each(|x| *x = 0.0);
            return;
        }
        // Zeros below m; every value from m on is written below. (Tested
        // first: an empty fill is still a call of `memset`, and order 0
        // with `out` exactly `nl` long is the common case.)
        if m > 0 {
            out[..m].iter_mut().for_each(|x| *x = 0.0);
        }
        if out.len() > nl {
            out[nl..].iter_mut().for_each(|x| *x = 0.0);
        }
        let sin = ((1.0 - mu) * (1.0 + mu)).max(0.0).sqrt();
        let pmm = self.c0 * sin.powi(m as i32);
        out[m] = pmm;
        if m + 1 < nl {
            out[m + 1] = self.c1 * mu * pmm;
        }
        for l in m + 2..nl {
            out[l] = self.a[l] * mu * out[l - 1] - self.b[l] * out[l - 2];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn iterator_and_pair_agree_with_closed_forms() {
        // P_3(x) = (5x^3 - 3x)/2, P_4(x) = (35x^4 - 30x^2 + 3)/8: rounding only.
        for x in [-1.0, -0.3, 0.0, 0.7, 1.0] {
            let p: Vec<f64> = legendre_polynomials(x).take(5).collect();
            let p3 = 0.5 * (5.0 * x * x * x - 3.0 * x);
            let p4 = (35.0 * x.powi(4) - 30.0 * x * x + 3.0) / 8.0;
            assert!((p[3] - p3).abs() < 1e-15 && (p[4] - p4).abs() < 1e-15, "x = {x}");
            assert_eq!(legendre_pair(4, x), (p[4], p[3]));
        }
    }

    #[test]
    fn associated_functions_match_closed_forms() {
        // Lambda_2^1 = sqrt(1/6) P_2^1 = sqrt(1/6) 3 mu sqrt(1 - mu^2) (Condon–Shortley
        // phase dropped, as in DISORT); Lambda_2^2 = sqrt(1/24) 3 (1 - mu^2).
        let mu: f64 = 0.4;
        let mut out = [0.0; 3];
        normalized_legendre(1, mu, &mut out);
        let s = (1.0 - mu * mu).sqrt();
        assert!((out[2] - (1.0f64 / 6.0).sqrt() * 3.0 * mu * s).abs() < 1e-15);
        normalized_legendre(2, mu, &mut out);
        assert!((out[2] - (1.0f64 / 24.0).sqrt() * 3.0 * s * s).abs() < 1e-15);
    }
}
