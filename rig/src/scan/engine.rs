//! The scan engine: runs a scan program on a bench and writes the run.
//!
//! Threads: the force stream and the camera stream read their devices; the recorder labels and
//! writes; the watchers check force, stream and camera every 2 ms; this thread moves the axes.
//! Per point: checkpoint (everything before is durable; a crash resumes here), operator prompts
//! (indenter change, manual y row), force offset re-measured at the safe height, lateral move,
//! approach to first contact, the indentation profile (force targets on the F/T reading or depth
//! targets) with a dwell at each target, retract. The camera is filmed from the approach to the
//! end of the retract. A point interrupted (pause now, watcher) is cut back to its checkpoint and
//! done again, so no point is lost or recorded twice; the same holds after a crash.

use super::clearance::{Clearance, Motion, UnderLoad, LOAD_SAMPLES};
use super::control::{Operator, Phase, Prompt, Reply, Request, ScanControl, ScanProgress, Status};
use super::failure::ScanError;
use super::offset_check::OffsetCheck;
use super::origin::ContactOrigin;
use super::plan::{BenchLimits, ScanPoint, ScanProgram, Targets};
use super::press::{approach, press_to, ForceGuard, PressError, PressSettings};
use super::watchers::{Alarm, SharedTare, WatchSettings, Watchers};
use crate::acquire::camera_stream::CameraStream;
use crate::acquire::clock_fit_labeler::{ClockFitLabeler, ClockFitOptions};
use crate::acquire::force_stream::{ForceMonitor, ForceStream};
use crate::acquire::host_labeler::HostLabeler;
use crate::acquire::labeler::FrameLabeler;
use crate::acquire::record_tap::RecordTap;
use crate::acquire::recorder::{
    Filming, FrameContext, PendingCheckpoint, Recorder, RecorderFailure, RecorderStats,
};
use crate::acquire::strobe_labeler::StrobeLabeler;
use crate::axis::{Axis, AxisError, AxisStatus, StopMode};
use crate::camera::{Camera, CameraSettings, Cutout};
use crate::clock::HostTime;
use crate::devices::Devices;
use crate::force::ForceSensor;
use crate::scan::sidecar::RunSidecar;
use crate::store::documents::{
    now_utc, ExitStatus, Position, ProfileRef, StartDocument, StopDocument, LAYOUT_VERSION,
};
use crate::store::error::StoreError;
use crate::store::frames::{FrameCodec, FrameStorage};
use crate::store::run_lock::RunLock;
use crate::store::run_writer::RunWriter;
use crate::sync::method::SyncMethod;
use crate::sync::trigger::TriggerTiming;
use crate::units::{Millimetres, Newtons};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// Everything a scan needs besides the devices.
#[derive(Debug, Clone)]
pub struct ScanSetup {
    pub program: ScanProgram,
    /// The plan file's text, stored in the run (and compared on resume).
    pub plan_text: String,
    pub limits: BenchLimits,
    pub origin: ContactOrigin,
    pub sync: SyncMethod,
    /// The DAQ-triggered camera's timing, for `trigger`.
    pub trigger: Option<TriggerTiming>,
    pub sensor_id: String,
    /// The sensor's design (`layered`, `integrated`), when the rig names or simulates it.
    pub variant: Option<String>,
    /// The rig configuration as used, for the start document.
    pub rig_text: String,
    pub seed: Option<u64>,
    pub profile: Option<ProfileRef>,
    pub camera: CameraSettings,
    /// The part of each frame a new run stores (the square around the disc); `None`: whole
    /// frames. A resumed run stores what it stored before.
    pub cutout: Option<Cutout>,
    /// The codec a new run stores frames in (`None`: the default for the camera's pixel
    /// format). A resumed run stores as it stored before.
    pub codec: Option<FrameCodec>,
    /// Press tuning; the contact threshold, ceiling and approach limit are set from the plan and
    /// the bench.
    pub press: PressSettings,
    pub watch: WatchSettings,
    /// Files the caller adds to the run when it closes (the simulated bench's ground truth).
    pub sidecars: Vec<Arc<dyn RunSidecar>>,
    /// The zero-load check of the sensor's profile, made on the first offset measurement of
    /// each session (new run or resume).
    pub offset_check: Option<Arc<dyn OffsetCheck>>,
    /// What the caller sees of the recording as it happens (live display, live validation).
    pub taps: Vec<Arc<dyn RecordTap>>,
}

/// Where the run goes.
#[derive(Debug)]
pub enum RunTarget {
    /// A new run directory `root/<run_id>`.
    New { root: PathBuf, run_id: String },
    /// Continue an unfinished run after a crash or power loss. `held`: the run taken for
    /// writing before the rig was opened ([`RunTarget::resume`]), so that a second writer
    /// opens no device; `None`: it is taken when the run is reopened.
    Resume { dir: PathBuf, held: Option<RunLock> },
}

impl RunTarget {
    /// The resume of the run in `dir`, taken for writing now: call it before opening the rig.
    /// Refused while another process writes the run (the refusal names it) and for a directory
    /// that is not a run.
    pub fn resume(dir: &Path) -> Result<RunTarget, StoreError> {
        let lock = RunWriter::lock_for_reopen(dir)?;
        Ok(RunTarget::Resume {
            dir: dir.to_path_buf(),
            held: Some(lock),
        })
    }

    /// The run's directory.
    pub fn dir(&self) -> PathBuf {
        match self {
            RunTarget::New { root, run_id } => root.join(run_id),
            RunTarget::Resume { dir, .. } => dir.clone(),
        }
    }

    /// The run's id: the name of its directory.
    pub fn run_id(&self) -> String {
        match self {
            RunTarget::New { run_id, .. } => run_id.clone(),
            RunTarget::Resume { dir, .. } => dir
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default(),
        }
    }
}

/// How a scan ended.
#[derive(Debug, Clone, PartialEq)]
pub struct ScanOutcome {
    pub run_dir: PathBuf,
    pub status: ExitStatus,
    pub reason: String,
    pub points_done: u64,
    pub points_total: u64,
    pub frames: u64,
    pub dropped_frames: u64,
    pub force_samples: u64,
    pub lost_force_samples: u64,
    /// Frame records cut because their point was interrupted and done again.
    pub frames_discarded: u64,
    /// Software overhead per finished point (everything but motion, settling, dwell and operator
    /// prompts): mean and max, ms.
    pub overhead_mean_ms: f64,
    pub overhead_max_ms: f64,
}

/// How a point ended.
enum PointEnd {
    Done,
    /// Stopped by a request or a watcher (the point is done again after a pause).
    Interrupted(Alarm),
    /// The indenter found no contact before the approach limit: recorded and skipped.
    NoContact(String),
}

const MOVE_TIMEOUT: Duration = Duration::from_secs(120);
const POLL: Duration = Duration::from_millis(5);

/// How often the camera clock is latched (on the camera stream thread), for the methods that
/// place frames by clock (`strobe` to pick each frame's window, `clock-fit` for the window).
pub const LATCH_PERIOD: Duration = Duration::from_millis(250);

/// Exposure end to frame arrival assumed by `strobe` for a camera that gives no timestamp
/// latches (sensor readout and transfer of a USB3 camera: a few ms).
pub const ASSUMED_READOUT: Duration = Duration::from_millis(5);

/// Strobe level of the ExposureActive channel, V (half the 3.3 V logic level).
pub const STROBE_THRESHOLD_V: f64 = 1.65;

/// The labeler of synchronisation method `sync` for a camera with `settings` whose timestamps
/// tick at `tick_hz`, taking latches from `cameras` (started with
/// [`CameraStream::spawn_with_latches`]) for `strobe`, `trigger` and `clock-fit`; `trigger`
/// needs the DAQ-triggered camera's timing.
pub fn labeler_for(
    sync: SyncMethod,
    trigger: Option<TriggerTiming>,
    settings: &CameraSettings,
    tick_hz: f64,
    cameras: &CameraStream,
) -> Result<Box<dyn FrameLabeler>, ScanError> {
    Ok(match sync {
        SyncMethod::Strobe => {
            let mut options = ClockFitOptions::new(settings.exposure, tick_hz);
            options.assumed_readout = ASSUMED_READOUT;
            Box::new(StrobeLabeler::new(
                STROBE_THRESHOLD_V,
                options,
                Some(cameras.subscribe_latches()),
            ))
        }
        SyncMethod::ClockFit => Box::new(ClockFitLabeler::new(
            ClockFitOptions::new(settings.exposure, tick_hz),
            Some(cameras.subscribe_latches()),
        )),
        SyncMethod::Trigger => {
            let timing = trigger.ok_or_else(|| {
                ScanError::Setup(
                    "sync \"trigger\" needs the camera triggered by the DAQ ([camera] trigger = \"daq\")"
                        .into(),
                )
            })?;
            let mut options = ClockFitOptions::new(settings.exposure, tick_hz);
            options.assumed_readout = ASSUMED_READOUT;
            Box::new(StrobeLabeler::triggered(
                timing,
                STROBE_THRESHOLD_V,
                options,
                Some(cameras.subscribe_latches()),
            ))
        }
        SyncMethod::Host => Box::new(HostLabeler::new(settings.exposure)),
    })
}

/// Runs `setup.program` on `devices`.
pub fn run_scan(
    setup: &ScanSetup,
    devices: Devices,
    target: RunTarget,
    control: &ScanControl,
    operator: &mut dyn Operator,
    progress: &dyn Fn(ScanProgress),
) -> Result<ScanOutcome, ScanError> {
    let Devices {
        x,
        y,
        z,
        force,
        camera,
        description,
    } = devices;
    // A safe height at or past the sensor surface is refused before the run is touched: the
    // approach would have no way down to search, and every lateral move would drag the indenter
    // through the sensor.
    let safe_z = Millimetres(setup.program.plan.approach.safe_z);
    setup
        .limits
        .approach_limit(safe_z)
        .map_err(|e| ScanError::Setup(format!("the plan: {e}")))?;
    // Open the run first: a bad resume target must fail before anything moves.
    let opened = open_run(setup, &description, target)?;
    let run_dir = opened.writer.dir().to_path_buf();
    progress(ScanProgress::Message(format!(
        "run directory {}",
        run_dir.display()
    )));
    let bench = Bench {
        axes: Axes { x, y, z },
        force,
        camera,
    };
    // Whatever fails from here on, the run keeps what was recorded: the error says where it is
    // and how to go on.
    scan_opened_run(setup, bench, opened, control, operator, progress)
        .map_err(|e| e.stopped(&run_dir))
}

/// The devices a scan moves and films with.
struct Bench {
    axes: Axes,
    force: Box<dyn ForceSensor>,
    camera: Box<dyn Camera>,
}

/// A run opened for writing, and where the scan starts in it.
struct OpenedRun {
    writer: RunWriter,
    first_point: u64,
    /// Frame records of an unfinished point cut on reopening.
    discarded: u64,
    /// Why the run failed last time, when it had.
    failed: Option<String>,
}

/// The threads that read the devices for the whole scan.
struct Streams {
    force: ForceStream,
    cameras: CameraStream,
}

/// The scan of an opened run: the bench homed and its streams started, the points, the bench
/// left safe, the run closed.
fn scan_opened_run(
    setup: &ScanSetup,
    bench: Bench,
    opened: OpenedRun,
    control: &ScanControl,
    operator: &mut dyn Operator,
    progress: &dyn Fn(ScanProgress),
) -> Result<ScanOutcome, ScanError> {
    let Bench {
        mut axes,
        force,
        camera,
    } = bench;
    let safe_z = Millimetres(setup.program.plan.approach.safe_z);
    home(&mut axes, setup, progress)?;
    let run_dir = opened.writer.dir().to_path_buf();
    let (streams, recorder, context) = start_recording(setup, force, camera, opened.writer)?;
    if opened.discarded > 0 || opened.first_point > 0 || opened.failed.is_some() {
        let after = opened
            .failed
            .map(|why| format!(" (the run had failed: {why})"))
            .unwrap_or_default();
        recorder.event(
            "resume-run",
            Some(opened.first_point),
            &format!(
                "resumed at point {}; {} frame records of the unfinished point cut{after}",
                opened.first_point, opened.discarded
            ),
        );
    }
    let mut run = Runner::start(
        setup,
        control,
        progress,
        RunnerParts {
            run_dir,
            axes,
            monitor: streams.force.monitor(),
            recorder,
            context,
            safe_z,
            first_point: opened.first_point,
            discarded: opened.discarded,
        },
    )?;
    // z goes down to the safe height only once the F/T's no-contact reading is known (z homed),
    // watching for a load on the way.
    let result = run
        .descend_to_safe_height()
        .and_then(|()| run.points(opened.first_point, operator));
    // Cleanup whatever happened: z up, everything stopped, streams closed, run closed.
    run.leave_bench_safe();
    run.context.set(None);
    if let Some(why) = streams.cameras.latch_error() {
        run.recorder.event(
            "sync",
            None,
            &format!("the camera clock could not be latched, clock-fit labels used the frame arrivals only: {why}"),
        );
    }
    close_run(run, streams, result)
}

/// Homes z (away from the sensor), then x and, unless it is moved by hand, y, with z still at
/// home: nothing moves laterally before the F/T has shown that nothing touches the indenter.
fn home(
    axes: &mut Axes,
    setup: &ScanSetup,
    progress: &dyn Fn(ScanProgress),
) -> Result<(), ScanError> {
    progress(ScanProgress::Message("homing x, y and z".into()));
    axes.z.begin_home()?;
    axes.z.wait_idle(MOVE_TIMEOUT)?;
    axes.x.begin_home()?;
    if !setup.limits.manual_y {
        axes.y.begin_home()?;
        axes.y.wait_idle(MOVE_TIMEOUT)?;
    }
    axes.x.wait_idle(MOVE_TIMEOUT)?;
    Ok(())
}

/// Starts the force and camera streams and the recorder that labels and writes their frames
/// into `writer`'s run.
fn start_recording(
    setup: &ScanSetup,
    force: Box<dyn ForceSensor>,
    camera: Box<dyn Camera>,
    writer: RunWriter,
) -> Result<(Streams, Recorder, FrameContext), ScanError> {
    // The camera delivers the pixel format the run stores: a resumed run's, not today's default.
    let settings = CameraSettings {
        pixel_format: writer.frame_storage().pixel_format,
        ..setup.camera.clone()
    };
    let stream = ForceStream::spawn(force)?;
    let tick_hz = camera.info().tick_frequency as f64;
    let cameras = match setup.sync {
        SyncMethod::ClockFit | SyncMethod::Strobe | SyncMethod::Trigger => {
            CameraStream::spawn_with_latches(camera, &settings, LATCH_PERIOD)?
        }
        SyncMethod::Host => CameraStream::spawn(camera, &settings)?,
    };
    let context = FrameContext::default();
    let labeler = labeler_for(setup.sync, setup.trigger, &settings, tick_hz, &cameras)?;
    let recorder = Recorder::spawn(
        writer,
        stream.samples().clone(),
        cameras.frames().clone(),
        labeler,
        context.clone(),
        setup.taps.clone(),
    )?;
    if let Some(refused) = stream.priority_refused() {
        // Not an error: most machines keep the pace without it. The run says so, for when
        // the watchers stop it for F/T silence.
        recorder.event("priority", None, &refused.to_string());
    }
    let streams = Streams {
        force: stream,
        cameras,
    };
    Ok((streams, recorder, context))
}

/// Stops the recorder: its run writer and counts, with the error that stopped it early (its
/// unfinished point's records then cut, so that a full disk gets back the space of their images,
/// enough to close the run).
fn finish_recorder(
    recorder: Recorder,
) -> Result<(RunWriter, RecorderStats, Option<StoreError>), ScanError> {
    let last_counts = recorder.stats();
    match recorder.finish() {
        Ok((writer, counts)) => Ok((writer, counts, None)),
        Err(RecorderFailure {
            error,
            writer: Some(writer),
        }) => {
            let mut writer = *writer;
            let _ = writer.rollback();
            Ok((writer, last_counts, Some(error)))
        }
        Err(RecorderFailure {
            error,
            writer: None,
        }) => Err(error.into()),
    }
}

/// Stops the streams and the recorder and closes the run with its stop document: the run's
/// outcome, or the first error among the points', the recorder's, the streams'.
fn close_run(
    run: Runner<'_>,
    streams: Streams,
    result: Result<Ending, ScanError>,
) -> Result<ScanOutcome, ScanError> {
    let (status, reason) = run.record_stop(&result);
    let Runner {
        setup,
        recorder,
        watchers,
        points_done,
        frames_discarded,
        overheads,
        ..
    } = run;
    let ms = |d: &Duration| d.as_secs_f64() * 1e3;
    let overhead_mean_ms = overheads.iter().map(ms).sum::<f64>() / overheads.len().max(1) as f64;
    let overhead_max_ms = overheads.iter().map(ms).fold(0.0, f64::max);
    drop(watchers);
    let camera_result = streams.cameras.stop();
    let stats = streams.force.monitor().stats();
    let force_result = streams.force.stop();
    let (writer, counts, recorder_error) = finish_recorder(recorder)?;
    let (status, reason) = match &recorder_error {
        Some(e) => (ExitStatus::Failed, e.to_string()),
        None => (status, reason),
    };
    let frames = writer.next_index();
    let force_samples = writer.force_samples();
    let stop = StopDocument {
        exit_status: status,
        reason: reason.clone(),
        stopped_utc: now_utc(),
        frames,
        dropped_frames: counts.dropped_frames,
        force_samples,
        lost_force_samples: stats.lost,
        points_done,
        sync_method: Some(setup.sync.name().into()),
        sync_error_ns: counts.sync_error_ns,
    };
    for sidecar in &setup.sidecars {
        append_sidecar(writer.dir(), sidecar.as_ref(), true)?;
    }
    let run_dir = writer.finish(&stop)?;
    if let Some(e) = recorder_error {
        return Err(e.into());
    }
    result?;
    camera_result?;
    force_result?;
    Ok(ScanOutcome {
        run_dir,
        status,
        reason,
        points_done,
        points_total: setup.program.points.len() as u64,
        frames,
        dropped_frames: counts.dropped_frames,
        force_samples,
        lost_force_samples: stats.lost,
        frames_discarded,
        overhead_mean_ms,
        overhead_max_ms,
    })
}

/// Appends the lines a sidecar gathered since it was last taken to its file in the run; `sync`
/// makes them durable (when the run closes; after a point they reach the OS only, a crash of the
/// process loses nothing of them).
fn append_sidecar(dir: &Path, sidecar: &dyn RunSidecar, sync: bool) -> Result<(), StoreError> {
    use std::io::Write;
    let path = dir.join(sidecar.file_name());
    let mut lines = String::new();
    for line in sidecar.take_lines() {
        lines.push_str(&line);
        lines.push('\n');
    }
    if lines.is_empty() && !sync {
        return Ok(());
    }
    let mut file = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(&path)
        .map_err(|e| StoreError::Io {
            path: path.clone(),
            source: e,
        })?;
    file.write_all(lines.as_bytes())
        .and_then(|_| if sync { file.sync_all() } else { Ok(()) })
        .map_err(|e| StoreError::Io { path, source: e })
}

fn open_run(
    setup: &ScanSetup,
    description: &[String],
    target: RunTarget,
) -> Result<OpenedRun, ScanError> {
    match target {
        RunTarget::New { root, run_id } => {
            let start = StartDocument {
                layout_version: LAYOUT_VERSION,
                run_id: run_id.clone(),
                started_utc: now_utc(),
                software: format!("fringe {}", env!("CARGO_PKG_VERSION")),
                sensor_id: setup.sensor_id.clone(),
                variant: setup.variant.clone(),
                plan: setup.plan_text.clone(),
                rig: format!(
                    "{}\n# devices:\n# {}",
                    setup.rig_text,
                    description.join("\n# ")
                ),
                calibration_profile: setup.profile.clone(),
                seed: setup.seed,
                sync_method: setup.sync.name().into(),
                frames: Some(
                    FrameStorage::new(setup.camera.pixel_format, setup.cutout)
                        .and_then(|s| s.with_codec(setup.codec))
                        .map_err(|e| ScanError::Setup(format!("storing frames: {e}")))?,
                ),
            };
            Ok(OpenedRun {
                writer: RunWriter::create(&root, &start)?,
                first_point: 0,
                discarded: 0,
                failed: None,
            })
        }
        RunTarget::Resume { dir, held } => {
            let lock = match held {
                Some(lock) => lock,
                None => RunWriter::lock_for_reopen(&dir)?,
            };
            // Everything is checked before the run is touched: a refused resume changes nothing.
            let (writer, existing) =
                RunWriter::reopen_held(&dir, lock, |existing| match super::resume_check::refusal(
                    &dir.display().to_string(),
                    &existing.start,
                    &setup.plan_text,
                    setup.sync.name(),
                    &setup.sensor_id,
                    &setup.rig_text,
                ) {
                    Some(why) => Err(ScanError::Setup(why)),
                    None => Ok(()),
                })?;
            Ok(OpenedRun {
                writer,
                first_point: existing.checkpoint.as_ref().map_or(0, |c| c.next_point),
                discarded: existing.discarded_frames,
                failed: existing.failed_stop.map(|s| s.reason),
            })
        }
    }
}

/// Waits up to one poll period for `axis` to finish its move: its status when it has.
fn settled(axis: &mut dyn Axis) -> Result<Option<AxisStatus>, AxisError> {
    match axis.wait_idle(POLL) {
        Ok(status) => Ok(Some(status)),
        Err(AxisError::Timeout { .. }) => Ok(None),
        Err(e) => Err(e),
    }
}

/// How the lateral move before a point ended.
enum Lateral {
    /// Both axes at rest, at these positions.
    AtRest {
        x: Millimetres,
        y: Millimetres,
    },
    Interrupted(Alarm),
}

struct Axes {
    x: Box<dyn Axis>,
    y: Box<dyn Axis>,
    z: Box<dyn Axis>,
}

impl Drop for Axes {
    /// A panic while the scan holds the axes stops them where they are.
    fn drop(&mut self) {
        super::panic_stop::stop_if_panicking([self.z.as_mut(), self.x.as_mut(), self.y.as_mut()]);
    }
}

/// A point the watchers interrupt this many times in a row ends the scan (a condition that
/// resuming does not clear, such as a camera that cannot keep up, would otherwise repeat it for
/// ever under `--yes`).
const MAX_WATCHER_RETRIES: u32 = 3;

/// Longest wait for the recorder to make a checkpoint.
const CHECKPOINT_TIMEOUT: Duration = Duration::from_secs(10);

/// Force samples averaged for the no-contact offset before every point (0.1 s at 5 kHz).
const TARE_SAMPLES: usize = 500;
/// Longest wait for fresh samples to tare from after an interruption.
const FRESH_TARE_TIMEOUT: Duration = Duration::from_secs(5);

enum Ending {
    Completed,
    Aborted(String),
}

struct Runner<'a> {
    setup: &'a ScanSetup,
    /// The run's directory (sidecars are appended to their files in it after every point).
    run_dir: PathBuf,
    axes: Axes,
    monitor: ForceMonitor,
    recorder: Recorder,
    context: FrameContext,
    watchers: Watchers,
    cancel: Arc<AtomicBool>,
    tare: SharedTare,
    press: PressSettings,
    control: &'a ScanControl,
    progress: &'a dyn Fn(ScanProgress),
    safe_z: Millimetres,
    points_done: u64,
    started: Instant,
    done_this_session: u64,
    /// The point the watchers interrupted last and how many times in a row.
    watcher_retries: (u64, u32),
    /// The zero-load check has been made this session.
    offset_checked: bool,
    /// Restarts of the F/T device already reported.
    force_restarts_seen: u64,
    /// After an interruption: the next tare takes only samples that arrived after this (the
    /// samples before it may be from under load, or from before the stream stalled or the
    /// device restarted with another zero).
    tare_not_before: Option<HostTime>,
    last_status: Instant,
    /// The indenter the operator last confirmed.
    mounted: Option<String>,
    /// Where the operator last set a y stage moved by hand.
    manual_y_at: Option<Millimetres>,
    /// The F/T's no-contact reading, which tells a load at the safe height.
    clearance: Clearance,
    frames_discarded: u64,
    /// Time of the current point spent moving, settling, dwelling or waiting for the operator
    /// (everything that is not software overhead).
    excluded: Duration,
    /// Software overhead of each finished point.
    overheads: Vec<Duration>,
    /// The checkpoint of the current point, made while the axes move to it.
    pending_checkpoint: Option<PendingCheckpoint>,
}

/// What a runner starts with, besides the setup, control and progress it borrows.
struct RunnerParts {
    run_dir: PathBuf,
    axes: Axes,
    monitor: ForceMonitor,
    recorder: Recorder,
    context: FrameContext,
    safe_z: Millimetres,
    first_point: u64,
    discarded: u64,
}

impl<'a> Runner<'a> {
    /// The runner of a scan whose streams and recorder run: the press settings from the plan,
    /// the watchers started, the force stream waited for.
    fn start(
        setup: &'a ScanSetup,
        control: &'a ScanControl,
        progress: &'a dyn Fn(ScanProgress),
        parts: RunnerParts,
    ) -> Result<Runner<'a>, ScanError> {
        let cancel = Arc::new(AtomicBool::new(false));
        let tare = SharedTare::default();
        let mut press = setup.press.clone();
        press.ceiling = Newtons(setup.program.plan.safety.force_ceiling);
        press.contact_threshold = Newtons(setup.program.plan.approach.contact_threshold);
        press.approach_limit = setup
            .limits
            .approach_limit(parts.safe_z)
            .map_err(|e| ScanError::Setup(format!("the plan: {e}")))?;
        let watch = WatchSettings {
            ceiling: press.ceiling,
            ..setup.watch.clone()
        };
        let watchers = Watchers::spawn(
            parts.monitor.clone(),
            Box::new(parts.recorder.stats_source()),
            control.clone(),
            tare.clone(),
            watch,
            cancel.clone(),
        );
        if !watchers.running() {
            return Err(ScanError::Setup("cannot start the watcher thread".into()));
        }
        // Wait for the force stream before the first reading.
        let started = Instant::now();
        while parts.monitor.stats().received < 500 && started.elapsed() < Duration::from_secs(3) {
            std::thread::sleep(Duration::from_millis(10));
        }
        // z is homed, away from the sensor: what the F/T reads now is no contact.
        let (_, homed) = parts.monitor.mean_of_last(TARE_SAMPLES).ok_or_else(|| {
            ScanError::Setup(format!("{}: no force samples", parts.monitor.device()))
        })?;
        tare.set(homed[2]);
        let clearance = Clearance::new(
            homed[2],
            parts.monitor.stats().restarts,
            "with z homed".into(),
            press.contact_threshold,
        );
        Ok(Runner {
            setup,
            run_dir: parts.run_dir,
            axes: parts.axes,
            monitor: parts.monitor,
            recorder: parts.recorder,
            context: parts.context,
            watchers,
            cancel,
            tare,
            press,
            control,
            progress,
            safe_z: parts.safe_z,
            points_done: parts.first_point,
            started: Instant::now(),
            done_this_session: 0,
            watcher_retries: (0, 0),
            offset_checked: false,
            force_restarts_seen: 0,
            tare_not_before: None,
            pending_checkpoint: None,
            last_status: Instant::now(),
            mounted: None,
            manual_y_at: None,
            clearance,
            frames_discarded: parts.discarded,
            excluded: Duration::ZERO,
            overheads: Vec::new(),
        })
    }

    /// How the scan ended, as the stop document says it, recorded among the run's events.
    fn record_stop(&self, result: &Result<Ending, ScanError>) -> (ExitStatus, String) {
        let (status, reason) = match result {
            Ok(Ending::Completed) => (ExitStatus::Completed, "all points done".to_string()),
            // Not the operator's decision: closed as a failed run is, which a resume reopens.
            Ok(Ending::Aborted(_)) if self.control.interrupted() => (
                ExitStatus::Failed,
                "interrupted, not aborted (a stop that keeps the run, a hung-up terminal, SIGHUP or SIGTERM); resume the run to go on".to_string(),
            ),
            Ok(Ending::Aborted(why)) => (ExitStatus::Aborted, why.clone()),
            Err(e) => (ExitStatus::Failed, e.to_string()),
        };
        self.recorder.event(
            "stop",
            Some(self.points_done),
            &format!("{status:?}: {reason}"),
        );
        (status, reason)
    }

    /// Leaves the bench safe whatever happened (z retracted, x and y stopped) and records the
    /// state it is left in among the run's events: what a user reads after a failure (was z
    /// lifted off the sensor, did x and y stop).
    fn leave_bench_safe(&mut self) {
        let mut end_state = vec![match self.retract() {
            Ok(()) => format!("z retracted to {:.3} mm", self.safe_z.0),
            Err(e) => format!("z NOT retracted ({e})"),
        }];
        // A y stage moved by hand has nothing to stop (and asking it its position would prompt).
        let manual_y = self.setup.limits.manual_y;
        for (name, axis) in [("x", &mut self.axes.x), ("y", &mut self.axes.y)] {
            if name == "y" && manual_y {
                continue;
            }
            end_state.push(match axis.status() {
                Ok(s) if s.moving => {
                    let stopped = axis
                        .stop(StopMode::Profiled)
                        .and_then(|_| axis.wait_idle(MOVE_TIMEOUT));
                    match stopped {
                        Ok(_) => format!("{name} stopped"),
                        Err(e) => format!("{name} NOT stopped ({e})"),
                    }
                }
                Ok(s) => format!("{name} at rest at {:.3} mm", s.position.0),
                Err(e) => format!("{name} unreachable ({e})"),
            });
        }
        self.recorder
            .event("end-state", Some(self.points_done), &end_state.join("; "));
    }
}

impl Runner<'_> {
    /// Runs the program's points from `first` on, until the last is done or the scan ends.
    fn points(&mut self, first: u64, operator: &mut dyn Operator) -> Result<Ending, ScanError> {
        let points = self.setup.program.points.clone();
        let mut k = first as usize;
        let mut row_confirmed: Option<f64> = None;
        while k < points.len() {
            let p = &points[k];
            let point_started = Instant::now();
            self.excluded = Duration::ZERO;
            self.checkpoint_before(p, row_confirmed)?;
            if let Some(ending) = self.before_point(p, &mut row_confirmed, operator)? {
                return Ok(ending);
            }
            match self.point(p)? {
                PointEnd::Done => {
                    self.point_done(p, point_started.elapsed())?;
                    k += 1;
                }
                PointEnd::NoContact(why) => {
                    // The approach ended at its limit: back to the safe height before the next
                    // lateral move.
                    self.retract()?;
                    self.point_skipped(p, &why);
                    k += 1;
                }
                PointEnd::Interrupted(alarm) => {
                    if let Some(ending) = self.point_interrupted(p, alarm, operator)? {
                        return Ok(ending);
                    }
                }
            }
        }
        self.status(true);
        Ok(Ending::Completed)
    }

    /// Begins the checkpoint before point `p`: waited for here when the scan stops for the
    /// operator (pause, indenter change, manual y row), otherwise made while the axes move to
    /// the point and waited for before the point films anything.
    fn checkpoint_before(
        &mut self,
        p: &ScanPoint,
        row_confirmed: Option<f64>,
    ) -> Result<(), ScanError> {
        let stops = self.control.request() != Request::Run
            || self.mounted.as_deref() != Some(p.shape.as_str())
            || (self.setup.limits.manual_y && row_confirmed != Some(p.y.0));
        let pending = self.recorder.checkpoint_begin(p.index)?;
        if stops {
            pending.wait(CHECKPOINT_TIMEOUT)?;
        } else {
            self.pending_checkpoint = Some(pending);
        }
        Ok(())
    }

    /// Serves a pause or abort request, then asks the operator to change the indenter or move
    /// a manual y stage when point `p` needs it; `Some` ends the scan.
    fn before_point(
        &mut self,
        p: &ScanPoint,
        row_confirmed: &mut Option<f64>,
        operator: &mut dyn Operator,
    ) -> Result<Option<Ending>, ScanError> {
        match self.control.request() {
            Request::Abort => return Ok(Some(Ending::Aborted("aborted by the operator".into()))),
            Request::PauseAfterIndentation | Request::PauseNow => {
                if !self.pause("paused by the operator".into(), operator)? {
                    return Ok(Some(Ending::Aborted("aborted by the operator".into())));
                }
            }
            Request::Run => {}
        }
        if self.mounted.as_deref() != Some(p.shape.as_str()) {
            let prompt = Prompt::ChangeIndenter {
                shape: p.shape.clone(),
            };
            if !self.ask(operator, &prompt, Some(p.index)) {
                return Ok(Some(Ending::Aborted(
                    "aborted at the indenter prompt".into(),
                )));
            }
            self.mounted = Some(p.shape.clone());
        }
        if self.setup.limits.manual_y && *row_confirmed != Some(p.y.0) {
            let prompt = Prompt::MoveY { y_mm: p.y.0 };
            if !self.ask(operator, &prompt, Some(p.index)) {
                return Ok(Some(Ending::Aborted(
                    "aborted at the y stage prompt".into(),
                )));
            }
            *row_confirmed = Some(p.y.0);
            self.manual_y_at = Some(p.y);
        }
        Ok(None)
    }

    /// Records point `p` as done after `total` (its software overhead among them) and appends
    /// the sidecars.
    fn point_done(&mut self, p: &ScanPoint, total: Duration) -> Result<(), ScanError> {
        let overhead = total.saturating_sub(self.excluded);
        self.overheads.push(overhead);
        self.recorder.event(
            "point-done",
            Some(p.index),
            &format!(
                "x {:.3} mm, y {:.3} mm, {} (repetition {}) in {:.1} s, software overhead {:.1} ms",
                p.x.0,
                p.y.0,
                p.shape,
                p.repetition + 1,
                total.as_secs_f64(),
                overhead.as_secs_f64() * 1e3
            ),
        );
        self.points_done = p.index + 1;
        self.done_this_session += 1;
        for sidecar in &self.setup.sidecars {
            append_sidecar(&self.run_dir, sidecar.as_ref(), false)?;
        }
        Ok(())
    }

    /// Records point `p` as skipped for want of contact (`why`) and tells the operator.
    fn point_skipped(&mut self, p: &ScanPoint, why: &str) {
        self.recorder.event("point-skipped", Some(p.index), why);
        (self.progress)(ScanProgress::Message(format!(
            "point {}: {why}; skipped",
            p.index + 1
        )));
        self.points_done = p.index + 1;
    }

    /// After point `p` was interrupted by `alarm`: retracts, cuts its frames and pauses, so
    /// that the point is done again; `Some` ends the scan (an abort, or too many watcher
    /// interruptions of one point in a row).
    fn point_interrupted(
        &mut self,
        p: &ScanPoint,
        alarm: Alarm,
        operator: &mut dyn Operator,
    ) -> Result<Option<Ending>, ScanError> {
        self.context.set(None);
        self.watchers.set_filming(false);
        self.retract()?;
        self.tare_not_before = Some(HostTime::now());
        let cut = self.recorder.rollback(Duration::from_secs(10))?;
        self.frames_discarded += cut;
        self.recorder.event(
            "point-interrupted",
            Some(p.index),
            &format!("{alarm}; {cut} frame records cut, the point will be done again"),
        );
        if self.control.request() == Request::Abort {
            return Ok(Some(Ending::Aborted("aborted by the operator".into())));
        }
        if alarm != Alarm::Requested {
            let (point, times) = self.watcher_retries;
            let times = if point == p.index { times + 1 } else { 1 };
            self.watcher_retries = (p.index, times);
            if times >= MAX_WATCHER_RETRIES {
                return Ok(Some(Ending::Aborted(format!(
                    "point {} was interrupted {times} times in a row by the watchers (last: {alarm}); the scan stops so that the cause can be fixed (the points done are kept)",
                    p.index + 1
                ))));
            }
        }
        let reason = match alarm {
            Alarm::Requested => "paused by the operator".to_string(),
            other => other.to_string(),
        };
        if !self.pause(reason, operator)? {
            return Ok(Some(Ending::Aborted("aborted while paused".into())));
        }
        Ok(None)
    }

    fn ask(&mut self, operator: &mut dyn Operator, prompt: &Prompt, point: Option<u64>) -> bool {
        self.recorder.event("prompt", point, &prompt.message());
        let asked = Instant::now();
        let reply = operator.ask(prompt);
        self.excluded += asked.elapsed();
        self.recorder.event("reply", point, &format!("{reply:?}"));
        reply == Reply::Continue
    }

    /// Paused: waits until the watchers' condition clears, then asks the operator. False: abort.
    fn pause(&mut self, reason: String, operator: &mut dyn Operator) -> Result<bool, ScanError> {
        self.recorder
            .event("pause", Some(self.points_done), &reason);
        (self.progress)(ScanProgress::Paused {
            reason: reason.clone(),
        });
        // z is at the safe height from here on (retracted after an interruption, or between
        // points): samples from now on are of no contact.
        self.tare_not_before.get_or_insert(HostTime::now());
        let mut said = false;
        loop {
            if self.control.request() == Request::Abort {
                return Ok(false);
            }
            match self.watchers.condition() {
                Some(Alarm::Ceiling { .. }) if self.retare_after_restart() => {
                    std::thread::sleep(Duration::from_millis(50));
                }
                Some(condition) => {
                    if !said {
                        (self.progress)(ScanProgress::Message(format!(
                            "waiting for the condition to clear: {condition}"
                        )));
                        said = true;
                    }
                    std::thread::sleep(Duration::from_millis(50));
                }
                None => break,
            }
        }
        let prompt = Prompt::Resume { reason };
        if !self.ask(operator, &prompt, Some(self.points_done)) {
            return Ok(false);
        }
        self.control.resume();
        self.watchers.reset();
        self.recorder.event("resume", Some(self.points_done), "");
        (self.progress)(ScanProgress::Resumed);
        Ok(true)
    }

    fn phase(&mut self, point: u64, phase: Phase) {
        (self.progress)(ScanProgress::Phase { point, phase });
    }

    fn interrupted(&self) -> Option<Alarm> {
        if !self.cancel.load(Ordering::SeqCst) {
            return None;
        }
        Some(self.watchers.alarm().unwrap_or(Alarm::Requested))
    }

    /// Measures the no-contact offset at the safe height (every point: drift is tracked).
    fn tare(&mut self, point: u64) -> Result<[f64; 6], ScanError> {
        if let Some(after) = self.tare_not_before {
            self.wait_for_fresh_samples(after)?;
            self.tare_not_before = None;
        }
        let (_, mean) = self.monitor.mean_of_last(TARE_SAMPLES).ok_or_else(|| {
            ScanError::Setup(format!("{}: no force samples", self.monitor.device()))
        })?;
        let restarts = self.monitor.stats().restarts;
        // Never a no-contact offset under load: it would hide the load from every label and
        // from the ceiling. After a device restart its zero moved: the reading starts again here.
        let from = if self.clearance.outdated(restarts) {
            format!(
                "at the safe height before point {} (the device had restarted)",
                point + 1
            )
        } else if self.clearance.loaded(mean[2]) {
            return Err(self.under_load(Motion::Tare, mean[2]).into());
        } else {
            format!("at the tare before point {}", point + 1)
        };
        self.clearance.follow(mean[2], restarts, from);
        self.tare.set(mean[2]);
        if restarts > self.force_restarts_seen {
            self.force_restarts_seen = restarts;
            let warning = format!(
                "force sensor {}: the device restarted (its sample counter began again; {restarts} time(s) this session): a bias set in it is gone and its zero moved, which this point's tare takes out of the labels; if it happens again, check the box's power supply and cable",
                self.monitor.device()
            );
            self.recorder.event("warning", Some(point), &warning);
            (self.progress)(ScanProgress::Message(format!("warning: {warning}")));
        }
        if !self.offset_checked {
            self.offset_checked = true;
            if let Some(check) = &self.setup.offset_check {
                let (n, sd) = self.monitor.spread_of_last(TARE_SAMPLES);
                let se = sd.map(|s| s / (n.max(1) as f64).sqrt());
                for warning in check.check(mean, se) {
                    self.recorder.event("warning", Some(point), &warning);
                    (self.progress)(ScanProgress::Message(format!("warning: {warning}")));
                }
            }
        }
        self.recorder.event(
            "force-offset",
            Some(point),
            &format!(
                "no-contact offset Fx {:.4} Fy {:.4} Fz {:.4} N, Mx {:.5} My {:.5} Mz {:.5} N m",
                mean[0], mean[1], mean[2], mean[3], mean[4], mean[5]
            ),
        );
        Ok(mean)
    }

    /// Paused, with z at the safe height, after the F/T device restarted: the force the
    /// watchers see over the ceiling is the device's new zero, not a load. Their zero is taken
    /// again from samples of no contact; false if there is no restart or not enough samples yet.
    fn retare_after_restart(&mut self) -> bool {
        if self.monitor.stats().restarts <= self.force_restarts_seen {
            return false;
        }
        let Some(after) = self.tare_not_before else {
            return false;
        };
        if self.monitor.count_since(after) < TARE_SAMPLES {
            return false;
        }
        let Some((_, mean)) = self.monitor.mean_of_last(TARE_SAMPLES) else {
            return false;
        };
        self.tare.set(mean[2]);
        true
    }

    /// Waits until [`TARE_SAMPLES`] samples have arrived after `after`.
    fn wait_for_fresh_samples(&mut self, after: HostTime) -> Result<(), ScanError> {
        let waiting = Instant::now();
        loop {
            let fresh = self.monitor.count_since(after);
            if fresh >= TARE_SAMPLES {
                self.excluded += waiting.elapsed();
                return Ok(());
            }
            if waiting.elapsed() > FRESH_TARE_TIMEOUT {
                return Err(ScanError::Setup(format!(
                    "{}: {fresh} force samples in {} s at the safe height after the interruption, {TARE_SAMPLES} needed to take the no-contact offset: check the F/T stream",
                    self.monitor.device(),
                    FRESH_TARE_TIMEOUT.as_secs()
                )));
            }
            std::thread::sleep(POLL);
        }
    }

    /// Waits for the x and y moves; stops them on an interruption. Where they came to rest is
    /// read from the status that showed the move ended: the lateral axes do not move while the
    /// point is pressed, so they are not asked again (each ask of a Modbus y stage is two
    /// transactions on its serial line, about 13 ms at 38400 baud).
    fn wait_lateral(&mut self) -> Result<Lateral, ScanError> {
        let started = Instant::now();
        let mut x_rest = None;
        let mut y_rest = if self.setup.limits.manual_y {
            // By hand: where the operator confirmed the row.
            Some(match self.manual_y_at {
                Some(y) => y,
                None => self.axes.y.status()?.position,
            })
        } else {
            None
        };
        loop {
            if let (Some(x), Some(y)) = (x_rest, y_rest) {
                return Ok(Lateral::AtRest { x, y });
            }
            if let Some(alarm) = self.interrupted() {
                let _ = self.axes.x.stop(StopMode::Immediate);
                let _ = self.axes.x.wait_idle(MOVE_TIMEOUT);
                // A y stage moved by hand has nothing to stop.
                if !self.setup.limits.manual_y {
                    let _ = self.axes.y.stop(StopMode::Immediate);
                    let _ = self.axes.y.wait_idle(MOVE_TIMEOUT);
                }
                return Ok(Lateral::Interrupted(alarm));
            }
            if let Some(fz) = self.fz_now().filter(|fz| self.clearance.loaded(*fz)) {
                let _ = self.axes.x.stop(StopMode::Immediate);
                if !self.setup.limits.manual_y {
                    let _ = self.axes.y.stop(StopMode::Immediate);
                }
                let _ = self.axes.x.wait_idle(MOVE_TIMEOUT);
                if !self.setup.limits.manual_y {
                    let _ = self.axes.y.wait_idle(MOVE_TIMEOUT);
                }
                return Err(self.under_load(Motion::LateralMoving, fz).into());
            }
            if started.elapsed() > MOVE_TIMEOUT {
                return Err(ScanError::Setup(format!(
                    "the lateral move did not finish within {MOVE_TIMEOUT:?} ({}, {})",
                    self.axes.x.endpoint(),
                    self.axes.y.endpoint()
                )));
            }
            if x_rest.is_none() {
                x_rest = settled(self.axes.x.as_mut())?.map(|s| s.position);
            }
            if y_rest.is_none() {
                y_rest = settled(self.axes.y.as_mut())?.map(|s| s.position);
            }
            self.status(false);
        }
    }

    /// Holds for `dwell`, filming; ends early on an interruption.
    fn dwell(&mut self, dwell: Duration) -> Option<Alarm> {
        let until = Instant::now() + dwell;
        while Instant::now() < until {
            if let Some(alarm) = self.interrupted() {
                return Some(alarm);
            }
            self.status(false);
            std::thread::sleep(POLL);
        }
        None
    }

    fn retract(&mut self) -> Result<(), ScanError> {
        if self.axes.z.status()?.moving {
            self.axes.z.stop(StopMode::Immediate)?;
            self.axes.z.wait_idle(MOVE_TIMEOUT)?;
        }
        self.axes.z.move_to(self.safe_z, MOVE_TIMEOUT)?;
        Ok(())
    }

    /// Fz now (N): the mean of the newest [`LOAD_SAMPLES`]; `None` before any sample (the
    /// watchers stop a silent stream).
    fn fz_now(&self) -> Option<f64> {
        self.monitor.mean_of_last(LOAD_SAMPLES).map(|(_, m)| m[2])
    }

    /// Refuses `motion` when the F/T reads a load now.
    fn check_clear(&mut self, motion: Motion) -> Result<(), ScanError> {
        match self.fz_now() {
            Some(fz) if self.clearance.loaded(fz) => Err(self.under_load(motion, fz).into()),
            _ => Ok(()),
        }
    }

    /// The refusal of `motion` under the load `fz` reads. The safe height proved not to be
    /// clear: from here on z retracts to the end of its travel away from the sensor, and it is
    /// taken there now (a move away from the sensor is always allowed).
    fn under_load(&mut self, motion: Motion, fz: f64) -> UnderLoad {
        let z = self
            .axes
            .z
            .status()
            .map_or(Millimetres(f64::NAN), |s| s.position);
        let safe_z = self.safe_z;
        self.safe_z = self.setup.limits.z.min;
        let lifted_to = match self.retract() {
            Ok(()) => self.safe_z,
            Err(_) => Millimetres(f64::NAN),
        };
        UnderLoad {
            device: self.monitor.device().to_string(),
            motion,
            load: self.clearance.load(fz),
            threshold: self.clearance.threshold(),
            z,
            safe_z,
            lifted_to,
            reference_from: self.clearance.from().to_string(),
        }
    }

    /// Moves z from its home down to the safe height, stopping at once if the F/T reads a load
    /// on the way or once there.
    fn descend_to_safe_height(&mut self) -> Result<(), ScanError> {
        (self.progress)(ScanProgress::Message(format!(
            "z to the safe height {:.3}",
            self.safe_z
        )));
        self.axes.z.begin_move_to(self.safe_z)?;
        let started = Instant::now();
        loop {
            if let Some(fz) = self.fz_now() {
                if self.clearance.loaded(fz) {
                    let _ = self.axes.z.stop(StopMode::Immediate);
                    let _ = self.axes.z.wait_idle(MOVE_TIMEOUT);
                    return Err(self.under_load(Motion::ToSafeHeight, fz).into());
                }
            }
            if settled(self.axes.z.as_mut())?.is_some() {
                break;
            }
            if started.elapsed() > MOVE_TIMEOUT {
                return Err(ScanError::Setup(format!(
                    "z did not reach the safe height within {MOVE_TIMEOUT:?} ({})",
                    self.axes.z.endpoint()
                )));
            }
        }
        self.check_clear(Motion::ToSafeHeight)
    }

    fn point(&mut self, p: &ScanPoint) -> Result<PointEnd, ScanError> {
        let i = p.index;
        let tare = self.tare(i)?;
        self.phase(i, Phase::Moving);
        // Never across the sensor under load.
        self.check_clear(Motion::LateralStart)?;
        self.axes.x.begin_move_to(p.x)?;
        if !self.setup.limits.manual_y {
            self.axes.y.begin_move_to(p.y)?;
        }
        let moving = Instant::now();
        let lateral = self.wait_lateral()?;
        self.excluded += moving.elapsed();
        // Nothing of this point is filmed, cut or checkpointed before its checkpoint is made.
        if let Some(pending) = self.pending_checkpoint.take() {
            pending.wait(CHECKPOINT_TIMEOUT)?;
        }
        let measured = match lateral {
            Lateral::AtRest { x, y } => Position {
                x,
                y,
                z: self.axes.z.status()?.position,
            },
            Lateral::Interrupted(alarm) => return Ok(PointEnd::Interrupted(alarm)),
        };
        let contact = self.setup.origin.contact_mm(measured.x, measured.y);
        let mut filming = Filming {
            point: i,
            commanded: Position {
                x: p.x,
                y: p.y,
                z: self.press.approach_limit,
            },
            measured,
            contact,
            shape: p.shape.clone(),
            tare,
        };
        self.context.set(Some(filming.clone()));
        self.watchers.set_filming(true);
        let end = self.indent(p, &mut filming);
        self.context.set(None);
        self.watchers.set_filming(false);
        end
    }

    /// Approaches point `p` to first contact, presses and dwells at each target, and retracts.
    fn indent(&mut self, p: &ScanPoint, filming: &mut Filming) -> Result<PointEnd, ScanError> {
        let i = p.index;
        self.phase(i, Phase::Approach);
        let tare_fz = Newtons(self.tare.get());
        let press = self.press.clone();
        let monitor = self.monitor.clone();
        let guard = ForceGuard::new(&monitor, &press, self.cancel.clone()).with_tare(tare_fz);
        let approaching = Instant::now();
        let approached = approach(self.axes.z.as_mut(), &guard);
        self.excluded += approaching.elapsed();
        let contact = match approached {
            Ok(c) => c,
            Err(e) => return self.press_failed(e),
        };
        self.recorder.event(
            "contact",
            Some(i),
            &format!(
                "first contact at z {:.4} mm ({:.3} N)",
                contact.z.0, contact.force.0
            ),
        );
        let n = match &self.setup.program.targets {
            Targets::Force(t) => t.len(),
            Targets::Depth(t) => t.len(),
        };
        let mut force_now = contact.force;
        for k in 0..n {
            self.phase(i, Phase::Pressing(k));
            let pressing = Instant::now();
            let reached = self.press_target(&guard, contact, force_now, k);
            self.excluded += pressing.elapsed();
            let reached = match reached {
                Ok(r) => r,
                Err(e) => return self.press_failed(e),
            };
            force_now = reached.force;
            if let Some(alarm) = self.hold(i, k, reached.z, filming)? {
                return Ok(PointEnd::Interrupted(alarm));
            }
        }
        self.retract_after_point(i)
    }

    /// Presses to target `k` from `contact`, the force now being `force_now`: a force target
    /// in a ramp, a depth target past contact at the ramp rate.
    fn press_target(
        &mut self,
        guard: &ForceGuard<'_>,
        contact: super::press::PressPoint,
        force_now: Newtons,
        k: usize,
    ) -> Result<super::press::PressPoint, PressError> {
        let setup = self.setup;
        let ramp_rate = setup.program.plan.indentation.ramp_rate;
        match &setup.program.targets {
            Targets::Force(t) => self.press_force_ramp(guard, contact, force_now, t[k], ramp_rate),
            // Past contact is towards the sensor: a larger z.
            Targets::Depth(t) => {
                let target = Millimetres(contact.z.0 + t[k].0);
                self.press_depth(guard, target, ramp_rate)
            }
        }
    }

    /// Ramps the pressing force from `from` to `target` through intermediate targets no more
    /// than half a second of ramp (`rate`, N/s) apart; `contact` when already there.
    fn press_force_ramp(
        &mut self,
        guard: &ForceGuard<'_>,
        contact: super::press::PressPoint,
        from: Newtons,
        target: Newtons,
        rate: f64,
    ) -> Result<super::press::PressPoint, PressError> {
        let step = (rate * 0.5).max(0.2);
        let mut result = Ok(contact);
        let mut f = from.0;
        while (target.0 - f).abs() > 1e-9 {
            f = if target.0 > f {
                (f + step).min(target.0)
            } else {
                (f - step).max(target.0)
            };
            result = press_to(self.axes.z.as_mut(), guard, Newtons(f));
            if result.is_err() {
                break;
            }
        }
        result
    }

    /// Films target `k` of point `i`, reached at z `reached_z`, for the dwell; the alarm if the
    /// dwell was interrupted.
    fn hold(
        &mut self,
        i: u64,
        k: usize,
        reached_z: Millimetres,
        filming: &mut Filming,
    ) -> Result<Option<Alarm>, ScanError> {
        filming.commanded.z = reached_z;
        // x and y stay where the lateral move left them.
        filming.measured.z = self.axes.z.status()?.position;
        self.context.set(Some(filming.clone()));
        self.phase(i, Phase::Dwell(k));
        let dwelling = Instant::now();
        let dwelt = self.dwell(self.setup.program.dwell);
        self.excluded += dwelling.elapsed();
        Ok(dwelt)
    }

    /// Moves z back to the safe height after point `i`, watching for interruptions.
    fn retract_after_point(&mut self, i: u64) -> Result<PointEnd, ScanError> {
        self.phase(i, Phase::Retract);
        let retracting = Instant::now();
        self.axes.z.begin_move_to(self.safe_z)?;
        loop {
            if let Some(alarm) = self.interrupted() {
                return Ok(PointEnd::Interrupted(alarm));
            }
            if settled(self.axes.z.as_mut())?.is_some() {
                break;
            }
            self.status(false);
        }
        self.excluded += retracting.elapsed();
        Ok(PointEnd::Done)
    }

    /// Moves z to `target` in steps paced by `rate` (mm/s), watching the force.
    fn press_depth(
        &mut self,
        guard: &ForceGuard<'_>,
        target: Millimetres,
        rate: f64,
    ) -> Result<super::press::PressPoint, PressError> {
        let step = (rate * 0.1).max(0.005);
        let mut z = self.axes.z.status()?.position.0;
        let mut steps = 0;
        while (target.0 - z).abs() > 1e-6 {
            if self.cancel.load(Ordering::SeqCst) {
                let _ = self.axes.z.stop(StopMode::Immediate);
                return Err(PressError::Cancelled);
            }
            let next = if target.0 > z {
                (z + step).min(target.0)
            } else {
                (z - step).max(target.0)
            };
            let t0 = Instant::now();
            self.axes
                .z
                .move_to(Millimetres(next), self.press.move_timeout)?;
            let f = guard.pressing_force()?;
            if f > self.press.ceiling {
                let _ = self.axes.z.stop(StopMode::Immediate);
                return Err(PressError::Ceiling {
                    force: f,
                    ceiling: self.press.ceiling,
                    retracted_to: self.axes.z.status()?.position,
                });
            }
            if let Some(rest) = Duration::from_millis(100).checked_sub(t0.elapsed()) {
                std::thread::sleep(rest);
            }
            z = next;
            steps += 1;
        }
        std::thread::sleep(self.press.settle);
        Ok(super::press::PressPoint {
            z: self.axes.z.status()?.position,
            force: guard.pressing_force()?,
            steps,
        })
    }

    fn press_failed(&mut self, e: PressError) -> Result<PointEnd, ScanError> {
        match e {
            PressError::Cancelled => Ok(PointEnd::Interrupted(
                self.watchers.alarm().unwrap_or(Alarm::Requested),
            )),
            PressError::Ceiling { force, ceiling, .. } => {
                self.cancel.store(true, Ordering::SeqCst);
                Ok(PointEnd::Interrupted(Alarm::Ceiling { force, ceiling }))
            }
            PressError::Force { .. } if self.watcher_tripped() => Ok(PointEnd::Interrupted(
                self.watchers.alarm().unwrap_or(Alarm::Requested),
            )),
            PressError::NoContact { limit, threshold } => Ok(PointEnd::NoContact(format!(
                "no contact above {:.2} N down to z {:.3} mm",
                threshold.0, limit.0
            ))),
            other => Err(other.into()),
        }
    }

    /// True when the watchers have tripped, allowing them one poll to see what the press saw.
    fn watcher_tripped(&self) -> bool {
        for _ in 0..5 {
            if self.cancel.load(Ordering::SeqCst) {
                return true;
            }
            std::thread::sleep(Duration::from_millis(2));
        }
        false
    }

    /// Sends a status line at most every 250 ms (or now when `force`).
    fn status(&mut self, force: bool) {
        if !force && self.last_status.elapsed() < Duration::from_millis(250) {
            return;
        }
        self.last_status = Instant::now();
        let total = self.setup.program.points.len() as u64;
        let left = total.saturating_sub(self.points_done);
        let eta = if self.done_this_session > 0 {
            self.started
                .elapsed()
                .mul_f64(left as f64 / self.done_this_session as f64)
        } else {
            let estimate = self.setup.program.estimate(&self.setup.limits).total;
            estimate.mul_f64(left as f64 / total.max(1) as f64)
        };
        let stats: RecorderStats = self.recorder.stats();
        let force_n = self
            .monitor
            .mean_of_last(50)
            .map_or(f64::NAN, |(_, m)| self.tare.get() - m[2]);
        (self.progress)(ScanProgress::Status(Status {
            points_done: self.points_done,
            points_total: total,
            eta,
            force_n,
            frame_rate_hz: stats.frame_rate_hz,
            frames_recorded: stats.frames_recorded,
            dropped_frames: stats.dropped_frames,
        }));
    }
}

/// A run id from the plan name and the UTC time ("grid-2026-11-23T02-10-00-123Z").
pub fn new_run_id(plan_name: &str) -> String {
    let name: String = plan_name
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                c
            } else {
                '-'
            }
        })
        .collect();
    format!("{name}-{}", now_utc().replace([':', '.'], "-"))
}

/// The runs root used when none is given.
pub fn default_root() -> &'static Path {
    Path::new("runs")
}
