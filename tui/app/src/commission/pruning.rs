//! What a commissioning keeps: the rounds' frames are pruned (each round's features, read once,
//! are kept in `features/`, and its run's records, events and force stream stay), unless asked
//! to keep them (`--keep-runs`). When the adaptation needs nothing of a round but its features
//! (neither `--last-block` nor `--fine-tune`), a round's frames go as soon as its features are
//! kept, so the disk holds one round's frames at a time; else after the commissioning passed.
//! The calibration scan and the acceptance scan are kept whole: the certificate cites them,
//! `fringe eval` recomputes its figures from the acceptance scan and `fringe check` compares the
//! unit with both.

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

/// Whether each round's frames go as soon as its features are kept: nothing after the rounds
/// trains on frames, and they were not asked to be kept.
pub(crate) fn prunes_as_read(keep_runs: bool, last_block: bool, fine_tune: bool) -> bool {
    !keep_runs && !last_block && !fine_tune
}

/// Removes the frame files of every round of `runs` whose features are kept, records which in
/// the journal and says how much was freed.
pub(crate) fn prune_rounds(c: &mut Commissioning<'_>, runs: &[PathBuf]) -> Result<()> {
    let mut freed = 0u64;
    let mut pruned = Vec::new();
    for run in runs {
        if let Some((id, bytes)) = prune_frames(c, run) {
            freed += bytes;
            pruned.push(id);
        }
    }
    if pruned.is_empty() {
        return Ok(());
    }
    record(c, &pruned)?;
    c.say(format!(
        "pruned the frames of {} ({:.1} GB freed): their features are kept in {}/, their records in runs/ (--keep-runs keeps the frames)",
        pruned.join(", "),
        freed as f64 / 1e9,
        c.dir.join(FEATURES_DIR).display()
    ));
    Ok(())
}

/// Removes the frame files of the round `run` just read, when its features are kept and
/// [`prunes_as_read`]; says so in a line of progress.
pub(crate) fn prune_read_round(c: &mut Commissioning<'_>, run: &Path) -> Result<()> {
    let o = &c.journal.options;
    if !prunes_as_read(c.keep_runs, o.last_block, o.fine_tune) {
        return Ok(());
    }
    let Some((id, bytes)) = prune_frames(c, run) else {
        return Ok(());
    };
    record(c, std::slice::from_ref(&id))?;
    c.host.notice(format!(
        "{id}: its frames pruned ({:.1} GB freed) now that its features are kept (--keep-runs keeps them)",
        bytes as f64 / 1e9
    ));
    Ok(())
}

/// The frames of `run` removed when its features are kept: its id and the bytes freed.
fn prune_frames(c: &mut Commissioning<'_>, run: &Path) -> Option<(String, u64)> {
    let id = run.file_name().map(|n| n.to_string_lossy().into_owned())?;
    let frames = RunReader::at(run).path(RunFile::FrameDir);
    if !frames.is_dir() || !features_path(&c.dir, &id).is_file() {
        return None;
    }
    let bytes = tree_bytes(&frames);
    match std::fs::remove_dir_all(&frames) {
        Ok(()) => Some((id, bytes)),
        Err(e) => {
            c.host.notice(format!(
                "warning: cannot prune the frames of {}: {e} (they stay)",
                run.display()
            ));
            None
        }
    }
}

/// The rounds `pruned` recorded in the journal.
fn record(c: &mut Commissioning<'_>, pruned: &[String]) -> Result<()> {
    for id in pruned {
        if !c.journal.pruned.contains(id) {
            c.journal.pruned.push(id.clone());
        }
    }
    c.journal.write(&c.dir)?;
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
            "{what} trains on the rounds' frames, and the frames of {} were pruned once their features were kept (enough for the heads): start a new commissioning with it (with --keep-runs to keep every round's frames)",
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
