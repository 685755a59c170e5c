//! Device clock <-> host clock: host = host_at_origin + (ticks - tick_origin) * ns_per_tick.
//!
//! Every device clock (camera timestamp ticks, F/T sample counter, DAQ sample index) is mapped onto
//! host time by one of these. The origin keeps the numbers small so that f64 keeps sub-nanosecond
//! resolution over days of ticks.

#[cfg(test)]
use crate::clock::HostTime;

/// A linear map from a device's tick counter to host nanoseconds.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub(crate) struct ClockMap {
    /// A device tick near the data the map was fitted on.
    pub tick_origin: u64,
    /// Host time, in ns, of `tick_origin`.
    pub host_at_origin_ns: f64,
    /// Host nanoseconds per device tick (nominal period times (1 + drift)).
    pub ns_per_tick: f64,
}

impl ClockMap {
    /// Host time in ns (fractional) of device tick `ticks`.
    pub(crate) fn host_ns(&self, ticks: u64) -> f64 {
        self.host_ns_f(ticks as f64)
    }

    /// Host time in ns of a fractional device tick (interpolated sample indices).
    pub(crate) fn host_ns_f(&self, ticks: f64) -> f64 {
        self.host_at_origin_ns + (ticks - self.tick_origin as f64) * self.ns_per_tick
    }

    /// Host time of device tick `ticks`, rounded to the nanosecond (clamped at the epoch).
    #[cfg(test)]
    pub(crate) fn host_time(&self, ticks: u64) -> HostTime {
        HostTime(self.host_ns(ticks).round().max(0.0) as u64)
    }

    /// The (fractional) device tick at host time `host_ns`.
    pub(crate) fn ticks_at(&self, host_ns: f64) -> f64 {
        self.tick_origin as f64 + (host_ns - self.host_at_origin_ns) / self.ns_per_tick
    }

    /// Drift of the device clock relative to `nominal_ns_per_tick`, in parts per million
    /// (positive: device ticks are longer than nominal, the device clock runs slow).
    #[cfg(test)]
    pub(crate) fn drift_ppm(&self, nominal_ns_per_tick: f64) -> f64 {
        (self.ns_per_tick / nominal_ns_per_tick - 1.0) * 1e6
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn maps_both_ways_and_reports_drift() {
        let map = ClockMap {
            tick_origin: 1_000_000_000_000,
            host_at_origin_ns: 5e9,
            ns_per_tick: 1.0001,
        };
        let host = map.host_ns(1_000_000_001_000);
        assert!((host - (5e9 + 1000.1)).abs() < 1e-6);
        assert!((map.ticks_at(host) - 1_000_000_001_000.0).abs() < 1e-6);
        assert!((map.drift_ppm(1.0) - 100.0).abs() < 1e-6);
        assert_eq!(map.host_time(1_000_000_000_000), HostTime(5_000_000_000));
    }
}
