//! Errors of the run store.

use super::layout::START;
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
    #[error("{} is not a run (there is no {START} in it): give the directory of a run that fringe scan wrote (`fringe runs --root DIR` lists the runs in DIR)", dir.display())]
    NotARun { dir: PathBuf },
}

impl StoreError {
    pub(crate) fn io(path: impl Into<PathBuf>, source: std::io::Error) -> StoreError {
        StoreError::Io {
            path: path.into(),
            source,
        }
    }
}
