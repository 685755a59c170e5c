//! The run store: one directory per scan, written append-only and crash-safe.
//!
//! ```text
//! runs/<run-id>/
//!   start.json        start document: plan, rig, sensor, profile, software version, seed
//!   frames.jsonl      one record per frame (appended, one line each)
//!   events.jsonl      checkpoints, pauses, watcher actions, operator prompts
//!   force.bin         the complete raw force stream at full rate (fixed-size records)
//!   frames/NNNNNNNN.fgl  lossless frames (.png for RGB8 and with `[recording] codec = "png"`),
//!                     stored as start.json's `frames` says (frames)
//!   checkpoint.json   the last checkpoint: the next point and how far the records went
//!   stop.json         stop document: exit status and counts (absent after a crash)
//!   MANIFEST.sha256   checksums of every file (sha256sum format), written at stop
//!   .lock             held by the process writing the run (not part of the run)
//! ```
//!
//! - `layout`: the names of a run's files (the store's own: others name them by what they hold,
//!   [`RunFile`]); which run a path is in.
//! - [`error`]: the store's errors, naming the file.
//! - [`disk_space`]: room left on the disk, checked before long writes.
//! - [`documents`]: the documents and records, serde types.
//! - [`force_log`]: the binary force stream format (pure encode/decode).
//! - [`frames`]: the frame files: how the frames are stored (pixel format, region, encoding),
//!   written and read; its codecs ([`frames::fgl`], FGL, fringe's lossless codec of one-channel
//!   frames, pure encode/decode; [`frames::png`], PNG files and image files read back), the
//!   demosaicing of stored mosaics ([`frames::debayer`]) and their errors.
//! - [`stored_part`]: `[recording]` of a rig file or a plan: whole frames or the disc's square.
//! - [`durable`]: atomic file replacement and durable directory entries.
//! - [`own_file`]: a run's files are its own regular files (no links, FIFOs or devices).
//! - [`run_lock`]: one writer per run (a lock that names its holder and dies with it).
//! - [`run_reader`]: reading a run, the one door every reader goes through ([`RunReader`]).
//! - [`run_writer`]: creating, appending to, reopening (after a crash) and closing a run
//!   ([`RunWriter`]).
//! - [`manifest`]: the checksum manifest.
//! - [`verify`]: checking a run directory.
//! - [`run_list`]: the runs under a directory, newest first.
//! - [`run_size`]: a run's size on disk, expected before a scan starts and measured after.
//! - [`export`]: the reference pipeline's `0.images/` + `0.labels.csv` layout.

pub(crate) mod disk_space;
pub(crate) mod documents;
pub(crate) mod durable;
pub(crate) mod error;
pub(crate) mod export;
pub(crate) mod force_log;
pub(crate) mod frames;
pub(crate) mod layout;
pub(crate) mod manifest;
pub(crate) mod own_file;
pub(crate) mod run_list;
pub(crate) mod run_lock;
pub(crate) mod run_reader;
pub(crate) mod run_size;
pub(crate) mod run_writer;
pub(crate) mod stored_part;
pub(crate) mod verify;

pub use disk_space::{available_bytes, human as human_bytes};
pub use documents::{
    now_utc, utc_date, utc_days, Checkpoint, Event, ExitStatus, Exposure, FrameRecord, Position,
    ProfileRef, StartDocument, StopDocument, LAYOUT_VERSION,
};
pub use durable::write_atomic;
pub use error::StoreError;
pub use export::{
    estimate_export, export_reference, remove_stale_partials, ExportEstimate, ExportOptions,
    ExportSummary, ExportedRun, ImageCompression,
};
pub use force_log::{
    check_header as check_force_log_header, decode_all as decode_force_log, ForceLogError,
};
pub use frames::debayer::{rgb_at, to_rgb8};
pub use frames::error::FrameFileError;
pub use frames::fgl::{
    decode as decode_fgl, encode as encode_fgl, header as fgl_header, CodecError, GreyImage,
    Pattern as FglPattern,
};
pub use frames::png::{save_png, write_png};
pub use frames::{
    in_whole_frame, pixels_to_image, read_plain, CutoutError, Encoding, FrameCodec, FrameStorage,
    StoredFrame, DISC_MARGIN_PX,
};
pub use layout::{outside_runs, run_holding, InsideRun, RunFile};
pub use manifest::write as write_manifest;
pub use run_list::{list as list_runs, RunSummary};
pub use run_lock::RunLock;
pub use run_reader::RunReader;
pub use run_size::{bytes_on_disk, mean_stored_frame_bytes, RecordingTime, RunSize};
pub use run_writer::{Existing, RunWriter};
pub use stored_part::{RecordingSection, StoredPart};
pub use verify::{verify as verify_run, VerifyReport};
