//! Host time: one monotonic time base for the whole process.
//!
//! Every sample and frame carries the host receive time as a [`HostTime`], nanoseconds since a
//! process-wide monotonic epoch (the first call). Device clocks (camera ticks, F/T sequence
//! numbers) stay in their own types and are mapped onto host time by the synchronisation step.

use std::sync::OnceLock;
use std::time::{Duration, Instant, SystemTime};

/// The process epoch and the wall clock read at it.
fn epoch_and_wall() -> (Instant, SystemTime) {
    static EPOCH: OnceLock<(Instant, SystemTime)> = OnceLock::new();
    *EPOCH.get_or_init(|| (Instant::now(), SystemTime::now()))
}

fn epoch() -> Instant {
    epoch_and_wall().0
}

/// A monotonic host instant, in nanoseconds since the process epoch.
#[derive(
    Debug,
    Clone,
    Copy,
    PartialEq,
    Eq,
    PartialOrd,
    Ord,
    Hash,
    Default,
    serde::Serialize,
    serde::Deserialize,
)]
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

    /// The wall-clock time of this instant, in ns since the Unix epoch: the wall clock read at
    /// the process epoch plus the monotonic time since. Later changes of the wall clock (NTP
    /// steps) do not move it, so stamps stay evenly spaced within a process.
    pub fn unix_nanos(self) -> i64 {
        let wall = epoch_and_wall().1;
        let at_epoch = match wall.duration_since(SystemTime::UNIX_EPOCH) {
            Ok(d) => d.as_nanos() as i64,
            Err(e) => -(e.duration().as_nanos() as i64),
        };
        at_epoch.saturating_add(self.0 as i64)
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

    #[test]
    fn host_time_maps_onto_the_wall_clock() {
        let wall = SystemTime::now()
            .duration_since(SystemTime::UNIX_EPOCH)
            .expect("after 1970")
            .as_nanos() as i64;
        let mapped = HostTime::now().unix_nanos();
        assert!((mapped - wall).abs() < 50_000_000, "{mapped} vs {wall}");
        assert_eq!(
            HostTime(2_000).unix_nanos() - HostTime(1_000).unix_nanos(),
            1_000
        );
    }
}
