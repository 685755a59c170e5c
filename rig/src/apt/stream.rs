//! The resynchronising APT stream decoder: splits a byte stream into packets, dropping one byte
//! at a time on garbage. No I/O: bytes are pushed in, packets taken out.

use super::codec::{decode, frame_len, DecodeError};
use super::ids::{is_controller_address, HOST, MAX_DATA_LEN};
use super::message::Packet;

/// Which way the frames a [`StreamDecoder`] reads travel; frames with other addresses are
/// treated as garbage.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Flow {
    /// Controller to host: dest is the host (or 0), source a controller address.
    FromDevice,
    /// Host to controller: source is the host, dest a controller address.
    ToDevice,
}

/// One item read by [`StreamDecoder::next_item`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Decoded {
    Packet(Packet),
    /// A well-addressed frame of a message id this codec does not know, skipped whole.
    Unknown {
        message_id: u16,
        dest: u8,
        source: u8,
        /// Frame length including the 6-byte header.
        len: usize,
    },
}

/// Splits a byte stream into packets, dropping one byte at a time to resynchronise on an unknown
/// id, an impossible length or an unexpected address. Never panics.
#[derive(Debug)]
pub struct StreamDecoder {
    flow: Flow,
    buf: Vec<u8>,
    dropped: u64,
}

impl StreamDecoder {
    pub fn new(flow: Flow) -> Self {
        StreamDecoder {
            flow,
            buf: Vec::new(),
            dropped: 0,
        }
    }

    /// Appends received bytes.
    pub fn push(&mut self, bytes: &[u8]) {
        self.buf.extend_from_slice(bytes);
    }

    /// Bytes discarded so far while resynchronising.
    pub fn dropped(&self) -> u64 {
        self.dropped
    }

    /// Bytes waiting for the rest of a frame.
    pub fn pending(&self) -> usize {
        self.buf.len()
    }

    fn addresses_ok(&self, header: &[u8]) -> bool {
        let dest = header[4] & 0x7f;
        let source = header[5];
        match self.flow {
            Flow::FromDevice => (dest == HOST || dest == 0) && is_controller_address(source),
            Flow::ToDevice => source == HOST && is_controller_address(dest),
        }
    }

    /// The next complete packet, if the buffer holds one.
    pub fn next_packet(&mut self) -> Option<Packet> {
        match self.next(false) {
            Some(Decoded::Packet(p)) => Some(p),
            _ => None,
        }
    }

    /// Like [`StreamDecoder::next_packet`], but a frame of an unknown message id whose header
    /// has plausible addresses (and a data length within 255) is skipped whole and reported, as
    /// a controller does with messages it does not implement.
    pub fn next_item(&mut self) -> Option<Decoded> {
        self.next(true)
    }

    fn next(&mut self, skip_unknown: bool) -> Option<Decoded> {
        loop {
            if self.buf.len() < 6 {
                return None;
            }
            let header = &self.buf[..6];
            let addresses_ok = self.addresses_ok(header);
            let len = match frame_len(header) {
                Ok(n) if addresses_ok => n,
                Err(DecodeError::UnknownId(message_id)) if skip_unknown && addresses_ok => {
                    let data_len = u16::from_le_bytes([header[2], header[3]]) as usize;
                    let is_long = header[4] & 0x80 != 0;
                    if is_long && data_len > MAX_DATA_LEN {
                        self.drop_one();
                        continue;
                    }
                    let len = if is_long { 6 + data_len } else { 6 };
                    if self.buf.len() < len {
                        return None;
                    }
                    let (dest, source) = (header[4] & 0x7f, header[5]);
                    self.buf.drain(..len);
                    return Some(Decoded::Unknown {
                        message_id,
                        dest,
                        source,
                        len,
                    });
                }
                _ => {
                    self.drop_one();
                    continue;
                }
            };
            if self.buf.len() < len {
                return None;
            }
            match decode(&self.buf[..len]) {
                Ok(p) => {
                    self.buf.drain(..len);
                    return Some(Decoded::Packet(p));
                }
                Err(_) => self.drop_one(),
            }
        }
    }

    fn drop_one(&mut self) {
        self.buf.remove(0);
        self.dropped += 1;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::apt::codec::encode;
    use crate::apt::ids::{id, USB_UNIT};
    use crate::apt::message::{Message, StatusBlock};
    use proptest::prelude::*;

    fn hex(s: &str) -> Vec<u8> {
        crate::trace::format::parse_hex(s).expect("hex")
    }

    #[test]
    fn stream_decoder_resyncs_on_garbage_and_split_reads() {
        let mut d = StreamDecoder::new(Flow::FromDevice);
        let completed = hex("64 04 0e 00 81 50 01 00 68 aa a0 01 00 00 00 00 30 00 00 80");
        let homed = hex("44 04 01 00 01 50");
        let mut stream = hex("00 ff 44 04 01 00 01 33 7e");
        stream.extend_from_slice(&completed);
        stream.extend_from_slice(&hex("13 04 ff 7f 81 50"));
        stream.extend_from_slice(&homed);
        let mut got = Vec::new();
        for chunk in stream.chunks(5) {
            d.push(chunk);
            while let Some(p) = d.next_packet() {
                got.push(p.message.id());
            }
        }
        assert_eq!(got, vec![id::MOT_MOVE_COMPLETED, id::MOT_MOVE_HOMED]);
        assert_eq!(d.dropped(), 9 + 6);
        assert_eq!(d.pending(), 0);
    }

    #[test]
    fn stream_decoder_rejects_host_frames_when_reading_from_the_device() {
        let mut d = StreamDecoder::new(Flow::FromDevice);
        d.push(&hex("23 02 01 00 50 01"));
        assert_eq!(d.next_packet(), None);
        let mut d = StreamDecoder::new(Flow::ToDevice);
        d.push(&hex("23 02 01 00 50 01"));
        assert_eq!(
            d.next_packet().map(|p| p.message),
            Some(Message::ModIdentify { channel: 1 })
        );
    }

    #[test]
    fn next_item_skips_unknown_host_frames_whole() {
        let mut d = StreamDecoder::new(Flow::ToDevice);
        // MOT_REQ_JOGPARAMS (short, unknown here), a long unknown frame whose data would look
        // like an identify, then a real MOD_IDENTIFY.
        d.push(&hex("17 04 01 00 50 01"));
        d.push(&hex("16 04 06 00 d0 01 23 02 01 00 50 01"));
        d.push(&hex("23 02 01 00 50 01"));
        let items: Vec<Decoded> = std::iter::from_fn(|| d.next_item()).collect();
        assert_eq!(
            items,
            vec![
                Decoded::Unknown {
                    message_id: 0x0417,
                    dest: USB_UNIT,
                    source: HOST,
                    len: 6
                },
                Decoded::Unknown {
                    message_id: 0x0416,
                    dest: USB_UNIT,
                    source: HOST,
                    len: 12
                },
                Decoded::Packet(Packet::to_device(
                    USB_UNIT,
                    Message::ModIdentify { channel: 1 }
                )),
            ]
        );
        assert_eq!(d.dropped(), 0);
    }

    proptest! {
        #[test]
        fn stream_decoder_never_panics(bytes in proptest::collection::vec(any::<u8>(), 0..600)) {
            let mut d = StreamDecoder::new(Flow::FromDevice);
            d.push(&bytes);
            while d.next_packet().is_some() {}
            let _ = decode(&bytes);
        }

        #[test]
        fn frames_embedded_in_garbage_are_recovered(
            garbage in proptest::collection::vec(
                proptest::collection::vec(any::<u8>(), 0..40), 4),
            position in any::<i32>(),
            status in any::<u32>(),
        ) {
            let frames = [
                encode(&Packet::from_device(USB_UNIT, Message::MoveHomed { channel: 1 })),
                encode(&Packet::from_device(USB_UNIT, Message::GetStatusUpdate(StatusBlock {
                    channel: 1, position, encoder: 0, status }))),
                encode(&Packet::from_device(0x21, Message::MoveCompleted { channel: 1, status: None })),
            ];
            let mut d = StreamDecoder::new(Flow::FromDevice);
            let mut got = Vec::new();
            for (g, f) in garbage.iter().zip(frames.iter()) {
                d.push(g);
                d.push(f);
            }
            d.push(&garbage[3]);
            // A frame that garbage pretends to start may swallow bytes; a trailing run of
            // short frames lets the decoder drain any such prefix.
            for _ in 0..50 {
                d.push(&frames[0]);
            }
            while let Some(p) = d.next_packet() {
                got.push(encode(&p));
            }
            for f in &frames[1..] {
                prop_assert!(got.contains(f), "frame {:02x?} lost", f);
            }
        }
    }
}
