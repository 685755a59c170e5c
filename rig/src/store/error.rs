//! Errors of the run store.

use super::layout::{InsideRun, START};
use std::path::PathBuf;

/// Errors of the run store, naming the file.
#[derive(Debug, thiserror::Error)]
pub enum StoreError {
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{path}: line {line}: {message}")]
    Parse {
        path: PathBuf,
        line: usize,
        message: String,
    },
    #[error("{path}: {message}")]
    Content { path: PathBuf, message: String },
    #[error("{}: the run is in use: {holder}; wait for it to end (or stop it), then try again", dir.display())]
    Busy { dir: PathBuf, holder: String },
    #[error("{} is not a run (there is no {START} in it)", dir.display())]
    NotARun { dir: PathBuf },
    /// An output (an export, a new run) asked for inside a run.
    #[error(transparent)]
    InsideRun(#[from] InsideRun),
    /// An export of a run that fails verification, not allowed to go on.
    #[error("{}: fails verify with {count} problem(s), the first: {first}", run.display())]
    Unverified {
        run: PathBuf,
        count: usize,
        first: String,
    },
}

impl StoreError {
    pub(crate) fn io(path: impl Into<PathBuf>, source: std::io::Error) -> StoreError {
        StoreError::Io {
            path: path.into(),
            source,
        }
    }
}
