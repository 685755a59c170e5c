//! The runner's moves outside the pressing: the lateral move to a point, z down to the safe
//! height at the start, z back to it.

use super::runner::{Runner, MOVE_TIMEOUT, POLL};
use crate::axis::{Axis, AxisError, AxisStatus, StopMode};
use crate::scan::clearance::Motion;
use crate::scan::control::ScanProgress;
use crate::scan::failure::ScanError;
use crate::scan::watchers::Alarm;
use crate::units::Millimetres;
use std::time::Instant;

/// Waits up to one poll period for `axis` to finish its move: its status when it has.
pub(super) fn settled(axis: &mut dyn Axis) -> Result<Option<AxisStatus>, AxisError> {
    match axis.wait_idle(POLL) {
        Ok(status) => Ok(Some(status)),
        Err(AxisError::Timeout { .. }) => Ok(None),
        Err(e) => Err(e),
    }
}

/// How the lateral move before a point ended.
pub(super) enum Lateral {
    /// Both axes at rest, at these positions.
    AtRest {
        x: Millimetres,
        y: Millimetres,
    },
    Interrupted(Alarm),
}

impl Runner<'_> {
    /// Waits for the x and y moves; stops them on an interruption. Where they came to rest is
    /// read from the status that showed the move ended: the lateral axes do not move while the
    /// point is pressed, so they are not asked again (each ask of a Modbus y stage is two
    /// transactions on its serial line, about 13 ms at 38400 baud).
    pub(super) fn wait_lateral(&mut self) -> Result<Lateral, ScanError> {
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

    pub(super) fn retract(&mut self) -> Result<(), ScanError> {
        if self.axes.z.status()?.moving {
            self.axes.z.stop(StopMode::Immediate)?;
            self.axes.z.wait_idle(MOVE_TIMEOUT)?;
        }
        self.axes.z.move_to(self.safe_z, MOVE_TIMEOUT)?;
        Ok(())
    }

    /// Moves z from its home down to the safe height, stopping at once if the F/T reads a load
    /// on the way or once there.
    pub(super) fn descend_to_safe_height(&mut self) -> Result<(), ScanError> {
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
}
