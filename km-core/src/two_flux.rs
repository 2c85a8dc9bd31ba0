//! # Two-flux Kubelka–Munk theory (seed 000 §2)
//!
//! Two diffuse fluxes, `i+` going down (depth `z` grows downward) and `i-`
//! going up, obey (seed eq. 2, with `K` the absorption and `S` the
//! back-scattering coefficient of the two-flux model, both 1/length)
//!
//! ```text
//! d i+/dz = -(K + S) i+ + S i-
//! d i-/dz = -S i+ + (K + S) i-                                  (2)
//! ```
//!
//! The theory note `docs/two-flux.md` derives everything here, names the
//! seed's misprints and numbers the equations; the `(eq. n)` tags below refer
//! to the seed's numbering, `(eq. Kn)` to the note's additions.
//!
//! ## What is here
//! * Single layer, closed form and scaled so nothing overflows
//!   ([`layer_rt`], [`r_infinity`], [`profile`]): `a = (K + S)/S`,
//!   `b = sqrt(a^2 - 1)`, `lambda = b S = sqrt(K (K + 2 S))` (eq. 4 corrected),
//!   `R = sinh(bSz0) / (a sinh + b cosh)`, `T = b / (a sinh + b cosh)` (eq. 10),
//!   `R_inf = a - b`.
//! * The seed's eigen form itself ([`eigen`], [`eigen_profile`], eq. 3–8), with
//!   its boundary matrix `F` written with decaying exponentials.
//! * Concatenation of any number of layers: the adding form ([`add`],
//!   [`stack_adding`], eq. 14 re-derived; the robust default) and the transfer
//!   matrix form ([`Transfer`], eq. 11–13, scaled).
//! * Mappings from the scene's `(sigma_a, sigma_s, g)` to `(K, S)` ([`KmMapping`]),
//!   Saunderson's interface correction ([`Slab::saunderson_top`]), Duncan's
//!   pigment mixing ([`mix_pigments`]), and the scene-level solver [`solve`].
//!
//! Every function returns finite values for finite inputs: thickness up to
//! `inf`, `K` down to 0 (the closed form's `0/0`), `S = 0`.

use std::f64::consts::{LN_2, PI};
use std::str::FromStr;
use std::time::Instant;

use serde_json::{Map, json};

use crate::error::CoreError;
use crate::fresnel;
use crate::layer::Layer;
use crate::scene::{Light, MonoScene, Scene, Substrate};
use crate::solution::{ChannelResult, Solution};

// ---------------------------------------------------------------------------
// Single layer.

/// Reflectance, transmittance and absorptance of one symmetric two-flux layer
/// for diffuse flux incident on one face (`r + t + a = 1`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rt {
    /// Reflectance `R` (eq. 10).
    pub r: f64,
    /// Transmittance `T` (eq. 10).
    pub t: f64,
    /// Absorptance `A = 1 - R - T`, computed as a sum of non-negative terms (eq. K3).
    pub a: f64,
}

/// Two fluxes at one depth: `down = i+`, `up = i-` (seed eq. 2 notation).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Fluxes {
    /// Downward flux `i+`.
    pub down: f64,
    /// Upward flux `i-`.
    pub up: f64,
}

fn check_ks(k: f64, s: f64) -> Result<(), CoreError> {
    if !k.is_finite() || k < 0.0 {
        return Err(CoreError::invalid("K", k, "must be finite and >= 0"));
    }
    if !s.is_finite() || s < 0.0 {
        return Err(CoreError::invalid("S", s, "must be finite and >= 0"));
    }
    if !(k + s).is_finite() {
        return Err(CoreError::invalid("K + S", k + s, "must be finite"));
    }
    Ok(())
}

fn check_thickness(d: f64) -> Result<(), CoreError> {
    if d.is_nan() || d < 0.0 {
        return Err(CoreError::invalid("thickness", d, "must be >= 0 (or inf)"));
    }
    Ok(())
}

/// The eigenvalue `lambda = b S = sqrt(K (K + 2 S))` (eq. 4 corrected:
/// `lambda^2 = sigma_t^2 - sigma_s^2 = K (K + 2 S)`), computed without the
/// cancellation of `sigma_t^2 - sigma_s^2` and without overflow of `K (K + 2 S)`.
fn lambda_of(k: f64, s: f64) -> f64 {
    k.sqrt() * (0.5 * k + s).sqrt() * std::f64::consts::SQRT_2
}

/// `h(d) = (1 - exp(-2 lambda d)) / lambda`, the scaled `2 sinh(x) e^{-x} / lambda`
/// (eq. K1); `h -> 2 d` as `lambda -> 0` and `h = 1/lambda` for a half-space.
fn h_of(lambda: f64, d: f64) -> f64 {
    if d.is_infinite() {
        return if lambda > 0.0 { 1.0 / lambda } else { f64::INFINITY };
    }
    let x = lambda * d;
    if x > 20.0 {
        // 1 - exp(-40) rounds to 1 in f64.
        1.0 / lambda
    } else if x < 1e-150 {
        // -expm1(-2x) / (2x) = 1 - x + ..., and x is below any rounding.
        2.0 * d
    } else {
        d * (-(-2.0 * x).exp_m1()) / x
    }
}

/// Scaled single-layer quantities for finite `d` (eq. K2–K3).
///
/// With `x = lambda d`, `e = exp(-2x)`, `h` of eq. K1:
/// `R = S h / (1 + e + (K+S) h)`, `T = 2 exp(-x) / (1 + e + (K+S) h)`,
/// `A = (K h + (1 - exp(-x))^2) / (1 + e + (K+S) h)`; for `h > 1` numerator and
/// denominator are divided by `h` so nothing overflows. Two transcendental
/// calls: `1 - e = (1 - exp(-x)) (1 + exp(-x))` and `e = exp(-x)^2`.
struct Parts {
    r: f64,
    t: f64,
    a: f64,
    /// `ln T`, from `x`, `h` and the denominator without forming `T`.
    ln_t: f64,
}

fn layer_parts(k: f64, s: f64, d: f64, want_ln: bool) -> Parts {
    if s == 0.0 {
        // No scattering: Beer–Lambert exactly, R = 0, T = exp(-K z0).
        return Parts { r: 0.0, t: (-k * d).exp(), a: -(-k * d).exp_m1(), ln_t: -k * d };
    }
    let sigma_t = k + s;
    let lambda = lambda_of(k, s);
    let x = lambda * d;
    let ex = (-x).exp();
    let em1 = -(-x).exp_m1();
    let e = ex * ex;
    // h of eq. K1, with 1 - exp(-2x) = em1 (1 + ex).
    let h = if x > 20.0 {
        1.0 / lambda
    } else if x < 1e-150 {
        2.0 * d
    } else {
        d * (em1 * (1.0 + ex)) / x
    };
    if h <= 1.0 {
        let den = 1.0 + e + sigma_t * h;
        let ln_t = if want_ln { LN_2 - x - den.ln() } else { 0.0 };
        Parts { r: s * h / den, t: 2.0 * ex / den, a: (k * h + em1 * em1) / den, ln_t }
    } else {
        let den = (1.0 + e) / h + sigma_t;
        let ln_t = if want_ln { LN_2 - x - h.ln() - den.ln() } else { 0.0 };
        Parts { r: s / den, t: 2.0 * ex / h / den, a: (k + em1 * em1 / h) / den, ln_t }
    }
}

/// Reflectance `R` and transmittance `T` of one layer (seed eq. 10), scaled.
///
/// `R = sinh(b S z0) / (a sinh(b S z0) + b cosh(b S z0))`,
/// `T = b / (a sinh(b S z0) + b cosh(b S z0))`, with `a = (K + S)/S`,
/// `b = sqrt(a^2 - 1)`. Evaluated in the scaled form of eq. K2, which stays
/// finite for every finite input: `K -> 0` gives `R = S z0 / (1 + S z0)`,
/// `S = 0` gives `R = 0, T = exp(-K z0)`, `z0 = 0` gives `R = 0, T = 1`, and
/// `z0 = inf` gives the half-space `R = R_inf = a - b`, `T = 0` (`T = 1` for a
/// clear half-space, `K = S = 0`: the light goes down for ever).
///
/// * `k`: two-flux absorption coefficient `K`, 1/length, `>= 0`.
/// * `s`: two-flux scattering coefficient `S`, 1/length, `>= 0`.
/// * `thickness`: `z0`, length, `>= 0` or `inf`.
///
/// # Errors
/// Negative or non-finite `K`, `S`; negative or NaN thickness.
///
/// # Reference
/// Seed 000 eq. 10; Kubelka (1948).
///
/// ```
/// use km_core::two_flux::layer_rt;
/// let rt = layer_rt(0.1, 0.4, 1.0).unwrap();
/// assert!((rt.r + rt.t + rt.a - 1.0).abs() < 1e-15);
/// // No absorption: R = S z0 / (1 + S z0).
/// let c = layer_rt(0.0, 2.0, 1.5).unwrap();
/// assert!((c.r - 3.0 / 4.0).abs() < 1e-15);
/// // No scattering: Beer–Lambert.
/// let b = layer_rt(0.7, 0.0, 2.0).unwrap();
/// assert!((b.t - (-1.4f64).exp()).abs() < 1e-15 && b.r == 0.0);
/// ```
pub fn layer_rt(k: f64, s: f64, thickness: f64) -> Result<Rt, CoreError> {
    check_ks(k, s)?;
    check_thickness(thickness)?;
    if thickness.is_infinite() {
        let r = r_infinity(k, s)?;
        let sigma_t = k + s;
        if sigma_t == 0.0 {
            return Ok(Rt { r: 0.0, t: 1.0, a: 0.0 });
        }
        // A = 1 - R_inf = (K + lambda) / (K + S + lambda).
        let lambda = lambda_of(k, s);
        return Ok(Rt { r, t: 0.0, a: (k + lambda) / (sigma_t + lambda) });
    }
    let p = layer_parts(k, s, thickness, false);
    Ok(Rt { r: p.r, t: p.t, a: p.a })
}

/// Reflectance of a half-space `R_inf = a - b` (seed §2, the limit of eq. 10).
///
/// Evaluated as `R_inf = S / (K + S + sqrt(K (K + 2 S)))` (eq. K4, `a - b =
/// 1/(a + b)`), exact for `S -> 0` where `a - b` cancels; 0 for `S = 0`.
///
/// # Errors
/// Negative or non-finite `K`, `S`.
///
/// # Reference
/// Kubelka & Munk (1931); Kubelka (1948).
///
/// ```
/// let r = km_core::two_flux::r_infinity(0.1, 0.4).unwrap();
/// let a: f64 = 0.5 / 0.4;
/// assert!((r - (a - (a * a - 1.0).sqrt())).abs() < 1e-15);
/// ```
pub fn r_infinity(k: f64, s: f64) -> Result<f64, CoreError> {
    check_ks(k, s)?;
    if s == 0.0 {
        return Ok(0.0);
    }
    Ok(s / (k + s + lambda_of(k, s)))
}

/// The fluxes `i+(z)`, `i-(z)` inside one layer lit by a unit flux from above
/// and nothing from below (seed eq. 9), scaled.
///
/// `i+(z) = (a sinh(bS(z0 - z)) + b cosh(bS(z0 - z))) / (a sinh(bSz0) + b cosh(bSz0))`,
/// `i-(z) = sinh(bS(z0 - z)) / (a sinh(bSz0) + b cosh(bSz0))`, evaluated as
/// `i+(z) = exp(-lambda z) ((K+S) h(z0-z) + 1 + e(z0-z)) / ((K+S) h(z0) + 1 + e(z0))`,
/// `i-(z) = exp(-lambda z) S h(z0-z) / ((K+S) h(z0) + 1 + e(z0))` (eq. K5),
/// with `e(d) = exp(-2 lambda d)` and `h` of eq. K1.
///
/// * `z`: depth, `0 <= z <= thickness` (finite).
///
/// # Errors
/// Invalid `K`, `S`, thickness; `z` outside the layer.
///
/// # Reference
/// Seed 000 eq. 9.
///
/// ```
/// use km_core::two_flux::{layer_rt, profile};
/// let top = profile(0.1, 0.4, 2.0, 0.0).unwrap();
/// let bottom = profile(0.1, 0.4, 2.0, 2.0).unwrap();
/// let rt = layer_rt(0.1, 0.4, 2.0).unwrap();
/// assert!((top.down - 1.0).abs() < 1e-15 && (top.up - rt.r).abs() < 1e-15);
/// assert!((bottom.down - rt.t).abs() < 1e-15 && bottom.up == 0.0);
/// ```
pub fn profile(k: f64, s: f64, thickness: f64, z: f64) -> Result<Fluxes, CoreError> {
    check_ks(k, s)?;
    check_thickness(thickness)?;
    if !z.is_finite() || z < 0.0 || z > thickness {
        return Err(CoreError::invalid("z", z, "depth must lie in [0, thickness]"));
    }
    let sigma_t = k + s;
    let lambda = lambda_of(k, s);
    if thickness.is_infinite() && lambda == 0.0 {
        // K = 0 half-space: everything comes back (R = 1), or nothing scatters.
        let up = if s > 0.0 { 1.0 } else { 0.0 };
        return Ok(Fluxes { down: 1.0, up });
    }
    let rest = thickness - z;
    let (h0, hz) = (h_of(lambda, thickness), h_of(lambda, rest));
    let e0 = if thickness.is_infinite() { 0.0 } else { (-2.0 * lambda * thickness).exp() };
    let ez = if rest.is_infinite() { 0.0 } else { (-2.0 * lambda * rest).exp() };
    let decay = (-lambda * z).exp();
    let (down, up) = if h0 <= 1.0 {
        let den = 1.0 + e0 + sigma_t * h0;
        (decay * (sigma_t * hz + 1.0 + ez) / den, decay * s * hz / den)
    } else {
        // Divide by h0 (>= hz) so nothing overflows.
        let den = (1.0 + e0) / h0 + sigma_t;
        let q = hz / h0;
        (decay * (sigma_t * q + (1.0 + ez) / h0) / den, decay * s * q / den)
    };
    Ok(Fluxes { down, up })
}

/// The fluxes inside one layer lit from both faces: `down_top` enters at
/// `z = 0` going down, `up_bottom` enters at `z = z0` going up. By linearity
/// and the layer's up–down symmetry (eq. K5b):
/// `i+(z) = down_top P+(z) + up_bottom P-(z0 - z)`,
/// `i-(z) = down_top P-(z) + up_bottom P+(z0 - z)`, with `P` of [`profile`].
///
/// Inside a stack, `down_top` and `up_bottom` of layer `k` are the junction
/// fluxes `down[k]` and `up[k + 1]` of [`stack_adding`] (index of its slab).
///
/// # Errors
/// Those of [`profile`]; a half-space with `up_bottom != 0`; non-finite or
/// negative incident fluxes.
///
/// # Reference
/// Seed 000 eq. 9 (superposed).
///
/// ```
/// use km_core::two_flux::{layer_rt, profile_two_sided};
/// // Lit from below only: the top sees T going up.
/// let p = profile_two_sided(0.1, 0.4, 2.0, 0.0, 0.0, 1.0).unwrap();
/// assert!((p.up - layer_rt(0.1, 0.4, 2.0).unwrap().t).abs() < 1e-15);
/// ```
pub fn profile_two_sided(
    k: f64,
    s: f64,
    thickness: f64,
    z: f64,
    down_top: f64,
    up_bottom: f64,
) -> Result<Fluxes, CoreError> {
    for (name, v) in [("down_top", down_top), ("up_bottom", up_bottom)] {
        if !v.is_finite() || v < 0.0 {
            return Err(CoreError::invalid(name, v, "incident flux must be finite and >= 0"));
        }
    }
    let from_top = profile(k, s, thickness, z)?;
    if up_bottom == 0.0 {
        return Ok(Fluxes { down: down_top * from_top.down, up: down_top * from_top.up });
    }
    if thickness.is_infinite() {
        return Err(CoreError::invalid("up_bottom", up_bottom, "a half-space has no bottom face"));
    }
    // Mirror image: light from below sees the layer upside down.
    let from_bottom = profile(k, s, thickness, (thickness - z).max(0.0))?;
    Ok(Fluxes {
        down: down_top * from_top.down + up_bottom * from_bottom.up,
        up: down_top * from_top.up + up_bottom * from_bottom.down,
    })
}

// ---------------------------------------------------------------------------
// The seed's eigen form (eq. 3–8).

/// Eigen-decomposition of `Q = [[-(K+S), S], [-S, K+S]]` (seed eq. 3–4, corrected).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Eigen {
    /// `lambda_1 = +lambda`, `lambda_2 = -lambda`, `lambda = sqrt((K+S)^2 - S^2)`
    /// (eq. 4; the seed prints `+ S^2`).
    pub lambda: [f64; 2],
    /// Columns of `V`: `v[j] = (v_j1, v_j2)`, proportional to `(1, a +- b)`,
    /// normalised to unit length (eq. 4).
    pub v: [[f64; 2]; 2],
}

/// The eigenvalues and eigenvectors of the two-flux matrix `Q` (seed eq. 4).
///
/// `lambda_{1,2} = +-(sigma_t^2 - sigma_s^2)^{1/2}`,
/// `v_{1,2} = (1, a +- b) / (2a^2 +- 2ab)^{1/2}` with `a = sigma_t / sigma_s`,
/// `b = (a^2 - 1)^{1/2}`. `a - b` is evaluated as `1/(a + b)` and the norm as
/// `hypot(1, a +- b)` (equal to the seed's `(2a^2 +- 2ab)^{1/2}`).
///
/// # Errors
/// `S = 0` (`a` infinite) or `K = 0` (`b = 0`: one defective eigenvalue, `Q`
/// is not diagonalisable): use the closed forms ([`layer_rt`], [`profile`]),
/// which cover these limits.
///
/// # Reference
/// Seed 000 eq. 3–4.
///
/// ```
/// let e = km_core::two_flux::eigen(0.1, 0.4).unwrap();
/// assert!((e.lambda[0] - (0.25f64 - 0.16).sqrt()).abs() < 1e-15);
/// ```
pub fn eigen(k: f64, s: f64) -> Result<Eigen, CoreError> {
    check_ks(k, s)?;
    if s == 0.0 {
        return Err(CoreError::invalid("S", s, "the eigen form needs S > 0 (a = (K+S)/S)"));
    }
    if k == 0.0 {
        return Err(CoreError::invalid("K", k, "the eigen form needs K > 0 (Q is defective)"));
    }
    let a = (k + s) / s;
    let lambda = lambda_of(k, s);
    let b = lambda / s;
    let plus = a + b;
    let minus = 1.0 / plus;
    let n1 = 1.0f64.hypot(plus);
    let n2 = 1.0f64.hypot(minus);
    Ok(Eigen { lambda: [lambda, -lambda], v: [[1.0 / n1, plus / n1], [1.0 / n2, minus / n2]] })
}

/// The fluxes of eq. 8 for unit incidence, through the eigen form with the
/// boundary matrix `F` of eq. 6, rescaled so every exponential decays.
///
/// The growing mode is anchored at the bottom, `i~_1(z) = c1' exp(lambda (z - z0))`,
/// the decaying one at the top, `i~_2(z) = c2 exp(-lambda z)`, so the seed's
/// `F = [[v11, v21], [v12 exp(lambda_1 z0), v22 exp(lambda_2 z0)]]` becomes
/// `F' = [[v11 E, v21], [v12, v22 E]]`, `E = exp(-lambda z0) <= 1` (eq. K6),
/// and `I(z) = c1' v_1 exp(lambda (z - z0)) + c2 v_2 exp(-lambda z)`.
///
/// # Errors
/// Those of [`eigen`] and [`profile`].
///
/// # Reference
/// Seed 000 eq. 5–8; the scaling is that of Stamnes & Conklin (1984).
pub fn eigen_profile(k: f64, s: f64, thickness: f64, z: f64) -> Result<Fluxes, CoreError> {
    let e = eigen(k, s)?;
    check_thickness(thickness)?;
    if !z.is_finite() || z < 0.0 || z > thickness {
        return Err(CoreError::invalid("z", z, "depth must lie in [0, thickness]"));
    }
    let lambda = e.lambda[0];
    let [[v11, v12], [v21, v22]] = e.v;
    let big_e = if thickness.is_infinite() { 0.0 } else { (-lambda * thickness).exp() };
    // Solve F' c = (1, 0) by Cramer's rule (eq. 7).
    let det = v11 * big_e * v22 * big_e - v21 * v12;
    let c1 = (v22 * big_e) / det;
    let c2 = -v12 / det;
    let g1 = if thickness.is_infinite() { 0.0 } else { (-lambda * (thickness - z)).exp() };
    let g2 = (-lambda * z).exp();
    Ok(Fluxes { down: c1 * v11 * g1 + c2 * v21 * g2, up: c1 * v12 * g1 + c2 * v22 * g2 })
}

// ---------------------------------------------------------------------------
// Slabs (layers, interfaces, substrates) and their concatenation.

/// Anything with two faces for the two fluxes: a layer, an interface, a stack
/// or an opaque ground. Reflectances and transmittances for diffuse flux from
/// above (`_top`, `_tb`) and from below (`_bottom`, `_bt`); `r + t + a = 1` on
/// each side.
///
/// In the seed's notation of eq. 11: `R11 = t_tb`, `R21 = r_top`,
/// `R12 = r_bottom`, `R22 = t_bt`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Slab {
    /// Reflectance for flux from above (`R21`).
    pub r_top: f64,
    /// Transmittance top to bottom (`R11`).
    pub t_tb: f64,
    /// Reflectance for flux from below (`R12`).
    pub r_bottom: f64,
    /// Transmittance bottom to top (`R22`).
    pub t_bt: f64,
    /// Absorptance for flux from above.
    pub a_top: f64,
    /// Absorptance for flux from below.
    pub a_bottom: f64,
}

impl Slab {
    /// Nothing at all: `t = 1` both ways.
    pub const CLEAR: Slab =
        Slab { r_top: 0.0, t_tb: 1.0, r_bottom: 0.0, t_bt: 1.0, a_top: 0.0, a_bottom: 0.0 };

    /// A symmetric two-flux layer ([`layer_rt`]); `thickness = inf` gives a half-space.
    ///
    /// # Errors
    /// Those of [`layer_rt`].
    pub fn layer(k: f64, s: f64, thickness: f64) -> Result<Slab, CoreError> {
        let rt = layer_rt(k, s, thickness)?;
        Ok(Slab {
            r_top: rt.r,
            t_tb: rt.t,
            r_bottom: rt.r,
            t_bt: rt.t,
            a_top: rt.a,
            a_bottom: rt.a,
        })
    }

    /// An opaque ground of hemispherical reflectance `albedo` in `[0, 1]`
    /// (Lambertian substrate; `albedo = 0` is black; a half-space layer is the
    /// ground `R_inf`). Nothing is transmitted; light from below is irrelevant.
    ///
    /// # Errors
    /// `albedo` outside `[0, 1]`.
    pub fn ground(albedo: f64) -> Result<Slab, CoreError> {
        if !(0.0..=1.0).contains(&albedo) {
            return Err(CoreError::invalid("albedo", albedo, "must lie in [0, 1]"));
        }
        Ok(Slab {
            r_top: albedo,
            t_tb: 0.0,
            r_bottom: 0.0,
            t_bt: 0.0,
            a_top: 1.0 - albedo,
            a_bottom: 1.0,
        })
    }

    /// A smooth interface between indices `n_above` and `n_below` for diffuse
    /// flux on both sides: `r_top = R_h(n_above -> n_below)`,
    /// `r_bottom = R_h(n_below -> n_above)` (hemispherical Fresnel reflectance,
    /// [`fresnel::diffuse_reflectance`]), `t = 1 - r`, no absorption.
    ///
    /// # Errors
    /// Indices not finite or below 1.
    pub fn interface_diffuse(n_above: f64, n_below: f64) -> Result<Slab, CoreError> {
        HemisphericalCache::default().interface(n_above, n_below)
    }

    /// Saunderson's top interface (Saunderson 1942): external reflectance
    /// `r_e` for the scene's light (collimated at `theta`: the Fresnel
    /// reflectance at `theta`; diffuse: the hemispherical one from outside)
    /// and internal diffuse reflectance `r_i = R_h(n_layer -> n_ambient)`.
    /// Added on top of a stack of reflectance `R`, it gives Saunderson's
    /// `R' = r_e + (1 - r_e)(1 - r_i) R / (1 - r_i R)` (eq. K12).
    ///
    /// # Errors
    /// Indices not finite or below 1.
    pub fn saunderson_top(light: Light, n_ambient: f64, n_layer: f64) -> Result<Slab, CoreError> {
        HemisphericalCache::default().saunderson_top(light, n_ambient, n_layer)
    }

    /// A lossless interface of reflectances `r_top`, `r_bottom` (`t = 1 - r`).
    fn interface(r_top: f64, r_bottom: f64) -> Slab {
        Slab { r_top, t_tb: 1.0 - r_top, r_bottom, t_bt: 1.0 - r_bottom, a_top: 0.0, a_bottom: 0.0 }
    }

    /// `1 - r_top`, as the sum `t_tb + a_top` (no cancellation when `r_top -> 1`).
    fn one_minus_r_top(&self) -> f64 {
        self.t_tb + self.a_top
    }

    /// `1 - r_bottom`, as the sum `t_bt + a_bottom`.
    fn one_minus_r_bottom(&self) -> f64 {
        self.t_bt + self.a_bottom
    }
}

fn check_n(name: &str, n: f64) -> Result<(), CoreError> {
    if !n.is_finite() || n < 1.0 {
        return Err(CoreError::invalid(name, n, "refractive index must be finite and >= 1"));
    }
    Ok(())
}

/// Adding two slabs, `top` over `bottom` (seed eq. 14, first line re-derived;
/// van de Hulst's adding formula / the Redheffer star product).
///
/// With `D = 1 - r_bottom(1) r_top(2)` (the geometric series of the
/// inter-reflections between the two slabs):
///
/// ```text
/// t_tb(12)     = t_tb(2) t_tb(1) / D                            (14a)
/// r_top(12)    = r_top(1) + t_bt(1) r_top(2) t_tb(1) / D        (14b)
/// r_bottom(12) = r_bottom(2) + t_tb(2) r_bottom(1) t_bt(2) / D  (14c)
/// t_bt(12)     = t_bt(1) t_bt(2) / D                            (14d)
/// ```
///
/// For symmetric layers `R12 = R1 + T1^2 R2 / (1 - R1 R2)` and
/// `T12 = T1 T2 / (1 - R1 R2)`. `D` is evaluated as
/// `(1 - r_bottom(1)) + r_bottom(1) (1 - r_top(2))` with each `1 - r` taken as
/// `t + a`, so every term is non-negative. The absorptances follow from the
/// flux at the junction (eq. K8).
///
/// # Reference
/// Seed 000 eq. 14; van de Hulst (1980), the adding method.
///
/// ```
/// use km_core::two_flux::{add, Slab};
/// let one = Slab::layer(0.1, 0.4, 1.0).unwrap();
/// let half = Slab::layer(0.1, 0.4, 0.5).unwrap();
/// let two = add(&half, &half);
/// assert!((two.r_top - one.r_top).abs() < 1e-15 && (two.t_tb - one.t_tb).abs() < 1e-15);
/// ```
pub fn add(top: &Slab, bottom: &Slab) -> Slab {
    // Inter-reflection denominator, all terms >= 0.
    let den = top.one_minus_r_bottom() + top.r_bottom * bottom.one_minus_r_top();
    let inv = if den > 0.0 { 1.0 / den } else { 0.0 };
    // Downward flux at the junction for unit flux from above; upward for unit flux from below.
    let down = top.t_tb * inv;
    let up = bottom.t_bt * inv;
    Slab {
        r_top: top.r_top + top.t_bt * bottom.r_top * down,
        t_tb: bottom.t_tb * down,
        r_bottom: bottom.r_bottom + bottom.t_tb * top.r_bottom * up,
        t_bt: top.t_bt * up,
        // Absorbed in the top slab (from the junction) and in the bottom one.
        a_top: top.a_top + down * (top.a_bottom * bottom.r_top + bottom.a_top),
        a_bottom: bottom.a_bottom + up * (bottom.a_top * top.r_bottom + top.a_bottom),
    }
}

/// The fluxes of a stack lit by a unit flux from above.
#[derive(Debug, Clone, PartialEq)]
pub struct StackFluxes {
    /// Total reflectance of the stack.
    pub r: f64,
    /// Total transmittance (out of the bottom of the last slab).
    pub t: f64,
    /// Fraction absorbed in each slab, top first.
    pub absorbed: Vec<f64>,
    /// Downward flux just above each slab, and below the last (`len + 1` values).
    pub down: Vec<f64>,
    /// Upward flux just above each slab, and below the last (`len + 1` values).
    pub up: Vec<f64>,
}

/// Any number of slabs, top first, by the adding form (eq. 14), with the
/// fluxes at every junction and the absorption in every slab.
///
/// First the stacks below each junction are added from the bottom up
/// (`B_k = slab_k + B_{k+1}`), then the fluxes go down:
/// `d_{k+1} = t_tb(k) d_k / (1 - r_bottom(k) r_top(B_{k+1}))`,
/// `u_k = r_top(B_k) d_k`, and slab `k` absorbs `a_top(k) d_k + a_bottom(k) u_{k+1}`
/// (eq. K9). An empty slice is a clear stack (`r = 0, t = 1`).
///
/// # Reference
/// Seed 000 eq. 14; van de Hulst (1980), the adding method.
///
/// ```
/// use km_core::two_flux::{stack_adding, Slab};
/// let s = [Slab::layer(0.1, 0.4, 1.0).unwrap(), Slab::ground(0.8).unwrap()];
/// let f = stack_adding(&s);
/// let a: f64 = f.absorbed.iter().sum();
/// assert!((f.r + f.t + a - 1.0).abs() < 1e-15);
/// ```
pub fn stack_adding(slabs: &[Slab]) -> StackFluxes {
    let n = slabs.len();
    // below[k]: everything from slab k down (below[n]: nothing, clear).
    let mut below = vec![Slab::CLEAR; n + 1];
    for k in (0..n).rev() {
        below[k] = add(&slabs[k], &below[k + 1]);
    }
    // Down pass: total downward flux above each slab and the upward flux there.
    let mut down = vec![0.0; n + 1];
    let mut up = vec![0.0; n + 1];
    let mut absorbed = vec![0.0; n];
    down[0] = 1.0;
    for k in 0..n {
        let s = &slabs[k];
        let b = &below[k + 1];
        let den = s.one_minus_r_bottom() + s.r_bottom * b.one_minus_r_top();
        let inv = if den > 0.0 { 1.0 / den } else { 0.0 };
        down[k + 1] = s.t_tb * down[k] * inv;
        up[k + 1] = b.r_top * down[k + 1];
        up[k] = below[k].r_top * down[k];
        absorbed[k] = s.a_top * down[k] + s.a_bottom * up[k + 1];
    }
    StackFluxes { r: below[0].r_top, t: down[n], absorbed, down, up }
}

/// Transfer matrix `A` of a slab or stack (seed eq. 11–13), kept scaled:
/// `A = exp(log_scale) M` with `max |M_ij| = 1`, and `ln det A` kept apart.
///
/// `A` maps the fluxes above a slab to those below,
/// `(i+_below, i-_below) = A (i+_above, i-_above)`, so a stack is the product
/// `A_n ... A_2 A_1` (eq. 11's concatenation). From a slab (eq. 12):
/// `A11 = t_tb - r_bottom r_top / t_bt`, `A12 = r_bottom / t_bt`,
/// `A21 = -r_top / t_bt`, `A22 = 1 / t_bt`, and `det A = t_tb / t_bt`.
/// Back to a slab (eq. 13), with the first line rewritten through the
/// determinant, `t_tb = A11 - A12 A21 / A22 = det A / A22`, which avoids the
/// cancellation of the seed's form (relative error `eps exp(2 lambda z0)`).
/// Opaque slabs (`t = 0`) have no transfer matrix: a ground enters as the
/// boundary condition of [`Transfer::reflectance_over`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Transfer {
    /// Scaled matrix `M`, rows then columns.
    pub m: [[f64; 2]; 2],
    /// `ln` of the scale factor: `A = exp(log_scale) M`.
    pub log_scale: f64,
    /// `ln det A` (0 for symmetric slabs).
    pub log_det: f64,
}

impl Transfer {
    /// The identity (no slab).
    pub const IDENTITY: Transfer =
        Transfer { m: [[1.0, 0.0], [0.0, 1.0]], log_scale: 0.0, log_det: 0.0 };

    /// The transfer matrix of one two-flux layer of finite thickness, built
    /// from the scaled eq. K2 so that `1/T` never overflows:
    /// `A = (1/T) [[T^2 - R^2, R], [-R, 1]]`.
    ///
    /// # Errors
    /// Those of [`layer_rt`]; an infinite thickness (a half-space is opaque:
    /// use it as the ground of [`Transfer::reflectance_over`]).
    pub fn layer(k: f64, s: f64, thickness: f64) -> Result<Transfer, CoreError> {
        check_ks(k, s)?;
        check_thickness(thickness)?;
        if thickness.is_infinite() {
            return Err(CoreError::invalid(
                "thickness",
                thickness,
                "a half-space has no transfer matrix; use it as the ground",
            ));
        }
        let p = layer_parts(k, s, thickness, true);
        let (r, t) = (p.r, p.t);
        Ok(Transfer { m: [[t * t - r * r, r], [-r, 1.0]], log_scale: -p.ln_t, log_det: 0.0 }
            .normalised())
    }

    /// The transfer matrix of a slab (eq. 12).
    ///
    /// # Errors
    /// A slab that does not transmit both ways (`t_tb = 0` or `t_bt = 0`).
    pub fn from_slab(slab: &Slab) -> Result<Transfer, CoreError> {
        if slab.t_bt <= 0.0 || slab.t_tb <= 0.0 {
            return Err(CoreError::invalid(
                "t",
                slab.t_bt.min(slab.t_tb),
                "an opaque slab has no transfer matrix; use it as the ground",
            ));
        }
        let m = [
            [slab.t_tb * slab.t_bt - slab.r_bottom * slab.r_top, slab.r_bottom],
            [-slab.r_top, 1.0],
        ];
        Ok(Transfer { m, log_scale: -slab.t_bt.ln(), log_det: (slab.t_tb / slab.t_bt).ln() }
            .normalised())
    }

    fn normalised(self) -> Transfer {
        let big = self.m.iter().flatten().fold(0.0f64, |acc, x| acc.max(x.abs()));
        if big == 0.0 || !big.is_finite() {
            return self;
        }
        let m = self.m.map(|row| row.map(|x| x / big));
        Transfer { m, log_scale: self.log_scale + big.ln(), ..self }
    }

    /// This stack with `below` under it: `A = A_below A_self` (eq. 11).
    pub fn then(&self, below: &Transfer) -> Transfer {
        let (a, b) = (&below.m, &self.m);
        let m = [
            [a[0][0] * b[0][0] + a[0][1] * b[1][0], a[0][0] * b[0][1] + a[0][1] * b[1][1]],
            [a[1][0] * b[0][0] + a[1][1] * b[1][0], a[1][0] * b[0][1] + a[1][1] * b[1][1]],
        ];
        Transfer {
            m,
            log_scale: self.log_scale + below.log_scale,
            log_det: self.log_det + below.log_det,
        }
        .normalised()
    }

    /// Back to reflectances and transmittances (eq. 13, first line through `det A`).
    /// The absorptances are `1 - r - t`, clamped at 0 against rounding.
    pub fn to_slab(&self) -> Slab {
        let m = &self.m;
        let r_top = -m[1][0] / m[1][1];
        let r_bottom = m[0][1] / m[1][1];
        let ln_m22 = m[1][1].ln();
        let t_bt = (-self.log_scale - ln_m22).exp();
        let t_tb = (self.log_det - self.log_scale - ln_m22).exp();
        Slab {
            r_top,
            t_tb,
            r_bottom,
            t_bt,
            a_top: (1.0 - r_top - t_tb).max(0.0),
            a_bottom: (1.0 - r_bottom - t_bt).max(0.0),
        }
    }

    /// Reflectance of this stack over an opaque ground of reflectance `r_ground`:
    /// the bottom boundary condition `i-_below = r_ground i+_below` gives
    /// `R = (r_ground A11 - A21) / (A22 - r_ground A12)` (eq. K10).
    pub fn reflectance_over(&self, r_ground: f64) -> f64 {
        let m = &self.m;
        (r_ground * m[0][0] - m[1][0]) / (m[1][1] - r_ground * m[0][1])
    }
}

/// Concatenate slabs (top first) by transfer matrices (eq. 11–13). An opaque
/// last slab (a ground, or a half-space layer) enters as a boundary condition.
/// Returns `(R, T)` of the stack.
///
/// # Errors
/// A slab other than the last that does not transmit.
///
/// # Reference
/// Seed 000 eq. 11–13.
pub fn stack_transfer(slabs: &[Slab]) -> Result<(f64, f64), CoreError> {
    let (last, rest) = match slabs.split_last() {
        None => return Ok((0.0, 1.0)),
        Some(x) => x,
    };
    let opaque = last.t_tb == 0.0;
    let upper = if opaque { rest } else { slabs };
    let mut a = Transfer::IDENTITY;
    for s in upper {
        a = a.then(&Transfer::from_slab(s)?);
    }
    if opaque {
        Ok((a.reflectance_over(last.r_top), 0.0))
    } else {
        let s = a.to_slab();
        Ok((s.r_top, s.t_tb))
    }
}

// ---------------------------------------------------------------------------
// From the scene's coefficients to K and S.

/// How the scene's `(sigma_a, sigma_s, g)` become the two-flux `(K, S)`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum KmMapping {
    /// `K = sigma_a`, `S = sigma_s`, as in the seed (eq. 1–2); `g` is ignored.
    #[default]
    Seed,
    /// Star, Marijnissen & van Gemert (1988), from diffusion theory:
    /// `K = 2 sigma_a`, `S = (3/4) sigma_s (1 - g) - (1/4) sigma_a` (eq. K13).
    /// Needs `3 sigma_s (1 - g) >= sigma_a` (`S >= 0`).
    StarEtAl1988,
    /// Gate (1974), confirmed by Thennadil (2008) for diffuse light:
    /// `K = 2 sigma_a`, `S = (3/4) sigma_s (1 - g)` (eq. K14).
    Gate1974,
}

impl KmMapping {
    /// The name used in the JSON output and on the command line.
    pub fn name(&self) -> &'static str {
        match self {
            KmMapping::Seed => "seed",
            KmMapping::StarEtAl1988 => "star1988",
            KmMapping::Gate1974 => "gate1974",
        }
    }

    /// `(K, S)` of a layer under this mapping (eq. K13–K14).
    ///
    /// # Errors
    /// A mapping that gives `S < 0` (Star et al. when `sigma_a > 3 sigma_s (1-g)`).
    ///
    /// ```
    /// use km_core::two_flux::KmMapping;
    /// let l = km_core::Layer::new(0.1, 0.4, 1.0, 0.5, 1.0).unwrap();
    /// assert_eq!(KmMapping::Seed.coefficients(&l).unwrap(), (0.1, 0.4));
    /// let (k, s) = KmMapping::StarEtAl1988.coefficients(&l).unwrap();
    /// assert!((k - 0.2).abs() < 1e-15 && (s - 0.125).abs() < 1e-15);
    /// ```
    pub fn coefficients(&self, layer: &Layer) -> Result<(f64, f64), CoreError> {
        let (sa, ss, g) = (layer.sigma_a, layer.sigma_s, layer.g());
        match self {
            KmMapping::Seed => Ok((sa, ss)),
            KmMapping::StarEtAl1988 => {
                let s = 0.75 * ss * (1.0 - g) - 0.25 * sa;
                if s < 0.0 {
                    return Err(CoreError::unsupported(
                        "km",
                        format!(
                            "mapping star1988 gives S = {s} < 0 (it needs sigma_a <= 3 sigma_s (1 - g); \
                             sigma_a = {sa}, sigma_s = {ss}, g = {g}); use gate1974 or seed"
                        ),
                    ));
                }
                Ok((2.0 * sa, s))
            }
            KmMapping::Gate1974 => Ok((2.0 * sa, 0.75 * ss * (1.0 - g))),
        }
    }
}

impl FromStr for KmMapping {
    type Err = CoreError;
    fn from_str(text: &str) -> Result<Self, CoreError> {
        match text {
            "seed" => Ok(KmMapping::Seed),
            "star1988" => Ok(KmMapping::StarEtAl1988),
            "gate1974" => Ok(KmMapping::Gate1974),
            other => Err(CoreError::scene(
                "km_mapping",
                None,
                format!("unknown mapping \"{other}\" (expected seed, star1988 or gate1974)"),
            )),
        }
    }
}

/// Two-flux coefficients of one pigment (or of a mixture).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct KmCoefficients {
    /// Absorption `K`, 1/length, `>= 0`.
    pub k: f64,
    /// Scattering `S`, 1/length, `>= 0`.
    pub s: f64,
}

/// Duncan's two-constant mixing rule: `K = sum c_i K_i / sum c_i`,
/// `S = sum c_i S_i / sum c_i` (eq. K15), the concentrations normalised to
/// fractions (multiply by the total for absolute concentrations).
///
/// # Errors
/// Different lengths, no pigment, a negative or non-finite concentration, a
/// zero total, or invalid `K`, `S`.
///
/// # Reference
/// Duncan (1940).
///
/// ```
/// use km_core::two_flux::{mix_pigments, KmCoefficients};
/// let white = KmCoefficients { k: 0.01, s: 5.0 };
/// let blue = KmCoefficients { k: 3.0, s: 1.0 };
/// let m = mix_pigments(&[3.0, 1.0], &[white, blue]).unwrap();
/// assert!((m.k - (0.03 + 3.0) / 4.0).abs() < 1e-15);
/// assert!(mix_pigments(&[-1.0, 1.0], &[white, blue]).is_err());
/// ```
pub fn mix_pigments(
    concentrations: &[f64],
    pigments: &[KmCoefficients],
) -> Result<KmCoefficients, CoreError> {
    if concentrations.len() != pigments.len() {
        return Err(CoreError::invalid(
            "concentrations",
            concentrations.len() as f64,
            &format!("need one concentration per pigment ({} pigments)", pigments.len()),
        ));
    }
    if pigments.is_empty() {
        return Err(CoreError::invalid("pigments", 0.0, "a mixture needs at least one pigment"));
    }
    let mut total = 0.0;
    let (mut k, mut s) = (0.0, 0.0);
    for (&c, p) in concentrations.iter().zip(pigments) {
        if !c.is_finite() || c < 0.0 {
            return Err(CoreError::invalid("concentration", c, "must be finite and >= 0"));
        }
        check_ks(p.k, p.s)?;
        total += c;
        k += c * p.k;
        s += c * p.s;
    }
    if total <= 0.0 || !total.is_finite() {
        return Err(CoreError::invalid("concentrations", total, "must sum to a finite value > 0"));
    }
    Ok(KmCoefficients { k: k / total, s: s / total })
}

// ---------------------------------------------------------------------------
// The scene-level solver.

/// Options of the two-flux solver.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct KmOptions {
    /// How `(sigma_a, sigma_s, g)` become `(K, S)`; the seed's identity by default.
    pub mapping: KmMapping,
}

/// The stack of one channel as slabs, with bookkeeping for the answer.
struct Built {
    slabs: Vec<Slab>,
    /// Index of the slab of each layer.
    layer_slab: Vec<usize>,
    /// Specular (mirror) reflectance of the top surface.
    r_specular: f64,
    /// Zero-order (never scattered, never reflected) transmittance.
    t_direct: f64,
    /// True when light can leave through the bottom.
    open_bottom: bool,
}

/// Hemispherical Fresnel reflectances already computed in this solve: the
/// integral of [`fresnel::diffuse_reflectance`] dominates the cost of a
/// channel, and spectral channels usually share their indices.
#[derive(Default)]
struct HemisphericalCache {
    memo: Vec<(f64, f64, f64)>,
}

impl HemisphericalCache {
    fn get(&mut self, n_i: f64, n_t: f64) -> f64 {
        if let Some(&(_, _, r)) = self.memo.iter().find(|m| m.0 == n_i && m.1 == n_t) {
            return r;
        }
        let r = fresnel::diffuse_reflectance(n_i, n_t);
        self.memo.push((n_i, n_t, r));
        r
    }

    /// The diffuse interface slab of [`Slab::interface_diffuse`].
    fn interface(&mut self, n_above: f64, n_below: f64) -> Result<Slab, CoreError> {
        check_n("n_above", n_above)?;
        check_n("n_below", n_below)?;
        Ok(Slab::interface(self.get(n_above, n_below), self.get(n_below, n_above)))
    }

    /// Saunderson's top interface of [`Slab::saunderson_top`].
    fn saunderson_top(&mut self, light: Light, n0: f64, n: f64) -> Result<Slab, CoreError> {
        check_n("n_ambient", n0)?;
        check_n("n_layer", n)?;
        let r_e = match light.mu0() {
            Some(mu0) => fresnel::reflectance(mu0, n0, n),
            None => self.get(n0, n),
        };
        Ok(Slab::interface(r_e, self.get(n, n0)))
    }
}

fn build(
    mono: &MonoScene,
    mapping: KmMapping,
    cache: &mut HemisphericalCache,
) -> Result<Built, CoreError> {
    let mut slabs = Vec::with_capacity(2 * mono.layers.len() + 2);
    let mut layer_slab = Vec::with_capacity(mono.layers.len());
    let first_n = mono.layers[0].n;
    let mut r_specular = 0.0;
    let mut t_direct = if mono.light.mu0().is_some() { 1.0 } else { 0.0 };
    // Saunderson's top interface (eq. K12).
    if first_n != mono.ambient_n {
        let top = cache.saunderson_top(mono.light, mono.ambient_n, first_n)?;
        r_specular = top.r_top;
        t_direct *= top.t_tb;
        slabs.push(top);
    }
    let mut n_above = first_n;
    let mut open_bottom = true;
    for (i, layer) in mono.layers.iter().enumerate() {
        // Interfaces between layers of different index: diffuse flux both sides.
        if layer.n != n_above {
            let iface = cache.interface(n_above, layer.n)?;
            t_direct *= iface.t_tb;
            slabs.push(iface);
        }
        let (k, s) = mapping.coefficients(layer).map_err(|e| match e {
            CoreError::Unsupported { method, reason } => {
                CoreError::Unsupported { method, reason: format!("layer[{}]: {reason}", i + 1) }
            }
            other => other,
        })?;
        let slab = Slab::layer(k, s, layer.thickness)?;
        t_direct *= if layer.is_half_space() {
            if k + s == 0.0 { 1.0 } else { 0.0 }
        } else {
            (-(k + s) * layer.thickness).exp()
        };
        layer_slab.push(slabs.len());
        slabs.push(slab);
        n_above = layer.n;
        if layer.is_half_space() {
            // Nothing below a half-space matters.
            open_bottom = k + s == 0.0;
            return Ok(Built { slabs, layer_slab, r_specular, t_direct, open_bottom });
        }
    }
    match mono.substrate {
        Substrate::Transparent { n } => {
            if n != n_above {
                let iface = cache.interface(n_above, n)?;
                t_direct *= iface.t_tb;
                slabs.push(iface);
            }
        }
        Substrate::Lambertian { albedo } => {
            slabs.push(Slab::ground(albedo)?);
            open_bottom = false;
        }
        Substrate::Black => {
            slabs.push(Slab::ground(0.0)?);
            open_bottom = false;
        }
    }
    if !open_bottom {
        t_direct = 0.0;
    }
    Ok(Built { slabs, layer_slab, r_specular, t_direct, open_bottom })
}

/// Solve one channel by the adding form (eq. 14).
///
/// # Errors
/// An invalid scene ([`MonoScene::validate`]) or a mapping that cannot treat a layer.
pub fn solve_mono(mono: &MonoScene, opts: &KmOptions) -> Result<ChannelResult, CoreError> {
    solve_channel(mono, opts, &mut HemisphericalCache::default())
}

fn solve_channel(
    mono: &MonoScene,
    opts: &KmOptions,
    cache: &mut HemisphericalCache,
) -> Result<ChannelResult, CoreError> {
    mono.validate()?;
    let b = build(mono, opts.mapping, cache)?;
    let f = stack_adding(&b.slabs);
    let t = if b.open_bottom { f.t } else { 0.0 };
    // Everything not reflected or transmitted is absorbed, in a layer or in the ground.
    let absorptance: f64 = f.absorbed.iter().sum();
    let layers: Vec<f64> = b.layer_slab.iter().map(|&i| f.absorbed[i]).collect();
    let (brdf, btdf) = if mono.directions_deg.is_empty() {
        (Vec::new(), Vec::new())
    } else {
        // KM has no angles: Lambertian-equivalent values of the diffuse parts.
        let rd = (f.r - b.r_specular).max(0.0) / PI;
        let td = (t - b.t_direct).max(0.0) / PI;
        (vec![rd; mono.directions_deg.len()], vec![td; mono.directions_deg.len()])
    };
    Ok(ChannelResult {
        reflectance: f.r,
        reflectance_specular: b.r_specular,
        transmittance: t,
        transmittance_direct: b.t_direct,
        absorptance,
        brdf,
        btdf,
        absorptance_layers: Some(layers),
        ..ChannelResult::default()
    })
}

/// Solve a scene by two-flux Kubelka–Munk, one [`ChannelResult`] per channel.
///
/// Conventions (see `docs/two-flux.md` §7):
/// * the two fluxes are diffuse; a collimated beam's angle enters only through
///   the Fresnel reflectance of the top interface (Saunderson);
/// * `reflectance_specular` is that interface's mirror reflection;
/// * `transmittance_direct` is the zero-order term of the two-flux series
///   (never scattered, never reflected: `prod exp(-(K+S) z0)` times the
///   interface transmittances) for collimated light, 0 for diffuse light; it
///   is not the Beer–Lambert beam at oblique incidence;
/// * `brdf`/`btdf` (when the scene asks for directions) are the
///   Lambertian-equivalent `(R - R_specular)/pi` and `(T - T_direct)/pi`;
/// * `absorptance_layers` are the fractions absorbed in each layer (interfaces
///   absorb nothing; the ground's absorption is in `absorptance` only);
/// * `seconds` is the solver's own wall time.
///
/// # Errors
/// An invalid channel, or a mapping that cannot treat a layer.
///
/// ```
/// use km_core::two_flux::{solve, KmOptions};
/// let scene = km_core::Scene::from_toml_str("[[layer]]\nsigma_a = 0.1\nsigma_s = 0.4\nthickness = 1.0\n").unwrap();
/// let sol = solve(&scene, &KmOptions::default()).unwrap();
/// let rt = km_core::two_flux::layer_rt(0.1, 0.4, 1.0).unwrap();
/// assert!((sol.channels[0].reflectance - rt.r).abs() < 1e-15);
/// ```
pub fn solve(scene: &Scene, opts: &KmOptions) -> Result<Solution, CoreError> {
    let start = Instant::now();
    let channels = {
        let mut cache = HemisphericalCache::default();
        scene
            .channels
            .iter()
            .map(|m| solve_channel(m, opts, &mut cache))
            .collect::<Result<Vec<_>, _>>()?
    };
    let seconds = start.elapsed().as_secs_f64();
    // The collimated-beam notes only where a beam falls on the stack.
    let collimated = scene.channels.iter().any(|m| m.light.mu0().is_some());
    let mut notes = Vec::new();
    if collimated {
        notes.push(
            "two-flux fluxes are diffuse: a collimated beam's angle enters only through the \
             Fresnel reflectance of the top interface (Saunderson)"
                .to_string(),
        );
        notes.push(
            "transmittance_direct is the zero-order (never scattered) term of the two-flux \
             series, not the Beer-Lambert beam at oblique incidence"
                .to_string(),
        );
    }
    if scene.channels.iter().any(|m| !m.directions_deg.is_empty()) {
        notes.push(
            "KM has no angles: brdf and btdf are the Lambertian-equivalent values \
             (R - R_specular)/pi and (T - T_direct)/pi, the same in every direction"
                .to_string(),
        );
    }
    if opts.mapping == KmMapping::Seed
        && scene.channels.iter().flat_map(|m| &m.layers).any(|l| l.g() != 0.0)
    {
        notes.push("mapping seed ignores g (K = sigma_a, S = sigma_s)".to_string());
    }
    let mut extra = Map::new();
    extra.insert("km_mapping".into(), json!(opts.mapping.name()));
    Ok(Solution {
        method: "km".into(),
        channels,
        labels: scene.labels.clone(),
        seconds,
        notes,
        extra,
        ..Default::default()
    })
}
