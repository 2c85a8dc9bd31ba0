//! # The Kubelka–Munk inverse for paints and coatings
//!
//! A paint laboratory measures a film's reflectance, not its absorption `K`
//! and scattering `S`. This module inverts the two-flux model of
//! [`km_core::two_flux`] in the closed forms the trade uses:
//!
//! * [`k_over_s`] / [`r_inf_from_k_over_s`]: an opaque film, `R_inf <-> K/S`
//!   (Kubelka & Munk 1931; eq. I1–I2 of `docs/inverse-km.md`).
//! * [`from_r_inf_r0`]: `K` and `S` from `R_inf` and the reflectance `R_0` of
//!   a film of thickness `X` over an ideal black ground (Kubelka 1948; eq. I4).
//! * [`from_black_white`]: `K` and `S` from the reflectances of one film over
//!   a dark and over a light ground of known reflectances (a drawdown on a
//!   black-and-white chart; Kubelka 1948, generalised to a non-ideal black;
//!   eq. I5–I7).
//! * [`Saunderson`]: measured (outside the surface) and internal (what
//!   Kubelka–Munk describes) reflectances, both ways (Saunderson 1942; eq. I8–I9).
//! * [`masstone_tint`]: a pigment's own `K` and `S` from its masstone and
//!   one tint with a white of known `K`, `S` (Duncan 1940 two-constant rule in
//!   Allen's formulation; eq. I10), and [`mixture_reflectance`], the
//!   prediction of a mixture (eq. I11).
//! * [`black_white_uncertainty`], [`r_inf_r0_uncertainty`]: standard
//!   uncertainties and correlation of `K`, `S` from those of the readings
//!   (first-order propagation; eq. I12).
//!
//! Every inverse is the exact algebraic inverse of [`km_core::two_flux`]'s
//! forward model: forward with `km_core`, then inverse, recovers `K` and `S`
//! to rounding level (tests `km-inverse/tests/kubelka.rs`).
//!
//! Reflectances here are the internal, diffuse two-flux reflectances unless a
//! name says `measured`: apply [`Saunderson::internal_from_measured`] first
//! to instrument readings of a film with a glossy surface.

use km_core::CoreError;
use km_core::fresnel;
use km_core::two_flux::{self, KmCoefficients, Slab};
use thiserror::Error;

/// An error of the Kubelka–Munk inverse: a value outside its domain, or
/// measurements no film can produce. Every message names the value.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum KubelkaError {
    /// An input outside its domain (a reflectance outside `[0, 1]`, a
    /// thickness `<= 0`, ...).
    #[error("invalid {name} = {value}: {reason}")]
    Invalid {
        /// Input name (as on the command line: `r_black`, `thickness`, ...).
        name: String,
        /// The offending value.
        value: f64,
        /// The domain.
        reason: String,
    },
    /// Inputs each in their domain that no Kubelka–Munk film can produce
    /// together (e.g. a film reflecting more over black than over white).
    #[error("infeasible {name} = {value}: {reason}")]
    Infeasible {
        /// The input (or derived quantity) that breaks the model.
        name: String,
        /// Its value.
        value: f64,
        /// Why, and what would be consistent.
        reason: String,
    },
    /// An error of the forward model in `km_core`.
    #[error(transparent)]
    Core(#[from] CoreError),
}

impl KubelkaError {
    fn invalid(name: &str, value: f64, reason: impl Into<String>) -> Self {
        KubelkaError::Invalid { name: name.into(), value, reason: reason.into() }
    }
    fn infeasible(name: &str, value: f64, reason: impl Into<String>) -> Self {
        KubelkaError::Infeasible { name: name.into(), value, reason: reason.into() }
    }
}

/// A reflectance must be finite and in `[0, 1]`.
fn check_reflectance(name: &str, r: f64) -> Result<(), KubelkaError> {
    if !r.is_finite() || !(0.0..=1.0).contains(&r) {
        return Err(KubelkaError::invalid(name, r, "a reflectance must lie in [0, 1]"));
    }
    Ok(())
}

/// A film thickness must be finite and `> 0`.
fn check_thickness(x: f64) -> Result<(), KubelkaError> {
    if !x.is_finite() || x <= 0.0 {
        return Err(KubelkaError::invalid("thickness", x, "film thickness must be finite and > 0"));
    }
    Ok(())
}

/// Rounding allowance on `a = (K + S)/S >= 1`, in units of the rounding
/// error bound of `a`: a conservative film (`K = 0`, `a = 1`) can come out
/// below 1 by rounding; within this many bounds it is taken as `K = 0`.
const A_ROUNDING: f64 = 16.0 * f64::EPSILON;

// ---------------------------------------------------------------------------
// Opaque films: R_inf <-> K/S.

/// The Kubelka–Munk function: `K/S` of an opaque film from its internal
/// reflectance `R_inf`,
///
/// `K/S = (1 - R_inf)^2 / (2 R_inf)`  (eq. I1).
///
/// * `r_inf`: internal reflectance of an opaque film, in `(0, 1]`.
///
/// # Errors
/// `r_inf` outside `(0, 1]` (`R_inf = 0` means `K/S = inf`: no scattering).
///
/// # Reference
/// Kubelka & Munk (1931); Kubelka (1948) eq. 6 solved for `K/S`.
///
/// ```
/// use km_inverse::kubelka::k_over_s;
/// assert!((k_over_s(0.5).unwrap() - 0.25).abs() < 1e-15);
/// assert!(k_over_s(0.0).is_err());
/// ```
pub fn k_over_s(r_inf: f64) -> Result<f64, KubelkaError> {
    check_reflectance("r_inf", r_inf)?;
    if r_inf == 0.0 {
        return Err(KubelkaError::invalid("r_inf", r_inf, "R_inf = 0 gives K/S = inf (S = 0)"));
    }
    let one_minus = 1.0 - r_inf;
    Ok(one_minus * one_minus / (2.0 * r_inf))
}

/// The internal reflectance of an opaque film from `K/S`,
///
/// `R_inf = 1 + K/S - sqrt((K/S)^2 + 2 K/S)`  (eq. I2),
///
/// evaluated as `1 / (1 + K/S + sqrt((K/S)^2 + 2 K/S))` (the same number
/// without the cancellation of the printed form when `K/S` is large).
///
/// * `k_over_s`: `K/S >= 0`, finite.
///
/// # Errors
/// `k_over_s` negative or not finite.
///
/// # Reference
/// Kubelka (1948) eq. 6 (`R_inf = a - b`, `a = 1 + K/S`, `b = sqrt(a^2 - 1)`).
///
/// ```
/// use km_inverse::kubelka::{k_over_s, r_inf_from_k_over_s};
/// let r = r_inf_from_k_over_s(0.25).unwrap();
/// assert!((r - 0.5).abs() < 1e-15);
/// assert!((k_over_s(r).unwrap() - 0.25).abs() < 1e-15);
/// ```
pub fn r_inf_from_k_over_s(k_over_s: f64) -> Result<f64, KubelkaError> {
    if !k_over_s.is_finite() || k_over_s < 0.0 {
        return Err(KubelkaError::invalid("K/S", k_over_s, "must be finite and >= 0"));
    }
    // sqrt(q^2 + 2q) = sqrt(q) sqrt(q + 2): no overflow of q^2 for large q.
    Ok(1.0 / (1.0 + k_over_s + k_over_s.sqrt() * (k_over_s + 2.0).sqrt()))
}

// ---------------------------------------------------------------------------
// Films of finite thickness.

/// What the inverse finds out about one film.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Film {
    /// Absorption coefficient `K`, 1/(unit of the thickness), `>= 0`.
    pub k: f64,
    /// Scattering coefficient `S`, 1/(unit of the thickness), `> 0`.
    pub s: f64,
    /// `K/S`.
    pub k_over_s: f64,
    /// Scattering power `S X` (dimensionless), the number the two reflectances
    /// determine; `S = (S X) / X`.
    pub sx: f64,
    /// Internal reflectance of the same material, opaque (`R_inf`, eq. I2).
    pub r_inf: f64,
    /// Internal reflectance of this film over an ideal black ground (`R_0`).
    pub r0: f64,
    /// Diffuse transmittance of this film (`T`, seed 000 eq. 10).
    pub t: f64,
}

impl Film {
    /// The film from `a = (K + S)/S`, `c = b coth(b S X)` (Kubelka 1948's two
    /// numbers) and the thickness; `a_minus_1` is `a - 1` computed without
    /// cancellation where the caller can, `a_scale` the size of the terms
    /// `a` was formed from (its rounding error is about `eps a_scale`).
    fn from_a_c(
        a: f64,
        a_minus_1: f64,
        a_scale: f64,
        c: f64,
        thickness: f64,
    ) -> Result<Film, KubelkaError> {
        // a < 1 would need K < 0: no film does that (beyond rounding).
        if a_minus_1 < -A_ROUNDING * a_scale {
            return Err(KubelkaError::infeasible(
                "(K+S)/S",
                a,
                "the reflectances imply a = (K + S)/S < 1, i.e. K < 0 (gain): check the grounds \
                 and the Saunderson correction",
            ));
        }
        let a_minus_1 = a_minus_1.max(0.0);
        // b = sqrt(a^2 - 1) = sqrt((a - 1)(a + 1)).
        let b = (a_minus_1 * (a + 1.0)).sqrt();
        // c = b coth(b S X) > b for a finite film; c <= b would be a film
        // thicker than opaque (R_0 >= R_inf).
        let c_minus_b = c - b;
        if c_minus_b.is_nan() || c_minus_b <= 0.0 || !c.is_finite() {
            return Err(KubelkaError::infeasible(
                "R_0",
                1.0 / (a + c),
                format!(
                    "the reflectances imply a film at or beyond opacity (R_0 >= R_inf = {}): \
                     S X is not determined, only K/S",
                    1.0 / (a + b)
                ),
            ));
        }
        // S X = arcoth(c / b) / b = ln((c + b)/(c - b)) / (2b)  (eq. I4),
        // as ln_1p(2b / (c - b)) / (2b), which tends to 1/c as b -> 0 (K = 0).
        let sx = if b > 0.0 { (2.0 * b / c_minus_b).ln_1p() / (2.0 * b) } else { 1.0 / c };
        let s = sx / thickness;
        let k = s * a_minus_1;
        // The rest through the forward model itself.
        let rt = two_flux::layer_rt(k, s, thickness)?;
        Ok(Film { k, s, k_over_s: a_minus_1, sx, r_inf: 1.0 / (a + b), r0: rt.r, t: rt.t })
    }
}

/// `K` and `S` from the internal reflectance of an opaque film `R_inf` and
/// that of a film of thickness `X` over an ideal black ground `R_0`:
///
/// ```text
/// a = (1/R_inf + R_inf) / 2,  b = (1/R_inf - R_inf) / 2,  K/S = a - 1
/// S X = (1 / b) arcoth((1 - a R_0) / (b R_0))
///     = ln(R_inf (1 - R_0 R_inf) / (R_inf - R_0)) / (1/R_inf - R_inf)     (I4)
/// ```
///
/// * `r_inf`: in `(0, 1]`; `r0`: in `(0, r_inf)`; `thickness`: `X > 0`
///   (any length unit; `K`, `S` come out in its inverse).
///
/// `R_inf = 1` is a white film (`K = 0`), treated as the limit `S X =
/// R_0 / (1 - R_0)`.
///
/// # Errors
/// A reflectance outside `[0, 1]`, `r_inf = 0`, `r0 = 0` (no scattering),
/// `r0 >= r_inf` (a film over black cannot reflect as much as the opaque
/// film), a thickness `<= 0`.
///
/// # Reference
/// Kubelka (1948), eq. 13 (`S X` from `R_0`, `R_inf`; hyperbolic form).
///
/// ```
/// use km_inverse::kubelka::from_r_inf_r0;
/// use km_core::two_flux::{layer_rt, r_infinity};
/// let (k, s, x) = (0.3, 2.0, 0.5);
/// let film = from_r_inf_r0(r_infinity(k, s).unwrap(), layer_rt(k, s, x).unwrap().r, x).unwrap();
/// assert!((film.k - k).abs() < 1e-13 && (film.s - s).abs() < 1e-13);
/// ```
pub fn from_r_inf_r0(r_inf: f64, r0: f64, thickness: f64) -> Result<Film, KubelkaError> {
    check_reflectance("r_inf", r_inf)?;
    check_reflectance("r_zero", r0)?;
    check_thickness(thickness)?;
    if r_inf == 0.0 {
        return Err(KubelkaError::invalid("r_inf", r_inf, "R_inf = 0 means S = 0"));
    }
    if r0 == 0.0 {
        return Err(KubelkaError::infeasible(
            "r_zero",
            r0,
            "a film over black that reflects nothing does not scatter (S = 0)",
        ));
    }
    if r0 >= r_inf {
        return Err(KubelkaError::infeasible(
            "r_zero",
            r0,
            format!(
                "a film over black reflects less than the opaque film (R_0 < R_inf = {r_inf}); \
                 R_0 = R_inf means an opaque film, where only K/S is determined"
            ),
        ));
    }
    // a and a - 1 = (1 - R_inf)^2 / (2 R_inf) without cancellation (eq. I1).
    let a = 0.5 * (1.0 / r_inf + r_inf);
    let a_minus_1 = k_over_s(r_inf)?;
    // c = b coth(b S X) = 1/R_0 - a (from R_0 = 1 / (a + c)).
    let b = 0.5 * (1.0 - r_inf) * (1.0 + r_inf) / r_inf;
    // c - b = 1/R_0 - 1/R_inf, formed as a quotient of a difference of data.
    let c = b + (r_inf - r0) / (r0 * r_inf);
    Film::from_a_c(a, a_minus_1, a, c, thickness)
}

/// `K` and `S` from the internal reflectances of one film of thickness `X`
/// over two grounds: `r_black` over a ground of reflectance `g_black`,
/// `r_white` over a ground of reflectance `g_white > g_black`.
///
/// A film over a ground `R_g` reflects (Kubelka 1948, eq. 11)
/// `R = (1 - R_g (a - c)) / (a + c - R_g)`, `a = (K + S)/S`,
/// `c = b coth(b S X)`, `b = sqrt(a^2 - 1)`. That is linear in `a` and `c`:
///
/// ```text
/// a (R + R_g) + c (R - R_g) = 1 + R R_g                                    (I5)
/// ```
///
/// so two grounds give `a` and `c` by Cramer's rule, with
/// `D = 2 (g_b R_w - g_w R_b)`:
///
/// ```text
/// a = ((1 + R_b g_b)(R_w - g_w) - (1 + R_w g_w)(R_b - g_b)) / D
/// c = ((R_b + g_b)(1 + R_w g_w) - (R_w + g_w)(1 + R_b g_b)) / D            (I6)
/// ```
///
/// For an ideal black (`g_b = 0`) this is Kubelka's
/// `a = (R_w + (R_0 - R_w + g_w) / (R_0 g_w)) / 2`, `c = 1/R_0 - a` (I7).
/// Then `S X = arcoth(c/b) / b` and `K = S (a - 1)` as in (I4).
///
/// * `r_black`, `r_white`: internal reflectances of the film, in `[0, 1]`,
///   `r_black < r_white`;
/// * `g_black`, `g_white`: the grounds' reflectances, `0 <= g_black < g_white <= 1`;
/// * `thickness`: `X > 0`.
///
/// # Errors
/// Values outside their domain; `r_black >= r_white` (the film hides its
/// ground, or the readings are swapped); a pair of readings that implies
/// `K < 0` or a film beyond opacity; `D = 0` (no scattering at all).
///
/// # Reference
/// Kubelka (1948), eq. 11 (reflectance over a ground) and its two-ground
/// solution; the general `g_black` by (I5), derived in `docs/inverse-km.md`.
///
/// ```
/// use km_inverse::kubelka::{from_black_white, reflectance_over_ground};
/// let (k, s, x) = (0.3, 2.0, 0.5);
/// let r_b = reflectance_over_ground(k, s, x, 0.02).unwrap();
/// let r_w = reflectance_over_ground(k, s, x, 0.85).unwrap();
/// let film = from_black_white(r_b, 0.02, r_w, 0.85, x).unwrap();
/// assert!((film.k - k).abs() < 1e-12 && (film.s - s).abs() < 1e-12);
/// assert!(from_black_white(r_w, 0.02, r_b, 0.85, x).is_err());
/// ```
pub fn from_black_white(
    r_black: f64,
    g_black: f64,
    r_white: f64,
    g_white: f64,
    thickness: f64,
) -> Result<Film, KubelkaError> {
    check_reflectance("r_black", r_black)?;
    check_reflectance("r_black_ground", g_black)?;
    check_reflectance("r_white", r_white)?;
    check_reflectance("r_white_ground", g_white)?;
    check_thickness(thickness)?;
    if g_black >= g_white {
        return Err(KubelkaError::invalid(
            "r_black_ground",
            g_black,
            format!("the dark ground must reflect less than the light one ({g_white})"),
        ));
    }
    // dR/dR_g = T^2 / (1 - R_0 R_g)^2 > 0: over the lighter ground the film
    // reflects more, unless it is opaque (T = 0).
    if r_black >= r_white {
        return Err(KubelkaError::infeasible(
            "r_black",
            r_black,
            format!(
                "a film reflects less over the dark ground than over the light one \
                 (r_white = {r_white}); equal readings mean an opaque film: use R_inf \
                 (only K/S is determined)"
            ),
        ));
    }
    let (rb, gb, rw, gw) = (r_black, g_black, r_white, g_white);
    // Cramer's rule on (I5) for the two grounds (I6).
    let det = 2.0 * (gb * rw - gw * rb);
    if det == 0.0 {
        return Err(KubelkaError::infeasible(
            "r_black",
            r_black,
            "the readings are those of a non-scattering film (S = 0), outside the \
             Kubelka–Munk inverse",
        ));
    }
    let (t1, t2) = ((1.0 + rb * gb) * (rw - gw), (1.0 + rw * gw) * (rb - gb));
    let a = (t1 - t2) / det;
    // Rounding scale of a: its numerator with every difference of readings
    // replaced by the sum (a relative rounding of each reading), over |D|.
    let a_scale = ((1.0 + rb * gb) * (rw + gw) + (1.0 + rw * gw) * (rb + gb)) / det.abs();
    let c = ((rb + gb) * (1.0 + rw * gw) - (rw + gw) * (1.0 + rb * gb)) / det;
    if !a.is_finite() || !c.is_finite() {
        return Err(KubelkaError::infeasible(
            "r_black",
            r_black,
            "the readings give no finite K, S",
        ));
    }
    Film::from_a_c(a, a - 1.0, a_scale, c, thickness)
}

/// Standard uncertainties of a fitted film's `K` and `S`, and their correlation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Uncertainty {
    /// Standard uncertainty of `K` (1/length).
    pub k: f64,
    /// Standard uncertainty of `S` (1/length).
    pub s: f64,
    /// Correlation coefficient of the errors of `K` and `S`, in `[-1, 1]`.
    pub correlation: f64,
}

/// First-order propagation of independent reading uncertainties through an
/// inverse `f(r1, r2) -> (K, S)`: `Cov = J diag(u1^2, u2^2) J^T`, the
/// Jacobian `J` by central differences (step `1e-6`, clipped to `[0, 1]`;
/// truncation ~1e-12 and rounding ~eps/1e-6 relative, far below any
/// reading's uncertainty).
fn propagate(
    r: [f64; 2],
    u: [f64; 2],
    f: impl Fn(f64, f64) -> Result<Film, KubelkaError>,
) -> Result<Uncertainty, KubelkaError> {
    for (name, v) in [("u_1", u[0]), ("u_2", u[1])] {
        if !v.is_finite() || v < 0.0 {
            return Err(KubelkaError::invalid(name, v, "an uncertainty must be finite and >= 0"));
        }
    }
    const H: f64 = 1e-6;
    let mut jac = [[0.0; 2]; 2];
    for i in 0..2 {
        // Central difference, one-sided at the ends of [0, 1].
        let (mut lo, mut hi) = (r, r);
        lo[i] = (r[i] - H).max(0.0);
        hi[i] = (r[i] + H).min(1.0);
        let (a, b) = (f(lo[0], lo[1])?, f(hi[0], hi[1])?);
        let d = hi[i] - lo[i];
        jac[0][i] = (b.k - a.k) / d;
        jac[1][i] = (b.s - a.s) / d;
    }
    let var = |p: usize, q: usize| {
        jac[p][0] * jac[q][0] * u[0] * u[0] + jac[p][1] * jac[q][1] * u[1] * u[1]
    };
    let (vk, vs, cks) = (var(0, 0), var(1, 1), var(0, 1));
    let correlation =
        if vk > 0.0 && vs > 0.0 { (cks / (vk * vs).sqrt()).clamp(-1.0, 1.0) } else { 0.0 };
    Ok(Uncertainty { k: vk.sqrt(), s: vs.sqrt(), correlation })
}

/// Standard uncertainties of `K`, `S` from [`from_black_white`], for
/// independent standard uncertainties `u_black`, `u_white` of the two
/// (internal) readings; the grounds and the thickness are taken as exact.
///
/// First order: `Cov(K, S) = J diag(u_black^2, u_white^2) J^T` with the
/// Jacobian of (I6)+(I4) by central differences. Near opacity the
/// uncertainties grow like `exp(2 b S X)` (docs/inverse-km.md §6): this is
/// how far a fit can be trusted.
///
/// # Errors
/// Those of [`from_black_white`] at the readings or a step away from them;
/// a negative or non-finite uncertainty.
///
/// # Reference
/// JCGM 100:2008 (GUM), §5.1.2 (law of propagation of uncertainty).
///
/// ```
/// use km_inverse::kubelka::{black_white_uncertainty, reflectance_over_ground};
/// let (k, s, x) = (0.3, 2.0, 0.5);
/// let rb = reflectance_over_ground(k, s, x, 0.0).unwrap();
/// let rw = reflectance_over_ground(k, s, x, 0.8).unwrap();
/// let u = black_white_uncertainty(rb, 0.0, rw, 0.8, x, 1e-3, 1e-3).unwrap();
/// assert!(u.k > 0.0 && u.s > 0.0 && u.correlation.abs() <= 1.0);
/// ```
pub fn black_white_uncertainty(
    r_black: f64,
    g_black: f64,
    r_white: f64,
    g_white: f64,
    thickness: f64,
    u_black: f64,
    u_white: f64,
) -> Result<Uncertainty, KubelkaError> {
    from_black_white(r_black, g_black, r_white, g_white, thickness)?;
    propagate([r_black, r_white], [u_black, u_white], |rb, rw| {
        from_black_white(rb, g_black, rw, g_white, thickness)
    })
}

/// Standard uncertainties of `K`, `S` from [`from_r_inf_r0`], for independent
/// standard uncertainties `u_r_inf`, `u_r0` of the two (internal) readings,
/// as [`black_white_uncertainty`].
///
/// # Errors
/// Those of [`from_r_inf_r0`] at the readings or a step away from them; a
/// negative or non-finite uncertainty.
///
/// # Reference
/// JCGM 100:2008 (GUM), §5.1.2.
///
/// ```
/// use km_inverse::kubelka::r_inf_r0_uncertainty;
/// let u = r_inf_r0_uncertainty(0.6, 0.4, 1.0, 1e-3, 1e-3).unwrap();
/// assert!(u.k > 0.0 && u.s > 0.0);
/// ```
pub fn r_inf_r0_uncertainty(
    r_inf: f64,
    r0: f64,
    thickness: f64,
    u_r_inf: f64,
    u_r0: f64,
) -> Result<Uncertainty, KubelkaError> {
    from_r_inf_r0(r_inf, r0, thickness)?;
    propagate([r_inf, r0], [u_r_inf, u_r0], |ri, r| from_r_inf_r0(ri, r, thickness))
}

/// Internal reflectance of a film of thickness `X` over a ground of
/// reflectance `r_ground`: the forward model the inverses invert, by
/// `km_core`'s adding of the layer and an opaque ground (seed 000 eq. 14b),
/// equal to Kubelka (1948) eq. 11,
/// `R = (1 - R_g (a - b coth(b S X))) / (a - R_g + b coth(b S X))`.
///
/// * `k`, `s`: `K`, `S >= 0` (1/length); `thickness`: `X >= 0` or `inf`;
///   `r_ground` in `[0, 1]`.
///
/// # Errors
/// Those of [`km_core::two_flux::layer_rt`] and [`Slab::ground`].
///
/// # Reference
/// Kubelka (1948) eq. 11; seed 000 eq. 14.
///
/// ```
/// use km_inverse::kubelka::reflectance_over_ground;
/// // Over black, the layer's own R; an opaque layer hides its ground.
/// let r = reflectance_over_ground(0.1, 0.4, 1.0, 0.0).unwrap();
/// assert_eq!(r, km_core::two_flux::layer_rt(0.1, 0.4, 1.0).unwrap().r);
/// ```
pub fn reflectance_over_ground(
    k: f64,
    s: f64,
    thickness: f64,
    r_ground: f64,
) -> Result<f64, KubelkaError> {
    check_reflectance("r_ground", r_ground)?;
    let layer = Slab::layer(k, s, thickness)?;
    let ground = Slab::ground(r_ground)?;
    Ok(two_flux::add(&layer, &ground).r_top)
}

// ---------------------------------------------------------------------------
// Saunderson's correction.

/// Whether the instrument's reading includes the mirror reflection of the
/// film's surface (sphere geometry "specular included", SCI) or not
/// ("specular excluded", SCE, or 45°/0° geometry).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Specular {
    /// The reading includes the surface reflection `k1` (SCI).
    #[default]
    Included,
    /// The reading excludes it (SCE, 45°/0°).
    Excluded,
}

/// Saunderson's correction between measured reflectance `R_m` and the
/// internal two-flux reflectance `R` of a film with a smooth surface:
///
/// ```text
/// R_m = k1 + (1 - k1)(1 - k2) R / (1 - k2 R)       specular included     (I8)
/// R   = (R_m - k1) / (1 - k1 - k2 + k2 R_m)                               (I9)
/// ```
///
/// (without `k1 +` and with `R_m - k1` replaced by `R_m` when the specular
/// component is excluded). `k1` is the surface's reflectance for the
/// incoming light (Fresnel at normal incidence: `((n - 1)/(n + 1))^2`), `k2`
/// the internal reflectance for the diffuse light inside (about 0.4–0.6 for
/// paints; the hemispherical Fresnel value for `n = 1.5` is 0.596).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Saunderson {
    /// External (specular) surface reflectance, in `[0, 1)`.
    pub k1: f64,
    /// Internal diffuse surface reflectance, in `[0, 1)`.
    pub k2: f64,
    /// Whether readings include the specular reflection.
    pub specular: Specular,
}

impl Saunderson {
    /// Saunderson's constants given directly.
    ///
    /// # Errors
    /// `k1` or `k2` outside `[0, 1)`.
    ///
    /// # Reference
    /// Saunderson (1942), eq. 1.
    ///
    /// ```
    /// use km_inverse::kubelka::{Saunderson, Specular};
    /// assert!(Saunderson::new(0.04, 0.6, Specular::Included).is_ok());
    /// assert!(Saunderson::new(0.04, 1.0, Specular::Included).is_err());
    /// ```
    pub fn new(k1: f64, k2: f64, specular: Specular) -> Result<Saunderson, KubelkaError> {
        for (name, v) in [("k1", k1), ("k2", k2)] {
            if !v.is_finite() || !(0.0..1.0).contains(&v) {
                return Err(KubelkaError::invalid(name, v, "must lie in [0, 1)"));
            }
        }
        Ok(Saunderson { k1, k2, specular })
    }

    /// `k1` from the refractive index `n` of the binder by the Fresnel
    /// reflectance at normal incidence from air, `k1 = ((n - 1)/(n + 1))^2`
    /// (0.04 for `n = 1.5`), and `k2` as given.
    ///
    /// # Errors
    /// `n` not finite or below 1; `k2` outside `[0, 1)`.
    ///
    /// # Reference
    /// Saunderson (1942); Born & Wolf, §1.5 (Fresnel formulae at normal incidence).
    ///
    /// ```
    /// use km_inverse::kubelka::{Saunderson, Specular};
    /// let c = Saunderson::from_index(1.5, 0.6, Specular::Included).unwrap();
    /// assert!((c.k1 - 0.04).abs() < 1e-15);
    /// ```
    pub fn from_index(n: f64, k2: f64, specular: Specular) -> Result<Saunderson, KubelkaError> {
        if !n.is_finite() || n < 1.0 {
            return Err(KubelkaError::invalid("n", n, "refractive index must be finite and >= 1"));
        }
        let r = (n - 1.0) / (n + 1.0);
        Saunderson::new(r * r, k2, specular)
    }

    /// Both constants from the index, as `km_core`'s scene solver builds a
    /// top interface for collimated light at normal incidence from air:
    /// `k1 = ((n - 1)/(n + 1))^2`, `k2 = 2 int_0^1 R_F(mu; n -> 1) mu dmu`
    /// (the hemispherical Fresnel reflectance from inside, total internal
    /// reflection included; `docs/two-flux.md` eq. K11).
    ///
    /// # Errors
    /// `n` not finite or below 1.
    ///
    /// # Reference
    /// Saunderson (1942); `km_core::fresnel::diffuse_reflectance`.
    ///
    /// ```
    /// use km_inverse::kubelka::{Saunderson, Specular};
    /// let c = Saunderson::fresnel(1.5, Specular::Included).unwrap();
    /// assert!((c.k2 - 0.596).abs() < 2e-3);
    /// ```
    pub fn fresnel(n: f64, specular: Specular) -> Result<Saunderson, KubelkaError> {
        if !n.is_finite() || n < 1.0 {
            return Err(KubelkaError::invalid("n", n, "refractive index must be finite and >= 1"));
        }
        Saunderson::from_index(n, fresnel::diffuse_reflectance(n, 1.0), specular)
    }

    /// The measured reflectance of a film of internal reflectance `r` (eq. I8).
    ///
    /// # Errors
    /// `r` outside `[0, 1]`.
    ///
    /// # Reference
    /// Saunderson (1942), eq. 1.
    ///
    /// ```
    /// use km_inverse::kubelka::{Saunderson, Specular};
    /// let c = Saunderson::new(0.04, 0.6, Specular::Included).unwrap();
    /// // A black film shows only its surface; a white one reflects everything.
    /// assert_eq!(c.measured_from_internal(0.0).unwrap(), 0.04);
    /// assert!((c.measured_from_internal(1.0).unwrap() - 1.0).abs() < 1e-15);
    /// ```
    pub fn measured_from_internal(&self, r: f64) -> Result<f64, KubelkaError> {
        check_reflectance("internal reflectance", r)?;
        // Light through the surface twice, with the inter-reflections under it.
        let body = (1.0 - self.k1) * (1.0 - self.k2) * r / (1.0 - self.k2 * r);
        Ok(match self.specular {
            Specular::Included => self.k1 + body,
            Specular::Excluded => body,
        })
    }

    /// The internal reflectance of a film whose measured reflectance is
    /// `r_measured` (eq. I9), the inverse of [`Saunderson::measured_from_internal`].
    ///
    /// # Errors
    /// `r_measured` outside `[0, 1]`; below `k1` with the specular component
    /// included (less than the surface alone reflects); a result above 1
    /// (more than the surface lets out).
    ///
    /// # Reference
    /// Saunderson (1942), eq. 1 solved for `R`.
    ///
    /// ```
    /// use km_inverse::kubelka::{Saunderson, Specular};
    /// let c = Saunderson::new(0.04, 0.6, Specular::Included).unwrap();
    /// let r = c.internal_from_measured(c.measured_from_internal(0.3).unwrap()).unwrap();
    /// assert!((r - 0.3).abs() < 1e-15);
    /// assert!(c.internal_from_measured(0.01).is_err());
    /// ```
    pub fn internal_from_measured(&self, r_measured: f64) -> Result<f64, KubelkaError> {
        check_reflectance("measured reflectance", r_measured)?;
        let (k1, k2) = (self.k1, self.k2);
        // The body reflection y = R_m - k1 (or R_m), then R = y / ((1-k1)(1-k2) + k2 y).
        let y = match self.specular {
            Specular::Included => {
                if r_measured < k1 {
                    return Err(KubelkaError::infeasible(
                        "measured reflectance",
                        r_measured,
                        format!("below the surface reflection k1 = {k1} (specular included)"),
                    ));
                }
                r_measured - k1
            }
            Specular::Excluded => r_measured,
        };
        let r = y / ((1.0 - k1) * (1.0 - k2) + k2 * y);
        if r > 1.0 {
            return Err(KubelkaError::infeasible(
                "measured reflectance",
                r_measured,
                format!("more than a white film shows through this surface (internal R = {r})"),
            ));
        }
        Ok(r)
    }
}

// ---------------------------------------------------------------------------
// Pigments: masstone and tint, mixtures (Duncan 1940).

/// A pigment's own `K` and `S` from its masstone and one tint with a white
/// (Duncan's two-constant theory, in Allen's single-pigment formulation).
///
/// The masstone (the pigment alone, opaque) gives `q_m = K_p/S_p` (eq. I1);
/// the tint (concentrations `c_p` of the pigment, `c_w` of a white of known
/// `K_w`, `S_w`, opaque) gives `q_t`; Duncan's rule
/// `q_t = (c_p K_p + c_w K_w) / (c_p S_p + c_w S_w)` then fixes the scale:
///
/// ```text
/// S_p = c_w (K_w - q_t S_w) / (c_p (q_t - q_m)),   K_p = q_m S_p           (I10)
/// ```
///
/// `K_p`, `S_p` are per unit concentration, in the units of `K_w`, `S_w`
/// (often `S_w = 1`: a relative scale).
///
/// * `r_inf_masstone`, `r_inf_tint`: internal reflectances of the opaque
///   masstone and tint, in `(0, 1]` (apply [`Saunderson`] to readings first);
/// * `c_pigment`, `c_white`: concentrations in the tint, `> 0`;
/// * `white`: `K_w >= 0`, `S_w > 0`.
///
/// # Errors
/// Values outside their domain; a tint whose `K/S` is not strictly between
/// that of the white and that of the masstone (no positive `S_p` fits).
///
/// # Reference
/// Duncan (1940) (two-constant mixing); E. Allen, "Colorant formulation and
/// shading", in *Optical Radiation Measurements* vol. 2 (1980), the
/// masstone–tint determination of single-pigment constants.
///
/// ```
/// use km_core::two_flux::KmCoefficients;
/// use km_inverse::kubelka::{masstone_tint, r_inf_from_k_over_s};
/// let white = KmCoefficients { k: 0.005, s: 1.0 };
/// // A blue with K = 2, S = 0.1, tinted 1 : 9 with the white.
/// let q_t = (0.1 * 2.0 + 0.9 * 0.005) / (0.1 * 0.1 + 0.9 * 1.0);
/// let p = masstone_tint(r_inf_from_k_over_s(20.0).unwrap(),
///     r_inf_from_k_over_s(q_t).unwrap(), 0.1, 0.9, white).unwrap();
/// assert!((p.k - 2.0).abs() < 1e-12 && (p.s - 0.1).abs() < 1e-13);
/// ```
pub fn masstone_tint(
    r_inf_masstone: f64,
    r_inf_tint: f64,
    c_pigment: f64,
    c_white: f64,
    white: KmCoefficients,
) -> Result<KmCoefficients, KubelkaError> {
    for (name, c) in [("c_pigment", c_pigment), ("c_white", c_white)] {
        if !c.is_finite() || c <= 0.0 {
            return Err(KubelkaError::invalid(name, c, "concentration must be finite and > 0"));
        }
    }
    if !white.k.is_finite() || white.k < 0.0 {
        return Err(KubelkaError::invalid("K_white", white.k, "must be finite and >= 0"));
    }
    if !white.s.is_finite() || white.s <= 0.0 {
        return Err(KubelkaError::invalid("S_white", white.s, "must be finite and > 0"));
    }
    let q_m = k_over_s(r_inf_masstone).map_err(|_| {
        KubelkaError::invalid("r_inf_masstone", r_inf_masstone, "must lie in (0, 1]")
    })?;
    let q_t = k_over_s(r_inf_tint)
        .map_err(|_| KubelkaError::invalid("r_inf_tint", r_inf_tint, "must lie in (0, 1]"))?;
    let q_w = white.k / white.s;
    // A positive S_p needs q_t strictly between q_w and q_m (eq. I10).
    let between = (q_w < q_t && q_t < q_m) || (q_m < q_t && q_t < q_w);
    if !between {
        return Err(KubelkaError::infeasible(
            "r_inf_tint",
            r_inf_tint,
            format!(
                "the tint's K/S = {q_t} must lie strictly between the white's ({q_w}) and the \
                 masstone's ({q_m})"
            ),
        ));
    }
    let s_p = c_white * (white.k - q_t * white.s) / (c_pigment * (q_t - q_m));
    Ok(KmCoefficients { k: q_m * s_p, s: s_p })
}

/// The internal reflectance of a mixture of pigments (Duncan's rule,
/// `km_core::two_flux::mix_pigments`, eq. K15) as a film of thickness `X`
/// over a ground, or opaque (`thickness = inf`):
///
/// ```text
/// K = sum c_i K_i / sum c_i,  S = sum c_i S_i / sum c_i,
/// R = R_inf(K/S) (opaque, eq. I2)  or  Kubelka (1948) eq. 11 over R_g      (I11)
/// ```
///
/// Apply [`Saunderson::measured_from_internal`] for what an instrument reads.
///
/// # Errors
/// Those of `mix_pigments` and [`reflectance_over_ground`].
///
/// # Reference
/// Duncan (1940); Kubelka (1948) eq. 6 and 11.
///
/// ```
/// use km_core::two_flux::KmCoefficients;
/// use km_inverse::kubelka::{mixture_reflectance, r_inf_from_k_over_s};
/// let white = KmCoefficients { k: 0.01, s: 1.0 };
/// let black = KmCoefficients { k: 1.0, s: 0.0 };
/// let r = mixture_reflectance(&[0.5, 0.5], &[white, black], f64::INFINITY, 0.0).unwrap();
/// assert!((r - r_inf_from_k_over_s(1.01).unwrap()).abs() < 1e-15);
/// ```
pub fn mixture_reflectance(
    concentrations: &[f64],
    pigments: &[KmCoefficients],
    thickness: f64,
    r_ground: f64,
) -> Result<f64, KubelkaError> {
    let mix = two_flux::mix_pigments(concentrations, pigments)?;
    if thickness.is_infinite() && thickness > 0.0 {
        check_reflectance("r_ground", r_ground)?;
        return Ok(two_flux::r_infinity(mix.k, mix.s)?);
    }
    reflectance_over_ground(mix.k, mix.s, thickness, r_ground)
}
