//! # Four-flux Kubelka–Munk: a collimated beam and the two diffuse fluxes
//!
//! The model of Maheu, Letoulouzan & Gouesbet (1984), as Vargas & Niklasson
//! (1997) write it: besides KM's diffuse fluxes `i+` (down) and `i-` (up),
//! a collimated beam goes down (`I_c`) and, after a mirror reflection below,
//! up (`J_c`). In a layer the beam travels at the refracted angle
//! (`mu = cos theta` in the layer, from the Snell invariant
//! `n0 sin theta0`) and decays by Beer–Lambert along its slant path; what it
//! loses by scattering feeds the diffuse pair, the fraction `b(mu)` scattered
//! into the upper hemisphere going to `i-` and the rest to `i+`
//! (docs/two-flux.md §12, eq. K16–K18):
//!
//! ```text
//! d I_c/dz = -beta I_c,                       beta = sigma_t / mu
//! d i+/dz  = -(K + S) i+ + S i- + F I_c,      F = sigma_s (1 - b(mu)) / mu
//! d i-/dz  = -S i+ + (K + S) i- - B I_c,      B = sigma_s b(mu) / mu
//! ```
//!
//! The diffuse pair is KM with the mapping's `K`, `S` and Saunderson's
//! interfaces; the beam crosses every interface with the Fresnel
//! reflectance at its own angle, and its reflections stay collimated. A
//! clear layer (`sigma_s = 0`) therefore carries the beam exactly: a glass
//! plate, a clear film over a substrate, absorbing or not, come out as the
//! closed-form Fresnel plate.
//!
//! Every slab (layer, interface, ground) maps the fluxes entering it,
//! `(collimated, diffuse)` per face, to those leaving it by 2 x 2 matrices
//! that are lower triangular (light that scattered never becomes
//! collimated again), and slabs are added by the matrix form of seed eq. 14
//! ([`stack`]). The layer's collimated responses are closed forms in
//! divided differences of the exponential (eq. K19–K22), finite across the
//! resonance `beta = lambda` and at `K = 0`.
//!
//! For diffuse light the beam is absent and the model is the two-flux one.

use crate::error::CoreError;
use crate::phase::PhaseFunction;

use super::{check_ks, check_thickness, lambda_of};

mod dd;
mod scene;
mod stack;

pub(super) use scene::solve_channel;
pub use stack::{FourSlab, FourStackFluxes, Lower, add_four, stack_four};

/// Which model `--method km` solves.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum KmModel {
    /// Four-flux (collimated + diffuse) when the light is collimated; the
    /// same as two-flux for diffuse light.
    #[default]
    #[cfg_attr(
        feature = "clap",
        value(
            name = "four-flux",
            help = "collimated beam refracted and attenuated along its path, feeding KM's diffuse pair"
        )
    )]
    FourFlux,
    /// Two diffuse fluxes only (seed §2): a collimated beam enters as
    /// diffuse light behind the top interface.
    #[cfg_attr(
        feature = "clap",
        value(name = "two-flux", help = "diffuse fluxes only, as in the seed paper")
    )]
    TwoFlux,
}

impl KmModel {
    /// The name in the JSON output and on the command line.
    pub fn name(&self) -> &'static str {
        match self {
            KmModel::FourFlux => "four-flux",
            KmModel::TwoFlux => "two-flux",
        }
    }
}

impl std::str::FromStr for KmModel {
    type Err = CoreError;
    fn from_str(text: &str) -> Result<Self, CoreError> {
        match text {
            "four-flux" => Ok(KmModel::FourFlux),
            "two-flux" => Ok(KmModel::TwoFlux),
            other => Err(CoreError::scene(
                "km_model",
                None,
                format!("unknown model \"{other}\" (expected four-flux or two-flux)"),
            )),
        }
    }
}

/// Highest Legendre order summed by [`backscatter_fraction`] (its work
/// bound). Henyey–Greenstein moments `g^l` fall below `1e-17` before it for
/// `|g| < 0.9996`; beyond, the sum stops here with a remainder of at most
/// `|g|^L / (1 - |g|)` (1e-14 at `|g| = 0.9996`, 0.45 at 0.9999).
pub const MAX_BACKSCATTER_ORDER: usize = 100_000;

/// Fraction `b(mu)` of the light scattered once from a beam of direction
/// cosine `mu` (downward, `0 < mu <= 1`) that goes into the upper
/// hemisphere (eq. K17):
///
/// `b(mu) = 1/2 - 1/2 sum_{l odd} chi_l P_l(mu) (P_{l-1}(0) - P_{l+1}(0))`
///
/// from the Legendre moments `chi_l` of the phase function (the azimuthal
/// mean of `P_l(cos Theta)` is `P_l(mu) P_l(mu')`, and
/// `(2l + 1) int_0^1 P_l = P_{l-1}(0) - P_{l+1}(0)`). The sum stops after four
/// odd moments below `1e-17` in size, or at [`MAX_BACKSCATTER_ORDER`].
/// Isotropic scattering gives `1/2`; the first term alone is the familiar
/// `1/2 - (3/4) g mu`.
///
/// # Reference
/// Wiscombe & Grams (1976), the backscattered fraction of two-stream models.
///
/// ```
/// use km_core::phase::Phase;
/// use km_core::two_flux::backscatter_fraction;
/// assert_eq!(backscatter_fraction(&Phase::Isotropic, 0.3), 0.5);
/// // Henyey–Greenstein at normal incidence has the closed form
/// // (1 - g) / (2 g) ((1 + g) / sqrt(1 + g^2) - 1).
/// let g: f64 = 0.7;
/// let exact = (1.0 - g) / (2.0 * g) * ((1.0 + g) / (1.0 + g * g).sqrt() - 1.0);
/// let b = backscatter_fraction(&Phase::henyey_greenstein(g).unwrap(), 1.0);
/// assert!((b - exact).abs() < 1e-14);
/// ```
pub fn backscatter_fraction(phase: &impl PhaseFunction, mu: f64) -> f64 {
    let mu = mu.clamp(-1.0, 1.0);
    // P_l(mu) for l = 1 (p) and l = 0 (p_prev); P_{l-1}(0) for odd l.
    let (mut p_prev, mut p) = (1.0, mu);
    let mut p0_below = 1.0;
    let mut sum = 0.0;
    let mut small = 0;
    let mut l = 1;
    while l < MAX_BACKSCATTER_ORDER {
        // P_{l+1}(0) = -l / (l + 1) P_{l-1}(0) for odd l.
        let lf = l as f64;
        let p0_above = -lf / (lf + 1.0) * p0_below;
        let chi = phase.legendre_moment(l);
        sum += chi * p * (p0_below - p0_above);
        small = if chi.abs() < 1e-17 { small + 1 } else { 0 };
        if small >= 4 {
            break;
        }
        // Two steps of the recurrence (l+1) P_{l+1} = (2l+1) mu P_l - l P_{l-1}.
        let p1 = ((2.0 * lf + 1.0) * mu * p - lf * p_prev) / (lf + 1.0);
        let p2 = ((2.0 * lf + 3.0) * mu * p1 - (lf + 1.0) * p) / (lf + 2.0);
        (p_prev, p) = (p1, p2);
        p0_below = p0_above;
        l += 2;
    }
    (0.5 - 0.5 * sum).clamp(0.0, 1.0)
}

/// What one layer does to a unit collimated flux entering it (eq. K21–K22).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CollimatedRt {
    /// Diffuse flux leaving the face the beam entered (`R_cd`).
    pub r: f64,
    /// Diffuse flux leaving the opposite face (`T_cd`).
    pub t: f64,
    /// The beam leaving the opposite face, `exp(-beta d)` (Beer–Lambert on the slant path).
    pub direct: f64,
    /// Absorbed, by the beam and by the diffuse light it fed: `1 - r - t - direct`.
    pub a: f64,
}

/// The response of one layer to a unit collimated flux (eq. K21–K22): the
/// diffuse fluxes it sends back (`r`) and on (`t`), the beam left
/// (`direct`) and the absorbed part.
///
/// With `beta = sigma_t / mu`, `F = sigma_s (1 - b) / mu`, `B = sigma_s b / mu`,
/// `Sigma = K + S`, `lambda = sqrt(K (K + 2S))`, `E1`, `E2` the divided
/// differences of `exp(-t d)` (eq. K19–K20) and
/// `N = (1 + exp(-2 lambda d)) / 2 + Sigma E1(2 lambda, 0)`:
///
/// ```text
/// r = [(F S + B Sigma) E2(beta + lambda, 2 lambda, 0)
///      + B/2 (E1(beta + lambda, 0) + E1(beta + lambda, 2 lambda))] / N
/// t = [(F Sigma + B S) E2(beta, beta + 2 lambda, lambda)
///      + F/2 (E1(beta, lambda) + E1(beta + 2 lambda, lambda))] / N
/// ```
///
/// Every term is non-negative. The layer is symmetric: a beam entering from
/// below sees the same numbers.
///
/// * `k`, `s`: the diffuse pair's `K`, `S` (1/length, `>= 0`).
/// * `sigma_a`, `sigma_s`: the layer's absorption and scattering coefficients
///   for the beam (1/length, `>= 0`).
/// * `back`: `b(mu)` of [`backscatter_fraction`], in `[0, 1]`.
/// * `mu`: the beam's direction cosine in the layer, `(0, 1]`.
/// * `thickness`: length, `>= 0` or `inf`.
///
/// # Errors
/// Any argument outside its domain.
///
/// # Reference
/// Maheu, Letoulouzan & Gouesbet (1984); Vargas & Niklasson (1997).
///
/// ```
/// use km_core::two_flux::collimated_layer;
/// // A clear absorbing layer: Beer–Lambert on the slant path, nothing diffuse.
/// let c = collimated_layer(0.2, 0.0, 0.1, 0.0, 0.5, 0.8, 2.0).unwrap();
/// assert!((c.direct - (-0.1f64 * 2.0 / 0.8).exp()).abs() < 1e-16 && c.r == 0.0);
/// // Scattering: energy is conserved.
/// let s = collimated_layer(0.1, 0.4, 0.05, 0.6, 0.3, 0.7, 1.5).unwrap();
/// assert!((s.r + s.t + s.direct + s.a - 1.0).abs() < 1e-15);
/// ```
pub fn collimated_layer(
    k: f64,
    s: f64,
    sigma_a: f64,
    sigma_s: f64,
    back: f64,
    mu: f64,
    thickness: f64,
) -> Result<CollimatedRt, CoreError> {
    check_ks(k, s)?;
    check_thickness(thickness)?;
    for (name, v) in [("sigma_a", sigma_a), ("sigma_s", sigma_s)] {
        if !v.is_finite() || v < 0.0 {
            return Err(CoreError::invalid(name, v, "must be finite and >= 0"));
        }
    }
    if !(0.0..=1.0).contains(&back) {
        return Err(CoreError::invalid("b", back, "the backscattered fraction lies in [0, 1]"));
    }
    if !(mu > 0.0 && mu <= 1.0) {
        return Err(CoreError::invalid("mu", mu, "the beam's cosine lies in (0, 1]"));
    }
    let d = thickness;
    let sigma_t = sigma_a + sigma_s;
    let beta = sigma_t / mu;
    // The beam: what passes and what it loses (scattered or absorbed).
    let (direct, lost) = if d.is_infinite() {
        if beta > 0.0 { (0.0, 1.0) } else { (1.0, 0.0) }
    } else {
        ((-beta * d).exp(), -(-beta * d).exp_m1())
    };
    if sigma_s == 0.0 {
        return Ok(CollimatedRt { r: 0.0, t: 0.0, direct, a: lost });
    }
    let (fwd, bwd) = (sigma_s * (1.0 - back) / mu, sigma_s * back / mu);
    // Rates in units of the largest and the thickness as the matching optical
    // depth: eq. K21–K22 are dimensionless, and no product of two large rates
    // overflows (sigma_s = 1e300 is a valid layer).
    let c = beta.max(k + s);
    let (r, t) = diffuse_from_beam(k / c, s / c, beta / c, fwd / c, bwd / c, d * c);
    // The diffuse part absorbs what it does not send out (none when K = 0).
    let scattered = sigma_s / sigma_t * lost;
    let a_diffuse = if k == 0.0 { 0.0 } else { (scattered - r - t).max(0.0) };
    Ok(CollimatedRt { r, t, direct, a: sigma_a / sigma_t * lost + a_diffuse })
}

/// `(r, t)` of [`collimated_layer`] for sources `fwd`, `bwd` (per unit
/// depth, per unit beam flux) decaying as `exp(-beta z)` (eq. K21–K22).
fn diffuse_from_beam(k: f64, s: f64, beta: f64, fwd: f64, bwd: f64, d: f64) -> (f64, f64) {
    let sigma = k + s;
    let lambda = lambda_of(k, s);
    if d.is_infinite() && lambda == 0.0 {
        // K = 0 half-space: the diffuse light is never absorbed; with S > 0
        // all of it comes back (R_inf = 1), with S = 0 what goes down stays down.
        let (up, down) = (bwd / beta, fwd / beta);
        return if s > 0.0 { (up + down, 0.0) } else { (up, down) };
    }
    let e = if d.is_infinite() { 0.0 } else { (-2.0 * lambda * d).exp() };
    let n = 0.5 * (1.0 + e) + sigma * dd::e1(2.0 * lambda, 0.0, d);
    let (bl, l2) = (beta + lambda, 2.0 * lambda);
    let r = (fwd * s + bwd * sigma) * dd::e2(bl, l2, 0.0, d)
        + 0.5 * bwd * (dd::e1(bl, 0.0, d) + dd::e1(bl, l2, d));
    let t = (fwd * sigma + bwd * s) * dd::e2(beta, beta + l2, lambda, d)
        + 0.5 * fwd * (dd::e1(beta, lambda, d) + dd::e1(beta + l2, lambda, d));
    (r / n, t / n)
}
