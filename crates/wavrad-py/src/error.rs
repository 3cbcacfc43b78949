//! The Python exception tree, and the one place where Rust errors become
//! Python exceptions.
//!
//! ```text
//! Exception
//! └── WavradError
//!     ├── SceneError   wavrad-io: scene files, meshes, images (file and line),
//!     │                blocks of links (wavrad.Plan)
//!     └── SolveError   wavrad-core: settings, empty scene, no light, missing sensor,
//!                      a diverging solve, an image with pixels not finite,
//!                      blocks that do not cover a plan
//! ```
//! Settings outside their described range or choices, and settings that do
//! not go together, are `SolveError`s; arguments Python cannot convert (a
//! wrongly typed setting, a wrongly shaped image) raise the built-in
//! `ValueError`, an unknown keyword `TypeError`.

use pyo3::create_exception;
use pyo3::exceptions::{PyException, PyValueError};
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
            Error::Argument(message) => PyValueError::new_err(message),
            Error::Python(e) => e,
        }
    }
}
