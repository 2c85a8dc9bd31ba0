//! Pigments: single-pigment constants from masstone and tint, and the
//! reflectance of mixtures (Duncan 1940; `docs/inverse-km.md` eq. I10–I11).

use super::{KubelkaError, check_reflectance, k_over_s, reflectance_over_ground};
use km_core::two_flux::{self, KmCoefficients};

/// A pigment's own `K` and `S` from its masstone and one tint with a white
/// (Duncan's two-constant theory, in Allen's single-pigment formulation).
///
/// The masstone (the pigment alone, opaque) gives `q_m = K_p/S_p` (eq. I1);
/// the tint (concentrations `c_p` of the pigment, `c_w` of a white of known
/// `K_w`, `S_w`, opaque) gives `q_t`; Duncan's rule
/// `q_t = (c_p K_p + c_w K_w) / (c_p S_p + c_w S_w)` then fixes the scale:
///
/// ```text
/// S_p = c_w (K_w - q_t S_w) / (c_p (q_t - q_m)),   K_p = q_m S_p           (I10)
/// ```
///
/// `K_p`, `S_p` are per unit concentration, in the units of `K_w`, `S_w`
/// (often `S_w = 1`: a relative scale).
///
/// * `r_inf_masstone`, `r_inf_tint`: internal reflectances of the opaque
///   masstone and tint, in `(0, 1]` (apply [`Saunderson`](super::Saunderson) to readings first);
/// * `c_pigment`, `c_white`: concentrations in the tint, `> 0`;
/// * `white`: `K_w >= 0`, `S_w > 0`.
///
/// # Errors
/// Values outside their domain; a tint whose `K/S` is not strictly between
/// that of the white and that of the masstone (no positive `S_p` fits).
///
/// # Reference
/// Duncan (1940) (two-constant mixing); E. Allen, "Colorant formulation and
/// shading", in *Optical Radiation Measurements* vol. 2 (1980), the
/// masstone–tint determination of single-pigment constants.
///
/// ```
/// use km_core::two_flux::KmCoefficients;
/// use km_inverse::kubelka::{masstone_tint, r_inf_from_k_over_s};
/// let white = KmCoefficients { k: 0.005, s: 1.0 };
/// // A blue with K = 2, S = 0.1, tinted 1 : 9 with the white.
/// let q_t = (0.1 * 2.0 + 0.9 * 0.005) / (0.1 * 0.1 + 0.9 * 1.0);
/// let p = masstone_tint(r_inf_from_k_over_s(20.0).unwrap(),
///     r_inf_from_k_over_s(q_t).unwrap(), 0.1, 0.9, white).unwrap();
/// assert!((p.k - 2.0).abs() < 1e-12 && (p.s - 0.1).abs() < 1e-13);
/// ```
pub fn masstone_tint(
    r_inf_masstone: f64,
    r_inf_tint: f64,
    c_pigment: f64,
    c_white: f64,
    white: KmCoefficients,
) -> Result<KmCoefficients, KubelkaError> {
    for (name, c) in [("c_pigment", c_pigment), ("c_white", c_white)] {
        if !c.is_finite() || c <= 0.0 {
            return Err(KubelkaError::invalid(name, c, "concentration must be finite and > 0"));
        }
    }
    if !white.k.is_finite() || white.k < 0.0 {
        return Err(KubelkaError::invalid("K_white", white.k, "must be finite and >= 0"));
    }
    if !white.s.is_finite() || white.s <= 0.0 {
        return Err(KubelkaError::invalid("S_white", white.s, "must be finite and > 0"));
    }
    let q_m = k_over_s(r_inf_masstone).map_err(|_| {
        KubelkaError::invalid("r_inf_masstone", r_inf_masstone, "must lie in (0, 1]")
    })?;
    let q_t = k_over_s(r_inf_tint)
        .map_err(|_| KubelkaError::invalid("r_inf_tint", r_inf_tint, "must lie in (0, 1]"))?;
    let q_w = white.k / white.s;
    // A positive S_p needs q_t strictly between q_w and q_m (eq. I10).
    let between = (q_w < q_t && q_t < q_m) || (q_m < q_t && q_t < q_w);
    if !between {
        return Err(KubelkaError::infeasible(
            "r_inf_tint",
            r_inf_tint,
            format!(
                "the tint's K/S = {q_t} must lie strictly between the white's ({q_w}) and the \
                 masstone's ({q_m})"
            ),
        ));
    }
    let s_p = c_white * (white.k - q_t * white.s) / (c_pigment * (q_t - q_m));
    Ok(KmCoefficients { k: q_m * s_p, s: s_p })
}

/// The internal reflectance of a mixture of pigments (Duncan's rule,
/// `km_core::two_flux::mix_pigments`, eq. K15) as a film of thickness `X`
/// over a ground, or opaque (`thickness = inf`):
///
/// ```text
/// K = sum c_i K_i / sum c_i,  S = sum c_i S_i / sum c_i,
/// R = R_inf(K/S) (opaque, eq. I2)  or  Kubelka (1948) eq. 11 over R_g      (I11)
/// ```
///
/// Apply [`Saunderson::measured_from_internal`](super::Saunderson::measured_from_internal) for what an instrument reads.
///
/// # Errors
/// Those of `mix_pigments` and [`reflectance_over_ground`].
///
/// # Reference
/// Duncan (1940); Kubelka (1948) eq. 6 and 11.
///
/// ```
/// use km_core::two_flux::KmCoefficients;
/// use km_inverse::kubelka::{mixture_reflectance, r_inf_from_k_over_s};
/// let white = KmCoefficients { k: 0.01, s: 1.0 };
/// let black = KmCoefficients { k: 1.0, s: 0.0 };
/// let r = mixture_reflectance(&[0.5, 0.5], &[white, black], f64::INFINITY, 0.0).unwrap();
/// assert!((r - r_inf_from_k_over_s(1.01).unwrap()).abs() < 1e-15);
/// ```
pub fn mixture_reflectance(
    concentrations: &[f64],
    pigments: &[KmCoefficients],
    thickness: f64,
    r_ground: f64,
) -> Result<f64, KubelkaError> {
    let mix = two_flux::mix_pigments(concentrations, pigments)?;
    if thickness.is_infinite() && thickness > 0.0 {
        check_reflectance("r_ground", r_ground)?;
        return Ok(two_flux::r_infinity(mix.k, mix.s)?);
    }
    reflectance_over_ground(mix.k, mix.s, thickness, r_ground)
}
