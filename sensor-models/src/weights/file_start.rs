//! The first bytes of a file: reading them, and describing them for a message when a file is
//! not what it should be.

use super::error::ModelFileErrorKind;
use std::io::Read;
use std::path::Path;

/// Fills `buf` with the file's first bytes; returns how many it has.
pub(crate) fn read_head(path: &Path, buf: &mut [u8]) -> Result<usize, ModelFileErrorKind> {
    let file = std::fs::File::open(path).map_err(ModelFileErrorKind::Read)?;
    let mut got = 0;
    let mut reader = file.take(buf.len() as u64);
    loop {
        match reader.read(&mut buf[got..]) {
            Ok(0) => return Ok(got),
            Ok(k) => got += k,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(ModelFileErrorKind::Read(e)),
        }
    }
}

/// The first bytes of a file, for a message: hex, as text, and a guess of what it is.
pub(crate) fn describe_start(head: &[u8]) -> String {
    let shown = &head[..head.len().min(8)];
    let hex: Vec<String> = shown.iter().map(|b| format!("{b:02x}")).collect();
    let text: String = shown
        .iter()
        .map(|&b| {
            if b.is_ascii_graphic() || b == b' ' {
                b as char
            } else {
                '.'
            }
        })
        .collect();
    let guess = KNOWN_STARTS
        .iter()
        .find(|(magic, _)| head.starts_with(magic))
        .map(|(_, what)| format!(", {what}"))
        .unwrap_or_default();
    format!("{} (\"{text}\"{guess})", hex.join(" "))
}

/// First bytes of files people mistake for weights.
const KNOWN_STARTS: [(&[u8], &str); 10] = [
    (b"\x89PNG", "a PNG image"),
    (b"\xff\xd8\xff", "a JPEG image"),
    (b"II*\x00", "a TIFF image"),
    (b"MM\x00*", "a TIFF image"),
    (b"\x89HDF", "an HDF5 file (Keras?)"),
    (b"\x93NUMPY", "a NumPy array"),
    (b"\x1f\x8b", "gzip-compressed: decompress it first"),
    (b"\x7fELF", "a program"),
    (b"{", "JSON text"),
    (
        b"version https://git-lfs",
        "a Git LFS pointer: run git lfs pull",
    ),
];
