//! The measurement model of the slab inverse (`docs/inverse.md` §2): what
//! was measured ([`Measurement`]), how ([`Setup`]: the sample between its
//! slides, the spheres, what `M_R` and `M_T` include), and what that set-up
//! reads for given optical properties ([`model`], eq. I1).

use crate::InverseError;
use crate::forward::{Optical, Sample};
use crate::sphere::{SphereSetup, double_m_r_m_t, single_m_r_m_t};
use crate::stack::StackModel;

/// Measurement uncertainty assumed when none is given: iad's default
/// convergence tolerance (`-e 0.0001`), an absolute reflectance.
pub const DEFAULT_SIGMA: f64 = 1e-4;

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

    pub(crate) fn validate(&self) -> Result<(), InverseError> {
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
    pub(crate) fn values(&self) -> Vec<f64> {
        let mut v = vec![self.m_r, self.m_t];
        v.extend(self.m_u);
        v
    }

    /// Standard uncertainties in the same order, and whether any was given.
    pub(crate) fn sigmas(&self) -> (Vec<f64>, bool) {
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

    pub(crate) fn validate(&self) -> Result<(), InverseError> {
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
