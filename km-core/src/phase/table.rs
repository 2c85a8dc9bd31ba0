//! Phase functions as tables and as Legendre series, and the piecewise-linear
//! representation both share for fast evaluation and sampling.
//!
//! * [`Piecewise`]: `p` linear in `mu = cos t` between nodes on `[-1, 1]`,
//!   its cumulative distribution exact for that interpolant and inverted in
//!   closed form (a quadratic per interval, eq. P15), so sampling is exact
//!   for the interpolant.
//! * [`PhaseTable`]: a user's table of `(cos t, p)` pairs, normalised by km
//!   (`2 pi integral p dmu = 1` for the linear interpolant, eq. P16) and
//!   checked; its Legendre moments are exact for the interpolant (eq. P17,
//!   summation by parts against `R_l = integral integral P_l`).
//! * [`LegendreSeries`]: `p = sum_l (2l + 1) chi_l P_l / (4 pi)` from given
//!   moments (DISORT's `PMOM`, `chi_0 = 1`), evaluated by the recurrence LG1;
//!   its piecewise-linear interpolant (adaptive in angle, eq. P18) is built
//!   on first use for sampling and fast evaluation.

use std::f64::consts::PI;
use std::sync::OnceLock;

use super::Anisotropy;
use crate::error::CoreError;
use crate::legendre::legendre_coefficients;

/// Most moments computed of a table (the solvers use at most `2N + 1 = 1025`;
/// the rest serve the second-order intensity correction's tail).
pub const MAX_TABLE_MOMENTS: usize = 4096;

/// Most nodes of an adaptive interpolant (eq. P18).
const MAX_ADAPTIVE_NODES: usize = 1 << 16;

/// `p` piecewise linear in `mu` on nodes `-1 = mu_0 < ... < mu_K = 1`, with
/// its cumulative distribution `F(mu_k) = 2 pi integral_{-1}^{mu_k} p`.
#[derive(Clone, PartialEq)]
pub struct Piecewise {
    mu: Box<[f64]>,
    p: Box<[f64]>,
    cdf: Box<[f64]>,
}

impl Piecewise {
    /// From nodes and non-negative values (checked by the callers), scaled
    /// so that the interpolant integrates to 1 (eq. P16); returns it and the
    /// factor the values were divided by (`2 pi integral p` before).
    fn normalised(mu: Vec<f64>, mut p: Vec<f64>) -> (Piecewise, f64) {
        let mut cdf = vec![0.0; mu.len()];
        for k in 1..mu.len() {
            cdf[k] = cdf[k - 1] + PI * (mu[k] - mu[k - 1]) * (p[k] + p[k - 1]);
        }
        let total = cdf[mu.len() - 1];
        p.iter_mut().for_each(|v| *v /= total);
        cdf.iter_mut().for_each(|v| *v /= total);
        let last = cdf.len() - 1;
        cdf[last] = 1.0;
        (Piecewise { mu: mu.into(), p: p.into(), cdf: cdf.into() }, total)
    }

    /// The nodes `mu_k`, ascending from -1 to 1.
    pub fn mu(&self) -> &[f64] {
        &self.mu
    }

    /// The normalised values `p(mu_k)`, 1/sr.
    pub fn values(&self) -> &[f64] {
        &self.p
    }

    /// The interval `k` with `mu_k <= c <= mu_{k+1}`.
    fn interval(&self, c: f64) -> usize {
        let k = self.mu.partition_point(|&m| m <= c);
        k.clamp(1, self.mu.len() - 1) - 1
    }

    /// `p(c)` by linear interpolation, 1/sr.
    pub fn eval(&self, c: f64) -> f64 {
        let c = c.clamp(-1.0, 1.0);
        let k = self.interval(c);
        let (m0, m1) = (self.mu[k], self.mu[k + 1]);
        let t = (c - m0) / (m1 - m0);
        self.p[k] + t * (self.p[k + 1] - self.p[k])
    }

    /// The cosine with `F(c) = u` (eq. P15): on the interval where the
    /// cumulative distribution crosses `u`, `2 pi (p_k d + s d^2 / 2) = u - F_k`
    /// (`d = c - mu_k`, `s` the slope) solved without cancellation.
    pub fn sample(&self, u: f64) -> f64 {
        let u = u.clamp(0.0, 1.0);
        let k = (self.cdf.partition_point(|&f| f <= u)).clamp(1, self.cdf.len() - 1) - 1;
        let (m0, m1) = (self.mu[k], self.mu[k + 1]);
        let (p0, p1) = (self.p[k], self.p[k + 1]);
        let r = (u - self.cdf[k]) / (2.0 * PI);
        let h = m1 - m0;
        let s = (p1 - p0) / h;
        // s d^2 / 2 + p0 d - r = 0, d = 2 r / (p0 + sqrt(p0^2 + 2 s r)).
        let disc = (p0 * p0 + 2.0 * s * r).max(0.0);
        let den = p0 + disc.sqrt();
        let d = if den > 0.0 { 2.0 * r / den } else { 0.0 };
        (m0 + d.clamp(0.0, h)).clamp(-1.0, 1.0)
    }

    /// An adaptive interpolant of `f` (eq. P18): 257 nodes uniform in angle,
    /// each interval halved (in angle) while the midpoint's linear
    /// interpolation is off by more than 1e-5 of the value and by more than
    /// 1e-10 in probability; negative values are set to 0 and the most
    /// negative one returned with the interpolant (`(table, factor, min)`).
    fn adaptive(f: &dyn Fn(f64) -> f64) -> (Piecewise, f64, f64) {
        let k0 = 256;
        let start: Vec<f64> = (0..=k0).map(|k| PI * (k0 - k) as f64 / k0 as f64).collect();
        let mut theta = vec![start[0]];
        let mut vals = vec![f(start[0].cos())];
        // Left to right: refine the interval from the last node kept to the
        // top of the stack until it is fine, then keep its right end.
        let mut stack: Vec<(f64, f64)> = Vec::new();
        for &tb in start[1..].iter() {
            stack.push((tb, f(tb.cos())));
            while let Some(&(tb, vb)) = stack.last() {
                let (ta, va) = (theta[theta.len() - 1], vals[vals.len() - 1]);
                let tm = 0.5 * (ta + tb);
                let (ma, mb, mm) = (ta.cos(), tb.cos(), tm.cos());
                let vm = f(mm);
                let lerp = va + (mm - ma) / (mb - ma) * (vb - va);
                let err = (vm - lerp).abs();
                let fine = err <= 1e-5 * vm.abs() || err * (mb - ma) * 2.0 * PI <= 1e-10;
                let full = theta.len() + stack.len() >= MAX_ADAPTIVE_NODES;
                if fine || (ta - tb) < 1e-7 || full {
                    theta.push(tb);
                    vals.push(vb);
                    stack.pop();
                } else {
                    stack.push((tm, vm));
                }
            }
        }
        let min = vals.iter().copied().fold(f64::INFINITY, f64::min);
        let mut mu: Vec<f64> = theta.iter().map(|t| t.cos()).collect();
        mu[0] = -1.0;
        let last = mu.len() - 1;
        mu[last] = 1.0;
        let p = vals.iter().map(|v| v.max(0.0)).collect();
        let (pw, total) = Piecewise::normalised(mu, p);
        (pw, total, min)
    }
}

impl std::fmt::Debug for Piecewise {
    /// A summary: the node count and the end values (a table may hold 10^5 nodes).
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let n = self.p.len();
        write!(f, "Piecewise {{ nodes: {n}, p(-1): {:e}, p(1): {:e} }}", self.p[0], self.p[n - 1])
    }
}

/// A user's phase function table (eq. P16, P17).
#[derive(Clone, PartialEq)]
pub struct PhaseTable {
    table: Piecewise,
    /// `2 pi integral p dmu` of the values as given (1 for a normalised table).
    given_norm: f64,
    moments: Box<[f64]>,
}

impl PhaseTable {
    /// A table from `(cos t, p)` pairs: `cos t` strictly monotone (ascending
    /// or descending) from -1 to 1 (ends within 1e-9, set exactly), `p >= 0`
    /// finite, not all zero; `p` is linear in `cos t` between the nodes and
    /// normalised by km (eq. P16).
    ///
    /// # Errors
    /// Fewer than 2 pairs, lists of different lengths, values that are not
    /// finite, negative `p`, a zero table, cosines outside `[-1, 1]`, not
    /// strictly monotone or not reaching both ends, or a mean cosine of
    /// magnitude 1 (a delta function).
    ///
    /// ```
    /// use km_core::phase::PhaseTable;
    /// // Isotropic, given unnormalised.
    /// let t = PhaseTable::new(&[-1.0, 1.0], &[2.0, 2.0]).unwrap();
    /// assert!((t.eval(0.3) - 0.25 / std::f64::consts::PI).abs() < 1e-15);
    /// assert!((t.given_norm() - 8.0 * std::f64::consts::PI).abs() < 1e-12);
    /// ```
    pub fn new(cos_theta: &[f64], p: &[f64]) -> Result<PhaseTable, CoreError> {
        let (mu, p) = check_table(cos_theta, p)?;
        let (table, given_norm) = Piecewise::normalised(mu, p);
        let moments = table_moments(&table, MAX_TABLE_MOMENTS);
        if !Anisotropy::admits(moments[1]) {
            return Err(CoreError::invalid(
                "table mean cosine",
                moments[1],
                "must satisfy |g| < 1",
            ));
        }
        Ok(PhaseTable { table, given_norm, moments })
    }

    /// `2 pi integral p dmu` of the table as given (what km divided by).
    pub fn given_norm(&self) -> f64 {
        self.given_norm
    }

    /// The normalised table.
    pub fn table(&self) -> &Piecewise {
        &self.table
    }

    /// The moments `chi_0 = 1 .. chi_L`, `L = ` [`MAX_TABLE_MOMENTS`] `- 1` (eq. P17).
    pub fn moments(&self) -> &[f64] {
        &self.moments
    }

    /// `p(c)`, 1/sr.
    pub fn eval(&self, c: f64) -> f64 {
        self.table.eval(c)
    }
}

impl std::fmt::Debug for PhaseTable {
    /// A summary (the table and its 4096 moments would fill a screen).
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "PhaseTable {{ table: {:?}, given_norm: {:e}, g: {} }}",
            self.table, self.given_norm, self.moments[1]
        )
    }
}

/// The checks of [`PhaseTable::new`]; returns the pairs ascending in `cos t`.
fn check_table(cos_theta: &[f64], p: &[f64]) -> Result<(Vec<f64>, Vec<f64>), CoreError> {
    let n = cos_theta.len();
    if n != p.len() {
        return Err(CoreError::invalid(
            "table",
            p.len() as f64,
            &format!("{} values of p for {n} cosines", p.len()),
        ));
    }
    if n < 2 {
        return Err(CoreError::invalid("table", n as f64, "needs at least 2 pairs"));
    }
    if let Some(&v) = cos_theta.iter().find(|v| !v.is_finite() || v.abs() > 1.0 + 1e-9) {
        return Err(CoreError::invalid("cos_theta", v, "must lie in [-1, 1]"));
    }
    if let Some(&v) = p.iter().find(|v| !v.is_finite() || **v < 0.0) {
        return Err(CoreError::invalid("p", v, "must be finite and >= 0"));
    }
    let (mut mu, mut pv) = (cos_theta.to_vec(), p.to_vec());
    if mu[0] > mu[n - 1] {
        mu.reverse();
        pv.reverse();
    }
    if let Some(k) = (1..n).find(|&k| mu[k] <= mu[k - 1]) {
        return Err(CoreError::invalid("cos_theta", mu[k], "must be strictly monotone"));
    }
    if (mu[0] + 1.0).abs() > 1e-9 || (mu[n - 1] - 1.0).abs() > 1e-9 {
        return Err(CoreError::invalid(
            "cos_theta",
            if (mu[0] + 1.0).abs() > 1e-9 { mu[0] } else { mu[n - 1] },
            "the table must span cos_theta from -1 to 1 (theta from 180 to 0 degrees)",
        ));
    }
    mu[0] = -1.0;
    mu[n - 1] = 1.0;
    let mass: f64 = (1..n).map(|k| (mu[k] - mu[k - 1]) * (pv[k] + pv[k - 1])).sum();
    if mass.is_nan() || mass <= 0.0 {
        return Err(CoreError::invalid("p", 0.0, "the table is zero everywhere"));
    }
    Ok((mu, pv))
}

/// The moments `chi_0 .. chi_{n-1}` of a piecewise-linear `p` (eq. P17):
/// `chi_0 = 1`, `chi_1` per interval, and for `l >= 2`
/// `chi_l = 2 pi sum_k R_l(mu_k) (s_k - s_{k-1})` over the inner nodes, with
/// `s_k` the slope on interval `k` and
/// `R_l = [(P_{l+2} - P_l)/(2l + 3) - (P_l - P_{l-2})/(2l - 1)] / (2l + 1)`.
fn table_moments(t: &Piecewise, n: usize) -> Box<[f64]> {
    let (mu, p) = (&t.mu, &t.p);
    let kn = mu.len();
    let mut chi = vec![0.0; n];
    chi[0] = 1.0;
    // chi_1 = 2 pi sum_k integral (p_k + s_k (x - mu_k)) x dx.
    let mut c1 = 0.0;
    for k in 0..kn - 1 {
        let (a, b) = (mu[k], mu[k + 1]);
        let s = (p[k + 1] - p[k]) / (b - a);
        let i1 = 0.5 * (b * b - a * a);
        let i2 = (b * b * b - a * a * a) / 3.0;
        c1 += (p[k] - s * a) * i1 + s * i2;
    }
    if n > 1 {
        chi[1] = 2.0 * PI * c1;
    }
    let coef = legendre_coefficients(n + 2);
    let mut pl = vec![0.0; n + 2];
    for k in 1..kn - 1 {
        let s_prev = (p[k] - p[k - 1]) / (mu[k] - mu[k - 1]);
        let s_next = (p[k + 1] - p[k]) / (mu[k + 1] - mu[k]);
        let jump = s_next - s_prev;
        if jump == 0.0 {
            continue;
        }
        let x = mu[k];
        pl[0] = 1.0;
        pl[1] = x;
        for l in 2..n + 2 {
            let (al, bl) = coef[l];
            pl[l] = al * x * pl[l - 1] - bl * pl[l - 2];
        }
        for (l, c) in chi.iter_mut().enumerate().skip(2).take(n.saturating_sub(2)) {
            let lf = l as f64;
            let r = ((pl[l + 2] - pl[l]) / (2.0 * lf + 3.0)
                - (pl[l] - pl[l - 2]) / (2.0 * lf - 1.0))
                / (2.0 * lf + 1.0);
            *c += 2.0 * PI * r * jump;
        }
    }
    chi.into()
}

/// A phase function given by its Legendre moments (DISORT's `PMOM`,
/// `chi_0 = 1`): `p = sum_{l<=L} (2l + 1) chi_l P_l / (4 pi)`.
pub struct LegendreSeries {
    moments: Box<[f64]>,
    /// The adaptive interpolant (eq. P18) and the series' least value,
    /// built on first use.
    lookup: OnceLock<(Piecewise, f64)>,
}

impl std::fmt::Debug for LegendreSeries {
    /// A summary: the number of moments and the first ones.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let m = &self.moments;
        write!(f, "LegendreSeries {{ moments: {}, chi: {:?}", m.len(), &m[..m.len().min(4)])?;
        write!(f, "{} }}", if m.len() > 4 { ", ..." } else { "" })
    }
}

impl Clone for LegendreSeries {
    fn clone(&self) -> Self {
        LegendreSeries { moments: self.moments.clone(), lookup: OnceLock::new() }
    }
}

impl PartialEq for LegendreSeries {
    fn eq(&self, other: &Self) -> bool {
        self.moments == other.moments
    }
}

impl LegendreSeries {
    /// A series from `chi_1 .. chi_L` (`chi_0 = 1` implied, as DISORT's PMOM
    /// from index 1); trailing zeros are dropped.
    ///
    /// # Errors
    /// A moment not finite or of magnitude above 1 (DISORT's check of PMOM),
    /// or `|chi_1| = 1` (a delta function).
    ///
    /// ```
    /// use km_core::phase::LegendreSeries;
    /// // Rayleigh: chi_2 = 0.1.
    /// let s = LegendreSeries::new(&[0.0, 0.1]).unwrap();
    /// assert!((s.eval(1.0) - 3.0 / (8.0 * std::f64::consts::PI)).abs() < 1e-15);
    /// assert!(LegendreSeries::new(&[1.2]).is_err());
    /// ```
    pub fn new(moments_from_1: &[f64]) -> Result<LegendreSeries, CoreError> {
        for (i, &c) in moments_from_1.iter().enumerate() {
            if !c.is_finite() || c.abs() > 1.0 {
                return Err(CoreError::invalid(
                    &format!("moments[{}] (chi_{})", i, i + 1),
                    c,
                    "Legendre moments must be finite with |chi_l| <= 1",
                ));
            }
        }
        if moments_from_1.first().is_some_and(|c| c.abs() >= 1.0) {
            return Err(CoreError::invalid(
                "chi_1",
                moments_from_1[0],
                "|chi_1| = |g| must be < 1",
            ));
        }
        let mut m = Vec::with_capacity(moments_from_1.len() + 1);
        m.push(1.0);
        m.extend_from_slice(moments_from_1);
        while m.len() > 1 && m[m.len() - 1] == 0.0 {
            m.pop();
        }
        Ok(LegendreSeries { moments: m.into(), lookup: OnceLock::new() })
    }

    /// `chi_0 = 1 .. chi_L` (no trailing zero).
    pub fn moments(&self) -> &[f64] {
        &self.moments
    }

    /// `p(c)` by the series (recurrence LG1), 1/sr.
    pub fn eval(&self, c: f64) -> f64 {
        series_sum(&self.moments, c, |x| x) / (4.0 * PI)
    }

    /// The phase function of moments `chi_l^2`, 1/sr.
    pub fn eval_convolved(&self, c: f64) -> f64 {
        series_sum(&self.moments, c, |x| x * x) / (4.0 * PI)
    }

    /// The adaptive interpolant (built once) and the series' least value on it.
    pub fn lookup(&self) -> &(Piecewise, f64) {
        self.lookup.get_or_init(|| {
            let (t, _, min) = Piecewise::adaptive(&|c| self.eval(c));
            (t, min)
        })
    }
}

/// `sum_l (2l + 1) f(chi_l) P_l(c)` by the recurrence LG1.
pub(crate) fn series_sum(chi: &[f64], c: f64, f: impl Fn(f64) -> f64) -> f64 {
    let c = c.clamp(-1.0, 1.0);
    let mut sum = f(chi[0]);
    if chi.len() > 1 {
        sum += 3.0 * f(chi[1]) * c;
    }
    let (mut p0, mut p1) = (1.0, c);
    for (l, &x) in chi.iter().enumerate().skip(2) {
        let lf = l as f64;
        let p = ((2.0 * lf - 1.0) * c * p1 - (lf - 1.0) * p0) / lf;
        sum += (2.0 * lf + 1.0) * f(x) * p;
        (p0, p1) = (p1, p);
    }
    sum
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::quadrature::gauss_legendre;

    /// Moments of a table (eq. P17) against Gauss quadrature of its
    /// interpolant interval by interval (exact for polynomials, 1e-13).
    #[test]
    fn table_moments_match_quadrature() {
        let mu = [-1.0, -0.5, 0.1, 0.6, 0.9, 1.0];
        let p = [0.05, 0.08, 0.1, 0.4, 1.5, 4.0];
        let t = PhaseTable::new(&mu, &p).unwrap();
        let (x, w) = gauss_legendre(40);
        for l in [0usize, 1, 2, 3, 7, 30] {
            let mut q = 0.0;
            for k in 0..mu.len() - 1 {
                let (a, b) = (mu[k], mu[k + 1]);
                let (h, m) = (0.5 * (b - a), 0.5 * (b + a));
                for (xi, wi) in x.iter().zip(&w) {
                    let c = m + h * xi;
                    q += 2.0 * PI * h * wi * t.eval(c) * crate::legendre::legendre_pair(l, c).0;
                }
            }
            assert!((q - t.moments()[l]).abs() < 1e-13, "l = {l}: {q} vs {}", t.moments()[l]);
        }
    }

    /// Sampling the interpolant is exact: the cumulative distribution at the
    /// sample is `u` (1e-12).
    #[test]
    fn piecewise_sampling_inverts_its_cdf() {
        let t = PhaseTable::new(&[1.0, 0.8, 0.0, -1.0], &[3.0, 1.0, 0.2, 0.3]).unwrap();
        let pw = t.table();
        for k in 0..=20 {
            let u = k as f64 / 20.0;
            let c = pw.sample(u);
            let j = pw.interval(c);
            let (m0, p0) = (pw.mu[j], pw.p[j]);
            let pc = pw.eval(c);
            let f = pw.cdf[j] + PI * (c - m0) * (p0 + pc);
            assert!((f - u).abs() < 1e-12, "u = {u}: F = {f}");
        }
    }

    #[test]
    fn bad_tables_are_refused() {
        assert!(PhaseTable::new(&[-1.0, 0.5], &[1.0, 1.0]).is_err());
        assert!(PhaseTable::new(&[-1.0, 0.5, 0.2, 1.0], &[1.0; 4]).is_err());
        assert!(PhaseTable::new(&[-1.0, 1.0], &[1.0, -1.0]).is_err());
        assert!(PhaseTable::new(&[-1.0, 1.0], &[0.0, 0.0]).is_err());
        assert!(PhaseTable::new(&[-1.0, 1.0], &[1.0]).is_err());
    }
}
