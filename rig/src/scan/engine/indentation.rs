//! One indentation: approach to first contact, the force or depth targets pressed in turn, the
//! dwell filmed at each (a press that slides: its one force, the dwell, the slide and the dwell
//! at its end), the retract; a press that failed, as the point's end.

use super::motions::settled;
use super::runner::{PointEnd, Runner, POLL};
use super::sliding::SlideEnd;
use crate::acquire::recorder::Filming;
use crate::axis::StopMode;
use crate::scan::control::Phase;
use crate::scan::failure::ScanError;
use crate::scan::plan::{ScanPoint, Targets};
use crate::scan::press::{approach, press_to, ForceGuard, PressError};
use crate::scan::watchers::Alarm;
use crate::units::{Millimetres, Newtons};
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

impl Runner<'_> {
    /// Approaches point `p` to first contact, presses and dwells at each target, and retracts.
    pub(super) fn indent(
        &mut self,
        p: &ScanPoint,
        filming: &mut Filming,
    ) -> Result<PointEnd, ScanError> {
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
        if let Some(s) = p.slide {
            // One force, then the slide.
            self.phase(i, Phase::Pressing(0));
            let pressing = Instant::now();
            let ramp_rate = self.setup.program.plan.indentation.ramp_rate;
            let reached = self.press_force_ramp(&guard, contact, contact.force, s.force, ramp_rate);
            self.excluded += pressing.elapsed();
            let reached = match reached {
                Ok(r) => r,
                Err(e) => return self.press_failed(e),
            };
            if let Some(alarm) = self.hold(i, 0, reached.z, filming)? {
                return Ok(PointEnd::Interrupted(alarm));
            }
            match self.slide(i, &s, &guard, contact, reached, filming)? {
                SlideEnd::Done => {}
                SlideEnd::Interrupted(alarm) => return Ok(PointEnd::Interrupted(alarm)),
            }
            self.phase(i, Phase::SlideDwell);
            let dwelling = Instant::now();
            let dwelt = self.dwell(self.setup.program.slide_dwell);
            self.excluded += dwelling.elapsed();
            if let Some(alarm) = dwelt {
                return Ok(PointEnd::Interrupted(alarm));
            }
            return self.retract_after_point(i);
        }
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
        contact: crate::scan::press::PressPoint,
        force_now: Newtons,
        k: usize,
    ) -> Result<crate::scan::press::PressPoint, PressError> {
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
        contact: crate::scan::press::PressPoint,
        from: Newtons,
        target: Newtons,
        rate: f64,
    ) -> Result<crate::scan::press::PressPoint, PressError> {
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

    /// Holds for `dwell`, filming; ends early on an interruption.
    pub(super) fn dwell(&mut self, dwell: Duration) -> Option<Alarm> {
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
    ) -> Result<crate::scan::press::PressPoint, PressError> {
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
        Ok(crate::scan::press::PressPoint {
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
}
