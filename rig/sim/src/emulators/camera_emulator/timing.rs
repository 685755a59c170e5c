//! The simulated camera's time base: its device clock against host time, and the exposure
//! windows it announces (the DAQ emulator samples them as the ExposureActive strobe). No threads.

use fringe_rig::HostTime;
use std::collections::VecDeque;
use std::sync::{Arc, Mutex};

/// A device clock: ticks (ns) with an offset and a rate error against host time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DeviceClock {
    /// Host instant at which the clock reads `ticks_at_ref`.
    pub reference: HostTime,
    pub ticks_at_ref: u64,
    /// Rate error: the device counts (1 + drift_ppm 1e-6) ticks per host nanosecond.
    pub drift_ppm: f64,
}

impl DeviceClock {
    fn rate(&self) -> f64 {
        1.0 + self.drift_ppm * 1e-6
    }

    /// The device clock at host time `t`.
    pub fn ticks_at(&self, t: HostTime) -> u64 {
        let dt = t.0 as f64 - self.reference.0 as f64;
        (self.ticks_at_ref as f64 + dt * self.rate())
            .round()
            .max(0.0) as u64
    }

    /// The host time at which the device clock reads `ticks`.
    pub fn host_at(&self, ticks: u64) -> HostTime {
        let dt = (ticks as f64 - self.ticks_at_ref as f64) / self.rate();
        HostTime((self.reference.0 as f64 + dt).round().max(0.0) as u64)
    }
}

/// A hardware trigger input: the rising edges of the signal wired to one of the camera's lines.
pub trait TriggerInput: Send + Sync {
    /// The first rising edge at or after `t`, while the source is pulsing.
    fn next_edge(&self, t: HostTime) -> Option<HostTime>;
}

/// One exposure, in host time.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ExposureWindow {
    pub id: u64,
    pub start: HostTime,
    pub end: HostTime,
}

/// Exposure windows shared between the camera (writer) and the DAQ (strobe channel).
///
/// The camera writes each window before it starts; readers take [`ExposureSchedule::snapshot`],
/// which reads the host clock under the same lock, so every sample at or before the snapshot's
/// `now` sees every window that starts by then.
#[derive(Debug, Default)]
pub struct ExposureSchedule {
    windows: Mutex<VecDeque<ExposureWindow>>,
}

/// Windows that ended longer ago than this are forgotten.
const SCHEDULE_KEEP_NS: u64 = 2_000_000_000;

impl ExposureSchedule {
    pub fn new() -> Arc<ExposureSchedule> {
        Arc::new(ExposureSchedule::default())
    }

    /// The windows under the schedule's lock (the software trigger reads the clock and publishes
    /// its window under it).
    pub(super) fn lock(&self) -> std::sync::MutexGuard<'_, VecDeque<ExposureWindow>> {
        self.windows.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Announces an exposure (the camera, before it starts); forgets long-ended windows.
    pub(super) fn push(&self, w: ExposureWindow) {
        let mut q = self.lock();
        let now = HostTime::now();
        while q
            .front()
            .is_some_and(|f| f.end.0 + SCHEDULE_KEEP_NS < now.0)
        {
            q.pop_front();
        }
        q.push_back(w);
    }

    /// The host time now, read under the lock, and the windows known then.
    pub fn snapshot(&self) -> (HostTime, Vec<ExposureWindow>) {
        let q = self.lock();
        (HostTime::now(), q.iter().copied().collect())
    }

    /// Whether `t` falls inside one of `windows` (start inclusive, end exclusive).
    pub fn exposing(windows: &[ExposureWindow], t: HostTime) -> bool {
        windows.iter().any(|w| w.start <= t && t < w.end)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn device_clock_maps_both_ways_with_drift() {
        let c = DeviceClock {
            reference: HostTime(0),
            ticks_at_ref: 5_000_000_000,
            drift_ppm: 100.0,
        };
        let t = HostTime(10_000_000_000);
        assert_eq!(c.ticks_at(t), 5_000_000_000 + 10_001_000_000);
        assert!((c.host_at(c.ticks_at(t)).0 as i64 - t.0 as i64).abs() <= 1);
    }

    #[test]
    fn schedule_tells_exposure_windows() {
        let w = [ExposureWindow {
            id: 0,
            start: HostTime(100),
            end: HostTime(200),
        }];
        assert!(!ExposureSchedule::exposing(&w, HostTime(99)));
        assert!(ExposureSchedule::exposing(&w, HostTime(100)));
        assert!(!ExposureSchedule::exposing(&w, HostTime(200)));
    }
}
