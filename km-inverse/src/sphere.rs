//! Integrating-sphere measurement equations: what a single or double sphere
//! reads for a sample of given totals (`docs/inverse.md` §3).
//!
//! A sphere of wall reflectance `r_w` has ports of area fractions `a_s`
//! (sample), `a_t` (third port: entrance for reflection, exit for
//! transmission), `a_d` (detector) and wall `a_w = 1 - a_s - a_t - a_d`.
//! Diffuse light bounces inside; the detector signal is the light first
//! put on the wall times the sphere gain. With a baffle between the sample
//! and the detector (the default of iad 4.0), the gain is
//!
//! `1/G = 1 - (r_w + (a_t/a_w) r_third) (a_w + (1 - a_t)(a_d r_d + a_s r_s))` (S1)
//!
//! where `r_s` is the diffuse reflectance of what covers the sample port and
//! `r_third` that of the third port; without a baffle
//! `1/G = 1 - a_w r_w - a_d r_d - a_s r_s - a_t r_third`.
//!
//! Single sphere, substitution method (the sample and the standard are put
//! in turn in the sample port):
//!
//! `M_R = r_std (P - P_0) / (P_std - P_0)` with
//! `P = G(URU) [r_w (1 - a_t) (UR1 - R_u) + r_w c R_u]`,
//! `P_std = G(r_std) r_std`, `P_0 = 0` (no light hits the wall first), (S2)
//!
//! `M_T = G(URU, r_3) [r_1 (UT1 - T_u) + r_3 C T_u] / G(0, r_cal)`, (S3)
//!
//! with `r_1 = r_w (1 - a_t) + r_3 a_t` (baffle), and `r_3 = r_cal = r_w`
//! when the transmission sphere has no third port, `r_3 = r_cal = r_std,t`
//! when the unscattered beam is kept (`C > 0`), `r_3 = 0`, `r_cal = r_std,t`
//! otherwise. Double sphere (both spheres at once, light crossing from one
//! to the other through the sample): Pickering et al. 1993 eq. 7–8 as
//! written in iad (`Two_Sphere_R`, `Two_Sphere_T`), see [`double_m_r_m_t`].
//!
//! # Reference
//! Prahl, *Inverse Adding-Doubling* manual (iad 4.0), chapter "Sphere
//! corrections" (`iad_calc.w`, functions `Gain`, `Gain_11`, `Gain_22`,
//! `Two_Sphere_R`, `Two_Sphere_T`); Pickering, Prahl, van Wieringen,
//! Beek, Sterenborg, van Gemert, Appl. Opt. 32, 399–410 (1993), eq. 1–8.
//! Goebel, Caldwell & Hammond, JOSA 56, 783 (1966) for the sphere gain.
//!
//! Not modelled (as in iad without its Monte Carlo loop): light lost out of
//! the sides of the sample or outside the sample port ("lost light").

use crate::InverseError;

/// One integrating sphere.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sphere {
    /// Diameter of the sphere (any length unit, the same for all diameters).
    pub d_sphere: f64,
    /// Diameter of the sample port.
    pub d_sample: f64,
    /// Diameter of the third port (entrance for reflection, exit for transmission).
    pub d_third: f64,
    /// Diameter of the detector port.
    pub d_detector: f64,
    /// Diffuse reflectance of the wall, `[0, 1]`.
    pub r_wall: f64,
    /// Diffuse reflectance of the detector, `[0, 1]` (iad's default 0).
    pub r_detector: f64,
}

/// Port fractions of a sphere: `(a_s, a_t, a_d, a_w)`, each `(d / (2 D))^2`
/// (the cap area of a port over the sphere area, small-port form used by iad).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Ports {
    a_s: f64,
    a_t: f64,
    a_d: f64,
    a_w: f64,
}

impl Sphere {
    /// Check the geometry: positive sphere, ports that fit, reflectances in `[0, 1]`.
    ///
    /// # Errors
    /// [`InverseError::Invalid`] naming the offending value.
    pub fn validate(&self, which: &str) -> Result<(), InverseError> {
        let bad = |n: &str, v: f64, r: &str| InverseError::invalid(&format!("{which}.{n}"), v, r);
        if !(self.d_sphere.is_finite() && self.d_sphere > 0.0) {
            return Err(bad("d_sphere", self.d_sphere, "must be finite and > 0"));
        }
        for (n, d) in [
            ("d_sample", self.d_sample),
            ("d_third", self.d_third),
            ("d_detector", self.d_detector),
        ] {
            if !(d.is_finite() && d >= 0.0 && d < self.d_sphere) {
                return Err(bad(n, d, "must lie in [0, d_sphere)"));
            }
        }
        for (n, r) in [("r_wall", self.r_wall), ("r_detector", self.r_detector)] {
            if !(0.0..=1.0).contains(&r) {
                return Err(bad(n, r, "must lie in [0, 1]"));
            }
        }
        if self.ports().a_w <= 0.0 {
            return Err(bad("d_sample", self.d_sample, "ports leave no wall"));
        }
        Ok(())
    }

    fn ports(&self) -> Ports {
        let f = |d: f64| (d / (2.0 * self.d_sphere)).powi(2);
        let (a_s, a_t, a_d) = (f(self.d_sample), f(self.d_third), f(self.d_detector));
        Ports { a_s, a_t, a_d, a_w: 1.0 - a_s - a_t - a_d }
    }

    /// Sphere gain (S1) with the sample port covered by diffuse reflectance
    /// `r_s` and the third port by `r_third`; `baffle` as in iad (default on).
    ///
    /// # Reference
    /// Prahl, iad manual, `Gain` (eq. S1 of `docs/inverse.md`); Goebel et al. 1966.
    ///
    /// ```
    /// use km_inverse::sphere::Sphere;
    /// let s = Sphere { d_sphere: 200.0, d_sample: 25.0, d_third: 12.0, d_detector: 1.0,
    ///                  r_wall: 0.0, r_detector: 0.0 };
    /// assert_eq!(s.gain(0.5, 0.0, true), 1.0); // a black wall: no multiple bounces
    /// ```
    pub fn gain(&self, r_s: f64, r_third: f64, baffle: bool) -> f64 {
        let p = self.ports();
        let inv = if baffle {
            1.0 - (self.r_wall + (p.a_t / p.a_w) * r_third)
                * (p.a_w + (1.0 - p.a_t) * (p.a_d * self.r_detector + p.a_s * r_s))
        } else {
            1.0 - p.a_w * self.r_wall - p.a_d * self.r_detector - p.a_s * r_s - p.a_t * r_third
        };
        1.0 / inv
    }
}

/// The sphere set-up of a measurement.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SphereSetup {
    /// Number of spheres used at a time: 1 (substitution) or 2 (double sphere).
    pub count: usize,
    /// The reflection sphere.
    pub r_sphere: Sphere,
    /// The transmission sphere.
    pub t_sphere: Sphere,
    /// Reflectance of the reflection standard, `(0, 1]`.
    pub r_std: f64,
    /// Transmittance read as 100 % in the transmission calibration, `(0, 1]` (iad default 1).
    pub t_std: f64,
    /// Baffles between sample and detector in both spheres (iad default: yes).
    pub baffle: bool,
}

impl SphereSetup {
    /// Check both spheres and the standards.
    ///
    /// # Errors
    /// [`InverseError::Invalid`] naming the offending value.
    pub fn validate(&self) -> Result<(), InverseError> {
        if !(1..=2).contains(&self.count) {
            return Err(InverseError::invalid("spheres", self.count as f64, "must be 0, 1 or 2"));
        }
        self.r_sphere.validate("r_sphere")?;
        self.t_sphere.validate("t_sphere")?;
        for (n, v) in [("r_std", self.r_std), ("t_std", self.t_std)] {
            if !(v > 0.0 && v <= 1.0) {
                return Err(InverseError::invalid(n, v, "must lie in (0, 1]"));
            }
        }
        Ok(())
    }
}

/// Single-sphere (substitution) readings (S2), (S3) for a sample with
/// collimated totals `ur1`, `ut1`, their unscattered parts `r_u`, `t_u`,
/// diffuse-light reflectance `uru`; `c`, `c_t`: the fractions of `R_u` and
/// `T_u` that the spheres collect.
///
/// # Reference
/// Prahl, iad manual (iad 4.0, `Calculate_Distance_With_Corrections`,
/// one sphere, substitution); Pickering et al. 1993 eq. 1–4.
///
/// ```
/// use km_inverse::sphere::{single_m_r_m_t, Sphere, SphereSetup};
/// // Vanishing ports, no baffle: the gains of sample and standard agree, so
/// // the diffuse parts read as they are and the specular (reflection) or
/// // unscattered (transmission) light is weighted by the first wall bounce.
/// let s = Sphere { d_sphere: 1e6, d_sample: 1.0, d_third: 0.0, d_detector: 1.0,
///                  r_wall: 0.98, r_detector: 0.0 };
/// let set = SphereSetup { count: 1, r_sphere: s, t_sphere: s, r_std: 1.0, t_std: 1.0,
///                         baffle: false };
/// let (mr, mt) = single_m_r_m_t(&set, 0.3, 0.5, 0.04, 0.2, 0.3, 1.0, 1.0);
/// assert!((mr - (0.26 + 0.98 * 0.04)).abs() < 1e-9);
/// assert!((mt - (0.3 + 0.98 * 0.2)).abs() < 1e-9);
/// ```
#[allow(clippy::too_many_arguments)]
pub fn single_m_r_m_t(
    set: &SphereSetup,
    ur1: f64,
    ut1: f64,
    r_u: f64,
    t_u: f64,
    uru: f64,
    c: f64,
    c_t: f64,
) -> (f64, f64) {
    let (rs, ts) = (&set.r_sphere, &set.t_sphere);
    // Reflection sphere: light first hits the sample; the diffuse part goes
    // to the wall past the baffle (factor r_w (1 - a_t)), the collected
    // specular part c R_u straight to the wall.
    let pr = rs.ports();
    let r_first = if set.baffle { rs.r_wall * (1.0 - pr.a_t) } else { 1.0 };
    let p_sample =
        rs.gain(uru, 0.0, set.baffle) * (r_first * (ur1 - r_u).max(0.0) + rs.r_wall * c * r_u);
    let p_std = rs.gain(set.r_std, 0.0, set.baffle) * set.r_std;
    let m_r = set.r_std * p_sample / p_std;

    // Transmission sphere: what covers the third port (S3's r_3, r_cal).
    let pt = ts.ports();
    let (r_cal, r_third) = if pt.a_t == 0.0 {
        (ts.r_wall, ts.r_wall)
    } else if c_t > 0.0 {
        (set.t_std, set.t_std)
    } else {
        (set.t_std, 0.0)
    };
    let r_first = if set.baffle { ts.r_wall * (1.0 - pt.a_t) + r_third * pt.a_t } else { 1.0 };
    let p = r_third * t_u * c_t + r_first * (ut1 - t_u).max(0.0);
    let m_t = p * ts.gain(uru, r_third, set.baffle) / ts.gain(0.0, r_cal, set.baffle);
    (m_r, m_t)
}

/// Double-sphere readings: both spheres see the sample at once and trade
/// light through it (Pickering et al. 1993 eq. 7–8, in iad's form with no
/// light hitting the wall first):
///
/// `G_11 = G / (1 - a_s a_s' a_w a_w' (1 - a_t)(1 - a_t') G G' UTU^2)`,
/// `R(x) = a_d (1 - a_t) r_w G_11 [UR1 + a_s' (1 - a_t') r_w' UT1 UTU G']`,
/// `T(x) = a_d' (1 - a_t') r_w' G_22 [UT1 + (1 - a_t) r_w a_s UTU UR1 G]`,
///
/// normalised as `M_R = r_std (R - R_0) / (R_std - R_0)`, `M_T = (T - T_0) / (T_100 - T_0)`
/// (standard in the reflection port; empty port with the beam through for 100 %).
///
/// # Reference
/// Pickering et al., Appl. Opt. 32, 399 (1993) eq. 7–8; Prahl, iad manual,
/// `Gain_11`, `Gain_22`, `Two_Sphere_R`, `Two_Sphere_T`.
pub fn double_m_r_m_t(set: &SphereSetup, ur1: f64, ut1: f64, uru: f64, utu: f64) -> (f64, f64) {
    let (rs, ts) = (&set.r_sphere, &set.t_sphere);
    let (pr, pt) = (rs.ports(), ts.ports());
    let b = set.baffle;
    let reading = |ur1: f64, uru: f64, ut1: f64, utu: f64| -> (f64, f64) {
        let g = rs.gain(uru, 0.0, b);
        let gp = ts.gain(uru, 0.0, b);
        let cross = 1.0
            - pr.a_s
                * pt.a_s
                * pr.a_w
                * pt.a_w
                * (1.0 - pr.a_t)
                * (1.0 - pt.a_t)
                * g
                * gp
                * utu
                * utu;
        let (g11, g22) = (g / cross, gp / cross);
        let r = pr.a_d
            * (1.0 - pr.a_t)
            * rs.r_wall
            * g11
            * (ur1 + pt.a_s * (1.0 - pt.a_t) * ts.r_wall * ut1 * utu * gp);
        let t = pt.a_d
            * (1.0 - pt.a_t)
            * ts.r_wall
            * g22
            * (ut1 + (1.0 - pr.a_t) * rs.r_wall * pr.a_s * utu * ur1 * g);
        (r, t)
    };
    let (r0, t0) = reading(0.0, 0.0, 0.0, 0.0);
    let (r, t) = reading(ur1, uru, ut1, utu);
    let (r_std, _) = reading(set.r_std, set.r_std, 0.0, 0.0);
    let (_, t_100) = reading(0.0, 0.0, 1.0, 1.0);
    (set.r_std * (r - r0) / (r_std - r0), (t - t0) / (t_100 - t0))
}
