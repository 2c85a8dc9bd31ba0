//! The intensity correction for peaked phase functions at user exit
//! directions (Nakajima & Tanaka 1988; DISORT v2+, Stamnes et al. 2000
//! §3.6): the exact single scattering (TMS) and the second-order correction
//! of the forward peak (IMS), for one homogeneous layer, in the layer's own
//! frame (eq. 5 and 5a–5h of `docs/multiflux.md`).
//!
//! Delta-M (Wiscombe 1977) writes the phase function of a layer as
//!
//! ```text
//!   p = f p'' + (1 - f) p*                                                   (C1)
//! ```
//!
//! with `f = chi_L` (`L` the moments kept, `2N` or `3N/2`: eq. 4b), the truncated `p*`
//! (moments `chi*_l = (chi_l - f)/(1 - f)`, `l < L`), and the peak `p''` (moments 1
//! for `l < L`, `chi_l / f` beyond),
//! which it replaces by a delta in the forward direction: the light scattered
//! into the peak stays in the beam, the optical thickness becomes
//! `tau* = (1 - omega f) tau`. The discrete-ordinate solution is then exact for
//! the fluxes but its radiance carries the truncated `p*`.
//!
//! **TMS.** The once-scattered radiance of the scaled problem is replaced by the
//! exact phase function along the scaled path (C2, eq. 5):
//! `dJ(cos Theta) = [omega p/(1 - omega f) - omega* p*] / mu_b` per unit horizontal
//! irradiance, integrated along the exit path like every other source.
//!
//! **IMS.** Scattering twice within the peak is counted by the TMS as scattering
//! once (the scaled beam still holds the light scattered into the peak, and so
//! does the scaled exit path): at second order in `omega f` the TMS radiance
//! holds `2 (omega f)^2 p''` where the truth holds `(omega f)^2 p'' * p''` (the
//! convolution, moments multiply). With the intermediate direction near the
//! beam's (the peak is narrow), the path integral is the function `xi` (C4) and
//!
//! ```text
//!   dI_IMS = -1/(4 pi mu_b) (omega f)^2/(1 - omega f) P(cos Theta) xi(mu, mu_b/(1 - omega f), tau)   (C3)
//!   P = 2 p'' - p'' * p'' = sum_l (2l+1) g_l (2 - g_l) P_l,   g_l = 1 (l < L), chi_l / f (l >= L)
//!   xi(mu1, mu2, tau) = 1/(mu1 mu2) integral_0^tau t e^{-t/mu2} e^{-(tau - t)/mu1} dt              (C4)
//! ```
//!
//! (Stamnes et al. 2000, eq. A7, A13, A15, the normalisation of `p` there
//! being `4 pi` ours.) It is applied to down-going exits within 10 degrees of
//! the beam's polar angle, as DISORT does (the approximation holds near the
//! forward peak only). Without dividing by `f`:
//! `f^2 P = f^2 S + 2 f R1 - R2`, with `S = sum_{l<L} (2l+1) P_l`,
//! `R1 = 4 pi p - sum_{l<L} (2l+1) chi_l P_l` and `R2` the same for the phase
//! function of moments `chi_l^2` (Henyey–Greenstein: HG of `g^2`), so the term
//! vanishes smoothly as `f -> 0`.

use km_core::legendre::legendre_polynomials;
use km_core::phase::{Phase, PhaseFunction};

/// Half-width of the cone around the beam's polar angle where the IMS term is
/// applied (degrees; DISORT's `DTHETA` in `c_intensity_correction`).
pub const IMS_CONE_DEG: f64 = 10.0;

/// The intensity correction of one layer (eq. C2–C4): exact single scattering
/// (TMS) and the second-order forward-peak correction (IMS) for a collimated
/// beam of unit irradiance on a horizontal plane, at any exit direction.
///
/// # Reference
/// Nakajima & Tanaka 1988, J. Quant. Spectrosc. Radiat. Transfer 40, 51–69
/// (the TMS and IMS methods); Stamnes, Tsay, Wiscombe & Laszlo 2000 (DISORT
/// report v1.1) eq. 68 (TMS), A7, A13, A15 and 72 (IMS, `xi`).
#[derive(Debug, Clone)]
pub struct PeakCorrection {
    /// The exact phase function.
    phase: Phase,
    /// Unscaled single-scattering albedo, `[0, 1]`.
    omega: f64,
    /// Delta-M truncation fraction `f = chi_L`.
    f: f64,
    /// Unscaled Legendre moments `chi_l`, `l < L`.
    chi: Vec<f64>,
    /// Apply the second-order (IMS) term.
    secondary: bool,
}

impl PeakCorrection {
    /// The correction for a layer of phase function `phase`, unscaled albedo
    /// `omega` in `[0, 1]`, delta-M with `n_keep = L` moments kept
    /// (`f = chi_L`, eq. 4b: the layer's scaling's own `L`); `secondary` switches the IMS term on.
    ///
    /// ```
    /// use km_core::phase::Phase;
    /// use km_multiflux::correction::PeakCorrection;
    /// let c = PeakCorrection::new(Phase::henyey_greenstein(0.9).unwrap(), 0.99, 32, true);
    /// assert!((c.f() - 0.9f64.powi(32)).abs() < 1e-15);
    /// ```
    pub fn new(phase: Phase, omega: f64, n_keep: usize, secondary: bool) -> Self {
        let chi: Vec<f64> = (0..n_keep).map(|l| phase.legendre_moment(l)).collect();
        let f = phase.legendre_moment(n_keep);
        PeakCorrection { phase, omega, f, chi, secondary }
    }

    /// The delta-M truncation fraction `f`.
    pub fn f(&self) -> f64 {
        self.f
    }

    /// `1 - omega f`, the delta-M factor of the optical thickness.
    fn factor(&self) -> f64 {
        1.0 - self.omega * self.f
    }

    /// The TMS source difference (eq. C2):
    /// `[omega p(c)/(1 - omega f) - omega* p*(c)] / mu_b` at the scattering
    /// cosine `c`, per unit horizontal irradiance of a beam of cosine `mu_b`.
    pub fn single_source(&self, cos_theta: f64, mu_b: f64) -> f64 {
        let c = cos_theta.clamp(-1.0, 1.0);
        // omega* p* = omega/(1 - omega f) sum_{l<2N} (2l+1)(chi_l - f) P_l / (4 pi).
        let trunc = legendre_sum(c, self.chi.len(), |l| self.chi[l] - self.f);
        let k = self.omega / self.factor();
        k * (self.phase.eval(c) - trunc / (4.0 * std::f64::consts::PI)) / mu_b
    }

    /// `(omega f)^2 P(c)` of eq. C3 (dimensionless, the `4 pi` normalisation of
    /// the Legendre sums), computed as `omega^2 (f^2 S + 2 f R1 - R2)`.
    pub fn peak_pspike(&self, cos_theta: f64) -> f64 {
        let c = cos_theta.clamp(-1.0, 1.0);
        let four_pi = 4.0 * std::f64::consts::PI;
        let nk = self.chi.len();
        let (s, s1, s2) = legendre_sums3(c, nk, &self.chi);
        // The phase function of moments chi_l^2 (HG: HG of g^2, in closed form).
        let p2 = self.phase.eval_convolved(c);
        let r1 = four_pi * self.phase.eval(c) - s1;
        let r2 = four_pi * p2 - s2;
        self.omega * self.omega * (self.f * self.f * s + 2.0 * self.f * r1 - r2)
    }

    /// The radiance correction `(up, down)` of a layer of scaled optical
    /// thickness `tau_scaled` (may be infinite) for a beam of cosine `mu_b` and
    /// unit horizontal irradiance entering at the top, at the exit cosine
    /// `mu_x > 0` leaving the top (up) and the bottom (down), `phi_deg` the
    /// azimuth of the exit direction with 180 = mirror side (up) and forward
    /// (down). All in the layer's own medium (refracted cosines).
    ///
    /// `up = dJ(c_up) beta phi(1/mu_b + beta, tau*)`,
    /// `down = dJ(c_dn) beta E2(1/mu_b, beta, tau*) + dI_IMS` (eq. C2–C4, 14 of
    /// `docs/multiflux.md`), `beta = 1/mu_x`,
    /// `c_up/dn = ∓mu_x mu_b + sin sin_b cos(phi - 180)`.
    pub fn radiance(&self, mu_b: f64, mu_x: f64, phi_deg: f64, tau_scaled: f64) -> (f64, f64) {
        self.radiance_along(&self.paths(mu_b, mu_x, tau_scaled), phi_deg)
    }

    /// The factors of [`Self::radiance`] that do not depend on the azimuth
    /// (the path integrals of eq. 14 and C4 and the sines): computed once per
    /// polar angle and shared by the exit directions of every azimuth:
    /// `beta = 1/mu_x`, `phi(1/mu_b + beta, tau*)`, `E2(1/mu_b, beta, tau*)`,
    /// `sin theta_x sin theta_b` and the IMS path factor. Domain as
    /// [`Self::radiance`].
    ///
    /// # Reference
    /// Stamnes, Tsay, Wiscombe & Laszlo 2000 (DISORT report v1.1), eq. 68
    /// and 72 (the path integrals of the TMS and IMS terms).
    ///
    /// ```
    /// use km_core::phase::Phase;
    /// use km_multiflux::correction::PeakCorrection;
    /// let c = PeakCorrection::new(Phase::henyey_greenstein(0.9).unwrap(), 0.95, 16, true);
    /// let p = c.paths(0.8, 0.75, 1.5);
    /// for phi in [0.0, 90.0, 170.0, 180.0] {
    ///     assert_eq!(c.radiance_along(&p, phi), c.radiance(0.8, 0.75, phi, 1.5));
    /// }
    /// ```
    pub fn paths(&self, mu_b: f64, mu_x: f64, tau_scaled: f64) -> PeakPaths {
        let (sx, sb) = ((1.0 - mu_x * mu_x).max(0.0).sqrt(), (1.0 - mu_b * mu_b).max(0.0).sqrt());
        let beta = 1.0 / mu_x;
        let kb = 1.0 / mu_b;
        let secondary = (self.secondary && tau_scaled.is_finite())
            .then(|| self.secondary_path(mu_b, mu_x, tau_scaled / self.factor()));
        PeakPaths {
            mu_b,
            mu_x,
            sines: sx * sb,
            beta,
            up: phi(kb + beta, tau_scaled),
            down: e2(kb, beta, tau_scaled),
            secondary,
        }
    }

    /// [`Self::radiance`] at azimuth `phi_deg` from the shared factors `p`
    /// ([`Self::paths`]); the same numbers bit for bit.
    pub fn radiance_along(&self, p: &PeakPaths, phi_deg: f64) -> (f64, f64) {
        let cphi = (phi_deg - 180.0).to_radians().cos();
        (self.up_at(p, cphi), self.down_at(p, cphi))
    }

    /// The up-going part of [`Self::radiance_along`] alone (a layer with
    /// nothing below it to receive the down-going part).
    pub fn radiance_up_along(&self, p: &PeakPaths, phi_deg: f64) -> f64 {
        self.up_at(p, (phi_deg - 180.0).to_radians().cos())
    }

    /// The up-going radiance at `cos(phi - 180 deg) = cphi`.
    fn up_at(&self, p: &PeakPaths, cphi: f64) -> f64 {
        let c_up = -p.mu_x * p.mu_b + p.sines * cphi;
        self.single_source(c_up, p.mu_b) * p.beta * p.up
    }

    /// The down-going radiance at `cos(phi - 180 deg) = cphi`.
    fn down_at(&self, p: &PeakPaths, cphi: f64) -> f64 {
        let c_dn = p.mu_x * p.mu_b + p.sines * cphi;
        let mut down = self.single_source(c_dn, p.mu_b) * p.beta * p.down;
        if let Some(path) = p.secondary {
            // As secondary_radiance: zero outside the cone.
            down += if path == 0.0 { 0.0 } else { self.peak_pspike(c_dn) * path };
        }
        down
    }

    /// The IMS term of eq. C3 at the bottom of a layer of unscaled optical
    /// thickness `tau`, zero outside the cone of [`IMS_CONE_DEG`] around the
    /// beam's polar angle.
    pub fn secondary_radiance(&self, mu_b: f64, mu_x: f64, cos_theta: f64, tau: f64) -> f64 {
        let path = self.secondary_path(mu_b, mu_x, tau);
        if path == 0.0 {
            return 0.0;
        }
        self.peak_pspike(cos_theta) * path
    }

    /// The factor of eq. C3 that does not depend on the azimuth:
    /// `-xi(mu_x, mu_b/(1 - omega f), tau) / (4 pi mu_b (1 - omega f))`, so
    /// that [`Self::secondary_radiance`] is `peak_pspike(cos Theta)` times it;
    /// zero outside the cone of [`IMS_CONE_DEG`], for `omega f = 0`, and for
    /// `tau` (unscaled) not finite and positive.
    pub fn secondary_path(&self, mu_b: f64, mu_x: f64, tau: f64) -> f64 {
        let wf = self.omega * self.f;
        if !self.secondary || wf <= 0.0 || !tau.is_finite() || tau <= 0.0 {
            return 0.0;
        }
        let cone = (mu_b.clamp(-1.0, 1.0).acos() - mu_x.clamp(-1.0, 1.0).acos()).abs();
        if cone > IMS_CONE_DEG.to_radians() {
            return 0.0;
        }
        let xi = xi(mu_x, mu_b / (1.0 - wf), tau);
        -xi / ((1.0 - wf) * 4.0 * std::f64::consts::PI * mu_b)
    }
}

/// The factors of [`PeakCorrection::radiance`] that do not depend on the
/// azimuth, for one beam cosine `mu_b`, exit cosine `mu_x` and layer
/// ([`PeakCorrection::paths`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PeakPaths {
    mu_b: f64,
    mu_x: f64,
    /// `sin theta_x sin theta_b`.
    sines: f64,
    /// `1 / mu_x`.
    beta: f64,
    /// `phi(1/mu_b + beta, tau*)` (the exit up).
    up: f64,
    /// `E2(1/mu_b, beta, tau*)` (the exit down).
    down: f64,
    /// The IMS path factor of [`PeakCorrection::secondary_path`] (`None`
    /// without the IMS term or for a half-space).
    secondary: Option<f64>,
}

/// `sum_{l<n} (2l+1) a(l) P_l(c)` with the polynomials of
/// [`km_core::legendre::legendre_polynomials`] (recurrence LG1).
fn legendre_sum(c: f64, n: usize, a: impl Fn(usize) -> f64) -> f64 {
    let mut sum = 0.0;
    for (l, pl) in legendre_polynomials(c).take(n).enumerate() {
        sum += (2 * l + 1) as f64 * a(l) * pl;
    }
    sum
}

/// `(S, S1, S2) = sum_{l<n} (2l+1) {1, chi_l, chi_l^2} P_l(c)` in one pass of
/// the recurrence LG1 ([`km_core::legendre::legendre_polynomials`]).
fn legendre_sums3(c: f64, n: usize, chi: &[f64]) -> (f64, f64, f64) {
    let (mut s, mut s1, mut s2) = (0.0, 0.0, 0.0);
    for (l, pl) in legendre_polynomials(c).take(n).enumerate() {
        let w = (2 * l + 1) as f64 * pl;
        s += w;
        s1 += w * chi[l];
        s2 += w * chi[l] * chi[l];
    }
    (s, s1, s2)
}

/// `xi(mu1, mu2, tau) = 1/(mu1 mu2) integral_0^tau t e^{-t/mu2} e^{-(tau-t)/mu1} dt`
/// (eq. C4; Stamnes et al. 2000 eq. 72), without cancellation: with
/// `a = (1/mu2 - 1/mu1) tau`, the integral is `tau^2 e^{-tau/mu1} h(a)`,
/// `h(a) = (1 - (1 + a) e^{-a})/a^2` (series `1/2 - a/3 + a^2/8 - ...` for small `|a|`).
/// Domain: `mu1, mu2 > 0`, `tau >= 0` finite.
///
/// # Reference
/// Stamnes, Tsay, Wiscombe & Laszlo 2000 (DISORT report v1.1), eq. 72.
///
/// ```
/// use km_multiflux::correction::xi;
/// // Equal cosines: tau^2 e^{-tau/mu} / (2 mu^2).
/// let (mu, tau) = (0.6f64, 1.5f64);
/// let exact = tau * tau * (-tau / mu).exp() / (2.0 * mu * mu);
/// assert!((xi(mu, mu, tau) - exact).abs() < 1e-15);
/// ```
pub fn xi(mu1: f64, mu2: f64, tau: f64) -> f64 {
    let y = 1.0 / mu2 - 1.0 / mu1;
    let a = y * tau;
    let integral = if a.abs() < 0.1 {
        // h(a) = sum_{n>=2} (-1)^n (n-1)/n! a^(n-2): terms to a^8 (error < 1e-12).
        let mut h = 0.0;
        let mut fact = 1.0;
        let mut pw = 1.0;
        for n in 2..=10u32 {
            fact *= n as f64;
            let sign = if n % 2 == 0 { 1.0 } else { -1.0 };
            h += sign * (n - 1) as f64 / fact * pw;
            pw *= a;
        }
        tau * tau * (-tau / mu1).exp() * h
    } else {
        // (e^{-tau/mu1} - (1 + a) e^{-tau/mu2}) / y^2: both exponentials decay.
        ((-tau / mu1).exp() - (1.0 + a) * (-tau / mu2).exp()) / (y * y)
    };
    integral / (mu1 * mu2)
}

// Path integrals of exponential attenuation along an exit path, shared by the
// slab's exit-direction probes and by the correction.

/// `exp(-t / mu)`, 0 for an infinite `t`: the attenuation along a path of
/// cosine `mu` through the optical thickness `t`.
pub(crate) fn atten(t: f64, mu: f64) -> f64 {
    if t.is_infinite() { 0.0 } else { (-t / mu).exp() }
}

/// `(1 - exp(-c t)) / c` for `c >= 0`, `t >= 0` (may be infinite); `t` at `c = 0`.
pub(crate) fn phi(c: f64, t: f64) -> f64 {
    if t.is_infinite() {
        return if c > 0.0 { 1.0 / c } else { f64::INFINITY };
    }
    let x = c * t;
    if x < 1e-10 { t * (1.0 - 0.5 * x) } else { -(-x).exp_m1() / c }
}

/// `(exp(-a t) - exp(-b t)) / (b - a)` for `a, b >= 0`, finite or infinite `t`
/// (its limit `t exp(-a t)` at `a = b`), without cancellation.
pub(crate) fn e2(a: f64, b: f64, t: f64) -> f64 {
    let (lo, hi) = if a <= b { (a, b) } else { (b, a) };
    if t.is_infinite() {
        return if lo > 0.0 { 0.0 } else { phi(hi, t) };
    }
    (-lo * t).exp() * phi(hi - lo, t)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// xi against a composite Simpson quadrature of its integral (1e-9
    /// relative: 20000 panels, error ~ h^4 times the fourth derivative, < 1e-11 here).
    #[test]
    fn xi_matches_quadrature() {
        for &(m1, m2, tau) in &[
            (0.5, 0.5, 1.0),
            (0.5, 0.52, 2.0),
            (0.9, 0.3, 0.7),
            (0.2, 0.8, 5.0),
            (0.7, 0.7001, 1e-3),
        ] {
            let n = 20000;
            let h = tau / n as f64;
            let fx = |t: f64| t * (-t / m2).exp() * (-(tau - t) / m1).exp();
            let q: f64 = (0..=n)
                .map(|i| {
                    let w = if i == 0 || i == n {
                        1.0
                    } else if i % 2 == 1 {
                        4.0
                    } else {
                        2.0
                    };
                    w * fx(i as f64 * h)
                })
                .sum::<f64>()
                * h
                / 3.0
                / (m1 * m2);
            let x = xi(m1, m2, tau);
            assert!((x - q).abs() < 1e-9 * q.abs(), "{m1} {m2} {tau}: {x} vs {q}");
        }
    }

    /// The peak term vanishes without truncation (f = 0: isotropic) and its
    /// Legendre form matches the direct sum of DISORT's definition
    /// `sum_l (2l+1) g_l (2 - g_l) P_l` (Henyey–Greenstein g = 0.6, 2N = 8,
    /// summed to l = 400 where g^l < 1e-88).
    #[test]
    fn pspike_matches_direct_sum() {
        let iso = PeakCorrection::new(Phase::Isotropic, 1.0, 8, true);
        assert_eq!(iso.peak_pspike(0.3), 0.0);
        let g: f64 = 0.6;
        let c = PeakCorrection::new(Phase::henyey_greenstein(g).unwrap(), 0.9, 8, true);
        let f = g.powi(8);
        for &x in &[1.0, 0.99, 0.5, -0.3] {
            let direct = 0.81
                * f
                * f
                * legendre_sum(x, 400, |l| {
                    let gl = if l < 8 { 1.0 } else { g.powi(l as i32) / f };
                    gl * (2.0 - gl)
                });
            let v = c.peak_pspike(x);
            assert!((v - direct).abs() < 1e-10 * direct.abs().max(1.0), "{x}: {v} vs {direct}");
        }
    }
}
