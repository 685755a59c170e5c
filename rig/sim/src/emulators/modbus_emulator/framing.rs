//! Modbus TCP and RTU request frames taken off a byte buffer and answered by a [`ModbusCore`]:
//! bytes in, reply frames out, no I/O. The core sits behind a mutex because the server shares it
//! between connections and the emulator handle.

use super::core::ModbusCore;
use fringe_rig::modbus::{crc16, rtu_frame, tcp_frame, TcpHeader};
use fringe_rig::HostTime;
use std::sync::{Mutex, MutexGuard};

/// The length of the RTU request frame starting at `buf[0]` (slave id), once enough bytes are
/// there to know it; `Some(None)` for a function code this drive does not know.
fn rtu_request_len(buf: &[u8]) -> Option<Option<usize>> {
    match buf.get(1)? {
        0x03 | 0x04 | 0x06 => Some(Some(8)),
        0x10 => buf.get(6).map(|&n| Some(9 + n as usize)),
        _ => Some(None),
    }
}

pub(super) fn lock(core: &Mutex<ModbusCore>) -> MutexGuard<'_, ModbusCore> {
    // Every request leaves the core consistent, so a poisoned lock is still usable.
    core.lock().unwrap_or_else(|e| e.into_inner())
}

/// Takes one Modbus TCP request off the front of `buf` and answers it; `Err` for a byte stream
/// that is not Modbus TCP (the connection is to be closed).
pub(super) fn tcp_exchange(
    buf: &mut Vec<u8>,
    core: &Mutex<ModbusCore>,
    slave: u8,
) -> Result<Option<Vec<u8>>, ()> {
    if buf.len() < 7 {
        return Ok(None);
    }
    let protocol = u16::from_be_bytes([buf[2], buf[3]]);
    let length = u16::from_be_bytes([buf[4], buf[5]]) as usize;
    if protocol != 0 || !(2..=254).contains(&length) {
        return Err(());
    }
    if buf.len() < 6 + length {
        return Ok(None);
    }
    let header = TcpHeader {
        transaction: u16::from_be_bytes([buf[0], buf[1]]),
        unit: buf[6],
    };
    let pdu: Vec<u8> = buf[7..6 + length].to_vec();
    buf.drain(..6 + length);
    let response = if header.unit == slave || header.unit == 0 || header.unit == 0xFF {
        lock(core).handle_pdu(&pdu, HostTime::now())
    } else {
        // As a gateway would: no device with that unit id behind it.
        vec![pdu.first().copied().unwrap_or(0) | 0x80, 0x0B]
    };
    Ok(Some(tcp_frame(header, &response)))
}

/// Takes complete RTU frames off `buf`, answering those addressed to `slave`. With `silence`
/// (no byte for longer than the inter-frame gap) whatever is left is a broken frame: dropped.
pub(super) fn rtu_exchange(
    buf: &mut Vec<u8>,
    core: &Mutex<ModbusCore>,
    slave: u8,
    silence: bool,
) -> Vec<Vec<u8>> {
    let mut replies = Vec::new();
    loop {
        let len = match rtu_request_len(buf) {
            None => break,
            Some(Some(n)) if buf.len() >= n => n,
            Some(Some(_)) => break,
            // Unknown function: the frame ends at the silence.
            Some(None) if silence => buf.len(),
            Some(None) => break,
        };
        let frame: Vec<u8> = buf.drain(..len).collect();
        if frame.len() < 4 {
            continue;
        }
        let crc = u16::from_le_bytes([frame[len - 2], frame[len - 1]]);
        if crc != crc16(&frame[..len - 2]) {
            // A corrupted frame: a drive stays silent and resynchronises at the next gap.
            buf.clear();
            break;
        }
        let (address, pdu) = (frame[0], &frame[1..len - 2]);
        if address != slave && address != 0 {
            continue;
        }
        let response = lock(core).handle_pdu(pdu, HostTime::now());
        if address != 0 {
            replies.push(rtu_frame(slave, &response));
        }
    }
    if silence {
        buf.clear();
    }
    replies
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::emulators::modbus_emulator::core::tests::core;

    #[test]
    fn rtu_framing_answers_only_its_slave_and_drops_bad_crc() {
        let core = Mutex::new(core("leadshine-pr"));
        let read = rtu_frame(1, &[0x03, 0x60, 0x2A, 0x00, 0x02]);
        let mut buf = [read.clone(), rtu_frame(2, &[0x03, 0x60, 0x2A, 0x00, 0x02])].concat();
        let replies = rtu_exchange(&mut buf, &core, 1, false);
        assert_eq!(replies.len(), 1);
        assert_eq!(replies[0][..3], [1, 0x03, 4]);
        let mut bad = read.clone();
        bad[3] ^= 1;
        buf = bad;
        assert!(rtu_exchange(&mut buf, &core, 1, false).is_empty());
        assert!(buf.is_empty());
        // Half a frame waits for the rest; after a silence it is dropped.
        buf = read[..5].to_vec();
        assert!(rtu_exchange(&mut buf, &core, 1, false).is_empty());
        assert_eq!(buf.len(), 5);
        assert!(rtu_exchange(&mut buf, &core, 1, true).is_empty());
        assert!(buf.is_empty());
        // Unknown function: illegal function after the gap.
        buf = rtu_frame(1, &[0x2B, 0x0E, 0x01, 0x00]);
        let replies = rtu_exchange(&mut buf, &core, 1, true);
        assert_eq!(replies, vec![rtu_frame(1, &[0xAB, 0x01])]);
    }

    proptest::proptest! {
        #[test]
        fn garbage_never_panics_and_always_gets_a_well_formed_answer(
            bytes in proptest::collection::vec(proptest::prelude::any::<u8>(), 0..300),
        ) {
            let core = Mutex::new(core("oriental-az"));
            let now = HostTime::now();
            let reply = lock(&core).handle_pdu(&bytes, now);
            proptest::prop_assert!(!reply.is_empty());
            if reply[0] & 0x80 != 0 {
                proptest::prop_assert_eq!(reply.len(), 2);
            }
            let mut buf = bytes.clone();
            for r in rtu_exchange(&mut buf, &core, 1, true) {
                proptest::prop_assert_eq!(crc16(&r[..r.len() - 2]).to_le_bytes(), [r[r.len() - 2], r[r.len() - 1]]);
            }
            proptest::prop_assert!(buf.is_empty());
            let mut buf = bytes;
            while let Ok(Some(_)) = tcp_exchange(&mut buf, &core, 1) {}
        }
    }
}
