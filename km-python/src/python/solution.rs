//! `km.Solution`: totals, BRDF/BTDF samples, uncertainties, the plan.

use km::UncertaintyValue;
use km::{Solution, Uncertainty};
use numpy::{IntoPyArray, PyArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use serde_json::Value;

use super::convert::json_to_py;

/// What a solve returns: totals, BRDF/BTDF samples, uncertainties, the plan.
///
/// Made by `km.solve` and `km.merge`, not by hand. For a one-channel scene
/// the totals are floats and `brdf`/`btdf` 1-D arrays over the output
/// directions; for `C` channels each total is an array of shape `(C,)` and
/// `brdf`/`btdf` have shape `(C, D)`. `to_dict()` is the `km solve --json`
/// object, unchanged: there `channels` (present for several channels) is
/// the list of channel labels and each total a list over them, while the
/// attribute `channels` is their number (as on `Scene`, `Batch` and `Bsdf`)
/// and `labels` the list: `sol.to_dict()["channels"] == sol.labels` and
/// `sol.channels == len(sol.labels)`.
///
/// Attributes
/// ----------
/// method : str
///     The method that solved.
/// channels : int
///     Number of spectral channels.
/// labels : list of str
///     Channel labels.
/// reflectance, transmittance, absorptance : float or ndarray
///     Totals (the delta parts included).
/// reflectance_specular, transmittance_direct : float or ndarray
///     The mirror reflection and the unscattered beam.
/// brdf, btdf : ndarray
///     Smooth BRDF/BTDF (1/sr) at `directions_deg`.
/// directions_deg : list of [float, float]
///     The output directions `[theta, phi]`, degrees.
/// stderr, error_estimate, model_error_estimate : dict or None
///     Standard errors (Monte Carlo), estimated errors (a tolerance), how far
///     a closed form may be off, by key.
/// absorptance_layers : ndarray or None
///     Absorbed fraction per layer.
/// notes : list of str
///     What the solver simplified.
/// plan, accuracy, extra : dict or None
///     The plan obeyed, how a tolerance was met, method diagnostics.
/// seconds : float
///     The solver's wall time.
///
/// Examples
/// --------
/// >>> import km
/// >>> sol = km.solve(km.Scene(layers=[km.layer(tau=1.0, albedo=0.9)]), "km")
/// >>> round(sol.reflectance + sol.transmittance + sol.absorptance, 12)
/// 1.0
/// >>> sol.to_dict()["method"], sol.channels
/// ('km', 1)
#[pyclass(frozen, name = "Solution", module = "km")]
pub struct PySolution {
    pub(crate) sol: Solution,
}

impl PySolution {
    fn per_channel<'py>(
        &self,
        py: Python<'py>,
        get: impl Fn(&km::ChannelResult) -> f64,
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
        get: impl Fn(&km::ChannelResult) -> &Vec<f64>,
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
        get: impl Fn(&km::ChannelResult) -> Option<&Uncertainty>,
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
    /// Method name (`km`, `multiflux`, `mc`, `dipole`, `direction-set`).
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
        let get = |c: &km::ChannelResult| -> Vec<f64> {
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
    /// The field at the scene's ``[output] depths`` (docs/field.md), as
    /// ``km.field`` gives it: ``depths`` and 2-D arrays (channels x depths)
    /// ``fluence``, ``absorbed``, ``net_flux``, with ``stderr`` of the same
    /// keys for Monte Carlo, and ``radiance`` (``km.field``'s dict) when the
    /// scene asks for ``[output] inside_directions_deg`` and the method gives
    /// it (multiflux, mc); None when the scene asks for no depths or the
    /// method gives no depth field.
    #[getter]
    fn field<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyDict>>> {
        use super::field::rows;
        let Some(f) = &self.sol.field else { return Ok(None) };
        let d = PyDict::new(py);
        d.set_item("depths", f.depths.clone().into_pyarray(py))?;
        let values = [&f.fluence, &f.absorbed, &f.net_flux];
        for (k, v) in km::DEPTH_KEYS.iter().zip(values) {
            d.set_item(*k, rows(py, v.clone())?)?;
        }
        if let Some(se) = &f.stderr {
            let s = PyDict::new(py);
            for (k, v) in km::DEPTH_KEYS.iter().zip(se) {
                s.set_item(*k, rows(py, v.clone())?)?;
            }
            d.set_item("stderr", s)?;
        }
        if let Some(r) = &f.radiance {
            d.set_item("radiance", super::field::radiance_dict(py, r.clone())?)?;
        }
        Ok(Some(d))
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
    /// How far a closed form (km, dipole) may be off, by key
    /// (docs/two-flux.md eq. K25), or None for the other methods.
    #[getter]
    fn model_error_estimate<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyDict>>> {
        self.per_key(py, |c| c.model_error_estimate.as_ref())
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
        json_to_py(py, &Value::Object(self.sol.diagnostics.to_json()))
    }
    /// The solver's own wall time, seconds.
    #[getter]
    fn seconds(&self) -> f64 {
        self.sol.seconds
    }
    /// The `km solve --json` object, as a dict.
    ///
    /// Returns
    /// -------
    /// dict
    ///     The JSON object of `km solve SCENE --json`, key for key.
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        json_to_py(py, &self.sol.to_json())
    }
    /// The `km solve --json` object, as text.
    ///
    /// Parameters
    /// ----------
    /// indent : bool, default False
    ///     Pretty-print with indentation.
    ///
    /// Returns
    /// -------
    /// str
    #[pyo3(signature = (indent=false))]
    fn to_json(&self, indent: bool) -> String {
        let v = self.sol.to_json();
        if indent { serde_json::to_string_pretty(&v).unwrap_or_default() } else { v.to_string() }
    }
    /// HTML for Jupyter: the totals per channel and an SVG plot of the BRDF/BTDF.
    fn _repr_html_(slf: &Bound<'_, Self>) -> PyResult<String> {
        slf.py().import("km._repr")?.call_method1("solution_html", (slf,))?.extract()
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
