//! Modbus client codec: requests out, responses in, for RTU and TCP framing. Pure, no I/O.
//!
//! Only the three function codes a stage needs are supported: 0x03 read holding registers, 0x06
//! write single register and 0x10 write multiple registers. Exception responses are decoded with
//! their meaning. The parsers take whatever bytes have arrived so far and say whether a whole frame
//! is there; they never panic, whatever the input.

use std::fmt;
use std::time::Duration;

/// Most registers one read may ask for (Modbus application protocol, 6.3).
pub(crate) const MAX_READ: u16 = 125;
/// Most registers one write-multiple may carry (6.12).
pub(crate) const MAX_WRITE: u16 = 123;

/// Bits per RTU character on the wire: start, 8 data, parity (or a second stop bit) and stop.
/// The Modbus serial line specification (V1.02, 2.5.1) counts 11 whatever the parity.
pub(crate) const RTU_BITS_PER_CHARACTER: u32 = 11;

/// How long `bytes` characters take on an RTU line at `baud`.
pub fn rtu_wire_time(baud: u32, bytes: usize) -> Duration {
    let baud = u64::from(baud.max(1));
    Duration::from_nanos(bytes as u64 * u64::from(RTU_BITS_PER_CHARACTER) * 1_000_000_000 / baud)
}

/// The silent interval that separates RTU frames: 3.5 character times, fixed at 1.75 ms above
/// 19200 baud (Modbus serial line specification V1.02, 2.5.1.1). A frame sent sooner after the
/// previous one on the line is, for the devices on it, part of that one: a broken frame.
pub fn rtu_silent_interval(baud: u32) -> Duration {
    if baud > 19_200 {
        Duration::from_micros(1750)
    } else {
        rtu_wire_time(baud, 7) / 2
    }
}

/// How Modbus frames travel.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Framing {
    /// Serial line: slave address, PDU, CRC-16 (low byte first).
    Rtu,
    /// TCP: MBAP header (transaction id, protocol 0, length, unit id), then the PDU.
    Tcp,
}

impl fmt::Display for Framing {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Framing::Rtu => "Modbus RTU",
            Framing::Tcp => "Modbus TCP",
        })
    }
}

/// A client request.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Request {
    /// Function 0x03.
    ReadHolding { start: u16, count: u16 },
    /// Function 0x06.
    WriteSingle { address: u16, value: u16 },
    /// Function 0x10.
    WriteMultiple { start: u16, values: Vec<u16> },
}

impl Request {
    /// The function code.
    pub fn function(&self) -> u8 {
        match self {
            Request::ReadHolding { .. } => 0x03,
            Request::WriteSingle { .. } => 0x06,
            Request::WriteMultiple { .. } => 0x10,
        }
    }

    /// Checks the request fits the protocol limits.
    pub fn validate(&self) -> Result<(), CodecError> {
        match self {
            Request::ReadHolding { count, .. } if *count == 0 || *count > MAX_READ => {
                Err(CodecError::BadRequest(format!(
                    "a read must ask for 1..={MAX_READ} registers, not {count}"
                )))
            }
            Request::WriteMultiple { values, .. }
                if values.is_empty() || values.len() > MAX_WRITE as usize =>
            {
                Err(CodecError::BadRequest(format!(
                    "a write-multiple must carry 1..={MAX_WRITE} registers, not {}",
                    values.len()
                )))
            }
            _ => Ok(()),
        }
    }
}

impl fmt::Display for Request {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Request::ReadHolding { start, count } => {
                write!(f, "read holding registers 0x{start:04X} x{count}")
            }
            Request::WriteSingle { address, value } => {
                write!(f, "write register 0x{address:04X} = {value}")
            }
            Request::WriteMultiple { start, values } => {
                write!(f, "write registers 0x{start:04X} x{}", values.len())
            }
        }
    }
}

/// A Modbus exception code, as returned in an exception response.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ExceptionCode(pub u8);

impl ExceptionCode {
    /// The meaning of the code (Modbus application protocol, section 7).
    pub fn meaning(self) -> &'static str {
        match self.0 {
            0x01 => "illegal function: the device does not support this function code",
            0x02 => "illegal data address: a register in the request does not exist on the device (check the register map)",
            0x03 => "illegal data value: the device rejected a value or the register count (check the map's units and ranges)",
            0x04 => "server device failure: the device hit an unrecoverable error while acting on the request",
            0x05 => "acknowledge: the device accepted a long-running request and is still processing it",
            0x06 => "server device busy: the device is processing a long command; retry later",
            0x08 => "memory parity error",
            0x0A => "gateway path unavailable: the gateway has no path to the addressed slave",
            0x0B => "gateway target device failed to respond: check the slave id and the serial side of the gateway",
            _ => "unknown exception code",
        }
    }
}

impl fmt::Display for ExceptionCode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "exception 0x{:02X} ({})", self.0, self.meaning())
    }
}

/// A server response, as decoded from the wire.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Response {
    /// Function 0x03: the register values.
    ReadHolding(Vec<u16>),
    /// Function 0x06: the echoed address and value.
    WriteSingle { address: u16, value: u16 },
    /// Function 0x10: the echoed start and count.
    WriteMultiple { start: u16, count: u16 },
    /// An exception response to `function`.
    Exception { function: u8, code: ExceptionCode },
}

/// What a parser found in the bytes received so far.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Parsed<H> {
    /// More bytes are needed.
    Incomplete,
    /// A whole frame: its header (slave id for RTU, [`TcpHeader`] for TCP), the response and how
    /// many bytes it used.
    Frame {
        header: H,
        response: Response,
        len: usize,
    },
}

/// The MBAP header of a TCP frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TcpHeader {
    pub transaction: u16,
    pub unit: u8,
}

/// Bytes that are not a valid Modbus frame, or a response that does not answer the request.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum CodecError {
    #[error("CRC mismatch: frame says 0x{received:04X}, bytes give 0x{computed:04X} (noise on the line, or wrong baud/parity)")]
    Crc { received: u16, computed: u16 },
    #[error("unsupported function code 0x{0:02X} in the reply")]
    UnsupportedFunction(u8),
    #[error("malformed reply: {0}")]
    Malformed(String),
    #[error("reply does not answer the request: {0}")]
    Mismatch(String),
    #[error("invalid request: {0}")]
    BadRequest(String),
}

/// CRC-16/MODBUS (polynomial 0xA001 reflected, initial 0xFFFF). Sent low byte first.
pub fn crc16(bytes: &[u8]) -> u16 {
    let mut crc: u16 = 0xFFFF;
    for &b in bytes {
        crc ^= u16::from(b);
        for _ in 0..8 {
            crc = if crc & 1 != 0 {
                (crc >> 1) ^ 0xA001
            } else {
                crc >> 1
            };
        }
    }
    crc
}

/// The protocol data unit (function code and data) of a request.
pub(crate) fn encode_request_pdu(request: &Request) -> Vec<u8> {
    let mut pdu = vec![request.function()];
    match request {
        Request::ReadHolding { start, count } => {
            pdu.extend_from_slice(&start.to_be_bytes());
            pdu.extend_from_slice(&count.to_be_bytes());
        }
        Request::WriteSingle { address, value } => {
            pdu.extend_from_slice(&address.to_be_bytes());
            pdu.extend_from_slice(&value.to_be_bytes());
        }
        Request::WriteMultiple { start, values } => {
            pdu.extend_from_slice(&start.to_be_bytes());
            let n = values.len().min(MAX_WRITE as usize);
            pdu.extend_from_slice(&(n as u16).to_be_bytes());
            pdu.push((n * 2) as u8);
            for v in &values[..n] {
                pdu.extend_from_slice(&v.to_be_bytes());
            }
        }
    }
    pdu
}

/// The protocol data unit of a response (used by simulators and tests).
#[cfg(test)]
pub(crate) fn encode_response_pdu(response: &Response) -> Vec<u8> {
    match response {
        Response::ReadHolding(values) => {
            let n = values.len().min(MAX_READ as usize);
            let mut pdu = vec![0x03, (n * 2) as u8];
            for v in &values[..n] {
                pdu.extend_from_slice(&v.to_be_bytes());
            }
            pdu
        }
        Response::WriteSingle { address, value } => {
            let mut pdu = vec![0x06];
            pdu.extend_from_slice(&address.to_be_bytes());
            pdu.extend_from_slice(&value.to_be_bytes());
            pdu
        }
        Response::WriteMultiple { start, count } => {
            let mut pdu = vec![0x10];
            pdu.extend_from_slice(&start.to_be_bytes());
            pdu.extend_from_slice(&count.to_be_bytes());
            pdu
        }
        Response::Exception { function, code } => vec![function | 0x80, code.0],
    }
}

/// Wraps a PDU in an RTU frame for `slave`.
pub fn rtu_frame(slave: u8, pdu: &[u8]) -> Vec<u8> {
    let mut frame = Vec::with_capacity(pdu.len() + 3);
    frame.push(slave);
    frame.extend_from_slice(pdu);
    let crc = crc16(&frame);
    frame.extend_from_slice(&crc.to_le_bytes());
    frame
}

/// Wraps a PDU in a TCP frame (MBAP header).
pub fn tcp_frame(header: TcpHeader, pdu: &[u8]) -> Vec<u8> {
    let mut frame = Vec::with_capacity(pdu.len() + 7);
    frame.extend_from_slice(&header.transaction.to_be_bytes());
    frame.extend_from_slice(&[0, 0]);
    frame.extend_from_slice(&((pdu.len() + 1) as u16).to_be_bytes());
    frame.push(header.unit);
    frame.extend_from_slice(pdu);
    frame
}

/// An RTU request frame.
pub(crate) fn encode_rtu(slave: u8, request: &Request) -> Vec<u8> {
    rtu_frame(slave, &encode_request_pdu(request))
}

/// A TCP request frame.
pub(crate) fn encode_tcp(header: TcpHeader, request: &Request) -> Vec<u8> {
    tcp_frame(header, &encode_request_pdu(request))
}

/// Length of the response PDU starting at `pdu[0]`, if enough bytes are there to know it.
fn response_pdu_len(pdu: &[u8]) -> Result<Option<usize>, CodecError> {
    let Some(&function) = pdu.first() else {
        return Ok(None);
    };
    match function {
        0x03 => Ok(pdu.get(1).map(|&n| 2 + n as usize)),
        0x06 | 0x10 => Ok(Some(5)),
        f if f & 0x80 != 0 => Ok(Some(2)),
        f => Err(CodecError::UnsupportedFunction(f)),
    }
}

/// Decodes a complete response PDU.
pub fn decode_response_pdu(pdu: &[u8]) -> Result<Response, CodecError> {
    let word = |i: usize| -> Result<u16, CodecError> {
        match (pdu.get(i), pdu.get(i + 1)) {
            (Some(&h), Some(&l)) => Ok(u16::from_be_bytes([h, l])),
            _ => Err(CodecError::Malformed(format!(
                "reply PDU of {} bytes is too short",
                pdu.len()
            ))),
        }
    };
    let Some(&function) = pdu.first() else {
        return Err(CodecError::Malformed("empty reply PDU".into()));
    };
    let expected = response_pdu_len(pdu)?;
    if expected != Some(pdu.len()) {
        return Err(CodecError::Malformed(format!(
            "reply PDU for function 0x{function:02X} has {} bytes, expected {}",
            pdu.len(),
            expected.map_or_else(|| "more".to_string(), |n| n.to_string())
        )));
    }
    match function {
        0x03 => {
            let n = pdu.get(1).copied().unwrap_or(0) as usize;
            if n & 1 != 0 {
                return Err(CodecError::Malformed(format!(
                    "odd byte count {n} in a register read reply"
                )));
            }
            (0..n / 2)
                .map(|i| word(2 + 2 * i))
                .collect::<Result<Vec<_>, _>>()
                .map(Response::ReadHolding)
        }
        0x06 => Ok(Response::WriteSingle {
            address: word(1)?,
            value: word(3)?,
        }),
        0x10 => Ok(Response::WriteMultiple {
            start: word(1)?,
            count: word(3)?,
        }),
        f => Ok(Response::Exception {
            function: f & 0x7F,
            code: ExceptionCode(pdu.get(1).copied().unwrap_or(0)),
        }),
    }
}

/// Parses an RTU response from the start of `buf`; the header is the slave id.
pub fn parse_rtu(buf: &[u8]) -> Result<Parsed<u8>, CodecError> {
    let Some(&slave) = buf.first() else {
        return Ok(Parsed::Incomplete);
    };
    let pdu_len = match response_pdu_len(&buf[1..])? {
        Some(n) => n,
        None => return Ok(Parsed::Incomplete),
    };
    let len = 1 + pdu_len + 2;
    if buf.len() < len {
        return Ok(Parsed::Incomplete);
    }
    let computed = crc16(&buf[..len - 2]);
    let received = u16::from_le_bytes([buf[len - 2], buf[len - 1]]);
    if computed != received {
        return Err(CodecError::Crc { received, computed });
    }
    let response = decode_response_pdu(&buf[1..len - 2])?;
    Ok(Parsed::Frame {
        header: slave,
        response,
        len,
    })
}

/// Parses a TCP response from the start of `buf`.
pub fn parse_tcp(buf: &[u8]) -> Result<Parsed<TcpHeader>, CodecError> {
    if buf.len() < 7 {
        return Ok(Parsed::Incomplete);
    }
    let transaction = u16::from_be_bytes([buf[0], buf[1]]);
    let protocol = u16::from_be_bytes([buf[2], buf[3]]);
    let length = u16::from_be_bytes([buf[4], buf[5]]) as usize;
    if protocol != 0 {
        return Err(CodecError::Malformed(format!(
            "MBAP protocol id {protocol}, expected 0 (is this a Modbus TCP port?)"
        )));
    }
    if !(2..=254).contains(&length) {
        return Err(CodecError::Malformed(format!(
            "MBAP length {length} is outside 2..=254"
        )));
    }
    let len = 6 + length;
    if buf.len() < len {
        return Ok(Parsed::Incomplete);
    }
    let response = decode_response_pdu(&buf[7..len])?;
    Ok(Parsed::Frame {
        header: TcpHeader {
            transaction,
            unit: buf[6],
        },
        response,
        len,
    })
}

/// What a successful reply carried.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Reply {
    /// Register values of a read.
    Registers(Vec<u16>),
    /// A write was acknowledged.
    Written,
    /// The device refused the request.
    Exception(ExceptionCode),
}

/// Checks that `response` answers `request` (function, counts, echoes).
pub fn match_reply(request: &Request, response: &Response) -> Result<Reply, CodecError> {
    match (request, response) {
        (_, Response::Exception { function, code }) => {
            if *function == request.function() {
                Ok(Reply::Exception(*code))
            } else {
                Err(CodecError::Mismatch(format!(
                    "exception for function 0x{function:02X}, but the request was function 0x{:02X}",
                    request.function()
                )))
            }
        }
        (Request::ReadHolding { count, .. }, Response::ReadHolding(values)) => {
            if values.len() == *count as usize {
                Ok(Reply::Registers(values.clone()))
            } else {
                Err(CodecError::Mismatch(format!(
                    "asked for {count} registers, got {}",
                    values.len()
                )))
            }
        }
        (
            Request::WriteSingle { address, value },
            Response::WriteSingle {
                address: a,
                value: v,
            },
        ) => {
            if (address, value) == (a, v) {
                Ok(Reply::Written)
            } else {
                Err(CodecError::Mismatch(format!(
                    "wrote 0x{address:04X} = {value}, device echoed 0x{a:04X} = {v}"
                )))
            }
        }
        (Request::WriteMultiple { start, values }, Response::WriteMultiple { start: s, count }) => {
            if *start == *s && values.len() == *count as usize {
                Ok(Reply::Written)
            } else {
                Err(CodecError::Mismatch(format!(
                    "wrote {} registers at 0x{start:04X}, device echoed {count} at 0x{s:04X}",
                    values.len()
                )))
            }
        }
        (req, resp) => Err(CodecError::Mismatch(format!(
            "request was {req}, reply was {resp:?}"
        ))),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn silent_interval_follows_the_serial_line_specification() {
        // 3.5 characters of 11 bits: 4.01 ms at 9600 baud, 2.005 ms at 19200, then 1.75 ms.
        assert_eq!(rtu_silent_interval(9600), Duration::from_nanos(4_010_416));
        assert_eq!(rtu_silent_interval(19_200), Duration::from_nanos(2_005_208));
        assert_eq!(rtu_silent_interval(38_400), Duration::from_micros(1750));
        assert_eq!(rtu_silent_interval(115_200), Duration::from_micros(1750));
        assert_eq!(rtu_wire_time(38_400, 8), Duration::from_nanos(2_291_666));
    }

    fn hex(s: &str) -> Vec<u8> {
        crate::trace::format::parse_hex(s).expect("hex")
    }

    #[test]
    fn read_request_matches_the_spec_example() {
        // Modbus over serial line, the classic example: slave 1, read 10 registers from 0.
        let frame = encode_rtu(
            1,
            &Request::ReadHolding {
                start: 0,
                count: 10,
            },
        );
        assert_eq!(frame, hex("01 03 00 00 00 0A C5 CD"));
        assert_eq!(crc16(&hex("01 03 00 00 00 0A")), 0xCDC5);
    }

    #[test]
    fn crc_of_known_frames() {
        // Write single register 0x0001 = 0x0003 on slave 0x11: CRC 9A 9B (spec example).
        assert_eq!(
            encode_rtu(
                0x11,
                &Request::WriteSingle {
                    address: 1,
                    value: 3
                }
            ),
            hex("11 06 00 01 00 03 9A 9B")
        );
        // CRC-16/MODBUS check value for "123456789".
        assert_eq!(crc16(b"123456789"), 0x4B37);
    }

    #[test]
    fn write_multiple_request_layout() {
        let req = Request::WriteMultiple {
            start: 0x0001,
            values: vec![0x000A, 0x0102],
        };
        assert_eq!(
            encode_request_pdu(&req),
            hex("10 00 01 00 02 04 00 0A 01 02")
        );
        let tcp = encode_tcp(
            TcpHeader {
                transaction: 0x1234,
                unit: 7,
            },
            &req,
        );
        assert_eq!(
            tcp,
            hex("12 34 00 00 00 0B 07 10 00 01 00 02 04 00 0A 01 02")
        );
    }

    #[test]
    fn parses_rtu_read_reply_in_pieces() {
        let frame = rtu_frame(1, &hex("03 04 00 01 FF FE"));
        for cut in 0..frame.len() {
            assert_eq!(
                parse_rtu(&frame[..cut]),
                Ok(Parsed::Incomplete),
                "cut at {cut}"
            );
        }
        assert_eq!(
            parse_rtu(&frame),
            Ok(Parsed::Frame {
                header: 1,
                response: Response::ReadHolding(vec![1, 0xFFFE]),
                len: frame.len()
            })
        );
    }

    #[test]
    fn rtu_crc_error_is_reported() {
        let mut frame = rtu_frame(1, &hex("06 00 01 00 03"));
        frame[3] ^= 0x40;
        assert!(matches!(parse_rtu(&frame), Err(CodecError::Crc { .. })));
    }

    #[test]
    fn exception_reply_is_decoded_with_meaning() {
        let frame = hex("00 05 00 00 00 03 01 90 02");
        let Ok(Parsed::Frame {
            header,
            response,
            len,
        }) = parse_tcp(&frame)
        else {
            panic!("not a frame");
        };
        assert_eq!((header.transaction, header.unit, len), (5, 1, 9));
        let req = Request::WriteMultiple {
            start: 0,
            values: vec![1],
        };
        let reply = match_reply(&req, &response).expect("matches");
        assert_eq!(reply, Reply::Exception(ExceptionCode(2)));
        assert!(ExceptionCode(2)
            .to_string()
            .contains("illegal data address"));
    }

    #[test]
    fn mismatched_echo_is_an_error() {
        let req = Request::WriteSingle {
            address: 1,
            value: 2,
        };
        let resp = Response::WriteSingle {
            address: 1,
            value: 3,
        };
        assert!(matches!(
            match_reply(&req, &resp),
            Err(CodecError::Mismatch(_))
        ));
        let read = Request::ReadHolding { start: 0, count: 2 };
        assert!(match_reply(&read, &Response::ReadHolding(vec![1])).is_err());
    }

    #[test]
    fn tcp_rejects_foreign_protocol_id() {
        assert!(matches!(
            parse_tcp(&hex("00 01 00 07 00 03 01 03 00")),
            Err(CodecError::Malformed(_))
        ));
    }

    #[test]
    fn request_limits() {
        assert!(Request::ReadHolding {
            start: 0,
            count: 126
        }
        .validate()
        .is_err());
        assert!(Request::WriteMultiple {
            start: 0,
            values: vec![]
        }
        .validate()
        .is_err());
        assert!(Request::ReadHolding {
            start: 0,
            count: 125
        }
        .validate()
        .is_ok());
    }

    fn any_response() -> impl Strategy<Value = Response> {
        prop_oneof![
            proptest::collection::vec(any::<u16>(), 1..=125).prop_map(Response::ReadHolding),
            (any::<u16>(), any::<u16>())
                .prop_map(|(address, value)| Response::WriteSingle { address, value }),
            (any::<u16>(), any::<u16>())
                .prop_map(|(start, count)| Response::WriteMultiple { start, count }),
            (prop_oneof![Just(3u8), Just(6), Just(16)], any::<u8>()).prop_map(|(function, c)| {
                Response::Exception {
                    function,
                    code: ExceptionCode(c),
                }
            }),
        ]
    }

    proptest! {
        #[test]
        fn parsers_never_panic_on_garbage(bytes in proptest::collection::vec(any::<u8>(), 0..300)) {
            let _ = parse_rtu(&bytes);
            let _ = parse_tcp(&bytes);
            let _ = decode_response_pdu(&bytes);
        }

        #[test]
        fn rtu_round_trip(slave in any::<u8>(), response in any_response()) {
            let frame = rtu_frame(slave, &encode_response_pdu(&response));
            prop_assert_eq!(parse_rtu(&frame), Ok(Parsed::Frame { header: slave, response, len: frame.len() }));
        }

        #[test]
        fn tcp_round_trip(transaction in any::<u16>(), unit in any::<u8>(), response in any_response(), tail in proptest::collection::vec(any::<u8>(), 0..10)) {
            let header = TcpHeader { transaction, unit };
            let mut frame = tcp_frame(header, &encode_response_pdu(&response));
            let len = frame.len();
            frame.extend_from_slice(&tail);
            prop_assert_eq!(parse_tcp(&frame), Ok(Parsed::Frame { header, response, len }));
        }
    }
}
