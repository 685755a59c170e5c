//! APT frames: pure encode/decode of one frame, no I/O.
//!
//! Two frame shapes, little-endian:
//! - short, 6 bytes: `id u16, param1 u8, param2 u8, dest u8, source u8`;
//! - long: `id u16, datalen u16, dest | 0x80, source`, then `datalen` data bytes.
//!
//! [`encode`] and [`decode`] convert one frame; [`frame_len`] reads the length a header
//! announces. The ids are in [`super::ids`], the messages in [`super::message`], and
//! [`super::stream::StreamDecoder`] splits a byte stream into frames.

use super::ids::{id, shape, Shape, MAX_DATA_LEN};
use super::message::{
    HomeParams, HwInfo, Message, Packet, StatusBlock, StopMode, UStatusBlock, VelParams,
};

/// Why a frame did not decode.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum DecodeError {
    #[error("APT frame too short: {0} bytes, a frame has at least 6")]
    TooShort(usize),
    #[error("unknown APT message id 0x{0:04x}")]
    UnknownId(u16),
    #[error("APT {name} (0x{id:04x}) has the wrong shape: {detail}")]
    Shape {
        id: u16,
        name: &'static str,
        detail: String,
    },
    #[error("APT frame length {got} does not match its header ({expected})")]
    Length { got: usize, expected: usize },
}

/// Encodes one packet into a frame.
pub fn encode(packet: &Packet) -> Vec<u8> {
    use Message::*;
    let id = packet.message.id();
    let short = |p1: u8, p2: u8| {
        let mut v = Vec::with_capacity(6);
        v.extend_from_slice(&id.to_le_bytes());
        v.extend_from_slice(&[p1, p2, packet.dest & 0x7f, packet.source]);
        v
    };
    let long = |data: Vec<u8>| {
        let mut v = Vec::with_capacity(6 + data.len());
        v.extend_from_slice(&id.to_le_bytes());
        v.extend_from_slice(&(data.len() as u16).to_le_bytes());
        v.extend_from_slice(&[packet.dest | 0x80, packet.source]);
        v.extend_from_slice(&data);
        v
    };
    match &packet.message {
        ModIdentify { channel }
        | ReqChanEnableState { channel }
        | MoveHome { channel }
        | MoveHomed { channel }
        | ReqHomeParams { channel }
        | ReqStatusUpdate { channel }
        | ReqUStatusUpdate { channel }
        | ReqStatusBits { channel }
        | ReqVelParams { channel }
        | ReqPosCounter { channel }
        | MoveAbsoluteStored { channel }
        | MoveRelativeStored { channel }
        | ReqMoveAbsParams { channel }
        | ReqMoveRelParams { channel } => short(*channel, 0),
        SetChanEnableState { channel, enable } => short(*channel, if *enable { 1 } else { 2 }),
        GetChanEnableState { channel, enabled } => short(*channel, if *enabled { 1 } else { 2 }),
        HwReqInfo | HwStartUpdateMsgs | HwStopUpdateMsgs | HwNoFlashProgramming
        | AckUStatusUpdate | SuspendEndOfMoveMsgs | ResumeEndOfMoveMsgs => short(0, 0),
        HwResponse { param1, param2 } => short(*param1, *param2),
        SetTstActuatorType { actuator } => short(*actuator, 0),
        MoveStop { channel, mode } => short(*channel, *mode as u8),
        MoveCompleted { channel, status } | MoveStopped { channel, status } => match status {
            None => short(*channel as u8, 0),
            Some(block) => long(status_block_bytes(block)),
        },
        HwGetInfo(info) => long(info_bytes(info)),
        HwRichResponse {
            message_id,
            code,
            notes,
        } => {
            let mut d = Vec::with_capacity(68);
            d.extend_from_slice(&message_id.to_le_bytes());
            d.extend_from_slice(&code.to_le_bytes());
            d.extend_from_slice(&fixed_text(notes, 64));
            long(d)
        }
        SetHomeParams(h) | GetHomeParams(h) => {
            let mut d = Vec::with_capacity(14);
            for v in [h.channel, h.direction, h.limit_switch] {
                d.extend_from_slice(&v.to_le_bytes());
            }
            d.extend_from_slice(&h.velocity.to_le_bytes());
            d.extend_from_slice(&h.offset.to_le_bytes());
            long(d)
        }
        MoveAbsolute {
            channel,
            position: value,
        }
        | MoveRelative {
            channel,
            distance: value,
        }
        | SetPosCounter {
            channel,
            position: value,
        }
        | GetPosCounter {
            channel,
            position: value,
        }
        | SetMoveAbsParams {
            channel,
            position: value,
        }
        | GetMoveAbsParams {
            channel,
            position: value,
        }
        | SetMoveRelParams {
            channel,
            distance: value,
        }
        | GetMoveRelParams {
            channel,
            distance: value,
        } => {
            let mut d = channel.to_le_bytes().to_vec();
            d.extend_from_slice(&value.to_le_bytes());
            long(d)
        }
        GetStatusBits { channel, status } => {
            let mut d = channel.to_le_bytes().to_vec();
            d.extend_from_slice(&status.to_le_bytes());
            long(d)
        }
        GetStatusUpdate(block) => long(status_block_bytes(block)),
        GetUStatusUpdate(u) => {
            let mut d = u.channel.to_le_bytes().to_vec();
            d.extend_from_slice(&u.position.to_le_bytes());
            d.extend_from_slice(&u.velocity.to_le_bytes());
            d.extend_from_slice(&u.current_ma.to_le_bytes());
            d.extend_from_slice(&u.status.to_le_bytes());
            long(d)
        }
        SetVelParams(v) | GetVelParams(v) => {
            let mut d = v.channel.to_le_bytes().to_vec();
            for x in [v.min_velocity, v.acceleration, v.max_velocity] {
                d.extend_from_slice(&x.to_le_bytes());
            }
            long(d)
        }
    }
}

fn status_block_bytes(b: &StatusBlock) -> Vec<u8> {
    let mut d = b.channel.to_le_bytes().to_vec();
    d.extend_from_slice(&b.position.to_le_bytes());
    d.extend_from_slice(&b.encoder.to_le_bytes());
    d.extend_from_slice(&b.status.to_le_bytes());
    d
}

fn fixed_text(s: &str, n: usize) -> Vec<u8> {
    let mut v: Vec<u8> = s.bytes().take(n).collect();
    v.resize(n, 0);
    v
}

fn info_bytes(i: &HwInfo) -> Vec<u8> {
    let mut d = Vec::with_capacity(84);
    d.extend_from_slice(&i.serial_number.to_le_bytes());
    d.extend_from_slice(&fixed_text(&i.model, 8));
    d.extend_from_slice(&i.hw_type.to_le_bytes());
    d.extend_from_slice(&i.firmware);
    d.extend_from_slice(&fixed_text(&i.notes, 60));
    d.extend_from_slice(&i.hw_version.to_le_bytes());
    d.extend_from_slice(&i.mod_state.to_le_bytes());
    d.extend_from_slice(&i.channels.to_le_bytes());
    d
}

/// Little-endian field reader over a data block whose length was checked.
struct Fields<'a> {
    data: &'a [u8],
    at: usize,
}

impl<'a> Fields<'a> {
    fn new(data: &'a [u8]) -> Self {
        Fields { data, at: 0 }
    }
    fn take<const N: usize>(&mut self) -> [u8; N] {
        let mut out = [0u8; N];
        if let Some(src) = self.data.get(self.at..self.at + N) {
            out.copy_from_slice(src);
        }
        self.at += N;
        out
    }
    fn u16(&mut self) -> u16 {
        u16::from_le_bytes(self.take())
    }
    fn i16(&mut self) -> i16 {
        i16::from_le_bytes(self.take())
    }
    fn u32(&mut self) -> u32 {
        u32::from_le_bytes(self.take())
    }
    fn i32(&mut self) -> i32 {
        i32::from_le_bytes(self.take())
    }
    fn text(&mut self, n: usize) -> String {
        let raw = self.data.get(self.at..self.at + n).unwrap_or(&[]);
        self.at += n;
        let end = raw.iter().position(|&b| b == 0).unwrap_or(raw.len());
        String::from_utf8_lossy(&raw[..end]).trim_end().to_string()
    }
}

fn status_block(f: &mut Fields) -> StatusBlock {
    StatusBlock {
        channel: f.u16(),
        position: f.i32(),
        encoder: f.i32(),
        status: f.u32(),
    }
}

/// The total frame length announced by a header, or an error if the header cannot start a
/// frame of a known message. `header` must hold at least 6 bytes.
pub fn frame_len(header: &[u8]) -> Result<usize, DecodeError> {
    if header.len() < 6 {
        return Err(DecodeError::TooShort(header.len()));
    }
    let msg_id = u16::from_le_bytes([header[0], header[1]]);
    let (shape, name) = shape(msg_id).ok_or(DecodeError::UnknownId(msg_id))?;
    let is_long = header[4] & 0x80 != 0;
    let len = u16::from_le_bytes([header[2], header[3]]) as usize;
    let bad = |detail: String| DecodeError::Shape {
        id: msg_id,
        name,
        detail,
    };
    match (shape, is_long) {
        (Shape::Short, false) | (Shape::ShortOrLong(_), false) => Ok(6),
        (Shape::Short, true) => Err(bad("a short message with the data flag set".into())),
        (_, true) if len > MAX_DATA_LEN => Err(bad(format!("data length {len} exceeds 255"))),
        (Shape::Long(n), true) | (Shape::ShortOrLong(n), true) if len == n => Ok(6 + n),
        (Shape::LongEither(a, b), true) if len == a || len == b => Ok(6 + len),
        (_, true) => Err(bad(format!("unexpected data length {len}"))),
        (_, false) => Err(bad("a long message without the data flag".into())),
    }
}

/// Decodes exactly one frame.
pub fn decode(frame: &[u8]) -> Result<Packet, DecodeError> {
    use Message::*;
    let expected = frame_len(frame)?;
    if frame.len() != expected {
        return Err(DecodeError::Length {
            got: frame.len(),
            expected,
        });
    }
    let msg_id = u16::from_le_bytes([frame[0], frame[1]]);
    let (p1, p2) = (frame[2], frame[3]);
    let dest = frame[4] & 0x7f;
    let source = frame[5];
    let is_long = frame[4] & 0x80 != 0;
    let mut f = Fields::new(&frame[6..]);
    let message = match msg_id {
        id::MOD_IDENTIFY => ModIdentify { channel: p1 },
        id::MOD_SET_CHANENABLESTATE => SetChanEnableState {
            channel: p1,
            enable: p2 == 1,
        },
        id::MOD_REQ_CHANENABLESTATE => ReqChanEnableState { channel: p1 },
        id::MOD_GET_CHANENABLESTATE => GetChanEnableState {
            channel: p1,
            enabled: p2 == 1,
        },
        id::HW_REQ_INFO => HwReqInfo,
        id::HW_GET_INFO => HwGetInfo(HwInfo {
            serial_number: f.u32(),
            model: f.text(8),
            hw_type: f.u16(),
            firmware: f.take(),
            notes: f.text(60),
            hw_version: f.u16(),
            mod_state: f.u16(),
            channels: f.u16(),
        }),
        id::HW_START_UPDATEMSGS => HwStartUpdateMsgs,
        id::HW_STOP_UPDATEMSGS => HwStopUpdateMsgs,
        id::HW_NO_FLASH_PROGRAMMING => HwNoFlashProgramming,
        id::HW_RESPONSE => HwResponse {
            param1: p1,
            param2: p2,
        },
        id::HW_RICHRESPONSE => HwRichResponse {
            message_id: f.u16(),
            code: f.u16(),
            notes: f.text(64),
        },
        id::MOT_MOVE_HOME => MoveHome { channel: p1 },
        id::MOT_MOVE_HOMED => MoveHomed { channel: p1 },
        id::MOT_SET_HOMEPARAMS | id::MOT_GET_HOMEPARAMS => {
            let h = HomeParams {
                channel: f.u16(),
                direction: f.u16(),
                limit_switch: f.u16(),
                velocity: f.i32(),
                offset: f.i32(),
            };
            if msg_id == id::MOT_SET_HOMEPARAMS {
                SetHomeParams(h)
            } else {
                GetHomeParams(h)
            }
        }
        id::MOT_REQ_HOMEPARAMS => ReqHomeParams { channel: p1 },
        id::MOT_MOVE_ABSOLUTE if !is_long => MoveAbsoluteStored { channel: p1 },
        id::MOT_MOVE_ABSOLUTE => MoveAbsolute {
            channel: f.u16(),
            position: f.i32(),
        },
        id::MOT_MOVE_RELATIVE if !is_long => MoveRelativeStored { channel: p1 },
        id::MOT_MOVE_RELATIVE => MoveRelative {
            channel: f.u16(),
            distance: f.i32(),
        },
        id::MOT_SET_MOVEABSPARAMS => SetMoveAbsParams {
            channel: f.u16(),
            position: f.i32(),
        },
        id::MOT_REQ_MOVEABSPARAMS => ReqMoveAbsParams { channel: p1 },
        id::MOT_GET_MOVEABSPARAMS => GetMoveAbsParams {
            channel: f.u16(),
            position: f.i32(),
        },
        id::MOT_SET_MOVERELPARAMS => SetMoveRelParams {
            channel: f.u16(),
            distance: f.i32(),
        },
        id::MOT_REQ_MOVERELPARAMS => ReqMoveRelParams { channel: p1 },
        id::MOT_GET_MOVERELPARAMS => GetMoveRelParams {
            channel: f.u16(),
            distance: f.i32(),
        },
        id::MOT_MOVE_COMPLETED | id::MOT_MOVE_STOPPED => {
            let (channel, status) = if is_long {
                let b = status_block(&mut f);
                (b.channel, Some(b))
            } else {
                (p1 as u16, None)
            };
            if msg_id == id::MOT_MOVE_COMPLETED {
                MoveCompleted { channel, status }
            } else {
                MoveStopped { channel, status }
            }
        }
        id::MOT_MOVE_STOP => MoveStop {
            channel: p1,
            mode: if p2 == 1 {
                StopMode::Immediate
            } else {
                StopMode::Profiled
            },
        },
        id::MOT_REQ_STATUSUPDATE => ReqStatusUpdate { channel: p1 },
        id::MOT_GET_STATUSUPDATE => GetStatusUpdate(status_block(&mut f)),
        id::MOT_REQ_USTATUSUPDATE => ReqUStatusUpdate { channel: p1 },
        id::MOT_GET_USTATUSUPDATE => GetUStatusUpdate(UStatusBlock {
            channel: f.u16(),
            position: f.i32(),
            velocity: f.i16(),
            current_ma: f.i16(),
            status: f.u32(),
        }),
        id::MOT_ACK_USTATUSUPDATE => AckUStatusUpdate,
        id::MOT_REQ_STATUSBITS => ReqStatusBits { channel: p1 },
        id::MOT_GET_STATUSBITS => GetStatusBits {
            channel: f.u16(),
            status: f.u32(),
        },
        id::MOT_SET_VELPARAMS | id::MOT_GET_VELPARAMS => {
            let v = VelParams {
                channel: f.u16(),
                min_velocity: f.i32(),
                acceleration: f.i32(),
                max_velocity: f.i32(),
            };
            if msg_id == id::MOT_SET_VELPARAMS {
                SetVelParams(v)
            } else {
                GetVelParams(v)
            }
        }
        id::MOT_REQ_VELPARAMS => ReqVelParams { channel: p1 },
        id::MOT_SET_POSCOUNTER => SetPosCounter {
            channel: f.u16(),
            position: f.i32(),
        },
        id::MOT_REQ_POSCOUNTER => ReqPosCounter { channel: p1 },
        id::MOT_GET_POSCOUNTER => GetPosCounter {
            channel: f.u16(),
            position: f.i32(),
        },
        id::MOT_SET_TSTACTUATORTYPE => SetTstActuatorType { actuator: p1 },
        id::MOT_SUSPEND_ENDOFMOVEMSGS => SuspendEndOfMoveMsgs,
        id::MOT_RESUME_ENDOFMOVEMSGS => ResumeEndOfMoveMsgs,
        other => return Err(DecodeError::UnknownId(other)),
    };
    Ok(Packet {
        dest,
        source,
        message,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::apt::ids::{bay_address, HOST, USB_UNIT};

    fn hex(s: &str) -> Vec<u8> {
        crate::trace::format::parse_hex(s).expect("hex")
    }

    #[test]
    fn identify_example_from_the_protocol() {
        let p = Packet::to_device(USB_UNIT, Message::ModIdentify { channel: 1 });
        assert_eq!(encode(&p), hex("23 02 01 00 50 01"));
        assert_eq!(decode(&hex("23 02 01 00 50 01")).expect("decode"), p);
    }

    #[test]
    fn absolute_move_example_is_position_2048() {
        let bytes = hex("53 04 06 00 d0 01 01 00 00 08 00 00");
        let p = decode(&bytes).expect("decode");
        assert_eq!(p.dest, USB_UNIT);
        assert_eq!(p.source, HOST);
        assert_eq!(
            p.message,
            Message::MoveAbsolute {
                channel: 1,
                position: 2048
            }
        );
        assert_eq!(encode(&p), bytes);
    }

    #[test]
    fn move_completed_example_carries_a_status_block() {
        let bytes = hex("64 04 0e 00 81 50 01 00 68 aa a0 01 00 00 00 00 30 00 00 80");
        let p = decode(&bytes).expect("decode");
        assert_eq!((p.dest, p.source), (HOST, USB_UNIT));
        let Message::MoveCompleted {
            channel: 1,
            status: Some(b),
        } = p.message
        else {
            panic!("not a long MOVE_COMPLETED: {:?}", p.message)
        };
        assert_eq!(b.position, 0x01a0_aa68);
        assert_eq!(b.status, 0x8000_0030);
        assert_eq!(encode(&p), bytes);
    }

    #[test]
    fn velparams_example_addresses_bay_1() {
        let bytes = hex("13 04 0e 00 a2 01 01 00 00 00 00 00 b0 35 00 00 cd cc cc 00");
        let p = decode(&bytes).expect("decode");
        assert_eq!(p.dest, 0x22);
        assert_eq!(bay_address(1), Some(0x22));
        assert_eq!(
            p.message,
            Message::SetVelParams(VelParams {
                channel: 1,
                min_velocity: 0,
                acceleration: 0x35b0,
                max_velocity: 0x00cc_cccd
            })
        );
        assert_eq!(encode(&p), bytes);
    }

    #[test]
    fn short_move_completed_and_keepalive() {
        let p = Packet::from_device(
            USB_UNIT,
            Message::MoveCompleted {
                channel: 1,
                status: None,
            },
        );
        assert_eq!(encode(&p), hex("64 04 01 00 01 50"));
        let ack = Packet::to_device(USB_UNIT, Message::AckUStatusUpdate);
        assert_eq!(encode(&ack), hex("92 04 00 00 50 01"));
    }

    #[test]
    fn hw_info_round_trips_with_84_data_bytes() {
        let info = HwInfo {
            serial_number: 26_000_123,
            model: "KST101".into(),
            hw_type: 16,
            firmware: [4, 0, 1, 0],
            notes: "APT Stepper Motor Controller".into(),
            hw_version: 3,
            mod_state: 0,
            channels: 1,
        };
        let bytes = encode(&Packet::from_device(
            USB_UNIT,
            Message::HwGetInfo(info.clone()),
        ));
        assert_eq!(bytes.len(), 90);
        assert_eq!(&bytes[..6], &[0x06, 0x00, 0x54, 0x00, 0x81, 0x50]);
        let back = decode(&bytes).expect("decode");
        assert_eq!(back.message, Message::HwGetInfo(info.clone()));
        assert_eq!(info.firmware_version(), "1.0.4");
    }

    #[test]
    fn statusupdate_of_28_bytes_uses_the_first_14() {
        let mut bytes = hex("81 04 1c 00 81 21 01 00 00 10 00 00 00 00 00 00 00 04 00 80");
        bytes.extend_from_slice(&[0xee; 14]);
        let p = decode(&bytes).expect("28-byte status");
        assert_eq!(
            p.message,
            Message::GetStatusUpdate(StatusBlock {
                channel: 1,
                position: 4096,
                encoder: 0,
                status: 0x8000_0400
            })
        );
    }

    #[test]
    fn every_message_round_trips() {
        let vel = VelParams {
            channel: 1,
            min_velocity: 0,
            acceleration: 4506,
            max_velocity: -7,
        };
        let home = HomeParams {
            channel: 1,
            direction: 2,
            limit_switch: 1,
            velocity: 9,
            offset: -3,
        };
        let block = StatusBlock {
            channel: 1,
            position: -5,
            encoder: 7,
            status: 0x8000_2400,
        };
        let all = vec![
            Message::ModIdentify { channel: 1 },
            Message::SetChanEnableState {
                channel: 1,
                enable: true,
            },
            Message::SetChanEnableState {
                channel: 2,
                enable: false,
            },
            Message::ReqChanEnableState { channel: 1 },
            Message::GetChanEnableState {
                channel: 1,
                enabled: true,
            },
            Message::HwReqInfo,
            Message::HwStartUpdateMsgs,
            Message::HwStopUpdateMsgs,
            Message::HwNoFlashProgramming,
            Message::HwResponse {
                param1: 3,
                param2: 4,
            },
            Message::HwRichResponse {
                message_id: 0x0453,
                code: 9,
                notes: "bad".into(),
            },
            Message::MoveHome { channel: 1 },
            Message::MoveHomed { channel: 1 },
            Message::SetHomeParams(home),
            Message::ReqHomeParams { channel: 1 },
            Message::GetHomeParams(home),
            Message::MoveAbsolute {
                channel: 1,
                position: -100,
            },
            Message::MoveRelative {
                channel: 1,
                distance: i32::MIN,
            },
            Message::MoveCompleted {
                channel: 1,
                status: None,
            },
            Message::MoveCompleted {
                channel: 1,
                status: Some(block),
            },
            Message::MoveStopped {
                channel: 1,
                status: None,
            },
            Message::MoveStopped {
                channel: 1,
                status: Some(block),
            },
            Message::MoveStop {
                channel: 1,
                mode: StopMode::Immediate,
            },
            Message::MoveStop {
                channel: 1,
                mode: StopMode::Profiled,
            },
            Message::ReqStatusUpdate { channel: 1 },
            Message::GetStatusUpdate(block),
            Message::ReqUStatusUpdate { channel: 1 },
            Message::GetUStatusUpdate(UStatusBlock {
                channel: 1,
                position: 3,
                velocity: -2,
                current_ma: 300,
                status: 0x10,
            }),
            Message::AckUStatusUpdate,
            Message::ReqStatusBits { channel: 1 },
            Message::GetStatusBits {
                channel: 1,
                status: 0x4000,
            },
            Message::SetVelParams(vel),
            Message::ReqVelParams { channel: 1 },
            Message::GetVelParams(vel),
            Message::SetPosCounter {
                channel: 1,
                position: 0,
            },
            Message::ReqPosCounter { channel: 1 },
            Message::GetPosCounter {
                channel: 1,
                position: 77,
            },
            Message::SetTstActuatorType { actuator: 0x42 },
            Message::MoveAbsoluteStored { channel: 1 },
            Message::MoveRelativeStored { channel: 1 },
            Message::SetMoveAbsParams {
                channel: 1,
                position: 4096,
            },
            Message::ReqMoveAbsParams { channel: 1 },
            Message::GetMoveAbsParams {
                channel: 1,
                position: -4096,
            },
            Message::SetMoveRelParams {
                channel: 1,
                distance: -2,
            },
            Message::ReqMoveRelParams { channel: 1 },
            Message::GetMoveRelParams {
                channel: 1,
                distance: 2,
            },
            Message::SuspendEndOfMoveMsgs,
            Message::ResumeEndOfMoveMsgs,
        ];
        for m in all {
            let p = Packet::to_device(0x23, m);
            let bytes = encode(&p);
            assert_eq!(decode(&bytes).as_ref(), Ok(&p), "{}", p.message.name());
            assert_eq!(frame_len(&bytes), Ok(bytes.len()));
        }
    }

    #[test]
    fn bad_frames_are_errors() {
        assert_eq!(
            decode(&hex("ff ff 00 00 50 01")),
            Err(DecodeError::UnknownId(0xffff))
        );
        assert!(matches!(
            decode(&hex("53 04 00 01 d0 01")),
            Err(DecodeError::Shape { .. })
        ));
        // A long-only message without the data flag.
        assert!(matches!(
            decode(&hex("13 04 06 00 50 01")),
            Err(DecodeError::Shape { .. })
        ));
        // MOT_MOVE_ABSOLUTE has a short form: move to the stored absolute position.
        assert_eq!(
            decode(&hex("53 04 01 00 50 01")).map(|p| p.message),
            Ok(Message::MoveAbsoluteStored { channel: 1 })
        );
        assert_eq!(decode(&hex("23 02")), Err(DecodeError::TooShort(2)));
    }
}
