//! `photostereo._native`: the compiled half of the Python package `photostereo`.
//!
//! The public API (argument checking, accepting a `Dataset`, a path or an array, the
//! docstrings) is `python/photostereo/__init__.py`; the functions here take plain arrays
//! and paths. Every computation runs with the GIL released ([`compute`]) and inside
//! `catch_unwind`, so no panic reaches Python; library errors become `FileNotFoundError`
//! (a missing path), `OSError` (other file problems) or `ValueError` (bad data), with the
//! library's message, which names the file and the fix.

mod convert;
mod dataset;
mod funcs;
mod table;

use std::panic::{catch_unwind, AssertUnwindSafe};

use photostereo::Error;
use pyo3::exceptions::{PyFileNotFoundError, PyOSError, PyRuntimeError, PyValueError};
use pyo3::prelude::*;

/// A library error as the Python exception of its kind, with the library's message.
pub(crate) fn to_py(e: Error) -> PyErr {
    let msg = e.to_string();
    match e.root() {
        Error::NotFound { .. } => PyFileNotFoundError::new_err(msg),
        Error::Io { cause, .. } if cause.kind() == std::io::ErrorKind::NotFound => {
            PyFileNotFoundError::new_err(msg)
        }
        Error::Io { .. } => PyOSError::new_err(msg),
        _ => PyValueError::new_err(msg),
    }
}

/// Run `f` with the GIL released; a library error becomes its Python exception and a
/// panic (a bug) a `RuntimeError` saying so, never a crash of the interpreter.
pub(crate) fn compute<T: Send>(
    py: Python<'_>,
    f: impl FnOnce() -> photostereo::Result<T> + Send,
) -> PyResult<T> {
    let out = py.detach(|| catch_unwind(AssertUnwindSafe(f)));
    match out {
        Ok(Ok(v)) => Ok(v),
        Ok(Err(e)) => Err(to_py(e)),
        Err(panic) => {
            let what = panic
                .downcast_ref::<String>()
                .cloned()
                .or_else(|| panic.downcast_ref::<&str>().map(|s| s.to_string()))
                .unwrap_or_else(|| "unknown".into());
            Err(PyRuntimeError::new_err(format!(
                "internal error in photostereo (please report it): {what}"
            )))
        }
    }
}

#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<dataset::Dataset>()?;
    m.add_class::<table::Table>()?;
    m.add_class::<funcs::LookupResult>()?;
    m.add_function(wrap_pyfunction!(dataset::load_dataset, m)?)?;
    m.add_function(wrap_pyfunction!(table::calibrate, m)?)?;
    m.add_function(wrap_pyfunction!(funcs::lookup, m)?)?;
    m.add_function(wrap_pyfunction!(funcs::lambertian, m)?)?;
    m.add_function(wrap_pyfunction!(funcs::lights_from_sphere, m)?)?;
    m.add_function(wrap_pyfunction!(funcs::integrate, m)?)?;
    m.add_function(wrap_pyfunction!(funcs::interreflect, m)?)?;
    m.add_function(wrap_pyfunction!(funcs::run, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
