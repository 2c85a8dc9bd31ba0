//! The Fourier components of the phase function in azimuth (tables of the
//! normalised associated Legendre functions of [`km_core::legendre`]) and
//! delta-M scaling.
//!
//! With `Lambda_l^m(mu) = sqrt((l-m)!/(l+m)!) P_l^m(mu)` the addition theorem
//! gives, for a phase function with Legendre moments `chi_l`
//! (`p = (1/4pi) sum_l (2l+1) chi_l P_l(cos Theta)`),
//!
//! ```text
//!   p(s, s') = sum_m (2 - delta_m0)/(2 pi) p^m(mu, mu') cos m(phi - phi')     (L1)
//!   p^m(mu, mu') = 1/2 sum_{l>=m} (2l+1) chi_l Lambda_l^m(mu) Lambda_l^m(mu')  (L2)
//! ```
//!
//! and the scattering integral of the Fourier component `I^m` of the
//! radiance is `integral_{-1}^{1} p^m(mu, mu') I^m(mu') dmu'` (DISORT,
//! Stamnes et al. 1988 eq. 2–4; the normalisation of Lambda is theirs).
//! `Lambda_l^m(-mu) = (-1)^(l+m) Lambda_l^m(mu)`.
//!
//! Delta-M (Wiscombe 1977): with `f = chi_L` (`L` = number of moments kept),
//! `chi*_l = (chi_l - f)/(1 - f)`, `omega* = omega (1 - f)/(1 - omega f)`,
//! `tau* = tau (1 - omega f)`  (eq. L3).

/// The normalised associated Legendre functions `Lambda_l^m` and their
/// recurrence live in [`km_core::legendre`] (eq. LG2 there), the one home of
/// the Legendre recurrences; re-exported here under their old paths.
pub use km_core::legendre::{LegendreRecurrence, normalized_legendre};

/// `Lambda_l^m(mu_i)` for every `mu_i` and `l = 0..nl`, node-major
/// (`out[i * nl + l]`), with the recurrence coefficients of
/// [`normalized_legendre`] computed once ([`LegendreRecurrence`]).
pub fn legendre_table(m: usize, mu: &[f64], nl: usize) -> Vec<f64> {
    let mut out = vec![0.0; mu.len() * nl];
    if m >= nl {
        return out;
    }
    let rec = LegendreRecurrence::new(m, nl);
    for (i, &x) in mu.iter().enumerate() {
        rec.eval(x, &mut out[i * nl..(i + 1) * nl]);
    }
    out
}

/// The asymmetry of eq. 4b: a series that falls no faster between `l = N`
/// and `2N` than a Henyey–Greenstein function of this `g` is taken for a
/// peak the `2N` moments do not resolve. Above 0.95, so that every
/// Henyey–Greenstein mixture with `|g| <= 0.95` stays on plain delta-M with
/// a margin of `(0.96/0.95)^N` against rounding.
pub const FLAT_SERIES_G: f64 = 0.96;

/// The smallest `chi_{2N}` of eq. 4b: below it the kept lobe carries too
/// little of the scattering to matter.
pub const FLAT_SERIES_MIN: f64 = 0.02;

/// The number of Legendre moments delta-M keeps for a phase function of
/// moments `chi(l)` at `n` streams per hemisphere (eq. 4b of
/// docs/multiflux.md): `2N` (Wiscombe 1977), or `floor(3N/2)` when the
/// series is still flat at `l = 2N`,
///
/// ```text
/// chi_{2N} >= 0.02  and  chi_{2N} > 0.96^{2(N-K)} chi_{2K},  K = ceil(N/2),
/// ```
///
/// as for a diffraction peak (a cloud's droplets: `chi_64 / chi_32 = 0.78`
/// at `N = 32`), whose kept lobe the Gauss nodes cannot integrate
/// (docs/phase.md §4). Any mixture of Henyey–Greenstein terms of
/// non-negative weights and `|g_i| <= 0.95` has
/// `chi_{2N} = sum w_i g_i^{2N} <= 0.95^{2(N-K)} chi_{2K}` (even moments,
/// every term non-negative), so it never qualifies. The solver asks it for
/// phase functions given as data only (`legendre`, `table`, `particles`).
///
/// ```
/// use km_multiflux::legendre::kept_moments;
/// let hg = |l: usize| 0.95f64.powi(l as i32);
/// assert_eq!(kept_moments(hg, 32), 64);
/// let flat = |l: usize| if l == 0 { 1.0 } else { 0.5 + 0.5 * 0.7f64.powi(l as i32) };
/// assert_eq!(kept_moments(flat, 32), 48);
/// ```
pub fn kept_moments(chi: impl Fn(usize) -> f64, n: usize) -> usize {
    let k = n.div_ceil(2);
    let (c2n, c2k) = (chi(2 * n), chi(2 * k));
    let exponent = i32::try_from(2 * (n - k)).unwrap_or(i32::MAX);
    if c2n >= FLAT_SERIES_MIN && c2n > FLAT_SERIES_G.powi(exponent) * c2k {
        3 * n / 2
    } else {
        2 * n
    }
}

/// Delta-M scaled `(chi*, omega*, tau_factor)` of eq. L3 with `f = chi[n_keep]`
/// (`chi` holds at least `n_keep + 1` moments): returns the first `n_keep`
/// scaled moments, the scaled albedo and `1 - omega f` (the factor on `tau`).
pub fn delta_m(chi: &[f64], omega: f64, n_keep: usize) -> (Vec<f64>, f64, f64) {
    let f = chi[n_keep];
    if f == 0.0 {
        return (chi[..n_keep].to_vec(), omega, 1.0);
    }
    let scaled = chi[..n_keep].iter().map(|c| (c - f) / (1.0 - f)).collect();
    let tau_factor = 1.0 - omega * f;
    let omega_s = if tau_factor > 0.0 { omega * (1.0 - f) / tau_factor } else { 0.0 };
    (scaled, omega_s, tau_factor)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn table_matches_the_single_recurrence() {
        let mus = [0.0, 0.1, 0.5, 0.99, 1.0];
        for m in [0, 1, 7] {
            let t = legendre_table(m, &mus, 20);
            let mut b = vec![0.0; 20];
            for (i, &x) in mus.iter().enumerate() {
                normalized_legendre(m, x, &mut b);
                for l in 0..20 {
                    assert!((t[i * 20 + l] - b[l]).abs() < 1e-14);
                }
            }
        }
    }

    #[test]
    fn addition_theorem_reproduces_henyey_greenstein() {
        // p from (L1)-(L2) with chi_l = g^l vs the closed form, g = 0.5, 200 moments:
        // the truncation error is g^200 ~ 1e-60, so rounding only (1e-12 relative).
        let g: f64 = 0.5;
        let nl = 200;
        let chi: Vec<f64> = (0..nl).map(|l| g.powi(l as i32)).collect();
        let (mu, mup, dphi) = (0.3f64, -0.7f64, 1.1f64);
        let cos_t = mu * mup + (1.0 - mu * mu).sqrt() * (1.0 - mup * mup).sqrt() * dphi.cos();
        let exact = (1.0 - g * g)
            / (4.0 * std::f64::consts::PI * (1.0 + g * g - 2.0 * g * cos_t).powf(1.5));
        let mut sum = 0.0;
        let (mut a, mut b) = (vec![0.0; nl], vec![0.0; nl]);
        for m in 0..nl {
            normalized_legendre(m, mu, &mut a);
            normalized_legendre(m, mup, &mut b);
            let pm: f64 =
                0.5 * (m..nl).map(|l| (2 * l + 1) as f64 * chi[l] * a[l] * b[l]).sum::<f64>();
            let cm = if m == 0 { 1.0 } else { 2.0 } / (2.0 * std::f64::consts::PI);
            sum += cm * pm * (m as f64 * dphi).cos();
        }
        assert!((sum - exact).abs() < 1e-12 * exact, "{sum} vs {exact}");
    }
}
