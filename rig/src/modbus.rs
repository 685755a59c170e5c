//! Modbus motorised stages (the y axis): a pure client codec, register maps from configuration
//! and a driver implementing [`crate::axis::Axis`] over any [`crate::transport::ByteLink`].

pub(crate) mod codec;
pub(crate) mod map;
pub(crate) mod stage;

pub use codec::{
    crc16, decode_response_pdu, match_reply, parse_rtu, parse_tcp, rtu_frame, rtu_silent_interval,
    rtu_wire_time, tcp_frame, CodecError, ExceptionCode, Framing, Parsed, Reply, Request, Response,
    TcpHeader,
};
pub use map::{
    Field, Homing, MapError, Operation, Profile, RegisterMap, Registers, Role, SerialConfig,
    Status, StatusBit, Trigger, WordOrder, Write,
};
pub use stage::{ModbusStage, StageOptions};
