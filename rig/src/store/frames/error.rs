//! The errors of frame files, naming the file.

use std::io;
use std::path::PathBuf;

/// Errors from writing or reading frame files, naming the file.
#[derive(Debug, thiserror::Error)]
pub enum FrameFileError {
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: io::Error,
    },
    #[error("{path}: {source}")]
    Image {
        path: PathBuf,
        #[source]
        source: image::ImageError,
    },
    #[error("{path}: {message}")]
    Content { path: PathBuf, message: String },
}

impl FrameFileError {
    /// What is wrong, without the file's path (for a caller that names the file itself).
    pub fn reason(&self) -> String {
        match self {
            FrameFileError::Io { source, .. } => source.to_string(),
            FrameFileError::Image { source, .. } => source.to_string(),
            FrameFileError::Content { message, .. } => message.clone(),
        }
    }
}
