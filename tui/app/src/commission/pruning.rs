//! What a passing commissioning keeps: the rounds' frames are pruned (each round's features,
//! read once, are kept in `features/`, and its run's records, events and force stream stay),
//! unless asked to keep them (`--keep-runs`). The calibration scan and the acceptance scan are
//! kept whole: the certificate cites them, `fringe eval` recomputes its figures from the
//! acceptance scan and `fringe check` compares the unit with both.

use super::scans::Commissioning;
use crate::workflow_error::{refuse, WorkflowError};
use fringe_rig::store::{RunFile, RunReader};
use std::path::{Path, PathBuf};

type Result<T> = std::result::Result<T, WorkflowError>;

/// The commissioning directory's folder of each round's features, read once.
pub(crate) const FEATURES_DIR: &str = "features";

/// Where the features of the round `run_id` are kept in the commissioning directory `dir`.
pub(crate) fn features_path(dir: &Path, run_id: &str) -> PathBuf {
    dir.join(FEATURES_DIR).join(format!("{run_id}.features"))
}

/// Removes the frame files of every round of `runs` whose features are kept, records which in
/// the journal and says how much was freed.
pub(crate) fn prune_rounds(c: &mut Commissioning<'_>, runs: &[PathBuf]) -> Result<()> {
    let mut freed = 0u64;
    let mut pruned = Vec::new();
    for run in runs {
        let Some(id) = run.file_name().map(|n| n.to_string_lossy().into_owned()) else {
            continue;
        };
        let frames = RunReader::at(run).path(RunFile::FrameDir);
        if !frames.is_dir() || !features_path(&c.dir, &id).is_file() {
            continue;
        }
        let bytes = tree_bytes(&frames);
        match std::fs::remove_dir_all(&frames) {
            Ok(()) => {
                freed += bytes;
                pruned.push(id);
            }
            Err(e) => c.host.notice(format!(
                "warning: cannot prune the frames of {}: {e} (they stay)",
                run.display()
            )),
        }
    }
    if pruned.is_empty() {
        return Ok(());
    }
    for id in &pruned {
        if !c.journal.pruned.contains(id) {
            c.journal.pruned.push(id.clone());
        }
    }
    c.journal.write(&c.dir)?;
    c.say(format!(
        "pruned the frames of {} ({:.1} GB freed): their features are kept in {}/, their records in runs/ (--keep-runs keeps the frames)",
        pruned.join(", "),
        freed as f64 / 1e9,
        c.dir.join(FEATURES_DIR).display()
    ));
    Ok(())
}

/// Refuses to train on `runs` (`what`: the last block, full fine-tuning) when any of their
/// frames were pruned after the commissioning passed.
pub(crate) fn frames_kept(c: &Commissioning<'_>, runs: &[PathBuf], what: &str) -> Result<()> {
    let pruned: Vec<&str> = runs
        .iter()
        .filter_map(|r| r.file_name().and_then(|n| n.to_str()))
        .filter(|id| c.journal.pruned.iter().any(|p| p == id))
        .collect();
    if !pruned.is_empty() {
        refuse!(
            "{what} trains on the rounds' frames, and the frames of {} were pruned when this commissioning passed (their features are kept, enough for the heads): start a new commissioning with it (with --keep-runs to keep every round's frames)",
            pruned.join(", ")
        );
    }
    Ok(())
}

/// Bytes of the files under `dir`.
fn tree_bytes(dir: &Path) -> u64 {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return 0;
    };
    entries
        .filter_map(|e| e.ok())
        .map(|e| match e.metadata() {
            Ok(m) if m.is_dir() => tree_bytes(&e.path()),
            Ok(m) => m.len(),
            Err(_) => 0,
        })
        .sum()
}
