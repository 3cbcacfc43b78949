//! The Python exception tree, and the one place where Rust errors become
//! Python exceptions.
//!
//! ```text
//! Exception
//! └── WavradError
//!     ├── SceneError     wavrad-io: scene files, meshes, images (file and line),
//!     │                  blocks of links (wavrad.Plan)
//!     ├── SolveError     wavrad-core: settings, empty scene, no light, missing sensor,
//!     │                  a diverging solve, an image with pixels not finite,
//!     │                  blocks that do not cover a plan
//!     └── ArgumentError  (also a ValueError) an argument wavrad cannot use: a
//!                        wrongly typed setting, a wrongly shaped image, a plan
//!                        used up, an option without its companion
//!
//! UserWarning
//! └── SolveWarning       what a solve tells as it goes on: a limit reached and
//!                        what it cut short, linking coarsened, triples left out
//! ```
//! Settings outside their described range or choices, and settings that do
//! not go together, are `SolveError`s. Python's own `TypeError` stays for
//! what any Python function raises it for: an unknown keyword, an argument
//! PyO3 cannot convert.

use pyo3::create_exception;
use pyo3::exceptions::{PyException, PyUserWarning, PyValueError};
use pyo3::prelude::*;
use pyo3::sync::GILOnceCell;
use pyo3::types::{PyDict, PyTuple, PyType};
use pyo3::PyErr;

create_exception!(
    wavrad,
    WavradError,
    PyException,
    "Base class of every wavrad error."
);
create_exception!(
    wavrad,
    SceneError,
    WavradError,
    "A scene, mesh or image file could not be read or written (the message names the file and line), or bytes are not a block of links of this plan."
);
create_exception!(
    wavrad,
    SolveError,
    WavradError,
    "The solver or renderer refused its input or failed (invalid settings, empty scene, no light, no sensor, a diverging solve, pixels not finite)."
);

create_exception!(
    wavrad,
    SolveWarning,
    PyUserWarning,
    "A solve went on, but the user should know: a time or memory limit (or Ctrl-C) cut it short and what that left unrefined or out, linking coarsened, surface triples left out of a plan."
);

/// `wavrad.ArgumentError`, made once: `create_exception!` takes one base,
/// and it has two (`WavradError`, `ValueError`), so that `except
/// ValueError` keeps catching it.
static ARGUMENT_ERROR: GILOnceCell<Py<PyType>> = GILOnceCell::new();

/// The type `wavrad.ArgumentError`.
pub fn argument_error(py: Python<'_>) -> PyResult<&Bound<'_, PyType>> {
    ARGUMENT_ERROR
        .get_or_try_init(py, || {
            let bases = PyTuple::new(
                py,
                [py.get_type::<WavradError>(), py.get_type::<PyValueError>()],
            )?;
            let namespace = PyDict::new(py);
            namespace.set_item("__module__", "wavrad")?;
            namespace.set_item(
                "__doc__",
                "An argument wavrad cannot use (a wrongly typed setting, a wrongly shaped image, a plan used up); also a ValueError.",
            )?;
            let made = py
                .get_type::<PyType>()
                .call1(("ArgumentError", bases, namespace))?;
            Ok(made.downcast_into::<PyType>()?.unbind())
        })
        .map(|t| t.bind(py))
}

/// Everything the binding can fail with.
#[derive(Debug)]
pub enum Error {
    /// From `wavrad-io`.
    Scene(wavrad_io::Error),
    /// From `wavrad-core`.
    Solve(wavrad_core::Error),
    /// A Python argument has a value the binding cannot convert.
    Argument(String),
    /// Raised by Python itself while converting (already an exception).
    Python(PyErr),
}

/// Result with the binding's [`Error`].
pub type Result<T> = std::result::Result<T, Error>;

impl From<wavrad_io::Error> for Error {
    fn from(e: wavrad_io::Error) -> Self {
        Error::Scene(e)
    }
}

impl From<wavrad_core::Error> for Error {
    fn from(e: wavrad_core::Error) -> Self {
        Error::Solve(e)
    }
}

impl From<PyErr> for Error {
    fn from(e: PyErr) -> Self {
        Error::Python(e)
    }
}

impl From<Error> for PyErr {
    fn from(e: Error) -> PyErr {
        match e {
            Error::Scene(e) => SceneError::new_err(e.to_string()),
            Error::Solve(e) => SolveError::new_err(e.to_string()),
            Error::Argument(message) => Python::with_gil(|py| match argument_error(py) {
                Ok(kind) => PyErr::from_type(kind.clone(), message),
                Err(e) => e,
            }),
            Error::Python(e) => e,
        }
    }
}
