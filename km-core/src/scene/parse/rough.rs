//! The parser's rough faces and conductor substrates (docs/rough.md,
//! docs/scene-file.md): `roughness`, `distribution` on a layer and on the
//! substrate; `kind = "conductor"` with `n`, `k` or `metal`.

use toml::{Spanned, Value};

use super::layer::RawSub;
use super::{Coef, Parser, RawSubstrate};
use crate::error::CoreError;
use crate::metals;
use crate::microfacet::{Distribution, MAX_ALPHA, Microfacet};
use crate::scene::Substrate;

/// A face's roughness per channel and its distribution.
pub(super) struct Face {
    pub(super) alpha: Coef,
    dist: Distribution,
}

impl Face {
    /// The face of channel `ch`: `None` where `alpha = 0` (smooth).
    pub(super) fn at(&self, ch: usize) -> Option<Microfacet> {
        let a = self.alpha.at(ch);
        // The values were checked in `face`: (0, 1] or 0.
        if a > 0.0 { Microfacet::new(a, self.dist).ok() } else { None }
    }
}

impl Parser {
    /// `roughness` (GGX/Beckmann alpha, `0 <= alpha <= 1`, 0 = smooth; a
    /// number or a list per channel) and `distribution` (`"ggx"`, the default,
    /// or `"beckmann"`) of the face at `prefix` (`layer[i]` or `substrate`).
    pub(super) fn face(
        &self,
        prefix: &str,
        roughness: &Option<Spanned<Value>>,
        distribution: &Option<Spanned<String>>,
    ) -> Result<Option<Face>, CoreError> {
        let dist = match distribution {
            None => Distribution::Ggx,
            Some(d) => Distribution::from_name(d.get_ref()).ok_or_else(|| {
                CoreError::scene(
                    format!("{prefix}.distribution"),
                    self.line(d.span()),
                    format!(
                        "unknown distribution \"{}\" (expected \"ggx\" or \"beckmann\")",
                        d.get_ref()
                    ),
                )
            })?,
        };
        let Some(r) = roughness else {
            if let Some(d) = distribution {
                return Err(CoreError::scene(
                    format!("{prefix}.distribution"),
                    self.line(d.span()),
                    "a distribution needs a roughness",
                ));
            }
            return Ok(None);
        };
        let alpha = self.coef(&format!("{prefix}.roughness"), r)?;
        for &x in &alpha.values {
            if !(0.0..=MAX_ALPHA).contains(&x) {
                return Err(CoreError::scene(
                    alpha.key.clone(),
                    alpha.line,
                    format!("{x}: roughness must lie in [0, {MAX_ALPHA}] (0 = smooth)"),
                ));
            }
        }
        Ok(Some(Face { alpha, dist }))
    }

    /// The substrate's face: rough only for a transparent or conductor substrate.
    pub(super) fn substrate_face(
        &self,
        raw: Option<&RawSubstrate>,
        sub: &RawSub,
    ) -> Result<Option<Face>, CoreError> {
        let Some(s) = raw else { return Ok(None) };
        let face = self.face("substrate", &s.roughness, &s.distribution)?;
        if let (Some(f), RawSub::Lambertian(_) | RawSub::Black) = (&face, sub) {
            return Err(CoreError::scene(
                f.alpha.key.clone(),
                f.alpha.line,
                "a lambertian or black substrate has no face of its own to roughen \
                 (roughen the last layer's top face, or use kind = \"conductor\")",
            ));
        }
        Ok(face)
    }

    /// `[substrate] kind = "conductor"`: `n` and `k` (numbers or lists per
    /// channel), or `metal = "Al" | "Ag" | "Au" | "Cu" | "Cr"`.
    pub(super) fn conductor(
        &self,
        s: &RawSubstrate,
        line: Option<usize>,
    ) -> Result<RawSub, CoreError> {
        if let Some(a) = &s.albedo {
            return Err(CoreError::scene(
                "substrate.albedo",
                self.line(a.span()),
                "a conductor substrate takes no albedo (its reflectance follows from n, k)",
            ));
        }
        match (&s.metal, &s.n, &s.k) {
            (Some(m), None, None) => {
                let l = self.line(m.span());
                if !metals::METALS.contains(&m.get_ref().as_str()) {
                    return Err(CoreError::scene(
                        "substrate.metal",
                        l,
                        format!(
                            "unknown metal \"{}\" (known: {})",
                            m.get_ref(),
                            metals::METALS.join(", ")
                        ),
                    ));
                }
                Ok(RawSub::Metal(m.get_ref().clone(), l))
            }
            (Some(m), _, _) => Err(CoreError::scene(
                "substrate.metal",
                self.line(m.span()),
                "give either metal or n and k, not both",
            )),
            (None, Some(n), Some(k)) => {
                Ok(RawSub::Conductor(self.coef("substrate.n", n)?, self.coef("substrate.k", k)?))
            }
            (None, n, k) => {
                let missing = if n.is_none() { "substrate.n" } else { "substrate.k" };
                let l = n.as_ref().or(k.as_ref()).map_or(line, |v| self.line(v.span()));
                Err(CoreError::scene(
                    missing,
                    l,
                    "a conductor substrate needs n and k (complex index n + i k), or a metal",
                ))
            }
        }
    }
}

/// Channel-wise checks of a conductor's `n > 0` and `k >= 0`.
pub(super) fn check_conductor(n: &Coef, k: &Coef) -> Result<(), CoreError> {
    for &x in &n.values {
        if !(x.is_finite() && x > 0.0) {
            return Err(CoreError::scene(
                n.key.clone(),
                n.line,
                format!("{x}: must be finite and > 0"),
            ));
        }
    }
    for &x in &k.values {
        if !(x.is_finite() && x >= 0.0) {
            return Err(CoreError::scene(
                k.key.clone(),
                k.line,
                format!("{x}: must be finite and >= 0"),
            ));
        }
    }
    Ok(())
}

/// The conductor of a named metal in channel `ch`, at the scene's wavelength.
pub(super) fn metal(
    name: &str,
    line: Option<usize>,
    wavelengths_nm: Option<&[f64]>,
    ch: usize,
) -> Result<Substrate, CoreError> {
    let Some(w) = wavelengths_nm else {
        return Err(CoreError::scene(
            "substrate.metal",
            line,
            "a named metal needs the channels' wavelengths: add [spectrum] wavelengths_nm \
             (or give n and k per channel)",
        ));
    };
    let wl = if w.len() == 1 { w[0] } else { w[ch] };
    let (n, k) = metals::nk(name, wl).map_err(|_| {
        let (lo, hi) = metals::range_nm(name).unwrap_or((0.0, 0.0));
        CoreError::scene(
            "spectrum.wavelengths_nm",
            None,
            format!("{wl} nm is outside the {name} table ({lo:.0}-{hi:.0} nm, docs/rough.md §5)"),
        )
    })?;
    Ok(Substrate::Conductor { n, k })
}
