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
use km_core::two_flux::{self, Slab};
use thiserror::Error;

mod duncan;
mod saunderson;
mod uncertainty;

pub use duncan::{masstone_tint, mixture_reflectance};
pub use saunderson::{Saunderson, Specular};
pub use uncertainty::{Uncertainty, black_white_uncertainty, r_inf_r0_uncertainty};

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
