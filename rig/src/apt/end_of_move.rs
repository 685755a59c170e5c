//! The end of a motion, in [`Axis::wait_idle`](crate::axis::Axis::wait_idle): the end-of-move
//! message waited for, a late stop acknowledgement told from it, faults and a silent K-Cube
//! caught during the motion, the final status and the check of how the motion ended.

use super::driver::ThorlabsAxis;
use super::io_thread::{is_end_of_move, lock, Observed};
use super::message::{Message, Packet};
use super::pending::Pending;
use super::status::{StatusBits, FAULT_MASK};
use crate::axis::AxisError;
use std::time::{Duration, Instant};

/// Waiting for the end of a motion, in [`Axis::wait_idle`].
impl ThorlabsAxis {
    /// The end-of-move message of `pending`, waited for until `timeout`; fails on a fault or a
    /// silent K-Cube. The motion stays pending when the time runs out.
    pub(super) fn wait_end_of_move(
        &mut self,
        pending: &Pending,
        timeout: Duration,
    ) -> Result<Packet, AxisError> {
        let polled = !self.config.controller.uses_update_messages();
        let deadline = Instant::now() + timeout;
        loop {
            let now = Instant::now();
            if now >= deadline {
                // The motion stays pending: a later wait continues it (a scan polls with short
                // waits while it watches the force); a new command or a stop replaces it.
                return Err(self.end_of_move_timeout(pending, timeout));
            }
            let slice_end = if polled {
                (now + self.config.timeouts.poll_period).min(deadline)
            } else {
                (now + Duration::from_millis(20)).min(deadline)
            };
            if let Some(p) = self.next_event(slice_end, is_end_of_move)? {
                if self.late_stop_ack(&p, pending) {
                    continue;
                }
                return Ok(p);
            }
            self.check_during_move(pending, polled)?;
        }
    }

    /// The timeout error naming the end-of-move message `pending` waits for.
    fn end_of_move_timeout(&self, pending: &Pending, timeout: Duration) -> AxisError {
        let expected = match pending {
            Pending::Home => "MOT_MOVE_HOMED",
            Pending::Move(_) => "MOT_MOVE_COMPLETED",
            Pending::Stop(_) => "MOT_MOVE_STOPPED",
        };
        AxisError::Timeout {
            axis: self.config.axis.clone(),
            endpoint: self.endpoint.clone(),
            what: format!("{expected} while {}", pending.what()),
            timeout,
            flags: self.latest_flags(),
        }
    }

    /// Counts a MOT_MOVE_STOPPED against the stops sent; true when it is the late
    /// acknowledgement of a stop sent before this motion began, not the end of `pending`.
    fn late_stop_ack(&mut self, p: &Packet, pending: &Pending) -> bool {
        let stop_ack = matches!(p.message, Message::MoveStopped { .. });
        if stop_ack && self.unacked_stops > 0 {
            self.unacked_stops -= 1;
            return !matches!(pending, Pending::Stop(_));
        }
        false
    }

    /// Between events: fails when a K-Cube went silent, or when the latest status since the
    /// motion started shows a fault (which ends the motion).
    fn check_during_move(&mut self, pending: &Pending, polled: bool) -> Result<(), AxisError> {
        if !polled && self.silent_since_motion() {
            return Err(self.silent(&format!("status while {}", pending.what())));
        }
        let o = if polled {
            Some(self.observe()?)
        } else {
            // Only a status sent after the motion started says something about it.
            let shared = lock(&self.shared);
            shared
                .latest
                .filter(|_| shared.updates > self.updates_at_start)
        };
        if let Some(o) = o {
            if o.status & FAULT_MASK != 0 {
                self.pending = None;
                let flags = StatusBits(o.status).move_faults(self.config.limit_polarity);
                return Err(self.fault(pending.what(), flags));
            }
        }
        Ok(())
    }

    /// Position and status at the end of a motion: carried by the end message, or else asked
    /// of a polled controller or heard at a K-Cube's next update.
    pub(super) fn final_status(&mut self, end: &Packet) -> Result<Observed, AxisError> {
        let polled = !self.config.controller.uses_update_messages();
        Ok(match &end.message {
            Message::MoveCompleted {
                status: Some(b), ..
            }
            | Message::MoveStopped {
                status: Some(b), ..
            } => Observed {
                position: b.position,
                status: b.status,
            },
            // A polled controller is asked; one on update messages is heard at its next update.
            _ if polled => self.observe()?,
            _ => self.next_status("status update after the end of the motion")?,
        })
    }

    /// Fails when the motion `pending` ended with faults in `bits`, or was stopped by the
    /// controller (`stopped`) when it was not a stop.
    pub(super) fn check_end(
        &self,
        pending: Pending,
        bits: StatusBits,
        stopped: bool,
    ) -> Result<(), AxisError> {
        let polarity = self.config.limit_polarity;
        match pending {
            Pending::Home => {
                let faults = bits.faults(polarity);
                if stopped || !faults.is_empty() {
                    let mut flags = faults;
                    if flags.is_empty() {
                        flags = bits.names(polarity);
                    }
                    return Err(self.fault(
                        "homing (the controller stopped the homing run)".into(),
                        flags,
                    ));
                }
            }
            Pending::Move(what) => {
                let faults = bits.move_faults(polarity);
                if !faults.is_empty() {
                    return Err(self.fault(what, faults));
                }
                if stopped {
                    return Err(self.fault(
                        format!("{what}: the controller stopped the move (MOT_MOVE_STOPPED)"),
                        bits.names(polarity),
                    ));
                }
            }
            Pending::Stop(what) => {
                let faults = bits.faults(polarity);
                if !faults.is_empty() {
                    return Err(self.fault(format!("stopping ({what})"), faults));
                }
            }
        }
        Ok(())
    }
}
