//! A reflectance-only fit (`docs/inverse.md` §6): one measurement, `M_R`,
//! determines one unknown when another quantity is fixed, as iad does with
//! `-F` (a fixed scattering coefficient) or with `M_R` alone for a thick
//! sample.
//!
//! With `g` fixed (`FitOptions::g`, default 0) and the sample's thickness
//! `d`, the fixed quantity leaves one unknown:
//!
//! * `mu_s` fixed: `mu_a` unknown; `a = mu_s / (mu_a + mu_s)`,
//!   `b = (mu_a + mu_s) d`; `M_R` falls as `mu_a` grows;
//! * `mu_a` fixed: `mu_s` unknown; `M_R` grows with `mu_s`;
//! * a semi-infinite sample (`b` large enough that nothing comes back from
//!   its far face, [`THICK_TAU`]): `a` unknown; `M_R` grows with `a`.
//!
//! `M_R(x) = M_R,measured` (eq. I1, or the sphere equations S2 with spheres)
//! is solved by bisection on a bracket where the model is monotone (eq. R1),
//! and `u(x) = sigma_R / |dM_R/dx|` (eq. R2, a central difference). A
//! measurement outside the range the fixed quantity allows (e.g. above
//! `M_R(mu_a = 0)`) is refused with that range: it does not determine the
//! unknown.

use crate::InverseError;
use crate::forward::Optical;
use crate::slab::{DEFAULT_SIGMA, FitResult, Setup, Status, Uncertainty, model_with};
use crate::stack::StackModel;

/// Optical thickness standing for a semi-infinite sample: `e^{-2 b}` below
/// `1e-26`, far below any measurement.
pub const THICK_TAU: f64 = 30.0;

/// Streams of the forward model when none are given (the middle of the
/// ladder of eq. I7).
pub const DEFAULT_STREAMS: usize = 32;

/// The quantity held fixed in a reflectance-only fit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Fixed {
    /// The scattering coefficient `mu_s` (1/length): `mu_a` is fitted (iad `-F`).
    MuS(f64),
    /// The absorption coefficient `mu_a` (1/length): `mu_s` is fitted.
    MuA(f64),
    /// A semi-infinite sample: the albedo is fitted (iad with `M_R` alone).
    SemiInfinite,
}

impl Fixed {
    /// The unknown's name.
    fn unknown(self) -> &'static str {
        match self {
            Fixed::MuS(_) => "mu_a",
            Fixed::MuA(_) => "mu_s",
            Fixed::SemiInfinite => "albedo",
        }
    }

    /// The slab's `(a, b)` for the unknown `x` and thickness `d`.
    fn optical(self, x: f64, d: f64, g: f64) -> Optical {
        let (mu_a, mu_s) = match self {
            Fixed::MuS(s) => (x, s),
            Fixed::MuA(a) => (a, x),
            Fixed::SemiInfinite => return Optical { albedo: x, tau: THICK_TAU, g },
        };
        let t = mu_a + mu_s;
        Optical { albedo: if t > 0.0 { mu_s / t } else { 0.0 }, tau: t * d, g }
    }
}

/// Fit the one unknown of `fixed` to `m_r` (standard uncertainty `sigma_r`,
/// default [`DEFAULT_SIGMA`]) with anisotropy `g` and `streams` (default
/// [`DEFAULT_STREAMS`]).
///
/// # Errors
/// A fixed value that is negative or not finite, `m_r` outside `(0, 1)` or
/// outside the range the fixed quantity allows, a forward-model failure.
///
/// ```
/// use km_inverse::forward::{Optical, Sample};
/// use km_inverse::reflectance::{Fixed, fit_reflectance};
/// use km_inverse::slab::{Setup, model};
/// let set = Setup::new(Sample::new(1.0, 1.4, None).unwrap());
/// // mu_a = 0.1, mu_s = 1.9 over d = 1: a = 0.95, b = 2.
/// let m = model(&set, &Optical { albedo: 0.95, tau: 2.0, g: 0.0 }, 32).unwrap();
/// let r = fit_reflectance(&set, m[0], None, Fixed::MuS(1.9), 0.0, None).unwrap();
/// assert!((r.mu_a - 0.1).abs() < 1e-8);
/// ```
pub fn fit_reflectance(
    set: &Setup,
    m_r: f64,
    sigma_r: Option<f64>,
    fixed: Fixed,
    g: f64,
    streams: Option<usize>,
) -> Result<FitResult, InverseError> {
    if !(m_r > 0.0 && m_r < 1.0) {
        return Err(InverseError::invalid("m_r", m_r, "must lie in (0, 1)"));
    }
    if let Fixed::MuS(v) | Fixed::MuA(v) = fixed
        && !(v.is_finite() && v >= 0.0)
    {
        return Err(InverseError::invalid(fixed_name(fixed), v, "must be finite and >= 0"));
    }
    let stack = StackModel::new(&set.sample, streams.unwrap_or(DEFAULT_STREAMS))?;
    let d = set.sample.thickness;
    let mut evaluations = 0;
    let mut m_r_at = |x: f64| {
        evaluations += 1;
        model_with(set, &stack, &fixed.optical(x, d, g)).map(|m| m[0])
    };
    let (lo, hi) = bracket(fixed, m_r, &mut m_r_at)?;
    let x = bisect(lo, hi, m_r, &mut m_r_at)?;
    // Eq. R2: the slope by a central difference (one-sided at a bound).
    let h = match fixed {
        Fixed::SemiInfinite => 1e-6_f64.min((1.0 - x) / 2.0).max(1e-9),
        _ => 1e-6 * x.max(1e-3),
    };
    let (a, b) = ((x - h).max(0.0), x + h);
    let slope = (m_r_at(b)? - m_r_at(a)?) / (b - a);
    let sigma = sigma_r.unwrap_or(DEFAULT_SIGMA);
    let u = sigma / slope.abs();
    let fitted = m_r_at(x)?;
    let mut r = result(fixed, x, u, g, d, fitted, sigma_r.is_some(), stack.streams());
    r.residual = (fitted - m_r).abs() / sigma;
    r.evaluations = evaluations;
    Ok(r)
}

fn fixed_name(f: Fixed) -> &'static str {
    match f {
        Fixed::MuS(_) => "mu_s",
        Fixed::MuA(_) => "mu_a",
        Fixed::SemiInfinite => "semi-infinite",
    }
}

/// A bracket `[lo, hi]` of the unknown whose model values enclose `m_r`.
fn bracket(
    fixed: Fixed,
    m_r: f64,
    m_r_at: &mut dyn FnMut(f64) -> Result<f64, InverseError>,
) -> Result<(f64, f64), InverseError> {
    let out_of_range = |lo: f64, hi: f64| {
        InverseError::invalid(
            "m_r",
            m_r,
            &format!(
                "is outside [{lo:.6}, {hi:.6}], the reflectances this sample gives with {} \
                 fixed: M_R does not determine {}",
                fixed_name(fixed),
                fixed.unknown()
            ),
        )
    };
    if let Fixed::SemiInfinite = fixed {
        let (r0, r1) = (m_r_at(0.0)?, m_r_at(1.0 - 1e-9)?);
        return if m_r > r0 && m_r < r1 {
            Ok((0.0, 1.0 - 1e-9))
        } else {
            Err(out_of_range(r0, r1))
        };
    }
    // The edge x = 0, then doublings from 1 until the model passes m_r.
    let r0 = m_r_at(0.0)?;
    let (mut lo, mut hi) = (0.0, 1.0);
    for _ in 0..60 {
        let r = m_r_at(hi)?;
        let passed = match fixed {
            Fixed::MuS(_) => r < m_r,
            _ => r > m_r,
        };
        if passed {
            let inside = match fixed {
                Fixed::MuS(_) => m_r < r0,
                _ => m_r > r0,
            };
            return if inside { Ok((lo, hi)) } else { Err(out_of_range(r0.min(r), r0.max(r))) };
        }
        lo = hi;
        hi *= 2.0;
    }
    let r = m_r_at(hi)?;
    Err(out_of_range(r0.min(r), r0.max(r)))
}

/// Bisection of `M_R(x) = m_r` on `[lo, hi]` (eq. R1) to a relative width of `1e-12`.
fn bisect(
    mut lo: f64,
    mut hi: f64,
    m_r: f64,
    m_r_at: &mut dyn FnMut(f64) -> Result<f64, InverseError>,
) -> Result<f64, InverseError> {
    let f_lo = m_r_at(lo)? - m_r;
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if hi - lo <= 1e-12 * hi.abs().max(1e-12) {
            return Ok(mid);
        }
        if (m_r_at(mid)? - m_r).signum() == f_lo.signum() {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    Ok(0.5 * (lo + hi))
}

/// The [`FitResult`] of a reflectance-only fit (residual and evaluations set by the caller).
#[allow(clippy::too_many_arguments)]
fn result(
    fixed: Fixed,
    x: f64,
    u: f64,
    g: f64,
    d: f64,
    fitted: f64,
    sigma_given: bool,
    streams: usize,
) -> FitResult {
    let p = fixed.optical(x, d, g);
    let (mu_a, mu_s) = match fixed {
        Fixed::SemiInfinite => ((1.0 - x) * THICK_TAU / d, x * THICK_TAU / d),
        _ => ((1.0 - p.albedo) * p.tau / d, p.albedo * p.tau / d),
    };
    // Only the unknown is uncertain, and what follows from it: a = mu_s / t,
    // b = t d with t = mu_a + mu_s; a semi-infinite sample has no mu_a, mu_s
    // of its own.
    let t = mu_a + mu_s;
    let (u_a, u_b, u_mu_a, u_mu_s) = match fixed {
        Fixed::MuS(_) => (mu_s / (t * t) * u, d * u, u, 0.0),
        Fixed::MuA(_) => (mu_a / (t * t) * u, d * u, 0.0, u),
        Fixed::SemiInfinite => (u, 0.0, f64::NAN, f64::NAN),
    };
    let mut notes = vec![format!(
        "reflectance only: {} fitted with {} fixed and g = {g} (docs/inverse.md, eq. R1, R2)",
        fixed.unknown(),
        match fixed {
            Fixed::MuS(v) => format!("mu_s = {v}"),
            Fixed::MuA(v) => format!("mu_a = {v}"),
            Fixed::SemiInfinite => "a semi-infinite sample".to_string(),
        }
    )];
    if let Fixed::SemiInfinite = fixed {
        notes.push(format!(
            "semi-infinite: only the albedo is determined; tau, mu_a, mu_s are those of b = \
             {THICK_TAU} standing for an infinite thickness"
        ));
    }
    FitResult {
        albedo: p.albedo,
        tau: p.tau,
        g,
        mu_a,
        mu_s,
        mu_s_prime: mu_s * (1.0 - g),
        fitted: [fitted, f64::NAN, f64::NAN],
        residual: 0.0,
        status: Status::Converged,
        uncertainty: Uncertainty {
            albedo: u_a,
            tau: u_b,
            g: 0.0,
            mu_a: u_mu_a,
            mu_s: u_mu_s,
            mu_s_prime: u_mu_s * (1.0 - g),
            correlation: Vec::new(),
            ill_conditioned: !u.is_finite(),
            reasons: Vec::new(),
            sigma_given,
        },
        streams,
        evaluations: 0,
        notes,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::forward::Sample;
    use crate::slab::model;
    use crate::sphere::{Sphere, SphereSetup};

    fn slid() -> Setup {
        Setup::new(Sample::new(0.5, 1.4, Some(1.5)).unwrap())
    }

    // Round trips through the model at the fit's own streams: the bisection
    // stops at a relative width of 1e-12, so the unknown comes back to ~1e-9.
    #[test]
    fn mu_a_fixed_gives_mu_s_back() {
        let set = slid();
        // mu_a = 0.4, mu_s = 3.6 over d = 0.5: a = 0.9, b = 2, g = 0.5.
        let m = model(&set, &Optical { albedo: 0.9, tau: 2.0, g: 0.5 }, 16).unwrap();
        let r = fit_reflectance(&set, m[0], Some(1e-3), Fixed::MuA(0.4), 0.5, Some(16)).unwrap();
        assert!((r.mu_s - 3.6).abs() < 1e-8, "{}", r.mu_s);
        assert!(r.uncertainty.sigma_given && r.uncertainty.mu_s > 0.0);
    }

    #[test]
    fn a_semi_infinite_sample_gives_its_albedo_back_also_with_a_sphere() {
        let s = Sphere {
            d_sphere: 200.0,
            d_sample: 25.0,
            d_third: 12.0,
            d_detector: 1.0,
            r_wall: 0.98,
            r_detector: 0.0,
        };
        let spheres = SphereSetup {
            count: 1,
            r_sphere: s,
            t_sphere: s,
            r_std: 0.98,
            t_std: 1.0,
            baffle: true,
        };
        for set in [slid(), Setup { spheres: Some(spheres), ..slid() }] {
            let m = model(&set, &Optical { albedo: 0.97, tau: THICK_TAU, g: 0.0 }, 16).unwrap();
            let r = fit_reflectance(&set, m[0], None, Fixed::SemiInfinite, 0.0, Some(16)).unwrap();
            assert!((r.albedo - 0.97).abs() < 1e-8, "{}", r.albedo);
            assert!(!r.uncertainty.sigma_given);
        }
    }

    #[test]
    fn a_reflectance_out_of_reach_is_refused_with_the_range() {
        let e = fit_reflectance(&slid(), 0.95, None, Fixed::SemiInfinite, 0.0, Some(8));
        let text = e.unwrap_err().to_string();
        assert!(text.contains("does not determine albedo"), "{text}");
        assert!(fit_reflectance(&slid(), 0.2, None, Fixed::MuS(-1.0), 0.0, Some(8)).is_err());
    }
}
