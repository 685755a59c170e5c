//! Reading a run: the one door through which runs are read ([`RunReader`]), and the readers
//! of its documents that the store's own files share (the writer reopening a run, verify, the
//! run list, export).
//!
//! A reader names a run's files by what they hold ([`RunFile`]); their names are the store's
//! ([`super::layout`]): nothing outside the store joins them. Every read takes what the run
//! says (its layout version, how it stores its frames), never today's defaults, so every run
//! written by an earlier fringe reads as it did.

use super::documents::{
    Checkpoint, Event, FrameRecord, StartDocument, StopDocument, LAYOUT_VERSION,
};
use super::error::StoreError;
use super::force_log;
use super::frames::{FrameStorage, StoredFrame};
use super::layout::{RunFile, START};
use super::own_file;
use crate::force::ForceSample;
use std::path::{Path, PathBuf};

/// A run directory, read. Nothing is read until asked for: [`RunReader::at`] only names the
/// directory, each method reads (and checks) the file it is about.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RunReader {
    dir: PathBuf,
}

impl RunReader {
    /// The run in `dir` (nothing is read yet).
    pub fn at(dir: &Path) -> RunReader {
        RunReader {
            dir: dir.to_path_buf(),
        }
    }

    /// The run directory.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// Where the run keeps `file` (for messages, and for tools and tests that look at the
    /// files themselves).
    pub fn path(&self, file: RunFile) -> PathBuf {
        self.dir.join(file.name())
    }

    /// Whether the directory holds a run: its start document is a file (not read).
    pub fn is_run(&self) -> bool {
        self.has(RunFile::Start)
    }

    /// Whether the run's `file` is there, as a file.
    pub fn has(&self, file: RunFile) -> bool {
        self.path(file).is_file()
    }

    /// The start document; [`StoreError::NotARun`] when there is none (a missing directory, a
    /// typo, the runs root instead of one run), an error naming the file when it is of a newer
    /// layout than this fringe reads.
    pub fn start(&self) -> Result<StartDocument, StoreError> {
        read_start(&self.dir)
    }

    /// The frame records, in order (a torn last line, a crash mid-write, is left out; a missing
    /// file holds none).
    pub fn frames(&self) -> Result<Vec<FrameRecord>, StoreError> {
        Ok(read_lines(&self.path(RunFile::Frames))?.0)
    }

    /// The events, in order (a torn last line is left out; a missing file holds none).
    pub fn events(&self) -> Result<Vec<Event>, StoreError> {
        Ok(read_lines(&self.path(RunFile::Events))?.0)
    }

    /// The raw force stream: every whole sample, and the bytes of a torn record at its end.
    pub fn force(&self) -> Result<(Vec<ForceSample>, usize), StoreError> {
        let path = self.path(RunFile::Force);
        let bytes = own_file::read(&path).map_err(|e| StoreError::io(&path, e))?;
        force_log::decode_all(&bytes).map_err(|e| StoreError::Content {
            path,
            message: e.to_string(),
        })
    }

    /// The last checkpoint; `None` when the run reached none.
    pub fn checkpoint(&self) -> Result<Option<Checkpoint>, StoreError> {
        let path = self.path(RunFile::Checkpoint);
        match path.is_file() {
            true => Ok(Some(read_document(&path)?)),
            false => Ok(None),
        }
    }

    /// The stop document; `None` while the run has not ended (or after a crash).
    pub fn stop(&self) -> Result<Option<StopDocument>, StoreError> {
        let path = self.path(RunFile::Stop);
        match path.exists() {
            true => Ok(Some(read_document(&path)?)),
            false => Ok(None),
        }
    }

    /// Whether the run was closed whole: its stop document and its manifest are there.
    pub fn is_closed(&self) -> bool {
        self.has(RunFile::Stop) && self.has(RunFile::Manifest)
    }

    /// The frame file of `record`, checked to lie inside the run ([`FrameRecord::file_in`]).
    pub fn frame_file(&self, record: &FrameRecord) -> Result<PathBuf, StoreError> {
        record.file_in(&self.dir)
    }

    /// Where `record` says its frame file is, as written (not checked: [`RunReader::frame_file`]
    /// checks it).
    pub fn frame_path(&self, record: &FrameRecord) -> PathBuf {
        self.dir.join(&record.file)
    }

    /// The stored frame of `record` (pixels as the camera delivered them, inside the part the
    /// run keeps), read as `storage` (the run's [`StartDocument::frame_storage`]) says:
    /// `Ok(Err(reason))` when its file is missing or damaged (the reason without the file's
    /// path), an error when the record names a path outside the run or what is not the run's
    /// own regular file (a link, a FIFO), which no reader reads.
    pub fn stored_frame(
        &self,
        storage: &FrameStorage,
        record: &FrameRecord,
    ) -> Result<Result<StoredFrame, String>, StoreError> {
        let source = self.frame_file(record)?;
        match own_file::check_in(&self.dir, Path::new(&record.file)) {
            Ok(()) => {}
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Err("missing".into())),
            Err(e) => return Err(StoreError::io(&source, e)),
        }
        Ok(storage.read(&source).map_err(|e| e.reason()))
    }
}

/// The start document of the run in `dir`; [`StoreError::NotARun`] when `dir` has none (a
/// missing directory, a typo, the runs root instead of one run).
pub(crate) fn read_start(dir: &Path) -> Result<StartDocument, StoreError> {
    let path = dir.join(START);
    if !path.exists() {
        return Err(StoreError::NotARun {
            dir: dir.to_path_buf(),
        });
    }
    let start: StartDocument = read_document(&path)?;
    if start.layout_version > LAYOUT_VERSION {
        return Err(StoreError::Content {
            path,
            message: format!(
                "the run has layout version {} but this fringe ({}) reads up to {LAYOUT_VERSION}: \
                 read it with a newer fringe",
                start.layout_version,
                env!("CARGO_PKG_VERSION")
            ),
        });
    }
    Ok(start)
}

/// Reads a JSON document.
pub(crate) fn read_document<T: serde::de::DeserializeOwned>(path: &Path) -> Result<T, StoreError> {
    let text = own_file::read_to_string(path).map_err(|e| StoreError::io(path, e))?;
    serde_json::from_str(&text).map_err(|e| StoreError::Parse {
        path: path.to_path_buf(),
        line: e.line(),
        message: e.to_string(),
    })
}

/// Reads a JSON-lines file; a torn last line (no newline) is returned separately, not parsed.
pub(crate) fn read_lines<T: serde::de::DeserializeOwned>(
    path: &Path,
) -> Result<(Vec<T>, Option<String>), StoreError> {
    let text = match own_file::read_to_string(path) {
        Ok(t) => t,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok((Vec::new(), None)),
        Err(e) => return Err(StoreError::io(path, e)),
    };
    let (complete, torn) = match text.rfind('\n') {
        Some(i) if i + 1 < text.len() => (&text[..=i], Some(text[i + 1..].to_string())),
        Some(_) => (text.as_str(), None),
        None if text.is_empty() => ("", None),
        None => ("", Some(text.clone())),
    };
    let mut out = Vec::new();
    for (k, line) in complete.lines().enumerate() {
        out.push(serde_json::from_str(line).map_err(|e| StoreError::Parse {
            path: path.to_path_buf(),
            line: k + 1,
            message: e.to_string(),
        })?);
    }
    Ok((out, torn))
}

/// The frame records of a run, with the byte offset at which each complete line ends.
pub(crate) struct FrameLines {
    pub records: Vec<FrameRecord>,
    /// `ends[k]`: length of the file up to and including the newline of record `k`.
    pub ends: Vec<u64>,
    /// A torn last line (no newline), not parsed.
    pub torn: Option<String>,
}

/// Reads `frames.jsonl` (a missing file holds no records).
pub(crate) fn read_frame_lines(path: &Path) -> Result<FrameLines, StoreError> {
    let (records, torn) = read_lines::<FrameRecord>(path)?;
    let text = match own_file::read(path) {
        Ok(t) => t,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Vec::new(),
        Err(e) => return Err(StoreError::io(path, e)),
    };
    let ends: Vec<u64> = text
        .iter()
        .enumerate()
        .filter(|(_, b)| **b == b'\n')
        .map(|(i, _)| i as u64 + 1)
        .collect();
    if ends.len() != records.len() {
        return Err(StoreError::Content {
            path: path.to_path_buf(),
            message: format!(
                "{} lines but {} records (the file changed while it was read)",
                ends.len(),
                records.len()
            ),
        });
    }
    Ok(FrameLines {
        records,
        ends,
        torn,
    })
}
