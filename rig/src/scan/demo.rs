//! The short demonstration the main job runs on the simulated bench until full scan plans land:
//! home the axes, press the indenter at a few points to a few force levels, record every frame of
//! each dwell with its force label from the exposure strobe, store a run and score the labels
//! against the simulator's ground truth.

use super::engine::{labeler_for, LATCH_PERIOD};
use super::press::{approach, press_to, retract, ForceGuard, PressError, PressSettings};
use crate::acquire::camera_stream::CameraStream;
use crate::acquire::force_stream::ForceStream;
use crate::acquire::recorder::{Filming, FrameContext, Recorder};
use crate::axis::Axis;
use crate::camera::CameraSettings;
use crate::devices::Devices;
use crate::sim::ground_truth::TruthLog;
use crate::sim::rig::SimRig;
use crate::store::documents::{
    now_utc, ExitStatus, FrameRecord, Position, StartDocument, StopDocument,
};
use crate::store::run_writer::RunWriter;
use crate::store::StoreError;
use crate::sync::method::SyncMethod;
use crate::units::{Millimetres, Newtons};
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use std::sync::Arc;
use std::time::Duration;

/// What the demonstration presses.
#[derive(Debug, Clone, PartialEq)]
pub struct DemoPlan {
    /// Contact points in the sensor frame, mm from the disc centre.
    pub points: Vec<(f64, f64)>,
    pub targets: Vec<Newtons>,
    /// Time held (and filmed) at each target.
    pub dwell: Duration,
}

impl Default for DemoPlan {
    fn default() -> Self {
        DemoPlan {
            points: vec![(-6.0, 0.0), (0.0, 0.0), (5.0, -4.0)],
            targets: vec![Newtons(1.0), Newtons(4.0), Newtons(9.0)],
            dwell: Duration::from_millis(400),
        }
    }
}

/// What the demonstration did.
#[derive(Debug, Clone, PartialEq)]
pub struct DemoSummary {
    pub run_dir: PathBuf,
    pub presses: usize,
    pub frames_seen: u64,
    pub frames_recorded: u64,
    pub frames_unlabelled: u64,
    pub dropped_frames: u64,
    pub force_samples: u64,
    /// RMS of (label normal force - true normal force at mid-exposure) over recorded frames in
    /// contact, N.
    pub label_rms_error: Option<f64>,
    pub label_frames_scored: usize,
}

/// Why the demonstration stopped.
#[derive(Debug, thiserror::Error)]
pub enum DemoError {
    #[error(transparent)]
    Press(#[from] PressError),
    #[error(transparent)]
    Axis(#[from] crate::axis::AxisError),
    #[error(transparent)]
    Force(#[from] crate::force::ForceError),
    #[error(transparent)]
    Camera(#[from] crate::camera::CameraError),
    #[error(transparent)]
    Store(#[from] StoreError),
    #[error("{0}")]
    Other(String),
}

fn position(x: &mut dyn Axis, y: &mut dyn Axis, z: &mut dyn Axis) -> Result<Position, DemoError> {
    Ok(Position {
        x: x.status()?.position,
        y: y.status()?.position,
        z: z.status()?.position,
    })
}

/// Runs the demonstration on `devices` (from `sim`), writing a run under `root`.
pub fn run_demo(
    sim: &SimRig,
    devices: Devices,
    truth: Arc<TruthLog>,
    root: &Path,
    plan: &DemoPlan,
    progress: &mut dyn FnMut(&str),
) -> Result<DemoSummary, DemoError> {
    let Devices {
        mut x,
        mut y,
        mut z,
        force,
        camera,
        description,
    } = devices;
    let geometry = sim.bench.config().geometry;
    let timeout = Duration::from_secs(60);
    progress("homing x, y and z");
    x.begin_home()?;
    z.begin_home()?;
    y.begin_home()?;
    x.wait_idle(timeout)?;
    z.wait_idle(timeout)?;
    y.wait_idle(timeout)?;
    let safe_z = Millimetres(geometry.z_touch_mm - 1.5);
    z.move_to(safe_z, timeout)?;

    let stream = ForceStream::spawn(force)?;
    let monitor = stream.monitor();
    std::thread::sleep(Duration::from_millis(400));
    let (_, tare) = monitor
        .mean_of_last(1000)
        .ok_or_else(|| DemoError::Other("no force samples after 0.4 s".into()))?;
    progress(&format!(
        "force sensor tared with nothing touching: Fz offset {:.3} N",
        tare[2]
    ));

    let run_id = format!("demo-{}", now_utc().replace([':', '.'], "-"));
    let start = StartDocument {
        layout_version: crate::store::documents::LAYOUT_VERSION,
        run_id: run_id.clone(),
        started_utc: now_utc(),
        software: format!("fringe {}", env!("CARGO_PKG_VERSION")),
        sensor_id: sim.config.sensor.id.clone(),
        plan: format!("{plan:?}"),
        rig: description.join("\n"),
        calibration_profile: None,
        seed: Some(sim.config.seed),
        sync_method: "strobe".into(),
    };
    let writer = RunWriter::create(root, &start)?;
    let run_dir = writer.dir().to_path_buf();
    let settings = CameraSettings::default();
    let tick_hz = camera.info().tick_frequency as f64;
    let cameras = CameraStream::spawn_with_latches(camera, &settings, LATCH_PERIOD)?;
    let filming = FrameContext::default();
    let labeler = labeler_for(SyncMethod::Strobe, &settings, tick_hz, &cameras);
    let recorder = Recorder::spawn(
        writer,
        stream.samples().clone(),
        cameras.frames().clone(),
        labeler,
        filming.clone(),
    )?;

    let settings = PressSettings {
        approach_limit: Millimetres(geometry.z_touch_mm + 3.0),
        ..PressSettings::default()
    };
    let cancel = Arc::new(AtomicBool::new(false));
    let guard = ForceGuard::new(&monitor, &settings, cancel).with_tare(Newtons(tare[2]));
    let shape = sim.bench.indenter().tip.name().to_string();
    let mut presses = 0;
    for (k, &(px, py)) in plan.points.iter().enumerate() {
        let target_x = Millimetres(geometry.x_centre_mm + px);
        let target_y = Millimetres(geometry.y_centre_mm + py);
        progress(&format!(
            "point {}/{}: contact at ({px:+.1}, {py:+.1}) mm from the sensor centre",
            k + 1,
            plan.points.len()
        ));
        x.begin_move_to(target_x)?;
        y.begin_move_to(target_y)?;
        x.wait_idle(timeout)?;
        y.wait_idle(timeout)?;
        let contact = approach(z.as_mut(), &guard)?;
        progress(&format!("  first contact at z = {:.3} mm", contact.z.0));
        for target in &plan.targets {
            let p = press_to(z.as_mut(), &guard, *target)?;
            let measured = position(x.as_mut(), y.as_mut(), z.as_mut())?;
            filming.set(Some(Filming {
                point: k as u64,
                commanded: Position {
                    x: target_x,
                    y: target_y,
                    z: p.z,
                },
                measured,
                contact: [px, py],
                shape: shape.clone(),
                tare,
            }));
            std::thread::sleep(plan.dwell);
            filming.set(None);
            presses += 1;
            progress(&format!(
                "  {:.1} N reached ({:.2} N measured after {} steps), filmed {:.1} s",
                target.0,
                p.force.0,
                p.steps,
                plan.dwell.as_secs_f64()
            ));
        }
        retract(z.as_mut(), safe_z, timeout)?;
    }
    cameras.stop()?;
    let stats = monitor.stats();
    let _sensor = stream.stop()?;
    let (writer, counts) = recorder.finish()?;
    let force_samples = writer.force_samples();
    let stop = StopDocument {
        exit_status: ExitStatus::Completed,
        reason: "demonstration finished".into(),
        stopped_utc: now_utc(),
        frames: counts.frames_recorded + counts.frames_unlabelled,
        dropped_frames: counts.dropped_frames,
        force_samples,
        lost_force_samples: stats.lost,
        points_done: plan.points.len() as u64,
        sync_method: Some("strobe".into()),
        sync_error_ns: counts.sync_error_ns,
    };
    // The simulator's ground truth goes into the run (a simulated run can be scored later).
    let truth_path = writer.dir().join("truth.jsonl");
    let mut lines = String::new();
    for r in truth.records() {
        lines.push_str(&r.to_json());
        lines.push('\n');
    }
    crate::store::run_writer::write_atomic(&truth_path, lines.as_bytes())?;
    let run_dir_done = writer.finish(&stop)?;
    debug_assert_eq!(run_dir_done, run_dir);

    // Score the labels against the ground truth at mid-exposure.
    let truths = truth.frames();
    let (records, _) =
        crate::store::run_writer::read_lines::<FrameRecord>(&run_dir.join(crate::store::FRAMES))?;
    let mut errors = Vec::new();
    for r in &records {
        let Some(w) = r.wrench else { continue };
        if let Some(t) = truths.iter().find(|t| t.id == r.frame_id) {
            let true_force = t.contact.map_or(0.0, |c| c.0);
            errors.push(-w.fz.0 - true_force);
        }
    }
    let label_rms_error = (!errors.is_empty())
        .then(|| (errors.iter().map(|e| e * e).sum::<f64>() / errors.len() as f64).sqrt());
    Ok(DemoSummary {
        run_dir,
        presses,
        frames_seen: counts.frames_seen,
        frames_recorded: counts.frames_recorded,
        frames_unlabelled: counts.frames_unlabelled,
        dropped_frames: counts.dropped_frames,
        force_samples,
        label_rms_error,
        label_frames_scored: errors.len(),
    })
}
