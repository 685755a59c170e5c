//! How a Thorlabs APT axis is configured: the controller ([`Controller`]), its homing
//! ([`HomeConfig`]), the driver's timeouts ([`Timeouts`]) and the whole axis ([`AptConfig`]).

use super::actuator::Actuator;
use super::ids::{bay_address, USB_UNIT};
use super::status::LimitPolarity;
use crate::axis::SoftLimits;
use crate::units::{Millimetres, MillimetresPerSecond, MillimetresPerSecondSquared};
use std::fmt;
use std::str::FromStr;
use std::time::Duration;

/// The controller model.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Controller {
    Kst101,
    Kst201,
    Bsc201,
    Bsc202,
    Bsc203,
}

impl Controller {
    /// K-Cubes run on update messages with a keep-alive; BSC20x are polled.
    pub fn uses_update_messages(self) -> bool {
        matches!(self, Controller::Kst101 | Controller::Kst201)
    }

    /// The address of this controller: K-Cubes and a BSC201 without a bay are the USB unit
    /// 0x50; a BSC202/203 channel is a rack bay (0x21 + bay, bay 0 by default).
    pub fn address(self, bay: Option<u8>) -> Option<u8> {
        match (self, bay) {
            (Controller::Kst101 | Controller::Kst201, _) => Some(USB_UNIT),
            (Controller::Bsc201, None) => Some(USB_UNIT),
            (_, Some(b)) => bay_address(b),
            (_, None) => bay_address(0),
        }
    }
}

/// A controller name that is not one of the supported models.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("unknown Thorlabs controller `{0}` (use kst101, kst201, bsc201, bsc202 or bsc203)")]
pub struct UnknownController(pub String);

impl FromStr for Controller {
    type Err = UnknownController;
    fn from_str(s: &str) -> Result<Self, UnknownController> {
        match s.to_ascii_lowercase().as_str() {
            "kst101" => Ok(Controller::Kst101),
            "kst201" => Ok(Controller::Kst201),
            "bsc201" => Ok(Controller::Bsc201),
            "bsc202" => Ok(Controller::Bsc202),
            "bsc203" => Ok(Controller::Bsc203),
            other => Err(UnknownController(other.to_string())),
        }
    }
}

impl fmt::Display for Controller {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Controller::Kst101 => "KST101",
            Controller::Kst201 => "KST201",
            Controller::Bsc201 => "BSC201",
            Controller::Bsc202 => "BSC202",
            Controller::Bsc203 => "BSC203",
        })
    }
}

/// Direction of the homing run.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum HomeDirection {
    Forward = 1,
    Reverse = 2,
}

/// Limit switch the homing run looks for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum HomeLimitSwitch {
    Reverse = 1,
    Forward = 4,
}

/// Home parameters, in millimetres.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HomeConfig {
    pub direction: HomeDirection,
    pub limit_switch: HomeLimitSwitch,
    pub velocity: MillimetresPerSecond,
    pub offset: Millimetres,
}

/// Timing of the driver.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Timeouts {
    /// How long to wait for the reply to a request.
    pub reply: Duration,
    /// Status poll period while waiting for a BSC20x move.
    pub poll_period: Duration,
    /// Period of MOT_ACK_USTATUSUPDATE on K-Cubes (the controller needs one at least every
    /// second).
    pub keepalive_period: Duration,
    /// How long the I/O thread blocks in one read before looking at commands again.
    pub read_slice: Duration,
}

impl Default for Timeouts {
    fn default() -> Self {
        Timeouts {
            reply: Duration::from_secs(2),
            poll_period: Duration::from_millis(100),
            keepalive_period: Duration::from_millis(900),
            read_slice: Duration::from_millis(5),
        }
    }
}

/// Configuration of one Thorlabs axis.
#[derive(Debug, Clone, PartialEq)]
pub struct AptConfig {
    /// Axis name ("x", "z", "y").
    pub axis: String,
    pub controller: Controller,
    /// Rack bay (0..=9) of a BSC20x channel; `None` for K-Cubes and a BSC201 as a USB unit.
    pub bay: Option<u8>,
    /// Channel ident in messages (1 for single-channel units and bays).
    pub channel: u8,
    pub actuator: Actuator,
    pub velocity: MillimetresPerSecond,
    pub acceleration: MillimetresPerSecondSquared,
    pub home: HomeConfig,
    pub soft_limits: Option<SoftLimits>,
    pub limit_polarity: LimitPolarity,
    pub timeouts: Timeouts,
}

impl AptConfig {
    /// A configuration with conservative defaults: 1 mm/s, 1 mm/s^2, homing in reverse onto the
    /// reverse limit at 1 mm/s with no offset, no soft limits.
    pub fn new(axis: &str, controller: Controller, actuator: Actuator) -> Self {
        AptConfig {
            axis: axis.to_string(),
            controller,
            bay: None,
            channel: 1,
            actuator,
            velocity: MillimetresPerSecond(1.0),
            acceleration: MillimetresPerSecondSquared(1.0),
            home: HomeConfig {
                direction: HomeDirection::Reverse,
                limit_switch: HomeLimitSwitch::Reverse,
                velocity: MillimetresPerSecond(1.0),
                offset: Millimetres(0.0),
            },
            soft_limits: None,
            limit_polarity: LimitPolarity::Bit0Forward,
            timeouts: Timeouts::default(),
        }
    }
}
