//! The extension module `km._km` (feature `python`): thin wrappers of
//! [`crate::engine`], [`crate::build`], [`crate::sweep`] and the Monte Carlo
//! shards, with the GIL released while Rust works; the long calls stop on
//! Ctrl-C, and parallel work runs after a fork (module `interrupt`).
//!
//! Every error is a `km.KmError` (a `ValueError`) with attributes `key` and
//! `line`; a panic inside a solver is caught at this boundary and becomes a
//! `km.KmError` too (a last guard: solvers return errors, they do not panic).
//!
//! Modules: `convert` (Python values to scene TOML, JSON to Python),
//! `scene` (`km.Scene`), `solution` (`km.Solution`), `batch` (`km.solve`,
//! batch solves, Monte Carlo shards), `bsdf` (`km.Bsdf`), `fit` (`km.fit`),
//! `fit_km` (`km.fit_km`, `km.colour`), `phase` (`km.phase`, `km.mie`).

use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

use crate::error::Error;

mod batch;
mod bsdf;
mod convert;
mod field;
mod fit;
mod fit_km;
mod interrupt;
mod phase;
mod scene;
mod settings;
mod solution;

pub(crate) use scene::PyScene;
pub(crate) use solution::PySolution;

pyo3::create_exception!(
    km,
    KmError,
    PyValueError,
    "Bad input to km: a scene, an option or a method that cannot treat the scene.\n\n\
     A subclass of ``ValueError``; ``str(err)`` is the message of the ``km``\n\
     command, word for word. Two subclasses add a standard base:\n\
     ``km.KmTypeError`` (also a ``TypeError``) and ``km.KmFileNotFoundError``\n\
     (also a ``FileNotFoundError``), so ``except km.KmError`` catches them all.\n\n\
     Attributes\n\
     ----------\n\
     key : str or None\n\
     \x20   The scene key or option named (``layer[1].albedo``, ``streams``).\n\
     line : int or None\n\
     \x20   1-based line of the scene text, or None.\n\n\
     Examples\n\
     --------\n\
     >>> import km\n\
     >>> try:\n\
     ...     km.Scene.from_toml(\"[[layer]]\\ntau = 1.0\\nalbedo = 1.5\\n\")\n\
     ... except km.KmError as e:\n\
     ...     print(e.key, e.line)\n\
     layer[1].albedo 3\n"
);

/// A `km.KmError` with `key` and `line` set.
pub(crate) fn py_err(py: Python<'_>, e: Error) -> PyErr {
    let err = KmError::new_err(e.to_string());
    let v = err.value(py);
    // Setting attributes on a fresh exception instance cannot fail in practice;
    // if it did, the message still carries key and line.
    let _ = v.setattr("key", e.key());
    let _ = v.setattr("line", e.line());
    err
}

/// A `km.KmError` of the subclass `class` of `km._errors` (`KmTypeError`,
/// `KmFileNotFoundError`), with `key` and `line` set; a plain `km.KmError`
/// if that class cannot be found.
pub(crate) fn py_err_as(py: Python<'_>, e: Error, class: &str) -> PyErr {
    let (msg, key, line) = (e.to_string(), e.key().map(str::to_string), e.line());
    let made =
        py.import("km._errors").and_then(|m| m.getattr(class)).and_then(|c| c.call1((&msg,)));
    match made {
        Ok(v) => {
            // As in `py_err`: the message carries key and line in any case.
            let _ = v.setattr("key", key);
            let _ = v.setattr("line", line);
            PyErr::from_value(v)
        }
        Err(_) => py_err(py, e),
    }
}

/// A missing file as `km.KmFileNotFoundError` (a `FileNotFoundError` and a
/// `km.KmError`) with `errno`, `strerror` and `filename` set; `e` otherwise.
pub(crate) fn file_err(py: Python<'_>, path: &std::path::Path, e: Error) -> PyErr {
    let missing =
        matches!(std::fs::metadata(path), Err(io) if io.kind() == std::io::ErrorKind::NotFound);
    if !missing {
        return py_err(py, e);
    }
    let msg = e.to_string();
    let err = py_err_as(py, e, "KmFileNotFoundError");
    let v = err.value(py);
    let _ = v.setattr("errno", 2);
    let _ = v.setattr("strerror", msg);
    let _ = v.setattr("filename", path.display().to_string());
    err
}

/// Run `f` with the GIL released, turning a panic into [`Error::Internal`]
/// (on a pool of this process after a fork: [`interrupt::fork_safe`]). A
/// signal waits until `f` returns: for the calls whose work is short or
/// bounded by a budget; the long ones are [`interrupt::interruptible`].
pub(crate) fn guarded<T: Send>(
    py: Python<'_>,
    f: impl FnOnce() -> Result<T, Error> + Send,
) -> PyResult<T> {
    py.detach(|| interrupt::caught(|| interrupt::fork_safe(f))).map_err(|e| py_err(py, e))
}

/// The extension module `km._km`.
#[pymodule]
fn _km(m: &Bound<'_, PyModule>) -> PyResult<()> {
    interrupt::init();
    m.add("KmError", m.py().get_type::<KmError>())?;
    m.add_class::<PyScene>()?;
    m.add_class::<PySolution>()?;
    m.add_class::<batch::PyPartial>()?;
    m.add_class::<bsdf::PyBsdfCore>()?;
    m.add_class::<fit::PyFitResult>()?;
    m.add_function(wrap_pyfunction!(fit::_fit, m)?)?;
    m.add_function(wrap_pyfunction!(fit::_fit_many, m)?)?;
    m.add_function(wrap_pyfunction!(fit::fit_file, m)?)?;
    m.add_function(wrap_pyfunction!(fit_km::fit_km, m)?)?;
    m.add_function(wrap_pyfunction!(fit_km::colour_of, m)?)?;
    m.add_function(wrap_pyfunction!(fit_km::delta_e2000, m)?)?;
    m.add_function(wrap_pyfunction!(fit_km::srgb, m)?)?;
    m.add_function(wrap_pyfunction!(batch::_solve, m)?)?;
    m.add_function(wrap_pyfunction!(batch::_solve_scenes, m)?)?;
    m.add_function(wrap_pyfunction!(batch::_solve_sweep, m)?)?;
    m.add_function(wrap_pyfunction!(batch::run_shard, m)?)?;
    m.add_function(wrap_pyfunction!(batch::merge, m)?)?;
    m.add_function(wrap_pyfunction!(field::field, m)?)?;
    m.add_function(wrap_pyfunction!(field::profile, m)?)?;
    m.add_function(wrap_pyfunction!(phase::_phase, m)?)?;
    m.add_function(wrap_pyfunction!(phase::_mie, m)?)?;
    m.add_function(wrap_pyfunction!(settings::_settings, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
