//! The run store: one directory per scan, written append-only and crash-safe.
//!
//! ```text
//! runs/<run-id>/
//!   start.json        start document: plan, rig, sensor, profile, software version, seed
//!   frames.jsonl      one record per frame (appended, one line each)
//!   events.jsonl      checkpoints, pauses, watcher actions, operator prompts
//!   force.bin         the complete raw force stream at full rate (fixed-size records)
//!   frames/NNNNNNNN.png  lossless frames
//!   checkpoint.json   the last checkpoint: the next point and how far the records went
//!   stop.json         stop document: exit status and counts (absent after a crash)
//!   MANIFEST.sha256   checksums of every file (sha256sum format), written at stop
//!   .lock             held by the process writing the run (not part of the run)
//! ```
//!
//! - [`disk_space`]: room left on the disk, checked before long writes.
//! - [`documents`]: the documents and records, serde types.
//! - [`force_log`]: the binary force stream format (pure encode/decode).
//! - [`durable`]: atomic file replacement and durable directory entries.
//! - [`own_file`]: a run's files are its own regular files (no links, FIFOs or devices).
//! - [`run_lock`]: one writer per run (a lock that names its holder and dies with it).
//! - [`run_writer`]: creating, appending to, reopening (after a crash) and closing a run.
//! - [`manifest`]: the checksum manifest.
//! - [`verify`]: checking a run directory.
//! - [`run_list`]: the runs under a directory, newest first.
//! - [`export`]: the reference pipeline's `0.images/` + `0.labels.csv` layout.

pub mod disk_space;
pub mod documents;
pub mod durable;
pub mod export;
pub mod force_log;
pub mod manifest;
pub mod own_file;
pub mod run_list;
pub mod run_lock;
pub mod run_writer;
pub mod verify;

use std::path::PathBuf;

/// File names inside a run directory.
pub const START: &str = "start.json";
pub const FRAMES: &str = "frames.jsonl";
pub const EVENTS: &str = "events.jsonl";
pub const FORCE: &str = "force.bin";
pub const FRAME_DIR: &str = "frames";
pub const STOP: &str = "stop.json";
pub const CHECKPOINT: &str = "checkpoint.json";
pub const MANIFEST: &str = "MANIFEST.sha256";

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

/// The start document of the run in `dir`; [`StoreError::NotARun`] when `dir` has none (a
/// missing directory, a typo, the runs root instead of one run).
pub fn read_start(dir: &std::path::Path) -> Result<documents::StartDocument, StoreError> {
    let path = dir.join(START);
    if !path.exists() {
        return Err(StoreError::NotARun {
            dir: dir.to_path_buf(),
        });
    }
    run_writer::read_document(&path)
}

/// The run that `path` is in or is (a directory with a start document among its ancestors),
/// once links are resolved; `path` need not exist yet. Outputs (reports, exports) are never
/// written into a run: it would no longer verify.
pub fn run_holding(path: &std::path::Path) -> Option<PathBuf> {
    let absolute = std::path::absolute(path).ok()?;
    // The deepest ancestor that exists, resolved; the rest of the path cannot hold a run yet.
    let real = absolute
        .ancestors()
        .find_map(|a| std::fs::canonicalize(a).ok())?;
    real.ancestors()
        .find(|a| a.join(START).is_file())
        .map(std::path::Path::to_path_buf)
}

impl StoreError {
    pub(crate) fn io(path: impl Into<PathBuf>, source: std::io::Error) -> StoreError {
        StoreError::Io {
            path: path.into(),
            source,
        }
    }
}
