//! Controlling a running scan from outside (terminal, Ctrl-C, tests) and what it reports.
//!
//! - [`ScanControl`]: pause (after the current indentation, or now), resume, abort. Cheap to clone;
//!   every request is a flag the scan reads at its next check (at most a few ms away).
//! - The person at the bench is reached through [`crate::operator::Operator`] (its own module, as
//!   a device moved by hand asks them too).
//! - [`ScanProgress`]: what the scan reports while it runs.

use std::sync::atomic::{AtomicBool, AtomicU8, Ordering};
use std::sync::Arc;
use std::time::Duration;

const RUN: u8 = 0;
const PAUSE_AFTER: u8 = 1;
const PAUSE_NOW: u8 = 2;
const ABORT: u8 = 3;

/// Requests to a running scan.
#[derive(Debug, Clone, Default)]
pub struct ScanControl(Arc<AtomicU8>, Arc<AtomicBool>);

/// What has been asked of the scan.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Request {
    Run,
    /// Finish the current indentation, then pause.
    PauseAfterIndentation,
    /// Stop motion now (retract), pause; the interrupted point is done again on resume.
    PauseNow,
    /// Stop, retract, close the run as aborted.
    Abort,
}

impl ScanControl {
    pub fn new() -> ScanControl {
        ScanControl::default()
    }

    /// Asks for a pause after the current indentation; asking again while that is pending
    /// escalates to a pause now (Ctrl-C once, then twice).
    pub fn pause(&self) -> Request {
        let _ = self
            .0
            .fetch_update(Ordering::SeqCst, Ordering::SeqCst, |v| match v {
                RUN => Some(PAUSE_AFTER),
                PAUSE_AFTER => Some(PAUSE_NOW),
                _ => None,
            });
        self.request()
    }

    pub fn pause_now(&self) {
        let _ = self
            .0
            .fetch_update(Ordering::SeqCst, Ordering::SeqCst, |v| {
                (v != ABORT).then_some(PAUSE_NOW)
            });
    }

    pub fn abort(&self) {
        self.0.store(ABORT, Ordering::SeqCst);
    }

    /// Stops the scan as an abort does (motion stopped, z retracted, the run closed), but for
    /// a reason that is not the operator's decision (the terminal hung up, the process was
    /// asked to end): the run is closed resumable.
    pub fn interrupt(&self) {
        self.1.store(true, Ordering::SeqCst);
        self.abort();
    }

    /// Whether the stop was an interruption ([`ScanControl::interrupt`]), not an abort.
    pub fn interrupted(&self) -> bool {
        self.1.load(Ordering::SeqCst)
    }

    /// Clears a pause request (the scan resumes when it is paused).
    pub fn resume(&self) {
        let _ = self
            .0
            .fetch_update(Ordering::SeqCst, Ordering::SeqCst, |v| {
                (v != ABORT).then_some(RUN)
            });
    }

    pub fn request(&self) -> Request {
        match self.0.load(Ordering::SeqCst) {
            PAUSE_AFTER => Request::PauseAfterIndentation,
            PAUSE_NOW => Request::PauseNow,
            ABORT => Request::Abort,
            _ => Request::Run,
        }
    }

    /// True when motion must stop now (pause now or abort).
    pub fn stop_now(&self) -> bool {
        matches!(self.request(), Request::PauseNow | Request::Abort)
    }
}

/// Phases of one indentation, reported as they start.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Phase {
    /// Lateral move to the point at the safe height.
    Moving,
    /// Lowering until first contact.
    Approach,
    /// Pressing to target `k` of the profile.
    Pressing(usize),
    /// Holding target `k` (filmed).
    Dwell(usize),
    /// Sliding sideways, z holding the force (filmed).
    Sliding,
    /// Holding at the end of a slide (filmed).
    SlideDwell,
    /// Back to the safe height.
    Retract,
}

impl Phase {
    pub fn name(&self) -> String {
        match self {
            Phase::Moving => "moving".into(),
            Phase::Approach => "approach".into(),
            Phase::Pressing(k) => format!("pressing to target {}", k + 1),
            Phase::Dwell(k) => format!("dwell at target {}", k + 1),
            Phase::Sliding => "sliding".into(),
            Phase::SlideDwell => "dwell after the slide".into(),
            Phase::Retract => "retract".into(),
        }
    }
}

/// What the scan reports.
#[derive(Debug, Clone, PartialEq)]
pub enum ScanProgress {
    /// A line for the log.
    Message(String),
    /// A point started a phase.
    Phase {
        point: u64,
        phase: Phase,
    },
    /// Periodic status.
    Status(Status),
    Paused {
        reason: String,
    },
    Resumed,
}

/// Periodic status for progress bars.
#[derive(Debug, Clone, PartialEq)]
pub struct Status {
    pub points_done: u64,
    pub points_total: u64,
    /// Estimated time left.
    pub eta: Duration,
    /// Pressing force now (tared), N.
    pub force_n: f64,
    pub frame_rate_hz: f64,
    pub frames_recorded: u64,
    pub dropped_frames: u64,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_second_pause_request_escalates_and_abort_is_final() {
        let c = ScanControl::new();
        assert_eq!(c.pause(), Request::PauseAfterIndentation);
        assert!(!c.stop_now());
        assert_eq!(c.pause(), Request::PauseNow);
        assert!(c.stop_now());
        c.resume();
        assert_eq!(c.request(), Request::Run);
        c.abort();
        c.resume();
        c.pause();
        assert_eq!(c.request(), Request::Abort);
    }
}
