//! `km.fit_km`: the Kubelka–Munk inverse of paint drawdowns (`km fit --km`,
//! docs/inverse-km.md) and `km.colour` / `km.delta_e2000` (km-inverse's
//! colour module, docs/colour.md).
//!
//! The JSON object of `km fit --km --json` is assembled here from
//! km-inverse's public functions (`kubelka::from_black_white`,
//! `from_r_inf_r0`, `k_over_s`, the uncertainties and Saunderson's
//! correction), key for key as the command assembles it.

use km_inverse::colour::{self, Illuminant, Lab, Observer, Spectrum, Xyz};
use km_inverse::kubelka::{self, Film, Saunderson, Specular, Uncertainty};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use serde_json::{Map, Value, json};

use super::convert::json_to_py;
use super::{guarded, py_err};
use crate::error::Error;

/// Standard uncertainty assumed for each reading (as `km fit --km`).
const READING_U: f64 = 1e-3;

fn lib(name: &str, e: impl std::fmt::Display) -> Error {
    Error::option(name, e.to_string())
}

/// `d(internal)/d(reading)` of Saunderson's correction by a central
/// difference of step 1e-7 (one-sided at the ends of [0, 1]), as the command.
fn internal_slope(corr: &Option<Saunderson>, r: f64) -> f64 {
    let Some(c) = corr else { return 1.0 };
    let (lo, hi) = ((r - 1e-7).max(0.0), (r + 1e-7).min(1.0));
    match (c.internal_from_measured(lo), c.internal_from_measured(hi)) {
        (Ok(a), Ok(b)) => (b - a) / (hi - lo),
        _ => f64::NAN,
    }
}

fn uncertainty_json(u: Option<Uncertainty>) -> Value {
    match u {
        Some(u) if u.k.is_finite() && u.s.is_finite() => json!({
            "K": u.k, "S": u.s, "correlation": u.correlation, "u_reading": READING_U
        }),
        _ => Value::Null,
    }
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

/// The three maps of the JSON object being assembled.
#[derive(Default)]
struct Out {
    inputs: Map<String, Value>,
    internals: Map<String, Value>,
    out: Map<String, Value>,
}

/// Measured -> internal reflectance (Saunderson's correction, if any), naming the input.
fn internal(corr: &Option<Saunderson>, name: &str, r: f64) -> Result<f64, Error> {
    match corr {
        None => Ok(r),
        Some(c) => c.internal_from_measured(r).map_err(|e| lib(name, e)),
    }
}

/// A film over a dark and a light ground (Kubelka 1948; eq. I5–I7 of docs/inverse-km.md).
fn two_grounds(i: &Inputs, corr: &Option<Saunderson>, o: &mut Out) -> Result<Film, Error> {
    let r_black = need(i.r_black, "r_black", "the film over the dark ground")?;
    let r_white = need(i.r_white, "r_white", "the film over the light ground")?;
    let g_white = need(i.r_white_ground, "r_white_ground", "the light ground's reflectance")?;
    let thickness = need(i.thickness, "thickness", "the film thickness")?;
    let g_black = i.r_black_ground.unwrap_or(0.0);
    let (rb, rw) = (internal(corr, "r_black", r_black)?, internal(corr, "r_white", r_white)?);
    for (k, v) in [
        ("r_black", r_black),
        ("r_white", r_white),
        ("r_black_ground", g_black),
        ("r_white_ground", g_white),
        ("thickness", thickness),
    ] {
        o.inputs.insert(k.into(), json!(v));
    }
    o.internals.insert("r_black".into(), json!(rb));
    o.internals.insert("r_white".into(), json!(rw));
    o.out.insert("mode".into(), json!("black_white"));
    let film = kubelka::from_black_white(rb, g_black, rw, g_white, thickness)
        .map_err(|e| lib("r_black", e))?;
    let (ub, uw) =
        (READING_U * internal_slope(corr, r_black), READING_U * internal_slope(corr, r_white));
    let u = kubelka::black_white_uncertainty(rb, g_black, rw, g_white, thickness, ub, uw);
    o.out.insert("uncertainty".into(), uncertainty_json(u.ok()));
    Ok(film)
}

/// An opaque film and, with `r_zero`, the film over ideal black (eq. I4),
/// or the opaque film alone (`K/S` only, eq. I1).
fn opaque(i: &Inputs, corr: &Option<Saunderson>, o: &mut Out) -> Result<Option<Film>, Error> {
    if i.r_white_ground.is_some() || i.r_black_ground.is_some() {
        return Err(Error::option(
            "r_white_ground",
            "r_white_ground/r_black_ground belong to r_black/r_white",
        ));
    }
    let r_inf = need(i.r_inf, "r_inf", "the reflectance of the opaque film")?;
    let ri = internal(corr, "r_inf", r_inf)?;
    o.inputs.insert("r_inf".into(), json!(r_inf));
    o.internals.insert("r_inf".into(), json!(ri));
    let Some(r_zero) = i.r_zero else {
        if i.thickness.is_some() {
            return Err(Error::option(
                "thickness",
                "needs r_zero: an opaque film alone gives only K/S",
            ));
        }
        o.out.insert("mode".into(), json!("r_inf"));
        let ks = kubelka::k_over_s(ri).map_err(|e| lib("r_inf", e))?;
        o.out.insert("K_over_S".into(), json!(ks));
        o.out.insert("R_inf".into(), json!(ri));
        o.out.insert("uncertainty".into(), Value::Null);
        return Ok(None);
    };
    let thickness = need(i.thickness, "thickness", "the film thickness")?;
    let r0 = internal(corr, "r_zero", r_zero)?;
    o.inputs.insert("r_zero".into(), json!(r_zero));
    o.inputs.insert("thickness".into(), json!(thickness));
    o.internals.insert("r_zero".into(), json!(r0));
    o.out.insert("mode".into(), json!("r_inf_r_zero"));
    let film = kubelka::from_r_inf_r0(ri, r0, thickness).map_err(|e| lib("r_zero", e))?;
    let (ui, u0) =
        (READING_U * internal_slope(corr, r_inf), READING_U * internal_slope(corr, r_zero));
    let u = kubelka::r_inf_r0_uncertainty(ri, r0, thickness, ui, u0);
    o.out.insert("uncertainty".into(), uncertainty_json(u.ok()));
    Ok(Some(film))
}

/// The `km fit --km --json` object.
fn compute(i: &Inputs) -> Result<Value, Error> {
    let two = i.r_black.is_some() || i.r_white.is_some();
    if two && (i.r_inf.is_some() || i.r_zero.is_some()) {
        return Err(Error::option(
            "r_inf",
            "give either r_black/r_white (film over two grounds) or r_inf [r_zero], not both",
        ));
    }
    let corr = saunderson(i)?;
    let mut o = Out::default();
    let film = if two { Some(two_grounds(i, &corr, &mut o)?) } else { opaque(i, &corr, &mut o)? };
    let out = &mut o.out;
    match film {
        Some(f) => {
            for (k, v) in [
                ("K", f.k),
                ("S", f.s),
                ("K_over_S", f.k_over_s),
                ("S_X", f.sx),
                ("R_inf", f.r_inf),
                ("R_0", f.r0),
                ("T", f.t),
                ("thickness", f.sx / f.s),
            ] {
                out.insert(k.into(), json!(v));
            }
        }
        None => {
            for k in ["K", "S", "S_X", "R_0", "T", "thickness"] {
                out.insert(k.into(), Value::Null);
            }
        }
    }
    if let (Some(c), Some(ri)) = (&corr, out.get("R_inf").and_then(Value::as_f64)) {
        let m = c.measured_from_internal(ri).map_err(|e| lib("r_inf", e))?;
        out.insert("R_inf_measured".into(), json!(m));
    }
    out.insert(
        "saunderson".into(),
        corr.map(|c| json!({ "k1": c.k1, "k2": c.k2 })).unwrap_or(Value::Null),
    );
    out.insert("inputs".into(), Value::Object(o.inputs));
    out.insert("internal".into(), Value::Object(o.internals));
    Ok(Value::Object(o.out))
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
