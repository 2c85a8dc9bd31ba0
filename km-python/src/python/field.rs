//! `km.field`: the depth-resolved field of a scene (`km::field`,
//! docs/field.md) as numpy arrays, channels x depths.

use km::field::{FieldOptions, FieldRequest, field as km_field};
use numpy::{IntoPyArray, PyArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use super::interrupt::interruptible;
use super::{PyScene, guarded, py_err};
use crate::error::Error;

/// Rows of equal length (channels x depths or x layers) as one 2-D array.
pub(crate) fn rows(py: Python<'_>, v: Vec<Vec<f64>>) -> PyResult<Bound<'_, PyAny>> {
    let (r, c) = (v.len(), v.first().map_or(0, Vec::len));
    let flat: Vec<f64> = v.into_iter().flatten().collect();
    let a = flat.into_pyarray(py).reshape([r, c])?;
    Ok(a.into_any())
}

/// The fluence rate, absorbed power density and net flux at depths (see `km.field`).
#[pyfunction]
#[pyo3(signature = (scene, method="multiflux", *, depths=None, streams=None, samples=None,
                    seed=None, dz=None, fdr=None, dipole=None, directions=None, mc_cone=None))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn field<'py>(
    py: Python<'py>,
    scene: &Bound<'py, PyScene>,
    method: &str,
    depths: Option<Vec<f64>>,
    streams: Option<usize>,
    samples: Option<u64>,
    seed: Option<u64>,
    dz: Option<f64>,
    fdr: Option<&str>,
    dipole: Option<&str>,
    directions: Option<Vec<[f64; 2]>>,
    mc_cone: Option<f64>,
) -> PyResult<Bound<'py, PyDict>> {
    let method = crate::engine::method(method).map_err(|e| py_err(py, e))?;
    let defaults = FieldRequest::default();
    let mut request = FieldRequest {
        method,
        depths: None,
        streams,
        samples: samples.unwrap_or(defaults.samples),
        seed: seed.unwrap_or(defaults.seed),
        dz,
        directions,
        mc_cone: mc_cone.unwrap_or(defaults.mc_cone),
        ..defaults
    };
    // The dipole's model and F_dr through the one table of settings (its
    // choices, defaults and the refusal of either for another method), as
    // `km solve` and `km.solve` read them.
    if fdr.is_some() || dipole.is_some() {
        let text: Vec<(String, String)> = [("fdr", fdr), ("dipole", dipole)]
            .into_iter()
            .filter_map(|(k, v)| v.map(|v| (k.to_string(), v.to_string())))
            .collect();
        let o = crate::engine::Options { method, settings: text, ..Default::default() };
        let lib = o.library().map_err(|e| py_err(py, e))?;
        if let km::MethodOptions::Dipole(d) = lib.method {
            (request.fdr, request.dipole) = (d.fdr, d.model);
        }
    }
    let opts = request.options().map_err(|e| match e {
        km::KmError::Option { name, value, reason } => {
            py_err(py, Error::option(name, format!("{value}: {reason}")))
        }
        e => py_err(py, Error::from(e)),
    })?;
    let scene = &scene.get().scene;
    // Monte Carlo is stoppable by Ctrl-C; the other methods are bounded by
    // their work budget.
    let f = if method == km::Method::Mc {
        interruptible(py, |c| {
            let opts = FieldOptions {
                mc: km::McOptions { cancel: Some(c.clone()), ..opts.mc.clone() },
                ..opts.clone()
            };
            Ok(km_field(scene, depths.as_deref(), &opts)?)
        })?
    } else {
        guarded(py, || Ok(km_field(scene, depths.as_deref(), &opts)?))?
    };
    let d = PyDict::new(py);
    d.set_item("method", f.method.name())?;
    d.set_item("labels", f.labels)?;
    d.set_item("depths", f.depths.into_pyarray(py))?;
    d.set_item("fluence", rows(py, f.fluence)?)?;
    d.set_item("absorbed", rows(py, f.absorbed)?)?;
    d.set_item("net_flux", rows(py, f.net_flux)?)?;
    d.set_item("absorptance_layers", rows(py, f.absorptance_layers)?)?;
    if let Some(se) = f.stderr {
        let s = PyDict::new(py);
        s.set_item("fluence", rows(py, se.fluence)?)?;
        s.set_item("absorbed", rows(py, se.absorbed)?)?;
        s.set_item("net_flux", rows(py, se.net_flux)?)?;
        d.set_item("stderr", s)?;
    }
    if let Some(r) = f.inside {
        d.set_item("radiance", radiance_dict(py, r)?)?;
    }
    d.set_item("seconds", f.seconds)?;
    Ok(d)
}

/// The radiance inside as `km.field` returns it: the directions, the values
/// and standard errors as (channel, depth, direction) arrays, the collimated
/// beams and the Monte Carlo cones (`None` where the method has none).
pub(crate) fn radiance_dict<'py>(
    py: Python<'py>,
    r: km::field::InsideField,
) -> PyResult<Bound<'py, PyDict>> {
    let cube = |v: Vec<Vec<Vec<f64>>>| -> PyResult<Bound<'py, PyAny>> {
        let (c, k) = (v.len(), v.first().map_or(0, Vec::len));
        let j = v.first().and_then(|x| x.first()).map_or(0, Vec::len);
        let flat: Vec<f64> = v.into_iter().flatten().flatten().collect();
        Ok(flat.into_pyarray(py).reshape([c, k, j])?.into_any())
    };
    let o = PyDict::new(py);
    let nj = r.directions.len();
    let dirs: Vec<f64> = r.directions.into_iter().flatten().collect();
    o.set_item("directions", dirs.into_pyarray(py).reshape([nj, 2])?)?;
    o.set_item("values", cube(r.radiance)?)?;
    match r.stderr {
        Some(se) => o.set_item("stderr", cube(se)?)?,
        None => o.set_item("stderr", py.None())?,
    }
    match r.beams {
        Some([dn, up]) => {
            o.set_item("beam_down", rows(py, dn)?)?;
            o.set_item("beam_up", rows(py, up)?)?;
        }
        None => {
            o.set_item("beam_down", py.None())?;
            o.set_item("beam_up", py.None())?;
        }
    }
    match r.cone_half_angle_deg {
        Some(c) => o.set_item("cone_half_angle_deg", c.into_pyarray(py))?,
        None => o.set_item("cone_half_angle_deg", py.None())?,
    }
    Ok(o)
}

/// `Rd(r)` of a pencil beam, and with `depths` the dipole's `phi(r, z)` (see `km.profile`).
#[pyfunction]
#[pyo3(signature = (scene, method="dipole", *, r_max=None, points=20, samples=1_000_000,
                    seed=1, depths=None))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn profile<'py>(
    py: Python<'py>,
    scene: &Bound<'py, PyScene>,
    method: &str,
    r_max: Option<f64>,
    points: usize,
    samples: u64,
    seed: u64,
    depths: Option<Vec<f64>>,
) -> PyResult<Bound<'py, PyDict>> {
    let method = crate::engine::method(method).map_err(|e| py_err(py, e))?;
    if samples == 0 {
        return Err(py_err(py, Error::option("samples", "0: need at least one photon")));
    }
    let opts = km::ProfileOptions {
        method,
        r_max,
        points,
        samples,
        seed,
        depths: depths.unwrap_or_default(),
    };
    let scene = &scene.get().scene;
    let p = guarded(py, || Ok(km::profile(scene, &opts)?))?;
    let d = PyDict::new(py);
    d.set_item("method", p.method.name())?;
    d.set_item("labels", p.labels)?;
    d.set_item("r", p.r.into_pyarray(py))?;
    d.set_item("rd", rows(py, p.rd)?)?;
    match p.stderr {
        Some(se) => d.set_item("stderr", rows(py, se)?)?,
        None => d.set_item("stderr", py.None())?,
    }
    let nd = p.depths.len();
    d.set_item("depths", p.depths.into_pyarray(py))?;
    match p.fluence {
        Some(f) => {
            let (c, n) = (f.len(), opts.points);
            let flat: Vec<f64> = f.into_iter().flatten().flatten().collect();
            d.set_item("fluence", flat.into_pyarray(py).reshape([c, nd, n])?)?;
        }
        None => d.set_item("fluence", py.None())?,
    }
    Ok(d)
}
