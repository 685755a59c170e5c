//! Modbus motorised stages (the y axis): a pure client codec, register maps from configuration
//! and a driver implementing [`crate::axis::Axis`] over any [`crate::transport::ByteLink`].

pub mod codec;
pub mod map;
pub(crate) mod stage;

pub use codec::{ExceptionCode, Framing};
pub use map::{MapError, RegisterMap, WordOrder};
pub use stage::{ModbusStage, StageOptions};
