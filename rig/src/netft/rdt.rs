//! The Net F/T / Ethernet Axia RDT (raw data transfer) codec: pure bytes <-> messages.
//!
//! Request (host to sensor, 8 bytes, big-endian): header `0x1234` u16, command u16, sample
//! count u32 (0 = stream until stopped). Record (sensor to host, 36 bytes, big-endian):
//! `rdt_sequence` u32, `ft_sequence` u32, `status` u32, then Fx Fy Fz Tx Ty Tz as i32 counts.
//! In buffered mode one datagram holds several records back to back.

/// UDP port the sensor listens on for RDT requests.
pub const DEFAULT_PORT: u16 = 49152;
/// The fixed first field of every request.
pub(crate) const HEADER: u16 = 0x1234;
/// Size of one request.
pub(crate) const REQUEST_LEN: usize = 8;
/// Size of one record.
pub(crate) const RECORD_LEN: usize = 36;

/// An RDT command.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Command {
    /// Stop streaming (0x0000).
    Stop,
    /// Real-time streaming: one record per datagram (0x0002).
    RealTime,
    /// Buffered streaming: several records per datagram (0x0003).
    Buffered,
    /// Multi-unit streaming (0x0004).
    MultiUnit,
    /// Reset the threshold latch (0x0041).
    ResetThresholdLatch,
    /// Software bias: the sensor zeroes its output at the current load (0x0042).
    SoftwareBias,
}

impl Command {
    /// The command code on the wire.
    pub fn code(self) -> u16 {
        match self {
            Command::Stop => 0x0000,
            Command::RealTime => 0x0002,
            Command::Buffered => 0x0003,
            Command::MultiUnit => 0x0004,
            Command::ResetThresholdLatch => 0x0041,
            Command::SoftwareBias => 0x0042,
        }
    }

    /// The command with this code, if it is one.
    pub fn from_code(code: u16) -> Option<Command> {
        Some(match code {
            0x0000 => Command::Stop,
            0x0002 => Command::RealTime,
            0x0003 => Command::Buffered,
            0x0004 => Command::MultiUnit,
            0x0041 => Command::ResetThresholdLatch,
            0x0042 => Command::SoftwareBias,
            _ => return None,
        })
    }
}

/// A message that is not valid RDT.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum RdtError {
    #[error("RDT request of {len} bytes (a request is exactly {REQUEST_LEN} bytes)")]
    RequestLength { len: usize },
    #[error("RDT request header {found:#06x} (expected {HEADER:#06x})")]
    Header { found: u16 },
    #[error("unknown RDT command {code:#06x}")]
    UnknownCommand { code: u16 },
    #[error("RDT datagram of {len} bytes is not a whole number of {RECORD_LEN}-byte records")]
    DatagramLength { len: usize },
}

/// One RDT request.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Request {
    pub command: Command,
    /// Records to send before stopping; 0 = until a stop request.
    pub sample_count: u32,
}

impl Request {
    /// A request with sample count 0.
    pub fn new(command: Command) -> Request {
        Request {
            command,
            sample_count: 0,
        }
    }

    /// The 8 bytes on the wire.
    pub fn encode(&self) -> [u8; REQUEST_LEN] {
        let mut out = [0u8; REQUEST_LEN];
        out[0..2].copy_from_slice(&HEADER.to_be_bytes());
        out[2..4].copy_from_slice(&self.command.code().to_be_bytes());
        out[4..8].copy_from_slice(&self.sample_count.to_be_bytes());
        out
    }

    /// Parses a request (what a simulated sensor receives).
    pub fn decode(bytes: &[u8]) -> Result<Request, RdtError> {
        let b: &[u8; REQUEST_LEN] = bytes
            .try_into()
            .map_err(|_| RdtError::RequestLength { len: bytes.len() })?;
        let header = u16::from_be_bytes([b[0], b[1]]);
        if header != HEADER {
            return Err(RdtError::Header { found: header });
        }
        let code = u16::from_be_bytes([b[2], b[3]]);
        let command = Command::from_code(code).ok_or(RdtError::UnknownCommand { code })?;
        Ok(Request {
            command,
            sample_count: u32::from_be_bytes([b[4], b[5], b[6], b[7]]),
        })
    }
}

/// One RDT record: a sample in raw counts.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Record {
    /// Position in this stream; restarts at 1 with every start request.
    pub rdt_sequence: u32,
    /// The sensor's internal sample counter since power-up (does not reset).
    pub ft_sequence: u32,
    /// Status word; 0 = ok.
    pub status: u32,
    /// Fx Fy Fz Tx Ty Tz in counts.
    pub counts: [i32; 6],
}

fn be_u32(b: &[u8], at: usize) -> u32 {
    u32::from_be_bytes([b[at], b[at + 1], b[at + 2], b[at + 3]])
}

impl Record {
    /// The 36 bytes on the wire.
    pub fn encode(&self) -> [u8; RECORD_LEN] {
        let mut out = [0u8; RECORD_LEN];
        out[0..4].copy_from_slice(&self.rdt_sequence.to_be_bytes());
        out[4..8].copy_from_slice(&self.ft_sequence.to_be_bytes());
        out[8..12].copy_from_slice(&self.status.to_be_bytes());
        for (i, c) in self.counts.iter().enumerate() {
            out[12 + 4 * i..16 + 4 * i].copy_from_slice(&c.to_be_bytes());
        }
        out
    }

    /// Parses one record from exactly 36 bytes.
    pub fn decode(b: &[u8; RECORD_LEN]) -> Record {
        Record {
            rdt_sequence: be_u32(b, 0),
            ft_sequence: be_u32(b, 4),
            status: be_u32(b, 8),
            counts: std::array::from_fn(|i| be_u32(b, 12 + 4 * i) as i32),
        }
    }
}

/// The records in one datagram (one in real-time mode, several in buffered mode), in order.
///
/// Fails without decoding anything if the length is zero or not a multiple of 36.
pub fn decode_datagram(bytes: &[u8]) -> Result<Records<'_>, RdtError> {
    if bytes.is_empty() || !bytes.chunks_exact(RECORD_LEN).remainder().is_empty() {
        return Err(RdtError::DatagramLength { len: bytes.len() });
    }
    Ok(Records {
        chunks: bytes.chunks_exact(RECORD_LEN),
    })
}

/// Iterator over the records of a datagram (see [`decode_datagram`]).
pub struct Records<'a> {
    chunks: std::slice::ChunksExact<'a, u8>,
}

impl Iterator for Records<'_> {
    type Item = Record;
    fn next(&mut self) -> Option<Record> {
        let chunk = self.chunks.next()?;
        let arr: &[u8; RECORD_LEN] = chunk.try_into().ok()?;
        Some(Record::decode(arr))
    }
    fn size_hint(&self) -> (usize, Option<usize>) {
        self.chunks.size_hint()
    }
}

/// Concatenates records into one datagram (buffered mode; what a simulated sensor sends).
pub fn encode_datagram(records: &[Record]) -> Vec<u8> {
    records.iter().flat_map(|r| r.encode()).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn start_request_bytes() {
        assert_eq!(
            Request::new(Command::RealTime).encode(),
            [0x12, 0x34, 0x00, 0x02, 0, 0, 0, 0]
        );
        assert_eq!(
            Request {
                command: Command::Buffered,
                sample_count: 0x0102_0304
            }
            .encode(),
            [0x12, 0x34, 0x00, 0x03, 1, 2, 3, 4]
        );
        assert_eq!(
            Request::new(Command::Stop).encode(),
            [0x12, 0x34, 0, 0, 0, 0, 0, 0]
        );
        assert_eq!(
            Request::new(Command::SoftwareBias).encode()[2..4],
            [0x00, 0x42]
        );
        assert_eq!(
            Request::new(Command::ResetThresholdLatch).encode()[2..4],
            [0x00, 0x41]
        );
        assert_eq!(
            Request::new(Command::MultiUnit).encode()[2..4],
            [0x00, 0x04]
        );
    }

    #[test]
    fn request_decoding_rejects_bad_headers_and_commands() {
        let r = Request {
            command: Command::SoftwareBias,
            sample_count: 7,
        };
        assert_eq!(Request::decode(&r.encode()), Ok(r));
        assert_eq!(
            Request::decode(&[0x12, 0x35, 0, 2, 0, 0, 0, 0]),
            Err(RdtError::Header { found: 0x1235 })
        );
        assert_eq!(
            Request::decode(&[0x12, 0x34, 0, 9, 0, 0, 0, 0]),
            Err(RdtError::UnknownCommand { code: 9 })
        );
        assert_eq!(
            Request::decode(&[0x12]),
            Err(RdtError::RequestLength { len: 1 })
        );
    }

    #[test]
    fn record_fields_are_big_endian_and_signed() {
        let mut b = [0u8; RECORD_LEN];
        b[0..4].copy_from_slice(&[0, 0, 0, 5]);
        b[4..8].copy_from_slice(&[0, 1, 0, 0]);
        b[8..12].copy_from_slice(&[0x40, 0, 0, 0]);
        b[12..16].copy_from_slice(&[0xff, 0xff, 0xff, 0xfe]); // Fx = -2
        b[32..36].copy_from_slice(&[0, 0, 0x03, 0xe8]); // Tz = 1000
        let r = Record::decode(&b);
        assert_eq!(r.rdt_sequence, 5);
        assert_eq!(r.ft_sequence, 65536);
        assert_eq!(r.status, 0x4000_0000);
        assert_eq!(r.counts, [-2, 0, 0, 0, 0, 1000]);
        assert_eq!(r.encode(), b);
    }

    #[test]
    fn buffered_datagrams_hold_several_records() {
        let recs: Vec<Record> = (1..=3)
            .map(|i| Record {
                rdt_sequence: i,
                ft_sequence: 100 + i,
                status: 0,
                counts: [i as i32; 6],
            })
            .collect();
        let bytes = encode_datagram(&recs);
        assert_eq!(bytes.len(), 108);
        let back: Vec<Record> = decode_datagram(&bytes).expect("decode").collect();
        assert_eq!(back, recs);
        assert_eq!(
            decode_datagram(&bytes[..40]).err(),
            Some(RdtError::DatagramLength { len: 40 })
        );
        assert!(decode_datagram(&[]).is_err());
    }

    proptest! {
        #[test]
        fn decoding_never_panics(bytes in proptest::collection::vec(any::<u8>(), 0..400)) {
            let _ = Request::decode(&bytes);
            if let Ok(records) = decode_datagram(&bytes) {
                prop_assert_eq!(records.count(), bytes.len() / RECORD_LEN);
            } else {
                prop_assert!(bytes.is_empty() || bytes.len() % RECORD_LEN != 0);
            }
        }

        #[test]
        fn records_round_trip(seq: u32, ft: u32, status: u32, counts: [i32; 6]) {
            let r = Record { rdt_sequence: seq, ft_sequence: ft, status, counts };
            prop_assert_eq!(Record::decode(&r.encode()), r);
        }
    }
}
