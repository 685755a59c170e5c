//! Thorlabs APT stepper axes (K-Cube KST101/KST201, BSC20x) over the APT serial protocol.
//!
//! - [`codec`]: pure encode/decode of APT frames and a resynchronising stream decoder.
//! - [`status`]: the 32 status bits, by name, with fault classification.
//! - [`actuator`]: actuator table (microsteps per mm, actuator type codes) and unit conversions.
//! - [`driver`]: [`driver::ThorlabsAxis`], the [`crate::axis::Axis`] driver over any
//!   [`crate::transport::ByteLink`].

pub mod actuator;
pub mod codec;
pub mod driver;
pub mod status;

pub use actuator::Actuator;
pub use codec::{Message, Packet, StreamDecoder};
pub use driver::{open_serial, AptConfig, Controller, ThorlabsAxis, Timeouts};
pub use status::{LimitPolarity, StatusBits};
