//! From the scene's coefficients to the two-flux K and S, and Duncan's
//! pigment mixing.

use std::str::FromStr;

use crate::error::CoreError;
use crate::layer::Layer;

use super::check_ks;

/// How the scene's `(sigma_a, sigma_s, g)` become the two-flux `(K, S)`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum KmMapping {
    /// `K = sigma_a`, `S = sigma_s`, as in the seed (seed eq. 1–2); `g` is
    /// ignored. The paper's figures use it.
    #[cfg_attr(
        feature = "clap",
        value(name = "seed", help = "K = sigma_a, S = sigma_s, as in the seed paper")
    )]
    Seed,
    /// Star, Marijnissen & van Gemert (1988), from diffusion theory:
    /// `K = 2 sigma_a`, `S = (3/4) sigma_s (1 - g) - (1/4) sigma_a` (eq. K13).
    /// Needs `3 sigma_s (1 - g) >= sigma_a` (`S >= 0`).
    #[cfg_attr(
        feature = "clap",
        value(
            name = "star1988",
            help = "Star, Marijnissen & van Gemert 1988: K = 2 sigma_a, S = 3/4 sigma_s (1 - g) - 1/4 sigma_a"
        )
    )]
    StarEtAl1988,
    /// Gate (1974), confirmed by Thennadil (2008) for diffuse light:
    /// `K = 2 sigma_a`, `S = (3/4) sigma_s (1 - g)` (eq. K14). The default:
    /// the least error against converged multi-flux on the grid of
    /// docs/two-flux.md §13 among the mappings that treat every scene.
    #[default]
    #[cfg_attr(
        feature = "clap",
        value(name = "gate1974", help = "Gate 1974: K = 2 sigma_a, S = 3/4 sigma_s (1 - g)")
    )]
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
        let (sa, ss, g) = (layer.sigma_a(), layer.sigma_s(), layer.g());
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
