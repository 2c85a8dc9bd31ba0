//! `km._BsdfCore`: the whole BSDF of a scene's stack (`km::bsdf`), evaluated
//! at any angles; the Python class `km.Bsdf` (km/_bsdf.py) broadcasts the
//! arguments and shapes the arrays.
//!
//! Every evaluation builds the library's [`Bsdf`] on the distinct incidence
//! and exit polar angles asked for (eq. B1 of docs/bsdf.md: Fourier
//! coefficients per polar pair plus the single-scattering correction), so the
//! values are those of `km bsdf` at the same angles, not an interpolation.

use km::MultifluxOptions;
use km::Scene;
use km::bsdf::{Bsdf, BsdfOptions, Side, gauss_angles};
use numpy::{IntoPyArray, PyArrayMethods, PyReadonlyArray1};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use super::{PyScene, guarded, py_err};
use crate::error::Error;

/// The streams `km bsdf` chooses by default: the largest default of the
/// solver over the incidences of its default grid (`gauss:32`) and over the
/// channels, so that every evaluation of one object uses the same streams.
fn default_streams(scene: &Scene) -> usize {
    let (grid, _) = gauss_angles(32);
    scene.channels().iter().map(|ch| km::default_bsdf_streams(ch, &grid)).fold(1, usize::max)
}

fn side_of(name: &str) -> Result<Side, Error> {
    match name {
        "above" => Ok(Side::Above),
        "below" => Ok(Side::Below),
        other => {
            Err(Error::option("side", format!("\"{other}\": expected \"above\" or \"below\"")))
        }
    }
}

/// Distinct values of `v`, ascending, and the index of every entry of `v` in them.
fn distinct(v: &[f64]) -> (Vec<f64>, Vec<usize>) {
    let mut u = v.to_vec();
    u.sort_by(f64::total_cmp);
    u.dedup_by(|a, b| a.to_bits() == b.to_bits());
    let idx = v.iter().map(|x| u.partition_point(|y| y.total_cmp(x).is_lt())).collect();
    (u, idx)
}

/// The BSDF of a scene's stack (see `km.bsdf`); the arrays are flat.
#[pyclass(frozen, name = "_BsdfCore", module = "km._km")]
pub struct PyBsdfCore {
    scene: Scene,
    toml: String,
    opts: MultifluxOptions,
    transmits: bool,
    n_above: f64,
    n_below: Option<f64>,
}

/// At most this many (channel, distinct theta_i, distinct theta_o) triples per
/// evaluation: the operators keep `M + 1` coefficients and the correction
/// weights per triple (about 1 kB each), so 2^20 triples stay near 1 GB.
const MAX_PAIRS: usize = 1 << 20;

impl PyBsdfCore {
    fn build(&self, side: &str, theta_i: &[f64], theta_o: &[f64]) -> Result<Bsdf, Error> {
        let pairs = self.scene.channels().len() * theta_i.len() * theta_o.len();
        if pairs > MAX_PAIRS {
            return Err(Error::option(
                "theta_o",
                format!(
                    "{} channel(s) x {} distinct theta_i x {} distinct theta_o = {pairs} pairs \
                     (at most {MAX_PAIRS}): evaluate on a coarser grid or in chunks",
                    self.scene.channels().len(),
                    theta_i.len(),
                    theta_o.len()
                ),
            ));
        }
        let options = BsdfOptions { solver: self.opts.clone(), side: side_of(side)? };
        Ok(Bsdf::new(&self.scene, theta_i, theta_o, &options)?)
    }
}

fn vec1(a: &PyReadonlyArray1<'_, f64>) -> Vec<f64> {
    a.as_array().iter().copied().collect()
}

#[pymethods]
impl PyBsdfCore {
    #[new]
    #[pyo3(signature = (scene, streams=None, max_fourier_order=None, fourier_tol=None))]
    fn new(
        py: Python<'_>,
        scene: &Bound<'_, PyScene>,
        streams: Option<usize>,
        max_fourier_order: Option<usize>,
        fourier_tol: Option<f64>,
    ) -> PyResult<PyBsdfCore> {
        let s = scene.get();
        let (scene, toml) = (s.scene.clone(), s.toml.clone());
        let core = guarded(py, || {
            let streams = Some(streams.unwrap_or_else(|| default_streams(&scene)));
            let mut opts = MultifluxOptions { streams, max_fourier_order, ..Default::default() };
            if let Some(tol) = fourier_tol {
                opts.fourier_tol = tol;
            }
            // One small table checks the scene and the options and tells
            // whether the stack transmits.
            let probe = Bsdf::new(
                &scene,
                &[0.0],
                &[0.0],
                &BsdfOptions { solver: opts.clone(), side: Side::Above },
            )?;
            let core = PyBsdfCore {
                n_above: probe.n_in,
                n_below: probe.n_out,
                transmits: probe.transmits,
                scene,
                toml,
                opts,
            };
            Ok(core)
        })?;
        Ok(core)
    }

    /// Streams (Gauss nodes per hemisphere and Snell segment) of every evaluation.
    #[getter]
    fn streams(&self) -> usize {
        self.opts.streams.unwrap_or(0)
    }
    /// Upper bound of the Fourier order, or None (as the series needs).
    #[getter]
    fn max_fourier_order(&self) -> Option<usize> {
        self.opts.max_fourier_order
    }
    /// Where the azimuthal series stops (`km bsdf --fourier-tol`).
    #[getter]
    fn fourier_tol(&self) -> f64 {
        self.opts.fourier_tol
    }
    /// Whether light leaves through the far side (transparent substrate, no half-space).
    #[getter]
    fn transmits(&self) -> bool {
        self.transmits
    }
    /// Refractive index of the ambient medium (above the stack).
    #[getter]
    fn n_above(&self) -> f64 {
        self.n_above
    }
    /// Refractive index of the medium below (None when the stack is opaque).
    #[getter]
    fn n_below(&self) -> Option<f64> {
        self.n_below
    }
    /// The most values one evaluation returns (channels x points), as the
    /// most values of one `km bsdf` table at budget 1.
    #[getter]
    fn max_values(&self) -> usize {
        km::bsdf_file::MAX_TABLE_VALUES
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
    /// The scene's TOML text.
    fn scene_toml(&self) -> String {
        self.toml.clone()
    }

    /// BRDF or BTDF (smooth part, 1/sr) at points `(theta_i[k], theta_o[k],
    /// phi[k])` (degrees; equal lengths): a `channels x n` array.
    fn _eval<'py>(
        &self,
        py: Python<'py>,
        side: &str,
        transmitted: bool,
        theta_i: PyReadonlyArray1<'py, f64>,
        theta_o: PyReadonlyArray1<'py, f64>,
        phi: PyReadonlyArray1<'py, f64>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let (ti, to, ph) = (vec1(&theta_i), vec1(&theta_o), vec1(&phi));
        let n = ti.len();
        if to.len() != n || ph.len() != n {
            return Err(py_err(
                py,
                Error::option("phi", "theta_i, theta_o and phi differ in length"),
            ));
        }
        if let Some(p) = ph.iter().find(|p| !p.is_finite()) {
            return Err(py_err(py, Error::option("phi", format!("{p} is not finite"))));
        }
        let nc = self.scene.channels().len();
        // At most a table's worth of values per call (`km bsdf`'s
        // `MAX_TABLE_VALUES`, 32 MB): 10^7 azimuths took 870 MB.
        let max = km::bsdf_file::MAX_TABLE_VALUES;
        if nc.saturating_mul(n) > max {
            let msg = format!(
                "{nc} channel(s) x {n} points = {} values, over the {max} of one call: \
                 evaluate in chunks",
                nc.saturating_mul(n)
            );
            return Err(py_err(py, Error::option("phi", msg)));
        }
        if n == 0 {
            return Ok(Vec::<f64>::new().into_pyarray(py).reshape([nc, 0])?.into_any());
        }
        let out = guarded(py, || {
            let (ui, ii) = distinct(&ti);
            let (uo, io) = distinct(&to);
            let b = self.build(side, &ui, &uo)?;
            let mut out = vec![0.0; nc * n];
            for c in 0..nc {
                for k in 0..n {
                    let v = &mut out[c * n + k..c * n + k + 1];
                    b.eval_into(c, ii[k], io[k], &ph[k..k + 1], transmitted, v);
                }
            }
            Ok(out)
        })?;
        Ok(out.into_pyarray(py).reshape([nc, n])?.into_any())
    }

    /// Totals and delta parts per incidence (`channels x n_i` arrays).
    fn _totals<'py>(
        &self,
        py: Python<'py>,
        side: &str,
        theta_i: PyReadonlyArray1<'py, f64>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let ti = vec1(&theta_i);
        let nc = self.scene.channels().len();
        let d = PyDict::new(py);
        if ti.is_empty() {
            for k in TOTALS {
                d.set_item(k, Vec::<f64>::new().into_pyarray(py).reshape([nc, 0])?)?;
            }
            return Ok(d);
        }
        let b = guarded(py, || {
            let (ui, ii) = distinct(&ti);
            Ok((self.build(side, &ui, &[0.0])?, ii))
        })?;
        let (b, ii) = b;
        for (k, name) in TOTALS.iter().enumerate() {
            let flat: Vec<f64> = b
                .channels
                .iter()
                .flat_map(|c| {
                    let v = match k {
                        0 => &c.reflectance,
                        1 => &c.transmittance,
                        2 => &c.reflectance_specular,
                        _ => &c.transmittance_direct,
                    };
                    ii.iter().map(move |&i| v[i])
                })
                .collect();
            d.set_item(name, flat.into_pyarray(py).reshape([nc, ti.len()])?)?;
        }
        Ok(d)
    }

    /// The arrays of `km bsdf --format npz` on the grids given; `exact`:
    /// with the exact single rough path (eq. R18 of docs/rough.md), else
    /// the series alone ([`Bsdf::drop_exact_paths`]).
    fn _table<'py>(
        &self,
        py: Python<'py>,
        side: &str,
        theta_i: PyReadonlyArray1<'py, f64>,
        theta_o: PyReadonlyArray1<'py, f64>,
        phi: PyReadonlyArray1<'py, f64>,
        exact: bool,
    ) -> PyResult<Bound<'py, PyDict>> {
        let (ti, to, ph) = (vec1(&theta_i), vec1(&theta_o), vec1(&phi));
        // The grid budget of `km bsdf` at budget 1 (angle pairs and table
        // values), before any work: a 1024 x 1024 x 72 table took 1.45 GB.
        let request = km::bsdf_file::BsdfRequest {
            theta_i: ti.clone(),
            theta_o: to.clone(),
            phi: ph.clone(),
            from_below: side == "below",
            streams: self.opts.streams,
            fourier_tol: Some(self.opts.fourier_tol),
            format: km::bsdf_file::BsdfFormat::Npz,
            budget: 1.0,
            channel_mix: None,
        };
        km::bsdf_file::check_grid(self.scene.channels().len(), &request, true, 1.0).map_err(
            |e| match e {
                km::bsdf::BsdfError::Input { name, reason } => {
                    py_err(py, Error::option(name, reason))
                }
                e => py_err(py, Error::option("phi", e.to_string())),
            },
        )?;
        let (b, brdf, btdf) = guarded(py, || {
            let mut b = self.build(side, &ti, &to)?;
            if !exact {
                b.drop_exact_paths();
            }
            let t = km::bsdf::write::Table::new(&b, &ph)?;
            let (r, t) = (t.brdf, t.btdf);
            Ok((b, r, t))
        })?;
        let (nc, ni, no, np) = (b.channels.len(), ti.len(), to.len(), ph.len());
        let d = PyDict::new(py);
        d.set_item("theta_i", ti.into_pyarray(py))?;
        d.set_item("theta_o", to.into_pyarray(py))?;
        d.set_item("phi", ph.into_pyarray(py))?;
        d.set_item("brdf", brdf.into_pyarray(py).reshape([nc, ni, no, np])?)?;
        d.set_item("btdf", btdf.into_pyarray(py).reshape([nc, ni, no, np])?)?;
        for (k, name) in TOTALS.iter().enumerate() {
            let flat: Vec<f64> = b
                .channels
                .iter()
                .flat_map(|c| {
                    match k {
                        0 => &c.reflectance,
                        1 => &c.transmittance,
                        2 => &c.reflectance_specular,
                        _ => &c.transmittance_direct,
                    }
                    .clone()
                })
                .collect();
            d.set_item(name, flat.into_pyarray(py).reshape([nc, ni])?)?;
        }
        let orders: Vec<usize> = (0..nc).map(|c| b.orders(c)).collect();
        d.set_item("fourier_orders", orders)?;
        d.set_item("streams", b.channels.iter().map(|c| c.streams).max())?;
        Ok(d)
    }

    fn __reduce__<'py>(slf: &Bound<'py, Self>) -> PyResult<Reduced<'py>> {
        let py = slf.py();
        let me = slf.get();
        let scene = py.get_type::<PyScene>().getattr("from_toml")?.call1((me.toml.clone(),))?;
        let args = (scene, me.streams(), me.opts.max_fourier_order, me.opts.fourier_tol);
        Ok((slf.get_type().into_any(), args))
    }
}

/// What `__reduce__` returns: the class and its arguments.
type Reduced<'py> = (Bound<'py, PyAny>, (Bound<'py, PyAny>, usize, Option<usize>, f64));

/// Names of the per-incidence totals, in the order of `ChannelBsdf`'s fields.
const TOTALS: [&str; 4] =
    ["reflectance", "transmittance", "reflectance_specular", "transmittance_direct"];
