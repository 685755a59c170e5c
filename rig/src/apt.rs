//! Thorlabs APT stepper axes (K-Cube KST101/KST201, BSC20x) over the APT serial protocol.
//!
//! - [`ids`]: addresses, message ids and how each id is framed.
//! - [`message`]: the typed messages and packets with their payload blocks.
//! - [`codec`]: pure encode/decode of one APT frame.
//! - [`stream`]: the resynchronising stream decoder (bytes in, packets out, no I/O).
//! - [`status`]: the 32 status bits, by name, with fault classification.
//! - [`actuator`]: actuator table (microsteps per mm, actuator type codes) and unit conversions.
//! - [`config`]: how an axis is configured ([`config::AptConfig`]: controller, actuator, homing,
//!   timeouts).
//! - [`driver`]: [`driver::ThorlabsAxis`], the [`crate::axis::Axis`] driver over any
//!   [`crate::transport::ByteLink`]; its I/O thread in `io_thread`, the motion it waits for in
//!   `pending` and the end of that motion in `end_of_move`.

pub mod actuator;
pub mod codec;
pub mod config;
pub mod driver;
mod end_of_move;
pub mod ids;
mod io_thread;
pub mod message;
mod pending;
pub mod status;
pub mod stream;

pub use actuator::Actuator;
pub use config::{AptConfig, Controller, Timeouts};
pub use driver::{open_serial, ThorlabsAxis};
pub use message::{Message, Packet};
pub use status::{LimitPolarity, StatusBits};
pub use stream::StreamDecoder;
