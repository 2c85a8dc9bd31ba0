//! The scene file (TOML) of docs/scene-file.md and its validated form.
//!
//! A [`Scene`] holds one [`MonoScene`] per spectral channel: every
//! coefficient of the file may be a scalar or a list, and all lists have the
//! same length (the number of channels). Solvers work on a [`MonoScene`].
//!
//! Every refusal is a [`CoreError::Scene`] naming the key and, when the value
//! is in the file, its 1-based line. The full key reference is
//! `docs/scene-file.md`.
//!
//! Reading is bounded ([`SceneLimits`], docs/limits.md): the file must be a
//! regular file (or `-` for standard input) of at most 16 MiB, line numbers
//! come from one index built in one pass, and the expanded scene (channels x
//! (layers + directions)) is refused before it is allocated when it exceeds
//! its cell budget.

use std::io::Read;
use std::ops::Range;
use std::path::Path;

use serde::Deserialize;
use toml::{Spanned, Value};

use crate::error::CoreError;
use crate::layer::Layer;
use crate::presets;

/// Default largest scene file, bytes (16 MiB): a scene of 10^5 layers is
/// about 3 MB, so this leaves a factor of five over any scene seen in use.
pub const DEFAULT_MAX_SCENE_BYTES: u64 = 16 << 20;

/// Default largest expanded scene, in cells: one cell is one layer or one
/// output direction of one channel, so the validated [`Scene`] holds
/// `channels x (layers + directions)` cells (about 50 bytes each, and the
/// solvers' results one or two `f64` per direction cell). 2^22 cells keep the
/// scene and a result under about 300 MB.
pub const DEFAULT_MAX_SCENE_CELLS: u64 = 1 << 22;

/// Smallest distance to grazing incidence accepted for `light.theta_deg`,
/// degrees. At `90 - theta < 1e-6` degrees (`mu0 < 1.7e-8`) the beam's
/// path through a layer, `tau / mu0`, exceeds 10^7 optical depths per unit
/// `tau`, and the methods part ways in floating point (multi-flux gave
/// R = 0 at 89.9999999 degrees, R = 0.505 at 89.999999): such scenes are
/// refused rather than answered differently by each method.
pub const GRAZING_MARGIN_DEG: f64 = 1e-6;

/// Bounds on what reading a scene may cost (docs/limits.md).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SceneLimits {
    /// Largest scene file or standard input, bytes (default [`DEFAULT_MAX_SCENE_BYTES`]).
    pub max_bytes: u64,
    /// Largest `channels x (layers + directions)` (default [`DEFAULT_MAX_SCENE_CELLS`]).
    pub max_cells: u64,
}

impl Default for SceneLimits {
    fn default() -> Self {
        SceneLimits { max_bytes: DEFAULT_MAX_SCENE_BYTES, max_cells: DEFAULT_MAX_SCENE_CELLS }
    }
}

impl SceneLimits {
    /// The defaults, raised (or lowered) by the environment variables
    /// `KM_MAX_SCENE_BYTES` and `KM_MAX_SCENE_CELLS` (positive integers;
    /// anything else is ignored).
    pub fn from_env() -> SceneLimits {
        let get = |name: &str, default: u64| {
            std::env::var(name)
                .ok()
                .and_then(|v| v.trim().parse::<u64>().ok())
                .filter(|&v| v > 0)
                .unwrap_or(default)
        };
        let d = SceneLimits::default();
        SceneLimits {
            max_bytes: get("KM_MAX_SCENE_BYTES", d.max_bytes),
            max_cells: get("KM_MAX_SCENE_CELLS", d.max_cells),
        }
    }
}

/// How the stack is lit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Light {
    /// A collimated beam at polar angle `theta_deg` (0 = normal, `< 90`),
    /// arriving from azimuth 0.
    Collimated {
        /// Polar angle of incidence in degrees, `0 <= theta < 90`.
        theta_deg: f64,
    },
    /// Uniform (Lambertian) illumination from the whole upper hemisphere.
    Diffuse,
}

impl Light {
    /// `mu0 = cos(theta)` of a collimated beam; `None` for diffuse light.
    pub fn mu0(&self) -> Option<f64> {
        match *self {
            Light::Collimated { theta_deg } => Some(theta_deg.to_radians().cos()),
            Light::Diffuse => None,
        }
    }
}

/// What lies below the last layer (one channel).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Substrate {
    /// A clear half-space of index `n` (light that reaches it leaves the stack).
    Transparent {
        /// Refractive index, `>= 1`.
        n: f64,
    },
    /// An opaque Lambertian reflector of albedo in `[0, 1]`, in optical
    /// contact with the last layer (no interface of its own).
    Lambertian {
        /// Hemispherical reflectance, `0 <= albedo <= 1`.
        albedo: f64,
    },
    /// An opaque perfect absorber.
    Black,
}

/// One spectral channel of a scene: what every solver takes.
#[derive(Debug, Clone, PartialEq)]
pub struct MonoScene {
    /// Illumination.
    pub light: Light,
    /// Refractive index of the clear medium above the stack, `>= 1`.
    pub ambient_n: f64,
    /// Layers, top first (at least one).
    pub layers: Vec<Layer>,
    /// What lies below.
    pub substrate: Substrate,
    /// Exit directions `[theta_deg, phi_deg]` for BRDF/BTDF samples
    /// (`theta` from the normal on the exit side, `0 <= theta < 90`).
    pub directions_deg: Vec<[f64; 2]>,
}

impl MonoScene {
    /// Index of the medium below the stack (`None` for opaque substrates).
    pub fn substrate_n(&self) -> Option<f64> {
        match self.substrate {
            Substrate::Transparent { n } => Some(n),
            _ => None,
        }
    }

    /// Check the invariants that the parser guarantees, for scenes built in code.
    ///
    /// # Errors
    /// Empty stack, invalid light angle, ambient index, substrate or direction.
    pub fn validate(&self) -> Result<(), CoreError> {
        if self.layers.is_empty() {
            return Err(CoreError::scene("layer", None, "the stack has no layer"));
        }
        if let Light::Collimated { theta_deg } = self.light {
            check_incidence(theta_deg, None)?;
        }
        if !self.ambient_n.is_finite() || self.ambient_n < 1.0 {
            return Err(CoreError::scene("ambient.n", None, "must be finite and >= 1"));
        }
        for (i, l) in self.layers.iter().enumerate() {
            let ok = l.sigma_a.is_finite()
                && l.sigma_a >= 0.0
                && l.sigma_s.is_finite()
                && l.sigma_s >= 0.0
                && (l.sigma_a + l.sigma_s).is_finite()
                && (l.thickness.is_infinite() || l.tau().is_finite())
                && l.thickness >= 0.0
                && l.n.is_finite()
                && l.n >= 1.0
                && l.g().abs() < 1.0;
            if !ok {
                return Err(CoreError::scene(format!("layer[{}]", i + 1), None, "invalid layer"));
            }
            if l.is_half_space() && i + 1 != self.layers.len() {
                return Err(CoreError::scene(
                    format!("layer[{}].thickness", i + 1),
                    None,
                    "only the last layer may be a half-space",
                ));
            }
        }
        match self.substrate {
            Substrate::Transparent { n } if !n.is_finite() || n < 1.0 => {
                return Err(CoreError::scene("substrate.n", None, "must be finite and >= 1"));
            }
            Substrate::Lambertian { albedo } if !(0.0..=1.0).contains(&albedo) => {
                return Err(CoreError::scene("substrate.albedo", None, "must lie in [0, 1]"));
            }
            _ => {}
        }
        for d in &self.directions_deg {
            check_theta("output.directions_deg", d[0], None)?;
            if !d[1].is_finite() {
                return Err(CoreError::scene("output.directions_deg", None, "phi must be finite"));
            }
        }
        Ok(())
    }
}

/// A validated scene: one [`MonoScene`] per spectral channel.
#[derive(Debug, Clone, PartialEq)]
pub struct Scene {
    /// The channels, in order (at least one).
    pub channels: Vec<MonoScene>,
    /// A label per channel (`"R"`, `"550 nm"`, or the channel number).
    pub labels: Vec<String>,
    /// Wavelengths in nm when the file gives them.
    pub wavelengths_nm: Option<Vec<f64>>,
}

impl Scene {
    /// Parse and validate a scene file.
    ///
    /// # Errors
    /// A [`CoreError::Scene`] naming the key and line of the first problem:
    /// TOML syntax, unknown keys, missing or conflicting keys, values out of
    /// their domain, lists of different lengths.
    ///
    /// ```
    /// let s = km_core::Scene::from_toml_str(r#"
    /// [light]
    /// kind = "collimated"
    /// theta_deg = 45.0
    /// [[layer]]
    /// tau = 1.0
    /// albedo = [0.5, 0.9]
    /// "#).unwrap();
    /// assert_eq!(s.channels.len(), 2);
    /// assert!((s.channels[1].layers[0].albedo() - 0.9).abs() < 1e-15);
    /// ```
    pub fn from_toml_str(text: &str) -> Result<Scene, CoreError> {
        Scene::from_toml_str_with(text, &SceneLimits::default())
    }

    /// [`Scene::from_toml_str`] under explicit [`SceneLimits`].
    ///
    /// # Errors
    /// Those of [`Scene::from_toml_str`], and a text or an expanded scene over its limit.
    pub fn from_toml_str_with(text: &str, limits: &SceneLimits) -> Result<Scene, CoreError> {
        if text.len() as u64 > limits.max_bytes {
            return Err(too_big("scene text", text.len() as u64, limits.max_bytes));
        }
        let raw: RawScene = toml::from_str(text).map_err(|e| toml_error(text, &e))?;
        Parser { lines: LineIndex::new(text), limits: *limits }.scene(raw)
    }

    /// Read and parse a scene file from disk (`-`: standard input), under
    /// [`SceneLimits::from_env`].
    ///
    /// # Errors
    /// I/O errors, a path that is not a regular file (directory, FIFO,
    /// device, socket), a file over the size limit (all as a scene error on
    /// key `file`), and those of [`Scene::from_toml_str`].
    pub fn from_path(path: &Path) -> Result<Scene, CoreError> {
        Scene::from_path_with(path, &SceneLimits::from_env())
    }

    /// [`Scene::from_path`] under explicit [`SceneLimits`].
    ///
    /// # Errors
    /// Those of [`Scene::from_path`].
    pub fn from_path_with(path: &Path, limits: &SceneLimits) -> Result<Scene, CoreError> {
        let text = read_scene_text(path, limits.max_bytes)?;
        Scene::from_toml_str_with(&text, limits)
    }

    /// A one-channel scene from a [`MonoScene`] built in code (validated).
    ///
    /// # Errors
    /// Those of [`MonoScene::validate`].
    pub fn single(mono: MonoScene) -> Result<Scene, CoreError> {
        mono.validate()?;
        Ok(Scene { channels: vec![mono], labels: vec!["0".into()], wavelengths_nm: None })
    }
}

// ---------------------------------------------------------------------------
// Raw (file) form. Every value is kept with its span so errors can name lines.

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawScene {
    light: Option<RawLight>,
    ambient: Option<RawAmbient>,
    layer: Option<Vec<RawLayer>>,
    substrate: Option<RawSubstrate>,
    output: Option<RawOutput>,
    spectrum: Option<RawSpectrum>,
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
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawSubstrate {
    kind: Option<Spanned<String>>,
    n: Option<Spanned<Value>>,
    albedo: Option<Spanned<Value>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawOutput {
    directions_deg: Option<Spanned<Value>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawSpectrum {
    labels: Option<Spanned<Vec<String>>>,
    wavelengths_nm: Option<Spanned<Value>>,
}

/// A coefficient per channel: one value (broadcast) or a list.
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

struct Parser {
    lines: LineIndex,
    limits: SceneLimits,
}

/// Byte offsets of the line starts of a text, built in one pass, so that the
/// line of a byte offset is a binary search (the parser asks for one line per
/// value: a scan from the start for each was quadratic in the file size).
struct LineIndex {
    starts: Vec<usize>,
}

impl LineIndex {
    fn new(text: &str) -> LineIndex {
        let mut starts = vec![0];
        starts.extend(text.bytes().enumerate().filter(|&(_, b)| b == b'\n').map(|(i, _)| i + 1));
        LineIndex { starts }
    }

    /// 1-based line of byte offset `at` (offsets past the end give the last line).
    fn line(&self, at: usize) -> usize {
        // Number of line starts at or before `at`.
        self.starts.partition_point(|&s| s <= at)
    }
}

fn line_of(text: &str, span: Range<usize>) -> usize {
    LineIndex::new(text).line(span.start.min(text.len()))
}

fn too_big(what: &str, bytes: u64, max: u64) -> CoreError {
    CoreError::scene(
        "file",
        None,
        format!(
            "{what} of {bytes} bytes is over the limit of {max} bytes \
             (set KM_MAX_SCENE_BYTES to raise it; docs/limits.md)"
        ),
    )
}

/// The text of a scene file read as [`Scene::from_path`] reads it: at most
/// `max` bytes; `-` is standard input; anything else must be a regular file
/// (checked before opening, so a FIFO without a writer or `/dev/zero` is
/// refused at once), opened without blocking.
///
/// # Errors
/// Those of [`Scene::from_path`] about the file.
pub fn read_scene_text(path: &Path, max: u64) -> Result<String, CoreError> {
    let shown = path.display();
    let io =
        |e: std::io::Error| CoreError::scene("file", None, format!("cannot read {shown}: {e}"));
    let mut buf = Vec::new();
    if path.as_os_str() == "-" {
        std::io::stdin().lock().take(max + 1).read_to_end(&mut buf).map_err(io)?;
        if buf.len() as u64 > max {
            return Err(too_big("standard input", buf.len() as u64, max));
        }
    } else {
        // The type before opening: opening a FIFO with no writer blocks.
        let meta = std::fs::metadata(path).map_err(io)?;
        if !meta.is_file() {
            return Err(CoreError::scene(
                "file",
                None,
                format!(
                    "{shown} is {}: a scene must be a regular file (or - for standard input)",
                    crate::atomic_file::kind(&meta.file_type())
                ),
            ));
        }
        if meta.len() > max {
            return Err(too_big(&format!("{shown}"), meta.len(), max));
        }
        // O_NONBLOCK: should the path be swapped for a FIFO after the check,
        // the open does not hang.
        use std::os::unix::fs::OpenOptionsExt;
        let f = std::fs::OpenOptions::new()
            .read(true)
            .custom_flags(libc::O_NONBLOCK)
            .open(path)
            .map_err(io)?;
        let meta = f.metadata().map_err(io)?;
        if !meta.is_file() {
            return Err(CoreError::scene(
                "file",
                None,
                format!(
                    "{shown} is {}: a scene must be a regular file",
                    crate::atomic_file::kind(&meta.file_type())
                ),
            ));
        }
        // A file that grows while read is cut at max + 1 bytes and refused.
        f.take(max + 1).read_to_end(&mut buf).map_err(io)?;
        if buf.len() as u64 > max {
            return Err(too_big(&format!("{shown}"), buf.len() as u64, max));
        }
    }
    String::from_utf8(buf).map_err(|e| {
        CoreError::scene(
            "file",
            None,
            format!(
                "{shown} is not UTF-8 text (invalid byte at offset {})",
                e.utf8_error().valid_up_to()
            ),
        )
    })
}

fn toml_error(text: &str, e: &toml::de::Error) -> CoreError {
    let line = e.span().map(|s| line_of(text, s));
    // toml's message names the key (e.g. "unknown field `sigmaa`, expected ...").
    let msg = e.message().trim().to_string();
    let key = msg
        .split('`')
        .nth(1)
        .filter(|_| msg.contains("unknown field") || msg.contains("missing field"))
        .unwrap_or("scene")
        .to_string();
    CoreError::scene(key, line, msg)
}

fn check_theta(key: &str, theta: f64, line: Option<usize>) -> Result<(), CoreError> {
    if !theta.is_finite() || !(0.0..90.0).contains(&theta) {
        return Err(CoreError::scene(key, line, format!("{theta} must lie in [0, 90) degrees")));
    }
    Ok(())
}

/// The incidence angle: [`check_theta`], and at least [`GRAZING_MARGIN_DEG`] from grazing.
fn check_incidence(theta: f64, line: Option<usize>) -> Result<(), CoreError> {
    let key = "light.theta_deg";
    check_theta(key, theta, line)?;
    // The margin less one part in 10^6, so that 89.999999 itself (stored as
    // 89.99999899999999...) is accepted.
    if 90.0 - theta < GRAZING_MARGIN_DEG * (1.0 - 1e-6) {
        return Err(CoreError::scene(
            key,
            line,
            format!(
                "{theta} is within {GRAZING_MARGIN_DEG:e} degrees of grazing, where the methods \
                 lose all precision (mu0 = {:.1e}); use theta_deg <= {} (at grazing a Fresnel \
                 interface reflects everything: R -> 1)",
                theta.to_radians().cos(),
                90.0 - GRAZING_MARGIN_DEG
            ),
        ));
    }
    Ok(())
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

    fn scene(&self, raw: RawScene) -> Result<Scene, CoreError> {
        let mut coefs: Vec<(String, Option<usize>, usize)> = Vec::new();
        let mut note = |c: &Coef| coefs.push((c.key.clone(), c.line, c.values.len()));

        // [light]
        let light = match raw.light {
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
        };

        // [ambient]
        let ambient_n = match raw.ambient.as_ref().and_then(|a| a.n.as_ref()) {
            None => Coef::constant("ambient.n", 1.0),
            Some(v) => self.coef("ambient.n", v)?,
        };
        for &x in &ambient_n.values {
            if !x.is_finite() || x < 1.0 {
                return Err(CoreError::scene(
                    ambient_n.key.clone(),
                    ambient_n.line,
                    format!("{x}: refractive index must be finite and >= 1"),
                ));
            }
        }
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
        let mut layers = Vec::with_capacity(n_layers);
        for (i, l) in raw_layers.iter().enumerate() {
            let lay = self.layer(i, n_layers, l, &ambient_n)?;
            for c in [&lay.a, &lay.b, &lay.thickness, &lay.g, &lay.n] {
                note(c);
            }
            layers.push(lay);
        }

        // [substrate]
        let substrate = self.substrate(raw.substrate.as_ref(), &ambient_n)?;
        match &substrate {
            RawSub::Transparent(c) | RawSub::Lambertian(c) => note(c),
            RawSub::Black => {}
        }

        // [output]
        let directions_deg = match raw.output.as_ref().and_then(|o| o.directions_deg.as_ref()) {
            None => Vec::new(),
            Some(v) => self.directions(v)?,
        };

        // [spectrum]
        let mut labels: Option<(Vec<String>, Option<usize>)> = None;
        let mut wavelengths_nm = None;
        if let Some(s) = &raw.spectrum {
            if let Some(w) = &s.wavelengths_nm {
                let c = self.coef("spectrum.wavelengths_nm", w)?;
                for &x in &c.values {
                    if !x.is_finite() || x <= 0.0 {
                        return Err(CoreError::scene(
                            c.key.clone(),
                            c.line,
                            "wavelengths must be > 0",
                        ));
                    }
                }
                labels = Some((c.values.iter().map(|x| format!("{x} nm")).collect(), c.line));
                note(&c);
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
                labels = Some((v, line));
            }
        }

        // All lists must have one length: the number of channels. The
        // [spectrum] table, when present, sets it (stable sort keeps file order).
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

        // The expanded scene's size, before it is allocated.
        let cells = channels as u64 * (n_layers as u64 + directions_deg.len() as u64);
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
                    directions_deg.len(),
                    cells * 64 / 1_000_000,
                    self.limits.max_cells
                ),
            ));
        }
        let mut out = Vec::with_capacity(channels);
        for ch in 0..channels {
            let mut ls = Vec::with_capacity(n_layers);
            for lay in &layers {
                ls.push(lay.build(ch)?);
            }
            let sub = match &substrate {
                RawSub::Transparent(c) => Substrate::Transparent { n: c.at(ch) },
                RawSub::Lambertian(c) => Substrate::Lambertian { albedo: c.at(ch) },
                RawSub::Black => Substrate::Black,
            };
            out.push(MonoScene {
                light,
                ambient_n: ambient_n.at(ch),
                layers: ls,
                substrate: sub,
                directions_deg: directions_deg.clone(),
            });
        }
        // Channel-wise checks on substrate values.
        match &substrate {
            RawSub::Transparent(c) => {
                for &x in &c.values {
                    if !x.is_finite() || x < 1.0 {
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
            RawSub::Black => {}
        }
        let labels = match labels {
            Some((l, _)) => l,
            None if channels == 3 => vec!["R".into(), "G".into(), "B".into()],
            None => (0..channels).map(|c| c.to_string()).collect(),
        };
        Ok(Scene { channels: out, labels, wavelengths_nm })
    }

    fn layer(
        &self,
        i: usize,
        n_layers: usize,
        l: &RawLayer,
        ambient_n: &Coef,
    ) -> Result<LayerCoefs, CoreError> {
        let k = |name: &str| format!("layer[{}].{name}", i + 1);
        let sigma_a = self.opt_coef(&k("sigma_a"), &l.sigma_a)?;
        let sigma_s = self.opt_coef(&k("sigma_s"), &l.sigma_s)?;
        let thickness = self.opt_coef(&k("thickness"), &l.thickness)?;
        let tau = self.opt_coef(&k("tau"), &l.tau)?;
        let albedo = self.opt_coef(&k("albedo"), &l.albedo)?;
        let g = self.opt_coef(&k("g"), &l.g)?.unwrap_or(Coef::constant(&k("g"), 0.0));
        let mut n = self.opt_coef(&k("n"), &l.n)?;
        let is_last = i + 1 == n_layers;

        // The layer's form: preset, (sigma_a, sigma_s, thickness) or (tau, albedo).
        let sigma_form = sigma_a.is_some() || sigma_s.is_some();
        let tau_form = tau.is_some() || albedo.is_some();
        if let Some(p) = &l.preset {
            let line = self.line(p.span());
            if sigma_form || tau_form {
                let key = if sigma_form { k("sigma_a") } else { k("tau") };
                return Err(CoreError::scene(
                    key,
                    line,
                    "a preset gives sigma_a and sigma_s: remove them or the preset",
                ));
            }
            let Some(m) = presets::lookup(p.get_ref()) else {
                return Err(CoreError::scene(
                    k("preset"),
                    line,
                    format!(
                        "unknown preset \"{}\" (known: {})",
                        p.get_ref(),
                        presets::names().join(", ")
                    ),
                ));
            };
            // sigma_s = sigma_s' / (1 - g): the preset gives the reduced coefficient.
            let mut s = Vec::with_capacity(3);
            for c in 0..3 {
                // A g list of another length is refused later with the list-length rule.
                let gc = g.values[c.min(g.values.len() - 1)];
                s.push(m.sigma_s_prime[c] / (1.0 - gc.clamp(-0.999_999, 0.999_999)));
            }
            if n.is_none() {
                n = Some(Coef { key: k("n"), line, values: vec![m.eta] });
            }
            let thickness = match thickness {
                Some(t) => t,
                None => {
                    if !is_last {
                        return Err(CoreError::scene(
                            k("thickness"),
                            line,
                            "a preset layer that is not the last needs a thickness",
                        ));
                    }
                    Coef { key: k("thickness"), line, values: vec![f64::INFINITY] }
                }
            };
            return self.finish_layer(
                i,
                is_last,
                Form::Sigma,
                Coef { key: k("sigma_a"), line, values: m.sigma_a.to_vec() },
                Coef { key: k("sigma_s"), line, values: s },
                thickness,
                g,
                n.unwrap_or(Coef { key: k("n"), line: None, values: ambient_n.values.clone() }),
            );
        }
        if sigma_form && tau_form {
            let c = tau.as_ref().or(albedo.as_ref()).map(|c| (c.key.clone(), c.line));
            let (key, line) = c.unwrap_or((k("tau"), None));
            return Err(CoreError::scene(
                key,
                line,
                "give either sigma_a, sigma_s, thickness or tau, albedo, not both",
            ));
        }
        let n = n.unwrap_or(Coef { key: k("n"), line: None, values: ambient_n.values.clone() });
        if tau_form {
            if let Some(t) = &thickness {
                return Err(CoreError::scene(
                    t.key.clone(),
                    t.line,
                    "the tau form takes no thickness (tau = sigma_t * thickness)",
                ));
            }
            let missing = |name: &str| {
                CoreError::scene(k(name), None, "the tau form needs both tau and albedo")
            };
            let tau = tau.ok_or_else(|| missing("tau"))?;
            let albedo = albedo.ok_or_else(|| missing("albedo"))?;
            return self.finish_layer(
                i,
                is_last,
                Form::Tau,
                tau,
                albedo,
                Coef::constant(&k("thickness"), 1.0),
                g,
                n,
            );
        }
        let missing = |name: &str| {
            CoreError::scene(
                k(name),
                None,
                "missing: a layer needs sigma_a, sigma_s and thickness (or tau and albedo, or a preset)",
            )
        };
        let sigma_a = sigma_a.ok_or_else(|| missing("sigma_a"))?;
        let sigma_s = sigma_s.ok_or_else(|| missing("sigma_s"))?;
        let thickness = thickness.ok_or_else(|| missing("thickness"))?;
        self.finish_layer(i, is_last, Form::Sigma, sigma_a, sigma_s, thickness, g, n)
    }

    #[allow(clippy::too_many_arguments)]
    fn finish_layer(
        &self,
        i: usize,
        is_last: bool,
        form: Form,
        a: Coef,
        b: Coef,
        thickness: Coef,
        g: Coef,
        n: Coef,
    ) -> Result<LayerCoefs, CoreError> {
        // Domain checks value by value, so the message names key and line.
        let check = |c: &Coef, ok: &dyn Fn(f64) -> bool, what: &str| -> Result<(), CoreError> {
            for &x in &c.values {
                if !ok(x) {
                    return Err(CoreError::scene(c.key.clone(), c.line, format!("{x}: {what}")));
                }
            }
            Ok(())
        };
        match form {
            Form::Sigma => {
                check(&a, &|x| x.is_finite() && x >= 0.0, "must be finite and >= 0")?;
                check(&b, &|x| x.is_finite() && x >= 0.0, "must be finite and >= 0")?;
                check(&thickness, &|x| x >= 0.0, "must be >= 0 (or \"inf\" for a half-space)")?;
                // sigma_t = sigma_a + sigma_s and tau = sigma_t * thickness must be
                // representable: 1e308 + 1e308 overflows, and the methods then
                // disagree (R = 0 or R = 1) instead of failing.
                let len = a.values.len().max(b.values.len()).max(thickness.values.len());
                // Lists of different lengths are refused later, with their lines.
                let same = [&a, &b, &thickness]
                    .iter()
                    .all(|c| matches!(c.values.len(), 1) || c.values.len() == len);
                for c in (0..len).filter(|_| same) {
                    let (sa, ss, d) = (a.at(c), b.at(c), thickness.at(c));
                    let sigma_t = sa + ss;
                    if !sigma_t.is_finite() {
                        return Err(CoreError::scene(
                            b.key.clone(),
                            b.line,
                            format!(
                                "sigma_a + sigma_s = {sa:e} + {ss:e} overflows (> {:e}); \
                                 rescale the length unit",
                                f64::MAX
                            ),
                        ));
                    }
                    if d.is_finite() && !(sigma_t * d).is_finite() {
                        return Err(CoreError::scene(
                            thickness.key.clone(),
                            thickness.line,
                            format!(
                                "the optical thickness (sigma_a + sigma_s) * thickness = \
                                 {sigma_t:e} * {d:e} overflows; give thickness = \"inf\" for an \
                                 opaque half-space or rescale the length unit"
                            ),
                        ));
                    }
                }
            }
            Form::Tau => {
                check(&a, &|x| x >= 0.0, "must be >= 0 (or \"inf\" for a half-space)")?;
                check(&b, &|x| (0.0..=1.0).contains(&x), "albedo must lie in [0, 1]")?;
            }
        }
        check(&g, &|x| x.is_finite() && x.abs() < 1.0, "|g| must be < 1")?;
        check(&n, &|x| x.is_finite() && x >= 1.0, "refractive index must be finite and >= 1")?;
        let half = match form {
            Form::Sigma => thickness.values.iter().any(|x| x.is_infinite()),
            Form::Tau => a.values.iter().any(|x| x.is_infinite()),
        };
        if half && !is_last {
            let c = if form == Form::Sigma { &thickness } else { &a };
            return Err(CoreError::scene(
                c.key.clone(),
                c.line,
                "only the last layer may be a half-space (inf)",
            ));
        }
        let _ = i;
        Ok(LayerCoefs { form, a, b, thickness, g, n })
    }

    fn substrate(&self, s: Option<&RawSubstrate>, ambient_n: &Coef) -> Result<RawSub, CoreError> {
        let Some(s) = s else {
            // Default: a clear half-space of the ambient index.
            return Ok(RawSub::Transparent(Coef {
                key: "substrate.n".into(),
                line: None,
                values: ambient_n.values.clone(),
            }));
        };
        let kind = s.kind.as_ref().map(|k| (k.get_ref().as_str(), self.line(k.span())));
        let unexpected = |c: &Option<Spanned<Value>>, key: &str, kind: &str| match c {
            Some(v) => Err(CoreError::scene(
                key,
                self.line(v.span()),
                format!("a {kind} substrate takes no {}", key.trim_start_matches("substrate.")),
            )),
            None => Ok(()),
        };
        match kind {
            None | Some(("transparent", _)) => {
                unexpected(&s.albedo, "substrate.albedo", "transparent")?;
                Ok(RawSub::Transparent(match &s.n {
                    Some(v) => self.coef("substrate.n", v)?,
                    None => Coef {
                        key: "substrate.n".into(),
                        line: None,
                        values: ambient_n.values.clone(),
                    },
                }))
            }
            Some(("lambertian", line)) => {
                unexpected(&s.n, "substrate.n", "lambertian")?;
                match &s.albedo {
                    Some(v) => Ok(RawSub::Lambertian(self.coef("substrate.albedo", v)?)),
                    None => Err(CoreError::scene(
                        "substrate.albedo",
                        line,
                        "a lambertian substrate needs an albedo",
                    )),
                }
            }
            Some(("black", _)) => {
                unexpected(&s.n, "substrate.n", "black")?;
                unexpected(&s.albedo, "substrate.albedo", "black")?;
                Ok(RawSub::Black)
            }
            Some((other, line)) => Err(CoreError::scene(
                "substrate.kind",
                line,
                format!(
                    "unknown kind \"{other}\" (expected \"transparent\", \"lambertian\" or \"black\")"
                ),
            )),
        }
    }

    fn directions(&self, v: &Spanned<Value>) -> Result<Vec<[f64; 2]>, CoreError> {
        let key = "output.directions_deg";
        let line = self.line(v.span());
        let Value::Array(items) = v.get_ref() else {
            return Err(CoreError::scene(key, line, "expected a list of [theta, phi] pairs"));
        };
        let mut out = Vec::with_capacity(items.len());
        for item in items {
            let pair = match item {
                Value::Array(p) if p.len() == 2 => p,
                _ => {
                    return Err(CoreError::scene(
                        key,
                        line,
                        "each direction is a pair [theta, phi] in degrees",
                    ));
                }
            };
            let theta = self.number(key, line, &pair[0])?;
            let phi = self.number(key, line, &pair[1])?;
            check_theta(key, theta, line)?;
            if !phi.is_finite() {
                return Err(CoreError::scene(key, line, format!("phi = {phi} must be finite")));
            }
            out.push([theta, phi]);
        }
        Ok(out)
    }
}

#[derive(Clone, Copy, PartialEq)]
enum Form {
    /// a = sigma_a, b = sigma_s
    Sigma,
    /// a = tau, b = albedo
    Tau,
}

struct LayerCoefs {
    form: Form,
    a: Coef,
    b: Coef,
    thickness: Coef,
    g: Coef,
    n: Coef,
}

impl LayerCoefs {
    fn build(&self, ch: usize) -> Result<Layer, CoreError> {
        let g = self.g.at(ch);
        let n = self.n.at(ch);
        let r = match self.form {
            Form::Sigma => Layer::new(self.a.at(ch), self.b.at(ch), self.thickness.at(ch), g, n),
            Form::Tau => Layer::from_tau_albedo(self.a.at(ch), self.b.at(ch), g, n),
        };
        // The checks above make this unreachable, but keep the line in any message.
        r.map_err(|e| CoreError::scene(self.a.key.clone(), self.a.line, e.to_string()))
    }
}

enum RawSub {
    Transparent(Coef),
    Lambertian(Coef),
    Black,
}
