//! A scan run exported to MCAP as ROS 2 records it (`fringe export RUN --format mcap`): the
//! frames, the F/T at its full rate, the labels and the events on the topics of
//! [`super::ros_messages`], every message stamped on Unix time ([`super::run_clock`]), so the
//! run opens in Foxglove (and `rosbags`, the `mcap` readers, `ros2 bag`) beside a robot's own
//! logs. Written through `fringe_ros2::Recorder` (the `ros2` profile, `ros2msg` schemas, CDR,
//! zstd chunks, summary and index), the one MCAP writer `fringe stream --mcap` uses too.
//!
//! The file is written beside its destination as `.<name>.partial-<pid>` and renamed into place
//! once whole and synced: a failed or interrupted export leaves nothing at the destination (the
//! partial file is removed; one left by a killed process says so by its name and is removed by
//! the next export to the same place). An existing file is never replaced.

use super::ros_messages::{self, RunTimes, RunTopics};
use super::run_clock::{restarts, ClockSource, RunClock};
use fringe_rig::store::{
    outside_runs, remove_stale_partials, verify_run, Event, FrameRecord, FrameStorage, RunLock,
    RunReader, StoreError,
};
use fringe_rig::ForceSample;
use fringe_ros2::{
    Classification, Image, Log, PointStamped, Qos, RecordError, Recorder, WrenchStamped,
};
use std::collections::BTreeMap;
use std::path::{Component, Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

/// How a run is exported to MCAP.
#[derive(Debug, Clone)]
pub struct McapExportOptions {
    /// The topics' namespace (`/fringe`).
    pub namespace: String,
    /// The sensor's frame id (`fringe_sensor`); the camera's and the F/T's are it with
    /// `_camera` and `_ft`.
    pub frame_id: String,
    /// Export a run that fails verify too: a frame missing or damaged is left out (its labels
    /// stay), each listed in the summary's problems.
    pub allow_unverified: bool,
    /// Set (by a signal handler) to stop the export: the partial file is removed and an error
    /// returned.
    pub cancel: Option<&'static AtomicBool>,
}

impl Default for McapExportOptions {
    fn default() -> McapExportOptions {
        McapExportOptions {
            namespace: "/fringe".into(),
            frame_id: "fringe_sensor".into(),
            allow_unverified: false,
            cancel: None,
        }
    }
}

/// Why an MCAP export failed, naming the run or the file.
#[derive(Debug, thiserror::Error)]
pub enum McapExportError {
    #[error(transparent)]
    Store(#[from] StoreError),
    #[error(transparent)]
    Record(#[from] RecordError),
    #[error(transparent)]
    Name(#[from] fringe_ros2::NameError),
    #[error("{}: the file exists; an export never replaces one (choose a new name, or remove it first)", path.display())]
    Exists { path: PathBuf },
    #[error("{}: not a file name to create (give the .mcap file to write)", path.display())]
    NotAFile { path: PathBuf },
    #[error("{}: {source}", path.display())]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("{}: {reason} (frame of record {index} of the run {})", path.display(), run.display())]
    Frame {
        run: PathBuf,
        path: PathBuf,
        index: u64,
        reason: String,
    },
    #[error("{}: the export was interrupted (a signal); nothing was written", path.display())]
    Interrupted { path: PathBuf },
}

fn io(path: &Path, source: std::io::Error) -> McapExportError {
    McapExportError::Io {
        path: path.to_path_buf(),
        source,
    }
}

/// How many messages of each kind an export of a run writes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct McapCounts {
    /// Images (one per frame record whose frame could be read).
    pub frames: u64,
    /// Force samples (`NS/ft`).
    pub force_samples: u64,
    /// Labels (`NS/wrench` and `NS/shape` each).
    pub labels: u64,
    /// Labels in contact (`NS/contact`).
    pub contacts: u64,
    /// Events (`NS/events`).
    pub events: u64,
}

/// How the run's host times became Unix times.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ClockMapping {
    pub source: ClockSource,
    /// Processes that wrote the run (1 unless it was resumed).
    pub processes: usize,
    /// How far a stamp may be off the wall clock of the host that recorded the run, at most.
    pub uncertainty: Duration,
}

/// What an export wrote.
#[derive(Debug, Clone, PartialEq)]
pub struct McapExportSummary {
    pub path: PathBuf,
    pub bytes: u64,
    pub counts: McapCounts,
    /// Frames left out as missing or damaged (only with `allow_unverified`).
    pub skipped_frames: u64,
    /// Records with no label to publish (not valid, or no force over the exposure).
    pub without_label: u64,
    /// What verify found wrong with the run and the frames left out (with `allow_unverified`).
    pub problems: Vec<String>,
    pub topics: RunTopics,
    pub clock: ClockMapping,
}

/// What an export of a run will write, said before it starts: its messages, its bytes and its
/// time, measured by exporting a few of the run's own frames and force samples to a scratch file.
#[derive(Debug, Clone, PartialEq)]
pub struct McapExportEstimate {
    pub counts: McapCounts,
    /// Frames exported to measure the rest.
    pub sampled_frames: u64,
    pub bytes: u64,
    pub time: Duration,
}

/// The run read whole, but for its frames' pixels.
struct RunContent {
    reader: RunReader,
    storage: FrameStorage,
    records: Vec<FrameRecord>,
    events: Vec<Event>,
    force: Vec<ForceSample>,
    clock: RunClock,
    frame_restarts: Vec<usize>,
    force_restarts: Vec<usize>,
    event_restarts: Vec<usize>,
    metadata: BTreeMap<String, String>,
}

impl RunContent {
    fn read(run: &Path) -> Result<RunContent, StoreError> {
        let reader = RunReader::at(run);
        let start = reader.start()?;
        let records = reader.frames()?;
        let events = reader.events()?;
        let force = if reader.has(fringe_rig::store::RunFile::Force) {
            reader.force()?.0
        } else {
            Vec::new()
        };
        let clock = RunClock::of_run(&start, &events);
        let frame_restarts = restarts(records.iter().map(|r| r.host_arrival_ns));
        let force_restarts = restarts(force.iter().map(|s| s.host_time.0));
        let event_restarts = restarts(events.iter().map(|e| e.host_ns));
        let mut metadata = BTreeMap::from([
            ("run_id".to_string(), start.run_id.clone()),
            ("started_utc".to_string(), start.started_utc.clone()),
            ("software".to_string(), start.software.clone()),
            ("sensor_id".to_string(), start.sensor_id.clone()),
            ("sync_method".to_string(), start.sync_method.clone()),
            (
                "exported_by".to_string(),
                format!("fringe {}", env!("CARGO_PKG_VERSION")),
            ),
        ]);
        if let Some(v) = start.sensor_variant() {
            metadata.insert("variant".into(), v);
        }
        if let Some(p) = &start.calibration_profile {
            metadata.insert("calibration_profile".into(), p.path.clone());
        }
        Ok(RunContent {
            storage: start.frame_storage(),
            reader,
            records,
            events,
            force,
            clock,
            frame_restarts,
            force_restarts,
            event_restarts,
            metadata,
        })
    }

    fn times(&self) -> RunTimes<'_> {
        RunTimes {
            clock: &self.clock,
            frame_restarts: self.frame_restarts.clone(),
            force_restarts: self.force_restarts.clone(),
            event_restarts: self.event_restarts.clone(),
        }
    }

    fn clock_mapping(&self) -> ClockMapping {
        ClockMapping {
            source: self.clock.source(),
            processes: self.clock.processes(),
            uncertainty: Duration::from_nanos(self.clock.uncertainty_ns()),
        }
    }

    fn counts(&self) -> McapCounts {
        let labels: Vec<&FrameRecord> = self
            .records
            .iter()
            .filter(|r| ros_messages::has_label(r))
            .collect();
        McapCounts {
            frames: self.records.len() as u64,
            force_samples: self.force.len() as u64,
            labels: labels.len() as u64,
            contacts: labels
                .iter()
                .filter(|r| {
                    r.contact.is_some() && r.shape != fringe_rig::reference_layout::NO_CONTACT
                })
                .count() as u64,
            events: self.events.len() as u64,
        }
    }
}

/// The channels of an export.
struct Channels {
    image: fringe_ros2::Channel<Image>,
    ft: fringe_ros2::Channel<WrenchStamped>,
    wrench: fringe_ros2::Channel<WrenchStamped>,
    contact: fringe_ros2::Channel<PointStamped>,
    shape: fringe_ros2::Channel<Classification>,
    events: fringe_ros2::Channel<Log>,
}

impl Channels {
    fn open(r: &mut Recorder, t: &RunTopics) -> Result<Channels, RecordError> {
        Ok(Channels {
            // Sensor data, as the stream offers its topics; the events reliable, as /rosout.
            image: r.channel(&t.image, Qos::SENSOR_DATA)?,
            ft: r.channel(&t.ft, Qos::SENSOR_DATA)?,
            wrench: r.channel(&t.wrench, Qos::SENSOR_DATA)?,
            contact: r.channel(&t.contact, Qos::SENSOR_DATA)?,
            shape: r.channel(&t.shape, Qos::SENSOR_DATA)?,
            events: r.channel(&t.events, Qos::DEFAULT)?,
        })
    }
}

/// Progress of an export: frames written of the run's.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct McapProgress {
    pub frames: u64,
    pub of: u64,
}

/// Exports the run in `run` to the MCAP file `out`, which must not exist (nor lie in a run).
/// A run that fails verify is refused unless `options.allow_unverified`; the run is held for
/// reading meanwhile (a scan or resume writing it is refused, and an export of a run being
/// written is refused).
pub fn export_mcap(
    run: &Path,
    out: &Path,
    options: &McapExportOptions,
    mut progress: impl FnMut(McapProgress),
) -> Result<McapExportSummary, McapExportError> {
    let (parent, staging) = check_destination(out)?;
    let topics = RunTopics::new(&options.namespace, &options.frame_id)?;
    let _lock = match RunReader::at(run).is_run() {
        true => RunLock::read(run)?,
        false => None,
    };
    let report = verify_run(run)?;
    if !report.ok() && !options.allow_unverified {
        return Err(StoreError::Unverified {
            run: run.to_path_buf(),
            count: report.problems.len(),
            first: report.problems[0].clone(),
        }
        .into());
    }
    let content = RunContent::read(run)?;
    std::fs::create_dir_all(&parent).map_err(|e| io(&parent, e))?;
    remove_stale_partials(&parent, &staging);
    let written = write_run(&content, &staging, &topics, options, &mut progress).and_then(
        |(counts, left_out)| {
            // Whole on disk before it takes its name.
            std::fs::File::open(&staging)
                .and_then(|f| f.sync_all())
                .map_err(|e| io(&staging, e))?;
            if out.symlink_metadata().is_ok() {
                return Err(McapExportError::Exists {
                    path: out.to_path_buf(),
                });
            }
            std::fs::rename(&staging, out).map_err(|e| io(out, e))?;
            std::fs::File::open(&parent)
                .and_then(|d| d.sync_all())
                .map_err(|e| io(&parent, e))?;
            Ok((counts, left_out))
        },
    );
    let (counts, left_out) = match written {
        Ok(w) => w,
        Err(e) => {
            // Best effort: the error that stopped the export is the one to report.
            let _ = std::fs::remove_file(&staging);
            return Err(match e {
                McapExportError::Interrupted { .. } => McapExportError::Interrupted {
                    path: out.to_path_buf(),
                },
                e => e,
            });
        }
    };
    let bytes = std::fs::metadata(out).map_err(|e| io(out, e))?.len();
    let all = content.counts();
    let mut problems = report.problems;
    let skipped_frames = left_out.len() as u64;
    problems.extend(left_out);
    Ok(McapExportSummary {
        path: out.to_path_buf(),
        bytes,
        counts,
        skipped_frames,
        without_label: all.frames - all.labels,
        problems,
        topics,
        clock: content.clock_mapping(),
    })
}

/// Estimates the export of the run in `run` to `out` (refused as the export would refuse it):
/// its messages, and the bytes and time of [`ESTIMATE_FRAMES`] of its frames (spread over the
/// run) and up to [`ESTIMATE_SAMPLES`] of its force samples written to a scratch file, scaled to
/// the run.
pub fn estimate_mcap_export(
    run: &Path,
    out: &Path,
    options: &McapExportOptions,
) -> Result<McapExportEstimate, McapExportError> {
    // Nothing to estimate for an export that will be refused.
    check_destination(out)?;
    let content = RunContent::read(run)?;
    let counts = content.counts();
    let topics = RunTopics::new(&options.namespace, &options.frame_id)?;
    let times = content.times();
    let scratch = std::env::temp_dir().join(format!(
        "fringe-mcap-estimate-{}-{}.mcap",
        std::process::id(),
        ESTIMATE_COUNTER.fetch_add(1, Ordering::SeqCst)
    ));
    let measured = (|| -> Result<_, McapExportError> {
        // The force samples alone, then the frames: each one's bytes and time per message.
        let mut r = Recorder::create(&scratch)?;
        let mut ch = Channels::open(&mut r, &topics)?;
        let started = Instant::now();
        let n = content.force.len().min(ESTIMATE_SAMPLES);
        for (k, s) in content.force.iter().take(n).enumerate() {
            let t = times.force_unix_ns(k, s);
            r.write(&mut ch.ft, &ros_messages::ft_sample(s, t, &topics), t, t)?;
        }
        r.finish()?;
        let ft_time = started.elapsed();
        let ft_bytes = file_len(&scratch)?;
        let mut r = Recorder::create(&scratch)?;
        let mut ch = Channels::open(&mut r, &topics)?;
        let started = Instant::now();
        let total = content.records.len();
        let take = total.min(ESTIMATE_FRAMES);
        let mut sampled = 0u64;
        for j in 0..take {
            let k = j * total / take;
            let record = &content.records[k];
            let Ok(Ok(stored)) = content.reader.stored_frame(&content.storage, record) else {
                continue;
            };
            let t = times.frame_unix_ns(k, record, &content.force);
            r.write(
                &mut ch.image,
                &ros_messages::image(stored, t, &topics),
                t,
                t,
            )?;
            sampled += 1;
        }
        r.finish()?;
        let frame_time = started.elapsed();
        let frame_bytes = file_len(&scratch)?;
        Ok((n, ft_time, ft_bytes, sampled, frame_time, frame_bytes))
    })();
    let _ = std::fs::remove_file(&scratch);
    let (n, ft_time, ft_bytes, sampled, frame_time, frame_bytes) = measured?;
    let per = |total: f64, of: u64| if of == 0 { 0.0 } else { total / of as f64 };
    let bytes = per(ft_bytes as f64, n as u64) * counts.force_samples as f64
        + per(frame_bytes as f64, sampled) * counts.frames as f64
        + LABEL_BYTES * (counts.labels * 2 + counts.contacts) as f64
        + EVENT_BYTES * counts.events as f64;
    let time = per(ft_time.as_secs_f64(), n as u64) * counts.force_samples as f64
        + per(frame_time.as_secs_f64(), sampled) * counts.frames as f64;
    Ok(McapExportEstimate {
        counts,
        sampled_frames: sampled,
        bytes: bytes as u64,
        time: Duration::try_from_secs_f64(time).unwrap_or(Duration::MAX),
    })
}

/// Frames an estimate writes.
const ESTIMATE_FRAMES: usize = 5;
/// Force samples an estimate writes (two seconds at 5 kHz).
const ESTIMATE_SAMPLES: usize = 10_000;
/// Bytes of a label message in the file, about (a compressed WrenchStamped and its record).
const LABEL_BYTES: f64 = 60.0;
/// Bytes of an event in the file, about.
const EVENT_BYTES: f64 = 150.0;
/// Scratch files of estimates made at once in one process get names of their own.
static ESTIMATE_COUNTER: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);

fn file_len(path: &Path) -> Result<u64, McapExportError> {
    Ok(std::fs::metadata(path).map_err(|e| io(path, e))?.len())
}

/// Writes the run's messages to `path`, in time order across the topics: the counts, and a line
/// for each frame left out (with `allow_unverified`).
fn write_run(
    content: &RunContent,
    path: &Path,
    topics: &RunTopics,
    options: &McapExportOptions,
    progress: &mut impl FnMut(McapProgress),
) -> Result<(McapCounts, Vec<String>), McapExportError> {
    let times = content.times();
    let mut r = Recorder::create(path)?;
    let mut metadata = content.metadata.clone();
    let mapping = content.clock_mapping();
    metadata.insert(
        "stamps".into(),
        match mapping.source {
            ClockSource::Events => format!(
                "Unix time of the recording host: host monotonic times plus the offset its events' wall-clock times give (within {} us; {} process(es))",
                mapping.uncertainty.as_micros(),
                mapping.processes
            ),
            ClockSource::StartDocument => "Unix time of the recording host, from the run's start time (the run has no events: to a fraction of a second)".into(),
        },
    );
    r.metadata("fringe_run", metadata)?;
    let mut ch = Channels::open(&mut r, topics)?;
    let mut counts = McapCounts::default();
    let mut left_out = Vec::new();
    let (mut next_sample, mut next_event) = (0usize, 0usize);
    let total = content.records.len() as u64;
    // Force samples and events up to `until` (Unix ns), in their order.
    let mut catch_up = |r: &mut Recorder,
                        ch: &mut Channels,
                        counts: &mut McapCounts,
                        until: u64|
     -> Result<(), McapExportError> {
        while let Some(s) = content.force.get(next_sample) {
            let t = times.force_unix_ns(next_sample, s);
            if t > until {
                break;
            }
            r.write(&mut ch.ft, &ros_messages::ft_sample(s, t, topics), t, t)?;
            counts.force_samples += 1;
            next_sample += 1;
        }
        while let Some(e) = content.events.get(next_event) {
            let t = times.event_unix_ns(next_event, e);
            if t > until {
                break;
            }
            r.write(&mut ch.events, &ros_messages::event(e, t), t, t)?;
            counts.events += 1;
            next_event += 1;
        }
        Ok(())
    };
    for (k, record) in content.records.iter().enumerate() {
        if options.cancel.is_some_and(|c| c.load(Ordering::SeqCst)) {
            return Err(McapExportError::Interrupted {
                path: path.to_path_buf(),
            });
        }
        let t = times.frame_unix_ns(k, record, &content.force);
        catch_up(&mut r, &mut ch, &mut counts, t)?;
        match content.reader.stored_frame(&content.storage, record)? {
            Ok(stored) => {
                r.write(&mut ch.image, &ros_messages::image(stored, t, topics), t, t)?;
                counts.frames += 1;
            }
            Err(reason) if options.allow_unverified => left_out.push(format!(
                "{}: {reason} (frame of record {}): left out of the export",
                record.file, record.index
            )),
            Err(reason) => {
                return Err(McapExportError::Frame {
                    run: content.reader.dir().to_path_buf(),
                    path: content.reader.frame_path(record),
                    index: record.index,
                    reason,
                })
            }
        }
        if let Some(label) = ros_messages::label(record, t, topics) {
            r.write(&mut ch.wrench, &label.wrench, t, t)?;
            if let Some(c) = &label.contact {
                r.write(&mut ch.contact, c, t, t)?;
                counts.contacts += 1;
            }
            r.write(&mut ch.shape, &label.shape, t, t)?;
            counts.labels += 1;
        }
        progress(McapProgress {
            frames: k as u64 + 1,
            of: total,
        });
    }
    catch_up(&mut r, &mut ch, &mut counts, u64::MAX)?;
    r.finish()?;
    Ok((counts, left_out))
}

/// Refuses a destination that exists, is no file name or lies in a run; returns the directory
/// it is made in and the partial file beside it.
fn check_destination(out: &Path) -> Result<(PathBuf, PathBuf), McapExportError> {
    let name = match out.components().next_back() {
        Some(Component::Normal(name)) => name.to_string_lossy().into_owned(),
        _ => {
            return Err(McapExportError::NotAFile {
                path: out.to_path_buf(),
            })
        }
    };
    if out.symlink_metadata().is_ok() {
        return Err(McapExportError::Exists {
            path: out.to_path_buf(),
        });
    }
    outside_runs(out).map_err(StoreError::from)?;
    let parent = match out.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let staging = parent.join(format!(".{name}.partial-{}", std::process::id()));
    Ok((parent, staging))
}

#[cfg(test)]
mod tests {
    use super::*;
    use fringe_rig::store::{
        now_utc, ExitStatus, Exposure, Position, RunWriter, StartDocument, StopDocument,
        LAYOUT_VERSION,
    };
    use fringe_rig::{Frame, HostTime, Millimetres, Newtons, PixelFormat, Wrench};
    use std::io::Write;

    /// Unix ns of 2026-12-06T10:00:00.000Z, the first process's host time zero.
    const T1: i64 = 1_796_551_200_000_000_000;
    /// The second process's, an hour later.
    const T2: i64 = T1 + 3_600_000_000_000;

    fn utc(unix: i64) -> String {
        let secs = unix / 1_000_000_000;
        let ms = unix % 1_000_000_000 / 1_000_000;
        let rem = secs % 86_400;
        format!(
            "{}T{:02}:{:02}:{:02}.{ms:03}Z",
            fringe_rig::store::utc_date(secs / 86_400),
            rem / 3600,
            rem / 60 % 60,
            rem % 60
        )
    }

    /// A run written by two processes (a resume): frames at host 5 s and 6 s, then, after the
    /// host clock started again, at 2 s and 3 s; force samples and events likewise, each event
    /// with the UTC time its process's clock gives.
    fn resumed_run(root: &Path) -> PathBuf {
        let start = StartDocument {
            layout_version: LAYOUT_VERSION,
            run_id: "resumed".into(),
            started_utc: utc(T1),
            software: "test".into(),
            sensor_id: "s1".into(),
            variant: None,
            plan: String::new(),
            rig: String::new(),
            calibration_profile: None,
            seed: None,
            ft_axes: None,
            sync_method: "host".into(),
            frames: Some(FrameStorage::new(PixelFormat::Mono8, None).expect("storage")),
        };
        let mut w = RunWriter::create(root, &start).expect("run");
        let p = Position {
            x: Millimetres(0.0),
            y: Millimetres(0.0),
            z: Millimetres(0.0),
        };
        let samples = |hosts: std::ops::Range<u64>| -> Vec<ForceSample> {
            hosts
                .map(|k| ForceSample {
                    device_tick: k,
                    transport_seq: None,
                    host_time: HostTime(k * 1_000_000_000),
                    wrench: Wrench {
                        fz: Newtons(-(k as f64)),
                        ..Wrench::default()
                    },
                    status: 0,
                    strobe: None,
                })
                .collect()
        };
        w.append_force(&samples(4..8)).expect("force");
        w.append_force(&samples(1..5)).expect("force");
        for (index, host_s) in [5u64, 6, 2, 3].into_iter().enumerate() {
            let index = index as u64;
            let arrival = host_s * 1_000_000_000;
            let frame = Frame {
                id: index,
                device_timestamp: index,
                host_arrival: HostTime(arrival),
                width: 2,
                height: 2,
                format: PixelFormat::Mono8,
                data: vec![index as u8; 4],
            };
            let file = w.save_frame_image(&frame, index).expect("frame");
            w.append_frame(&FrameRecord {
                index,
                frame_id: index,
                file,
                device_timestamp: index,
                host_arrival_ns: arrival,
                exposure: Some(Exposure {
                    start_ns: arrival as f64 - 3e6,
                    end_ns: arrival as f64 - 1e6,
                    error_ns: 0.0,
                }),
                exposure_ticks: None,
                point: index,
                commanded: p,
                measured: p,
                wrench: Some(Wrench::default()),
                shear: None,
                shape: "None".into(),
                contact: None,
                valid: true,
                notes: vec![],
            })
            .expect("record");
        }
        let dir = w.dir().to_path_buf();
        let mut events = std::fs::OpenOptions::new()
            .append(true)
            .open(dir.join("events.jsonl"))
            .expect("events");
        for (host_s, epoch) in [(4i64, T1), (7, T1), (1, T2), (4, T2)] {
            let host = host_s * 1_000_000_000;
            let e = Event {
                host_ns: host as u64,
                utc: utc(epoch + host),
                kind: "point-done".into(),
                point: None,
                message: String::new(),
            };
            writeln!(events, "{}", serde_json::to_string(&e).expect("json")).expect("event");
        }
        drop(events);
        w.finish(&StopDocument {
            exit_status: ExitStatus::Completed,
            reason: "done".into(),
            stopped_utc: now_utc(),
            frames: 4,
            dropped_frames: 0,
            force_samples: 8,
            lost_force_samples: 0,
            points_done: 4,
            sync_method: Some("host".into()),
            sync_error_ns: None,
        })
        .expect("finish");
        dir
    }

    fn scratch(name: &str) -> PathBuf {
        let dir =
            std::env::temp_dir().join(format!("fringe-app-mcap-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).expect("scratch");
        dir
    }

    /// Each process of a resumed run keeps its own offset: the frames, the samples and the events
    /// written after the resume an hour later, though their host times are smaller.
    #[test]
    fn a_resumed_run_s_processes_each_map_to_their_own_unix_time() {
        let dir = scratch("resumed");
        let run = resumed_run(&dir.join("runs"));
        let out = dir.join("run.mcap");
        let summary =
            export_mcap(&run, &out, &McapExportOptions::default(), |_| {}).expect("export");
        assert_eq!(summary.clock.processes, 2);
        assert_eq!(summary.clock.source, ClockSource::Events);
        assert_eq!(
            summary.counts,
            McapCounts {
                frames: 4,
                force_samples: 8,
                labels: 4,
                contacts: 0,
                events: 4,
            }
        );
        let bytes = std::fs::read(&out).expect("the file");
        let mut times: BTreeMap<String, Vec<i64>> = BTreeMap::new();
        for m in mcap::MessageStream::new(&bytes).expect("mcap") {
            let m = m.expect("a message");
            times
                .entry(m.channel.topic.clone())
                .or_default()
                .push(m.log_time as i64);
        }
        // Every event's window holds the offset exactly: its middle is half a millisecond on.
        let half = 500_000;
        let frame = |epoch: i64, s: i64| epoch + s * 1_000_000_000 - 2_000_000 + half;
        assert_eq!(
            times["/fringe/image"],
            [frame(T1, 5), frame(T1, 6), frame(T2, 2), frame(T2, 3)]
        );
        assert_eq!(times["/fringe/wrench"], times["/fringe/image"]);
        let at = |epoch: i64, s: i64| epoch + s * 1_000_000_000 + half;
        let mut ft: Vec<i64> = (4..8).map(|s| at(T1, s)).collect();
        ft.extend((1..5).map(|s| at(T2, s)));
        assert_eq!(times["/fringe/ft"], ft);
        assert_eq!(
            times["/fringe/events"],
            [at(T1, 4), at(T1, 7), at(T2, 1), at(T2, 4)]
        );
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// A signal during the export: an error, no file at the destination, no partial file beside.
    #[test]
    fn an_interrupted_export_leaves_nothing() {
        static STOP: AtomicBool = AtomicBool::new(true);
        let dir = scratch("interrupted");
        let run = resumed_run(&dir.join("runs"));
        let out = dir.join("run.mcap");
        let options = McapExportOptions {
            cancel: Some(&STOP),
            ..McapExportOptions::default()
        };
        let err = export_mcap(&run, &out, &options, |_| {}).expect_err("interrupted");
        assert!(matches!(err, McapExportError::Interrupted { .. }), "{err}");
        let left: Vec<String> = std::fs::read_dir(&dir)
            .expect("dir")
            .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
            .collect();
        assert_eq!(left, ["runs"]);
        let _ = std::fs::remove_dir_all(&dir);
    }
}
