//! Durable writes: a file replaced atomically (temp file, fsync, rename, fsync of the directory),
//! a file written and fsynced, and a directory's entries made durable. The run writer, the
//! manifest and the export all write this way.

use super::error::StoreError;
use std::fs::File;
use std::io::Write;
use std::path::Path;

/// Writes `bytes` to `path` atomically: after a crash the file is either the old one or the new.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), StoreError> {
    let tmp = path.with_extension("tmp");
    write_synced(&tmp, bytes)?;
    std::fs::rename(&tmp, path).map_err(|e| StoreError::io(path, e))?;
    if let Some(dir) = path.parent() {
        sync_dir(dir)?;
    }
    Ok(())
}

/// Creates (or replaces) `path` with `bytes` and fsyncs its content, not atomically: for files
/// inside a directory that is itself renamed into place when complete (the export), and for
/// [`write_atomic`]'s temporary file. The directory entry is made durable by [`sync_dir`].
/// Never written through a symbolic link ([`super::own_file::create`]).
pub(crate) fn write_synced(path: &Path, bytes: &[u8]) -> Result<(), StoreError> {
    let mut f = super::own_file::create(path).map_err(|e| StoreError::io(path, e))?;
    f.write_all(bytes).map_err(|e| StoreError::io(path, e))?;
    f.sync_all().map_err(|e| StoreError::io(path, e))
}

/// Makes the entries of `dir` (files created or renamed in it) durable.
pub(crate) fn sync_dir(dir: &Path) -> Result<(), StoreError> {
    File::open(dir)
        .and_then(|d| d.sync_all())
        .map_err(|e| StoreError::io(dir, e))
}
