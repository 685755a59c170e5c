//! `.safetensors` files (a JSON header of names, element types, shapes and offsets, then the
//! raw little-endian bytes), through the `safetensors` crate.

use super::element;
use super::error::{ModelFileError, ModelFileErrorKind};
use super::state_dict::StateDict;
use super::tensor::{StoredType, Tensor};
use crate::model_card::{CardError, ModelCard, CARD_METADATA_KEY};
use safetensors::tensor::{Dtype, SafeTensorError, SafeTensors, TensorView};
use std::collections::HashMap;
use std::io::Write;
use std::path::{Path, PathBuf};

/// Reads every tensor of a safetensors file (F32, F16, BF16, F64 or I64 elements).
pub fn read_safetensors(path: impl AsRef<Path>) -> Result<StateDict, ModelFileError> {
    let path = path.as_ref();
    let bytes = std::fs::read(path).map_err(|e| ModelFileErrorKind::Read(e).at(path))?;
    state_dict_of(&bytes).map_err(|kind| kind.at(path))
}

/// Reads every tensor of safetensors bytes held in memory (`name` names them in messages).
pub(crate) fn read_safetensors_bytes(
    bytes: &[u8],
    name: &str,
) -> Result<StateDict, ModelFileError> {
    state_dict_of(bytes).map_err(|kind| kind.at(Path::new(name)))
}

fn state_dict_of(bytes: &[u8]) -> Result<StateDict, ModelFileErrorKind> {
    if bytes.is_empty() {
        return Err(ModelFileErrorKind::Empty);
    }
    let file = SafeTensors::deserialize(bytes).map_err(|e| header_error(bytes, e))?;
    let mut state = StateDict::new();
    for (name, view) in file.iter() {
        let stored = match view.dtype() {
            Dtype::F32 => StoredType::F32,
            Dtype::F16 => StoredType::F16,
            Dtype::BF16 => StoredType::BF16,
            Dtype::F64 => StoredType::F64,
            Dtype::I64 => StoredType::I64,
            other => {
                return Err(ModelFileErrorKind::Unsupported(format!(
                "tensor '{name}' has elements of {other:?} (F32, F16, BF16, F64 and I64 are read)"
            )))
            }
        };
        let data = element::decode_all(view.data(), stored, false);
        let tensor = Tensor {
            shape: view.shape().to_vec(),
            data,
            stored,
        };
        state.insert(name, tensor);
    }
    Ok(state)
}

/// The model card a safetensors file carries in its header's metadata (`__metadata__`, key
/// `fringe.model_card`), if it has one. Only the header is read; a file that is not
/// safetensors, or whose header cannot be read, has none (reading its weights says why).
pub fn card_in_safetensors(path: &Path) -> Result<Option<ModelCard>, CardError> {
    let Some(header) = read_header(path) else {
        return Ok(None);
    };
    let Ok(serde_json::Value::Object(header)) = serde_json::from_slice(&header) else {
        return Ok(None);
    };
    match header
        .get("__metadata__")
        .and_then(|m| m.get(CARD_METADATA_KEY))
        .and_then(|v| v.as_str())
    {
        Some(text) => ModelCard::embedded(path, text).map(Some),
        None => Ok(None),
    }
}

/// The JSON header of a safetensors file: its 8-byte little-endian length, then the header.
fn read_header(path: &Path) -> Option<Vec<u8>> {
    use std::io::Read;
    let mut file = std::fs::File::open(path).ok()?;
    let mut len = [0u8; 8];
    file.read_exact(&mut len).ok()?;
    let n = u64::from_le_bytes(len);
    if n > MAX_HEADER {
        return None;
    }
    let mut header = Vec::new();
    file.take(n).read_to_end(&mut header).ok()?;
    (header.len() as u64 == n).then_some(header)
}

/// The largest header the safetensors crate reads (100 MB).
pub(crate) const MAX_HEADER: u64 = 100_000_000;

/// A safetensors header the crate refused: cut short, or not safetensors at all.
fn header_error(bytes: &[u8], e: SafeTensorError) -> ModelFileErrorKind {
    match e {
        SafeTensorError::MetadataIncompleteBuffer => ModelFileErrorKind::Truncated(format!(
            "the safetensors header announces more tensor data than the file's {} bytes",
            bytes.len()
        )),
        SafeTensorError::InvalidHeaderLength | SafeTensorError::HeaderTooSmall => {
            ModelFileErrorKind::Truncated(format!(
                "the safetensors header is longer than the file's {} bytes",
                bytes.len()
            ))
        }
        other => ModelFileErrorKind::Malformed(format!("damaged safetensors header: {other}")),
    }
}

/// Writes `state` to `path` as safetensors, every tensor as F32 (through a temporary file in
/// the same directory, renamed into place, so a reader never sees half a file).
pub fn write_safetensors(path: impl AsRef<Path>, state: &StateDict) -> Result<(), ModelFileError> {
    write_safetensors_with_card(path, state, None)
}

/// As [`write_safetensors`], with `card` in the header's metadata, so that the weights say how
/// to run them even when they travel without the card beside them.
pub fn write_safetensors_with_card(
    path: impl AsRef<Path>,
    state: &StateDict,
    card: Option<&ModelCard>,
) -> Result<(), ModelFileError> {
    let path = path.as_ref();
    let metadata = match card {
        Some(c) => {
            let text = serde_json::to_string(c).map_err(|e| {
                ModelFileErrorKind::Malformed(format!("the model card cannot be written: {e}"))
                    .at(path)
            })?;
            Some(HashMap::from([(CARD_METADATA_KEY.to_string(), text)]))
        }
        None => None,
    };
    let write_err = |e: std::io::Error| ModelFileErrorKind::Write(e).at(path);
    let buffers: Vec<(String, Vec<usize>, Vec<u8>)> = state
        .iter()
        .map(|(name, t)| {
            let bytes: Vec<u8> = t.data.iter().flat_map(|v| v.to_le_bytes()).collect();
            (name.to_string(), t.shape.clone(), bytes)
        })
        .collect();
    let mut views = Vec::with_capacity(buffers.len());
    for (name, shape, bytes) in &buffers {
        let view = TensorView::new(Dtype::F32, shape.clone(), bytes).map_err(|e| {
            ModelFileErrorKind::Malformed(format!("tensor '{name}' cannot be written: {e}"))
                .at(path)
        })?;
        views.push((name.as_str(), view));
    }
    let serialized = safetensors::tensor::serialize(views, metadata)
        .map_err(|e| ModelFileErrorKind::Malformed(format!("cannot serialize: {e}")).at(path))?;
    let temp = temporary_sibling(path);
    let written = (|| {
        let mut file = std::fs::File::create(&temp)?;
        file.write_all(&serialized)?;
        file.sync_all()?;
        std::fs::rename(&temp, path)
    })();
    if let Err(e) = written {
        let _ = std::fs::remove_file(&temp);
        return Err(write_err(e));
    }
    Ok(())
}

/// `dir/.name.tmp-<pid>` beside `path`.
fn temporary_sibling(path: &Path) -> PathBuf {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "weights".into());
    path.with_file_name(format!(".{name}.tmp-{}", std::process::id()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn writes_and_reads_back_f32() {
        let dir = std::env::temp_dir().join(format!("fringe-st-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("dir");
        let path = dir.join("w.safetensors");
        let mut sd = StateDict::new();
        sd.insert(
            "module.a.weight",
            Tensor::new(vec![2, 2], vec![1.0, -2.0, 3.5, 0.0]).expect("tensor"),
        );
        sd.insert("b", Tensor::new(vec![0], vec![]).expect("tensor"));
        write_safetensors(&path, &sd).expect("write");
        let back = read_safetensors(&path).expect("read");
        assert_eq!(back, sd);
        assert!(back.contains("a.weight"));
        assert_eq!(card_in_safetensors(&path).expect("header"), None);
        let card = ModelCard {
            input_size: Some(112),
            classes: Some(vec!["None".into(), "pentagon".into()]),
            ..ModelCard::default()
        };
        write_safetensors_with_card(&path, &sd, Some(&card)).expect("write with card");
        assert_eq!(card_in_safetensors(&path).expect("header"), Some(card));
        assert_eq!(read_safetensors(&path).expect("read"), sd);
        let _ = std::fs::remove_dir_all(&dir);
    }
}
