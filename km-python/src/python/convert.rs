//! Python values to the scene file's TOML values, and JSON values to Python.

use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyList, PyString, PyTuple};
use serde_json::Value;

use super::{py_err, py_err_as};
use crate::error::Error;

pub(crate) fn to_toml(py: Python<'_>, key: &str, obj: &Bound<'_, PyAny>) -> PyResult<toml::Value> {
    // A Python value of a type the scene file has no place for: a
    // `km.KmTypeError` (a `TypeError` and a `km.KmError`) naming the key.
    let refuse = |what: String| {
        py_err_as(
            py,
            Error::Scene(km::CoreError::scene(
                key,
                None,
                format!("{what} cannot be a value of the scene file"),
            )),
            "KmTypeError",
        )
    };
    if obj.is_instance_of::<PyBool>() {
        return Ok(toml::Value::Boolean(obj.extract()?));
    }
    if obj.is_instance_of::<PyInt>() {
        return match obj.extract::<i64>() {
            Ok(i) => Ok(toml::Value::Integer(i)),
            // Beyond i64: a float, or (beyond the largest float, 10**400)
            // a refusal naming the key, not a bare OverflowError.
            Err(_) => obj.extract::<f64>().map(toml::Value::Float).map_err(|_| {
                py_err(
                    py,
                    Error::Scene(km::CoreError::scene(
                        key,
                        None,
                        "an integer beyond the largest float (1.8e308)",
                    )),
                )
            }),
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
pub(crate) fn section(py: Python<'_>, key: &str, obj: &Bound<'_, PyAny>) -> PyResult<toml::Table> {
    match to_toml(py, key, obj)? {
        toml::Value::String(kind) => {
            Ok(toml::Table::from_iter([("kind".to_string(), toml::Value::String(kind))]))
        }
        toml::Value::Table(t) => Ok(t),
        _ => Err(py_err(
            py,
            Error::Scene(km::CoreError::scene(
                key,
                None,
                "expected a kind (a string) or a mapping of the section's keys",
            )),
        )),
    }
}

// ---------------------------------------------------------------------------
// JSON values -> Python.

pub(crate) fn json_to_py<'py>(py: Python<'py>, v: &Value) -> PyResult<Bound<'py, PyAny>> {
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
