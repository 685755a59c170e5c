//! Host time: one monotonic time base for the whole process.
//!
//! Every sample and frame carries the host receive time as a [`HostTime`], nanoseconds since a
//! process-wide monotonic epoch (the first call). Device clocks (camera ticks, F/T sequence
//! numbers) stay in their own types and are mapped onto host time by the synchronisation step.

use std::sync::OnceLock;
use std::time::{Duration, Instant};

fn epoch() -> Instant {
    static EPOCH: OnceLock<Instant> = OnceLock::new();
    *EPOCH.get_or_init(Instant::now)
}

/// A monotonic host instant, in nanoseconds since the process epoch.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Default, serde::Serialize, serde::Deserialize)]
#[serde(transparent)]
pub struct HostTime(pub u64);

impl HostTime {
    /// The current host time.
    pub fn now() -> HostTime {
        HostTime::from_instant(Instant::now())
    }

    /// Converts an [`Instant`] to host time (instants before the epoch clamp to zero).
    pub fn from_instant(t: Instant) -> HostTime {
        HostTime(t.saturating_duration_since(epoch()).as_nanos() as u64)
    }

    /// Nanoseconds since the epoch.
    pub fn nanos(self) -> u64 {
        self.0
    }

    /// Seconds since the epoch, as a float.
    pub fn seconds(self) -> f64 {
        self.0 as f64 * 1e-9
    }

    /// Time elapsed from `earlier` to `self` (zero if `earlier` is later).
    pub fn since(self, earlier: HostTime) -> Duration {
        Duration::from_nanos(self.0.saturating_sub(earlier.0))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn host_time_is_monotonic() {
        let a = HostTime::now();
        std::thread::sleep(Duration::from_millis(2));
        let b = HostTime::now();
        assert!(b > a);
        assert!(b.since(a) >= Duration::from_millis(2));
        assert_eq!(a.since(b), Duration::ZERO);
    }
}
