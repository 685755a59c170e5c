//! A model's ONNX graph written (`fringe model export`), with its card in it, so that `model
//! info`, `model run` and evaluation read it with the input size, colour and classes it was
//! trained with.

use crate::models::choice::{open_model, ChoiceError};
use fringe_sensor_models::onnx_graph;
use fringe_sensor_models::ModelCard;
use fringe_sensor_models::{Model, ModelError};
use std::path::{Path, PathBuf};

/// A graph written.
pub struct Exported {
    /// The model exported.
    pub model: Model,
    /// The graph's size, bytes.
    pub bytes: usize,
}

/// A graph that could not be written.
#[derive(Debug, thiserror::Error)]
pub enum OnnxExportError {
    #[error(transparent)]
    Open(#[from] ChoiceError),
    #[error(transparent)]
    Model(#[from] ModelError),
    /// The output is one of the model's own files.
    #[error(
        "{}: that is a file of the model {} (its weights or its card): writing the ONNX graph there would destroy it; give another output, e.g. {}",
        .out.display(),
        .model.display(),
        .model.with_extension("onnx").display()
    )]
    ModelFile { out: PathBuf, model: PathBuf },
    #[error("{}: cannot write", .path.display())]
    Write {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
}

/// Writes the ONNX graph of model argument `path` to `out` (through a `.onnx.partial` file, so
/// that `out` is whole or absent). `warn` hears a model without its card and one whose graph
/// is a copy of another.
pub fn export(
    path: &Path,
    out: &Path,
    warn: &mut dyn FnMut(String),
) -> Result<Exported, OnnxExportError> {
    let m = open_model(path)?;
    if let Some(w) = m.missing_card_warning() {
        warn(w);
    }
    refuse_model_file(&m.path, out)?;
    if let Some(w) = m.copy_warning() {
        warn(w);
    }
    let bytes = onnx_graph::encode(&m.onnx_with_card()?);
    let tmp = out.with_extension("onnx.partial");
    let failed = |path: &Path| {
        let path = path.to_path_buf();
        move |source| OnnxExportError::Write { path, source }
    };
    std::fs::write(&tmp, &bytes).map_err(failed(&tmp))?;
    std::fs::rename(&tmp, out).map_err(failed(out))?;
    Ok(Exported {
        model: m,
        bytes: bytes.len(),
    })
}

/// Refuses an output that is one of the model's own files (its weights or its card,
/// `<file>.json` or `<stem>.json`): writing the graph there would destroy the model.
fn refuse_model_file(model: &Path, out: &Path) -> Result<(), OnnxExportError> {
    let real = |p: &Path| std::fs::canonicalize(p).ok();
    let Some(out_real) = real(out) else {
        // It does not exist yet: it is no file of the model.
        return Ok(());
    };
    let own = std::iter::once(model.to_path_buf()).chain(ModelCard::candidates(model));
    if own
        .collect::<Vec<_>>()
        .iter()
        .any(|f| real(f).as_ref() == Some(&out_real))
    {
        return Err(OnnxExportError::ModelFile {
            out: out.to_path_buf(),
            model: model.to_path_buf(),
        });
    }
    Ok(())
}
