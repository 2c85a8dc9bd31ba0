//! `km.fit_km`: the Kubelka–Munk inverse of paint drawdowns (`km fit --km`,
//! docs/inverse-km.md) and `km.colour` / `km.delta_e2000` (km-inverse's
//! colour module, docs/colour.md).
//!
//! The JSON object of `km fit --km --json` is the library's
//! (`km_inverse::drawdown::DrawdownFit::to_json`), as for the command.

use km_inverse::colour::{self, Illuminant, Lab, Observer, Spectrum, Xyz};
use km_inverse::drawdown::{DrawdownInputs, Input};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use serde_json::Value;

use super::convert::json_to_py;
use super::{guarded, py_err};
use crate::error::Error;

fn lib(name: &str, e: impl std::fmt::Display) -> Error {
    Error::option(name, e.to_string())
}

/// The `km fit --km --json` object: [`DrawdownInputs::fit`] on the
/// keywords' readings (the library decides which readings they make and
/// assembles the JSON, as for the command); a refusal names its keyword
/// (`r_inf` when the library's refusal names no input).
fn compute(i: &DrawdownInputs) -> Result<Value, Error> {
    let fit = i.fit().map_err(|e| {
        let key = e.input().map_or("r_inf", Input::name);
        Error::option(key, e.message(|i| i.name().to_string()))
    })?;
    Ok(fit.to_json())
}

/// Kubelka–Munk inverse of a film (see `km.fit_km`): the `km fit --km --json` dict.
#[pyfunction]
#[pyo3(signature = (*, r_black=None, r_white=None, r_white_ground=None, r_black_ground=None,
                    r_inf=None, r_zero=None, thickness=None, n=None, k2=None))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn fit_km<'py>(
    py: Python<'py>,
    r_black: Option<f64>,
    r_white: Option<f64>,
    r_white_ground: Option<f64>,
    r_black_ground: Option<f64>,
    r_inf: Option<f64>,
    r_zero: Option<f64>,
    thickness: Option<f64>,
    n: Option<f64>,
    k2: Option<f64>,
) -> PyResult<Bound<'py, PyAny>> {
    let i = DrawdownInputs {
        r_black,
        r_white,
        r_white_ground,
        r_black_ground,
        r_inf,
        r_zero,
        thickness,
        n,
        k2,
    };
    let v = guarded(py, || compute(&i))?;
    json_to_py(py, &v)
}

fn observer(name: &str) -> Result<Observer, Error> {
    match name {
        "1931" | "2" => Ok(Observer::Cie1931TwoDegree),
        "1964" | "10" => Ok(Observer::Cie1964TenDegree),
        o => Err(Error::option("observer", format!("\"{o}\": expected \"1931\" or \"1964\""))),
    }
}

fn illuminant(name: &str) -> Result<Illuminant, Error> {
    match name {
        "D65" => Ok(Illuminant::D65),
        "D50" => Ok(Illuminant::D50),
        o => Err(Error::option("illuminant", format!("\"{o}\": expected \"D65\" or \"D50\""))),
    }
}

/// Colour of a reflectance or transmittance spectrum (see `km.colour`).
#[pyfunction]
#[pyo3(name = "colour", signature = (wavelengths_nm, values, *, observer="1931", illuminant="D65"))]
pub(crate) fn colour_of<'py>(
    py: Python<'py>,
    wavelengths_nm: Vec<f64>,
    values: Vec<f64>,
    observer: &str,
    illuminant: &str,
) -> PyResult<Bound<'py, PyDict>> {
    let (obs, ill) = (
        self::observer(observer).map_err(|e| py_err(py, e))?,
        self::illuminant(illuminant).map_err(|e| py_err(py, e))?,
    );
    let (xyz, white, lab, rgb) = guarded(py, || {
        let s = Spectrum::new(wavelengths_nm, values).map_err(|e| lib("spectrum", e))?;
        let xyz = colour::xyz(&s, obs, ill);
        let white = colour::white_point(obs, ill);
        let lab = colour::lab(xyz, white).map_err(|e| lib("spectrum", e))?;
        Ok((xyz, white, lab, colour::srgb(xyz)))
    })?;
    let d = PyDict::new(py);
    d.set_item("xyz", (xyz.x, xyz.y, xyz.z))?;
    d.set_item("white", (white.x, white.y, white.z))?;
    d.set_item("lab", (lab.l, lab.a, lab.b))?;
    d.set_item("srgb", (rgb[0], rgb[1], rgb[2]))?;
    d.set_item("srgb_u8", colour::srgb_u8(rgb).to_vec())?;
    Ok(d)
}

/// Refuse a colour triple with a value that is not finite, naming the argument.
fn finite3(py: Python<'_>, name: &str, v: (f64, f64, f64)) -> PyResult<()> {
    if [v.0, v.1, v.2].iter().all(|x| x.is_finite()) {
        return Ok(());
    }
    Err(py_err(py, Error::option(name, format!("{v:?} has a value that is not finite"))))
}

/// CIEDE2000 colour difference of two CIELAB colours (see `km.delta_e2000`).
#[pyfunction]
pub(crate) fn delta_e2000(
    py: Python<'_>,
    lab1: (f64, f64, f64),
    lab2: (f64, f64, f64),
) -> PyResult<f64> {
    finite3(py, "lab1", lab1)?;
    finite3(py, "lab2", lab2)?;
    let l = |(l, a, b): (f64, f64, f64)| Lab { l, a, b };
    Ok(colour::ciede2000(l(lab1), l(lab2)))
}

/// sRGB (linear-light encoded to the sRGB curve, 0..1) of CIE XYZ (Y = 100 white).
#[pyfunction]
pub(crate) fn srgb(py: Python<'_>, xyz: (f64, f64, f64)) -> PyResult<(f64, f64, f64)> {
    finite3(py, "xyz", xyz)?;
    let v = colour::srgb(Xyz { x: xyz.0, y: xyz.1, z: xyz.2 });
    Ok((v[0], v[1], v[2]))
}
