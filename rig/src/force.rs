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

/// How the F/T sensor's axes sit on the bench, to turn its readings into forces in the sensor's
/// frame (x, y along the stage axes, z up, away from the photoelastic sensor): a rig file's
/// `[force] x_axis_deg` and `z_toward_tool`, the simulated bench's from its mount.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct FtAxes {
    /// The F/T x axis from the stage's +x, counter-clockwise seen from above, degrees.
    pub x_axis_deg: f64,
    /// The F/T z axis points down, at the tool (ATI's tool frame); otherwise up.
    pub z_toward_tool: bool,
}

impl FtAxes {
    /// The tangential force the indenter applies to the sensor's surface, sensor frame [x, y],
    /// N, from a tared reading `force` = [Fx, Fy, Fz] in the F/T frame. The F/T reads the
    /// force on the tool: the surface pushes the indenter back, so the push on the surface is
    /// its opposite.
    pub fn surface_shear(&self, force: [f64; 3]) -> [f64; 2] {
        // Undo the turn about the F/T z, then the flip about x (the tool frame's y and z point
        // against the stage's).
        let (s, c) = self.x_axis_deg.to_radians().sin_cos();
        let x = c * force[0] - s * force[1];
        let y = s * force[0] + c * force[1];
        let y = if self.z_toward_tool { -y } else { y };
        [-x, -y]
    }
}

#[cfg(test)]
mod tests {
    use super::FtAxes;

    #[test]
    fn the_push_on_the_surface_is_read_back_in_the_sensor_frame() {
        // ATI's tool frame on the default mount: a push along +x makes the tool feel -x (Fx
        // negative); along +y the tool feels -y, which the flipped frame reads as +Fy.
        let tool = FtAxes {
            x_axis_deg: 0.0,
            z_toward_tool: true,
        };
        assert_eq!(tool.surface_shear([-1.5, 0.0, -3.0]), [1.5, 0.0]);
        assert_eq!(tool.surface_shear([0.0, 0.8, -3.0]), [0.0, 0.8]);
        // An F/T turned by 90 degrees, z up: its x axis is the stage's +y.
        let turned = FtAxes {
            x_axis_deg: 90.0,
            z_toward_tool: false,
        };
        let [x, y] = turned.surface_shear([-2.0, 0.0, 3.0]);
        assert!(x.abs() < 1e-12 && (y - 2.0).abs() < 1e-12, "{x} {y}");
        let [x, y] = turned.surface_shear([0.0, -1.0, 3.0]);
        assert!((x + 1.0).abs() < 1e-12 && y.abs() < 1e-12, "{x} {y}");
    }
}
