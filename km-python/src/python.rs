//! The extension module `km._km` (feature `python`): thin wrappers of
//! [`crate::engine`], [`crate::build`], [`crate::sweep`] and the Monte Carlo
//! shards, with the GIL released while Rust works.
//!
//! Every error is a `km.KmError` (a `ValueError`) with attributes `key` and
//! `line`; a panic inside a solver is caught at this boundary and becomes a
//! `km.KmError` too (a last guard: solvers return errors, they do not panic).

use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::PathBuf;

use km_core::solution::UncertaintyValue;
use km_core::{Light, Scene, Solution, Substrate, Uncertainty};
use numpy::{IntoPyArray, PyArrayMethods, PyReadonlyArray2};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyList, PyString, PyTuple};
use serde_json::Value;

use crate::engine::Options;
use crate::error::Error;
use crate::sweep::{Columns, Target};
use km::Method;

pyo3::create_exception!(
    km,
    KmError,
    PyValueError,
    "Bad input to km: a scene, an option or a method that cannot treat the scene.\n\n\
     Attributes: `key` (the scene key or option named, or None) and `line`\n\
     (1-based line of the scene text, or None)."
);

/// A `km.KmError` with `key` and `line` set.
fn py_err(py: Python<'_>, e: Error) -> PyErr {
    let err = KmError::new_err(e.to_string());
    let v = err.value(py);
    // Setting attributes on a fresh exception instance cannot fail in practice;
    // if it did, the message still carries key and line.
    let _ = v.setattr("key", e.key());
    let _ = v.setattr("line", e.line());
    err
}

/// Run `f` with the GIL released, turning a panic into [`Error::Internal`].
fn guarded<T: Send>(py: Python<'_>, f: impl FnOnce() -> Result<T, Error> + Send) -> PyResult<T> {
    py.detach(|| {
        catch_unwind(AssertUnwindSafe(f)).unwrap_or_else(|p| {
            let msg = p
                .downcast_ref::<String>()
                .cloned()
                .or_else(|| p.downcast_ref::<&str>().map(|s| s.to_string()))
                .unwrap_or_else(|| "panic".into());
            Err(Error::Internal(msg))
        })
    })
    .map_err(|e| py_err(py, e))
}

// ---------------------------------------------------------------------------
// Python values -> the scene file's TOML values.

fn to_toml(py: Python<'_>, key: &str, obj: &Bound<'_, PyAny>) -> PyResult<toml::Value> {
    let refuse = |what: String| {
        py_err(
            py,
            Error::Scene(km_core::CoreError::scene(
                key,
                None,
                format!("{what} cannot be a value of the scene file"),
            )),
        )
    };
    if obj.is_instance_of::<PyBool>() {
        return Ok(toml::Value::Boolean(obj.extract()?));
    }
    if obj.is_instance_of::<PyInt>() {
        return match obj.extract::<i64>() {
            Ok(i) => Ok(toml::Value::Integer(i)),
            Err(_) => Ok(toml::Value::Float(obj.extract::<f64>()?)),
        };
    }
    if obj.is_instance_of::<PyFloat>() {
        return Ok(toml::Value::Float(obj.extract()?));
    }
    if let Ok(s) = obj.cast::<PyString>() {
        return Ok(toml::Value::String(s.to_str()?.to_string()));
    }
    if let Ok(d) = obj.cast::<PyDict>() {
        let mut t = toml::Table::new();
        for (k, v) in d.iter() {
            let k: String = k.extract().map_err(|_| refuse("a key that is not a string".into()))?;
            let sub = format!("{key}.{k}");
            t.insert(k, to_toml(py, &sub, &v)?);
        }
        return Ok(toml::Value::Table(t));
    }
    // numpy arrays and scalars: through their plain Python form.
    if obj.hasattr("tolist")? && !obj.is_instance_of::<PyList>() {
        return to_toml(py, key, &obj.call_method0("tolist")?);
    }
    if obj.is_instance_of::<PyList>() || obj.is_instance_of::<PyTuple>() {
        let mut items = Vec::new();
        for v in obj.try_iter()? {
            items.push(to_toml(py, key, &v?)?);
        }
        return Ok(toml::Value::Array(items));
    }
    if let Ok(x) = obj.extract::<f64>() {
        return Ok(toml::Value::Float(x));
    }
    Err(refuse(format!("a value of type {}", obj.get_type().name()?)))
}

/// A section given as a kind name (`"diffuse"`) or a mapping of its keys.
fn section(py: Python<'_>, key: &str, obj: &Bound<'_, PyAny>) -> PyResult<toml::Table> {
    match to_toml(py, key, obj)? {
        toml::Value::String(kind) => {
            Ok(toml::Table::from_iter([("kind".to_string(), toml::Value::String(kind))]))
        }
        toml::Value::Table(t) => Ok(t),
        _ => Err(py_err(
            py,
            Error::Scene(km_core::CoreError::scene(
                key,
                None,
                "expected a kind (a string) or a mapping of the section's keys",
            )),
        )),
    }
}

// ---------------------------------------------------------------------------
// JSON values -> Python.

fn json_to_py<'py>(py: Python<'py>, v: &Value) -> PyResult<Bound<'py, PyAny>> {
    Ok(match v {
        Value::Null => py.None().into_bound(py),
        Value::Bool(b) => PyBool::new(py, *b).to_owned().into_any(),
        Value::Number(n) => match (n.as_i64(), n.as_u64()) {
            (Some(i), _) if !n.is_f64() => i.into_pyobject(py)?.into_any(),
            (_, Some(u)) if !n.is_f64() => u.into_pyobject(py)?.into_any(),
            _ => n.as_f64().unwrap_or(f64::NAN).into_pyobject(py)?.into_any(),
        },
        Value::String(s) => PyString::new(py, s).into_any(),
        Value::Array(a) => {
            let list = PyList::empty(py);
            for x in a {
                list.append(json_to_py(py, x)?)?;
            }
            list.into_any()
        }
        Value::Object(o) => {
            let d = PyDict::new(py);
            for (k, x) in o {
                d.set_item(k, json_to_py(py, x)?)?;
            }
            d.into_any()
        }
    })
}

// ---------------------------------------------------------------------------
// Scene

/// A validated scene: one or more spectral channels of a layer stack.
///
/// Build it from a scene file's text (`Scene.from_toml`), a file
/// (`Scene.from_file`) or keyword arguments (`Scene(layers=[...], ...)`);
/// see docs/python.md. Scenes are immutable and picklable.
#[pyclass(frozen, name = "Scene", module = "km")]
pub struct PyScene {
    scene: Scene,
    toml: String,
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
                        Error::Scene(km_core::CoreError::scene(
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
    #[staticmethod]
    fn from_toml(py: Python<'_>, text: String) -> PyResult<PyScene> {
        PyScene::parse(py, text)
    }

    /// A scene from a scene file on disk.
    #[staticmethod]
    fn from_file(py: Python<'_>, path: PathBuf) -> PyResult<PyScene> {
        let text = std::fs::read_to_string(&path).map_err(|e| {
            py_err(
                py,
                Error::Scene(km_core::CoreError::scene(
                    "file",
                    None,
                    format!("cannot read {}: {e}", path.display()),
                )),
            )
        })?;
        PyScene::parse(py, text)
    }

    /// The scene as the text of a scene file (`km check` and `km solve` read it).
    fn to_toml(&self) -> String {
        self.toml.clone()
    }

    /// Number of spectral channels.
    #[getter]
    fn channels(&self) -> usize {
        self.scene.channels.len()
    }

    /// Channel labels.
    #[getter]
    fn labels(&self) -> Vec<String> {
        self.scene.labels.clone()
    }

    /// Wavelengths (nm) when the scene gives them.
    #[getter]
    fn wavelengths_nm(&self) -> Option<Vec<f64>> {
        self.scene.wavelengths_nm.clone()
    }

    /// The layers of one channel, top first, as dicts of their derived values
    /// (sigma_a, sigma_s, sigma_t, thickness, tau, albedo, g, n).
    #[pyo3(signature = (channel=0))]
    fn layers<'py>(&self, py: Python<'py>, channel: usize) -> PyResult<Bound<'py, PyList>> {
        let c = self.scene.channels.get(channel).ok_or_else(|| {
            py_err(
                py,
                Error::option("channel", format!("the scene has {} channel(s)", self.channels())),
            )
        })?;
        let list = PyList::empty(py);
        for l in &c.layers {
            let d = PyDict::new(py);
            d.set_item("sigma_a", l.sigma_a)?;
            d.set_item("sigma_s", l.sigma_s)?;
            d.set_item("sigma_t", l.sigma_t())?;
            d.set_item("thickness", l.thickness)?;
            d.set_item("tau", l.tau())?;
            d.set_item("albedo", l.albedo())?;
            d.set_item("g", l.g())?;
            d.set_item("n", l.n)?;
            list.append(d)?;
        }
        Ok(list)
    }

    /// The light: `{"kind": "collimated", "theta_deg": ...}` or `{"kind": "diffuse"}`.
    #[getter]
    fn light<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        match self.scene.channels[0].light {
            Light::Collimated { theta_deg } => {
                d.set_item("kind", "collimated")?;
                d.set_item("theta_deg", theta_deg)?;
            }
            Light::Diffuse => d.set_item("kind", "diffuse")?,
        }
        Ok(d)
    }

    /// The substrate of channel 0: `{"kind": ..., "n" or "albedo": ...}`.
    #[getter]
    fn substrate<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        match self.scene.channels[0].substrate {
            Substrate::Transparent { n } => {
                d.set_item("kind", "transparent")?;
                d.set_item("n", n)?;
            }
            Substrate::Lambertian { albedo } => {
                d.set_item("kind", "lambertian")?;
                d.set_item("albedo", albedo)?;
            }
            Substrate::Black => d.set_item("kind", "black")?,
        }
        Ok(d)
    }

    /// Exit directions `[theta_deg, phi_deg]` of the BRDF/BTDF samples.
    #[getter]
    fn directions_deg(&self) -> Vec<[f64; 2]> {
        self.scene.channels[0].directions_deg.clone()
    }

    fn __repr__(&self) -> String {
        let c = &self.scene.channels[0];
        format!(
            "km.Scene({} layer(s), {} channel(s), {} direction(s))",
            c.layers.len(),
            self.scene.channels.len(),
            c.directions_deg.len()
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

// ---------------------------------------------------------------------------
// Solution

/// What a solve returns: totals, BRDF/BTDF samples, uncertainties, the plan.
///
/// For a one-channel scene the totals are floats and `brdf`/`btdf` 1-D
/// arrays; for several channels each total is an array over channels and
/// `brdf`/`btdf` are `channels x directions`. `to_dict()` is the
/// `km solve --json` object.
#[pyclass(frozen, name = "Solution", module = "km")]
pub struct PySolution {
    sol: Solution,
}

impl PySolution {
    fn per_channel<'py>(
        &self,
        py: Python<'py>,
        get: impl Fn(&km_core::ChannelResult) -> f64,
    ) -> PyResult<Bound<'py, PyAny>> {
        let v: Vec<f64> = self.sol.channels.iter().map(get).collect();
        if v.len() == 1 {
            Ok(v[0].into_pyobject(py)?.into_any())
        } else {
            Ok(v.into_pyarray(py).into_any())
        }
    }

    fn angular<'py>(
        &self,
        py: Python<'py>,
        get: impl Fn(&km_core::ChannelResult) -> &Vec<f64>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let ch = &self.sol.channels;
        let d = ch.first().map(|c| get(c).len()).unwrap_or(0);
        if ch.len() == 1 {
            return Ok(get(&ch[0]).clone().into_pyarray(py).into_any());
        }
        let flat: Vec<f64> = ch
            .iter()
            .flat_map(|c| {
                let v = get(c);
                (0..d).map(move |i| v.get(i).copied().unwrap_or(f64::NAN))
            })
            .collect();
        Ok(flat.into_pyarray(py).reshape([ch.len(), d])?.into_any())
    }

    /// An uncertainty (stderr, error_estimate) as a dict: per key a float
    /// (one channel) or an array over channels; list entries (brdf, btdf,
    /// per-layer absorptance) become arrays, `channels x len` for several
    /// channels; a value missing in a channel is NaN.
    fn per_key<'py>(
        &self,
        py: Python<'py>,
        get: impl Fn(&km_core::ChannelResult) -> Option<&Uncertainty>,
    ) -> PyResult<Option<Bound<'py, PyDict>>> {
        if self.sol.channels.iter().all(|c| get(c).is_none()) {
            return Ok(None);
        }
        let mut keys: Vec<(&'static str, Option<usize>)> = Vec::new();
        for c in &self.sol.channels {
            for (k, v) in get(c).map(Uncertainty::entries).unwrap_or_default() {
                if !keys.iter().any(|(q, _)| *q == k) {
                    let len = match v {
                        UncertaintyValue::Number(_) => None,
                        UncertaintyValue::List(l) => Some(l.len()),
                    };
                    keys.push((k, len));
                }
            }
        }
        let d = PyDict::new(py);
        for (k, len) in keys {
            let value = match len {
                None => {
                    self.per_channel(py, |c| get(c).and_then(|u| u.get(k)).unwrap_or(f64::NAN))?
                }
                Some(len) => {
                    let ch = &self.sol.channels;
                    let flat: Vec<f64> = ch
                        .iter()
                        .flat_map(|c| {
                            let l = get(c).and_then(|u| u.get_list(k));
                            (0..len)
                                .map(move |i| l.and_then(|l| l.get(i)).copied().unwrap_or(f64::NAN))
                        })
                        .collect();
                    if ch.len() == 1 {
                        flat.into_pyarray(py).into_any()
                    } else {
                        flat.into_pyarray(py).reshape([ch.len(), len])?.into_any()
                    }
                }
            };
            d.set_item(k, value)?;
        }
        Ok(Some(d))
    }
}

#[pymethods]
impl PySolution {
    /// Method name (`km`, `multiflux`, `mc`, `dipole`).
    #[getter]
    fn method(&self) -> String {
        self.sol.method.clone()
    }
    /// Number of channels.
    #[getter]
    fn channels(&self) -> usize {
        self.sol.channels.len()
    }
    /// Channel labels.
    #[getter]
    fn labels(&self) -> Vec<String> {
        self.sol.labels.clone()
    }
    /// Total reflectance (specular part included).
    #[getter]
    fn reflectance<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        self.per_channel(py, |c| c.reflectance)
    }
    /// The mirror (delta) part of the reflectance.
    #[getter]
    fn reflectance_specular<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        self.per_channel(py, |c| c.reflectance_specular)
    }
    /// Total transmittance (unscattered part included).
    #[getter]
    fn transmittance<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        self.per_channel(py, |c| c.transmittance)
    }
    /// The unscattered (delta) part of the transmittance.
    #[getter]
    fn transmittance_direct<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        self.per_channel(py, |c| c.transmittance_direct)
    }
    /// Absorbed fraction.
    #[getter]
    fn absorptance<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        self.per_channel(py, |c| c.absorptance)
    }
    /// Smooth BRDF (1/sr) at the scene's output directions.
    #[getter]
    fn brdf<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        self.angular(py, |c| &c.brdf)
    }
    /// Smooth BTDF (1/sr) at the scene's output directions.
    #[getter]
    fn btdf<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        self.angular(py, |c| &c.btdf)
    }
    /// Absorbed fraction per layer (top first), when the method gives it.
    #[getter]
    fn absorptance_layers<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyAny>>> {
        if self.sol.channels.iter().any(|c| c.absorptance_layers.is_none()) {
            return Ok(None);
        }
        let empty = Vec::new();
        let get = |c: &km_core::ChannelResult| -> Vec<f64> {
            c.absorptance_layers.as_ref().unwrap_or(&empty).clone()
        };
        let ch = &self.sol.channels;
        if ch.len() == 1 {
            return Ok(Some(get(&ch[0]).into_pyarray(py).into_any()));
        }
        let d = get(&ch[0]).len();
        let flat: Vec<f64> = ch.iter().flat_map(get).collect();
        if flat.len() != d * ch.len() {
            return Ok(None);
        }
        Ok(Some(flat.into_pyarray(py).reshape([ch.len(), d])?.into_any()))
    }
    /// Standard errors by key (Monte Carlo), or None.
    #[getter]
    fn stderr<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyDict>>> {
        self.per_key(py, |c| c.stderr.as_ref())
    }
    /// Estimated errors by key (an accuracy target was given), or None.
    #[getter]
    fn error_estimate<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyDict>>> {
        self.per_key(py, |c| c.error_estimate.as_ref())
    }
    /// Notes of the solver (what it simplified, bounds of what it neglected).
    #[getter]
    fn notes(&self) -> Vec<String> {
        self.sol.notes.clone()
    }
    /// The plan obeyed: effects present, work skipped and why (a dict), or None.
    #[getter]
    fn plan<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        match &self.sol.plan {
            Some(p) => json_to_py(py, &p.to_json()),
            None => Ok(py.None().into_bound(py)),
        }
    }
    /// How an accuracy target was met (the JSON's `tolerance` object), or None.
    #[getter]
    fn accuracy<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        match (&self.sol.accuracy, self.sol.to_json().get("tolerance")) {
            (Some(_), Some(v)) => json_to_py(py, v),
            _ => Ok(py.None().into_bound(py)),
        }
    }
    /// The output directions `[theta_deg, phi_deg]` of `brdf`/`btdf`.
    #[getter]
    fn directions_deg(&self) -> Vec<[f64; 2]> {
        self.sol.directions.clone()
    }
    /// Method settings and diagnostics (`streams`, `fourier_orders`, ...), a dict.
    #[getter]
    fn extra<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        json_to_py(py, &Value::Object(self.sol.extra.clone()))
    }
    /// The solver's own wall time, seconds.
    #[getter]
    fn seconds(&self) -> f64 {
        self.sol.seconds
    }
    /// The `km solve --json` object, as a dict.
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        json_to_py(py, &self.sol.to_json())
    }
    /// The `km solve --json` object, as text.
    #[pyo3(signature = (indent=false))]
    fn to_json(&self, indent: bool) -> String {
        let v = self.sol.to_json();
        if indent { serde_json::to_string_pretty(&v).unwrap_or_default() } else { v.to_string() }
    }
    fn __repr__(&self) -> String {
        let c = &self.sol.channels;
        match c.len() {
            1 => format!(
                "km.Solution(method={:?}, reflectance={:.6}, transmittance={:.6}, absorptance={:.6})",
                self.sol.method, c[0].reflectance, c[0].transmittance, c[0].absorptance
            ),
            n => format!("km.Solution(method={:?}, {n} channels)", self.sol.method),
        }
    }
}

// ---------------------------------------------------------------------------
// Monte Carlo shards

/// The partial tally of one Monte Carlo shard (`km.run_shard`); `km.merge`
/// combines shards into exactly the single-run result. Picklable (exact).
#[pyclass(frozen, name = "Partial", module = "km")]
pub struct PyPartial {
    part: km_montecarlo::Partial,
}

#[pymethods]
impl PyPartial {
    /// A partial tally from its JSON text (the `km solve --shard` file format).
    #[staticmethod]
    fn from_json(py: Python<'_>, text: &str) -> PyResult<PyPartial> {
        let part = serde_json::from_str(text).map_err(|e| {
            py_err(py, Error::Solver(format!("not a km shard (partial tally): {e}")))
        })?;
        Ok(PyPartial { part })
    }
    /// The partial tally as JSON text (the format of `km solve --shard --out`,
    /// which `km merge` reads; sums kept bit for bit).
    fn to_json(&self) -> String {
        serde_json::to_string(&self.part).unwrap_or_default()
    }
    /// This shard's index.
    #[getter]
    fn index(&self) -> u64 {
        self.part.shard_index
    }
    /// Number of shards of the run.
    #[getter]
    fn count(&self) -> u64 {
        self.part.shard_count
    }
    /// Photons of the whole run, per channel.
    #[getter]
    fn samples(&self) -> u64 {
        self.part.options.samples
    }
    /// Seed of the run.
    #[getter]
    fn seed(&self) -> u64 {
        self.part.options.seed
    }
    /// Tracing wall time of this shard, seconds.
    #[getter]
    fn seconds(&self) -> f64 {
        self.part.seconds
    }
    fn __repr__(&self) -> String {
        format!(
            "km.Partial(shard {}/{}, {} batches, samples={}, seed={})",
            self.part.shard_index,
            self.part.shard_count,
            self.part.batches.len(),
            self.part.options.samples,
            self.part.options.seed
        )
    }
    fn __reduce__<'py>(slf: &Bound<'py, Self>) -> PyResult<(Bound<'py, PyAny>, (String,))> {
        let f = slf.get_type().getattr("from_json")?;
        Ok((f, (slf.get().to_json(),)))
    }
}

// ---------------------------------------------------------------------------
// Functions

#[allow(clippy::too_many_arguments)]
fn options(
    py: Python<'_>,
    method: &str,
    streams: Option<usize>,
    order: Option<usize>,
    samples: Option<u64>,
    seed: Option<u64>,
    tolerance: Option<f64>,
    threads: Option<usize>,
    analog: bool,
    all_effects: bool,
) -> PyResult<Options> {
    let method: Method = crate::engine::method(method).map_err(|e| py_err(py, e))?;
    Ok(Options { method, streams, order, samples, seed, tolerance, threads, analog, all_effects })
}

/// Solve a scene (see `km.solve`).
#[pyfunction]
#[pyo3(signature = (scene, method="multiflux", *, streams=None, order=None, samples=None,
                    seed=None, tolerance=None, threads=None, analog=false, all_effects=false))]
#[allow(clippy::too_many_arguments)]
fn solve(
    py: Python<'_>,
    scene: &Bound<'_, PyScene>,
    method: &str,
    streams: Option<usize>,
    order: Option<usize>,
    samples: Option<u64>,
    seed: Option<u64>,
    tolerance: Option<f64>,
    threads: Option<usize>,
    analog: bool,
    all_effects: bool,
) -> PyResult<PySolution> {
    let opts = options(
        py,
        method,
        streams,
        order,
        samples,
        seed,
        tolerance,
        threads,
        analog,
        all_effects,
    )?;
    let scene = &scene.get().scene;
    let sol = guarded(py, || crate::engine::solve(scene, &opts))?;
    Ok(PySolution { sol })
}

/// The columns of a batch as a dict of numpy arrays (flat point axis).
fn columns_dict<'py>(
    py: Python<'py>,
    results: Vec<Result<Solution, Error>>,
    channels: usize,
    directions: usize,
    labels: Vec<String>,
    errors: &str,
) -> PyResult<Bound<'py, PyDict>> {
    if errors == "raise"
        && let Some((i, e)) =
            results.iter().enumerate().find_map(|(i, r)| r.as_ref().err().map(|e| (i, e)))
    {
        let e = Error::Point { index: i, source: Box::new(clone_error(e)) };
        return Err(py_err(py, e));
    }
    let cols = py.detach(|| Columns::gather(&results, channels, directions));
    let (n, c, d) = (cols.n, cols.channels, cols.directions);
    let out = PyDict::new(py);
    for (k, v) in cols.scalars {
        out.set_item(k, v.into_pyarray(py).reshape([n, c])?)?;
    }
    out.set_item("brdf", cols.brdf.into_pyarray(py).reshape([n, c, d])?)?;
    out.set_item("btdf", cols.btdf.into_pyarray(py).reshape([n, c, d])?)?;
    for (name, map) in [("stderr", cols.stderr), ("error_estimate", cols.error_estimate)] {
        if map.is_empty() {
            out.set_item(name, py.None())?;
        } else {
            let sub = PyDict::new(py);
            for (k, v) in map {
                sub.set_item(k, v.into_pyarray(py).reshape([n, c])?)?;
            }
            out.set_item(name, sub)?;
        }
    }
    out.set_item("errors", cols.errors)?;
    out.set_item("labels", labels)?;
    Ok(out)
}

/// A copy of an error for the message of a batch (errors are not `Clone`).
fn clone_error(e: &Error) -> Error {
    match e {
        Error::Scene(c) => Error::Scene(c.clone()),
        Error::Option { name, reason } => {
            Error::Option { name: name.clone(), reason: reason.clone() }
        }
        other => Error::Solver(other.to_string()),
    }
}

fn check_errors_mode(py: Python<'_>, errors: &str) -> PyResult<()> {
    if errors != "raise" && errors != "nan" {
        return Err(py_err(
            py,
            Error::option("errors", format!("\"{errors}\": expected \"raise\" or \"nan\"")),
        ));
    }
    Ok(())
}

/// Batch solve of a list of scenes (see `km.solve_many`).
#[pyfunction]
#[pyo3(signature = (scenes, method="multiflux", *, streams=None, order=None, samples=None,
                    seed=None, tolerance=None, threads=None, analog=false, all_effects=false,
                    errors="raise"))]
#[allow(clippy::too_many_arguments)]
fn _solve_scenes<'py>(
    py: Python<'py>,
    scenes: Vec<Bound<'py, PyScene>>,
    method: &str,
    streams: Option<usize>,
    order: Option<usize>,
    samples: Option<u64>,
    seed: Option<u64>,
    tolerance: Option<f64>,
    threads: Option<usize>,
    analog: bool,
    all_effects: bool,
    errors: &str,
) -> PyResult<Bound<'py, PyDict>> {
    check_errors_mode(py, errors)?;
    let opts =
        options(py, method, streams, order, samples, seed, tolerance, None, analog, all_effects)?;
    let list: Vec<Scene> = scenes.iter().map(|s| s.get().scene.clone()).collect();
    let Some(first) = list.first() else {
        return Err(py_err(py, Error::option("scenes", "the batch is empty")));
    };
    let (channels, directions) = (first.channels.len(), first.channels[0].directions_deg.len());
    if let Some(i) = list.iter().position(|s| {
        s.channels.len() != channels || s.channels[0].directions_deg.len() != directions
    }) {
        return Err(py_err(
            py,
            Error::option(
                "scenes",
                format!(
                    "scene {i} has another number of channels or output directions than scene 0 \
                     (a batch returns arrays of one shape)"
                ),
            ),
        ));
    }
    let labels = first.labels.clone();
    let results = guarded(py, || crate::sweep::solve_many(&list, &opts, threads))?;
    columns_dict(py, results, channels, directions, labels, errors)
}

/// Batch solve of a parameter sweep of one scene (see `km.solve_many`).
#[pyfunction]
#[pyo3(signature = (scene, keys, values, method="multiflux", *, streams=None, order=None,
                    samples=None, seed=None, tolerance=None, threads=None, analog=false,
                    all_effects=false, errors="raise"))]
#[allow(clippy::too_many_arguments)]
fn _solve_sweep<'py>(
    py: Python<'py>,
    scene: &Bound<'py, PyScene>,
    keys: Vec<String>,
    values: PyReadonlyArray2<'py, f64>,
    method: &str,
    streams: Option<usize>,
    order: Option<usize>,
    samples: Option<u64>,
    seed: Option<u64>,
    tolerance: Option<f64>,
    threads: Option<usize>,
    analog: bool,
    all_effects: bool,
    errors: &str,
) -> PyResult<Bound<'py, PyDict>> {
    check_errors_mode(py, errors)?;
    let opts =
        options(py, method, streams, order, samples, seed, tolerance, None, analog, all_effects)?;
    let targets = keys
        .iter()
        .map(|k| k.parse::<Target>())
        .collect::<Result<Vec<_>, _>>()
        .map_err(|e| py_err(py, e))?;
    let view = values.as_array();
    if view.ncols() != targets.len() {
        return Err(py_err(py, Error::option("params", "one column of values per key")));
    }
    let flat: Vec<f64> = view.iter().copied().collect();
    let base = &scene.get().scene;
    let (channels, directions) = (base.channels.len(), base.channels[0].directions_deg.len());
    let results = guarded(py, || crate::sweep::solve_sweep(base, &targets, &flat, &opts, threads))?;
    columns_dict(py, results, channels, directions, base.labels.clone(), errors)
}

/// One shard of a Monte Carlo run (see `km.run_shard`).
#[pyfunction]
#[pyo3(signature = (scene, index, count, *, samples=None, seed=None, threads=None,
                    analog=false, all_effects=false))]
#[allow(clippy::too_many_arguments)]
fn run_shard(
    py: Python<'_>,
    scene: &Bound<'_, PyScene>,
    index: u64,
    count: u64,
    samples: Option<u64>,
    seed: Option<u64>,
    threads: Option<usize>,
    analog: bool,
    all_effects: bool,
) -> PyResult<PyPartial> {
    let opts = Options {
        method: Method::Mc,
        samples,
        seed,
        threads,
        analog,
        all_effects,
        ..Default::default()
    };
    let scene = &scene.get().scene;
    let part = guarded(py, || Ok(km_montecarlo::run_shard(scene, &opts.mc()?, index, count)?))?;
    Ok(PyPartial { part })
}

/// Merge Monte Carlo shards into the result of one run (see `km.merge`).
#[pyfunction]
fn merge(py: Python<'_>, parts: Vec<Bound<'_, PyPartial>>) -> PyResult<PySolution> {
    let parts: Vec<km_montecarlo::Partial> = parts.iter().map(|p| p.get().part.clone()).collect();
    let sol = guarded(py, || Ok(km_montecarlo::merge(&parts)?))?;
    Ok(PySolution { sol })
}

/// The extension module `km._km`.
#[pymodule]
fn _km(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("KmError", m.py().get_type::<KmError>())?;
    m.add_class::<PyScene>()?;
    m.add_class::<PySolution>()?;
    m.add_class::<PyPartial>()?;
    m.add_function(wrap_pyfunction!(solve, m)?)?;
    m.add_function(wrap_pyfunction!(_solve_scenes, m)?)?;
    m.add_function(wrap_pyfunction!(_solve_sweep, m)?)?;
    m.add_function(wrap_pyfunction!(run_shard, m)?)?;
    m.add_function(wrap_pyfunction!(merge, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
