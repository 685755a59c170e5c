//! The names of a run directory's files, and which run a path is in.

use std::path::{Path, PathBuf};

/// File names inside a run directory.
pub const START: &str = "start.json";
pub const FRAMES: &str = "frames.jsonl";
pub const EVENTS: &str = "events.jsonl";
pub const FORCE: &str = "force.bin";
pub const FRAME_DIR: &str = "frames";
pub const STOP: &str = "stop.json";
pub const CHECKPOINT: &str = "checkpoint.json";
pub const MANIFEST: &str = "MANIFEST.sha256";

/// The run that `path` is in or is (a directory with a start document among its ancestors),
/// once links are resolved; `path` need not exist yet. Outputs (reports, exports) are never
/// written into a run: it would no longer verify.
pub fn run_holding(path: &Path) -> Option<PathBuf> {
    let absolute = std::path::absolute(path).ok()?;
    // The deepest ancestor that exists, resolved; the rest of the path cannot hold a run yet.
    let real = absolute
        .ancestors()
        .find_map(|a| std::fs::canonicalize(a).ok())?;
    real.ancestors()
        .find(|a| a.join(START).is_file())
        .map(Path::to_path_buf)
}
