//! Gauss quadrature rules on `[-1, 1]`: Gauss–Legendre (every crate's angular
//! and radial integrals) and Gauss–Radau with a fixed node at `x = 1` (the
//! normal-incidence ring of the multi-flux direction sets).
//!
//! ```text
//!   integral_{-1}^{1} f(x) dx ~ sum_i w_i f(x_i)                          (QR1)
//! ```
//!
//! * Gauss–Legendre: `x_i` the roots of `P_n`, `w_i = 2 / ((1 - x_i^2) P_n'(x_i)^2)`,
//!   exact to degree `2n - 1` (Abramowitz & Stegun 25.4.29).
//! * Gauss–Radau (fixed node `x = 1`): the free nodes are the roots of
//!   `P_{n-1}(x) - P_n(x)` in `(-1, 1)`, `w_i = (1 + x_i) / (n^2 P_{n-1}(x_i)^2)`,
//!   the fixed node has `w = 2 / n^2`; exact to degree `2n - 2`
//!   (Abramowitz & Stegun 25.4.31, reflected).
//!
//! Both find their nodes by Newton's method on the polynomials of
//! [`crate::legendre`] (recurrence LG1).

use std::f64::consts::PI;
use std::sync::OnceLock;

use crate::CoreError;
use crate::legendre::legendre_pair;

/// Gauss–Legendre nodes and weights on `[-1, 1]` (eq. QR1), nodes ascending
/// (Newton on `P_n` from Tricomi's initial guess; Golub–Welsch is not needed
/// at these sizes). Accurate to ~1e-15 for `n <= 1000`.
///
/// # Reference
/// Abramowitz & Stegun (1964) 25.4.29; recurrence LG1 of [`crate::legendre`].
///
/// Domain: `n >= 0` (`n = 0` gives the empty rule).
///
/// ```
/// let (x, w) = km_core::quadrature::gauss_legendre(3);
/// // Exact for x^4 (degree <= 5): integral = 2/5.
/// let m: f64 = x.iter().zip(&w).map(|(x, w)| w * x.powi(4)).sum();
/// assert!((m - 0.4).abs() < 1e-15);
/// ```
pub fn gauss_legendre(n: usize) -> (Vec<f64>, Vec<f64>) {
    let mut x = vec![0.0; n];
    let mut w = vec![0.0; n];
    let m = n.div_ceil(2);
    for i in 0..m {
        // Initial guess (Tricomi), then Newton iterations on P_n.
        let mut z = (PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
        let mut dp = 1.0;
        for _ in 0..100 {
            let (p1, p0) = legendre_pair(n, z);
            // P_n' from (z^2 - 1) P_n' = n (z P_n - P_{n-1}).
            dp = n as f64 * (z * p1 - p0) / (z * z - 1.0);
            let dz = p1 / dp;
            z -= dz;
            if dz.abs() < 1e-16 {
                break;
            }
        }
        x[i] = -z;
        x[n - 1 - i] = z;
        w[i] = 2.0 / ((1.0 - z * z) * dp * dp);
        w[n - 1 - i] = w[i];
    }
    (x, w)
}

/// `integral_a^b f` by the `n`-point Gauss–Legendre rule (eq. QR1 mapped
/// onto `[a, b]`). The 24-point rule of the hemispherical Fresnel integrals
/// is computed once per process.
///
/// # Reference
/// Abramowitz & Stegun (1964) 25.4.30.
///
/// Domain: finite `a`, `b`; `f` smooth on `[a, b]` for the rule to converge.
///
/// ```
/// let s = km_core::quadrature::integrate_gl(|x| x * x, 0.0, 3.0, 4);
/// assert!((s - 9.0).abs() < 1e-13);
/// ```
pub fn integrate_gl(f: impl Fn(f64) -> f64, a: f64, b: f64, n: usize) -> f64 {
    let (h, c) = (0.5 * (b - a), 0.5 * (b + a));
    let sum =
        |x: &[f64], w: &[f64]| x.iter().zip(w).map(|(xi, wi)| wi * f(c + h * xi)).sum::<f64>();
    if n == CACHED_NODES {
        let (x, w) = CACHED_RULE.get_or_init(|| gauss_legendre(CACHED_NODES));
        return sum(x, w) * h;
    }
    let (x, w) = gauss_legendre(n);
    sum(&x, &w) * h
}

/// Nodes of the rule kept for the process (the sub-interval rule of
/// [`crate::fresnel::diffuse_reflectance`]).
pub(crate) const CACHED_NODES: usize = 24;
static CACHED_RULE: OnceLock<(Vec<f64>, Vec<f64>)> = OnceLock::new();

/// Gauss–Radau rule on `[-1, 1]` with the fixed node `x = 1`, `n >= 1` points,
/// exact for polynomials of degree `2n - 2`: returned with the fixed node
/// first, then descending.
///
/// # Reference
/// Abramowitz & Stegun (1964) 25.4.31 (reflected to put the fixed node at `+1`).
///
/// # Errors
/// [`CoreError::Invalid`] for `n = 0` or if Newton's method fails (the
/// weights must sum to 2 within 1e-10).
///
/// ```
/// let (x, w) = km_core::quadrature::gauss_radau_upper(3).unwrap();
/// assert_eq!(x[0], 1.0);
/// // Exact to degree 4: integral of x^4 = 2/5.
/// let m: f64 = x.iter().zip(&w).map(|(x, w)| w * x.powi(4)).sum();
/// assert!((m - 0.4).abs() < 1e-14);
/// ```
pub fn gauss_radau_upper(n: usize) -> Result<(Vec<f64>, Vec<f64>), CoreError> {
    if n == 0 {
        return Err(CoreError::invalid("radau points", 0.0, "need at least one point"));
    }
    let nf = n as f64;
    let mut x = vec![1.0];
    let mut w = vec![2.0 / (nf * nf)];
    for k in 1..n {
        // Chebyshev–Radau node as the initial guess, then Newton on
        // f = P_{n-1} - P_n, f' from P_k' = k (x P_k - P_{k-1}) / (x^2 - 1).
        let mut z = (2.0 * PI * k as f64 / (2.0 * nf - 1.0)).cos();
        for _ in 0..100 {
            let (pn, pn1) = legendre_pair(n, z);
            let (_, pn2) = legendre_pair(n - 1, z);
            let f = pn1 - pn;
            let dpn = nf * (z * pn - pn1) / (z * z - 1.0);
            let dpn1 = if n >= 2 { (nf - 1.0) * (z * pn1 - pn2) / (z * z - 1.0) } else { 0.0 };
            let dz = f / (dpn1 - dpn);
            z -= dz;
            if dz.abs() < 1e-15 {
                break;
            }
        }
        let (_, pn1) = legendre_pair(n, z);
        x.push(z);
        w.push((1.0 + z) / (nf * nf * pn1 * pn1));
    }
    // The rule must integrate 1 exactly; anything else means Newton failed.
    let total: f64 = w.iter().sum();
    if (total - 2.0).abs() > 1e-10 || x.iter().any(|v| !v.is_finite() || v.abs() > 1.0) {
        return Err(CoreError::invalid(
            "radau points",
            nf,
            "Newton's method did not converge (the weights do not sum to 2)",
        ));
    }
    Ok((x, w))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gauss_legendre_integrates_polynomials_exactly() {
        let (x, w) = gauss_legendre(8);
        let s: f64 = w.iter().sum();
        assert!((s - 2.0).abs() < 1e-14);
        // Degree 15 is exact for 8 points: integral of x^14 = 2/15.
        let m: f64 = x.iter().zip(&w).map(|(a, b)| b * a.powi(14)).sum();
        assert!((m - 2.0 / 15.0).abs() < 1e-14);
        // One point: the midpoint rule.
        assert_eq!(gauss_legendre(1), (vec![0.0], vec![2.0]));
    }

    #[test]
    fn gauss_radau_is_exact_to_degree_2n_minus_2_and_not_beyond() {
        for n in 1..12usize {
            let (x, w) = gauss_radau_upper(n).unwrap();
            for d in 0..=(2 * n - 2) {
                let exact = if d % 2 == 0 { 2.0 / (d + 1) as f64 } else { 0.0 };
                let q: f64 = x.iter().zip(&w).map(|(x, w)| w * x.powi(d as i32)).sum();
                assert!((q - exact).abs() < 1e-13, "n = {n}, degree {d}");
            }
            // Degree 2n - 1 is not integrated exactly (the rule is not Gauss).
            let d = 2 * n - 1;
            let exact = if d % 2 == 0 { 2.0 / (d + 1) as f64 } else { 0.0 };
            let q: f64 = x.iter().zip(&w).map(|(x, w)| w * x.powi(d as i32)).sum();
            assert!((q - exact).abs() > 1e-6, "n = {n}");
        }
        assert!(gauss_radau_upper(0).is_err());
    }
}
