//! `km.solve`, batch solves (`km.solve_many`) and Monte Carlo shards
//! (`km.run_shard`, `km.merge`, `km.Partial`).

use km::{Scene, Solution};
use numpy::{IntoPyArray, PyArrayMethods, PyReadonlyArray2};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use super::interrupt::interruptible;
use super::settings::options_from;
use super::{PyScene, PySolution, guarded, py_err};
use crate::engine::Options;
use crate::error::Error;
use crate::sweep::Columns;
use km::Method;

/// The partial tally of one Monte Carlo shard, made by `km.run_shard`.
///
/// `km.merge` combines all shards of a run into exactly (bit for bit) the
/// single-run result. Picklable exactly (the sums travel as IEEE-754 bit
/// patterns); `to_json()` is the `km solve --shard --out` file, which
/// `km merge` reads, so shards from Python and the command line mix.
///
/// Attributes
/// ----------
/// index, count : int
///     This shard and the number of shards of the run.
/// samples, seed : int
///     Photons per channel and seed of the whole run.
/// seconds : float
///     Tracing wall time of this shard.
///
/// Examples
/// --------
/// >>> import km, pickle
/// >>> s = km.Scene(layers=[km.layer(tau=1.0, albedo=0.9)])
/// >>> p = km.run_shard(s, 0, 2, samples=1000)
/// >>> (p.index, p.count), pickle.loads(pickle.dumps(p)).to_json() == p.to_json()
/// ((0, 2), True)
#[pyclass(frozen, name = "Partial", module = "km")]
pub struct PyPartial {
    part: km::Partial,
}

#[pymethods]
impl PyPartial {
    /// A partial tally from its JSON text (the `km solve --shard` file format).
    ///
    /// Parameters
    /// ----------
    /// text : str
    ///     The file's text.
    ///
    /// Returns
    /// -------
    /// Partial
    ///
    /// Raises
    /// ------
    /// KmError
    ///     Text that is not a km shard.
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

/// Solve a scene: the extension's side of `km.solve` (km/_solve.py), with
/// the settings of `km::settings::SETTINGS` as keyword arguments.
#[pyfunction]
#[pyo3(signature = (scene, method="multiflux", **settings))]
pub(crate) fn _solve(
    py: Python<'_>,
    scene: &Bound<'_, PyScene>,
    method: &str,
    settings: Option<&Bound<'_, PyDict>>,
) -> PyResult<PySolution> {
    let opts = options_from(py, method, settings)?;
    let scene = &scene.get().scene;
    // A Monte Carlo solve may last minutes: stoppable by Ctrl-C. The other
    // methods are bounded by their work budget and keep the cheaper call.
    let sol = if opts.method == Method::Mc {
        interruptible(py, |c| crate::engine::solve(scene, &opts.with_cancel(c)))?
    } else {
        guarded(py, || crate::engine::solve(scene, &opts))?
    };
    Ok(PySolution { sol })
}

/// The worker count of a batch (`threads`, taken out of the settings: in a
/// batch it sizes the pool, and each Monte Carlo point runs on one thread).
fn pool_threads(py: Python<'_>, settings: Option<&Bound<'_, PyDict>>) -> PyResult<Option<usize>> {
    let Some(d) = settings else { return Ok(None) };
    let Some(t) = d.get_item("threads")? else { return Ok(None) };
    d.del_item("threads")?;
    if t.is_none() {
        return Ok(None);
    }
    t.extract::<usize>().map(Some).map_err(|_| {
        py_err(py, Error::option("threads", format!("{t}: expected a whole number >= 1")))
    })
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
        Error::Setting { name, message } => {
            Error::Setting { name: name.clone(), message: message.clone() }
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
#[pyo3(signature = (scenes, method="multiflux", *, errors="raise", **settings))]
pub(crate) fn _solve_scenes<'py>(
    py: Python<'py>,
    scenes: Vec<Bound<'py, PyScene>>,
    method: &str,
    errors: &str,
    settings: Option<&Bound<'py, PyDict>>,
) -> PyResult<Bound<'py, PyDict>> {
    check_errors_mode(py, errors)?;
    let threads = pool_threads(py, settings)?;
    let opts = options_from(py, method, settings)?;
    let list: Vec<Scene> = scenes.iter().map(|s| s.get().scene.clone()).collect();
    let Some(first) = list.first() else {
        return Err(py_err(py, Error::option("scenes", "the batch is empty")));
    };
    let (channels, directions) =
        (first.channels().len(), first.channels()[0].directions_deg().len());
    if let Some(i) = list.iter().position(|s| {
        s.channels().len() != channels || s.channels()[0].directions_deg().len() != directions
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
    let labels = first.labels().to_vec();
    let results =
        interruptible(py, |c| crate::sweep::solve_many(&list, &opts.with_cancel(c), threads))?;
    columns_dict(py, results, channels, directions, labels, errors)
}

/// Batch solve of a parameter sweep of one scene (see `km.solve_many`).
#[pyfunction]
#[pyo3(signature = (scene, keys, values, method="multiflux", *, errors="raise", **settings))]
pub(crate) fn _solve_sweep<'py>(
    py: Python<'py>,
    scene: &Bound<'py, PyScene>,
    keys: Vec<String>,
    values: PyReadonlyArray2<'py, f64>,
    method: &str,
    errors: &str,
    settings: Option<&Bound<'py, PyDict>>,
) -> PyResult<Bound<'py, PyDict>> {
    check_errors_mode(py, errors)?;
    let threads = pool_threads(py, settings)?;
    let opts = options_from(py, method, settings)?;
    // Parsed here too, so that a bad key is named before the shape is checked.
    crate::sweep::quantities(&keys).map_err(|e| py_err(py, e))?;
    let view = values.as_array();
    if view.ncols() != keys.len() {
        return Err(py_err(py, Error::option("params", "one column of values per key")));
    }
    let flat: Vec<f64> = view.iter().copied().collect();
    let base = &scene.get().scene;
    let (channels, directions) = (base.channels().len(), base.channels()[0].directions_deg().len());
    let results = interruptible(py, |c| {
        crate::sweep::solve_sweep(base, &keys, &flat, &opts.with_cancel(c), threads)
    })?;
    columns_dict(py, results, channels, directions, base.labels().to_vec(), errors)
}

/// One shard of a Monte Carlo run (see `km.run_shard`).
#[pyfunction]
#[pyo3(signature = (scene, index, count, *, samples=None, seed=None, threads=None,
                    analog=false, all_effects=false))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn run_shard(
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
    let part = interruptible(py, |c| {
        Ok(km::mc_shard(scene, &opts.with_cancel(c).library()?, index, count)?)
    })?;
    Ok(PyPartial { part })
}

/// Merge Monte Carlo shards into the result of one run (see `km.merge`).
#[pyfunction]
pub(crate) fn merge(py: Python<'_>, parts: Vec<Bound<'_, PyPartial>>) -> PyResult<PySolution> {
    let parts: Vec<km::Partial> = parts.iter().map(|p| p.get().part.clone()).collect();
    let sol = guarded(py, || Ok(km::mc_merge(&parts)?))?;
    Ok(PySolution { sol })
}
