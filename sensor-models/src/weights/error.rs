//! Why a model file could not be read or written: one line naming the file and what was found.

use super::pickle::PickleError;
use std::path::{Path, PathBuf};

/// A model file that could not be read (or written), with the file's path. What the file
/// itself holds (tensor and entry names, class names) can hold any character: the message shows
/// control characters escaped, so it stays one line.
#[derive(Debug, thiserror::Error)]
#[error("{}: {}", path.display(), one_line(&kind.to_string()))]
pub struct ModelFileError {
    pub path: PathBuf,
    pub kind: ModelFileErrorKind,
}

/// `text` with its control characters (a newline, a NUL) written as escapes.
fn one_line(text: &str) -> String {
    text.chars()
        .map(|c| {
            if c.is_control() {
                c.escape_debug().to_string()
            } else {
                c.to_string()
            }
        })
        .collect()
}

/// What was wrong with the file.
#[derive(Debug, thiserror::Error)]
pub enum ModelFileErrorKind {
    #[error("cannot read: {0}")]
    Read(std::io::Error),
    #[error("cannot write: {0}")]
    Write(std::io::Error),
    #[error("empty file (0 bytes)")]
    Empty,
    /// Neither a `torch.save` file nor safetensors; says what the file starts with.
    #[error("not a PyTorch or safetensors file: starts with {0}")]
    Foreign(String),
    /// An ONNX model: a graph with weights, read by the ONNX backend, not as a state dict.
    #[error("an ONNX model, not a weights file: load it with the ONNX backend")]
    Onnx,
    /// A TorchScript archive (`torch.jit.save`): a program, not a state dict.
    #[error(
        "a TorchScript module (torch.jit.save), not a state dict: run it on the torch backend \
         (--backend torch, in a fringe built with --features torch), or save the model's \
         state_dict() or export it to ONNX for the other backends"
    )]
    TorchScript,
    /// The file ends before the data it announces.
    #[error("truncated: {0}")]
    Truncated(String),
    #[error("damaged pickle in {part}: {error}")]
    Pickle {
        part: &'static str,
        error: PickleError,
    },
    /// The file is well formed but holds no tensors (or no state dict).
    #[error("no tensors found: {0}")]
    NoTensors(String),
    /// The file's structure is inconsistent (a storage that is missing, a view out of range).
    #[error("{0}")]
    Malformed(String),
    /// A valid file using something this reader does not handle (an element type, a layout).
    #[error("unsupported: {0}")]
    Unsupported(String),
}

impl ModelFileErrorKind {
    /// This problem, in the file at `path`.
    pub fn at(self, path: &Path) -> ModelFileError {
        ModelFileError {
            path: path.to_path_buf(),
            kind: self,
        }
    }

    /// A pickle error in `part` of the file; a pickle cut short is a truncated file.
    pub(crate) fn pickle(part: &'static str, error: PickleError) -> ModelFileErrorKind {
        match error {
            PickleError::Truncated { offset, needed } => ModelFileErrorKind::Truncated(format!(
                "{part} ends at byte {offset} inside a value ({needed} more bytes needed)"
            )),
            error => ModelFileErrorKind::Pickle { part, error },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_from_the_file_with_control_characters_stay_on_one_line() {
        let e = ModelFileError {
            path: PathBuf::from("m.pth"),
            kind: ModelFileErrorKind::Foreign("entries: data.p\nl, a\u{0}b".into()),
        };
        assert_eq!(
            e.to_string(),
            "m.pth: not a PyTorch or safetensors file: starts with entries: data.p\\nl, a\\0b"
        );
    }
}
