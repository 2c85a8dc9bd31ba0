//! Divided differences of the exponential `f(t) = exp(-t d)` at
//! non-negative arguments, evaluated without cancellation (eq. K19–K20 of
//! docs/two-flux.md).
//!
//! The collimated–diffuse responses of a layer are sums of integrals
//! `int_0^d exp(-a z) exp(-b (d - z)) dz`, which are first divided
//! differences of `f`, and of their divided differences in a third
//! argument. Written out they contain `1 / (a - b)` (the resonance of the
//! collimated beam with a diffuse mode, `beta = lambda`) and `1 / lambda`
//! (conservative scattering); as divided differences they are smooth in all
//! their arguments and are evaluated here by a short Taylor series when the
//! arguments are close (`|a - b| d <= 1`) and by the recursion otherwise,
//! where the subtraction loses at most a factor 3.
//!
//! `d = inf` (a half-space) is allowed: `f(t) = 0` for `t > 0`, `f(0) = 1`.

/// `E1(a, b) = -f[a, b] = (exp(-b d) - exp(-a d)) / (a - b)
/// = int_0^d exp(-a z) exp(-b (d - z)) dz >= 0` (eq. K19), for `a, b >= 0`.
///
/// Evaluated as `exp(-min(a, b) d) (1 - exp(-|a - b| d)) / |a - b|` with
/// `expm1`, and as `exp(-a d) d` when `a = b`: every factor is bounded and
/// positive. For `d = inf` it is `1 / max(a, b)` when `min(a, b) = 0`, else 0.
pub(crate) fn e1(a: f64, b: f64, d: f64) -> f64 {
    let (lo, hi) = if a <= b { (a, b) } else { (b, a) };
    if d.is_infinite() {
        return if lo > 0.0 {
            0.0
        } else if hi > 0.0 {
            1.0 / hi
        } else {
            f64::INFINITY
        };
    }
    let decay = (-lo * d).exp();
    let gap = hi - lo;
    if gap == 0.0 {
        return decay * d;
    }
    // 1 - exp(-gap d) to full relative accuracy even for gap d << 1.
    decay * (-(-gap * d).exp_m1()) / gap
}

/// Taylor terms of `exp(-u)[0, u1, u2]` kept: with `u1, u2 <= 1` the term
/// `k` is at most `(k - 1) / k!`, below `1e-20` from `k = 24` on.
const SERIES_TERMS: usize = 26;

/// `E2(a, b, c) = f[a, b, c] >= 0` (eq. K20), symmetric in its arguments,
/// for `a, b, c >= 0`.
///
/// With the arguments sorted, `x0 <= x1 <= x2`, and `u_i = (x_i - x0) d`:
/// `f[x0, x1, x2] = exp(-x0 d) d^2 g[0, u1, u2]`, `g(u) = exp(-u)`. When
/// `u2 <= 1` the divided difference of `g` is the series
/// `sum_{k >= 2} (-1)^k / k! h_{k-2}(u1, u2)` (`h_n` the complete
/// homogeneous symmetric polynomial, `h_n = u2 h_{n-1} + u1^n`), whose sum is
/// at least `exp(-1) / 2` against terms of at most `1/2`; otherwise the
/// recursion `(E1(x0, x1) - E1(x1, x2)) / (x2 - x0)`, whose two terms differ
/// by a factor of at least `exp(1/2)`. For `d = inf`: `1 / (x1 x2)` when
/// `x0 = 0 < x1`, 0 when `x0 > 0`, infinite when `x0 = x1 = 0`.
pub(crate) fn e2(a: f64, b: f64, c: f64, d: f64) -> f64 {
    let mut x = [a, b, c];
    x.sort_by(f64::total_cmp);
    let [x0, x1, x2] = x;
    if d.is_infinite() {
        return if x0 > 0.0 {
            0.0
        } else if x1 > 0.0 {
            1.0 / (x1 * x2)
        } else {
            f64::INFINITY
        };
    }
    if (x2 - x0) * d > 1.0 { e2_recursion(x0, x1, x2, d) } else { e2_series(x0, x1, x2, d) }
}

/// `f[x0, x1, x2]` by the recursion (sorted arguments, `(x2 - x0) d > 1`).
fn e2_recursion(x0: f64, x1: f64, x2: f64, d: f64) -> f64 {
    (e1(x0, x1, d) - e1(x1, x2, d)) / (x2 - x0)
}

/// `f[x0, x1, x2]` by the Taylor series of `exp(-u)[0, u1, u2]` (sorted
/// arguments, `(x2 - x0) d <= 1`).
fn e2_series(x0: f64, x1: f64, x2: f64, d: f64) -> f64 {
    let (u1, u2) = ((x1 - x0) * d, (x2 - x0) * d);
    let (mut h, mut u1_pow, mut fact, mut sum) = (1.0, 1.0, 2.0, 0.5);
    for k in 3..SERIES_TERMS {
        u1_pow *= u1;
        h = u2 * h + u1_pow;
        fact *= k as f64;
        let term = h / fact;
        sum += if k % 2 == 0 { term } else { -term };
    }
    (-x0 * d).exp() * d * d * sum
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `E1` against its definition as an integral (Gauss–Legendre, 64
    /// nodes on 8 panels: exact to rounding for these smooth integrands).
    fn e1_quad(a: f64, b: f64, d: f64) -> f64 {
        let mut sum = 0.0;
        for p in 0..8 {
            let (lo, hi) = (d * p as f64 / 8.0, d * (p + 1) as f64 / 8.0);
            sum += crate::quadrature::integrate_gl(|z| (-a * z - b * (d - z)).exp(), lo, hi, 24);
        }
        sum
    }

    #[test]
    fn e1_matches_the_integral_across_the_resonance() {
        for &(a, b, d) in &[
            (1.0, 2.0, 1.5),
            (2.0, 2.0, 1.5),
            (2.0, 2.0 + 1e-12, 1.5),
            (0.0, 3.0, 0.7),
            (5.0, 0.0, 3.0),
            (1e-9, 0.0, 2.0),
            (30.0, 29.5, 1.0),
        ] {
            let q = e1_quad(a, b, d);
            let e = e1(a, b, d);
            assert!((e - q).abs() <= 1e-14 * q.max(1e-300), "E1({a}, {b}, {d}) = {e} vs {q}");
        }
    }

    /// `E2` at coincident arguments, `f[x, x, x] = f''(x) / 2 = d^2 exp(-x d) / 2`,
    /// the series and the recursion equal where both are accurate (spreads
    /// `u2` from 0.7 to 1.5 around the switch at 1; the recursion loses at
    /// most a factor 3 there), and the half-space values.
    #[test]
    fn e2_limits_and_the_switch_agree() {
        let d = 2.0f64;
        for x in [0.0f64, 0.3, 4.0] {
            let exact = d * d * (-x * d).exp() / 2.0;
            assert!((e2(x, x, x, d) - exact).abs() <= 2e-16 * exact.max(1e-300));
        }
        for (x1, x2) in [(0.3, 0.45), (0.3, 0.6), (0.12, 0.6), (0.59, 0.6), (0.5, 0.85)] {
            let (series, recursion) = (e2_series(0.1, x1, x2, d), e2_recursion(0.1, x1, x2, d));
            assert!((series - recursion).abs() < 4e-15 * series, "{series} vs {recursion}");
        }
        // Half-space values.
        assert_eq!(e2(0.0, 2.0, 4.0, f64::INFINITY), 1.0 / 8.0);
        assert_eq!(e2(0.5, 2.0, 4.0, f64::INFINITY), 0.0);
        assert_eq!(e1(0.0, 4.0, f64::INFINITY), 0.25);
    }

    /// `E2(a, b, c)` is `(E1(a, b) - E1(a, c)) / (c - b)` where the latter is
    /// well conditioned (arguments far apart).
    #[test]
    fn e2_is_the_divided_difference_of_e1() {
        let d = 1.3;
        for &(a, b, c) in &[(0.0, 2.0, 5.0), (1.0, 1.5, 3.0), (0.2, 0.4, 0.9), (3.0, 0.1, 0.7)] {
            let rec = (e1(a, b, d) - e1(a, c, d)) / (c - b);
            let v = e2(a, b, c, d);
            assert!((v - rec).abs() <= 1e-13 * v, "E2({a}, {b}, {c}) = {v} vs {rec}");
        }
    }
}
