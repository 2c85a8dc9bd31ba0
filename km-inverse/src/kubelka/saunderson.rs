//! Saunderson's correction between measured and internal reflectances
//! (Saunderson 1942; `docs/inverse-km.md` eq. I8–I9).

use super::{KubelkaError, check_reflectance};
use km_core::fresnel;

/// Whether the instrument's reading includes the mirror reflection of the
/// film's surface (sphere geometry "specular included", SCI) or not
/// ("specular excluded", SCE, or 45°/0° geometry).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Specular {
    /// The reading includes the surface reflection `k1` (SCI).
    #[default]
    Included,
    /// The reading excludes it (SCE, 45°/0°).
    Excluded,
}

/// Saunderson's correction between measured reflectance `R_m` and the
/// internal two-flux reflectance `R` of a film with a smooth surface:
///
/// ```text
/// R_m = k1 + (1 - k1)(1 - k2) R / (1 - k2 R)       specular included     (I8)
/// R   = (R_m - k1) / (1 - k1 - k2 + k2 R_m)                               (I9)
/// ```
///
/// (without `k1 +` and with `R_m - k1` replaced by `R_m` when the specular
/// component is excluded). `k1` is the surface's reflectance for the
/// incoming light (Fresnel at normal incidence: `((n - 1)/(n + 1))^2`), `k2`
/// the internal reflectance for the diffuse light inside (about 0.4–0.6 for
/// paints; the hemispherical Fresnel value for `n = 1.5` is 0.596).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Saunderson {
    /// External (specular) surface reflectance, in `[0, 1)`.
    pub k1: f64,
    /// Internal diffuse surface reflectance, in `[0, 1)`.
    pub k2: f64,
    /// Whether readings include the specular reflection.
    pub specular: Specular,
}

impl Saunderson {
    /// Saunderson's constants given directly.
    ///
    /// # Errors
    /// `k1` or `k2` outside `[0, 1)`.
    ///
    /// # Reference
    /// Saunderson (1942), eq. 1.
    ///
    /// ```
    /// use km_inverse::kubelka::{Saunderson, Specular};
    /// assert!(Saunderson::new(0.04, 0.6, Specular::Included).is_ok());
    /// assert!(Saunderson::new(0.04, 1.0, Specular::Included).is_err());
    /// ```
    pub fn new(k1: f64, k2: f64, specular: Specular) -> Result<Saunderson, KubelkaError> {
        for (name, v) in [("k1", k1), ("k2", k2)] {
            if !v.is_finite() || !(0.0..1.0).contains(&v) {
                return Err(KubelkaError::invalid(name, v, "must lie in [0, 1)"));
            }
        }
        Ok(Saunderson { k1, k2, specular })
    }

    /// `k1` from the refractive index `n` of the binder by the Fresnel
    /// reflectance at normal incidence from air, `k1 = ((n - 1)/(n + 1))^2`
    /// (0.04 for `n = 1.5`), and `k2` as given.
    ///
    /// # Errors
    /// `n` not finite or below 1; `k2` outside `[0, 1)`.
    ///
    /// # Reference
    /// Saunderson (1942); Born & Wolf, §1.5 (Fresnel formulae at normal incidence).
    ///
    /// ```
    /// use km_inverse::kubelka::{Saunderson, Specular};
    /// let c = Saunderson::from_index(1.5, 0.6, Specular::Included).unwrap();
    /// assert!((c.k1 - 0.04).abs() < 1e-15);
    /// ```
    pub fn from_index(n: f64, k2: f64, specular: Specular) -> Result<Saunderson, KubelkaError> {
        if !km_core::layer::is_refractive_index(n) {
            return Err(KubelkaError::invalid("n", n, "refractive index must be finite and >= 1"));
        }
        let r = (n - 1.0) / (n + 1.0);
        Saunderson::new(r * r, k2, specular)
    }

    /// Both constants from the index, as `km_core`'s scene solver builds a
    /// top interface for collimated light at normal incidence from air:
    /// `k1 = ((n - 1)/(n + 1))^2`, `k2 = 2 int_0^1 R_F(mu; n -> 1) mu dmu`
    /// (the hemispherical Fresnel reflectance from inside, total internal
    /// reflection included; `docs/two-flux.md` eq. K11).
    ///
    /// # Errors
    /// `n` not finite or below 1.
    ///
    /// # Reference
    /// Saunderson (1942); `km_core::fresnel::diffuse_reflectance`.
    ///
    /// ```
    /// use km_inverse::kubelka::{Saunderson, Specular};
    /// let c = Saunderson::fresnel(1.5, Specular::Included).unwrap();
    /// assert!((c.k2 - 0.596).abs() < 2e-3);
    /// ```
    pub fn fresnel(n: f64, specular: Specular) -> Result<Saunderson, KubelkaError> {
        if !km_core::layer::is_refractive_index(n) {
            return Err(KubelkaError::invalid("n", n, "refractive index must be finite and >= 1"));
        }
        Saunderson::from_index(n, fresnel::diffuse_reflectance(n, 1.0), specular)
    }

    /// The measured reflectance of a film of internal reflectance `r` (eq. I8).
    ///
    /// # Errors
    /// `r` outside `[0, 1]`.
    ///
    /// # Reference
    /// Saunderson (1942), eq. 1.
    ///
    /// ```
    /// use km_inverse::kubelka::{Saunderson, Specular};
    /// let c = Saunderson::new(0.04, 0.6, Specular::Included).unwrap();
    /// // A black film shows only its surface; a white one reflects everything.
    /// assert_eq!(c.measured_from_internal(0.0).unwrap(), 0.04);
    /// assert!((c.measured_from_internal(1.0).unwrap() - 1.0).abs() < 1e-15);
    /// ```
    pub fn measured_from_internal(&self, r: f64) -> Result<f64, KubelkaError> {
        check_reflectance("internal reflectance", r)?;
        // Light through the surface twice, with the inter-reflections under it.
        let body = (1.0 - self.k1) * (1.0 - self.k2) * r / (1.0 - self.k2 * r);
        Ok(match self.specular {
            Specular::Included => self.k1 + body,
            Specular::Excluded => body,
        })
    }

    /// The internal reflectance of a film whose measured reflectance is
    /// `r_measured` (eq. I9), the inverse of [`Saunderson::measured_from_internal`].
    ///
    /// # Errors
    /// `r_measured` outside `[0, 1]`; below `k1` with the specular component
    /// included (less than the surface alone reflects); a result above 1
    /// (more than the surface lets out).
    ///
    /// # Reference
    /// Saunderson (1942), eq. 1 solved for `R`.
    ///
    /// ```
    /// use km_inverse::kubelka::{Saunderson, Specular};
    /// let c = Saunderson::new(0.04, 0.6, Specular::Included).unwrap();
    /// let r = c.internal_from_measured(c.measured_from_internal(0.3).unwrap()).unwrap();
    /// assert!((r - 0.3).abs() < 1e-15);
    /// assert!(c.internal_from_measured(0.01).is_err());
    /// ```
    pub fn internal_from_measured(&self, r_measured: f64) -> Result<f64, KubelkaError> {
        check_reflectance("measured reflectance", r_measured)?;
        let (k1, k2) = (self.k1, self.k2);
        // The body reflection y = R_m - k1 (or R_m), then R = y / ((1-k1)(1-k2) + k2 y).
        let y = match self.specular {
            Specular::Included => {
                if r_measured < k1 {
                    return Err(KubelkaError::infeasible(
                        "measured reflectance",
                        r_measured,
                        format!("below the surface reflection k1 = {k1} (specular included)"),
                    ));
                }
                r_measured - k1
            }
            Specular::Excluded => r_measured,
        };
        let r = y / ((1.0 - k1) * (1.0 - k2) + k2 * y);
        if r > 1.0 {
            return Err(KubelkaError::infeasible(
                "measured reflectance",
                r_measured,
                format!("more than a white film shows through this surface (internal R = {r})"),
            ));
        }
        Ok(r)
    }
}
