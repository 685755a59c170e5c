//! The runs under a directory, newest first.

use super::documents::{StartDocument, StopDocument};
use super::error::StoreError;
use super::layout::{FRAMES, START, STOP};
use super::run_reader::{read_document, read_lines};
use std::path::{Path, PathBuf};

/// One line of `fringe runs`.
#[derive(Debug, Clone, PartialEq)]
pub struct RunSummary {
    pub dir: PathBuf,
    pub start: StartDocument,
    /// `None` for a run that has not ended (running, or crashed: resumable).
    pub stop: Option<StopDocument>,
    pub frames: u64,
}

/// Every run directory directly under `root` (those with a start document), newest first.
/// Unreadable runs are skipped and reported in the second list.
pub fn list(root: &Path) -> Result<(Vec<RunSummary>, Vec<String>), StoreError> {
    let mut runs = Vec::new();
    let mut unreadable = Vec::new();
    let entries = match std::fs::read_dir(root) {
        Ok(e) => e,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok((runs, unreadable)),
        Err(e) => return Err(StoreError::io(root, e)),
    };
    for entry in entries {
        let entry = entry.map_err(|e| StoreError::io(root, e))?;
        let dir = entry.path();
        if !dir.join(START).is_file() {
            continue;
        }
        let summary = (|| -> Result<RunSummary, StoreError> {
            let start: StartDocument = read_document(&dir.join(START))?;
            let stop_path = dir.join(STOP);
            let stop = if stop_path.exists() {
                Some(read_document(&stop_path)?)
            } else {
                None
            };
            let (frames, _) = read_lines::<serde_json::Value>(&dir.join(FRAMES))?;
            Ok(RunSummary {
                dir: dir.clone(),
                start,
                stop,
                frames: frames.len() as u64,
            })
        })();
        match summary {
            Ok(s) => runs.push(s),
            Err(e) => unreadable.push(e.to_string()),
        }
    }
    runs.sort_by(|a, b| b.start.started_utc.cmp(&a.start.started_utc));
    Ok((runs, unreadable))
}
