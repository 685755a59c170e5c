//! The names of a run directory's files, and which run a path is in.

use std::path::{Path, PathBuf};

/// File names inside a run directory: the store's own; everything outside the store names a
/// run's files by what they hold ([`RunFile`], through `RunReader::path`).
pub(crate) const START: &str = "start.json";
pub(crate) const FRAMES: &str = "frames.jsonl";
pub(crate) const EVENTS: &str = "events.jsonl";
pub(crate) const FORCE: &str = "force.bin";
pub(crate) const FRAME_DIR: &str = "frames";
pub(crate) const STOP: &str = "stop.json";
pub(crate) const CHECKPOINT: &str = "checkpoint.json";
pub(crate) const MANIFEST: &str = "MANIFEST.sha256";

/// A file (or, [`RunFile::FrameDir`], the directory of frame files) of a run, by what it holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RunFile {
    /// The start document.
    Start,
    /// The frame records.
    Frames,
    /// The events.
    Events,
    /// The raw force stream.
    Force,
    /// The directory of frame files.
    FrameDir,
    /// The last checkpoint.
    Checkpoint,
    /// The stop document.
    Stop,
    /// The checksum manifest.
    Manifest,
}

impl RunFile {
    /// Its name in the run directory.
    pub(crate) fn name(self) -> &'static str {
        match self {
            RunFile::Start => START,
            RunFile::Frames => FRAMES,
            RunFile::Events => EVENTS,
            RunFile::Force => FORCE,
            RunFile::FrameDir => FRAME_DIR,
            RunFile::Checkpoint => CHECKPOINT,
            RunFile::Stop => STOP,
            RunFile::Manifest => MANIFEST,
        }
    }
}

/// An output path that is a run or lies inside one ([`outside_runs`]).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error(
    "{}: is inside the run {} (nothing is ever written into a run: it would no longer verify \
     nor export); choose a path outside it",
    path.display(),
    run.display()
)]
pub struct InsideRun {
    pub path: PathBuf,
    pub run: PathBuf,
}

/// Refuses an output path (a file or directory about to be written, existing or not) that is a
/// run or lies inside one, once links are resolved: the one check every writer of outputs
/// (reports, exports, models, datasets, new runs) makes before it does any work.
pub fn outside_runs(path: &Path) -> Result<(), InsideRun> {
    match run_holding(path) {
        Some(run) => Err(InsideRun {
            path: path.to_path_buf(),
            run,
        }),
        None => Ok(()),
    }
}

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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn outputs_in_a_run_or_below_it_are_refused_others_not() {
        let root = std::env::temp_dir().join(format!("fringe-layout-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&root);
        let run = root.join("run-a");
        std::fs::create_dir_all(run.join("frames")).expect("run");
        std::fs::write(run.join(START), "{}").expect("start");
        std::os::unix::fs::symlink(run.join("frames"), root.join("alias")).expect("link");
        for inside in [
            run.clone(),
            run.join("model.onnx"),
            run.join("frames/new/deeper.safetensors"),
            root.join("alias/x.png"),
        ] {
            let e = outside_runs(&inside).expect_err("inside a run");
            assert_eq!(e.run, std::fs::canonicalize(&run).expect("real"));
            assert!(e.to_string().contains("is inside the run"), "{e}");
        }
        for outside in [
            root.clone(),
            root.join("out/model.onnx"),
            root.join("run-b"),
        ] {
            assert_eq!(outside_runs(&outside), Ok(()), "{}", outside.display());
        }
        let _ = std::fs::remove_dir_all(&root);
    }
}
