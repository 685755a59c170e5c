//! Camera traces: recording what a camera delivered, and playing it back as a [`Camera`].
//!
//! A camera trace is a directory holding a text index `index.trace` and one lossless PNG per
//! frame (see docs/trace-format.md, "Camera traces"):
//!
//! ```text
//! # fringe-camera-trace 1
//! # device: camera
//! # camera: Aravis-Fake-GV01
//! # vendor: Aravis
//! # model: Fake
//! # serial: GV01
//! # tick-frequency: 1000000000
//! # configured: exposure 2000 us, gain 0 dB, 50 Hz, roi full, mono8, trigger free-run
//!        1   1000000000   0.000000000  16  12  mono8  frame-000000.png
//! latch  0.010000000   1010000000   0.010000500
//! ```
//!
//! A frame line is `ID DEVICE_TIMESTAMP HOST_SECONDS WIDTH HEIGHT FORMAT FILE`, where
//! `HOST_SECONDS` is the host arrival time in seconds since the recording started. A latch line
//! is `latch HOST_BEFORE DEVICE_TICKS HOST_AFTER`.

use super::{
    format_name, parse_format_name, Camera, CameraError, CameraInfo, CameraSettings, Frame,
    PixelFormat, TimestampLatch, TriggerMode,
};
use crate::clock::HostTime;
use crate::store::frames::error::FrameFileError;
use crate::store::frames::png::{load_png, save_png};
use std::fs::File;
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};
use std::time::Duration;

/// First line of a camera trace index.
pub(crate) const MAGIC: &str = "# fringe-camera-trace 1";
/// File name of the index inside a camera trace directory.
pub(crate) const INDEX: &str = "index.trace";

/// Errors reading a camera trace, naming the file and line.
#[derive(Debug, thiserror::Error)]
pub enum CameraTraceError {
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: io::Error,
    },
    #[error("{path}:{line}: {message}")]
    Parse {
        path: PathBuf,
        line: usize,
        message: String,
    },
    #[error("{path}:{line}: {source}")]
    Field {
        path: PathBuf,
        line: usize,
        #[source]
        source: TraceFieldError,
    },
    #[error(transparent)]
    Frame(#[from] FrameFileError),
}

/// A field of a trace line that does not parse; [`CameraTraceError::Field`] adds the file and
/// line.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum TraceFieldError {
    #[error("bad seconds {0:?} (expected e.g. 0.020000000)")]
    Seconds(String),
    #[error("bad {what} {field:?}")]
    Number { what: &'static str, field: String },
    #[error("unknown pixel format {0:?} (mono8, rgb8 or bayerrg8)")]
    PixelFormat(String),
}

/// One recorded frame (pixels stay in their file until replayed).
#[derive(Debug, Clone, PartialEq)]
pub struct TraceFrame {
    pub id: u64,
    pub device_timestamp: u64,
    /// Host arrival since the recording started.
    pub host_offset: Duration,
    pub width: u32,
    pub height: u32,
    pub format: PixelFormat,
    /// File name relative to the trace directory.
    pub file: String,
}

/// One recorded timestamp latch, host times relative to the recording start.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TraceLatch {
    pub host_before: Duration,
    pub device_ticks: u64,
    pub host_after: Duration,
}

/// A parsed camera trace index.
#[derive(Debug, Clone, PartialEq)]
pub struct CameraTrace {
    pub dir: PathBuf,
    pub device: String,
    pub info: CameraInfo,
    /// `# configured:` lines, in order.
    pub configured: Vec<String>,
    pub frames: Vec<TraceFrame>,
    pub latches: Vec<TraceLatch>,
}

fn seconds(d: Duration) -> String {
    format!("{}.{:09}", d.as_secs(), d.subsec_nanos())
}

fn parse_seconds(text: &str) -> Result<Duration, TraceFieldError> {
    let bad = || TraceFieldError::Seconds(text.to_string());
    let (whole, frac) = text.split_once('.').unwrap_or((text, ""));
    if frac.len() > 9 || !frac.bytes().all(|b| b.is_ascii_digit()) {
        return Err(bad());
    }
    let secs: u64 = whole.parse().map_err(|_| bad())?;
    let nanos: u32 = if frac.is_empty() {
        0
    } else {
        format!("{frac:0<9}").parse().map_err(|_| bad())?
    };
    Ok(Duration::new(secs, nanos))
}

fn num<T: std::str::FromStr>(field: &str, what: &'static str) -> Result<T, TraceFieldError> {
    field.parse().map_err(|_| TraceFieldError::Number {
        what,
        field: field.to_string(),
    })
}

/// A one-line description of settings, for `# configured:` lines.
pub(crate) fn describe_settings(s: &CameraSettings) -> String {
    let roi = match s.roi {
        Some(r) => format!("{}x{}+{}+{}", r.width, r.height, r.x, r.y),
        None => "full".to_string(),
    };
    let trigger = match &s.trigger {
        TriggerMode::FreeRun => "free-run".to_string(),
        TriggerMode::Software => "software".to_string(),
        TriggerMode::Hardware(line) => format!("hardware {line}"),
    };
    let strobe = s
        .exposure_active_line
        .as_deref()
        .map(|l| format!(", exposure-active on {l}"))
        .unwrap_or_default();
    format!(
        "exposure {} us, gain {} dB, {} Hz, roi {roi}, {}, trigger {trigger}{strobe}",
        s.exposure.value(),
        s.gain.value(),
        s.frame_rate.value(),
        format_name(s.pixel_format)
    )
}

/// Why one index line did not parse; [`LineError::at`] adds the file and line.
enum LineError {
    Syntax(String),
    Field(TraceFieldError),
}

impl From<TraceFieldError> for LineError {
    fn from(e: TraceFieldError) -> Self {
        LineError::Field(e)
    }
}

impl LineError {
    /// The error for line `line` of the index at `path`.
    fn at(self, path: PathBuf, line: usize) -> CameraTraceError {
        match self {
            LineError::Syntax(message) => CameraTraceError::Parse {
                path,
                line,
                message,
            },
            LineError::Field(source) => CameraTraceError::Field { path, line, source },
        }
    }
}

/// A latch line `latch HOST_BEFORE DEVICE_TICKS HOST_AFTER`, split into fields.
fn parse_latch(fields: &[&str]) -> Result<TraceLatch, LineError> {
    if fields.len() != 4 {
        return Err(LineError::Syntax(
            "a latch line is `latch HOST_BEFORE DEVICE_TICKS HOST_AFTER`".into(),
        ));
    }
    Ok(TraceLatch {
        host_before: parse_seconds(fields[1])?,
        device_ticks: num(fields[2], "device ticks")?,
        host_after: parse_seconds(fields[3])?,
    })
}

/// A frame line `ID DEVICE_TIMESTAMP HOST_SECONDS WIDTH HEIGHT FORMAT FILE`, split into fields.
fn parse_frame(fields: &[&str]) -> Result<TraceFrame, LineError> {
    if fields.len() != 7 {
        return Err(LineError::Syntax(format!(
            "a frame line has 7 fields `ID DEVICE_TIMESTAMP HOST_SECONDS WIDTH HEIGHT FORMAT FILE`, found {}",
            fields.len()
        )));
    }
    Ok(TraceFrame {
        id: num(fields[0], "frame id")?,
        device_timestamp: num(fields[1], "device timestamp")?,
        host_offset: parse_seconds(fields[2])?,
        width: num(fields[3], "width")?,
        height: num(fields[4], "height")?,
        format: parse_format_name(fields[5])
            .ok_or_else(|| TraceFieldError::PixelFormat(fields[5].to_string()))?,
        file: fields[6].to_string(),
    })
}

impl CameraTrace {
    /// Parses an index; `dir` is where its frame files are.
    pub fn parse(text: &str, dir: &Path) -> Result<CameraTrace, CameraTraceError> {
        let path = dir.join(INDEX);
        let mut lines = text.lines().enumerate();
        match lines.next() {
            Some((_, first)) if first.trim_end() == MAGIC => {}
            _ => {
                return Err(CameraTraceError::Parse {
                    path,
                    line: 1,
                    message: format!("not a camera trace: the first line must be `{MAGIC}`"),
                })
            }
        }
        let mut trace = CameraTrace {
            dir: dir.to_path_buf(),
            device: "camera".into(),
            info: CameraInfo {
                vendor: String::new(),
                model: String::new(),
                serial: String::new(),
                id: String::new(),
                tick_frequency: 1_000_000_000,
            },
            configured: Vec::new(),
            frames: Vec::new(),
            latches: Vec::new(),
        };
        for (i, raw) in lines {
            let line = raw.trim();
            if line.is_empty() {
                continue;
            }
            trace
                .parse_line(line)
                .map_err(|e| e.at(path.clone(), i + 1))?;
        }
        Ok(trace)
    }

    /// Takes one non-empty index line: a `# key: value` header, a latch or a frame.
    fn parse_line(&mut self, line: &str) -> Result<(), LineError> {
        if let Some(comment) = line.strip_prefix('#') {
            if let Some((key, value)) = comment.trim().split_once(": ") {
                self.header_field(key, value.trim().to_string())?;
            }
            return Ok(());
        }
        let fields: Vec<&str> = line.split_whitespace().collect();
        if fields[0] == "latch" {
            self.latches.push(parse_latch(&fields)?);
        } else {
            self.frames.push(parse_frame(&fields)?);
        }
        Ok(())
    }

    /// Takes one `# key: value` header line; unknown keys are comments.
    fn header_field(&mut self, key: &str, value: String) -> Result<(), TraceFieldError> {
        match key {
            "device" => self.device = value,
            "camera" => self.info.id = value,
            "vendor" => self.info.vendor = value,
            "model" => self.info.model = value,
            "serial" => self.info.serial = value,
            "tick-frequency" => self.info.tick_frequency = num(&value, "tick-frequency")?,
            "configured" => self.configured.push(value),
            _ => {}
        }
        Ok(())
    }

    /// Loads `dir/index.trace`.
    pub fn load(dir: &Path) -> Result<CameraTrace, CameraTraceError> {
        let path = dir.join(INDEX);
        let text = std::fs::read_to_string(&path)
            .map_err(|source| CameraTraceError::Io { path, source })?;
        CameraTrace::parse(&text, dir)
    }

    /// Reads the pixels of one frame.
    pub fn load_frame(&self, frame: &TraceFrame) -> Result<Vec<u8>, CameraTraceError> {
        Ok(load_png(
            &self.dir.join(&frame.file),
            frame.format,
            frame.width,
            frame.height,
        )?)
    }
}

/// Writes a camera trace directory: the index and one PNG per frame.
pub struct CameraTraceWriter {
    dir: PathBuf,
    index: BufWriter<File>,
    index_path: PathBuf,
    start: HostTime,
    count: u64,
}

impl CameraTraceWriter {
    /// Creates `dir` and its index (replacing an existing index); `start` is time zero.
    pub fn create(
        dir: &Path,
        device: &str,
        info: &CameraInfo,
        start: HostTime,
    ) -> io::Result<CameraTraceWriter> {
        std::fs::create_dir_all(dir)?;
        let index_path = dir.join(INDEX);
        let mut index = BufWriter::new(File::create(&index_path)?);
        writeln!(index, "{MAGIC}")?;
        writeln!(index, "# device: {device}")?;
        writeln!(index, "# camera: {}", info.id)?;
        writeln!(index, "# vendor: {}", info.vendor)?;
        writeln!(index, "# model: {}", info.model)?;
        writeln!(index, "# serial: {}", info.serial)?;
        writeln!(index, "# tick-frequency: {}", info.tick_frequency)?;
        writeln!(
            index,
            "# frame: ID DEVICE_TIMESTAMP HOST_SECONDS WIDTH HEIGHT FORMAT FILE"
        )?;
        index.flush()?;
        Ok(CameraTraceWriter {
            dir: dir.to_path_buf(),
            index,
            index_path,
            start,
            count: 0,
        })
    }

    fn io_err(&self, source: io::Error) -> CameraTraceError {
        CameraTraceError::Io {
            path: self.index_path.clone(),
            source,
        }
    }

    /// Appends a `# configured:` line.
    pub fn configured(&mut self, settings: &CameraSettings) -> Result<(), CameraTraceError> {
        let line = format!("# configured: {}", describe_settings(settings));
        writeln!(self.index, "{line}")
            .and_then(|()| self.index.flush())
            .map_err(|e| self.io_err(e))
    }

    /// Saves the frame's PNG and appends its index line.
    pub fn frame(&mut self, frame: &Frame) -> Result<(), CameraTraceError> {
        let name = format!("frame-{:06}.png", self.count);
        save_png(frame, &self.dir.join(&name))?;
        let line = format!(
            "{:>8} {:>20} {:>16} {:>5} {:>5} {:>8} {name}",
            frame.id,
            frame.device_timestamp,
            seconds(frame.host_arrival.since(self.start)),
            frame.width,
            frame.height,
            format_name(frame.format)
        );
        writeln!(self.index, "{line}")
            .and_then(|()| self.index.flush())
            .map_err(|e| self.io_err(e))?;
        self.count += 1;
        Ok(())
    }

    /// Appends a latch line.
    pub fn latch(&mut self, latch: &TimestampLatch) -> Result<(), CameraTraceError> {
        let line = format!(
            "latch {} {} {}",
            seconds(latch.host_before.since(self.start)),
            latch.device_ticks,
            seconds(latch.host_after.since(self.start))
        );
        writeln!(self.index, "{line}")
            .and_then(|()| self.index.flush())
            .map_err(|e| self.io_err(e))
    }
}

/// A camera whose frames, settings and latches are also written to a camera trace.
pub struct RecordingCamera<C: Camera> {
    inner: C,
    writer: CameraTraceWriter,
    name: String,
}

impl<C: Camera> RecordingCamera<C> {
    /// Records `inner` into the trace directory `dir` (created if needed).
    pub fn new(inner: C, dir: &Path, device: &str) -> Result<Self, CameraError> {
        let info = inner.info();
        let writer =
            CameraTraceWriter::create(dir, device, &info, HostTime::now()).map_err(|source| {
                CameraError::Io {
                    camera: format!("{} (recording to {})", info.id, dir.display()),
                    source,
                }
            })?;
        Ok(RecordingCamera {
            inner,
            writer,
            name: info.id,
        })
    }

    /// The wrapped camera.
    pub fn inner(&self) -> &C {
        &self.inner
    }

    fn trace_err(&self, e: CameraTraceError) -> CameraError {
        CameraError::Device {
            camera: self.name.clone(),
            message: format!("cannot record the camera trace: {e}"),
        }
    }
}

impl<C: Camera> Camera for RecordingCamera<C> {
    fn info(&self) -> CameraInfo {
        self.inner.info()
    }

    fn configure(&mut self, settings: &CameraSettings) -> Result<(), CameraError> {
        self.inner.configure(settings)?;
        self.writer
            .configured(settings)
            .map_err(|e| self.trace_err(e))
    }

    fn start(&mut self) -> Result<(), CameraError> {
        self.inner.start()
    }

    fn trigger(&mut self) -> Result<(), CameraError> {
        self.inner.trigger()
    }

    fn next_frame(&mut self, timeout: Duration) -> Result<Option<Frame>, CameraError> {
        let frame = self.inner.next_frame(timeout)?;
        if let Some(f) = &frame {
            self.writer.frame(f).map_err(|e| self.trace_err(e))?;
        }
        Ok(frame)
    }

    fn stop(&mut self) -> Result<(), CameraError> {
        self.inner.stop()
    }

    fn latch_timestamp(&mut self) -> Result<TimestampLatch, CameraError> {
        let latch = self.inner.latch_timestamp()?;
        self.writer.latch(&latch).map_err(|e| self.trace_err(e))?;
        Ok(latch)
    }
}

/// How fast a [`ReplayCamera`] delivers frames.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ReplayPace {
    /// Each frame no earlier than its recorded host arrival after [`Camera::start`].
    Recorded,
    /// Each frame as soon as it is asked for.
    AsFastAsPossible,
}

/// A [`Camera`] that plays back a camera trace: the recorded frames in order, with their
/// recorded ids and device timestamps; host arrival is the replay's own host time.
///
/// In [`TriggerMode::Software`] (set by [`Camera::configure`]) one frame is delivered per
/// [`Camera::trigger`], as a triggered camera would. Timestamp latches return the recorded
/// latches in order, with their host times moved onto the replay's clock.
pub struct ReplayCamera {
    trace: CameraTrace,
    pace: ReplayPace,
    next: usize,
    next_latch: usize,
    started: Option<HostTime>,
    software_trigger: bool,
    pending_triggers: u64,
}

impl ReplayCamera {
    /// Opens the camera trace directory `dir`.
    pub fn open(dir: &Path, pace: ReplayPace) -> Result<ReplayCamera, CameraTraceError> {
        Ok(ReplayCamera::new(CameraTrace::load(dir)?, pace))
    }

    /// Plays an already loaded trace.
    pub fn new(trace: CameraTrace, pace: ReplayPace) -> ReplayCamera {
        ReplayCamera {
            trace,
            pace,
            next: 0,
            next_latch: 0,
            started: None,
            software_trigger: false,
            pending_triggers: 0,
        }
    }

    /// The trace being played.
    pub fn trace(&self) -> &CameraTrace {
        &self.trace
    }

    /// Frames not yet delivered.
    pub fn remaining(&self) -> usize {
        self.trace.frames.len() - self.next
    }

    fn name(&self) -> String {
        format!("replay of {}", self.trace.dir.display())
    }
}

impl ReplayCamera {
    /// The pixel formats the trace's frames are in (what the replayed camera offers).
    pub fn offered_formats(&self) -> Vec<PixelFormat> {
        let mut offered: Vec<PixelFormat> = self.trace.frames.iter().map(|f| f.format).collect();
        offered.sort_by_key(|f| format_name(*f));
        offered.dedup();
        offered
    }
}

impl Camera for ReplayCamera {
    fn info(&self) -> CameraInfo {
        self.trace.info.clone()
    }

    /// A replayed camera offers the pixel formats its trace holds, no other.
    fn configure(&mut self, settings: &CameraSettings) -> Result<(), CameraError> {
        let offered = self.offered_formats();
        if !offered.is_empty() && !offered.contains(&settings.pixel_format) {
            let names: Vec<&str> = offered.iter().map(|f| format_name(*f)).collect();
            return Err(CameraError::Feature {
                camera: self.name(),
                feature: "PixelFormat".into(),
                message: format!(
                    "cannot be set to {}: the camera offers {} (set [camera] pixel_format to it)",
                    format_name(settings.pixel_format),
                    names.join(", ")
                ),
            });
        }
        self.software_trigger = settings.trigger == TriggerMode::Software;
        Ok(())
    }

    fn start(&mut self) -> Result<(), CameraError> {
        self.started = Some(HostTime::now());
        Ok(())
    }

    fn trigger(&mut self) -> Result<(), CameraError> {
        if !self.software_trigger {
            return Err(CameraError::Device {
                camera: self.name(),
                message: "trigger() needs the software trigger mode (configure with TriggerMode::Software)".into(),
            });
        }
        self.pending_triggers += 1;
        Ok(())
    }

    /// Returns `Ok(None)` at once when the trace is exhausted.
    fn next_frame(&mut self, timeout: Duration) -> Result<Option<Frame>, CameraError> {
        let Some(started) = self.started else {
            return Err(CameraError::Device {
                camera: self.name(),
                message: "next_frame() before start()".into(),
            });
        };
        let Some(rec) = self.trace.frames.get(self.next).cloned() else {
            return Ok(None);
        };
        if self.software_trigger && self.pending_triggers == 0 {
            std::thread::sleep(timeout);
            return Ok(None);
        }
        if self.pace == ReplayPace::Recorded {
            let due = started
                .nanos()
                .saturating_add(rec.host_offset.as_nanos() as u64);
            let wait = HostTime(due).since(HostTime::now());
            if wait > timeout {
                std::thread::sleep(timeout);
                return Ok(None);
            }
            std::thread::sleep(wait);
        }
        let data = self
            .trace
            .load_frame(&rec)
            .map_err(|e| CameraError::Device {
                camera: self.name(),
                message: format!("cannot read frame {}: {e}", rec.id),
            })?;
        self.next += 1;
        self.pending_triggers = self.pending_triggers.saturating_sub(1);
        Ok(Some(Frame {
            id: rec.id,
            device_timestamp: rec.device_timestamp,
            host_arrival: HostTime::now(),
            width: rec.width,
            height: rec.height,
            format: rec.format,
            data,
        }))
    }

    fn stop(&mut self) -> Result<(), CameraError> {
        self.started = None;
        Ok(())
    }

    fn latch_timestamp(&mut self) -> Result<TimestampLatch, CameraError> {
        let Some(l) = self.trace.latches.get(self.next_latch).copied() else {
            return Err(CameraError::Device {
                camera: self.name(),
                message: format!(
                    "the trace has no more timestamp latches ({} recorded)",
                    self.trace.latches.len()
                ),
            });
        };
        self.next_latch += 1;
        let now = HostTime::now();
        let span = l.host_after.saturating_sub(l.host_before);
        Ok(TimestampLatch {
            host_before: now,
            device_ticks: l.device_ticks,
            host_after: HostTime(now.nanos().saturating_add(span.as_nanos() as u64)),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn seconds_round_trip_to_the_nanosecond() {
        for d in [
            Duration::ZERO,
            Duration::new(3, 5),
            Duration::new(12, 999_999_999),
        ] {
            assert_eq!(parse_seconds(&seconds(d)), Ok(d));
        }
        assert_eq!(parse_seconds("0.5"), Ok(Duration::from_millis(500)));
        assert!(parse_seconds("1.x").is_err());
    }

    #[test]
    fn parse_errors_name_the_line() {
        let text = format!("{MAGIC}\n# device: camera\n1 2 0.0 4 4 mono9 f.png\n");
        let err = CameraTrace::parse(&text, Path::new("/t")).expect_err("bad format");
        let msg = err.to_string();
        assert!(
            msg.contains("index.trace:3") && msg.contains("mono9"),
            "{msg}"
        );
        let err =
            CameraTrace::parse("# fringe-trace 1\n", Path::new("/t")).expect_err("wrong magic");
        assert!(err.to_string().contains("fringe-camera-trace"), "{err}");
    }
}
