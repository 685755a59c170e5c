//! The runs in a directory (`fringe runs`, the Runs screen): each with the name the other
//! commands take (its directory's) and the bytes its files take on disk.

use fringe_rig::store::bytes_on_disk;
use fringe_rig::store::StoreError;
use fringe_rig::store::{list_runs as list, RunSummary};
use std::path::Path;

/// One run of the listing.
pub struct ListedRun {
    /// What the store says of it: its start and stop documents, its frames.
    pub run: RunSummary,
    /// Its directory's name, which the other commands take (a copied run keeps its run id).
    pub name: String,
    /// The bytes of its files (`None`: the directory could not be read to the end).
    pub bytes: Option<u64>,
}

/// The runs under `root`, and what could not be read there (one line each).
pub fn list_runs(root: &Path) -> Result<(Vec<ListedRun>, Vec<String>), StoreError> {
    let (runs, unreadable) = list(root)?;
    let listed = runs
        .into_iter()
        .map(|run| ListedRun {
            name: run.dir.file_name().map_or_else(
                || run.dir.display().to_string(),
                |n| n.to_string_lossy().into_owned(),
            ),
            bytes: bytes_on_disk(&run.dir).ok(),
            run,
        })
        .collect();
    Ok((listed, unreadable))
}
