//! The force/torque sensor abstraction shared by the Net F/T driver, the DAQ + `.cal` path and
//! the simulated sensor.

use crate::clock::HostTime;
use crate::units::{Volts, Wrench};
use std::time::Duration;

/// One six-axis sample.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ForceSample {
    /// The device's own sample counter (Net F/T `ft_sequence`, DAQ sample index): the device
    /// clock that synchronisation maps onto host time.
    pub device_tick: u64,
    /// The transport sequence (Net F/T `rdt_sequence`), when there is one.
    pub transport_seq: Option<u32>,
    /// Host monotonic time at which the sample was received.
    pub host_time: HostTime,
    /// Force and torque in N and N m, bias removed.
    pub wrench: Wrench,
    /// Device status word (0 = ok).
    pub status: u32,
    /// Extra analogue channel sampled with the gauges (camera exposure-active strobe), if wired.
    pub strobe: Option<Volts>,
}

/// Counters kept by a streaming sensor.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct StreamStats {
    pub received: u64,
    /// Samples the device sent that never arrived (from sequence gaps).
    pub lost: u64,
    /// Samples that arrived after a later one and were dropped.
    pub out_of_order: u64,
    /// Samples whose status word was non-zero.
    pub errored: u64,
    /// Times the device's own sample counter started again (it rebooted: a bias set in the
    /// device is gone, and the transducer's offset may have changed).
    pub restarts: u64,
}

/// Errors from a force sensor, naming the device.
#[derive(Debug, thiserror::Error)]
pub enum ForceError {
    #[error("force sensor {device}: {message}")]
    Device { device: String, message: String },
    #[error("force sensor {device}: no data for {waited:?} ({hint})")]
    NoData {
        device: String,
        waited: Duration,
        hint: String,
    },
    #[error("force sensor {device}: status word {status:#010x} ({meaning}) at sample {tick}")]
    Status {
        device: String,
        status: u32,
        meaning: String,
        tick: u64,
    },
    #[error("force sensor {device}: link error: {source}")]
    Io {
        device: String,
        #[source]
        source: std::io::Error,
    },
    #[error("force sensor configuration {origin}: {message}")]
    Config { origin: String, message: String },
}

/// A six-axis force/torque sensor that streams samples.
pub trait ForceSensor: Send {
    /// A name for messages ("netft 192.168.1.1:49152").
    fn describe(&self) -> String;

    /// Starts streaming.
    fn start(&mut self) -> Result<(), ForceError>;

    /// Returns the next sample, or `None` if none arrived within `timeout`. A sample with a
    /// non-zero status word is returned as [`ForceError::Status`].
    fn next_sample(&mut self, timeout: Duration) -> Result<Option<ForceSample>, ForceError>;

    /// Stops streaming.
    fn stop(&mut self) -> Result<(), ForceError>;

    /// Sets the software bias to the current reading (subsequent samples read zero at this load).
    fn bias(&mut self) -> Result<(), ForceError>;

    /// Counters since `start`.
    fn stats(&self) -> StreamStats;
}
