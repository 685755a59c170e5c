//! The checksum manifest: SHA-256 of every file in a run, in `sha256sum` format, so that
//! `sha256sum -c MANIFEST.sha256` works as well as `fringe verify`.

use super::error::StoreError;
use super::layout::MANIFEST;
use super::run_lock::LOCK;
use sha2::{Digest, Sha256};
use std::fs::File;
use std::io::Read;
use std::path::{Path, PathBuf};

/// Every regular file under `dir` except the manifest and the writer's lock, as paths relative
/// to `dir` with `/`, sorted. A run holding anything that is neither a regular file nor a
/// directory (a symbolic link, a FIFO: [`strangers`]) is refused: no manifest vouches for it.
pub(crate) fn files(dir: &Path) -> Result<Vec<String>, StoreError> {
    let (files, strangers) = walk(dir)?;
    if let Some((rel, why)) = strangers.first() {
        return Err(StoreError::Content {
            path: dir.join(rel),
            message: format!("{why}; remove it from the run"),
        });
    }
    Ok(files)
}

/// An entry of a run that is neither a regular file nor a directory: its path relative to the
/// run and what is wrong with it.
pub(crate) type Stranger = (String, &'static str);

/// Every entry under `dir` (the lock file included) that is neither a regular file nor a
/// directory: its path relative to `dir` and what is wrong with it.
pub(crate) fn strangers(dir: &Path) -> Result<Vec<Stranger>, StoreError> {
    Ok(walk(dir)?.1)
}

/// The regular files of [`files`], and the entries that are neither regular files nor
/// directories, with what is wrong with each. Links are never followed.
fn walk(dir: &Path) -> Result<(Vec<String>, Vec<Stranger>), StoreError> {
    let mut out = Vec::new();
    let mut strangers = Vec::new();
    let mut stack = vec![PathBuf::new()];
    while let Some(rel) = stack.pop() {
        let here = dir.join(&rel);
        let entries = std::fs::read_dir(&here).map_err(|e| StoreError::io(&here, e))?;
        for entry in entries {
            let entry = entry.map_err(|e| StoreError::io(&here, e))?;
            let name = entry.file_name().to_string_lossy().into_owned();
            let kind = entry
                .file_type()
                .map_err(|e| StoreError::io(entry.path(), e))?;
            let child = rel.join(&name);
            let text = child.to_string_lossy().replace('\\', "/");
            if kind.is_dir() {
                stack.push(child);
            } else if !kind.is_file() {
                if let Some(why) = super::own_file::stranger(&entry.path()) {
                    strangers.push((text, why));
                }
            } else if child != Path::new(MANIFEST)
                && child != Path::new(LOCK)
                && !name.ends_with(".tmp")
            {
                out.push(text);
            }
        }
    }
    out.sort();
    strangers.sort();
    Ok((out, strangers))
}

/// SHA-256 of a file, lower-case hex.
pub(crate) fn sha256_file(path: &Path) -> Result<String, StoreError> {
    if let Ok(meta) = std::fs::symlink_metadata(path) {
        if !meta.file_type().is_file() {
            return Err(StoreError::io(
                path,
                std::io::Error::new(
                    std::io::ErrorKind::InvalidInput,
                    "is not a regular file (a link, a FIFO or a device): a run's files are its own regular files",
                ),
            ));
        }
    }
    let mut file = File::open(path).map_err(|e| StoreError::io(path, e))?;
    let mut hasher = Sha256::new();
    let mut buf = vec![0u8; 1 << 16];
    loop {
        let n = file.read(&mut buf).map_err(|e| StoreError::io(path, e))?;
        if n == 0 {
            break;
        }
        hasher.update(&buf[..n]);
    }
    Ok(hasher
        .finalize()
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect())
}

/// Writes `dir/MANIFEST.sha256` covering every file (atomically: temp file, fsync, rename).
pub fn write(dir: &Path) -> Result<(), StoreError> {
    let mut text = String::new();
    for rel in files(dir)? {
        let hash = sha256_file(&dir.join(&rel))?;
        text.push_str(&format!("{hash}  {rel}\n"));
    }
    super::durable::write_atomic(&dir.join(MANIFEST), text.as_bytes())
}

/// Compares the files with the manifest; returns one message per difference.
pub(crate) fn check(dir: &Path) -> Result<Vec<String>, StoreError> {
    let path = dir.join(MANIFEST);
    let text = std::fs::read_to_string(&path).map_err(|e| StoreError::io(&path, e))?;
    let mut problems = Vec::new();
    let mut listed = Vec::new();
    for (k, line) in text.lines().enumerate() {
        let Some((hash, rel)) = line.split_once("  ") else {
            problems.push(format!("{MANIFEST} line {}: not `<sha256>  <file>`", k + 1));
            continue;
        };
        listed.push(rel.to_string());
        let file = dir.join(rel);
        if let Err(e) = super::own_file::check_in(dir, Path::new(rel)) {
            if e.kind() != std::io::ErrorKind::NotFound {
                problems.push(format!("{rel}: {e}"));
                continue;
            }
        }
        if !file.is_file() {
            problems.push(format!("{rel}: listed in {MANIFEST} but missing"));
            continue;
        }
        let actual = sha256_file(&file)?;
        if actual != hash {
            problems.push(format!(
                "{rel}: checksum differs from {MANIFEST} (file changed or damaged)"
            ));
        }
    }
    // Links and FIFOs are reported by `strangers`.
    for rel in walk(dir)?.0 {
        if !listed.contains(&rel) {
            problems.push(format!(
                "{rel}: not listed in {MANIFEST} (added after the run ended)"
            ));
        }
    }
    Ok(problems)
}
