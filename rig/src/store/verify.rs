//! Checking a run directory: documents parse, records are consecutive, hold everything the last
//! checkpoint counts and point at existing frames inside the run, the force log is whole, counts agree with the stop document and every file matches the
//! manifest.

use super::documents::{FrameRecord, StartDocument, StopDocument};
use super::error::StoreError;
use super::layout::{CHECKPOINT, FORCE, FRAMES, MANIFEST, STOP};
use super::run_writer::{
    check_checkpoint, read_document, read_frame_lines, Checkpoint, FrameLines,
};
use super::{force_log, manifest, own_file};
use std::path::Path;

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
    let start: StartDocument = super::run_writer::read_start(dir)?;
    let mut problems = Vec::new();
    let frames: Vec<FrameRecord> = match read_frame_lines(&dir.join(FRAMES)) {
        Ok(lines) => {
            if let Some(t) = &lines.torn {
                problems.push(format!(
                    "{FRAMES}: torn last line ({} bytes, a crash mid-write)",
                    t.len()
                ));
            }
            check_against_checkpoint(dir, &lines, &mut problems);
            lines.records
        }
        Err(e) => {
            problems.push(e.to_string());
            Vec::new()
        }
    };
    // Every frame has the run's size (the first frame's): a run filmed at two sizes is two
    // runs in one directory.
    let mut size: Option<(u32, u32)> = None;
    let mut other_sizes = 0u64;
    for (k, f) in frames.iter().enumerate() {
        let own = own_file::check_in(dir, Path::new(&f.file)).is_ok();
        if let (Ok(path), true) = (f.file_in(dir), own) {
            if let Some(dims) = image_size(&path) {
                match size {
                    None => size = Some(dims),
                    Some(first) if first != dims => {
                        other_sizes += 1;
                        if other_sizes <= 3 {
                            problems.push(format!(
                                "{}: {}x{} px, where the run's frames are {}x{} px (filmed by another camera or at another size)",
                                f.file, dims.0, dims.1, first.0, first.1
                            ));
                        }
                    }
                    Some(_) => {}
                }
            }
        }
        if f.index != k as u64 {
            problems.push(format!(
                "{FRAMES}: record {} has index {}, expected {k}",
                k + 1,
                f.index
            ));
        }
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
    if other_sizes > 3 {
        problems.push(format!(
            "{FRAMES}: {other_sizes} frames in all are not the size of the run's first frame"
        ));
    }
    let force_path = dir.join(FORCE);
    let force_samples = match own_file::read(&force_path) {
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
    };
    let stop_path = dir.join(STOP);
    let ended = stop_path.exists();
    let mut manifest_missing = false;
    if ended {
        match read_document::<StopDocument>(&stop_path) {
            Ok(stop) => {
                if stop.frames != frames.len() as u64 {
                    problems.push(format!(
                        "{STOP}: says {} frames, {FRAMES} holds {}",
                        stop.frames,
                        frames.len()
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
        manifest_missing = !dir.join(MANIFEST).is_file();
        if !manifest_missing {
            problems.extend(manifest::check(dir)?);
        } else {
            problems.push(format!(
                "{MANIFEST}: missing (the run was stopped while closing; resuming it writes it)"
            ));
        }
    } else {
        problems.push(format!(
            "{STOP}: missing: the run did not finish (resume it)"
        ));
    }
    Ok(VerifyReport {
        run_id: start.run_id,
        frames: frames.len() as u64,
        force_samples,
        ended,
        manifest_missing,
        problems,
    })
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

/// Width and height of an image file, from its header; `None` when it cannot be read (a missing
/// or damaged frame is reported by the other checks).
fn image_size(path: &Path) -> Option<(u32, u32)> {
    image::ImageReader::open(path)
        .ok()?
        .with_guessed_format()
        .ok()?
        .into_dimensions()
        .ok()
}
