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
//! seed's misprints and numbers the equations; `seed eq. n` below is the
//! seed's numbering, `eq. Kn` the note's additions.
//!
//! ## What is here
//! * Single layer, closed form and scaled so nothing overflows
//!   ([`layer_rt`], [`r_infinity`], [`profile`]): `a = (K + S)/S`,
//!   `b = sqrt(a^2 - 1)`, `lambda = b S = sqrt(K (K + 2 S))` (seed eq. 4 corrected),
//!   `R = sinh(bSz0) / (a sinh + b cosh)`, `T = b / (a sinh + b cosh)` (seed eq. 10),
//!   `R_inf = a - b`.
//! * The seed's eigen form itself ([`eigen`], [`eigen_profile`], seed eq. 3–8), with
//!   its boundary matrix `F` written with decaying exponentials.
//! * Concatenation of any number of layers: the adding form ([`add`],
//!   [`stack_adding`], seed eq. 14 re-derived; the robust default) and the transfer
//!   matrix form ([`Transfer`], seed eq. 11–13, scaled).
//! * Mappings from the scene's `(sigma_a, sigma_s, g)` to `(K, S)` ([`KmMapping`]),
//!   Saunderson's interface correction ([`Slab::saunderson_top`]), Duncan's
//!   pigment mixing ([`mix_pigments`]), and the scene-level solver [`solve`].
//!
//! Every function returns finite values for finite inputs: thickness up to
//! `inf`, `K` down to 0 (the closed form's `0/0`), `S = 0`.

use std::f64::consts::LN_2;

use crate::error::CoreError;

mod depth;
mod four_flux;
mod mapping;
mod rough;
mod solve;
mod stack;

pub use depth::{KmDepthProfile, depth_profile};
pub use four_flux::{
    CollimatedRt, FourSlab, FourStackFluxes, KmModel, Lower, MAX_BACKSCATTER_ORDER, add_four,
    backscatter_fraction, collimated_layer, stack_four,
};
pub use mapping::{KmCoefficients, KmMapping, mix_pigments};
pub use solve::{KmOptions, solve, solve_mono};
pub use stack::{Slab, StackFluxes, Transfer, add, stack_adding, stack_transfer};

// ---------------------------------------------------------------------------
// Single layer.

/// Reflectance, transmittance and absorptance of one symmetric two-flux layer
/// for diffuse flux incident on one face (`r + t + a = 1`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rt {
    /// Reflectance `R` (seed eq. 10).
    pub r: f64,
    /// Transmittance `T` (seed eq. 10).
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

/// The eigenvalue `lambda = b S = sqrt(K (K + 2 S))` (seed eq. 4 corrected:
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

/// Reflectance of a half-space `R_inf = a - b` (seed §2, the limit of seed eq. 10).
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
// The seed's eigen form (seed eq. 3–8).

/// Eigen-decomposition of `Q = [[-(K+S), S], [-S, K+S]]` (seed eq. 3–4, corrected).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Eigen {
    /// `lambda_1 = +lambda`, `lambda_2 = -lambda`, `lambda = sqrt((K+S)^2 - S^2)`
    /// (seed eq. 4; the seed prints `+ S^2`).
    pub lambda: [f64; 2],
    /// Columns of `V`: `v[j] = (v_j1, v_j2)`, proportional to `(1, a +- b)`,
    /// normalised to unit length (seed eq. 4).
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

/// The fluxes of seed eq. 8 for unit incidence, through the eigen form with the
/// boundary matrix `F` of seed eq. 6, rescaled so every exponential decays.
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
    // Solve F' c = (1, 0) by Cramer's rule (seed eq. 7).
    let det = v11 * big_e * v22 * big_e - v21 * v12;
    let c1 = (v22 * big_e) / det;
    let c2 = -v12 / det;
    let g1 = if thickness.is_infinite() { 0.0 } else { (-lambda * (thickness - z)).exp() };
    let g2 = (-lambda * z).exp();
    Ok(Fluxes { down: c1 * v11 * g1 + c2 * v21 * g2, up: c1 * v12 * g1 + c2 * v22 * g2 })
}
