//! `km.Scene`: a validated scene from keyword arguments, TOML text or a file.

use std::path::PathBuf;

use km::{Light, Scene, Substrate};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

use super::convert::{section, to_toml};
use super::{guarded, py_err};
use crate::error::Error;

/// A validated scene: a stack of layers with its light, ambient medium,
/// substrate, output directions and one or more spectral channels.
///
/// Build it from keyword arguments (the keys of the scene file,
/// docs/scene-file.md), from a scene file's text (`Scene.from_toml`) or from
/// a file (`Scene.from_file`). Every key is checked as the scene file checks
/// it, with the same messages. Scenes are immutable, comparable with `==`
/// and picklable.
///
/// Parameters
/// ----------
/// layers : sequence of mapping
///     The layers, top first, each a mapping of `[[layer]]` keys (see
///     `km.layer`): `sigma_a`, `sigma_s`, `thickness` or `tau`, `albedo`;
///     `g`, `n`, `preset`. A value may be a number or a sequence/array (one
///     value per spectral channel).
/// light : str or mapping, optional
///     `"collimated"` (default) or `"diffuse"`, or a mapping of `[light]`.
/// theta_deg : float, optional
///     Polar angle of a collimated beam, degrees (default 0).
/// ambient_n : float or sequence, optional
///     Refractive index of the medium above the stack (default 1).
/// substrate : str or mapping, optional
///     `"transparent"`, `"lambertian"`, `"black"`, `"conductor"`, or a mapping
///     of `[substrate]` (`{"kind": "lambertian", "albedo": 0.8}`).
/// directions_deg : array_like, optional
///     `[[theta, phi], ...]` exit directions of the BRDF/BTDF samples, degrees.
/// spectrum : mapping, optional
///     `{"labels": [...], "wavelengths_nm": [...]}` of the channels.
///
/// Attributes
/// ----------
/// channels : int
///     Number of spectral channels.
/// labels : list of str
///     Channel labels.
/// wavelengths_nm : list of float or None
///     Wavelengths of the channels, when given.
/// light, substrate : dict
///     The light and the substrate of channel 0.
/// directions_deg : list of [float, float]
///     Exit directions of the BRDF/BTDF samples.
///
/// Raises
/// ------
/// KmError
///     A key that is unknown, missing or out of its range (`key` names it).
/// KmTypeError
///     A value that cannot stand in a scene (an object where a number belongs).
///
/// Examples
/// --------
/// >>> import km
/// >>> s = km.Scene(layers=[km.layer(tau=[1.0, 2.0], albedo=0.9, g=0.5)],
/// ...              theta_deg=30.0, substrate={"kind": "lambertian", "albedo": 0.5})
/// >>> s.channels
/// 2
/// >>> km.Scene.from_toml(s.to_toml()) == s
/// True
#[pyclass(frozen, name = "Scene", module = "km")]
pub struct PyScene {
    pub(crate) scene: Scene,
    pub(crate) toml: String,
}

impl PyScene {
    fn parse(py: Python<'_>, text: String) -> PyResult<PyScene> {
        let scene = guarded(py, || Ok(Scene::from_toml_str(&text)?))?;
        Ok(PyScene { scene, toml: text })
    }
}

#[pymethods]
impl PyScene {
    /// A scene from keyword arguments (the keys of the scene file).
    #[new]
    #[pyo3(signature = (layers, *, light=None, theta_deg=None, ambient_n=None, substrate=None,
                        directions_deg=None, spectrum=None))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        py: Python<'_>,
        layers: &Bound<'_, PyAny>,
        light: Option<&Bound<'_, PyAny>>,
        theta_deg: Option<&Bound<'_, PyAny>>,
        ambient_n: Option<&Bound<'_, PyAny>>,
        substrate: Option<&Bound<'_, PyAny>>,
        directions_deg: Option<&Bound<'_, PyAny>>,
        spectrum: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<PyScene> {
        let mut t = toml::Table::new();
        // [light]: a kind, a mapping, and/or theta_deg.
        let mut light_t = match light {
            Some(l) => section(py, "light", l)?,
            None => toml::Table::new(),
        };
        if let Some(th) = theta_deg {
            light_t.insert("theta_deg".into(), to_toml(py, "light.theta_deg", th)?);
        }
        if !light_t.is_empty() {
            t.insert("light".into(), toml::Value::Table(light_t));
        }
        if let Some(n) = ambient_n {
            let n = to_toml(py, "ambient.n", n)?;
            t.insert(
                "ambient".into(),
                toml::Value::Table(toml::Table::from_iter([("n".into(), n)])),
            );
        }
        // [[layer]]: a sequence of mappings (dicts or km.Layer).
        let mut list = Vec::new();
        for (i, l) in layers.try_iter()?.enumerate() {
            let l = l?;
            let l = if l.hasattr("to_dict")? { l.call_method0("to_dict")? } else { l };
            let key = format!("layer[{}]", i + 1);
            match to_toml(py, &key, &l)? {
                toml::Value::Table(lt) => list.push(toml::Value::Table(lt)),
                _ => {
                    return Err(py_err(
                        py,
                        Error::Scene(km::CoreError::scene(
                            key,
                            None,
                            "a layer is a mapping of its keys (sigma_a, sigma_s, thickness, \
                             tau, albedo, g, n, preset)",
                        )),
                    ));
                }
            }
        }
        t.insert("layer".into(), toml::Value::Array(list));
        if let Some(s) = substrate {
            t.insert("substrate".into(), toml::Value::Table(section(py, "substrate", s)?));
        }
        if let Some(d) = directions_deg {
            let d = to_toml(py, "output.directions_deg", d)?;
            let out = toml::Table::from_iter([("directions_deg".to_string(), d)]);
            t.insert("output".into(), toml::Value::Table(out));
        }
        if let Some(s) = spectrum {
            t.insert("spectrum".into(), to_toml(py, "spectrum", s)?);
        }
        let (scene, toml) = guarded(py, || crate::build::scene_from_table(&t))?;
        Ok(PyScene { scene, toml })
    }

    /// A scene from the text of a scene file (TOML, docs/scene-file.md).
    ///
    /// Parameters
    /// ----------
    /// text : str
    ///     The scene file's text.
    ///
    /// Returns
    /// -------
    /// Scene
    ///
    /// Raises
    /// ------
    /// KmError
    ///     An invalid scene, naming the key and the line.
    ///
    /// Examples
    /// --------
    /// >>> km.Scene.from_toml("[[layer]]\ntau = 1.0\nalbedo = 0.9\n").channels
    /// 1
    #[staticmethod]
    fn from_toml(py: Python<'_>, text: String) -> PyResult<PyScene> {
        PyScene::parse(py, text)
    }

    /// A scene from a scene file on disk.
    ///
    /// Parameters
    /// ----------
    /// path : str or path-like
    ///     The scene file (TOML, docs/scene-file.md); at most
    ///     `KM_MAX_SCENE_BYTES` bytes, a regular file.
    ///
    /// Returns
    /// -------
    /// Scene
    ///
    /// Raises
    /// ------
    /// KmFileNotFoundError
    ///     The file does not exist (also a `FileNotFoundError`).
    /// KmError
    ///     A file that cannot be read, or an invalid scene (key and line named).
    ///
    /// Examples
    /// --------
    /// >>> km.Scene.from_file("examples/seed-three-layers.toml")  # doctest: +SKIP
    /// km.Scene(3 layer(s), 1 channel(s), 3 direction(s))
    #[staticmethod]
    fn from_file(py: Python<'_>, path: PathBuf) -> PyResult<PyScene> {
        // The checked reader of `km`: a FIFO or /dev/zero is refused before
        // opening, and the size limit holds (KM_MAX_SCENE_BYTES).
        let limits = km::SceneLimits::from_env();
        let text = km::read_scene_text(&path, limits.max_bytes)
            .map_err(|e| super::file_err(py, &path, Error::Scene(e)))?;
        PyScene::parse(py, text)
    }

    /// The scene as the text of a scene file (`km check` and `km solve` read it).
    fn to_toml(&self) -> String {
        self.toml.clone()
    }

    /// Number of spectral channels.
    #[getter]
    fn channels(&self) -> usize {
        self.scene.channels().len()
    }

    /// Channel labels.
    #[getter]
    fn labels(&self) -> Vec<String> {
        self.scene.labels().to_vec()
    }

    /// Wavelengths (nm) when the scene gives them.
    #[getter]
    fn wavelengths_nm(&self) -> Option<Vec<f64>> {
        self.scene.wavelengths_nm().map(<[f64]>::to_vec)
    }

    /// The layers of one channel, top first, as dicts of their derived values.
    ///
    /// Parameters
    /// ----------
    /// channel : int, default 0
    ///     The channel.
    ///
    /// Returns
    /// -------
    /// list of dict
    ///     Per layer: sigma_a, sigma_s, sigma_t, thickness, tau, albedo, g, n.
    #[pyo3(signature = (channel=0))]
    fn layers<'py>(&self, py: Python<'py>, channel: usize) -> PyResult<Bound<'py, PyList>> {
        let c = self.scene.channels().get(channel).ok_or_else(|| {
            py_err(
                py,
                Error::option("channel", format!("the scene has {} channel(s)", self.channels())),
            )
        })?;
        let list = PyList::empty(py);
        for l in c.layers() {
            let d = PyDict::new(py);
            d.set_item("sigma_a", l.sigma_a())?;
            d.set_item("sigma_s", l.sigma_s())?;
            d.set_item("sigma_t", l.sigma_t())?;
            d.set_item("thickness", l.thickness())?;
            d.set_item("tau", l.tau())?;
            d.set_item("albedo", l.albedo())?;
            d.set_item("g", l.g())?;
            d.set_item("n", l.n())?;
            list.append(d)?;
        }
        Ok(list)
    }

    /// The light: `{"kind": "collimated", "theta_deg": ...}` or `{"kind": "diffuse"}`.
    #[getter]
    fn light<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        match self.scene.channels()[0].light() {
            Light::Collimated { theta_deg } => {
                d.set_item("kind", "collimated")?;
                d.set_item("theta_deg", theta_deg)?;
            }
            Light::Diffuse => d.set_item("kind", "diffuse")?,
        }
        Ok(d)
    }

    /// The substrate of channel 0: `{"kind": ..., "n" or "albedo" or "n", "k": ...}`.
    #[getter]
    fn substrate<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        match self.scene.channels()[0].substrate() {
            Substrate::Transparent { n } => {
                d.set_item("kind", "transparent")?;
                d.set_item("n", n)?;
            }
            Substrate::Lambertian { albedo } => {
                d.set_item("kind", "lambertian")?;
                d.set_item("albedo", albedo)?;
            }
            Substrate::Black => d.set_item("kind", "black")?,
            Substrate::Conductor { n, k } => {
                d.set_item("kind", "conductor")?;
                d.set_item("n", n)?;
                d.set_item("k", k)?;
            }
        }
        Ok(d)
    }

    /// Exit directions `[theta_deg, phi_deg]` of the BRDF/BTDF samples.
    #[getter]
    fn directions_deg(&self) -> Vec<[f64; 2]> {
        self.scene.channels()[0].directions_deg().to_vec()
    }

    fn __repr__(&self) -> String {
        let c = &self.scene.channels()[0];
        format!(
            "km.Scene({} layer(s), {} channel(s), {} direction(s))",
            c.layers().len(),
            self.scene.channels().len(),
            c.directions_deg().len()
        )
    }

    fn __eq__(&self, other: &Bound<'_, PyAny>) -> bool {
        other.cast::<PyScene>().map(|o| o.get().scene == self.scene).unwrap_or(false)
    }

    fn __reduce__<'py>(slf: &Bound<'py, Self>) -> PyResult<(Bound<'py, PyAny>, (String,))> {
        let f = slf.get_type().getattr("from_toml")?;
        Ok((f, (slf.get().toml.clone(),)))
    }
}
