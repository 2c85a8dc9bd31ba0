//! `km.fit`: optical properties of a slab from its measured reflectance and
//! transmittance (km-inverse's slab inverse, `km fit`; docs/inverse.md), one
//! point or many in parallel (a spectrum) with the GIL released.

use km_inverse::forward::Sample;
use km_inverse::reflectance::Fixed;
use km_inverse::request::FileKind;
use km_inverse::slab::{FitOptions, FitResult, Measurement, Setup};
use km_inverse::spectrum::{RowFit, RowFixed, RowOverrides, check_fixed, fit_rows, rows_json};
use numpy::PyReadonlyArray1;
use pyo3::prelude::*;
use pyo3::types::PyList;
use rayon::prelude::*;

use super::convert::json_to_py;
use super::interrupt::interruptible;
use super::{guarded, py_err};
use crate::error::Error;

/// The result of one slab fit (`km.fit` with scalar readings).
///
/// `to_dict()` is the `km fit --json` object (docs/inverse.md §6). Over many
/// points `km.fit` returns a `km.FitResults` dict of arrays instead.
///
/// Attributes
/// ----------
/// albedo, tau, g : float
///     Single-scattering albedo, optical thickness, anisotropy.
/// mu_a, mu_s, mu_s_prime : float
///     Absorption, scattering and reduced scattering coefficients, 1/(unit
///     of the thickness).
/// fitted : dict
///     What the fitted sample would read (`m_r`, `m_t`[, `m_u`]).
/// residual : float
///     Weighted residual of the fit.
/// status : str
///     How the fit ended (`converged`, ...).
/// uncertainty : dict
///     Standard uncertainties, correlations and conditioning.
/// streams, evaluations : int
///     Streams of the forward model; its evaluations.
/// notes : list of str
///     Remarks of the fit.
///
/// Examples
/// --------
/// >>> import km
/// >>> r = km.fit(0.2726, 0.2991, thickness=1, n_sample=1.4, n_slide=1.5)
/// >>> r.status, round(r.albedo, 3)
/// ('converged', 0.9)
#[pyclass(frozen, name = "FitResult", module = "km")]
pub struct PyFitResult {
    r: FitResult,
}

#[pymethods]
impl PyFitResult {
    /// Single-scattering albedo `mu_s / (mu_a + mu_s)`.
    #[getter]
    fn albedo(&self) -> f64 {
        self.r.albedo
    }
    /// Optical thickness `(mu_a + mu_s) d`.
    #[getter]
    fn tau(&self) -> f64 {
        self.r.tau
    }
    /// Anisotropy (fixed, or fitted when M_U was given).
    #[getter]
    fn g(&self) -> f64 {
        self.r.g
    }
    /// Absorption coefficient, 1/(unit of the thickness).
    #[getter]
    fn mu_a(&self) -> f64 {
        self.r.mu_a
    }
    /// Scattering coefficient, 1/(unit of the thickness).
    #[getter]
    fn mu_s(&self) -> f64 {
        self.r.mu_s
    }
    /// Reduced scattering coefficient `mu_s (1 - g)`.
    #[getter]
    fn mu_s_prime(&self) -> f64 {
        self.r.mu_s_prime
    }
    /// What the fitted sample would read: `{"m_r", "m_t"[, "m_u"]}`.
    #[getter]
    fn fitted<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        json_to_py(py, &self.r.to_json()["fitted"])
    }
    /// Weighted residual of the fit.
    #[getter]
    fn residual(&self) -> f64 {
        self.r.residual
    }
    /// How the fit ended (`converged`, ...; the JSON's `status`).
    #[getter]
    fn status(&self) -> String {
        self.r.to_json()["status"].as_str().unwrap_or_default().to_string()
    }
    /// Standard uncertainties, correlations and conditioning (a dict).
    #[getter]
    fn uncertainty<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        json_to_py(py, &self.r.to_json()["uncertainty"])
    }
    /// Streams of the forward model.
    #[getter]
    fn streams(&self) -> usize {
        self.r.streams
    }
    /// Forward-model evaluations.
    #[getter]
    fn evaluations(&self) -> usize {
        self.r.evaluations
    }
    /// Remarks of the fit.
    #[getter]
    fn notes(&self) -> Vec<String> {
        self.r.notes.clone()
    }
    /// The `km fit --json` object, as a dict.
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        json_to_py(py, &self.r.to_json())
    }
    /// HTML for Jupyter: the fitted values and an SVG plot of the fitted readings.
    fn _repr_html_(slf: &Bound<'_, Self>) -> PyResult<String> {
        slf.py().import("km._repr")?.call_method1("fit_html", (slf,))?.extract()
    }
    fn __repr__(&self) -> String {
        format!(
            "km.FitResult(albedo={:.6}, tau={:.6}, g={:.4}, mu_a={:.6e}, mu_s_prime={:.6e}, \
             status={})",
            self.r.albedo,
            self.r.tau,
            self.r.g,
            self.r.mu_a,
            self.r.mu_s_prime,
            self.status()
        )
    }
}

/// The sample and how it was measured (the flags of `km fit`).
#[derive(Clone, Copy)]
struct How {
    thickness: f64,
    n_sample: f64,
    n_slide: Option<f64>,
    incidence: f64,
    specular_in_m_r: f64,
    unscattered_in_m_t: f64,
    streams: Option<usize>,
}

impl How {
    fn setup(&self) -> Result<Setup, Error> {
        let sample = Sample::new(self.thickness, self.n_sample, self.n_slide)?
            .with_incidence(self.incidence)?;
        Ok(Setup {
            specular_in_m_r: self.specular_in_m_r,
            unscattered_in_m_t: self.unscattered_in_m_t,
            ..Setup::new(sample)
        })
    }
}

/// One measurement point: `m_r, m_t, m_u, sigma_r, sigma_t, sigma_u, g`.
type Point = (f64, f64, Option<f64>, Option<f64>, Option<f64>, Option<f64>, Option<f64>);

fn fit_point(set: &Setup, how: &How, p: Point) -> Result<FitResult, Error> {
    let (m_r, m_t, m_u, sigma_r, sigma_t, sigma_u, g) = p;
    let meas = Measurement { m_r, m_t, m_u, sigma_r, sigma_t, sigma_u };
    Ok(km_inverse::fit(set, &meas, &FitOptions { g, streams: how.streams })?)
}

/// Fit one slab (see `km.fit`).
#[pyfunction]
#[pyo3(signature = (m_r, m_t, m_u=None, *, thickness, n_sample=1.0, n_slide=None, g=None,
                    sigma_r=None, sigma_t=None, sigma_u=None, specular_in_m_r=1.0,
                    unscattered_in_m_t=1.0, incidence=0.0, streams=None))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn _fit(
    py: Python<'_>,
    m_r: f64,
    m_t: f64,
    m_u: Option<f64>,
    thickness: f64,
    n_sample: f64,
    n_slide: Option<f64>,
    g: Option<f64>,
    sigma_r: Option<f64>,
    sigma_t: Option<f64>,
    sigma_u: Option<f64>,
    specular_in_m_r: f64,
    unscattered_in_m_t: f64,
    incidence: f64,
    streams: Option<usize>,
) -> PyResult<PyFitResult> {
    let how = How {
        thickness,
        n_sample,
        n_slide,
        incidence,
        specular_in_m_r,
        unscattered_in_m_t,
        streams,
    };
    let r = guarded(py, || {
        let set = how.setup()?;
        fit_point(&set, &how, (m_r, m_t, m_u, sigma_r, sigma_t, sigma_u, g))
    })?;
    Ok(PyFitResult { r })
}

/// An optional column: NaN entries are "not given".
fn column(a: &Option<PyReadonlyArray1<'_, f64>>, n: usize) -> Result<Vec<Option<f64>>, Error> {
    match a {
        None => Ok(vec![None; n]),
        Some(a) => {
            let v: Vec<Option<f64>> =
                a.as_array().iter().map(|x| (!x.is_nan()).then_some(*x)).collect();
            if v.len() != n {
                return Err(Error::option("m_u", "every column has the length of m_r"));
            }
            Ok(v)
        }
    }
}

/// Fit many points of one sample in parallel (see `km.fit`); a list of
/// `FitResult` or, where a point fails, its `KmError`.
#[pyfunction]
#[pyo3(signature = (m_r, m_t, m_u, g, sigma_r, sigma_t, sigma_u, *, thickness, n_sample=1.0,
                    n_slide=None, specular_in_m_r=1.0, unscattered_in_m_t=1.0, incidence=0.0,
                    streams=None, budget=1.0))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn _fit_many<'py>(
    py: Python<'py>,
    m_r: PyReadonlyArray1<'py, f64>,
    m_t: PyReadonlyArray1<'py, f64>,
    m_u: Option<PyReadonlyArray1<'py, f64>>,
    g: Option<PyReadonlyArray1<'py, f64>>,
    sigma_r: Option<PyReadonlyArray1<'py, f64>>,
    sigma_t: Option<PyReadonlyArray1<'py, f64>>,
    sigma_u: Option<PyReadonlyArray1<'py, f64>>,
    thickness: f64,
    n_sample: f64,
    n_slide: Option<f64>,
    specular_in_m_r: f64,
    unscattered_in_m_t: f64,
    incidence: f64,
    streams: Option<usize>,
    budget: f64,
) -> PyResult<Bound<'py, PyList>> {
    let how = How {
        thickness,
        n_sample,
        n_slide,
        incidence,
        specular_in_m_r,
        unscattered_in_m_t,
        streams,
    };
    let (r, t): (Vec<f64>, Vec<f64>) =
        (m_r.as_array().to_vec(), m_t.as_array().iter().copied().collect());
    let n = r.len();
    let cols = (|| -> Result<_, Error> {
        let max = row_budget(budget)?;
        if n > max {
            return Err(Error::option(
                "m_r",
                format!(
                    "{n} readings, over the budget of {max} fits a call (about 0.5 ms a fit): \
                     raise it with budget= or fit in chunks"
                ),
            ));
        }
        if t.len() != n {
            return Err(Error::option("m_t", "every column has the length of m_r"));
        }
        Ok([
            column(&m_u, n)?,
            column(&g, n)?,
            column(&sigma_r, n)?,
            column(&sigma_t, n)?,
            column(&sigma_u, n)?,
        ])
    })()
    .map_err(|e| py_err(py, e))?;
    // Stoppable by Ctrl-C between points (one fit is short).
    let results = interruptible(py, |cancel| {
        let set = how.setup()?;
        let fits = (0..n)
            .into_par_iter()
            .map(|i| {
                if cancel.is_cancelled() {
                    return Err(Error::Cancelled);
                }
                let p = (r[i], t[i], cols[0][i], cols[2][i], cols[3][i], cols[4][i], cols[1][i]);
                fit_point(&set, &how, p)
            })
            .collect::<Vec<_>>();
        if cancel.is_cancelled() {
            return Err(Error::Cancelled);
        }
        Ok(fits)
    })?;
    let list = PyList::empty(py);
    for r in results {
        match r {
            Ok(r) => list.append(Bound::new(py, PyFitResult { r })?)?,
            Err(e) => list.append(py_err(py, e).into_value(py))?,
        }
    }
    Ok(list)
}

/// The fixed quantity of the rows that give M_R alone (`km fit`'s
/// `--fix-mu-s`, `--fix-mu-a`, `--semi-infinite`): at most one; `fix_mu_s` a
/// number or iad's power law text (`km_inverse::spectrum::RowFixed::parse_mu_s`).
fn row_fixed(
    fix_mu_s: Option<&Bound<'_, PyAny>>,
    fix_mu_a: Option<f64>,
    semi_infinite: bool,
) -> Result<Option<RowFixed>, Error> {
    let mu_s = match fix_mu_s {
        None => None,
        Some(v) => Some(if let Ok(x) = v.extract::<f64>() {
            if !x.is_finite() {
                return Err(Error::option("fix_mu_s", format!("{x}: must be finite")));
            }
            RowFixed::Same(Fixed::MuS(x))
        } else if let Ok(t) = v.extract::<String>() {
            RowFixed::parse_mu_s(&t).map_err(|e| Error::option("fix_mu_s", e))?
        } else {
            return Err(Error::option(
                "fix_mu_s",
                "a number or a power law text 'P L0 MU_S0 EXP' / 'R L0 MU_SP0 EXP'",
            ));
        }),
    };
    if let Some(a) = fix_mu_a
        && !(a.is_finite() && a >= 0.0)
    {
        return Err(Error::option("fix_mu_a", format!("{a}: must be finite and >= 0")));
    }
    RowFixed::one_of(mu_s, fix_mu_a, semi_infinite)
        .map_err(|e| Error::option("fix_mu_s", e.to_string()))
}

/// The row budget of a call at `budget` (`km_inverse::rxt::max_rows`,
/// 10^4 rows at 1), refusing a factor that is not finite and `> 0`.
fn row_budget(budget: f64) -> Result<usize, Error> {
    if !(budget.is_finite() && budget > 0.0) {
        return Err(Error::option("budget", format!("must be a finite factor > 0, not {budget}")));
    }
    Ok(km_inverse::rxt::max_rows(budget))
}

/// Largest measurement file read (bytes): a spectrum of 10^5 rows is ~5 MB.
const MAX_FILE_BYTES: u64 = 64 << 20;

/// Fit every row of a measurement file (see `km.fit_file`): the list of
/// `km fit FILE --json`, as dicts.
#[pyfunction]
#[pyo3(signature = (path, *, thickness=None, n_sample=1.0, n_slide=None, g=None, sigma_r=None,
                    sigma_t=None, sigma_u=None, specular_in_m_r=1.0, unscattered_in_m_t=1.0,
                    incidence=0.0, streams=None, fix_mu_s=None, fix_mu_a=None,
                    semi_infinite=false, budget=1.0))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn fit_file<'py>(
    py: Python<'py>,
    path: std::path::PathBuf,
    thickness: Option<f64>,
    n_sample: f64,
    n_slide: Option<f64>,
    g: Option<f64>,
    sigma_r: Option<f64>,
    sigma_t: Option<f64>,
    sigma_u: Option<f64>,
    specular_in_m_r: f64,
    unscattered_in_m_t: f64,
    incidence: f64,
    streams: Option<usize>,
    fix_mu_s: Option<Bound<'py, PyAny>>,
    fix_mu_a: Option<f64>,
    semi_infinite: bool,
    budget: f64,
) -> PyResult<Bound<'py, PyAny>> {
    let fixed = row_fixed(fix_mu_s.as_ref(), fix_mu_a, semi_infinite).map_err(|e| py_err(py, e))?;
    let max = row_budget(budget).map_err(|e| py_err(py, e))?;
    let raise = "raise it with budget= or fit the file in parts";
    if let Err(io) = std::fs::metadata(&path)
        && io.kind() == std::io::ErrorKind::NotFound
    {
        let e = Error::option("path", format!("{}: cannot read: {io}", path.display()));
        return Err(super::file_err(py, &path, e));
    }
    let list = interruptible(py, |cancel| {
        let name = path.display().to_string();
        let cannot = |e: String| Error::option("path", format!("{name}: {e}"));
        // The checked reader: a FIFO or /dev/zero is refused before opening.
        let text = km::read_checked_text(&path, MAX_FILE_BYTES, "a measurement file", "")
            .map_err(|e| cannot(e.to_string()))?;
        let rows = match FileKind::of(&path) {
            Some(FileKind::Rxt) => km_inverse::rxt::parse_rxt_within(&text, max, raise),
            Some(FileKind::Csv) => {
                let Some(thickness) = thickness else {
                    return Err(Error::option("thickness", "is required for a .csv file"));
                };
                let how = How {
                    thickness,
                    n_sample,
                    n_slide,
                    incidence,
                    specular_in_m_r,
                    unscattered_in_m_t,
                    streams,
                };
                km_inverse::rxt::parse_csv_within(&text, &how.setup()?, max, raise)
            }
            None => return Err(cannot("expected a .rxt or .csv file".into())),
        }
        .map_err(|e| cannot(e.to_string()))?;
        check_fixed(&rows, fixed).map_err(|e| Error::option("fix_mu_s", format!("{name}: {e}")))?;
        // As `km fit FILE` (km_inverse::spectrum): fractions other than 1
        // override the file, the sigmas and g given here stand where a row
        // has none; the rows are fitted in parallel, each as the command does.
        let sigmas = [sigma_r, sigma_t, sigma_u];
        let over = RowOverrides::from_options(specular_in_m_r, unscattered_in_m_t, sigmas, fixed);
        let opts = FitOptions { g, streams };
        // Stoppable by Ctrl-C between rows.
        let fits: Vec<RowFit> = rows
            .par_iter()
            .flat_map_iter(|row| {
                if cancel.is_cancelled() {
                    return Vec::new();
                }
                fit_rows(std::slice::from_ref(row), &over, &opts)
            })
            .collect();
        if cancel.is_cancelled() {
            return Err(Error::Cancelled);
        }
        if !fits.is_empty() && fits.iter().all(|f| f.result.is_err()) {
            return Err(cannot("no row could be fitted".into()));
        }
        Ok(rows_json(&fits))
    })?;
    json_to_py(py, &list)
}
