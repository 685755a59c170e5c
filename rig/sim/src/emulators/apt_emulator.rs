//! An emulated Thorlabs APT stepper controller (KST101, or one channel of a BSC20x rack) that
//! speaks the real protocol, so the real driver ([`fringe_rig::ThorlabsAxis`]) and third-party
//! software run against it unchanged.
//!
//! - [`core`]: the controller logic (host packets in, replies out, time passed in): identity,
//!   channel enable, actuator type, velocity/home/move parameters, position counter, homing,
//!   absolute and relative moves (with and without parameters), profiled and immediate stops,
//!   status requests, and update messages about every 100 ms that stop when the
//!   MOT_ACK_USTATUSUPDATE keep-alive is withheld (K-Cube) or after 5 s regardless (BSC20x).
//!   Motion is a shared [`crate::physics::motion::SimMotor`], in the configured actuator's scale.
//! - [`server`]: runs the core on a thread over any [`fringe_rig::ByteLink`] (in-process
//!   pair or pseudo-terminal) and returns a handle with counters and stop.
//!
//! Unknown messages are skipped whole and counted; garbage is dropped a byte at a time by the
//! codec's resynchronising stream decoder.

pub(crate) mod core;
pub(crate) mod server;

pub use self::core::{AptEmulatorConfig, KeepAlive};
pub use self::server::{AptEmulator, AptEmulatorHandle};
