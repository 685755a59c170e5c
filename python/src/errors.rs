//! The exceptions of the `fringe` package, each message naming the file or model and saying what
//! to do, as the command line's do.

use pyo3::create_exception;
use pyo3::exceptions::PyException;
use pyo3::PyErr;

create_exception!(
    fringe,
    FringeError,
    PyException,
    "Anything fringe could not do."
);
create_exception!(
    fringe,
    RunError,
    FringeError,
    "A run that cannot be read: no run there, a newer layout than this fringe reads, a damaged document."
);
create_exception!(
    fringe,
    FrameError,
    RunError,
    "A frame whose file is missing or damaged."
);
create_exception!(
    fringe,
    ModelError,
    FringeError,
    "A model that cannot be opened, chosen or run on these inputs."
);

/// A run error from anything that says what went wrong.
pub(crate) fn run_error(e: impl std::fmt::Display) -> PyErr {
    RunError::new_err(e.to_string())
}

/// A model error from anything that says what went wrong.
pub(crate) fn model_error(e: impl std::fmt::Display) -> PyErr {
    ModelError::new_err(e.to_string())
}
