//! Tissue keys and the file's length unit (docs/scene-file.md, "Tissue
//! keys and units"): a layer written as `mu_a` with `mu_s` or `mu_s_prime`
//! (and `g`), and `units = "mm" | "cm"`, converted once here.
//!
//! With `units`, every length of the file (thicknesses) and every
//! coefficient (`sigma_*`, `mu_*`, per length) is in that unit, and the
//! reader converts them to millimetres, the unit of the presets: lengths
//! times `s`, coefficients divided by `s`, `s = 10` for `"cm"`, `1` for
//! `"mm"` (eq. U1). Without `units` nothing is converted (the file's
//! numbers share one unspecified unit, as before).

use toml::Spanned;

use super::layer::{Form, LayerCoefs};
use super::{Coef, Parser, RawLayer, scaled};
use crate::error::CoreError;

/// Millimetres per unit of `units` (eq. U1); `1` when absent.
pub(super) fn length_scale(p: &Parser, units: Option<&Spanned<String>>) -> Result<f64, CoreError> {
    let Some(u) = units else {
        return Ok(1.0);
    };
    match u.get_ref().as_str() {
        "mm" => Ok(1.0),
        "cm" => Ok(10.0),
        other => Err(CoreError::scene(
            "units",
            p.line(u.span()),
            format!("unknown length unit \"{other}\" (known: \"mm\", \"cm\")"),
        )),
    }
}

impl Parser {
    /// The tissue form of layer `i` when it has a `mu_*` key: `sigma_a =
    /// mu_a`, `sigma_s = mu_s` or `mu_s_prime / (1 - g)` (channel by
    /// channel), the coefficients converted by `scale` (eq. U1; `thickness`
    /// comes converted). `other_form` names a key of another form found on
    /// the layer (refused together with `mu_*`).
    #[allow(clippy::too_many_arguments)]
    pub(super) fn tissue_layer(
        &self,
        i: usize,
        is_last: bool,
        l: &RawLayer,
        other_form: Option<&str>,
        thickness: Option<Coef>,
        g: Option<Coef>,
        n: Coef,
        scale: f64,
    ) -> Result<Option<LayerCoefs>, CoreError> {
        let k = |name: &str| format!("layer[{}].{name}", i + 1);
        let mu_a = self.opt_coef(&k("mu_a"), &l.mu_a)?;
        let mu_s = self.opt_coef(&k("mu_s"), &l.mu_s)?;
        let mu_sp = self.opt_coef(&k("mu_s_prime"), &l.mu_s_prime)?;
        let Some(first) = [&mu_a, &mu_s, &mu_sp].into_iter().flatten().next() else {
            return Ok(None);
        };
        let first = (first.key.clone(), first.line);
        if let Some(other) = other_form {
            return Err(CoreError::scene(
                first.0,
                first.1,
                format!(
                    "the tissue keys (mu_a, mu_s or mu_s_prime) are a form of their own: \
                     remove {other} or the mu_* keys"
                ),
            ));
        }
        if let (Some(_), Some(p)) = (&mu_s, &mu_sp) {
            return Err(CoreError::scene(
                p.key.clone(),
                p.line,
                "give mu_s or mu_s_prime, not both",
            ));
        }
        let need = |name: &str, why: &str| CoreError::scene(k(name), first.1, why.to_string());
        let mu_a = mu_a.ok_or_else(|| need("mu_a", "missing: the tissue form needs mu_a"))?;
        let thickness = thickness.ok_or_else(|| {
            need("thickness", "missing: the tissue form needs a thickness (or \"inf\")")
        })?;
        let (sigma_s, g) = match (mu_s, mu_sp) {
            (Some(s), _) => (s, g.unwrap_or(Coef::constant(&k("g"), 0.0))),
            (None, Some(sp)) => {
                let g = g.ok_or_else(|| {
                    CoreError::scene(
                        k("g"),
                        sp.line,
                        "mu_s_prime needs g (mu_s = mu_s_prime / (1 - g)); give g = 0 for \
                         isotropic scattering",
                    )
                })?;
                (self.unreduce(sp, &g)?, g)
            }
            (None, None) => {
                return Err(need("mu_s", "missing: the tissue form needs mu_s or mu_s_prime"));
            }
        };
        let inv = 1.0 / scale;
        let coefs = self.finish_layer(
            i,
            is_last,
            Form::Sigma,
            scaled(mu_a, inv),
            scaled(sigma_s, inv),
            thickness,
            g,
            n,
        )?;
        Ok(Some(coefs))
    }

    /// `mu_s = mu_s_prime / (1 - g)` per channel (one value broadcast).
    fn unreduce(&self, sp: Coef, g: &Coef) -> Result<Coef, CoreError> {
        let len = sp.values.len().max(g.values.len());
        if sp.values.len() != len && sp.values.len() != 1
            || g.values.len() != len && g.values.len() != 1
        {
            return Err(CoreError::scene(
                g.key.clone(),
                g.line,
                format!(
                    "{} values of g for {} values of mu_s_prime: give one or as many",
                    g.values.len(),
                    sp.values.len()
                ),
            ));
        }
        let mut values = Vec::with_capacity(len);
        for c in 0..len {
            let gc = g.at(c);
            if gc.is_nan() || gc.abs() >= 1.0 {
                return Err(CoreError::scene(
                    g.key.clone(),
                    g.line,
                    format!("{gc}: |g| must be < 1"),
                ));
            }
            values.push(sp.at(c) / (1.0 - gc));
        }
        Ok(Coef { key: sp.key, line: sp.line, values })
    }
}
