//! The scene file's raw (TOML) form and its parser into a [`Scene`]: every
//! value is kept with its span so that errors name their lines.

use std::ops::Range;

use serde::Deserialize;
use toml::{Spanned, Value};

use super::read::LineIndex;
use super::{
    Light, MonoScene, Scene, SceneLimits, Substrate, check_incidence, check_theta, is_wavelength,
};
use crate::error::CoreError;
use crate::layer::is_refractive_index;

mod depths;
mod layer;
mod phase;
mod rough;
mod tissue;

use layer::RawSub;

// ---------------------------------------------------------------------------
// Raw (file) form. Every value is kept with its span so errors can name lines.

/// Multiply every value of `c` by `f` (a no-op for `f = 1`).
fn scaled(mut c: Coef, f: f64) -> Coef {
    if f != 1.0 {
        for x in &mut c.values {
            *x *= f;
        }
    }
    c
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawScene {
    light: Option<RawLight>,
    ambient: Option<RawAmbient>,
    layer: Option<Vec<RawLayer>>,
    substrate: Option<RawSubstrate>,
    output: Option<RawOutput>,
    spectrum: Option<RawSpectrum>,
    /// The file's length unit, `"mm"` or `"cm"` (parse/tissue.rs).
    units: Option<Spanned<String>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawLight {
    kind: Option<Spanned<String>>,
    theta_deg: Option<Spanned<Value>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawAmbient {
    n: Option<Spanned<Value>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawLayer {
    sigma_a: Option<Spanned<Value>>,
    sigma_s: Option<Spanned<Value>>,
    thickness: Option<Spanned<Value>>,
    tau: Option<Spanned<Value>>,
    albedo: Option<Spanned<Value>>,
    g: Option<Spanned<Value>>,
    n: Option<Spanned<Value>>,
    preset: Option<Spanned<String>>,
    phase: Option<Spanned<Value>>,
    particles: Option<Spanned<Value>>,
    roughness: Option<Spanned<Value>>,
    distribution: Option<Spanned<String>>,
    mu_a: Option<Spanned<Value>>,
    mu_s: Option<Spanned<Value>>,
    mu_s_prime: Option<Spanned<Value>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawSubstrate {
    kind: Option<Spanned<String>>,
    n: Option<Spanned<Value>>,
    albedo: Option<Spanned<Value>>,
    k: Option<Spanned<Value>>,
    metal: Option<Spanned<String>>,
    roughness: Option<Spanned<Value>>,
    distribution: Option<Spanned<String>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawOutput {
    directions_deg: Option<Spanned<Value>>,
    depths: Option<Spanned<Value>>,
    inside_directions_deg: Option<Spanned<Value>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawSpectrum {
    labels: Option<Spanned<Vec<String>>>,
    wavelengths_nm: Option<Spanned<Value>>,
}

/// A coefficient per channel: one value (broadcast) or a list.
#[derive(Clone)]
struct Coef {
    key: String,
    line: Option<usize>,
    values: Vec<f64>,
}

impl Coef {
    fn constant(key: &str, v: f64) -> Coef {
        Coef { key: key.into(), line: None, values: vec![v] }
    }
    fn at(&self, c: usize) -> f64 {
        if self.values.len() == 1 { self.values[0] } else { self.values[c] }
    }
}

pub(super) struct Parser {
    pub(super) lines: LineIndex,
    pub(super) limits: SceneLimits,
}

impl Parser {
    fn line(&self, span: Range<usize>) -> Option<usize> {
        Some(self.lines.line(span.start))
    }

    /// One number: integer, float, or the strings "inf" / "infinity".
    fn number(&self, key: &str, line: Option<usize>, v: &Value) -> Result<f64, CoreError> {
        let x = match v {
            Value::Integer(i) => *i as f64,
            Value::Float(f) => *f,
            Value::String(s) if matches!(s.trim(), "inf" | "infinity" | "Inf" | "Infinity") => {
                f64::INFINITY
            }
            other => {
                return Err(CoreError::scene(
                    key,
                    line,
                    format!("expected a number, found {}", other.type_str()),
                ));
            }
        };
        if x.is_nan() {
            return Err(CoreError::scene(key, line, "NaN is not a value"));
        }
        Ok(x)
    }

    /// A scalar or a list of numbers.
    fn coef(&self, key: &str, v: &Spanned<Value>) -> Result<Coef, CoreError> {
        let line = self.line(v.span());
        let values = match v.get_ref() {
            Value::Array(items) => {
                if items.is_empty() {
                    return Err(CoreError::scene(key, line, "an empty list has no value"));
                }
                items.iter().map(|x| self.number(key, line, x)).collect::<Result<Vec<_>, _>>()?
            }
            other => vec![self.number(key, line, other)?],
        };
        Ok(Coef { key: key.into(), line, values })
    }

    fn opt_coef(&self, key: &str, v: &Option<Spanned<Value>>) -> Result<Option<Coef>, CoreError> {
        v.as_ref().map(|v| self.coef(key, v)).transpose()
    }

    pub(super) fn scene(&self, raw: RawScene) -> Result<Scene, CoreError> {
        let mut coefs: Vec<Count> = Vec::new();
        let mut note = |c: &Coef| coefs.push((c.key.clone(), c.line, c.values.len()));
        let light = self.light(raw.light.as_ref())?;
        let ambient_n = self.ambient(raw.ambient.as_ref())?;
        note(&ambient_n);

        // [[layer]]
        let raw_layers = raw.layer.unwrap_or_default();
        if raw_layers.is_empty() {
            return Err(CoreError::scene(
                "layer",
                None,
                "the stack is empty: add at least one [[layer]]",
            ));
        }
        let n_layers = raw_layers.len();
        let scale = tissue::length_scale(self, raw.units.as_ref())?;
        let (layers, faces) =
            self.layers(&raw_layers, raw.units.as_ref(), &ambient_n, scale, &mut note)?;

        // [substrate]
        let substrate = self.substrate(raw.substrate.as_ref(), &ambient_n)?;
        match &substrate {
            RawSub::Transparent(c) | RawSub::Lambertian(c) => note(c),
            RawSub::Conductor(n, k) => {
                note(n);
                note(k);
            }
            RawSub::Black | RawSub::Metal(..) => {}
        }
        let sub_face = self.substrate_face(raw.substrate.as_ref(), &substrate)?;
        if let Some(f) = &sub_face {
            note(&f.alpha);
        }

        // [output]
        let directions_deg = match raw.output.as_ref().and_then(|o| o.directions_deg.as_ref()) {
            None => Vec::new(),
            Some(v) => self.directions(v)?,
        };
        let depths = match raw.output.as_ref().and_then(|o| o.depths.as_ref()) {
            None => Vec::new(),
            Some(v) => self.depths(v, scale)?,
        };
        let inside = match raw.output.as_ref().and_then(|o| o.inside_directions_deg.as_ref()) {
            None => Vec::new(),
            Some(v) => self.inside_directions(v)?,
        };

        // [spectrum]
        let (labels, wavelengths_nm) = match &raw.spectrum {
            Some(s) => self.spectrum(s, &mut coefs)?,
            None => (None, None),
        };

        let (channels, first) = channel_count(&mut coefs)?;
        self.check_cells(channels, n_layers, directions_deg.len(), first)?;
        check_substrate_values(&substrate)?;
        let mut out = Vec::with_capacity(channels);
        for ch in 0..channels {
            let mut ls = Vec::with_capacity(n_layers);
            for (lay, face) in layers.iter().zip(&faces) {
                let wl = wavelengths_nm.as_ref().map(|w: &Vec<f64>| w[ch]);
                ls.push(lay.build(ch, wl)?.with_roughness(face.as_ref().and_then(|f| f.at(ch))));
            }
            let sub = match &substrate {
                RawSub::Transparent(c) => Substrate::Transparent { n: c.at(ch) },
                RawSub::Lambertian(c) => Substrate::Lambertian { albedo: c.at(ch) },
                RawSub::Black => Substrate::Black,
                RawSub::Conductor(n, k) => Substrate::Conductor { n: n.at(ch), k: k.at(ch) },
                RawSub::Metal(name, line) => {
                    rough::metal(name, *line, wavelengths_nm.as_deref(), ch)?
                }
            };
            // Every value was checked above with its key and line; the
            // constructor's checks cannot fail here.
            let mono = MonoScene::new(light, ambient_n.at(ch), ls, sub, directions_deg.clone())?;
            out.push(mono.with_substrate_roughness(sub_face.as_ref().and_then(|f| f.at(ch)))?);
        }
        let labels = match labels {
            Some(l) => l,
            None if channels == 3 => vec!["R".into(), "G".into(), "B".into()],
            None => (0..channels).map(|c| c.to_string()).collect(),
        };
        Ok(Scene::new(out, labels, wavelengths_nm)?
            .with_depths(depths)
            .with_inside_directions(inside))
    }

    /// `[[layer]]`: each layer's coefficients and top face, every coefficient
    /// passed to `note` in order.
    fn layers(
        &self,
        raw_layers: &[RawLayer],
        units: Option<&Spanned<String>>,
        ambient_n: &Coef,
        scale: f64,
        note: &mut impl FnMut(&Coef),
    ) -> Result<(Vec<layer::LayerCoefs>, Vec<Option<rough::Face>>), CoreError> {
        let n_layers = raw_layers.len();
        let mut layers = Vec::with_capacity(n_layers);
        let mut faces = Vec::with_capacity(n_layers);
        for (i, l) in raw_layers.iter().enumerate() {
            if let (Some(u), Some(_)) = (units, &l.particles) {
                return Err(CoreError::scene(
                    format!("layer[{}].particles", i + 1),
                    self.line(u.span()),
                    "a layer with particles takes its lengths in micrometres: remove units",
                ));
            }
            let lay = self.layer(i, n_layers, l, ambient_n, scale)?;
            for c in lay.coefs() {
                note(c);
            }
            layers.push(lay);
            let face = self.face(&format!("layer[{}]", i + 1), &l.roughness, &l.distribution)?;
            if let Some(f) = &face {
                note(&f.alpha);
            }
            faces.push(face);
        }
        Ok((layers, faces))
    }

    /// `[light]`: collimated (the default, at `theta_deg`, default 0) or diffuse.
    fn light(&self, raw: Option<&RawLight>) -> Result<Light, CoreError> {
        Ok(match raw {
            None => Light::Collimated { theta_deg: 0.0 },
            Some(l) => {
                let kind = l.kind.as_ref().map(|k| (k.get_ref().as_str(), self.line(k.span())));
                match kind {
                    None | Some(("collimated", _)) => {
                        let theta = match &l.theta_deg {
                            None => 0.0,
                            Some(t) => {
                                let line = self.line(t.span());
                                let x = self.number("light.theta_deg", line, t.get_ref())?;
                                check_incidence(x, line)?;
                                x
                            }
                        };
                        Light::Collimated { theta_deg: theta }
                    }
                    Some(("diffuse", _)) => {
                        if let Some(t) = &l.theta_deg {
                            return Err(CoreError::scene(
                                "light.theta_deg",
                                self.line(t.span()),
                                "diffuse light has no angle; remove theta_deg",
                            ));
                        }
                        Light::Diffuse
                    }
                    Some((other, line)) => {
                        return Err(CoreError::scene(
                            "light.kind",
                            line,
                            format!(
                                "unknown kind \"{other}\" (expected \"collimated\" or \"diffuse\")"
                            ),
                        ));
                    }
                }
            }
        })
    }

    /// `[ambient]`: the index above the stack (default 1), finite and >= 1.
    fn ambient(&self, raw: Option<&RawAmbient>) -> Result<Coef, CoreError> {
        let ambient_n = match raw.and_then(|a| a.n.as_ref()) {
            None => Coef::constant("ambient.n", 1.0),
            Some(v) => self.coef("ambient.n", v)?,
        };
        for &x in &ambient_n.values {
            if !is_refractive_index(x) {
                return Err(CoreError::scene(
                    ambient_n.key.clone(),
                    ambient_n.line,
                    format!("{x}: refractive index must be finite and >= 1"),
                ));
            }
        }
        Ok(ambient_n)
    }

    /// `[spectrum]`: the channels' labels (from `labels`, else from
    /// `wavelengths_nm`) and wavelengths; their lengths are noted in `coefs`.
    fn spectrum(&self, s: &RawSpectrum, coefs: &mut Vec<Count>) -> Result<Spectrum, CoreError> {
        let mut labels: Option<Vec<String>> = None;
        let mut wavelengths_nm = None;
        if let Some(w) = &s.wavelengths_nm {
            let c = self.coef("spectrum.wavelengths_nm", w)?;
            for &x in &c.values {
                if !is_wavelength(x) {
                    return Err(CoreError::scene(c.key.clone(), c.line, "wavelengths must be > 0"));
                }
            }
            labels = Some(c.values.iter().map(|x| format!("{x} nm")).collect());
            coefs.push((c.key.clone(), c.line, c.values.len()));
            wavelengths_nm = Some(c.values.clone());
        }
        if let Some(l) = &s.labels {
            let line = self.line(l.span());
            let v = l.get_ref().clone();
            if v.is_empty() {
                return Err(CoreError::scene(
                    "spectrum.labels",
                    line,
                    "an empty list has no value",
                ));
            }
            coefs.push(("spectrum.labels".into(), line, v.len()));
            labels = Some(v);
        }
        Ok((labels, wavelengths_nm))
    }

    /// The expanded scene's size, refused before it is allocated.
    fn check_cells(
        &self,
        channels: usize,
        n_layers: usize,
        n_directions: usize,
        first: Option<&Count>,
    ) -> Result<(), CoreError> {
        let cells = channels as u64 * (n_layers as u64 + n_directions as u64);
        if cells > self.limits.max_cells {
            let (key, line) = first.map(|f| (f.0.clone(), f.1)).unwrap_or(("layer".into(), None));
            return Err(CoreError::scene(
                key,
                line,
                format!(
                    "{channels} channel(s) x ({n_layers} layer(s) + {} direction(s)) = {cells} \
                     cells, about {} MB in memory, over the budget of {} cells; use fewer \
                     channels or directions, split the spectrum over several files, or set \
                     KM_MAX_SCENE_CELLS (docs/limits.md)",
                    n_directions,
                    cells * 64 / 1_000_000,
                    self.limits.max_cells
                ),
            ));
        }
        Ok(())
    }
}

/// A list's key, line and length.
type Count = (String, Option<usize>, usize);

/// The channels' labels and wavelengths of `[spectrum]`.
type Spectrum = (Option<Vec<String>>, Option<Vec<f64>>);

/// The number of channels: all lists must have one length. The
/// `[spectrum]` table, when present, sets it (a stable sort keeps the file
/// order); returns it with the list that set it.
fn channel_count(coefs: &mut [Count]) -> Result<(usize, Option<&Count>), CoreError> {
    coefs.sort_by_key(|c| !c.0.starts_with("spectrum"));
    let mut channels = 1;
    let mut first: Option<&(String, Option<usize>, usize)> = None;
    for c in coefs.iter().filter(|c| c.2 > 1 || c.0.starts_with("spectrum")) {
        match first {
            None => {
                channels = c.2;
                first = Some(c);
            }
            Some(f) if f.2 != c.2 => {
                let at = f.1.map(|l| format!(" (line {l})")).unwrap_or_default();
                return Err(CoreError::scene(
                    c.0.clone(),
                    c.1,
                    format!("list of {} values, but `{}`{at} has {}", c.2, f.0, f.2),
                ));
            }
            Some(_) => {}
        }
    }

    Ok((channels, first))
}

/// Channel-wise checks on the substrate's values.
fn check_substrate_values(substrate: &RawSub) -> Result<(), CoreError> {
    match substrate {
        RawSub::Transparent(c) => {
            for &x in &c.values {
                if !is_refractive_index(x) {
                    return Err(CoreError::scene(
                        c.key.clone(),
                        c.line,
                        format!("{x}: refractive index must be finite and >= 1"),
                    ));
                }
            }
        }
        RawSub::Lambertian(c) => {
            for &x in &c.values {
                if !(0.0..=1.0).contains(&x) {
                    return Err(CoreError::scene(
                        c.key.clone(),
                        c.line,
                        format!("{x}: albedo must lie in [0, 1]"),
                    ));
                }
            }
        }
        RawSub::Conductor(n, k) => {
            rough::check_conductor(n, k)?;
        }
        RawSub::Black | RawSub::Metal(..) => {}
    }
    Ok(())
}
