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

use std::path::Path;

use crate::error::CoreError;
use crate::layer::Layer;

mod parse;
mod read;

use parse::{Parser, RawScene};
pub use read::read_scene_text;
use read::{LineIndex, toml_error, too_big};

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
