//! The runner of a scan's points: what it holds (the axes, the force monitor, the recorder, the
//! watchers), how it starts and how it leaves the bench, and what it reports (phase, status).
//! Its work is in the sibling files: the points and the pauses between them (`points`), the
//! no-contact offset and load checks (`no_contact`), the moves (`motions`), the pressing
//! (`indentation`).

use crate::acquire::force_stream::ForceMonitor;
use crate::acquire::recorder::{FrameContext, PendingCheckpoint, Recorder, RecorderStats};
use crate::axis::{Axis, StopMode};
use crate::clock::HostTime;
use crate::scan::clearance::Clearance;
use crate::scan::control::{Phase, ScanControl, ScanProgress, Status};
use crate::scan::failure::ScanError;
use crate::scan::press::PressSettings;
use crate::scan::setup::ScanSetup;
use crate::scan::watchers::{Alarm, SharedTare, WatchSettings, Watchers};
use crate::store::documents::ExitStatus;
use crate::units::{Millimetres, Newtons};
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// How a point ended.
pub(super) enum PointEnd {
    Done,
    /// Stopped by a request or a watcher (the point is done again after a pause).
    Interrupted(Alarm),
    /// The indenter found no contact before the approach limit: recorded and skipped.
    NoContact(String),
}

pub(super) const MOVE_TIMEOUT: Duration = Duration::from_secs(120);

pub(super) const POLL: Duration = Duration::from_millis(5);

pub(super) struct Axes {
    pub(super) x: Box<dyn Axis>,
    pub(super) y: Box<dyn Axis>,
    pub(super) z: Box<dyn Axis>,
}

impl Drop for Axes {
    /// A panic while the scan holds the axes stops them where they are.
    fn drop(&mut self) {
        crate::scan::panic_stop::stop_if_panicking([
            self.z.as_mut(),
            self.x.as_mut(),
            self.y.as_mut(),
        ]);
    }
}

/// A point the watchers interrupt this many times in a row ends the scan (a condition that
/// resuming does not clear, such as a camera that cannot keep up, would otherwise repeat it for
/// ever under `--yes`).
pub(super) const MAX_WATCHER_RETRIES: u32 = 3;

/// Longest wait, after camera drops spoilt a point, for the camera to deliver a whole drop
/// window without losing a frame before the point is pressed again.
pub(super) const CAMERA_SETTLE_TIMEOUT: Duration = Duration::from_secs(30);

/// Longest wait for the recorder to make a checkpoint.
pub(super) const CHECKPOINT_TIMEOUT: Duration = Duration::from_secs(10);

/// Force samples averaged for the no-contact offset before every point (0.1 s at 5 kHz).
pub(super) const TARE_SAMPLES: usize = 500;

pub(super) enum Ending {
    Completed,
    Aborted(String),
    /// Stopped by the engine itself (a point the watchers kept interrupting): not the
    /// operator's decision, so closed as a failed run is, which a resume goes on with.
    Stopped(String),
}

pub(super) struct Runner<'a> {
    pub(super) setup: &'a ScanSetup,
    /// The run's directory (sidecars are appended to their files in it after every point).
    pub(super) run_dir: PathBuf,
    pub(super) axes: Axes,
    pub(super) monitor: ForceMonitor,
    pub(super) recorder: Recorder,
    pub(super) context: FrameContext,
    pub(super) watchers: Watchers,
    pub(super) cancel: Arc<AtomicBool>,
    pub(super) tare: SharedTare,
    pub(super) press: PressSettings,
    pub(super) control: &'a ScanControl,
    pub(super) progress: &'a dyn Fn(ScanProgress),
    pub(super) safe_z: Millimetres,
    pub(super) points_done: u64,
    pub(super) started: Instant,
    pub(super) done_this_session: u64,
    /// The point the watchers interrupted last and how many times in a row.
    pub(super) watcher_retries: (u64, u32),
    /// The zero-load check has been made this session.
    pub(super) offset_checked: bool,
    /// Restarts of the F/T device already reported.
    pub(super) force_restarts_seen: u64,
    /// After an interruption: the next tare takes only samples that arrived after this (the
    /// samples before it may be from under load, or from before the stream stalled or the
    /// device restarted with another zero).
    pub(super) tare_not_before: Option<HostTime>,
    pub(super) last_status: Instant,
    /// The indenter the operator last confirmed.
    pub(super) mounted: Option<String>,
    /// Where the operator last set a y stage moved by hand.
    pub(super) manual_y_at: Option<Millimetres>,
    /// The F/T's no-contact reading, which tells a load at the safe height.
    pub(super) clearance: Clearance,
    pub(super) frames_discarded: u64,
    /// Time of the current point spent moving, settling, dwelling or waiting for the operator
    /// (everything that is not software overhead).
    pub(super) excluded: Duration,
    /// Software overhead of each finished point.
    pub(super) overheads: Vec<Duration>,
    /// The checkpoint of the current point, made while the axes move to it.
    pub(super) pending_checkpoint: Option<PendingCheckpoint>,
}

/// What a runner starts with, besides the setup, control and progress it borrows.
pub(super) struct RunnerParts {
    pub(super) run_dir: PathBuf,
    pub(super) axes: Axes,
    pub(super) monitor: ForceMonitor,
    pub(super) recorder: Recorder,
    pub(super) context: FrameContext,
    pub(super) safe_z: Millimetres,
    pub(super) first_point: u64,
    pub(super) discarded: u64,
}

impl<'a> Runner<'a> {
    /// The runner of a scan whose streams and recorder run: the press settings from the plan,
    /// the watchers started, the force stream waited for.
    pub(super) fn start(
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
        // Wait for the force stream before the first reading.
        let started = Instant::now();
        while parts.monitor.stats().received < 500 && started.elapsed() < Duration::from_secs(3) {
            std::thread::sleep(Duration::from_millis(10));
        }
        // z is homed, away from the sensor: what the F/T reads now is no contact, the zero the
        // watchers start from (from no zero at all, the F/T's own offset would read as a load).
        let (_, homed) = parts
            .monitor
            .mean_of_last(TARE_SAMPLES)
            .ok_or_else(|| no_samples(&parts.monitor))?;
        tare.set(&homed);
        let watch = WatchSettings {
            ceiling: press.ceiling,
            tangential_ceiling: setup.program.plan.safety.tangential(),
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
    pub(super) fn record_stop(&self, result: &Result<Ending, ScanError>) -> (ExitStatus, String) {
        let (status, reason) = match result {
            Ok(Ending::Completed) => (ExitStatus::Completed, "all points done".to_string()),
            // Not the operator's decision: closed as a failed run is, which a resume reopens.
            Ok(Ending::Aborted(_)) if self.control.interrupted() => (
                ExitStatus::Failed,
                "interrupted, not aborted (a stop that keeps the run, a hung-up terminal, SIGHUP or SIGTERM); resume the run to go on".to_string(),
            ),
            Ok(Ending::Aborted(why)) => (ExitStatus::Aborted, why.clone()),
            Ok(Ending::Stopped(why)) => (ExitStatus::Failed, why.clone()),
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
    pub(super) fn leave_bench_safe(&mut self) {
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

    pub(super) fn phase(&mut self, point: u64, phase: Phase) {
        (self.progress)(ScanProgress::Phase { point, phase });
    }

    pub(super) fn interrupted(&self) -> Option<Alarm> {
        if !self.cancel.load(Ordering::SeqCst) {
            return None;
        }
        Some(self.watchers.alarm().unwrap_or(Alarm::Requested))
    }

    /// Sends a status line at most every 250 ms (or now when `force`).
    pub(super) fn status(&mut self, force: bool) {
        if !force && self.last_status.elapsed() < Duration::from_millis(250) {
            return;
        }
        let stats: RecorderStats = self.recorder.stats();
        self.status_with(stats);
    }

    /// Sends a status line now with the recorder's counts `stats` (the counts a pause's reason
    /// gives too, so that both say the same).
    pub(super) fn status_with(&mut self, stats: RecorderStats) {
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

/// Why there is no force sample to read: the stream's own error when it failed (a saturated
/// gauge, a lost device), else that none came.
pub(super) fn no_samples(monitor: &ForceMonitor) -> ScanError {
    match monitor.error() {
        Some(e) => ScanError::Setup(format!(
            "{}: the force stream stopped: {e}",
            monitor.device()
        )),
        None => ScanError::Setup(format!("{}: no force samples", monitor.device())),
    }
}
