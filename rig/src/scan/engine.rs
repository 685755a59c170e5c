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

mod indentation;
mod motions;
mod no_contact;
mod points;
pub(crate) mod recording;
mod runner;
mod sliding;

use self::recording::{append_sidecar, finish_recorder, start_recording, Streams};
use self::runner::{Axes, Ending, Runner, RunnerParts, MOVE_TIMEOUT};
use super::control::{ScanControl, ScanProgress};
use super::failure::ScanError;
use super::setup::ScanSetup;
use crate::camera::Camera;
use crate::devices::Devices;
use crate::force::ForceSensor;
use crate::operator::Operator;
use crate::store::documents::{now_utc, ExitStatus, StartDocument, StopDocument, LAYOUT_VERSION};
use crate::store::error::StoreError;
use crate::store::frames::FrameStorage;
use crate::store::run_lock::RunLock;
use crate::store::run_writer::RunWriter;
use crate::units::Millimetres;
use std::path::{Path, PathBuf};
use std::time::Duration;

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
    // So is a slide that would leave the disc.
    setup.check_slides_on_disc().map_err(ScanError::Setup)?;
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
                ft_axes: setup.ft_axes,
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
