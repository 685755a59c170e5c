//! One entry point for weights as users have them: [`read_weights`] tells a `torch.save` file
//! (zip or legacy), a safetensors file and an ONNX model apart by their content (the extension
//! only decides for ONNX), and says what a foreign file starts with.

use super::error::{ModelFileError, ModelFileErrorKind};
use super::file_start::{describe_start, read_head};
use super::safetensors_file::{read_safetensors, MAX_HEADER};
use super::state_dict::StateDict;
use super::torch_file::{read_torch, ZIP_MAGIC};
use std::path::Path;

/// How many first bytes are looked at to recognise a file.
const HEAD_LEN: usize = 512;

/// What a file's content says it is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum WeightsFormat {
    /// `torch.save` since PyTorch 1.6.
    TorchZip,
    /// `torch.save(..., _use_new_zipfile_serialization=False)`.
    TorchLegacy,
    Safetensors,
    Onnx,
}

/// Reads the weights in `path`: `.pth` / `.pt` from `torch.save`, or `.safetensors`.
/// An ONNX model is refused with [`ModelFileErrorKind::Onnx`] (the ONNX backend reads those).
pub fn read_weights(path: impl AsRef<Path>) -> Result<StateDict, ModelFileError> {
    let path = path.as_ref();
    match detect_format(path)? {
        WeightsFormat::TorchZip | WeightsFormat::TorchLegacy => read_torch(path),
        WeightsFormat::Safetensors => read_safetensors(path),
        WeightsFormat::Onnx => Err(ModelFileErrorKind::Onnx.at(path)),
    }
}

/// The format of the file at `path`, from its first bytes (and `.onnx` extension).
pub fn detect_format(path: impl AsRef<Path>) -> Result<WeightsFormat, ModelFileError> {
    let path = path.as_ref();
    let mut head = [0u8; HEAD_LEN];
    let n = read_head(path, &mut head).map_err(|k| k.at(path))?;
    let is_onnx_name = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("onnx"));
    format_of(&head[..n], is_onnx_name).map_err(|k| k.at(path))
}

fn format_of(head: &[u8], is_onnx_name: bool) -> Result<WeightsFormat, ModelFileErrorKind> {
    if head.is_empty() {
        return Err(ModelFileErrorKind::Empty);
    }
    if ZIP_MAGIC.iter().any(|m| head.starts_with(m)) {
        return Ok(WeightsFormat::TorchZip);
    }
    if head[0] == 0x80 && head.get(1).is_some_and(|p| (2..=5).contains(p)) {
        return Ok(WeightsFormat::TorchLegacy);
    }
    if let Some(n) = safetensors_header_len(head) {
        if n > MAX_HEADER {
            return Err(ModelFileErrorKind::Malformed(format!(
                "a safetensors header of {n} bytes, more than the {MAX_HEADER} bytes safetensors \
                 allows: the file is damaged (or not what it claims)"
            )));
        }
        return Ok(WeightsFormat::Safetensors);
    }
    if is_onnx_name || looks_like_onnx(head) {
        return Ok(WeightsFormat::Onnx);
    }
    if head.get(257..262) == Some(b"ustar") {
        return Err(ModelFileErrorKind::Unsupported(
            "a tar archive (torch.save before PyTorch 0.4): load and save it again with a \
             current PyTorch"
                .into(),
        ));
    }
    Err(ModelFileErrorKind::Foreign(describe_start(head)))
}

/// The header length of what looks like safetensors: an 8-byte little-endian length (at least
/// 2, for `{}`), then a JSON object. (A header longer than the file still counts: reading it
/// then reports the file as truncated.)
fn safetensors_header_len(head: &[u8]) -> Option<u64> {
    let len: [u8; 8] = head.get(..8)?.try_into().ok()?;
    let n = u64::from_le_bytes(len);
    (n >= 2 && head.get(8) == Some(&b'{')).then_some(n)
}

/// An ONNX ModelProto as exporters write it: field 1 (ir_version, a small varint) first, then
/// a string field (producer name, opset import or graph).
fn looks_like_onnx(head: &[u8]) -> bool {
    matches!(head, [0x08, v, next, ..] if (1..=20).contains(v) && matches!(next, 0x12 | 0x1a | 0x3a | 0x42))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn recognises_formats_by_content() {
        assert_eq!(
            format_of(b"PK\x03\x04rest", false).ok(),
            Some(WeightsFormat::TorchZip)
        );
        assert_eq!(
            format_of(b"\x80\x02\x8a\x0a", false).ok(),
            Some(WeightsFormat::TorchLegacy)
        );
        let mut st = 10u64.to_le_bytes().to_vec();
        st.extend(b"{\"a\":1}   ");
        assert_eq!(format_of(&st, false).ok(), Some(WeightsFormat::Safetensors));
        // A header length of 2^62 is named as such, not as a foreign file.
        let mut huge = (1u64 << 62).to_le_bytes().to_vec();
        huge.extend(b"{\"a\":1}");
        let e = format_of(&huge, false).expect_err("huge header");
        assert!(
            e.to_string()
                .contains("a safetensors header of 4611686018427387904 bytes"),
            "{e}"
        );
        assert_eq!(
            format_of(b"\x08\x08\x12\x07pytorch", false).ok(),
            Some(WeightsFormat::Onnx)
        );
        let e = format_of(b"\x89PNG\r\n\x1a\n....", false).expect_err("png");
        assert_eq!(
            e.to_string(),
            "not a PyTorch or safetensors file: starts with 89 50 4e 47 0d 0a 1a 0a \
             (\".PNG....\", a PNG image)"
        );
    }
}
