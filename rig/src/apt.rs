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

pub(crate) mod actuator;
pub(crate) mod codec;
pub(crate) mod config;
pub(crate) mod driver;
mod end_of_move;
pub(crate) mod ids;
mod io_thread;
pub(crate) mod message;
mod pending;
pub(crate) mod status;
pub(crate) mod stream;

pub use actuator::{Actuator, OutOfRange, ACCELERATION_SCALE, ACTUATORS, VELOCITY_SCALE};
pub use codec::{decode, encode, frame_len, DecodeError};
pub use config::{
    AptConfig, Controller, HomeConfig, HomeDirection, HomeLimitSwitch, Timeouts, UnknownController,
};
pub use driver::{open_serial, ThorlabsAxis};
pub use ids::{bay_address, HOST, RACK, USB_UNIT};
pub use message::{
    HomeParams, HwInfo, Message, Packet, StatusBlock, StopMode, UStatusBlock, VelParams,
};
pub use status::{
    LimitPolarity, StatusBits, ACTIVE, CHANNEL_ENABLED, COMMUTATION_ERROR, CURRENT_FAULT,
    CURRENT_LIMIT, DIGITAL_INPUT_1, DIGITAL_INPUT_2, DIGITAL_INPUT_3, DIGITAL_INPUT_4,
    ENCODER_FAULT, ERROR, FAULT_MASK, HOMED, HOMING, INITIALISING, INSTRUMENT_ERROR, INTERLOCK,
    JOGGING_FORWARD, JOGGING_REVERSE, LIMIT_BIT0, LIMIT_BIT1, MOTION_ERROR, MOTOR_CONNECTED,
    MOVING_FORWARD, MOVING_REVERSE, OVERCURRENT, OVER_TEMPERATURE, POWER_OK, SETTLED,
    SOFT_LIMIT_BIT2, SOFT_LIMIT_BIT3, TRACKING, VOLTAGE_FAULT,
};
pub use stream::{Decoded, Flow, StreamDecoder};
