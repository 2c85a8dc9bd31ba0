//! `km.phase` and `km.mie`: each layer's phase function, moments and Mie
//! efficiencies (`km::phase_report`, docs/phase.md §6), and one sphere by
//! Mie theory, as numpy arrays (channels first).

use km::mie::{Complex, SizeDistribution};
use km::phase_report::{ChannelPhase, PhaseOptions, PopulationPhase, mie_sphere, phase_report};
use numpy::{Complex64, IntoPyArray, PyArrayMethods};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

use super::{PyScene, guarded};
use crate::error::Error;

/// Rows of equal length as one 2-D array (`width` columns when there is no row).
fn rows(py: Python<'_>, v: Vec<Vec<f64>>, width: usize) -> PyResult<Bound<'_, PyAny>> {
    let r = v.len();
    let flat: Vec<f64> = v.into_iter().flatten().collect();
    Ok(flat.into_pyarray(py).reshape([r, width])?.into_any())
}

fn complex(c: Complex) -> Complex64 {
    Complex64::new(c.re, c.im)
}

/// One value per channel of a layer, as a 1-D array.
fn per_channel<'py>(
    py: Python<'py>,
    chans: &[ChannelPhase],
    f: impl Fn(&ChannelPhase) -> f64,
) -> Bound<'py, PyAny> {
    chans.iter().map(f).collect::<Vec<f64>>().into_pyarray(py).into_any()
}

/// The particles of a layer: per population and for the mixture, one value
/// per channel (NaN in a channel without particles).
fn particles<'py>(py: Python<'py>, chans: &[ChannelPhase]) -> PyResult<Option<Bound<'py, PyDict>>> {
    let count =
        chans.iter().filter_map(|c| c.particles.as_ref()).map(|p| p.populations.len()).max();
    let Some(count) = count else { return Ok(None) };
    let pop = |c: &ChannelPhase, k: usize| -> Option<PopulationPhase> {
        c.particles.as_ref().and_then(|p| p.populations.get(k)).cloned()
    };
    let pops = PyList::empty(py);
    for k in 0..count {
        let d = PyDict::new(py);
        let num = |f: &dyn Fn(&PopulationPhase) -> f64| -> Bound<'py, PyAny> {
            chans
                .iter()
                .map(|c| pop(c, k).map_or(f64::NAN, |p| f(&p)))
                .collect::<Vec<f64>>()
                .into_pyarray(py)
                .into_any()
        };
        let cplx = |f: &dyn Fn(&PopulationPhase) -> Complex| -> Bound<'py, PyAny> {
            chans
                .iter()
                .map(|c| pop(c, k).map_or(Complex64::new(f64::NAN, f64::NAN), |p| complex(f(&p))))
                .collect::<Vec<Complex64>>()
                .into_pyarray(py)
                .into_any()
        };
        let kind = chans.iter().find_map(|c| pop(c, k)).map(|p| match p.distribution {
            SizeDistribution::Mono { .. } => "mono",
            SizeDistribution::LogNormal { .. } => "lognormal",
        });
        d.set_item("distribution", kind)?;
        d.set_item("index", cplx(&|p| p.index))?;
        d.set_item("volume_fraction", num(&|p| p.volume_fraction))?;
        d.set_item(
            "radius_um",
            num(&|p| match p.distribution {
                SizeDistribution::Mono { radius_um } => radius_um,
                SizeDistribution::LogNormal { .. } => f64::NAN,
            }),
        )?;
        d.set_item(
            "median_um",
            num(&|p| match p.distribution {
                SizeDistribution::LogNormal { median_um, .. } => median_um,
                SizeDistribution::Mono { .. } => f64::NAN,
            }),
        )?;
        d.set_item(
            "sigma",
            num(&|p| match p.distribution {
                SizeDistribution::LogNormal { sigma, .. } => sigma,
                SizeDistribution::Mono { .. } => f64::NAN,
            }),
        )?;
        d.set_item("r_eff_um", num(&|p| p.r_eff_um))?;
        d.set_item("x_eff", num(&|p| p.x_eff))?;
        d.set_item("m", cplx(&|p| p.m))?;
        d.set_item("q_ext", num(&|p| p.q_ext))?;
        d.set_item("q_sca", num(&|p| p.q_sca))?;
        d.set_item("q_abs", num(&|p| p.q_abs))?;
        d.set_item("g", num(&|p| p.g))?;
        d.set_item("sigma_s", num(&|p| p.sigma_s))?;
        d.set_item("sigma_a", num(&|p| p.sigma_a))?;
        d.set_item("terms", num(&|p| p.terms as f64))?;
        d.set_item("radii", num(&|p| p.radii as f64))?;
        pops.append(d)?;
    }
    let mixed = PyDict::new(py);
    let mix = |f: &dyn Fn(&km::phase_report::ParticlesPhase) -> f64| -> Bound<'py, PyAny> {
        per_channel(py, chans, |c| c.particles.as_ref().map_or(f64::NAN, f))
    };
    mixed.set_item("q_ext", mix(&|p| p.q_ext))?;
    mixed.set_item("q_sca", mix(&|p| p.q_sca))?;
    mixed.set_item("q_abs", mix(&|p| p.q_abs))?;
    mixed.set_item("g", mix(&|p| p.g))?;
    mixed.set_item("sigma_s", mix(&|p| p.sigma_s))?;
    mixed.set_item("sigma_a", mix(&|p| p.sigma_a))?;
    mixed.set_item("r_eff_um", mix(&|p| p.r_eff_um))?;
    mixed.set_item("x_eff", mix(&|p| p.x_eff))?;
    let out = PyDict::new(py);
    out.set_item("populations", pops)?;
    out.set_item("mixed", mixed)?;
    Ok(Some(out))
}

/// Each layer's phase function (see `km.phase`).
#[pyfunction]
#[pyo3(signature = (scene, angles_deg=None, moments=None))]
pub(crate) fn _phase<'py>(
    py: Python<'py>,
    scene: &Bound<'py, PyScene>,
    angles_deg: Option<Vec<f64>>,
    moments: Option<usize>,
) -> PyResult<Bound<'py, PyDict>> {
    let scene = &scene.get().scene;
    let opts = PhaseOptions { angles_deg, moments };
    let r = guarded(py, || phase_report(scene, &opts).map_err(Error::Scene))?;
    let (na, nk) = (r.angles_deg.len(), r.max_moment + 1);
    let d = PyDict::new(py);
    d.set_item("normalisation", km::phase_report::NORMALISATION)?;
    d.set_item("labels", r.labels.clone())?;
    d.set_item("wavelengths_nm", r.wavelengths_nm.clone().map(|w| w.into_pyarray(py)))?;
    d.set_item("angles_deg", r.angles_deg.clone().into_pyarray(py))?;
    d.set_item("cos_theta", r.cos_theta.clone().into_pyarray(py))?;
    d.set_item("max_moment", r.max_moment)?;
    d.set_item("default_streams", r.default_streams)?;
    let layers = PyList::empty(py);
    for (i, chans) in r.layers.iter().enumerate() {
        let l = PyDict::new(py);
        l.set_item("layer", i + 1)?;
        l.set_item("kind", chans.iter().map(|c| c.kind).collect::<Vec<_>>())?;
        l.set_item(
            "scatters",
            chans.iter().map(|c| c.scatters).collect::<Vec<_>>().into_pyarray(py),
        )?;
        l.set_item("sigma_a", per_channel(py, chans, |c| c.sigma_a))?;
        l.set_item("sigma_s", per_channel(py, chans, |c| c.sigma_s))?;
        l.set_item("thickness", per_channel(py, chans, |c| c.thickness))?;
        l.set_item("tau", per_channel(py, chans, |c| c.tau))?;
        l.set_item("albedo", per_channel(py, chans, |c| c.albedo))?;
        l.set_item("n", per_channel(py, chans, |c| c.n))?;
        l.set_item("g", per_channel(py, chans, |c| c.g))?;
        l.set_item("series_length", chans.iter().map(|c| c.series_length).collect::<Vec<_>>())?;
        let filled =
            |v: &Vec<f64>, len: usize| if v.is_empty() { vec![f64::NAN; len] } else { v.clone() };
        l.set_item("p", rows(py, chans.iter().map(|c| filled(&c.p, na)).collect(), na)?)?;
        l.set_item(
            "moments",
            rows(py, chans.iter().map(|c| filled(&c.moments, nk)).collect(), nk)?,
        )?;
        l.set_item("particles", particles(py, chans)?)?;
        layers.append(l)?;
    }
    d.set_item("layers", layers)?;
    Ok(d)
}

/// One sphere by Mie theory (see `km.mie`).
#[pyfunction]
#[pyo3(signature = (radius_um, n, k, wavelength_nm, n_host=1.0, angles_deg=None, moments=None))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn _mie<'py>(
    py: Python<'py>,
    radius_um: f64,
    n: f64,
    k: f64,
    wavelength_nm: f64,
    n_host: f64,
    angles_deg: Option<Vec<f64>>,
    moments: Option<usize>,
) -> PyResult<Bound<'py, PyDict>> {
    let s = guarded(py, || {
        mie_sphere(radius_um, n, k, wavelength_nm, n_host, angles_deg.as_deref(), moments)
            .map_err(Error::Scene)
    })?;
    let d = PyDict::new(py);
    d.set_item("x", s.x)?;
    d.set_item("m", pyo3::types::PyComplex::from_doubles(py, s.m.re, s.m.im))?;
    d.set_item("qext", s.q_ext)?;
    d.set_item("qsca", s.q_sca)?;
    d.set_item("qabs", s.q_abs)?;
    d.set_item("qback", s.q_back)?;
    d.set_item("g", s.g)?;
    d.set_item("terms", s.terms)?;
    d.set_item("angles_deg", s.angles_deg.into_pyarray(py))?;
    d.set_item("cos_theta", s.cos_theta.into_pyarray(py))?;
    d.set_item("s1", s.s1.into_iter().map(complex).collect::<Vec<_>>().into_pyarray(py))?;
    d.set_item("s2", s.s2.into_iter().map(complex).collect::<Vec<_>>().into_pyarray(py))?;
    d.set_item("p", s.p.into_pyarray(py))?;
    d.set_item("moments", s.moments.into_pyarray(py))?;
    Ok(d)
}
