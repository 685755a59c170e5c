//! The axis abstraction shared by every stage: Thorlabs steppers (x, z, y), Modbus y stages and
//! the manual y stage.

use crate::units::{Millimetres, MillimetresPerSecond, MillimetresPerSecondSquared};
use std::fmt;
use std::time::Duration;

/// How to stop a motion.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StopMode {
    /// Decelerate along the motion profile.
    Profiled,
    /// Stop at once.
    Immediate,
}

/// What an axis reports about itself.
#[derive(Debug, Clone, PartialEq)]
pub struct AxisStatus {
    pub position: Millimetres,
    pub moving: bool,
    pub homed: bool,
    /// Names of the status flags that are set ("moving forward", "homed", "motion error", ...),
    /// in the vocabulary of the controller.
    pub flags: Vec<&'static str>,
    /// Flags that mean the axis cannot be trusted (limit hit, motion error, alarm...).
    pub faults: Vec<&'static str>,
}

impl fmt::Display for AxisStatus {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "position {:.4}", self.position)?;
        if self.flags.is_empty() {
            write!(f, ", no status flags set")
        } else {
            write!(f, ", flags: {}", self.flags.join(", "))
        }
    }
}

/// Errors from any axis, naming the axis and its endpoint.
#[derive(Debug, thiserror::Error)]
pub enum AxisError {
    #[error("axis {axis} ({endpoint}): {message}")]
    Device {
        axis: String,
        endpoint: String,
        message: String,
    },
    #[error("axis {axis} ({endpoint}): timed out after {timeout:?} waiting for {what}{}", status_suffix(.flags))]
    Timeout {
        axis: String,
        endpoint: String,
        what: String,
        timeout: Duration,
        flags: Vec<&'static str>,
    },
    /// The controller sent nothing it should have (no reply to a request, no status): it is off,
    /// unplugged, or on another port or address.
    #[error("axis {axis} ({endpoint}): no answer from the controller: {what}")]
    NotAnswering {
        axis: String,
        endpoint: String,
        what: String,
        waited: Duration,
    },
    #[error("axis {axis}: target {target} is not a number of millimetres; nothing was sent")]
    NotANumber { axis: String, target: Millimetres },
    #[error("axis {axis}: target {target:.4} is outside the soft limits {min:.4} .. {max:.4}; nothing was sent (change the target or the limits in the configuration)")]
    SoftLimit {
        axis: String,
        target: Millimetres,
        min: Millimetres,
        max: Millimetres,
    },
    #[error("axis {axis} ({endpoint}): fault while {what}: {}", .flags.join(", "))]
    Fault {
        axis: String,
        endpoint: String,
        what: String,
        flags: Vec<&'static str>,
    },
    #[error("axis {axis} ({endpoint}): configuration mismatch: {message}")]
    Mismatch {
        axis: String,
        endpoint: String,
        message: String,
    },
    #[error("axis {axis} ({endpoint}): link error: {source}")]
    Io {
        axis: String,
        endpoint: String,
        #[source]
        source: std::io::Error,
    },
    #[error("axis {axis}: cancelled by the operator")]
    Cancelled { axis: String },
}

fn status_suffix(flags: &[&'static str]) -> String {
    if flags.is_empty() {
        String::new()
    } else {
        format!(" (status: {})", flags.join(", "))
    }
}

/// Speed and acceleration of trapezoidal moves.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Kinematics {
    pub velocity: MillimetresPerSecond,
    pub acceleration: MillimetresPerSecondSquared,
}

/// Soft limits in millimetres, checked before any move is sent.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SoftLimits {
    pub min: Millimetres,
    pub max: Millimetres,
}

impl SoftLimits {
    /// No limits but finiteness: for axes configured without soft limits.
    pub const UNBOUNDED: SoftLimits = SoftLimits {
        min: Millimetres(f64::MIN),
        max: Millimetres(f64::MAX),
    };
}

/// Soft limits that are not a finite range with min <= max.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
#[error("soft limits min {min} and max {max}: both must be finite numbers with min not above max")]
pub struct InvalidSoftLimits {
    pub min: Millimetres,
    pub max: Millimetres,
}

impl SoftLimits {
    /// Limits from `min` to `max`, refused unless both are finite and `min <= max`.
    pub fn new(min: Millimetres, max: Millimetres) -> Result<SoftLimits, InvalidSoftLimits> {
        if min.0.is_finite() && max.0.is_finite() && min <= max {
            Ok(SoftLimits { min, max })
        } else {
            Err(InvalidSoftLimits { min, max })
        }
    }

    /// Checks `target` against the limits, naming `axis` in the error.
    pub fn check(&self, axis: &str, target: Millimetres) -> Result<(), AxisError> {
        if !target.0.is_finite() {
            return Err(AxisError::NotANumber {
                axis: axis.to_string(),
                target,
            });
        }
        if target >= self.min && target <= self.max {
            Ok(())
        } else {
            Err(AxisError::SoftLimit {
                axis: axis.to_string(),
                target,
                min: self.min,
                max: self.max,
            })
        }
    }
}

/// A linear axis in millimetres.
///
/// Motion is split into `begin_*` (send the command, return at once) and [`Axis::wait_idle`] so a
/// scan can watch the force while the axis moves; the blocking helpers combine the two.
pub trait Axis: Send {
    /// The axis name from configuration ("x", "z", "y").
    fn name(&self) -> &str;

    /// What the axis is connected through, for messages ("serial /dev/ttyUSB0", "manual").
    fn endpoint(&self) -> String;

    /// Starts homing.
    fn begin_home(&mut self) -> Result<(), AxisError>;

    /// Starts an absolute move; soft limits are checked before anything is sent.
    fn begin_move_to(&mut self, target: Millimetres) -> Result<(), AxisError>;

    /// Starts a relative move; the resulting target is checked against the soft limits first.
    fn begin_move_by(&mut self, delta: Millimetres) -> Result<(), AxisError>;

    /// Waits until the current motion has ended, and returns the final status. A timeout leaves
    /// the motion pending: waiting again continues to wait for the same motion.
    fn wait_idle(&mut self, timeout: Duration) -> Result<AxisStatus, AxisError>;

    /// Stops motion.
    fn stop(&mut self, mode: StopMode) -> Result<(), AxisError>;

    /// Current status.
    fn status(&mut self) -> Result<AxisStatus, AxisError>;

    /// Homes and waits.
    fn home(&mut self, timeout: Duration) -> Result<AxisStatus, AxisError> {
        self.begin_home()?;
        self.wait_idle(timeout)
    }

    /// Moves to `target` and waits.
    fn move_to(&mut self, target: Millimetres, timeout: Duration) -> Result<AxisStatus, AxisError> {
        self.begin_move_to(target)?;
        self.wait_idle(timeout)
    }

    /// Moves by `delta` and waits.
    fn move_by(&mut self, delta: Millimetres, timeout: Duration) -> Result<AxisStatus, AxisError> {
        self.begin_move_by(delta)?;
        self.wait_idle(timeout)
    }
}

#[cfg(test)]
mod soft_limit_tests {
    use super::*;

    #[test]
    fn limits_must_be_a_finite_ordered_range() {
        assert!(SoftLimits::new(Millimetres(0.0), Millimetres(10.0)).is_ok());
        assert!(SoftLimits::new(Millimetres(2.0), Millimetres(2.0)).is_ok());
        let err = SoftLimits::new(Millimetres(5.0), Millimetres(1.0)).expect_err("inverted");
        assert!(err.to_string().contains("min not above max"), "{err}");
        assert!(SoftLimits::new(Millimetres(f64::NAN), Millimetres(1.0)).is_err());
        assert!(SoftLimits::new(Millimetres(0.0), Millimetres(f64::INFINITY)).is_err());
    }
}
