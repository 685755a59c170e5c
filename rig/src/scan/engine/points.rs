//! The points of a scan and what happens between them: the checkpoint before each point, the
//! operator's prompts (pause, indenter change, manual y row), a point done, skipped or
//! interrupted and done again.

use super::motions::Lateral;
use super::recording::append_sidecar;
use super::runner::{
    Ending, PointEnd, Runner, CAMERA_SETTLE_TIMEOUT, CHECKPOINT_TIMEOUT, MAX_WATCHER_RETRIES,
};
use crate::acquire::recorder::Filming;
use crate::clock::HostTime;
use crate::operator::{Operator, Prompt, Reply};
use crate::scan::clearance::Motion;
use crate::scan::control::{Phase, Request, ScanProgress};
use crate::scan::failure::ScanError;
use crate::scan::plan::ScanPoint;
use crate::scan::watchers::{Alarm, REPRESS_EVENT, STOPPED_BY_WATCHERS_EVENT};
use crate::store::documents::Position;
use std::time::{Duration, Instant};

impl Runner<'_> {
    /// Runs the program's points from `first` on, until the last is done or the scan ends.
    pub(super) fn points(
        &mut self,
        first: u64,
        operator: &mut dyn Operator,
    ) -> Result<Ending, ScanError> {
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
            slide: None,
        };
        self.context.set(Some(filming.clone()));
        self.watchers.set_filming(true);
        let end = self.indent(p, &mut filming);
        self.context.set(None);
        self.watchers.set_filming(false);
        end
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
    /// that the point is pressed again (recorded as a `re-press` event; after camera drops, once
    /// the camera keeps up again); `Some` ends the scan (an abort, or too many watcher
    /// interruptions of one point in a row: a stop the run can be resumed from).
    fn point_interrupted(
        &mut self,
        p: &ScanPoint,
        alarm: Alarm,
        operator: &mut dyn Operator,
    ) -> Result<Option<Ending>, ScanError> {
        self.context.set(None);
        self.watchers.set_filming(false);
        // One count of the camera's drops for the pause's reason and the progress: the
        // recorder's, as the progress shows it, taken once.
        let alarm = match alarm {
            Alarm::CameraDrops {
                dropped, window, ..
            } => {
                let stats = self.recorder.stats();
                let total = stats.dropped_frames;
                self.status_with(stats);
                Alarm::CameraDrops {
                    dropped,
                    window,
                    total,
                }
            }
            other => other,
        };
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
                let why = format!(
                    "point {} was interrupted {times} times in a row by the watchers (last: {alarm}); the scan stops so that the cause can be fixed (the points done are kept; resume the run to go on)",
                    p.index + 1
                );
                self.recorder
                    .event(STOPPED_BY_WATCHERS_EVENT, Some(p.index), &why);
                return Ok(Some(Ending::Stopped(why)));
            }
            self.recorder.event(
                REPRESS_EVENT,
                Some(p.index),
                &format!(
                    "point {} pressed again after: {alarm} (try {} of at most {MAX_WATCHER_RETRIES} in a row)",
                    p.index + 1,
                    times + 1
                ),
            );
            if matches!(alarm, Alarm::CameraDrops { .. }) {
                self.camera_settles();
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

    /// Waits (at most [`CAMERA_SETTLE_TIMEOUT`]) until the camera has delivered a whole drop
    /// window without losing a frame, so that a point spoilt by drops is not pressed again into
    /// the same burst; says so once when it has to wait.
    fn camera_settles(&mut self) {
        let started = Instant::now();
        let mut said = false;
        while started.elapsed() < CAMERA_SETTLE_TIMEOUT {
            if self.control.request() == Request::Abort {
                return;
            }
            let (recent, window) = self.watchers.recent_drops();
            // The window must have passed since the burst that stopped the point.
            if recent == 0 {
                return;
            }
            if !said && recent > 0 {
                (self.progress)(ScanProgress::Message(format!(
                    "waiting for the camera to keep up ({recent} frames dropped within {:.1} s) before the point is pressed again",
                    window.as_secs_f64()
                )));
                said = true;
            }
            std::thread::sleep(Duration::from_millis(50));
        }
    }

    pub(super) fn ask(
        &mut self,
        operator: &mut dyn Operator,
        prompt: &Prompt,
        point: Option<u64>,
    ) -> bool {
        self.recorder.event("prompt", point, &prompt.message());
        let asked = Instant::now();
        let reply = operator.ask(prompt);
        self.excluded += asked.elapsed();
        self.recorder.event("reply", point, &format!("{reply:?}"));
        reply == Reply::Continue
    }

    /// Paused: waits until the watchers' condition clears, then asks the operator. False: abort.
    pub(super) fn pause(
        &mut self,
        reason: String,
        operator: &mut dyn Operator,
    ) -> Result<bool, ScanError> {
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
                Some(Alarm::Ceiling { .. } | Alarm::TangentialCeiling { .. })
                    if self.retare_after_restart() =>
                {
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
}
