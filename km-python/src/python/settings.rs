//! The keyword arguments of `km.solve` and the batch solves, read against the
//! one table of solve settings ([`km::settings::SETTINGS`]) that the `km
//! solve` flags are read against too: the same names, ranges, defaults and
//! messages. `km._km._settings()` exports the table, so that the package's
//! tests can check that every setting is a keyword argument of `km.solve`.

use km::settings::{Kind, SETTINGS, Value, setting};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyList, PyString};

use super::{py_err, py_err_as};
use crate::engine::Options;
use crate::error::Error;

/// The table of solve settings, one dict per setting: `name`, `methods`
/// (the methods that read it), `kind` (`flag`, `count`, `real`, `choice`,
/// `shard`), `min`, `max`, `choices`, `default` (text, or None when the
/// method chooses), `conflicts` and `help`.
#[pyfunction]
pub(crate) fn _settings(py: Python<'_>) -> PyResult<Bound<'_, PyList>> {
    let list = PyList::empty(py);
    for s in SETTINGS {
        let d = PyDict::new(py);
        d.set_item("name", s.name)?;
        d.set_item("methods", s.methods.iter().map(|m| m.name()).collect::<Vec<_>>())?;
        let (kind, min, max, choices): (&str, Option<f64>, Option<f64>, Vec<&str>) = match s.kind {
            Kind::Flag => ("flag", None, None, vec![]),
            Kind::Count { min, max } => ("count", Some(min as f64), Some(max as f64), vec![]),
            Kind::Real { min, max } => ("real", Some(min), Some(max), vec![]),
            Kind::Choice(names) => ("choice", None, None, names.to_vec()),
            Kind::Shard => ("shard", None, None, vec![]),
        };
        d.set_item("kind", kind)?;
        d.set_item("min", min)?;
        d.set_item("max", max)?;
        d.set_item("choices", choices)?;
        d.set_item("default", s.default)?;
        d.set_item("conflicts", s.conflicts.to_vec())?;
        d.set_item("help", s.help)?;
        list.append(d)?;
    }
    Ok(list)
}

/// A keyword argument as the text of its setting's value, or a
/// `km.KmTypeError` naming it when its type is not that of the setting.
fn text_of(py: Python<'_>, name: &str, kind: Kind, v: &Bound<'_, PyAny>) -> PyResult<String> {
    let wrong = |want: &str| -> PyResult<String> {
        let got = v.get_type().name().map(|n| n.to_string()).unwrap_or_default();
        Err(py_err_as(
            py,
            Error::option(name, format!("expected {want}, got a value of type {got}")),
            "KmTypeError",
        ))
    };
    // numpy scalars (np.int64, np.float64, np.bool_) count as their Python kind.
    let is_bool = v.is_instance_of::<PyBool>() || v.get_type().name()?.to_str()? == "bool";
    let is_number = !is_bool
        && (v.is_instance_of::<PyInt>()
            || v.is_instance_of::<PyFloat>()
            || v.hasattr("__index__")?
            || v.hasattr("__float__")?);
    match kind {
        Kind::Flag if is_bool => Ok(if v.is_truthy()? { "true" } else { "false" }.to_string()),
        Kind::Flag => wrong("True or False"),
        Kind::Count { .. } if is_number && (v.hasattr("__index__")?) => Ok(v.str()?.to_string()),
        Kind::Count { .. } | Kind::Real { .. } if is_number => {
            let x: f64 = v.extract()?;
            Ok(format!("{x:?}"))
        }
        Kind::Count { .. } => wrong("a whole number"),
        Kind::Real { .. } => wrong("a number"),
        Kind::Choice(names) => match v.cast::<PyString>() {
            Ok(s) => Ok(s.to_str()?.to_string()),
            Err(_) => wrong(&format!("one of the names {}", names.join(", "))),
        },
        Kind::Shard => wrong("nothing here (shards are km.run_shard's)"),
    }
}

/// The options of a solve by `method` from keyword arguments: each a setting
/// of [`SETTINGS`] (or `analog`, the older spelling of
/// `estimator="analog"`); `None` means "not given". Unknown names are a
/// `km.KmTypeError` (as Python's own for an unexpected keyword); values are
/// checked by [`crate::engine::Options::settings`].
pub(crate) fn options_from(
    py: Python<'_>,
    method: &str,
    kwargs: Option<&Bound<'_, PyDict>>,
) -> PyResult<Options> {
    let method = crate::engine::method(method).map_err(|e| py_err(py, e))?;
    let mut opts = Options { method, ..Default::default() };
    let Some(kwargs) = kwargs else { return Ok(opts) };
    for (k, v) in kwargs.iter() {
        let name: String = k.extract()?;
        if v.is_none() {
            continue;
        }
        if name == "analog" {
            let text = text_of(py, "analog", Kind::Flag, &v)?;
            opts.analog = text == "true";
            continue;
        }
        let s = match setting(&name) {
            Some(s) if s.name == name && s.kind != Kind::Shard => s,
            _ => {
                let names: Vec<&str> =
                    SETTINGS.iter().filter(|s| s.kind != Kind::Shard).map(|s| s.name).collect();
                let why = format!("unknown keyword argument (settings: {})", names.join(", "));
                return Err(py_err_as(py, Error::option(&name, why), "KmTypeError"));
            }
        };
        let text = text_of(py, s.name, s.kind, &v)?;
        let value = s.parse(&text).map_err(|e| py_err(py, e.into()))?;
        let count = |v: &Value| match v {
            Value::Count(n) => Some(*n),
            _ => None,
        };
        let real = |v: &Value| match v {
            Value::Real(x) => Some(*x),
            _ => None,
        };
        match s.name {
            "streams" => opts.streams = count(&value).map(|n| n as usize),
            "order" => opts.order = count(&value).map(|n| n as usize),
            "samples" => opts.samples = count(&value),
            "seed" => opts.seed = count(&value),
            "threads" => opts.threads = count(&value).map(|n| n as usize),
            "tolerance" => opts.tolerance = real(&value),
            "cone" => opts.cone = real(&value),
            "all_effects" => opts.all_effects = value == Value::Flag(true),
            _ => opts.settings.push((s.name.to_string(), text)),
        }
    }
    Ok(opts)
}
