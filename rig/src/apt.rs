//! Thorlabs APT stepper axes (K-Cube KST101/KST201, BSC20x) over the APT serial protocol.
//!
//! - [`ids`]: addresses, message ids and how each id is framed.
//! - [`message`]: the typed messages and packets with their payload blocks.
//! - [`codec`]: pure encode/decode of one APT frame.
//! - [`stream`]: the resynchronising stream decoder (bytes in, packets out, no I/O).
//! - [`status`]: the 32 status bits, by name, with fault classification.
//! - [`actuator`]: actuator table (microsteps per mm, actuator type codes) and unit conversions.
//! - [`driver`]: [`driver::ThorlabsAxis`], the [`crate::axis::Axis`] driver over any
//!   [`crate::transport::ByteLink`].

pub mod actuator;
pub mod codec;
pub mod driver;
pub mod ids;
pub mod message;
pub mod status;
pub mod stream;

pub use actuator::Actuator;
pub use driver::{open_serial, AptConfig, Controller, ThorlabsAxis, Timeouts};
pub use message::{Message, Packet};
pub use status::{LimitPolarity, StatusBits};
pub use stream::StreamDecoder;
