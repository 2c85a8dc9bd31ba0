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
use crate::layer::{Layer, is_refractive_index};
use crate::microfacet::Microfacet;

mod parse;
mod read;

use parse::{Parser, RawScene};
use read::{LineIndex, toml_error, too_big};
pub use read::{read_checked_text, read_scene_text};

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
    /// A collimated beam at `theta_deg` (checked: `0 <= theta < 90`, finite, and at
    /// least [`GRAZING_MARGIN_DEG`] from grazing).
    ///
    /// # Errors
    /// A [`CoreError::Scene`] on `light.theta_deg`.
    ///
    /// ```
    /// use km_core::Light;
    /// assert!((Light::collimated(60.0).unwrap().mu0().unwrap() - 0.5).abs() < 1e-15);
    /// assert!(Light::collimated(90.0).is_err());
    /// ```
    pub fn collimated(theta_deg: f64) -> Result<Light, CoreError> {
        check_incidence(theta_deg, None)?;
        Ok(Light::Collimated { theta_deg })
    }

    /// The checks of [`Light::collimated`] on any light (diffuse light has none).
    fn check(&self) -> Result<(), CoreError> {
        if let Light::Collimated { theta_deg } = *self {
            check_incidence(theta_deg, None)?;
        }
        Ok(())
    }

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
    /// An opaque conductor (metal) of complex refractive index `n + i k`,
    /// in optical contact with the last layer: its face reflects with the
    /// conductor Fresnel reflectance (docs/rough.md eq. R5), smooth or rough
    /// ([`MonoScene::substrate_roughness`]).
    Conductor {
        /// Real part of the complex index, `> 0`.
        n: f64,
        /// Imaginary part (extinction coefficient), `>= 0`.
        k: f64,
    },
}

impl Substrate {
    /// A clear half-space of index `n` (checked: finite, `>= 1`).
    ///
    /// # Errors
    /// A [`CoreError::Scene`] on `substrate.n`.
    ///
    /// ```
    /// assert!(km_core::Substrate::transparent(1.5).is_ok());
    /// assert!(km_core::Substrate::transparent(0.5).is_err());
    /// ```
    pub fn transparent(n: f64) -> Result<Substrate, CoreError> {
        let s = Substrate::Transparent { n };
        s.check()?;
        Ok(s)
    }

    /// An opaque Lambertian reflector (checked: `0 <= albedo <= 1`).
    ///
    /// # Errors
    /// A [`CoreError::Scene`] on `substrate.albedo`.
    ///
    /// ```
    /// assert!(km_core::Substrate::lambertian(0.8).is_ok());
    /// assert!(km_core::Substrate::lambertian(1.2).is_err());
    /// ```
    pub fn lambertian(albedo: f64) -> Result<Substrate, CoreError> {
        let s = Substrate::Lambertian { albedo };
        s.check()?;
        Ok(s)
    }

    /// The checks of a substrate, written once.
    fn check(&self) -> Result<(), CoreError> {
        match *self {
            Substrate::Transparent { n } if !is_refractive_index(n) => {
                Err(CoreError::scene("substrate.n", None, "must be finite and >= 1"))
            }
            Substrate::Lambertian { albedo } if !(0.0..=1.0).contains(&albedo) => {
                Err(CoreError::scene("substrate.albedo", None, "must lie in [0, 1]"))
            }
            Substrate::Conductor { n, .. } if !(n.is_finite() && n > 0.0) => {
                Err(CoreError::scene("substrate.n", None, "a conductor's n must be finite and > 0"))
            }
            Substrate::Conductor { k, .. } if !(k.is_finite() && k >= 0.0) => {
                Err(CoreError::scene("substrate.k", None, "must be finite and >= 0"))
            }
            _ => Ok(()),
        }
    }
}

/// One spectral channel of a scene: what every solver takes.
///
/// The fields are private: a [`MonoScene`] exists only through
/// [`MonoScene::new`] (and the checked `with_*` variants), which holds every
/// check of a scene once, so solvers receive a valid one and check nothing again.
#[derive(Debug, Clone, PartialEq)]
pub struct MonoScene {
    /// Illumination.
    light: Light,
    /// Refractive index of the clear medium above the stack, `>= 1`.
    ambient_n: f64,
    /// Layers, top first (at least one).
    layers: Vec<Layer>,
    /// What lies below.
    substrate: Substrate,
    /// Exit directions `[theta_deg, phi_deg]` for BRDF/BTDF samples
    /// (`theta` from the normal on the exit side, `0 <= theta < 90`).
    directions_deg: Vec<[f64; 2]>,
    /// Roughness of the substrate's face (transparent or conductor), `None`: smooth.
    substrate_roughness: Option<Microfacet>,
}

impl MonoScene {
    /// A checked channel: every invariant of a scene, written once.
    ///
    /// # Errors
    /// Empty stack, a half-space that is not the last layer, invalid light
    /// angle, ambient index, substrate or direction (a [`CoreError::Scene`]
    /// naming the key).
    ///
    /// ```
    /// use km_core::{Layer, Light, MonoScene, Substrate};
    /// let layer = Layer::new(0.1, 1.0, 1.0, 0.0, 1.5).unwrap();
    /// let s = MonoScene::new(Light::Diffuse, 1.0, vec![layer.clone()], Substrate::Black, vec![])
    ///     .unwrap();
    /// assert_eq!(s.layers().len(), 1);
    /// assert!(MonoScene::new(Light::Diffuse, 0.5, vec![layer], Substrate::Black, vec![]).is_err());
    /// ```
    pub fn new(
        light: Light,
        ambient_n: f64,
        layers: Vec<Layer>,
        substrate: Substrate,
        directions_deg: Vec<[f64; 2]>,
    ) -> Result<MonoScene, CoreError> {
        check_layers(&layers)?;
        light.check()?;
        check_ambient_n(ambient_n)?;
        substrate.check()?;
        check_directions(&directions_deg)?;
        Ok(MonoScene {
            light,
            ambient_n,
            layers,
            substrate,
            directions_deg,
            substrate_roughness: None,
        })
    }

    /// This channel with other layers (checked as in [`MonoScene::new`]).
    ///
    /// # Errors
    /// An empty stack, a half-space that is not last.
    pub fn with_layers(&self, layers: Vec<Layer>) -> Result<MonoScene, CoreError> {
        check_layers(&layers)?;
        Ok(MonoScene {
            light: self.light,
            ambient_n: self.ambient_n,
            layers,
            substrate: self.substrate,
            directions_deg: self.directions_deg.clone(),
            substrate_roughness: self.substrate_roughness,
        })
    }

    /// This channel with another substrate.
    ///
    /// # Errors
    /// An invalid substrate.
    pub fn with_substrate(&self, substrate: Substrate) -> Result<MonoScene, CoreError> {
        substrate.check()?;
        Ok(MonoScene { substrate, ..self.clone() })
    }

    /// This channel with other output directions.
    ///
    /// # Errors
    /// A direction outside `[0, 90)` degrees or a non-finite azimuth.
    pub fn with_directions(&self, directions_deg: Vec<[f64; 2]>) -> Result<MonoScene, CoreError> {
        check_directions(&directions_deg)?;
        Ok(MonoScene {
            light: self.light,
            ambient_n: self.ambient_n,
            layers: self.layers.clone(),
            substrate: self.substrate,
            directions_deg,
            substrate_roughness: self.substrate_roughness,
        })
    }

    /// This channel cut below layer `i` (0-based): layers `0..=i`, the last
    /// made a half-space (the planner's thick-layer cut, docs/planner.md).
    ///
    /// # Errors
    /// `i` beyond the last layer.
    pub fn cut_below(&self, i: usize) -> Result<MonoScene, CoreError> {
        let Some(layer) = self.layers.get(i) else {
            return Err(CoreError::scene(
                format!("layer[{}]", i + 1),
                None,
                format!("the stack has {} layer(s)", self.layers.len()),
            ));
        };
        let mut layers = self.layers[..i].to_vec();
        layers.push(layer.with_thickness(f64::INFINITY)?);
        self.with_layers(layers)
    }

    /// This channel with another substrate face: `None` smooth, or rough
    /// (docs/rough.md).
    ///
    /// # Errors
    /// A rough face on a Lambertian or black substrate (neither has a face of
    /// its own: they are in optical contact with the last layer).
    pub fn with_substrate_roughness(
        &self,
        roughness: Option<Microfacet>,
    ) -> Result<MonoScene, CoreError> {
        if roughness.is_some()
            && matches!(self.substrate, Substrate::Lambertian { .. } | Substrate::Black)
        {
            return Err(CoreError::scene(
                "substrate.roughness",
                None,
                "a lambertian or black substrate has no face of its own to roughen",
            ));
        }
        Ok(MonoScene { substrate_roughness: roughness, ..self.clone() })
    }

    /// The roughness of the substrate's face (`None`: smooth).
    pub fn substrate_roughness(&self) -> Option<Microfacet> {
        self.substrate_roughness
    }

    /// True when some face of the stack is rough: a layer's top face where
    /// the index changes, or the substrate's face (docs/rough.md §1).
    pub fn has_rough_face(&self) -> bool {
        let mut above = self.ambient_n;
        for l in &self.layers {
            if l.roughness().is_some() && l.n() != above {
                return true;
            }
            above = l.n();
        }
        match self.substrate {
            Substrate::Transparent { n } => self.substrate_roughness.is_some() && n != above,
            Substrate::Conductor { .. } => self.substrate_roughness.is_some(),
            _ => false,
        }
    }

    /// This channel under another light.
    ///
    /// # Errors
    /// An invalid incidence angle.
    pub fn with_light(&self, light: Light) -> Result<MonoScene, CoreError> {
        light.check()?;
        Ok(MonoScene { light, ..self.clone() })
    }

    /// This channel under another ambient index.
    ///
    /// # Errors
    /// `n` not finite or `< 1`.
    pub fn with_ambient_n(&self, ambient_n: f64) -> Result<MonoScene, CoreError> {
        check_ambient_n(ambient_n)?;
        Ok(MonoScene { ambient_n, ..self.clone() })
    }

    /// Illumination.
    pub fn light(&self) -> Light {
        self.light
    }

    /// Refractive index of the clear medium above the stack, finite and `>= 1`.
    pub fn ambient_n(&self) -> f64 {
        self.ambient_n
    }

    /// Layers, top first (at least one; only the last may be a half-space).
    pub fn layers(&self) -> &[Layer] {
        &self.layers
    }

    /// What lies below the stack.
    pub fn substrate(&self) -> Substrate {
        self.substrate
    }

    /// Exit directions `[theta_deg, phi_deg]` for BRDF/BTDF samples
    /// (`theta` from the normal on the exit side, `0 <= theta < 90`).
    pub fn directions_deg(&self) -> &[[f64; 2]] {
        &self.directions_deg
    }

    /// Index of the medium below the stack (`None` for opaque substrates).
    pub fn substrate_n(&self) -> Option<f64> {
        match self.substrate {
            Substrate::Transparent { n } => Some(n),
            _ => None,
        }
    }

    /// The Snell invariant of the collimated beam, `n0 sin(theta)` with `n0`
    /// the ambient index (conserved across every interface of the stack);
    /// `None` for diffuse light.
    pub fn beam_invariant(&self) -> Option<f64> {
        match self.light {
            Light::Collimated { theta_deg } => Some(self.ambient_n * theta_deg.to_radians().sin()),
            Light::Diffuse => None,
        }
    }
}

/// A validated scene: one [`MonoScene`] per spectral channel.
#[derive(Debug, Clone, PartialEq)]
pub struct Scene {
    /// The channels, in order (at least one).
    channels: Vec<MonoScene>,
    /// A label per channel (`"R"`, `"550 nm"`, or the channel number).
    labels: Vec<String>,
    /// Wavelengths in nm when the file gives them.
    wavelengths_nm: Option<Vec<f64>>,
    /// Depths of depth-resolved output (`[output] depths`; empty: none asked).
    depths: Vec<f64>,
    /// Directions of the radiance inside the stack at those depths
    /// (`[output] inside_directions_deg`; empty: none asked).
    inside_directions: Vec<[f64; 2]>,
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
    /// assert_eq!(s.channels().len(), 2);
    /// assert!((s.channels()[1].layers()[0].albedo() - 0.9).abs() < 1e-15);
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

    /// A one-channel scene labelled `"0"` (a [`MonoScene`] is valid by construction).
    pub fn single(mono: MonoScene) -> Scene {
        Scene {
            channels: vec![mono],
            labels: vec!["0".into()],
            wavelengths_nm: None,
            depths: Vec::new(),
            inside_directions: Vec::new(),
        }
    }

    /// A scene from its channels, a label per channel and, optionally, a
    /// wavelength per channel.
    ///
    /// # Errors
    /// No channel, or `labels` (or `wavelengths_nm`) not of one length with
    /// `channels`, or a wavelength not finite and `> 0` (a [`CoreError::Scene`]).
    pub fn new(
        channels: Vec<MonoScene>,
        labels: Vec<String>,
        wavelengths_nm: Option<Vec<f64>>,
    ) -> Result<Scene, CoreError> {
        if channels.is_empty() {
            return Err(CoreError::scene("spectrum", None, "a scene needs at least one channel"));
        }
        if labels.len() != channels.len() {
            return Err(CoreError::scene(
                "spectrum.labels",
                None,
                format!("{} labels for {} channels", labels.len(), channels.len()),
            ));
        }
        if let Some(w) = &wavelengths_nm {
            if w.len() != channels.len() {
                return Err(CoreError::scene(
                    "spectrum.wavelengths_nm",
                    None,
                    format!("{} wavelengths for {} channels", w.len(), channels.len()),
                ));
            }
            if w.iter().any(|&x| !is_wavelength(x)) {
                return Err(CoreError::scene(
                    "spectrum.wavelengths_nm",
                    None,
                    "wavelengths must be > 0",
                ));
            }
        }
        Ok(Scene {
            channels,
            labels,
            wavelengths_nm,
            depths: Vec::new(),
            inside_directions: Vec::new(),
        })
    }

    /// This scene with other channels (same labels, wavelengths and depths).
    ///
    /// # Errors
    /// Those of [`Scene::new`] (a different number of channels).
    pub fn with_channels(&self, channels: Vec<MonoScene>) -> Result<Scene, CoreError> {
        Ok(Scene::new(channels, self.labels.clone(), self.wavelengths_nm.clone())?
            .with_depths(self.depths.clone())
            .with_inside_directions(self.inside_directions.clone()))
    }

    /// This scene with the depths of depth-resolved output (`[output]
    /// depths`, in the layers' length unit; checked by their users).
    pub fn with_depths(mut self, depths: Vec<f64>) -> Scene {
        self.depths = depths;
        self
    }

    /// The depths of depth-resolved output the scene asks for (empty: none).
    pub fn depths(&self) -> &[f64] {
        &self.depths
    }

    /// This scene with the directions `[theta, phi]` (degrees; `theta` from
    /// the downward normal, `< 90` down-going, `> 90` up-going) of the
    /// radiance inside the stack at its depths (`[output]
    /// inside_directions_deg`; checked by their users).
    pub fn with_inside_directions(mut self, directions: Vec<[f64; 2]>) -> Scene {
        self.inside_directions = directions;
        self
    }

    /// The directions of the radiance inside the stack the scene asks for
    /// (empty: none).
    pub fn inside_directions(&self) -> &[[f64; 2]] {
        &self.inside_directions
    }

    /// The channels, in order (at least one).
    pub fn channels(&self) -> &[MonoScene] {
        &self.channels
    }

    /// A label per channel (`"R"`, `"550 nm"`, or the channel number).
    pub fn labels(&self) -> &[String] {
        &self.labels
    }

    /// Wavelengths in nm when the file gives them (one per channel).
    pub fn wavelengths_nm(&self) -> Option<&[f64]> {
        self.wavelengths_nm.as_deref()
    }

    /// The first channel and the others (a scene has at least one channel).
    pub fn split_first(&self) -> (&MonoScene, &[MonoScene]) {
        let (first, rest) = self.channels.split_at(1);
        (&first[0], rest)
    }

    /// The scene of some of this scene's channels, in the order of `keep`
    /// (indices out of range are skipped; an empty selection keeps the first
    /// channel, since a scene has at least one).
    pub fn select(&self, keep: &[usize]) -> Scene {
        let mut keep: Vec<usize> =
            keep.iter().copied().filter(|&i| i < self.channels.len()).collect();
        if keep.is_empty() {
            keep.push(0);
        }
        Scene {
            channels: keep.iter().map(|&i| self.channels[i].clone()).collect(),
            labels: keep.iter().map(|&i| self.labels[i].clone()).collect(),
            wavelengths_nm: self
                .wavelengths_nm
                .as_ref()
                .map(|w| keep.iter().filter_map(|&i| w.get(i).copied()).collect()),
            depths: self.depths.clone(),
            inside_directions: self.inside_directions.clone(),
        }
    }

    /// The channels, labels and wavelengths, taken apart.
    pub fn into_parts(self) -> (Vec<MonoScene>, Vec<String>, Option<Vec<f64>>) {
        (self.channels, self.labels, self.wavelengths_nm)
    }
}

/// True for a wavelength the scene accepts: finite and `> 0` nm.
pub(crate) fn is_wavelength(x: f64) -> bool {
    x.is_finite() && x > 0.0
}

/// A stack: at least one layer, only the last a half-space (each layer is
/// valid by construction; only their order is checked here).
fn check_layers(layers: &[Layer]) -> Result<(), CoreError> {
    if layers.is_empty() {
        return Err(CoreError::scene("layer", None, "the stack has no layer"));
    }
    if let Some(i) = layers.iter().position(Layer::is_half_space)
        && i + 1 != layers.len()
    {
        return Err(CoreError::scene(
            format!("layer[{}].thickness", i + 1),
            None,
            "only the last layer may be a half-space",
        ));
    }
    Ok(())
}

/// The index of the medium above the stack.
fn check_ambient_n(ambient_n: f64) -> Result<(), CoreError> {
    if !is_refractive_index(ambient_n) {
        return Err(CoreError::scene("ambient.n", None, "must be finite and >= 1"));
    }
    Ok(())
}

/// Exit directions: `theta` in `[0, 90)` degrees, `phi` finite.
fn check_directions(directions_deg: &[[f64; 2]]) -> Result<(), CoreError> {
    for d in directions_deg {
        check_theta("output.directions_deg", d[0], None)?;
        if !d[1].is_finite() {
            return Err(CoreError::scene("output.directions_deg", None, "phi must be finite"));
        }
    }
    Ok(())
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
