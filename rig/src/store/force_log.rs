//! The raw force stream on disk: a 16-byte header, then fixed-size little-endian records.
//!
//! Header: magic `FRNGFT01` (8 bytes), record size u32, reserved u32. Record (80 bytes):
//! device_tick u64, transport_seq u32 (0xFFFF_FFFF = none), status u32, host_ns u64, Fx Fy Fz (N)
//! and Mx My Mz (N m) as six f64, the strobe channel as f32 volts (NaN = not wired), 4 bytes of
//! padding. A torn record at the end of the file (a crash mid-write) is detected from the file
//! length and dropped on reopening.

use crate::clock::HostTime;
use crate::force::ForceSample;
use crate::units::{Volts, Wrench};

pub(crate) const MAGIC: &[u8; 8] = b"FRNGFT01";
pub(crate) const HEADER_LEN: usize = 16;
pub(crate) const RECORD_LEN: usize = 80;

/// The file header.
pub(crate) fn header() -> [u8; HEADER_LEN] {
    let mut h = [0u8; HEADER_LEN];
    h[..8].copy_from_slice(MAGIC);
    h[8..12].copy_from_slice(&(RECORD_LEN as u32).to_le_bytes());
    h
}

/// A force log this build cannot read.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ForceLogError {
    #[error("header is {0} bytes, expected {HEADER_LEN}")]
    ShortHeader(usize),
    #[error("not a fringe force log (bad magic)")]
    BadMagic,
    #[error("record size {0}, this build reads {RECORD_LEN}")]
    RecordSize(usize),
}

/// Checks a header.
pub fn check_header(bytes: &[u8]) -> Result<(), ForceLogError> {
    if bytes.len() < HEADER_LEN {
        return Err(ForceLogError::ShortHeader(bytes.len()));
    }
    if &bytes[..8] != MAGIC {
        return Err(ForceLogError::BadMagic);
    }
    let size = u32::from_le_bytes([bytes[8], bytes[9], bytes[10], bytes[11]]) as usize;
    if size != RECORD_LEN {
        return Err(ForceLogError::RecordSize(size));
    }
    Ok(())
}

/// Encodes one sample.
pub(crate) fn encode(sample: &ForceSample) -> [u8; RECORD_LEN] {
    let mut r = [0u8; RECORD_LEN];
    r[0..8].copy_from_slice(&sample.device_tick.to_le_bytes());
    r[8..12].copy_from_slice(&sample.transport_seq.unwrap_or(u32::MAX).to_le_bytes());
    r[12..16].copy_from_slice(&sample.status.to_le_bytes());
    r[16..24].copy_from_slice(&sample.host_time.0.to_le_bytes());
    for (k, v) in sample.wrench.to_array().iter().enumerate() {
        r[24 + 8 * k..32 + 8 * k].copy_from_slice(&v.to_le_bytes());
    }
    let strobe = sample.strobe.map(|v| v.0 as f32).unwrap_or(f32::NAN);
    r[72..76].copy_from_slice(&strobe.to_le_bytes());
    r
}

fn u64_at(r: &[u8], at: usize) -> u64 {
    let mut b = [0u8; 8];
    b.copy_from_slice(&r[at..at + 8]);
    u64::from_le_bytes(b)
}

fn u32_at(r: &[u8], at: usize) -> u32 {
    let mut b = [0u8; 4];
    b.copy_from_slice(&r[at..at + 4]);
    u32::from_le_bytes(b)
}

/// Decodes one record (`r` must be [`RECORD_LEN`] bytes).
pub(crate) fn decode(r: &[u8; RECORD_LEN]) -> ForceSample {
    let seq = u32_at(r, 8);
    let wrench: [f64; 6] = std::array::from_fn(|k| f64::from_bits(u64_at(r, 24 + 8 * k)));
    let strobe = f32::from_bits(u32_at(r, 72));
    ForceSample {
        device_tick: u64_at(r, 0),
        transport_seq: (seq != u32::MAX).then_some(seq),
        status: u32_at(r, 12),
        host_time: HostTime(u64_at(r, 16)),
        wrench: Wrench::from_array(wrench),
        strobe: (!strobe.is_nan()).then_some(Volts(strobe as f64)),
    }
}

/// Decodes every complete record of a whole file's bytes; returns them and the number of torn
/// trailing bytes.
pub fn decode_all(bytes: &[u8]) -> Result<(Vec<ForceSample>, usize), ForceLogError> {
    check_header(bytes)?;
    let body = &bytes[HEADER_LEN..];
    let whole = body.len() / RECORD_LEN;
    let samples = body
        .chunks_exact(RECORD_LEN)
        .map(|c| {
            let mut r = [0u8; RECORD_LEN];
            r.copy_from_slice(c);
            decode(&r)
        })
        .collect();
    Ok((samples, body.len() - whole * RECORD_LEN))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::units::Newtons;

    #[test]
    fn records_round_trip_bit_exactly_and_torn_tails_are_counted() {
        let a = ForceSample {
            device_tick: 1 << 40,
            transport_seq: Some(7),
            host_time: HostTime(123_456_789),
            wrench: Wrench::from_array([0.1, -0.2, -9.000_000_001, 1e-3, -2e-3, 3e-4]),
            status: 0x8000_0000,
            strobe: Some(Volts(3.25)),
        };
        let b = ForceSample {
            transport_seq: None,
            strobe: None,
            wrench: Wrench {
                fz: Newtons(-0.5),
                ..Wrench::default()
            },
            ..a
        };
        let mut file = header().to_vec();
        file.extend(encode(&a));
        file.extend(encode(&b));
        file.extend(&encode(&a)[..30]);
        let (samples, torn) = decode_all(&file).expect("decode");
        assert_eq!(samples, vec![a, b]);
        assert_eq!(torn, 30);
        assert_eq!(
            decode_all(b"FRNGFT02________"),
            Err(ForceLogError::BadMagic)
        );
    }
}
