//! Two-term Henyey–Greenstein: a forward and a backward lobe (Kattawar
//! 1975; Irvine 1965 for the sum of two Henyey–Greenstein lobes):
//!
//! ```text
//! p(cos t) = w p_HG(cos t; g1) + (1 - w) p_HG(cos t; g2)                       (P6)
//! chi_l = w g1^l + (1 - w) g2^l,   g = w g1 + (1 - w) g2                      (P7)
//! ```
//!
//! with `p_HG` of eq. P3, `|g1|, |g2| < 1`, `0 <= w <= 1`. Two successive
//! scatterings (the moments `chi_l^2`, needed by the second-order intensity
//! correction) are again a sum of Henyey–Greenstein lobes:
//! `w^2 p_HG(g1^2) + 2 w (1 - w) p_HG(g1 g2) + (1 - w)^2 p_HG(g2^2)` (P8).

use super::{Anisotropy, hg_eval, hg_sample};
use crate::error::CoreError;

/// Two-term Henyey–Greenstein (eq. P6), checked at construction.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TwoTermHg {
    g1: Anisotropy,
    g2: Anisotropy,
    weight: f64,
}

impl TwoTermHg {
    /// `w HG(g1) + (1 - w) HG(g2)`.
    ///
    /// # Errors
    /// `|g1|` or `|g2|` not below 1, `weight` outside `[0, 1]`, or a mean
    /// cosine `w g1 + (1 - w) g2` of magnitude 1 (cannot happen for valid
    /// lobes; checked for the record).
    ///
    /// ```
    /// use km_core::phase::TwoTermHg;
    /// let p = TwoTermHg::new(0.9, -0.3, 0.8).unwrap();
    /// assert!((p.g() - (0.8 * 0.9 - 0.2 * 0.3)).abs() < 1e-15);
    /// assert!(TwoTermHg::new(0.9, -0.3, 1.2).is_err());
    /// ```
    pub fn new(g1: f64, g2: f64, weight: f64) -> Result<TwoTermHg, CoreError> {
        let g1 = Anisotropy::new(g1)
            .map_err(|_| CoreError::invalid("g1", g1, "must satisfy |g1| < 1"))?;
        let g2 = Anisotropy::new(g2)
            .map_err(|_| CoreError::invalid("g2", g2, "must satisfy |g2| < 1"))?;
        if !(0.0..=1.0).contains(&weight) {
            return Err(CoreError::invalid("weight", weight, "must lie in [0, 1]"));
        }
        Ok(TwoTermHg { g1, g2, weight })
    }

    /// Asymmetry of the first lobe.
    pub fn g1(&self) -> f64 {
        self.g1.get()
    }

    /// Asymmetry of the second lobe.
    pub fn g2(&self) -> f64 {
        self.g2.get()
    }

    /// Weight `w` of the first lobe.
    pub fn weight(&self) -> f64 {
        self.weight
    }

    /// Mean cosine `w g1 + (1 - w) g2` (eq. P7).
    pub fn g(&self) -> f64 {
        self.weight * self.g1() + (1.0 - self.weight) * self.g2()
    }

    /// `p(cos t)` (eq. P6).
    pub(crate) fn eval(&self, c: f64) -> f64 {
        self.weight * hg_eval(self.g1(), c) + (1.0 - self.weight) * hg_eval(self.g2(), c)
    }

    /// `chi_l` (eq. P7).
    pub(crate) fn moment(&self, l: usize) -> f64 {
        let l = l as i32;
        self.weight * self.g1().powi(l) + (1.0 - self.weight) * self.g2().powi(l)
    }

    /// The phase function of moments `chi_l^2` (eq. P8).
    pub(crate) fn eval_convolved(&self, c: f64) -> f64 {
        let (w, g1, g2) = (self.weight, self.g1(), self.g2());
        w * w * hg_eval(g1 * g1, c)
            + 2.0 * w * (1.0 - w) * hg_eval(g1 * g2, c)
            + (1.0 - w) * (1.0 - w) * hg_eval(g2 * g2, c)
    }

    /// A cosine with density `2 pi p`: the first lobe for `u < w` (with
    /// `u / w` as its uniform), the second otherwise (`(u - w)/(1 - w)`):
    /// a pure function of `u`, not monotone in it.
    pub(crate) fn sample(&self, u: f64) -> f64 {
        let w = self.weight;
        if u < w {
            hg_sample(self.g1(), u / w)
        } else {
            hg_sample(self.g2(), ((u - w) / (1.0 - w)).min(1.0))
        }
    }
}
