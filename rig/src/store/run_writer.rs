//! Writing a run: create, append, checkpoint, reopen after a crash, finish.
//!
//! Crash safety: the start and stop documents and the manifest are written atomically (temp file,
//! fsync, rename, fsync of the directory); records are appended one whole line per write, frame
//! images are renamed into place before their record is appended, and [`RunWriter::checkpoint`]
//! fsyncs everything (the scan calls it before each grid point). After a crash, whatever reached
//! the disk is a valid prefix except possibly one torn line or force record at the end, which
//! [`RunWriter::reopen`] cuts off.

use super::documents::{
    now_utc, Checkpoint, Event, ExitStatus, FrameRecord, StartDocument, StopDocument,
};
use super::durable::{sync_dir, write_atomic};
use super::error::StoreError;
use super::frames::error::FrameFileError;
use super::frames::FrameStorage;
use super::layout::{RunFile, CHECKPOINT, EVENTS, FORCE, FRAMES, FRAME_DIR, MANIFEST, START, STOP};
use super::own_file;
use super::run_lock::RunLock;
use super::run_reader::{read_frame_lines, read_lines, read_start, FrameLines, RunReader};
use super::{force_log, manifest};
use crate::camera::Frame;
use crate::clock::HostTime;
use crate::force::ForceSample;
use crate::force::FtAxes;
use std::fs::{File, OpenOptions};
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

fn json<T: serde::Serialize>(path: &Path, value: &T) -> Result<String, StoreError> {
    serde_json::to_string(value).map_err(|e| StoreError::Content {
        path: path.to_path_buf(),
        message: format!("cannot encode: {e}"),
    })
}

fn open_append(path: &Path) -> Result<File, StoreError> {
    own_file::append(path).map_err(|e| StoreError::io(path, e))
}

/// What a reopened run already holds.
#[derive(Debug, Clone, PartialEq)]
pub struct Existing {
    pub start: StartDocument,
    pub frames: Vec<FrameRecord>,
    pub events: Vec<Event>,
    pub force_samples: u64,
    /// Bytes cut from torn ends (frames, events, force).
    pub cut_bytes: u64,
    /// The last checkpoint, if the run reached one.
    pub checkpoint: Option<Checkpoint>,
    /// Frame records cut because they came after the last checkpoint (an unfinished point).
    pub discarded_frames: u64,
    /// The stop document of a run that ended failed (a device or the disk failed), which a
    /// resume reopens: the document and the manifest are removed, the run goes on.
    pub failed_stop: Option<StopDocument>,
}

/// An open run directory.
pub struct RunWriter {
    dir: PathBuf,
    frames: File,
    events: File,
    force: BufWriter<File>,
    next_index: u64,
    force_samples: u64,
    last_checkpoint: Option<Checkpoint>,
    /// How the run stores its frames (its start document's, never today's default).
    storage: FrameStorage,
    /// How the run's F/T axes sit (its start document's), for the frames' shear.
    ft_axes: Option<FtAxes>,
    /// This process's hold on the run: no other writes it meanwhile (released last).
    _lock: RunLock,
}

impl RunWriter {
    /// Creates `root/<run_id>` and writes the start document; refuses an existing directory.
    /// A `root` inside a run is refused: the new run would be a stray directory of that one.
    pub fn create(root: &Path, start: &StartDocument) -> Result<RunWriter, StoreError> {
        super::layout::outside_runs(root)?;
        std::fs::create_dir_all(root).map_err(|e| StoreError::Content {
            path: root.to_path_buf(),
            message: format!(
                "cannot make the directory for the runs: {e} (choose one you can write, with --out DIR)"
            ),
        })?;
        let dir = root.join(&start.run_id);
        std::fs::create_dir(&dir).map_err(|e| {
            if e.kind() == std::io::ErrorKind::AlreadyExists {
                StoreError::Content {
                    path: dir.clone(),
                    message: "a run with this id exists already (resume it, or choose another id)"
                        .into(),
                }
            } else {
                StoreError::io(&dir, e)
            }
        })?;
        let lock = RunLock::write(&dir)?;
        let frame_dir = dir.join(FRAME_DIR);
        std::fs::create_dir(&frame_dir).map_err(|e| StoreError::io(&frame_dir, e))?;
        let start_path = dir.join(START);
        let text = serde_json::to_string_pretty(start).map_err(|e| StoreError::Content {
            path: start_path.clone(),
            message: format!("cannot encode: {e}"),
        })?;
        write_atomic(&start_path, text.as_bytes())?;
        let force_path = dir.join(FORCE);
        let mut force =
            own_file::create(&force_path).map_err(|e| StoreError::io(&force_path, e))?;
        force
            .write_all(&force_log::header())
            .map_err(|e| StoreError::io(&force_path, e))?;
        let writer = RunWriter {
            frames: open_append(&dir.join(FRAMES))?,
            events: open_append(&dir.join(EVENTS))?,
            force: BufWriter::with_capacity(1 << 20, force),
            dir,
            next_index: 0,
            force_samples: 0,
            last_checkpoint: None,
            storage: start.frame_storage(),
            ft_axes: start.ft_axes,
            _lock: lock,
        };
        sync_dir(&writer.dir)?;
        Ok(writer)
    }

    /// Reopens an unfinished run after a crash: cuts torn ends and the records of the point that
    /// did not finish, returns what is there.
    pub fn reopen(dir: &Path) -> Result<(RunWriter, Existing), StoreError> {
        RunWriter::reopen_if(dir, |_| Ok(()))
    }

    /// As [`RunWriter::reopen`], but `accept` sees what the run holds first and may refuse it
    /// (a different plan, say). Everything is read and checked before anything is changed: a
    /// run that is refused, by `accept` or because it is damaged, is left exactly as it was.
    /// A run another process writes is refused before anything is read ([`RunLock`]).
    pub fn reopen_if<E: From<StoreError>>(
        dir: &Path,
        accept: impl FnOnce(&Existing) -> Result<(), E>,
    ) -> Result<(RunWriter, Existing), E> {
        let lock = RunWriter::lock_for_reopen(dir)?;
        RunWriter::reopen_held(dir, lock, accept)
    }

    /// Takes the run in `dir` for writing, before anything else is opened (the devices of a
    /// resumed scan): a run another process writes is refused, naming it, and a directory that
    /// is not a run is refused without a lock file left in it. Hand the lock to
    /// [`RunWriter::reopen_held`].
    pub fn lock_for_reopen(dir: &Path) -> Result<RunLock, StoreError> {
        if !RunReader::at(dir).is_run() {
            // Not a run: say so (read_start's error) rather than leave a lock file in it.
            read_start(dir)?;
        }
        RunLock::write(dir)
    }

    /// [`RunWriter::reopen_if`] of the run in `dir`, held already by `lock` (from
    /// [`RunWriter::lock_for_reopen`] of the same directory).
    pub fn reopen_held<E: From<StoreError>>(
        dir: &Path,
        lock: RunLock,
        accept: impl FnOnce(&Existing) -> Result<(), E>,
    ) -> Result<(RunWriter, Existing), E> {
        let survey = survey(dir)?;
        accept(&survey.existing)?;
        // The run's manifest, written when it ends, will vouch for the frames it holds now.
        refuse_damaged_frames(dir, &survey.existing.frames)?;
        Ok(survey.apply(dir, lock)?)
    }
    /// The run directory.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// How the run stores its frames.
    pub fn frame_storage(&self) -> FrameStorage {
        self.storage
    }

    /// How the run's F/T axes sit on the bench (its start document's), if known.
    pub fn ft_axes(&self) -> Option<FtAxes> {
        self.ft_axes
    }

    /// Index the next frame record must have.
    pub fn next_index(&self) -> u64 {
        self.next_index
    }

    /// Force samples written so far.
    pub fn force_samples(&self) -> u64 {
        self.force_samples
    }

    /// Saves the image of frame record `index` under frames/ (renamed into place when complete);
    /// returns its path relative to the run directory. Named by record index, not camera frame
    /// id: ids start again when a run is resumed.
    pub fn save_frame_image(&self, frame: &Frame, index: u64) -> Result<String, StoreError> {
        let rel = format!(
            "{FRAME_DIR}/{index:08}.{}",
            self.storage.encoding.extension()
        );
        let path = self.dir.join(&rel);
        let tmp = self.dir.join(format!("{rel}.tmp"));
        self.storage.write(frame, &tmp).map_err(|e| match e {
            FrameFileError::Io { path, source }
            | FrameFileError::Image {
                path,
                source: image::ImageError::IoError(source),
            } => StoreError::Io { path, source },
            FrameFileError::Image { path, source } => StoreError::Content {
                path,
                message: source.to_string(),
            },
            FrameFileError::Content { path, message } => StoreError::Content { path, message },
        })?;
        std::fs::rename(&tmp, &path).map_err(|e| StoreError::io(&path, e))?;
        Ok(rel)
    }

    /// Appends a frame record; its index must be [`RunWriter::next_index`].
    pub fn append_frame(&mut self, record: &FrameRecord) -> Result<(), StoreError> {
        let path = self.dir.join(FRAMES);
        if record.index != self.next_index {
            return Err(StoreError::Content {
                path,
                message: format!(
                    "frame record index {} out of order (expected {})",
                    record.index, self.next_index
                ),
            });
        }
        let mut line = json(&path, record)?;
        line.push('\n');
        self.frames
            .write_all(line.as_bytes())
            .map_err(|e| StoreError::io(&path, e))?;
        self.next_index += 1;
        Ok(())
    }

    /// Appends an event.
    pub fn append_event(
        &mut self,
        kind: &str,
        point: Option<u64>,
        message: &str,
    ) -> Result<(), StoreError> {
        let path = self.dir.join(EVENTS);
        let event = Event {
            host_ns: HostTime::now().0,
            utc: now_utc(),
            kind: kind.to_string(),
            point,
            message: message.to_string(),
        };
        let mut line = json(&path, &event)?;
        line.push('\n');
        self.events
            .write_all(line.as_bytes())
            .map_err(|e| StoreError::io(&path, e))
    }

    /// Appends raw force samples (buffered; made durable by [`RunWriter::checkpoint`]). Each
    /// sample is counted once the buffer holds it: when the disk fills in the middle of a batch,
    /// the samples taken before the error are still written by the next flush, and the count
    /// (the stop document's) matches what the force log ends up holding.
    pub fn append_force(&mut self, samples: &[ForceSample]) -> Result<(), StoreError> {
        for s in samples {
            self.force
                .write_all(&force_log::encode(s))
                .map_err(|e| StoreError::io(self.dir.join(FORCE), e))?;
            self.force_samples += 1;
        }
        Ok(())
    }

    /// Makes everything written so far durable.
    pub fn checkpoint(&mut self) -> Result<(), StoreError> {
        let force = self.dir.join(FORCE);
        self.force.flush().map_err(|e| StoreError::io(&force, e))?;
        self.force
            .get_ref()
            .sync_data()
            .map_err(|e| StoreError::io(&force, e))?;
        self.frames
            .sync_data()
            .map_err(|e| StoreError::io(self.dir.join(FRAMES), e))?;
        self.events
            .sync_data()
            .map_err(|e| StoreError::io(self.dir.join(EVENTS), e))?;
        sync_dir(&self.dir.join(FRAME_DIR))
    }

    /// Makes everything durable and records a checkpoint before point `next_point`.
    pub fn checkpoint_at(&mut self, next_point: u64) -> Result<Checkpoint, StoreError> {
        self.checkpoint()?;
        let frames_path = self.dir.join(FRAMES);
        let frames_bytes = std::fs::metadata(&frames_path)
            .map_err(|e| StoreError::io(&frames_path, e))?
            .len();
        let checkpoint = Checkpoint {
            next_point,
            next_index: self.next_index,
            frames_bytes,
            utc: now_utc(),
        };
        let path = self.dir.join(CHECKPOINT);
        write_atomic(&path, json(&path, &checkpoint)?.as_bytes())?;
        self.last_checkpoint = Some(checkpoint.clone());
        Ok(checkpoint)
    }

    /// The last checkpoint written or found.
    pub fn last_checkpoint(&self) -> Option<&Checkpoint> {
        self.last_checkpoint.as_ref()
    }

    /// Cuts every frame record (and image) made after the last checkpoint: the records of a point
    /// that is going to be done again. Returns how many were cut.
    pub fn rollback(&mut self) -> Result<u64, StoreError> {
        let (index, bytes) = self
            .last_checkpoint
            .as_ref()
            .map_or((0, 0), |c| (c.next_index, c.frames_bytes));
        let cut = self.next_index.saturating_sub(index);
        if cut > 0 {
            let path = self.dir.join(FRAMES);
            self.frames
                .sync_data()
                .map_err(|e| StoreError::io(&path, e))?;
            set_length(&path, bytes)?;
            self.remove_images_from(index)?;
            self.next_index = index;
        }
        Ok(cut)
    }

    /// Removes frame images of record index `first` and later (and unfinished temporaries).
    fn remove_images_from(&self, first: u64) -> Result<(), StoreError> {
        let dir = self.dir.join(FRAME_DIR);
        let entries = match std::fs::read_dir(&dir) {
            Ok(e) => e,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(()),
            Err(e) => return Err(StoreError::io(&dir, e)),
        };
        for entry in entries {
            let entry = entry.map_err(|e| StoreError::io(&dir, e))?;
            let name = entry.file_name().to_string_lossy().to_string();
            let index = name.split('.').next().and_then(|n| n.parse::<u64>().ok());
            if name.ends_with(".tmp") || index.is_some_and(|i| i >= first) {
                let path = entry.path();
                std::fs::remove_file(&path).map_err(|e| StoreError::io(&path, e))?;
            }
        }
        sync_dir(&dir)
    }

    /// Ends the run: checkpoint, stop document, manifest. Returns the run directory.
    pub fn finish(mut self, stop: &StopDocument) -> Result<PathBuf, StoreError> {
        self.checkpoint()?;
        let path = self.dir.join(STOP);
        let text = serde_json::to_string_pretty(stop).map_err(|e| StoreError::Content {
            path: path.clone(),
            message: format!("cannot encode: {e}"),
        })?;
        write_atomic(&path, text.as_bytes())?;
        manifest::write(&self.dir)?;
        Ok(self.dir)
    }

    /// Finishes the close of a run that was stopped (killed, power lost) after its stop
    /// document and before its manifest: hashing a large run takes seconds, so that window is
    /// real. A run that ended completed or aborted gets its manifest and the stop document is
    /// returned; any other run (unfinished, failed, or closed whole) is left alone and `None`
    /// returned. The frames sat without a manifest: a damaged one is refused, and no manifest is
    /// written over it.
    pub fn finish_cut_close(dir: &Path) -> Result<Option<StopDocument>, StoreError> {
        let run = RunReader::at(dir);
        if !run.has(RunFile::Stop) || run.has(RunFile::Manifest) {
            return Ok(None);
        }
        let _lock = RunLock::write(dir)?;
        let Some(document) = run.stop()? else {
            return Ok(None);
        };
        if document.exit_status == ExitStatus::Failed {
            return Ok(None);
        }
        // The frames sat without a manifest: each is checked before one vouches for them.
        refuse_damaged_frames(dir, &read_frame_lines(&run.path(RunFile::Frames))?.records)?;
        manifest::write(dir)?;
        Ok(Some(document))
    }
}

/// The frames of `records` whose files are not whole ([`FrameStorage::check_file`]: an FGL
/// frame by its checksum, others decoded), one line each naming the file and its record. A
/// record whose file is missing, outside the run or not the run's own is passed over here
/// (verify reports it).
pub(crate) fn damaged_frames(
    dir: &Path,
    storage: &FrameStorage,
    records: &[FrameRecord],
) -> Vec<String> {
    records
        .iter()
        .filter_map(|r| {
            let path = r.file_in(dir).ok()?;
            own_file::check_in(dir, Path::new(&r.file)).ok()?;
            let e = storage.check_file(&path).err()?;
            Some(format!(
                "{}: {} (frame of record {})",
                r.file,
                e.reason(),
                r.index
            ))
        })
        .collect()
}

/// Refuses to go on with a run (resume it, write its manifest) while a frame it holds is
/// damaged: what is written next would vouch for it.
fn refuse_damaged_frames(dir: &Path, records: &[FrameRecord]) -> Result<(), StoreError> {
    let storage = read_start(dir)?.frame_storage();
    let damaged = damaged_frames(dir, &storage, records);
    match damaged.first() {
        None => Ok(()),
        Some(first) => Err(StoreError::Content {
            path: dir.to_path_buf(),
            message: format!(
                "{} frame file(s) are damaged, the first: {first}; nothing is written over \
                 them (no manifest vouches for a damaged frame): restore them from a backup",
                damaged.len()
            ),
        }),
    }
}

/// Checks the frame records against the last checkpoint: every record the checkpoint counts must
/// be there, byte for byte as far as the checkpoint went. Returns the length of `frames.jsonl`
/// at the checkpoint (where the records of the unfinished point begin); the message says what is
/// wrong otherwise.
pub(crate) fn check_checkpoint(lines: &FrameLines, c: &Checkpoint) -> Result<u64, String> {
    let held = lines.records.len() as u64;
    if held < c.next_index {
        return Err(format!(
            "{FRAMES} holds {held} records but {CHECKPOINT} counts {} before point {}: \
             the records of finished points are missing (the file was cut or damaged); \
             restore {FRAMES} from a backup, the run cannot be resumed without losing them",
            c.next_index, c.next_point
        ));
    }
    let bytes = match c.next_index {
        0 => 0,
        n => lines.ends[n as usize - 1],
    };
    if bytes != c.frames_bytes {
        return Err(format!(
            "the first {} records of {FRAMES} end at byte {bytes}, {CHECKPOINT} says {}: \
             records before the checkpoint were changed; restore {FRAMES} from a backup",
            c.next_index, c.frames_bytes
        ));
    }
    Ok(bytes)
}

/// What reopening a run finds and will change, worked out without changing anything.
struct Survey {
    existing: Existing,
    /// Length `frames.jsonl` is cut to, when it is cut.
    frames_length: Option<u64>,
    events_torn: u64,
    force_torn: u64,
}

fn survey(dir: &Path) -> Result<Survey, StoreError> {
    let run = RunReader::at(dir);
    let failed_stop = match run.stop()? {
        Some(document) if document.exit_status != ExitStatus::Failed => {
            return Err(StoreError::Content {
                path: run.path(RunFile::Stop),
                message: format!(
                    "the run has ended ({:?}: {}); start a new run instead of resuming",
                    document.exit_status, document.reason
                ),
            });
        }
        failed => failed,
    };
    let start: StartDocument = run.start()?;
    let frames_path = run.path(RunFile::Frames);
    let lines = read_frame_lines(&frames_path)?;
    let checkpoint = run.checkpoint()?;
    // Without a checkpoint (a run written by something other than the scan engine) every
    // complete record is kept.
    let (keep, keep_bytes) = match &checkpoint {
        Some(c) => {
            let bytes = check_checkpoint(&lines, c).map_err(|message| StoreError::Content {
                path: frames_path.clone(),
                message,
            })?;
            (c.next_index as usize, bytes)
        }
        None => (lines.records.len(), lines.ends.last().copied().unwrap_or(0)),
    };
    let frames_torn = lines.torn.as_ref().map_or(0, |t| t.len() as u64);
    let discarded_frames = (lines.records.len() - keep) as u64;
    let mut frames = lines.records;
    frames.truncate(keep);
    for (k, f) in frames.iter().enumerate() {
        if f.index != k as u64 {
            return Err(StoreError::Content {
                path: frames_path,
                message: format!(
                    "record {} has index {} (records must count up from 0): the run is damaged",
                    k + 1,
                    f.index
                ),
            });
        }
    }
    let (events, torn) = read_lines::<Event>(&dir.join(EVENTS))?;
    let events_torn = torn.map_or(0, |t| t.len() as u64);
    let (samples, force_torn) = run.force()?;
    let frames_length = (frames_torn > 0 || discarded_frames > 0).then_some(keep_bytes);
    Ok(Survey {
        existing: Existing {
            start,
            frames,
            events,
            force_samples: samples.len() as u64,
            cut_bytes: frames_torn + events_torn + force_torn as u64,
            checkpoint,
            discarded_frames,
            failed_stop,
        },
        frames_length,
        events_torn,
        force_torn: force_torn as u64,
    })
}

impl Survey {
    /// Cuts what the survey found to cut and opens the run for appending.
    fn apply(self, dir: &Path, lock: RunLock) -> Result<(RunWriter, Existing), StoreError> {
        if self.existing.failed_stop.is_some() {
            // The manifest first: a crash between the two leaves a stop document without a
            // manifest, which `fringe verify` reports and a resume reopens the same way.
            for name in [MANIFEST, STOP] {
                let path = dir.join(name);
                match std::fs::remove_file(&path) {
                    Ok(()) => {}
                    Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
                    Err(e) => return Err(StoreError::io(&path, e)),
                }
            }
            sync_dir(dir)?;
        }
        let frames_path = dir.join(FRAMES);
        if let Some(length) = self.frames_length {
            set_length(&frames_path, length)?;
        }
        let events_path = dir.join(EVENTS);
        if self.events_torn > 0 {
            truncate_by(&events_path, self.events_torn)?;
        }
        let force_path = dir.join(FORCE);
        if self.force_torn > 0 {
            truncate_by(&force_path, self.force_torn)?;
        }
        let existing = self.existing;
        let writer = RunWriter {
            frames: open_append(&frames_path)?,
            events: open_append(&events_path)?,
            force: BufWriter::with_capacity(1 << 20, open_append(&force_path)?),
            dir: dir.to_path_buf(),
            next_index: existing.frames.len() as u64,
            force_samples: existing.force_samples,
            last_checkpoint: existing.checkpoint.clone(),
            storage: existing.start.frame_storage(),
            ft_axes: existing.start.ft_axes,
            _lock: lock,
        };
        writer.remove_images_from(writer.next_index)?;
        Ok((writer, existing))
    }
}

fn set_length(path: &Path, bytes: u64) -> Result<(), StoreError> {
    let f = own_file::open_with(OpenOptions::new().write(true), path)
        .map_err(|e| StoreError::io(path, e))?;
    f.set_len(bytes)
        .and_then(|_| f.sync_all())
        .map_err(|e| StoreError::io(path, e))
}

fn truncate_by(path: &Path, bytes: u64) -> Result<(), StoreError> {
    let f = own_file::open_with(OpenOptions::new().write(true), path)
        .map_err(|e| StoreError::io(path, e))?;
    let len = f.metadata().map_err(|e| StoreError::io(path, e))?.len();
    f.set_len(len.saturating_sub(bytes))
        .and_then(|_| f.sync_all())
        .map_err(|e| StoreError::io(path, e))
}
