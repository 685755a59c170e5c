//! A run's size on disk: what a scan will write before it starts (its frames, its force log and
//! its frame records, from the scan's estimated duration), and what a run directory holds.
//!
//! The camera runs for the whole scan, but a run stores its frames only while the indenter
//! presses (approach, ramps, dwells, retract): the frames are that time times the frame rate
//! times the bytes of one stored frame ([`FrameStorage::expected_frame_bytes`], or a resumed
//! run's own mean so far, [`mean_stored_frame_bytes`]). The force stream is recorded all along
//! at full rate in fixed-size records ([`force_log`](super::force_log)); each frame adds one line
//! to frames.jsonl. The events, the start and stop documents and the manifest are a few
//! kilobytes, and the simulated bench's truth.jsonl about a kilobyte a frame: not counted.

use super::force_log::{HEADER_LEN, RECORD_LEN};
use super::frames::FrameStorage;
use super::layout::FRAME_DIR;
use crate::units::Hertz;
use std::io;
use std::path::Path;
use std::time::Duration;

/// Force samples a second the estimate assumes: the DAQ's 5 kHz (the reference rig and the
/// simulated bench). A Net F/T streams at the rate set on its box (up to 7 kHz): its log is then
/// up to 40 % larger, a few percent of a run whose frames are most of it.
pub(crate) const FORCE_RATE_HZ: f64 = 5000.0;

/// Bytes of one frame's line in frames.jsonl. Measured: 550 to 560 on a run of the simulated
/// bench synchronised by strobe (no host exposure window); a record with every field filled at
/// full precision takes 737; the notes of an invalid frame add a few dozen.
pub(crate) const RECORD_BYTES_PER_FRAME: u64 = 800;

/// How long a scan records ([`Estimate::recording_time`](crate::scan::plan::Estimate)).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RecordingTime {
    /// The whole scan: the force stream.
    pub total: Duration,
    /// Of which the indenter presses: the frames.
    pub filming: Duration,
}

impl RecordingTime {
    /// A scan that films from start to end.
    pub fn filming_throughout(total: Duration) -> RecordingTime {
        RecordingTime {
            total,
            filming: total,
        }
    }
}

/// What a run will take on disk.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RunSize {
    /// Frames the camera delivers over the scan.
    pub frames: u64,
    /// Bytes of one stored frame.
    pub frame_bytes_each: u64,
    /// All the frame files, bytes.
    pub frames_bytes: u64,
    /// force.bin, bytes.
    pub force_log_bytes: u64,
    /// frames.jsonl, bytes.
    pub records_bytes: u64,
}

impl RunSize {
    /// A scan recording for `time`, filmed at `frame_rate`, each frame stored as `storage`
    /// stores a frame of `frame_px` pixels (the camera frame's pixel count; a cutout stores its
    /// own).
    pub fn expected(
        time: RecordingTime,
        frame_rate: Hertz,
        storage: &FrameStorage,
        frame_px: u64,
    ) -> RunSize {
        RunSize::with_frame_bytes(time, frame_rate, storage.expected_frame_bytes(frame_px))
    }

    /// A scan recording for `time`, filmed at `frame_rate`, each frame taking
    /// `frame_bytes_each` (a resumed run's own mean).
    pub fn with_frame_bytes(
        time: RecordingTime,
        frame_rate: Hertz,
        frame_bytes_each: u64,
    ) -> RunSize {
        // Saturating conversions: an estimate of an absurd plan is huge, never a panic.
        let frames = (time.filming.as_secs_f64() * frame_rate.0.max(0.0)).ceil() as u64;
        let samples = (time.total.as_secs_f64() * FORCE_RATE_HZ).ceil() as u64;
        RunSize {
            frames,
            frame_bytes_each,
            frames_bytes: frames.saturating_mul(frame_bytes_each),
            force_log_bytes: samples
                .saturating_mul(RECORD_LEN as u64)
                .saturating_add(HEADER_LEN as u64),
            records_bytes: frames.saturating_mul(RECORD_BYTES_PER_FRAME),
        }
    }

    /// Everything, bytes.
    pub fn total_bytes(&self) -> u64 {
        self.frames_bytes
            .saturating_add(self.force_log_bytes)
            .saturating_add(self.records_bytes)
    }
}

/// The mean bytes of the frames a run has stored so far (its frames/ directory's bytes over its
/// frame files); `None` when it has none.
pub fn mean_stored_frame_bytes(run_dir: &Path) -> io::Result<Option<u64>> {
    let dir = run_dir.join(FRAME_DIR);
    let entries = match std::fs::read_dir(&dir) {
        Ok(e) => e,
        Err(e) if e.kind() == io::ErrorKind::NotFound => return Ok(None),
        Err(e) => return Err(e),
    };
    let (mut count, mut bytes) = (0u64, 0u64);
    for entry in entries {
        let meta = entry?.metadata()?;
        if meta.is_file() {
            count += 1;
            bytes = bytes.saturating_add(meta.len());
        }
    }
    Ok((count > 0).then(|| bytes.div_ceil(count)))
}

/// The bytes of the files in `dir` and below (their lengths; links are not followed).
pub fn bytes_on_disk(dir: &Path) -> io::Result<u64> {
    let mut total = 0u64;
    let mut pending = vec![dir.to_path_buf()];
    while let Some(d) = pending.pop() {
        for entry in std::fs::read_dir(&d)? {
            let entry = entry?;
            let meta = entry.path().symlink_metadata()?;
            if meta.is_dir() {
                pending.push(entry.path());
            } else if meta.is_file() {
                total = total.saturating_add(meta.len());
            }
        }
    }
    Ok(total)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::{Cutout, PixelFormat, Roi};
    use crate::store::documents::{Exposure, FrameRecord, Position};
    use crate::units::{Millimetres, Wrench};

    const REFERENCE_PX: u64 = 1920 * 1200;

    fn whole(format: PixelFormat) -> FrameStorage {
        FrameStorage::new(format, None).expect("storage")
    }

    #[test]
    fn a_minute_at_50_fps_is_3000_frames_and_300000_force_samples() {
        let storage = whole(PixelFormat::BayerRg8);
        let minute = RecordingTime::filming_throughout(Duration::from_secs(60));
        let size = RunSize::expected(minute, Hertz(50.0), &storage, REFERENCE_PX);
        let each = storage.expected_frame_bytes(REFERENCE_PX);
        assert_eq!(size.frames, 3000);
        assert_eq!(size.frame_bytes_each, each);
        assert_eq!(size.frames_bytes, 3000 * each);
        assert_eq!(size.force_log_bytes, 300_000 * 80 + 16);
        assert_eq!(size.records_bytes, 3000 * RECORD_BYTES_PER_FRAME);
        assert_eq!(
            size.total_bytes(),
            3000 * each + 300_000 * 80 + 16 + 3000 * RECORD_BYTES_PER_FRAME
        );
        // A minute of whole BayerRG8 frames of the reference camera, in FGL: about 2.9 GB (the
        // record_bench stored 3019 such frames in 2.84 GB, BENCHMARKS.md).
        assert!(
            (2.7e9..3.2e9).contains(&(size.total_bytes() as f64)),
            "{size:?}"
        );
        // Filming half of it: half the frames and records, the same force log.
        let half = RecordingTime {
            total: Duration::from_secs(60),
            filming: Duration::from_secs(30),
        };
        let part = RunSize::expected(half, Hertz(50.0), &storage, REFERENCE_PX);
        assert_eq!(part.frames, 1500);
        assert_eq!(part.force_log_bytes, size.force_log_bytes);
    }

    #[test]
    fn a_disc_square_is_smaller_than_whole_frames_and_rgb8_larger_than_bayer() {
        let minute = |storage: &FrameStorage| {
            let time = RecordingTime::filming_throughout(Duration::from_secs(60));
            RunSize::expected(time, Hertz(50.0), storage, REFERENCE_PX).total_bytes()
        };
        let disc = Cutout {
            roi: Roi {
                x: 480,
                y: 120,
                width: 960,
                height: 960,
            },
            frame_width: 1920,
            frame_height: 1200,
        };
        let bayer = minute(&whole(PixelFormat::BayerRg8));
        let square = minute(&FrameStorage::new(PixelFormat::BayerRg8, Some(disc)).expect("cut"));
        let rgb = minute(&whole(PixelFormat::Rgb8));
        assert!(square < bayer, "{square} vs {bayer}");
        assert!(rgb > 2 * bayer, "{rgb} vs {bayer}");
    }

    #[test]
    fn no_time_is_no_frames_and_an_absurd_estimate_saturates() {
        let storage = whole(PixelFormat::Rgb8);
        let time = RecordingTime::filming_throughout;
        let none = RunSize::expected(time(Duration::ZERO), Hertz(50.0), &storage, REFERENCE_PX);
        assert_eq!((none.frames, none.total_bytes()), (0, 16));
        let huge = RunSize::expected(time(Duration::MAX), Hertz(50.0), &storage, REFERENCE_PX);
        assert_eq!(huge.total_bytes(), u64::MAX);
    }

    #[test]
    fn a_full_frame_record_fits_the_per_frame_figure() {
        // Every number at full precision, as a scan writes them.
        let third = 1.0 / 3.0;
        let position = Position {
            x: Millimetres(112.345_678_901_234_56),
            y: Millimetres(25.000_000_000_000_004),
            z: Millimetres(13.123_456_789_012_345),
        };
        let record = FrameRecord {
            index: 1_234_567,
            frame_id: 1_234_999,
            file: "frames/01234567.png".into(),
            device_timestamp: 1_234_567_890_123_456,
            host_arrival_ns: 1_234_567_890_123_456_789,
            exposure: Some(Exposure {
                start_ns: 1_234_567_890_121_456_789.0 + third,
                end_ns: 1_234_567_890_123_456_789.0 + third,
                error_ns: 12_345.678_901_234_567,
            }),
            exposure_ticks: Some([123_456_789.012_345_67, 123_456_799.012_345_67]),
            point: 99_999,
            commanded: position,
            measured: position,
            wrench: Some(Wrench::from_arrays([-third; 3], [third; 3])),
            shear: None,
            shape: "rectangle".into(),
            contact: Some([-third, third]),
            valid: true,
            notes: Vec::new(),
        };
        let line = serde_json::to_string(&record).expect("json").len() as u64 + 1;
        assert!(line <= RECORD_BYTES_PER_FRAME, "{line} bytes");
        assert!(line > RECORD_BYTES_PER_FRAME * 3 / 4, "{line} bytes");
    }

    #[test]
    fn a_run_directory_is_measured_file_by_file() {
        let dir = std::env::temp_dir().join(format!("fringe-run-size-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        assert_eq!(mean_stored_frame_bytes(&dir).expect("absent"), None);
        std::fs::create_dir_all(dir.join(FRAME_DIR)).expect("dirs");
        assert_eq!(mean_stored_frame_bytes(&dir).expect("empty"), None);
        std::fs::write(dir.join("force.bin"), [0u8; 96]).expect("write");
        std::fs::write(dir.join(FRAME_DIR).join("00000000.png"), [0u8; 1000]).expect("write");
        std::fs::write(dir.join(FRAME_DIR).join("00000001.png"), [0u8; 2001]).expect("write");
        assert_eq!(mean_stored_frame_bytes(&dir).expect("two"), Some(1501));
        assert_eq!(bytes_on_disk(&dir).expect("sum"), 96 + 1000 + 2001);
        let _ = std::fs::remove_dir_all(&dir);
    }
}
