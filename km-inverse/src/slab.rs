//! The slab inverse of Prahl's inverse adding–doubling (iad), with km's
//! multi-flux solver as the forward model (`docs/inverse.md` §2, §4).
//!
//! Unknowns: albedo `a`, optical thickness `b`, and `g` when the
//! unscattered transmittance `M_U` is measured (otherwise `g` is fixed,
//! 0 by default as in iad). Measurements: `M_R`, `M_T`, optionally `M_U`.
//!
//! 1. **Start** from the two-flux (Kubelka–Munk) inverse of the diffuse
//!    parts, mapped to transport coefficients (eq. I4–I6 of the note), and
//!    `b` from `M_U` by Beer–Lambert with the interface reflections (F3).
//! 2. **Search** in unbounded variables `u = ln(a / (1 - a))`, `v = ln b`,
//!    `w = atanh g` (iad maps `a` and `b` the same way to keep its simplex
//!    inside the domain) by Levenberg–Marquardt on the relative residuals;
//!    a square system converges quadratically to the root.
//! 3. **Streams**: fit at `N` streams, re-evaluate at `2N`; accept when the
//!    forward model moved by less than a tenth of the smallest measurement
//!    uncertainty, otherwise double `N` and refit from there (eq. I7).
//! 4. **Uncertainty**: `C = (J^T S^-2 J)^-1` with `J` the Jacobian of the
//!    measurement model in `(a, b, g)` and `S` the measurement standard
//!    uncertainties; propagated to `mu_a`, `mu_s`, `mu_s'` (eq. I8–I10).

use serde::Serialize;
use serde_json::{Value, json};

use crate::InverseError;
pub use crate::covariance::Uncertainty;
use crate::covariance::{albedo_edge, covariance, edge_jacobian, search_jacobian};
use crate::search::{Problem, Space, search_ladder, start};
use crate::stack::StackModel;

pub use crate::measurement::{DEFAULT_SIGMA, Measurement, Setup, model, model_with};

/// The stream ladder of eq. I7 (Gauss nodes per hemisphere).
pub const STREAM_LADDER: [usize; 5] = [8, 16, 32, 64, 128];

/// Options of the fit.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct FitOptions {
    /// Fixed anisotropy `g` in `(-1, 1)`. `None`: fitted when `M_U` is
    /// given, otherwise 0 (iad's default).
    pub g: Option<f64>,
    /// Fixed stream count (`None`: the ladder rule I7).
    pub streams: Option<usize>,
}

/// How the fit ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Status {
    /// The model reproduces the measurements within their uncertainty.
    Converged,
    /// No slab reproduces the measurements; the result is the nearest
    /// feasible point (least squares in units of the uncertainties).
    OutOfRange,
    /// The measurements do not determine the parameters (singular Jacobian).
    NotUnique,
}

/// The answer of [`fit`].
#[derive(Debug, Clone, PartialEq)]
pub struct FitResult {
    /// Single-scattering albedo `a`.
    pub albedo: f64,
    /// Optical thickness `b` (`tau`).
    pub tau: f64,
    /// Asymmetry `g`.
    pub g: f64,
    /// Absorption coefficient `mu_a = (1 - a) b / d`, 1/length.
    pub mu_a: f64,
    /// Scattering coefficient `mu_s = a b / d`, 1/length.
    pub mu_s: f64,
    /// Reduced scattering coefficient `mu_s' = mu_s (1 - g)`, 1/length.
    pub mu_s_prime: f64,
    /// The model's `M_R`, `M_T`, `M_U` at the answer.
    pub fitted: [f64; 3],
    /// Largest `|model - measured| / sigma` over the measurements.
    pub residual: f64,
    /// How the fit ended.
    pub status: Status,
    /// Standard uncertainties and correlations.
    pub uncertainty: Uncertainty,
    /// Streams of the forward model (eq. I7).
    pub streams: usize,
    /// Forward-model evaluations used.
    pub evaluations: usize,
    /// Remarks (stream rule not met, restarts, ...).
    pub notes: Vec<String>,
}

impl FitResult {
    /// The JSON object of the `km fit --json` contract (`docs/inverse.md` §6).
    pub fn to_json(&self) -> Value {
        let u = &self.uncertainty;
        let mut fitted = json!({ "m_r": self.fitted[0], "m_t": self.fitted[1] });
        if !self.fitted[2].is_nan() {
            fitted["m_u"] = json!(self.fitted[2]);
        }
        let corr: serde_json::Map<String, Value> =
            u.correlation.iter().map(|(k, v)| (k.clone(), json!(v))).collect();
        json!({
            "albedo": self.albedo,
            "tau": self.tau,
            "g": self.g,
            "mu_a": self.mu_a,
            "mu_s": self.mu_s,
            "mu_s_prime": self.mu_s_prime,
            "fitted": fitted,
            "residual": self.residual,
            "status": self.status,
            "uncertainty": {
                "albedo": u.albedo, "tau": u.tau, "g": u.g,
                "mu_a": u.mu_a, "mu_s": u.mu_s, "mu_s_prime": u.mu_s_prime,
                "correlation": corr,
                "ill_conditioned": u.ill_conditioned,
                "reasons": u.reasons,
                "sigma_given": u.sigma_given,
            },
            "streams": self.streams,
            "evaluations": self.evaluations,
            "notes": self.notes,
        })
    }
}

/// Fit the slab's optical properties to one measurement.
///
/// Solves `model(a, b, g) = (M_R, M_T[, M_U])` (I1) for `(a, b)`, or
/// `(a, b, g)` when `M_U` is given and `g` is not fixed, in the least-squares
/// sense weighted by the measurement uncertainties; see the module doc for
/// the steps and `docs/inverse.md` for the equations.
///
/// # Reference
/// Prahl, van Gemert & Welch, "Determining the optical properties of turbid
/// media by using the adding-doubling method", Appl. Opt. 32, 559 (1993)
/// (the problem and iad's variables); Marquardt 1963 (the search).
///
/// # Errors
/// Measurements or set-up outside their domain ([`InverseError::Invalid`]);
/// a forward-model failure.
///
/// ```
/// use km_inverse::forward::{Optical, Sample};
/// use km_inverse::slab::{FitOptions, Measurement, Setup, Status, fit, model};
/// let set = Setup::new(Sample::new(1.0, 1.4, Some(1.5)).unwrap());
/// let truth = Optical { albedo: 0.9, tau: 2.0, g: 0.0 };
/// let m = model(&set, &truth, 16).unwrap();
/// let opts = FitOptions { streams: Some(16), ..FitOptions::default() };
/// let r = fit(&set, &Measurement::rt(m[0], m[1]), &opts).unwrap();
/// assert_eq!(r.status, Status::Converged);
/// assert!((r.albedo - 0.9).abs() < 1e-9 && (r.tau - 2.0).abs() < 1e-8);
/// ```
pub fn fit(set: &Setup, meas: &Measurement, opts: &FitOptions) -> Result<FitResult, InverseError> {
    check_fit_inputs(set, meas, opts)?;
    let space =
        Space { fit_g: meas.m_u.is_some() && opts.g.is_none(), g_fixed: opts.g.unwrap_or(0.0) };
    let values = meas.values();
    let (sigma, sigma_given) = meas.sigmas();
    let square = values.len() == space.dim();
    // Residuals of the search: a square system has a root whatever the
    // weights, so log ratios (well scaled for tiny M_T, M_U); an
    // over-determined one is weighted by the uncertainties. A measured
    // M_R = 0 (specular excluded, nothing scattered back) has no logarithm.
    let log = square && values.iter().all(|&v| v > 0.0);
    let scale = sigma.clone();
    let sigma_min = sigma.iter().copied().fold(f64::INFINITY, f64::min);
    let mut notes = Vec::new();

    let p0 = start(set, meas, if space.fit_g { 0.5 } else { space.g_fixed });
    let ladder: Vec<usize> = match opts.streams {
        Some(n) => vec![n],
        None => STREAM_LADDER.to_vec(),
    };
    let mut prob = Problem {
        set,
        space,
        meas: values.clone(),
        scale,
        log,
        stack: StackModel::new(&set.sample, ladder[0])?,
        evaluations: 0,
        last: None,
    };
    let x = search_ladder(&mut prob, space.point_of(&p0), &ladder, meas, sigma_min, &mut notes)?;
    let p = space.optical_at(&x);
    let fitted_m = prob.model_at(&x)?;
    let residual =
        (0..values.len()).map(|i| (fitted_m[i] - values[i]).abs() / sigma[i]).fold(0.0, f64::max);

    let (m, nd) = (values.len(), space.dim());
    let (singular, jac) = match albedo_edge(&p) {
        None => search_jacobian(&mut prob, &x, &fitted_m, &sigma)?,
        Some(dir) => {
            notes.push(format!(
                "albedo at its bound a = {} ({}): the uncertainties are one-sided limits",
                if dir < 0.0 { 1 } else { 0 },
                if dir < 0.0 { "no absorption, mu_a = 0" } else { "no scattering, mu_s = 0" }
            ));
            edge_jacobian(&mut prob, &p, &fitted_m, &sigma, dir)?
        }
    };
    let uncertainty = covariance(&jac, m, nd, &p, set.sample.thickness, space.fit_g, sigma_given);

    let status = fit_status(set, singular, residual, square, &mut notes);
    let d = set.sample.thickness;
    let mut fitted = [fitted_m[0], fitted_m[1], f64::NAN];
    if meas.m_u.is_some() {
        fitted[2] = fitted_m[2];
    }
    Ok(FitResult {
        albedo: p.albedo,
        tau: p.tau,
        g: p.g,
        mu_a: (1.0 - p.albedo) * p.tau / d,
        mu_s: p.albedo * p.tau / d,
        mu_s_prime: p.albedo * p.tau * (1.0 - p.g) / d,
        fitted,
        residual,
        status,
        uncertainty,
        streams: prob.stack.streams(),
        evaluations: prob.evaluations,
        notes,
    })
}

/// Refuses a set-up, measurement or option [`fit`] cannot take (before any
/// search): invalid values, an inconsistent pair, `g` outside (-1, 1),
/// `streams` outside [2, 256].
fn check_fit_inputs(
    set: &Setup,
    meas: &Measurement,
    opts: &FitOptions,
) -> Result<(), InverseError> {
    set.validate()?;
    meas.validate()?;
    consistent(set, meas)?;
    if let Some(g) = opts.g
        && !km_core::phase::Anisotropy::admits(g)
    {
        return Err(InverseError::invalid("g", g, "must lie in (-1, 1)"));
    }
    if let Some(n) = opts.streams
        && !(2..=256).contains(&n)
    {
        return Err(InverseError::invalid("streams", n as f64, "must lie in [2, 256]"));
    }
    Ok(())
}

/// The fit's status from a singular Jacobian and the largest weighted
/// residual (a square system must match within 1 sigma, an over-determined
/// one within 3), with its notes (and the spheres' lost-light note).
fn fit_status(
    set: &Setup,
    singular: bool,
    residual: f64,
    square: bool,
    notes: &mut Vec<String>,
) -> Status {
    let tol_residual = if square { 1.0 } else { 3.0 };
    let status = if singular {
        Status::NotUnique
    } else if residual > tol_residual {
        Status::OutOfRange
    } else {
        Status::Converged
    };
    if status == Status::OutOfRange {
        notes.push(
            "no slab reproduces the measurements: the result is the nearest feasible point".into(),
        );
    }
    if let Some(s) = &set.spheres {
        notes.push(format!(
            "lost light is not modelled: the {} sphere(s) are taken to collect all the light \
             leaving the sample's faces (none lost at its edges or past the port's rim, which iad \
             estimates by Monte Carlo, -M)",
            s.count
        ));
    }
    status
}

/// Refuse measurements no slab can give (before any search): an unscattered
/// transmittance `M_U` above that of a clear sample with the same faces
/// (`tau = 0`), or, without spheres, above the total transmittance
/// (`M_T >= c_T M_U`: the unscattered beam is part of `M_T` in the
/// fraction `c_T`).
fn consistent(set: &Setup, meas: &Measurement) -> Result<(), InverseError> {
    let Some(u) = meas.m_u else {
        return Ok(());
    };
    let (n_s, n_g) = (set.sample.n_sample, set.sample.n_slide);
    let top = crate::forward::unscattered_transmittance(n_s, n_g, 0.0);
    if u > top {
        return Err(InverseError::invalid(
            "m_u",
            u,
            &format!(
                "above {top:.6}, the unscattered transmittance of a clear sample with these \
                 faces (n_sample, n_slide): no slab gives it"
            ),
        ));
    }
    let c_t = set.unscattered_in_m_t;
    if set.spheres.is_none() && meas.m_t < c_t * u - 1e-12 {
        return Err(InverseError::invalid(
            "m_u",
            u,
            &format!(
                "M_T = {} is below {c_t} x M_U: the total transmittance includes the \
                 unscattered beam (--unscattered-in-m-t {c_t})",
                meas.m_t
            ),
        ));
    }
    Ok(())
}
