//! `km.fit_km`: the Kubelka–Munk inverse of paint drawdowns (`km fit --km`,
//! docs/inverse-km.md) and `km.colour` / `km.delta_e2000` (km-inverse's
//! colour module, docs/colour.md).
//!
//! The JSON object of `km fit --km --json` is the library's
//! (`km_inverse::drawdown::DrawdownFit::to_json`), as for the command.

use km_inverse::colour::{self, Illuminant, Lab, Observer, Spectrum, Xyz};
use km_inverse::drawdown::{Readings, fit_drawdown};
use km_inverse::kubelka::{KubelkaError, Saunderson, Specular};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use serde_json::Value;

use super::convert::json_to_py;
use super::{guarded, py_err};
use crate::error::Error;

fn lib(name: &str, e: impl std::fmt::Display) -> Error {
    Error::option(name, e.to_string())
}

/// The readings of `km.fit_km` (each optional; the mode decides which are needed).
#[derive(Default, Clone, Copy)]
struct Inputs {
    r_black: Option<f64>,
    r_white: Option<f64>,
    r_white_ground: Option<f64>,
    r_black_ground: Option<f64>,
    r_inf: Option<f64>,
    r_zero: Option<f64>,
    thickness: Option<f64>,
    n: Option<f64>,
    k2: Option<f64>,
}

fn need(v: Option<f64>, name: &str, what: &str) -> Result<f64, Error> {
    v.ok_or_else(|| Error::option(name, format!("is required ({what})")))
}

fn saunderson(i: &Inputs) -> Result<Option<Saunderson>, Error> {
    Ok(match (i.n, i.k2) {
        (None, None) => None,
        (None, Some(_)) => {
            return Err(Error::option(
                "k2",
                "needs n (k1 is the Fresnel reflectance of the binder)",
            ));
        }
        (Some(n), None) => {
            Some(Saunderson::fresnel(n, Specular::Included).map_err(|e| lib("n", e))?)
        }
        (Some(n), Some(k2)) => {
            Some(Saunderson::from_index(n, k2, Specular::Included).map_err(|e| lib("k2", e))?)
        }
    })
}

/// Which readings the keywords give (`r_black`/`r_white` over two grounds,
/// or `r_inf` [`r_zero`]), each missing or conflicting keyword named.
fn readings(i: &Inputs) -> Result<Readings, Error> {
    let two = i.r_black.is_some() || i.r_white.is_some();
    if two && (i.r_inf.is_some() || i.r_zero.is_some()) {
        return Err(Error::option(
            "r_inf",
            "give either r_black/r_white (film over two grounds) or r_inf [r_zero], not both",
        ));
    }
    if two {
        return Ok(Readings::BlackWhite {
            r_black: need(i.r_black, "r_black", "the film over the dark ground")?,
            r_white: need(i.r_white, "r_white", "the film over the light ground")?,
            g_white: need(i.r_white_ground, "r_white_ground", "the light ground's reflectance")?,
            thickness: need(i.thickness, "thickness", "the film thickness")?,
            g_black: i.r_black_ground.unwrap_or(0.0),
        });
    }
    if i.r_white_ground.is_some() || i.r_black_ground.is_some() {
        return Err(Error::option(
            "r_white_ground",
            "r_white_ground/r_black_ground belong to r_black/r_white",
        ));
    }
    let r_inf = need(i.r_inf, "r_inf", "the reflectance of the opaque film")?;
    match i.r_zero {
        Some(r_zero) => Ok(Readings::RInfRZero {
            r_inf,
            r_zero,
            thickness: need(i.thickness, "thickness", "the film thickness")?,
        }),
        None if i.thickness.is_some() => {
            Err(Error::option("thickness", "needs r_zero: an opaque film alone gives only K/S"))
        }
        None => Ok(Readings::RInf { r_inf }),
    }
}

/// The `km fit --km --json` object: [`km_inverse::drawdown::fit_drawdown`]
/// on the keywords' readings (the library assembles the JSON, as for the
/// command), a refusal naming the keyword of the reading.
fn compute(i: &Inputs) -> Result<Value, Error> {
    let corr = saunderson(i)?;
    let fit = fit_drawdown(readings(i)?, corr).map_err(|e| {
        let name = match &e {
            KubelkaError::Invalid { name, .. } | KubelkaError::Infeasible { name, .. } => {
                name.to_string()
            }
            _ => "r_inf".into(),
        };
        lib(&name, e)
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
    let i = Inputs {
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

/// CIEDE2000 colour difference of two CIELAB colours (see `km.delta_e2000`).
#[pyfunction]
pub(crate) fn delta_e2000(lab1: (f64, f64, f64), lab2: (f64, f64, f64)) -> f64 {
    let l = |(l, a, b): (f64, f64, f64)| Lab { l, a, b };
    colour::ciede2000(l(lab1), l(lab2))
}

/// sRGB (linear-light encoded to the sRGB curve, 0..1) of CIE XYZ (Y = 100 white).
#[pyfunction]
pub(crate) fn srgb(xyz: (f64, f64, f64)) -> (f64, f64, f64) {
    let v = colour::srgb(Xyz { x: xyz.0, y: xyz.1, z: xyz.2 });
    (v[0], v[1], v[2])
}
