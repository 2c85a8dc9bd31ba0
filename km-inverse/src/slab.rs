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
use crate::forward::{Optical, Sample, tau_from_unscattered};
use crate::linalg;
use crate::sphere::{SphereSetup, double_m_r_m_t, single_m_r_m_t};
use crate::stack::StackModel;

/// Measurement uncertainty assumed when none is given: iad's default
/// convergence tolerance (`-e 0.0001`), an absolute reflectance.
pub const DEFAULT_SIGMA: f64 = 1e-4;

/// The stream ladder of eq. I7 (Gauss nodes per hemisphere).
pub const STREAM_LADDER: [usize; 5] = [8, 16, 32, 64, 128];

/// What was measured on one sample at one wavelength.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Measurement {
    /// Measured total reflectance `M_R` (normal collimated light), `[0, 1]`.
    pub m_r: f64,
    /// Measured total transmittance `M_T`, `(0, 1]`.
    pub m_t: f64,
    /// Measured unscattered transmittance `M_U`, `(0, 1)`, if any.
    pub m_u: Option<f64>,
    /// Standard uncertainty of `M_R` (`None`: [`DEFAULT_SIGMA`]).
    pub sigma_r: Option<f64>,
    /// Standard uncertainty of `M_T` (`None`: [`DEFAULT_SIGMA`]).
    pub sigma_t: Option<f64>,
    /// Standard uncertainty of `M_U` (`None`: [`DEFAULT_SIGMA`]).
    pub sigma_u: Option<f64>,
}

impl Measurement {
    /// `M_R` and `M_T` alone, default uncertainties.
    pub fn rt(m_r: f64, m_t: f64) -> Self {
        Measurement { m_r, m_t, m_u: None, sigma_r: None, sigma_t: None, sigma_u: None }
    }

    fn validate(&self) -> Result<(), InverseError> {
        if !(0.0..=1.0).contains(&self.m_r) {
            return Err(InverseError::invalid("m_r", self.m_r, "must lie in [0, 1]"));
        }
        if !(self.m_t > 0.0 && self.m_t <= 1.0) {
            return Err(InverseError::invalid(
                "m_t",
                self.m_t,
                "must lie in (0, 1] (an opaque sample needs a different inverse)",
            ));
        }
        if let Some(u) = self.m_u
            && !(u > 0.0 && u < 1.0)
        {
            return Err(InverseError::invalid("m_u", u, "must lie in (0, 1)"));
        }
        for (n, s) in
            [("sigma_r", self.sigma_r), ("sigma_t", self.sigma_t), ("sigma_u", self.sigma_u)]
        {
            if let Some(s) = s
                && !(s.is_finite() && s > 0.0)
            {
                return Err(InverseError::invalid(n, s, "must be finite and > 0"));
            }
        }
        Ok(())
    }

    /// Measured values, in the order `M_R`, `M_T`, `M_U`.
    fn values(&self) -> Vec<f64> {
        let mut v = vec![self.m_r, self.m_t];
        v.extend(self.m_u);
        v
    }

    /// Standard uncertainties in the same order, and whether any was given.
    fn sigmas(&self) -> (Vec<f64>, bool) {
        let mut s =
            vec![self.sigma_r.unwrap_or(DEFAULT_SIGMA), self.sigma_t.unwrap_or(DEFAULT_SIGMA)];
        if self.m_u.is_some() {
            s.push(self.sigma_u.unwrap_or(DEFAULT_SIGMA));
        }
        let given = self.sigma_r.is_some() || self.sigma_t.is_some() || self.sigma_u.is_some();
        (s, given)
    }
}

/// How the sample was measured.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Setup {
    /// The sample and its slides.
    pub sample: Sample,
    /// Fraction of the specular reflection that `M_R` includes (iad `-c`;
    /// 1 = all, the default; 0 = specular excluded, e.g. by a light trap).
    pub specular_in_m_r: f64,
    /// Fraction of the unscattered beam that `M_T` includes (iad `-C`; default 1).
    pub unscattered_in_m_t: f64,
    /// Integrating spheres (`None`: the idealised 0-sphere measurement of
    /// the totals themselves).
    pub spheres: Option<SphereSetup>,
}

impl Setup {
    /// A 0-sphere set-up with iad's defaults (`M_R` includes the specular
    /// reflection, `M_T` the unscattered beam).
    pub fn new(sample: Sample) -> Self {
        Setup { sample, specular_in_m_r: 1.0, unscattered_in_m_t: 1.0, spheres: None }
    }

    fn validate(&self) -> Result<(), InverseError> {
        for (n, v) in [
            ("specular_in_m_r", self.specular_in_m_r),
            ("unscattered_in_m_t", self.unscattered_in_m_t),
        ] {
            if !(0.0..=1.0).contains(&v) {
                return Err(InverseError::invalid(n, v, "must lie in [0, 1]"));
            }
        }
        if let Some(s) = &self.spheres {
            s.validate()?;
        }
        Ok(())
    }
}

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

/// Standard uncertainties of the fitted parameters (same keys as the result).
#[derive(Debug, Clone, PartialEq)]
pub struct Uncertainty {
    /// `u(a)`.
    pub albedo: f64,
    /// `u(b)`.
    pub tau: f64,
    /// `u(g)` (0 when `g` was fixed).
    pub g: f64,
    /// `u(mu_a)`, 1/length.
    pub mu_a: f64,
    /// `u(mu_s)`, 1/length.
    pub mu_s: f64,
    /// `u(mu_s')`, 1/length.
    pub mu_s_prime: f64,
    /// Correlation coefficients: `(name, value)` for the pairs
    /// `albedo_tau`, `albedo_g`, `tau_g` (when `g` is fitted), `mu_a_mu_s_prime`.
    pub correlation: Vec<(String, f64)>,
    /// The problem is ill-conditioned at the answer (see `reasons`).
    pub ill_conditioned: bool,
    /// Why it is flagged.
    pub reasons: Vec<String>,
    /// The measurement uncertainties were given (`false`: [`DEFAULT_SIGMA`] assumed).
    pub sigma_given: bool,
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

/// The measurement model: what the set-up reads for a sample of optical
/// properties `p`, as `[M_R, M_T, M_U]`:
///
/// 0 spheres: `M_R = UR1 - (1 - c) R_u`, `M_T = UT1 - (1 - C) T_u`, (I1)
/// 1 or 2 spheres: `crate::sphere` (S2, S3, Pickering eq. 7–8);
/// always `M_U = T_u` (F2).
///
/// # Reference
/// Prahl, iad manual (iad 4.0), "Calculate_Distance_With_Corrections".
///
/// # Errors
/// A forward-model failure.
///
/// ```
/// use km_inverse::forward::{Optical, Sample};
/// use km_inverse::slab::{Setup, model};
/// let set = Setup::new(Sample::new(1.0, 1.0, None).unwrap());
/// let m = model(&set, &Optical { albedo: 0.0, tau: 1.0, g: 0.0 }, 8).unwrap();
/// assert!((m[1] - (-1f64).exp()).abs() < 1e-12 && m[0].abs() < 1e-15);
/// ```
pub fn model(set: &Setup, p: &Optical, streams: usize) -> Result<[f64; 3], InverseError> {
    model_with(set, &StackModel::new(&set.sample, streams)?, p)
}

/// [`model`] with the stack's boundaries and quadrature built once
/// ([`StackModel`], for many evaluations of one set-up, as in a fit).
///
/// # Errors
/// A forward-model failure.
///
/// ```
/// use km_inverse::forward::{Optical, Sample};
/// use km_inverse::slab::{Setup, model, model_with};
/// use km_inverse::stack::StackModel;
/// let set = Setup::new(Sample::new(1.0, 1.4, Some(1.5)).unwrap());
/// let stack = StackModel::new(&set.sample, 8).unwrap();
/// let p = Optical { albedo: 0.9, tau: 1.0, g: 0.5 };
/// assert_eq!(model_with(&set, &stack, &p).unwrap(), model(&set, &p, 8).unwrap());
/// ```
pub fn model_with(set: &Setup, stack: &StackModel, p: &Optical) -> Result<[f64; 3], InverseError> {
    let t = stack.totals(p, set.spheres.is_some())?;
    let (c, c_t) = (set.specular_in_m_r, set.unscattered_in_m_t);
    let (m_r, m_t) = match &set.spheres {
        None => (t.r_total - (1.0 - c) * t.r_specular, t.t_total - (1.0 - c_t) * t.t_unscattered),
        Some(s) if s.count == 1 => single_m_r_m_t(
            s,
            t.r_total,
            t.t_total,
            t.r_specular,
            t.t_unscattered,
            t.r_diffuse,
            c,
            c_t,
        ),
        Some(s) => double_m_r_m_t(
            s,
            t.r_total - (1.0 - c) * t.r_specular,
            t.t_total - (1.0 - c_t) * t.t_unscattered,
            t.r_diffuse,
            t.t_diffuse,
        ),
    };
    Ok([m_r, m_t, t.t_unscattered])
}

/// Bounds of the search variables: `|u| <= 36` keeps `a` within 2e-16 of
/// 0 and 1; `b` in `[1e-6, 1e4]` (iad clamps `b >= 1e-6` too); `|g| <= 0.995`.
const U_MAX: f64 = 36.0;
const V_MIN: f64 = -13.8;
const V_MAX: f64 = 9.2;
const W_MAX: f64 = 2.99; // atanh(0.995)

/// The free parameters and their transforms (step 2 of the module doc).
#[derive(Debug, Clone, Copy)]
struct Space {
    /// `g` is free.
    fit_g: bool,
    /// `g` when fixed.
    g_fixed: f64,
}

impl Space {
    fn dim(&self) -> usize {
        if self.fit_g { 3 } else { 2 }
    }
    fn optical_at(&self, x: &[f64]) -> Optical {
        let albedo = 1.0 / (1.0 + (-x[0]).exp());
        let tau = x[1].exp();
        let g = if self.fit_g { x[2].tanh() } else { self.g_fixed };
        Optical { albedo, tau, g }
    }
    fn point_of(&self, p: &Optical) -> Vec<f64> {
        let a = p.albedo.clamp(1e-12, 1.0 - 1e-12);
        let mut x = vec![(a / (1.0 - a)).ln(), p.tau.ln()];
        if self.fit_g {
            x.push(p.g.atanh());
        }
        self.clamp(&mut x);
        x
    }
    fn clamp(&self, x: &mut [f64]) {
        x[0] = x[0].clamp(-U_MAX, U_MAX);
        x[1] = x[1].clamp(V_MIN, V_MAX);
        if self.fit_g {
            x[2] = x[2].clamp(-W_MAX, W_MAX);
        }
    }
    /// `d(natural)/d(transformed)` per variable: `a (1 - a)`, `b`, `1 - g^2`.
    fn chain(&self, p: &Optical) -> Vec<f64> {
        let mut c = vec![p.albedo * (1.0 - p.albedo), p.tau];
        if self.fit_g {
            c.push(1.0 - p.g * p.g);
        }
        c
    }
}

/// Residuals of the search: `(model_i - measured_i) / scale_i`.
struct Problem<'a> {
    set: &'a Setup,
    space: Space,
    meas: Vec<f64>,
    scale: Vec<f64>,
    /// Log-ratio residuals (square systems) instead of `(M - m) / scale`.
    log: bool,
    /// The forward model at the current stream count.
    stack: StackModel,
    evaluations: usize,
    /// The last point evaluated and its model (a repeated point costs nothing).
    last: Option<(Vec<f64>, usize, [f64; 3])>,
}

impl Problem<'_> {
    /// Use `streams` from now on (a new [`StackModel`] when it changes).
    fn set_streams(&mut self, streams: usize) -> Result<(), InverseError> {
        if self.stack.streams() != streams {
            self.stack = StackModel::new(&self.set.sample, streams)?;
        }
        Ok(())
    }

    /// The measurement model at the search point `x` (memoised for the last point).
    fn model_at(&mut self, x: &[f64]) -> Result<[f64; 3], InverseError> {
        let n = self.stack.streams();
        if let Some((lx, ln, lm)) = &self.last
            && lx.as_slice() == x
            && *ln == n
        {
            return Ok(*lm);
        }
        self.evaluations += 1;
        let m = model_with(self.set, &self.stack, &self.space.optical_at(x))?;
        self.last = Some((x.to_vec(), n, m));
        Ok(m)
    }

    fn residuals(&mut self, x: &[f64]) -> Result<(Vec<f64>, [f64; 3]), InverseError> {
        let m = self.model_at(x)?;
        let r = (0..self.meas.len())
            .map(|i| {
                if self.log {
                    // Log ratio: symmetric in over- and undershoot, so tiny
                    // M_T or M_U do not drive the search to a = 0.
                    (m[i].max(1e-300) / self.meas[i].max(1e-300)).ln()
                } else {
                    (m[i] - self.meas[i]) / self.scale[i]
                }
            })
            .collect();
        Ok((r, m))
    }

    /// Forward-difference Jacobian in the transformed variables (row-major,
    /// measurements x parameters); step `1e-7` (about the square root of the
    /// forward model's relative precision, ~1e-14).
    fn jacobian(&mut self, x: &[f64], r0: &[f64]) -> Result<Vec<f64>, InverseError> {
        let (m, n) = (r0.len(), x.len());
        let mut jac = vec![0.0; m * n];
        for j in 0..n {
            let h = 1e-7 * x[j].abs().max(1.0);
            let mut xh = x.to_vec();
            // Step inward at a bound so the model stays defined.
            xh[j] += if x[j] + h > bound_hi(&self.space, j) { -h } else { h };
            let step = xh[j] - x[j];
            let (rh, _) = self.residuals(&xh)?;
            for i in 0..m {
                jac[i * n + j] = (rh[i] - r0[i]) / step;
            }
        }
        Ok(jac)
    }

    /// Levenberg–Marquardt from `x` (Marquardt 1963; Press et al.,
    /// *Numerical Recipes* §15.5): returns the best point and its residuals.
    ///
    /// The Jacobian is computed by forward differences once, then carried
    /// along by Broyden's rank-one update after each accepted step (Broyden
    /// 1965; Dennis & Schnabel 1996 §8.1): `J += (dr - J dx) dx^T / (dx^T dx)`,
    /// one forward solve per step instead of one plus one per parameter. It is
    /// recomputed by differences when a damped step fails with the updated
    /// Jacobian; the search ends only when a fresh Jacobian gives no descent.
    fn levenberg_marquardt(&mut self, mut x: Vec<f64>) -> Result<(Vec<f64>, f64), InverseError> {
        let n = x.len();
        let (mut r, _) = self.residuals(&x)?;
        let mut chi2 = sq(&r);
        let mut lambda = 1e-3;
        let mut jac = self.jacobian(&x, &r)?;
        let mut fresh = true;
        for _ in 0..200 {
            // Converged to round-off: the relative residuals are at the
            // forward model's precision (~1e-15).
            if chi2 < 1e-26 {
                break;
            }
            let (a, grad) = normal_equations(&jac, &r, n);
            let mut accepted = None;
            while lambda < 1e12 {
                // Damped step (A + lambda diag A) dx = -grad.
                let mut ad = a.clone();
                for p in 0..n {
                    ad[p * n + p] += lambda * a[p * n + p].max(1e-30);
                }
                let neg: Vec<f64> = grad.iter().map(|g| -g).collect();
                let Some(dx) = linalg::solve(&ad, &neg, n) else {
                    lambda *= 10.0;
                    continue;
                };
                let mut xn: Vec<f64> = x.iter().zip(&dx).map(|(a, b)| a + b).collect();
                self.space.clamp(&mut xn);
                let (rn, _) = self.residuals(&xn)?;
                if sq(&rn) < chi2 {
                    accepted = Some((xn, rn));
                    lambda = (lambda / 10.0).max(1e-12);
                    break;
                }
                lambda *= 10.0;
            }
            let Some((xn, rn)) = accepted else {
                if fresh {
                    break;
                }
                // The updated Jacobian led nowhere: differences again.
                jac = self.jacobian(&x, &r)?;
                (fresh, lambda) = (true, 1e-3);
                continue;
            };
            let dx: Vec<f64> = xn.iter().zip(&x).map(|(a, b)| a - b).collect();
            let step = dx.iter().fold(0.0f64, |s, d| s.max(d.abs()));
            broyden_update(&mut jac, &dx, &r, &rn);
            fresh = false;
            (x, r) = (xn, rn);
            chi2 = sq(&r);
            // A step below 1e-13 changes nothing further.
            if step < 1e-13 {
                break;
            }
        }
        Ok((x, chi2))
    }
}

/// Normal equations of a row-major Jacobian `J` (`m x n`): `(J^T J, J^T r)`.
fn normal_equations(jac: &[f64], r: &[f64], n: usize) -> (Vec<f64>, Vec<f64>) {
    let mut a = vec![0.0; n * n];
    let mut grad = vec![0.0; n];
    for (i, ri) in r.iter().enumerate() {
        for p in 0..n {
            grad[p] += jac[i * n + p] * ri;
            for q in 0..n {
                a[p * n + q] += jac[i * n + p] * jac[i * n + q];
            }
        }
    }
    (a, grad)
}

/// Broyden's rank-one update of a row-major Jacobian after the step `dx`
/// that moved the residuals from `r` to `rn` (Broyden 1965, the "good"
/// update): `J += (rn - r - J dx) dx^T / (dx^T dx)`.
fn broyden_update(jac: &mut [f64], dx: &[f64], r: &[f64], rn: &[f64]) {
    let n = dx.len();
    let dd: f64 = dx.iter().map(|d| d * d).sum();
    if dd == 0.0 {
        return;
    }
    for i in 0..r.len() {
        let jdx: f64 = (0..n).map(|j| jac[i * n + j] * dx[j]).sum();
        let f = (rn[i] - r[i] - jdx) / dd;
        for j in 0..n {
            jac[i * n + j] += f * dx[j];
        }
    }
}

fn bound_hi(space: &Space, j: usize) -> f64 {
    match j {
        0 => U_MAX,
        1 => V_MAX,
        _ => {
            let _ = space;
            W_MAX
        }
    }
}

fn sq(r: &[f64]) -> f64 {
    r.iter().map(|v| v * v).sum()
}

/// Starting point from the two-flux inverse (`docs/inverse.md` eq. I4–I6):
/// Kubelka's closed forms for a layer of diffuse reflectance `R` and
/// transmittance `T`,
///
/// `A = (1 + R^2 - T^2) / (2R)`, `B = sqrt(A^2 - 1)`,
/// `S d = ln((1 - R (A - B)) / T) / B`, `K d = S d (A - 1)`, (I4)
///
/// with `K = 2 mu_a`, `S = (3 mu_s' - mu_a) / 4` (I5), then
/// `a = a' / (1 - g + a' g)`, `b = b' / (1 - a g)` from the reduced
/// `a' = mu_s' / (mu_a + mu_s')`, `b' = (mu_a + mu_s') d` (I6).
/// With `M_U`, `b` comes from (F3) instead.
fn start(set: &Setup, meas: &Measurement, g: f64) -> Optical {
    let (r_b, _) = crate::forward::boundary(set.sample.n_sample, set.sample.n_slide);
    // Diffuse parts, roughly: remove the first-surface specular reflection.
    let r = (meas.m_r - set.specular_in_m_r * r_b).max(1e-4);
    let t = meas.m_t.max(1e-6);
    let fallback = Optical { albedo: 0.9, tau: 1.0, g };
    let ka = (1.0 + r * r - t * t) / (2.0 * r);
    let kb = (ka * ka - 1.0).max(0.0).sqrt();
    let (sd, kd) = if kb > 1e-8 && r + t < 1.0 {
        let sd = ((1.0 - r * (ka - kb)) / t).ln() / kb;
        (sd, sd * (ka - 1.0))
    } else {
        // No absorption in the two-flux sense: T = 1 / (1 + S d).
        ((1.0 - t) / t, 1e-3)
    };
    let mu_a = (kd / 2.0).max(1e-6);
    let mu_sp = ((4.0 * sd + mu_a) / 3.0).max(1e-6);
    let ap = mu_sp / (mu_a + mu_sp);
    let bp = mu_a + mu_sp;
    let mut p = Optical { albedo: ap / (1.0 - g + ap * g), tau: 0.0, g };
    p.tau = bp / (1.0 - p.albedo * g);
    if let Some(u) = meas.m_u
        && let Ok(b) = tau_from_unscattered(u, set.sample.n_sample, set.sample.n_slide)
    {
        p.tau = b;
        p.albedo = (1.0 - mu_a / b.max(1e-9)).clamp(0.05, 0.999);
    }
    p.albedo = p.albedo.clamp(0.05, 0.999);
    p.tau = p.tau.clamp(1e-3, 1e3);
    if p.albedo.is_finite() && p.tau.is_finite() { p } else { fallback }
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
    set.validate()?;
    meas.validate()?;
    if let Some(g) = opts.g
        && !(g.is_finite() && g.abs() < 1.0)
    {
        return Err(InverseError::invalid("g", g, "must lie in (-1, 1)"));
    }
    if let Some(n) = opts.streams
        && !(2..=256).contains(&n)
    {
        return Err(InverseError::invalid("streams", n as f64, "must lie in [2, 256]"));
    }
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
    let mut x = space.point_of(&p0);
    let mut chi2 = f64::INFINITY;
    for (k, &n) in ladder.iter().enumerate() {
        prob.set_streams(n)?;
        let (xn, c) = prob.levenberg_marquardt(x.clone())?;
        x = xn;
        chi2 = c;
        // Restarts when the start did not lead to a root (step 2).
        if square && chi2 > 1e-12 {
            // The unscattered beam alone bounds b from below (T >= T_u(b));
            // thick samples start just above that bound.
            let b_min = tau_from_unscattered(
                meas.m_t.min(
                    0.999
                        * crate::forward::unscattered_transmittance(
                            set.sample.n_sample,
                            set.sample.n_slide,
                            0.0,
                        ),
                ),
                set.sample.n_sample,
                set.sample.n_slide,
            )
            .unwrap_or(1.0)
            .max(0.01);
            let grid = [
                (0.5, 0.3),
                (0.99, 3.0),
                (0.9, 30.0),
                (0.3, 3.0),
                (0.999, 0.5),
                (0.3, 1.05 * b_min),
                (0.7, 1.05 * b_min),
                (0.95, 1.05 * b_min),
            ];
            for &(a, b) in &grid {
                let g = if space.fit_g { 0.5 } else { space.g_fixed };
                let xs = space.point_of(&Optical { albedo: a, tau: b, g });
                let (xr, cr) = prob.levenberg_marquardt(xs)?;
                if cr < chi2 {
                    x = xr;
                    chi2 = cr;
                }
            }
            notes.push(format!("restarted from a grid of starting points at {n} streams"));
        }
        if ladder.len() == 1 {
            break;
        }
        // Stream rule (I7): the forward model at 2N moves by < sigma_min / 10.
        let p = space.optical_at(&x);
        let m_n = prob.model_at(&x)?;
        let m_2n = model(set, &p, 2 * n)?;
        prob.evaluations += 1;
        let moved = (0..values.len()).map(|i| (m_n[i] - m_2n[i]).abs()).fold(0.0, f64::max);
        if moved < 0.1 * sigma_min {
            break;
        }
        if k + 1 == ladder.len() {
            notes.push(format!(
                "stream rule not met: the model moves by {moved:.1e} from {n} to {} streams \
                 (wanted < {:.1e})",
                2 * n,
                0.1 * sigma_min
            ));
        }
    }
    let _ = chi2;
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

/// The albedo sits at a bound of the search (`a < 1e-9` or `1 - a < 1e-9`):
/// the direction of an inward step in `a` (`+1` at 0, `-1` at 1).
fn albedo_edge(p: &Optical) -> Option<f64> {
    if p.albedo < 1e-9 {
        Some(1.0)
    } else if 1.0 - p.albedo < 1e-9 {
        Some(-1.0)
    } else {
        None
    }
}

/// The Jacobian of the answer from the search's own (in the unbounded
/// variables): whether it is singular (the measurements cannot tell the
/// parameters apart at any precision: scaled condition number above 1e12),
/// and the Jacobian of the measurements in units of sigma in the natural
/// variables `(a, b[, g])`, `J_nat = J_search / chain`, unscaled from log
/// ratios (`d ln M = dM / M`) when the search used them.
fn search_jacobian(
    prob: &mut Problem<'_>,
    x: &[f64],
    fitted: &[f64; 3],
    sigma: &[f64],
) -> Result<(bool, Vec<f64>), InverseError> {
    let (r0, _) = prob.residuals(x)?;
    let j_search = prob.jacobian(x, &r0)?;
    let (m, nd) = (r0.len(), x.len());
    let singular = scaled_condition(&normal_matrix(&j_search, m, nd), nd) > 1e12;
    let chain = prob.space.chain(&prob.space.optical_at(x));
    let jac = (0..m * nd)
        .map(|ix| {
            let (i, j) = (ix / nd, ix % nd);
            let jt = if prob.log { j_search[ix] * fitted[i] / sigma[i] } else { j_search[ix] };
            jt / chain[j].max(1e-300)
        })
        .collect();
    Ok((singular, jac))
}

/// The Jacobian at an albedo bound, by one-sided differences in the natural
/// variables (the search variable `u = ln(a / (1 - a))` flattens the model
/// there: `da/du = a (1 - a) = 0`, which would call every such answer
/// singular): step `1e-6` inward in `a`, relative `1e-7` in `b`, `1e-7` in `g`.
fn edge_jacobian(
    prob: &mut Problem<'_>,
    p: &Optical,
    fitted: &[f64; 3],
    sigma: &[f64],
    dir: f64,
) -> Result<(bool, Vec<f64>), InverseError> {
    let (m, nd) = (sigma.len(), prob.space.dim());
    let mut jac = vec![0.0; m * nd];
    for j in 0..nd {
        let mut q = *p;
        let h = match j {
            0 => dir * 1e-6,
            1 => 1e-7 * p.tau,
            // Inward in g, away from the nearer of -1 and 1.
            _ => {
                if p.g >= 0.0 {
                    -1e-7
                } else {
                    1e-7
                }
            }
        };
        match j {
            0 => q.albedo += h,
            1 => q.tau += h,
            _ => q.g += h,
        }
        prob.evaluations += 1;
        let mh = model_with(prob.set, &prob.stack, &q)?;
        for i in 0..m {
            jac[i * nd + j] = (mh[i] - fitted[i]) / (h * sigma[i]);
        }
    }
    let singular = scaled_condition(&normal_matrix(&jac, m, nd), nd) > 1e12;
    Ok((singular, jac))
}

/// `J^T J` of a row-major `m x n` Jacobian.
fn normal_matrix(jac: &[f64], m: usize, n: usize) -> Vec<f64> {
    let mut a = vec![0.0; n * n];
    for i in 0..m {
        for j in 0..n {
            for k in 0..n {
                a[j * n + k] += jac[i * n + j] * jac[i * n + k];
            }
        }
    }
    a
}

/// 1-norm condition number of a symmetric `n x n` matrix after Jacobi
/// scaling to a unit diagonal (explicit inverse: `n <= 3`); infinite when singular.
fn scaled_condition(a: &[f64], n: usize) -> f64 {
    let d: Vec<f64> = (0..n).map(|j| a[j * n + j].sqrt().max(1e-300)).collect();
    let s: Vec<f64> = (0..n * n).map(|ix| a[ix] / (d[ix / n] * d[ix % n])).collect();
    let norm1 = |v: &[f64]| {
        (0..n).map(|c| (0..n).map(|r| v[r * n + c].abs()).sum::<f64>()).fold(0.0, f64::max)
    };
    linalg::inverse(&s, n).map_or(f64::INFINITY, |inv| norm1(&s) * norm1(&inv))
}

/// Covariance of the fitted parameters and its propagation (eq. I8–I10):
///
/// `C = (J^T J)^-1` with `J_ij = (dM_i / dp_j) / sigma_i`, (I8)
/// `u(f)^2 = grad f^T C grad f` for `f` in `mu_a = (1 - a) b / d`,
/// `mu_s = a b / d`, `mu_s' = a b (1 - g) / d`, (I9)
/// `rho_jk = C_jk / sqrt(C_jj C_kk)`. (I10)
///
/// Flags: a singular or nearly singular `J^T J` (condition number of the
/// scaled matrix above 1e12: the measurements do not determine the
/// parameters), a relative uncertainty above 1, and `a` within two
/// standard uncertainties of 1 (the `a = 1` edge, where the linearisation fails).
///
/// # Reference
/// JCGM 100:2008 (GUM) §5.1.2 and JCGM 102:2011 §6.2 (propagation with the
/// covariance matrix); Press et al., *Numerical Recipes* §15.6.
fn covariance(
    jac: &[f64],
    m: usize,
    n: usize,
    p: &Optical,
    d: f64,
    fit_g: bool,
    sigma_given: bool,
) -> Uncertainty {
    let a = normal_matrix(jac, m, n);
    let dsc: Vec<f64> = (0..n).map(|j| a[j * n + j].sqrt().max(1e-300)).collect();
    let scaled: Vec<f64> = (0..n * n).map(|ix| a[ix] / (dsc[ix / n] * dsc[ix % n])).collect();
    let mut reasons = Vec::new();
    let inv_scaled = linalg::inverse(&scaled, n);
    let cond = scaled_condition(&a, n);
    let singular = cond.is_nan() || cond >= 1e12;
    let nan_u = || Uncertainty {
        albedo: f64::INFINITY,
        tau: f64::INFINITY,
        g: if fit_g { f64::INFINITY } else { 0.0 },
        mu_a: f64::INFINITY,
        mu_s: f64::INFINITY,
        mu_s_prime: f64::INFINITY,
        correlation: Vec::new(),
        ill_conditioned: true,
        reasons: Vec::new(),
        sigma_given,
    };
    if singular {
        let mut u = nan_u();
        u.reasons.push(format!(
            "the Jacobian of the measurements is singular (condition number {cond:.1e}): \
             the measurements do not determine the parameters"
        ));
        return u;
    }
    let inv = inv_scaled.unwrap_or_default();
    let c: Vec<f64> = (0..n * n).map(|ix| inv[ix] / (dsc[ix / n] * dsc[ix % n])).collect();
    let (aa, b, g) = (p.albedo, p.tau, p.g);
    // Gradients with respect to (a, b, g) of the derived quantities (I9).
    let mut grads = [
        vec![-b / d, (1.0 - aa) / d, 0.0],
        vec![b / d, aa / d, 0.0],
        vec![b * (1.0 - g) / d, aa * (1.0 - g) / d, -aa * b / d],
    ];
    for gr in &mut grads {
        gr.truncate(n);
    }
    let quad = |x: &[f64], y: &[f64]| -> f64 {
        (0..n).map(|j| (0..n).map(|k| x[j] * c[j * n + k] * y[k]).sum::<f64>()).sum()
    };
    let sd = |j: usize| c[j * n + j].max(0.0).sqrt();
    let rho = |j: usize, k: usize| c[j * n + k] / (sd(j) * sd(k));
    let mut correlation = vec![("albedo_tau".to_string(), rho(0, 1))];
    if fit_g {
        correlation.push(("albedo_g".into(), rho(0, 2)));
        correlation.push(("tau_g".into(), rho(1, 2)));
    }
    let (u_mua, u_musp) = (quad(&grads[0], &grads[0]).sqrt(), quad(&grads[2], &grads[2]).sqrt());
    correlation.push(("mu_a_mu_s_prime".into(), quad(&grads[0], &grads[2]) / (u_mua * u_musp)));
    let u = Uncertainty {
        albedo: sd(0),
        tau: sd(1),
        g: if fit_g { sd(2) } else { 0.0 },
        mu_a: u_mua,
        mu_s: quad(&grads[1], &grads[1]).sqrt(),
        mu_s_prime: u_musp,
        correlation,
        ill_conditioned: false,
        reasons: Vec::new(),
        sigma_given,
    };
    if cond > 1e8 {
        reasons.push(format!("nearly singular Jacobian (condition number {cond:.1e})"));
    }
    if aa + 2.0 * u.albedo >= 1.0 {
        reasons.push("albedo within two standard uncertainties of 1 (the a = 1 edge)".into());
    }
    if u.tau > b {
        reasons
            .push("u(tau) > tau: the transmittance carries no information on the thickness".into());
    }
    if fit_g && u.g > 1.0 {
        reasons.push("u(g) > 1: the measurements do not determine g".into());
    }
    let ill = !reasons.is_empty();
    Uncertainty { ill_conditioned: ill, reasons, ..u }
}
