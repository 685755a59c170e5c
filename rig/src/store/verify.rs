//! Checking a run directory: documents parse, records are consecutive, hold everything the last
//! checkpoint counts and point at existing frames inside the run, each frame named by one
//! record, the force log is whole, counts agree with the stop document, every file matches the
//! manifest (without one, each frame is checked by its own checksum or decoded), and the run
//! holds only regular files (its lock file too).

use super::documents::{Checkpoint, FrameRecord, StartDocument, StopDocument};
use super::error::StoreError;
use super::frames::stored_dimensions;
use super::layout::{CHECKPOINT, FORCE, FRAMES, MANIFEST, STOP};
use super::run_lock::{self, LOCK};
use super::run_reader::{read_document, read_frame_lines, FrameLines};
use super::run_writer::{check_checkpoint, damaged_frames};
use super::{force_log, manifest, own_file};
use std::collections::HashMap;
use std::path::{Component, Path};

/// What checking a run found.
#[derive(Debug, Clone, PartialEq)]
pub struct VerifyReport {
    pub run_id: String,
    pub frames: u64,
    pub force_samples: u64,
    /// The run ended (a stop document exists).
    pub ended: bool,
    /// It ended but was stopped while writing its manifest (resuming it writes the manifest).
    pub manifest_missing: bool,
    /// The process writing the run now, as its lock names it (`pid N: command (since ...)`);
    /// `None` when no process writes it.
    pub writer: Option<String>,
    /// Every problem found, one line each; empty means the run is intact.
    pub problems: Vec<String>,
}

impl VerifyReport {
    pub fn ok(&self) -> bool {
        self.problems.is_empty()
    }
}

/// Checks the run in `dir`. Fails only when `dir` is not a run at all (no readable start
/// document); everything else is reported as a problem.
pub fn verify(dir: &Path) -> Result<VerifyReport, StoreError> {
    let start: StartDocument = super::run_reader::read_start(dir)?;
    let mut problems = Vec::new();
    let frames = read_frames(dir, &mut problems);
    check_frames(dir, &start, &frames, &mut problems);
    let force_samples = count_force_samples(dir, &mut problems);
    let ended = dir.join(STOP).exists();
    let mut manifest_missing = false;
    let writer = run_lock::writer(dir);
    if ended {
        check_stop_counts(dir, frames.len() as u64, force_samples, &mut problems);
        manifest_missing = !dir.join(MANIFEST).is_file();
        if !manifest_missing {
            problems.extend(manifest::check(dir)?);
        } else {
            problems.push(format!(
                "{MANIFEST}: missing (the run was stopped while closing; resuming it writes it)"
            ));
        }
    } else if let Some(holder) = &writer {
        problems.push(format!(
            "{STOP}: missing: the run is being written, {holder}; verify it once that process has ended"
        ));
    } else {
        problems.push(format!(
            "{STOP}: missing: the run did not finish (resume it)"
        ));
    }
    if !ended || manifest_missing {
        // No manifest vouches for the frames: each is checked on its own.
        problems.extend(damaged_frames(dir, &start.frame_storage(), &frames));
    }
    for (rel, why) in manifest::strangers(dir)? {
        problems.push(if rel == LOCK {
            let link =
                std::fs::symlink_metadata(dir.join(LOCK)).is_ok_and(|m| m.file_type().is_symlink());
            format!(
                "{LOCK}: is {}, not the regular file fringe makes: nothing opens the run through \
                 it (writers and exports are refused); remove it (what it points to is not \
                 touched)",
                if link {
                    "a symbolic link"
                } else {
                    "a FIFO, a socket or a device"
                }
            )
        } else {
            format!("{rel}: {why}")
        });
    }
    Ok(VerifyReport {
        run_id: start.run_id,
        frames: frames.len() as u64,
        force_samples,
        ended,
        manifest_missing,
        writer,
        problems,
    })
}

/// The frame records, reporting a torn last line and records the checkpoint counts but the
/// file lost; none when the file cannot be read.
fn read_frames(dir: &Path, problems: &mut Vec<String>) -> Vec<FrameRecord> {
    match read_frame_lines(&dir.join(FRAMES)) {
        Ok(lines) => {
            if let Some(t) = &lines.torn {
                problems.push(format!(
                    "{FRAMES}: torn last line ({} bytes, a crash mid-write)",
                    t.len()
                ));
            }
            check_against_checkpoint(dir, &lines, problems);
            lines.records
        }
        Err(e) => {
            problems.push(e.to_string());
            Vec::new()
        }
    }
}

/// Checks each record in turn: its frame's size (the stored region's, when the run stores only
/// a part of each frame), its index, that no other record names its frame and that its frame
/// exists inside the run.
fn check_frames(
    dir: &Path,
    start: &StartDocument,
    frames: &[FrameRecord],
    problems: &mut Vec<String>,
) {
    let mut sizes = FrameSizes {
        first: start
            .frame_storage()
            .cutout
            .map(|c| (c.roi.width, c.roi.height)),
        others: 0,
    };
    // Each frame file's first record, by its path inside the run.
    let mut named: HashMap<Vec<String>, (usize, u64)> = HashMap::with_capacity(frames.len());
    for (k, f) in frames.iter().enumerate() {
        let key: Vec<String> = Path::new(&f.file)
            .components()
            .filter_map(|c| match c {
                Component::Normal(n) => Some(n.to_string_lossy().into_owned()),
                _ => None,
            })
            .collect();
        if let Some(dims) = frame_size(dir, f) {
            sizes.note(&f.file, dims, problems);
        }
        if f.index != k as u64 {
            problems.push(format!(
                "{FRAMES}: record {} has index {}, expected {k}",
                k + 1,
                f.index
            ));
        }
        // A line repeated whole is the index's problem, above.
        let (first_at, first) = *named.entry(key).or_insert((k, f.index));
        if first_at != k && first != f.index {
            problems.push(format!(
                "{}: named by record {} and again by record {}: each frame file belongs to one \
                 record (an edited {FRAMES}; an export would give both records the same image)",
                f.file, first, f.index
            ));
        }
        check_frame_file(dir, f, problems);
    }
    sizes.finish(problems);
}

/// Width and height of a record's frame when it is a readable image inside the run.
fn frame_size(dir: &Path, f: &FrameRecord) -> Option<(u32, u32)> {
    let own = own_file::check_in(dir, Path::new(&f.file)).is_ok();
    match (f.file_in(dir), own) {
        (Ok(path), true) => stored_dimensions(&path),
        _ => None,
    }
}

/// Reports a record whose frame is outside the run, missing or unreadable.
fn check_frame_file(dir: &Path, f: &FrameRecord, problems: &mut Vec<String>) {
    match f.file_in(dir) {
        Ok(_) => match own_file::check_in(dir, Path::new(&f.file)) {
            Ok(()) => {}
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => problems.push(format!(
                "{}: frame of record {} is missing",
                f.file, f.index
            )),
            Err(e) => problems.push(format!("{}: {e}", f.file)),
        },
        Err(e) => problems.push(e.to_string()),
    }
}

/// Every frame has the run's size (its stored region's, else the first frame's): a run filmed at
/// two sizes is two runs in one directory. The first three others are reported one by one, more as a count.
#[derive(Default)]
struct FrameSizes {
    /// The first frame's width and height.
    first: Option<(u32, u32)>,
    /// How many frames differ from it.
    others: u64,
}

impl FrameSizes {
    /// Notes the size of frame `file`, reporting it if it is one of the first three to differ.
    fn note(&mut self, file: &str, dims: (u32, u32), problems: &mut Vec<String>) {
        match self.first {
            None => self.first = Some(dims),
            Some(first) if first != dims => {
                self.others += 1;
                if self.others <= 3 {
                    problems.push(format!(
                        "{}: {}x{} px, where the run's frames are {}x{} px (filmed by another camera or at another size, or edited)",
                        file, dims.0, dims.1, first.0, first.1
                    ));
                }
            }
            Some(_) => {}
        }
    }

    /// Reports how many frames differ in all, when more than three do.
    fn finish(&self, problems: &mut Vec<String>) {
        if self.others > 3 {
            problems.push(format!(
                "{FRAMES}: {} frames in all are not the size of the run's first frame",
                self.others
            ));
        }
    }
}

/// The number of whole samples in the force log, reporting a torn or unreadable log (0 then).
fn count_force_samples(dir: &Path, problems: &mut Vec<String>) -> u64 {
    match own_file::read(&dir.join(FORCE)) {
        Ok(bytes) => match force_log::decode_all(&bytes) {
            Ok((samples, torn)) => {
                if torn > 0 {
                    problems.push(format!("{FORCE}: {torn} bytes of a torn record at the end"));
                }
                samples.len() as u64
            }
            Err(message) => {
                problems.push(format!("{FORCE}: {message}"));
                0
            }
        },
        Err(e) => {
            problems.push(format!("{FORCE}: {e}"));
            0
        }
    }
}

/// Reports where the stop document's frame and force sample counts differ from the files.
fn check_stop_counts(dir: &Path, frames: u64, force_samples: u64, problems: &mut Vec<String>) {
    match read_document::<StopDocument>(&dir.join(STOP)) {
        Ok(stop) => {
            if stop.frames != frames {
                problems.push(format!(
                    "{STOP}: says {} frames, {FRAMES} holds {frames}",
                    stop.frames
                ));
            }
            if stop.force_samples != force_samples {
                problems.push(format!(
                    "{STOP}: says {} force samples, {FORCE} holds {force_samples}",
                    stop.force_samples
                ));
            }
        }
        Err(e) => problems.push(e.to_string()),
    }
}

/// Every record the last checkpoint counts must still be there (a file cut or damaged in the
/// middle loses records of finished points, which a resume would never redo).
fn check_against_checkpoint(dir: &Path, lines: &FrameLines, problems: &mut Vec<String>) {
    let path = dir.join(CHECKPOINT);
    if !path.is_file() {
        return;
    }
    match read_document::<Checkpoint>(&path) {
        Ok(c) => {
            if let Err(message) = check_checkpoint(lines, &c) {
                problems.push(format!("{FRAMES}: {message}"));
            }
        }
        Err(e) => problems.push(e.to_string()),
    }
}
