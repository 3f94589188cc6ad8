//! The Python module `crashrig`: every command of the `crashrig` tool as a function, and
//! COLMAP models read into pycolmap-shaped objects with NumPy arrays.
//!
//! Each function calls the same library entry as the command (never the binary) and returns
//! the same dict as the command's `--json` (`grid`: the `grid.csv` columns as NumPy arrays).
//! Errors raise `crashrig.Error` (a `ValueError`) with the command's `error:` text; library
//! warnings are Python warnings (`UserWarning`). Long calls release the GIL, report progress
//! to an optional `progress(stage, done, total)` callable and stop on Ctrl-C.
//!
//! Build and install with `pip install ./crates/python` (maturin; `docs/PYTHON.md`).
//!
//! # Example (Python)
//! ```text
//! import crashrig, pandas
//! model = crashrig.read_model("fixtures/paper/twoview/model")
//! print(len(model.images), model.images[1].cam_from_world())
//! table = pandas.DataFrame(crashrig.grid("fixtures/scenarios/three_cameras_z0.toml", samples=500, seed=1))
//! ```

mod args;
mod commands;
mod convert;
mod model;
mod watch;

use pyo3::prelude::*;

pyo3::create_exception!(
    crashrig,
    Error,
    pyo3::exceptions::PyValueError,
    "A crashrig error: bad input or a failed step, with the command's `error:` text."
);

/// The text of a library error as the command prints it after `error: `: the error and its
/// causes joined with ": " ([`crashrig_input::message::error_line`]).
pub(crate) fn error_text(e: &(dyn std::error::Error + 'static)) -> String {
    crashrig_input::message::error_line(e)
}

/// `crashrig.Error` with the command's text of `e`.
pub(crate) fn to_py_err(e: impl std::error::Error + 'static) -> PyErr {
    Error::new_err(error_text(&e))
}

/// `crashrig.Error` with a message.
pub(crate) fn py_error(message: impl Into<String>) -> PyErr {
    Error::new_err(message.into())
}

/// The native module `crashrig._crashrig` (re-exported by the package `crashrig`).
#[pymodule(name = "_crashrig")]
fn crashrig_module(m: &Bound<'_, PyModule>) -> PyResult<()> {
    // Ctrl-C stays Python's (a KeyboardInterrupt); the outdir signal thread would exit the
    // interpreter.
    crashrig_outdir::leave_signals_to_host();
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add("Error", m.py().get_type::<Error>())?;
    model::register(m)?;
    commands::register(m)?;
    Ok(())
}
