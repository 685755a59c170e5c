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
    /// A move the axis cannot make as asked (a speed above its configured one, a stage moved
    /// by hand asked for a speed).
    #[error("axis {axis}: {message}")]
    Motion { axis: String, message: String },
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

impl Kinematics {
    /// Refuses a motion that is not a positive speed and acceleration within `limit` (the
    /// axis's configured kinematics), naming `axis`; nothing is sent then.
    pub fn check_within(&self, axis: &str, limit: &Kinematics) -> Result<(), AxisError> {
        let (v, a) = (self.velocity.0, self.acceleration.0);
        if !(v.is_finite() && v > 0.0 && a.is_finite() && a > 0.0) {
            return Err(AxisError::Motion {
                axis: axis.to_string(),
                message: format!(
                    "speed {v} mm/s and acceleration {a} mm/s² must be positive numbers; nothing was sent"
                ),
            });
        }
        // A rounding of the limit's own value is not above it.
        let above = |x: f64, max: f64| x > max * (1.0 + 1e-9);
        if above(v, limit.velocity.0) || above(a, limit.acceleration.0) {
            return Err(AxisError::Motion {
                axis: axis.to_string(),
                message: format!(
                    "speed {v:.4} mm/s and acceleration {a:.4} mm/s² exceed the configured {:.4} mm/s and {:.4} mm/s²; nothing was sent (lower them, or raise the axis's configured kinematics)",
                    limit.velocity.0, limit.acceleration.0
                ),
            });
        }
        Ok(())
    }

    /// How far a rest-to-rest trapezoidal move of `distance` (mm, either sign) has gone after
    /// `elapsed` seconds: where a stepper controller that was sent the move puts the axis.
    pub fn travelled(&self, distance: f64, elapsed: f64) -> f64 {
        let d = distance.abs();
        let (v, a) = (
            self.velocity.0.abs().max(1e-12),
            self.acceleration.0.abs().max(1e-12),
        );
        let t = elapsed.max(0.0);
        // The peak speed: the cruise speed, or less on a move too short to reach it.
        let peak = v.min((a * d).sqrt());
        let ramp = peak / a;
        let ramp_d = 0.5 * a * ramp * ramp;
        let cruise = (d - 2.0 * ramp_d).max(0.0) / peak;
        let s = if t <= ramp {
            0.5 * a * t * t
        } else if t <= ramp + cruise {
            ramp_d + peak * (t - ramp)
        } else {
            let u = (t - ramp - cruise).min(ramp);
            ramp_d + peak * cruise + peak * u - 0.5 * a * u * u
        };
        s.min(d) * distance.signum()
    }

    /// The time a rest-to-rest trapezoidal move of `distance` takes, s.
    pub fn move_seconds(&self, distance: f64) -> f64 {
        let d = distance.abs();
        let (v, a) = (
            self.velocity.0.abs().max(1e-9),
            self.acceleration.0.abs().max(1e-9),
        );
        if d <= v * v / a {
            2.0 * (d / a).sqrt()
        } else {
            d / v + v / a
        }
    }
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

    /// Starts an absolute move at `motion` (speed and acceleration) instead of the configured
    /// kinematics, for this move only (a slide under force control); later moves go at the
    /// configured kinematics again. Refused, nothing sent, for a motion above the configured one
    /// ([`Kinematics::check_within`]) or on an axis that cannot set its speed.
    fn begin_move_to_at(
        &mut self,
        target: Millimetres,
        motion: Kinematics,
    ) -> Result<(), AxisError>;

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
mod kinematics_tests {
    use super::*;

    fn k(v: f64, a: f64) -> Kinematics {
        Kinematics {
            velocity: MillimetresPerSecond(v),
            acceleration: MillimetresPerSecondSquared(a),
        }
    }

    #[test]
    fn a_trapezoid_ramps_cruises_and_ends_where_it_was_sent() {
        // 2 mm/s, 4 mm/s²: 0.5 s of ramp (0.5 mm) each end, 4 mm of cruise (2 s).
        let m = k(2.0, 4.0);
        assert!((m.move_seconds(5.0) - 3.0).abs() < 1e-12);
        assert!((m.travelled(5.0, 0.25) - 0.125).abs() < 1e-12);
        assert!((m.travelled(5.0, 1.5) - 2.5).abs() < 1e-12);
        assert!((m.travelled(5.0, 2.75) - (5.0 - 0.125)).abs() < 1e-12);
        assert_eq!(m.travelled(5.0, 10.0), 5.0);
        assert_eq!(m.travelled(-5.0, 10.0), -5.0);
        assert!((m.travelled(-5.0, 1.5) + 2.5).abs() < 1e-12);
        // Too short to reach the speed: a triangle, half way at half time.
        let short = m.move_seconds(0.5);
        assert!((m.travelled(0.5, short / 2.0) - 0.25).abs() < 1e-12);
        assert_eq!(m.travelled(5.0, -1.0), 0.0);
    }

    #[test]
    fn motions_above_the_configured_ones_are_refused_naming_the_axis() {
        let limit = k(2.0, 4.0);
        assert!(k(2.0, 4.0).check_within("x", &limit).is_ok());
        assert!(k(0.5, 1.0).check_within("x", &limit).is_ok());
        let e = k(3.0, 4.0).check_within("x", &limit).expect_err("too fast");
        assert!(
            e.to_string().starts_with("axis x: speed 3.0000 mm/s"),
            "{e}"
        );
        assert!(k(1.0, 5.0).check_within("x", &limit).is_err());
        assert!(k(0.0, 1.0).check_within("x", &limit).is_err());
        assert!(k(f64::NAN, 1.0).check_within("x", &limit).is_err());
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
