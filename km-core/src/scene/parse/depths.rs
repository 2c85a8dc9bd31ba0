//! `[output] depths`: the depths of depth-resolved output
//! (`docs/scene-file.md`), a list `[z, ...]` or a regular grid
//! `{ step = dz, max = z_max }` (`0, dz, 2 dz, ...` up to `z_max`).

use toml::{Spanned, Value};

use super::Parser;
use crate::error::CoreError;

/// Most depths one scene may ask for.
const MAX_DEPTHS: usize = 100_000;

const KEY: &str = "output.depths";

impl Parser {
    /// The depths of `[output] depths`, each finite and `>= 0`, multiplied
    /// by the file's length `scale` (as thicknesses are).
    pub(super) fn depths(&self, v: &Spanned<Value>, scale: f64) -> Result<Vec<f64>, CoreError> {
        let line = self.line(v.span());
        let err = |reason: String| CoreError::scene(KEY, line, reason);
        let depths = match v.get_ref() {
            Value::Array(items) => {
                if items.is_empty() {
                    return Err(err("an empty list asks for no depth".into()));
                }
                if items.len() > MAX_DEPTHS {
                    return Err(err(format!("{} depths: at most {MAX_DEPTHS}", items.len())));
                }
                items.iter().map(|x| self.number(KEY, line, x)).collect::<Result<Vec<_>, _>>()?
            }
            Value::Table(t) => self.depth_grid(t, line)?,
            other => {
                return Err(err(format!(
                    "expected a list of depths or {{ step = ..., max = ... }}, found {}",
                    other.type_str()
                )));
            }
        };
        if let Some(z) = depths.iter().find(|z| !(z.is_finite() && **z >= 0.0)) {
            return Err(err(format!("depth {z} must be finite and >= 0")));
        }
        Ok(depths.into_iter().map(|z| z * scale).collect())
    }

    /// `{ step, max }`: `i step` for `i = 0, 1, ...` while `<= max` (with a
    /// relative slack of 1e-9, so `max` itself is kept when it is a multiple).
    fn depth_grid(
        &self,
        t: &toml::map::Map<String, Value>,
        line: Option<usize>,
    ) -> Result<Vec<f64>, CoreError> {
        let err = |reason: String| CoreError::scene(KEY, line, reason);
        if let Some(k) = t.keys().find(|k| !matches!(k.as_str(), "step" | "max")) {
            return Err(err(format!("unknown key \"{k}\" (known: \"step\", \"max\")")));
        }
        let get = |k: &str| match t.get(k) {
            Some(v) => self.number(&format!("{KEY}.{k}"), line, v),
            None => Err(err(format!("a grid of depths needs \"{k}\""))),
        };
        let (step, max) = (get("step")?, get("max")?);
        if !(step.is_finite() && step > 0.0) {
            return Err(err(format!("step = {step} must be finite and > 0")));
        }
        if !(max.is_finite() && max >= 0.0) {
            return Err(err(format!("max = {max} must be finite and >= 0")));
        }
        let count = (max / step * (1.0 + 1e-9)).floor() + 1.0;
        if count > MAX_DEPTHS as f64 {
            return Err(err(format!(
                "max / step = {} depths: at most {MAX_DEPTHS}",
                (max / step).floor() + 1.0
            )));
        }
        Ok((0..count as usize).map(|i| (i as f64 * step).min(max)).collect())
    }
}
