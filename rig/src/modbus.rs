//! Modbus motorised stages (the y axis): a pure client codec, register maps from configuration
//! and a driver implementing [`crate::axis::Axis`] over any [`crate::transport::ByteLink`].

pub(crate) mod codec;
pub(crate) mod map;
pub(crate) mod stage;

pub use codec::{
    crc16, decode_response_pdu, match_reply, parse_rtu, parse_tcp, rtu_frame, rtu_silent_interval,
    rtu_wire_time, tcp_frame, Parsed, Request, Response, TcpHeader,
};
pub use map::{Field, Role};

pub use codec::{ExceptionCode, Framing};
pub use map::{MapError, RegisterMap, WordOrder};
pub use stage::{ModbusStage, StageOptions};
