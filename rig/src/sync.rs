//! Synchronisation: one clock model and the ways to fit it, and exposure-window force labels.
//!
//! - [`clock_map`]: the one clock model of the project, device ticks <-> host nanoseconds (offset
//!   and rate).
//! - [`one_way`]: fitting it from device timestamps and host arrival times (lower convex hull,
//!   TICSync).
//! - [`camera_clock`]: the camera's clock on host time, fitted from frames and latches (where a
//!   frame's exposure lies).
//! - [`latch`]: fitting it from timestamp-latch exchanges (host before, device value, host after).
//! - [`strobe`]: exposure windows found in a sampled exposure-active channel, in sample index.
//! - [`trigger`]: exposure windows of a camera triggered by the DAQ's counter, in sample index.
//! - [`method`]: the synchronisation methods (strobe, trigger, clock-fit, host).
//! - [`window`]: the force averaged over an exposure window (interpolated at the edges).
//!
//! Methods and facts: docs of the shared project, hardware.md section E.

pub(crate) mod camera_clock;
pub(crate) mod clock_map;
pub(crate) mod latch;
pub(crate) mod method;
pub(crate) mod one_way;
pub(crate) mod strobe;
pub(crate) mod trigger;
pub(crate) mod window;
