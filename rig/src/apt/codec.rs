//! APT frames: pure encode/decode, no I/O.
//!
//! Two frame shapes, little-endian:
//! - short, 6 bytes: `id u16, param1 u8, param2 u8, dest u8, source u8`;
//! - long: `id u16, datalen u16, dest | 0x80, source`, then `datalen` data bytes.
//!
//! [`encode`] and [`decode`] convert one frame; [`StreamDecoder`] splits a byte stream into
//! packets and resynchronises on garbage by dropping one byte at a time.

use std::fmt;

/// The host (PC) address.
pub const HOST: u8 = 0x01;
/// A rack controller (BSC202/203 as a whole).
pub const RACK: u8 = 0x11;
/// A generic USB unit (K-Cubes, BSC201).
pub const USB_UNIT: u8 = 0x50;

/// The address of rack bay `bay` (0..=9): 0x21..=0x2A.
pub fn bay_address(bay: u8) -> Option<u8> {
    (bay <= 9).then_some(0x21 + bay)
}

/// True for an address a controller may use as its own.
pub fn is_controller_address(a: u8) -> bool {
    a == RACK || a == USB_UNIT || (0x21..=0x2A).contains(&a)
}

/// No APT data packet is longer than this.
pub const MAX_DATA_LEN: usize = 255;

/// Message ids.
pub mod id {
    pub const HW_REQ_INFO: u16 = 0x0005;
    pub const HW_GET_INFO: u16 = 0x0006;
    pub const HW_START_UPDATEMSGS: u16 = 0x0011;
    pub const HW_STOP_UPDATEMSGS: u16 = 0x0012;
    pub const HW_NO_FLASH_PROGRAMMING: u16 = 0x0018;
    pub const HW_RESPONSE: u16 = 0x0080;
    pub const HW_RICHRESPONSE: u16 = 0x0081;
    pub const MOD_SET_CHANENABLESTATE: u16 = 0x0210;
    pub const MOD_REQ_CHANENABLESTATE: u16 = 0x0211;
    pub const MOD_GET_CHANENABLESTATE: u16 = 0x0212;
    pub const MOD_IDENTIFY: u16 = 0x0223;
    pub const MOT_SET_POSCOUNTER: u16 = 0x0410;
    pub const MOT_REQ_POSCOUNTER: u16 = 0x0411;
    pub const MOT_GET_POSCOUNTER: u16 = 0x0412;
    pub const MOT_SET_VELPARAMS: u16 = 0x0413;
    pub const MOT_REQ_VELPARAMS: u16 = 0x0414;
    pub const MOT_GET_VELPARAMS: u16 = 0x0415;
    pub const MOT_REQ_STATUSBITS: u16 = 0x0429;
    pub const MOT_GET_STATUSBITS: u16 = 0x042A;
    pub const MOT_SET_HOMEPARAMS: u16 = 0x0440;
    pub const MOT_REQ_HOMEPARAMS: u16 = 0x0441;
    pub const MOT_GET_HOMEPARAMS: u16 = 0x0442;
    pub const MOT_SET_MOVERELPARAMS: u16 = 0x0445;
    pub const MOT_REQ_MOVERELPARAMS: u16 = 0x0446;
    pub const MOT_GET_MOVERELPARAMS: u16 = 0x0447;
    pub const MOT_MOVE_HOME: u16 = 0x0443;
    pub const MOT_MOVE_HOMED: u16 = 0x0444;
    pub const MOT_MOVE_RELATIVE: u16 = 0x0448;
    pub const MOT_SET_MOVEABSPARAMS: u16 = 0x0450;
    pub const MOT_REQ_MOVEABSPARAMS: u16 = 0x0451;
    pub const MOT_GET_MOVEABSPARAMS: u16 = 0x0452;
    pub const MOT_MOVE_ABSOLUTE: u16 = 0x0453;
    pub const MOT_MOVE_COMPLETED: u16 = 0x0464;
    pub const MOT_MOVE_STOP: u16 = 0x0465;
    pub const MOT_MOVE_STOPPED: u16 = 0x0466;
    pub const MOT_SUSPEND_ENDOFMOVEMSGS: u16 = 0x046B;
    pub const MOT_RESUME_ENDOFMOVEMSGS: u16 = 0x046C;
    pub const MOT_REQ_STATUSUPDATE: u16 = 0x0480;
    pub const MOT_GET_STATUSUPDATE: u16 = 0x0481;
    pub const MOT_REQ_USTATUSUPDATE: u16 = 0x0490;
    pub const MOT_GET_USTATUSUPDATE: u16 = 0x0491;
    pub const MOT_ACK_USTATUSUPDATE: u16 = 0x0492;
    pub const MOT_SET_TSTACTUATORTYPE: u16 = 0x04FE;
}

/// How a message id is framed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Shape {
    Short,
    /// Long with exactly this many data bytes.
    Long(usize),
    /// Long with either of these lengths (the first is the one we encode).
    LongEither(usize, usize),
    /// Short, or long with this many data bytes.
    ShortOrLong(usize),
}

fn shape(message_id: u16) -> Option<(Shape, &'static str)> {
    use id::*;
    use Shape::*;
    Some(match message_id {
        HW_REQ_INFO => (Short, "HW_REQ_INFO"),
        HW_GET_INFO => (Long(84), "HW_GET_INFO"),
        HW_START_UPDATEMSGS => (Short, "HW_START_UPDATEMSGS"),
        HW_STOP_UPDATEMSGS => (Short, "HW_STOP_UPDATEMSGS"),
        HW_NO_FLASH_PROGRAMMING => (Short, "HW_NO_FLASH_PROGRAMMING"),
        HW_RESPONSE => (Short, "HW_RESPONSE"),
        HW_RICHRESPONSE => (Long(68), "HW_RICHRESPONSE"),
        MOD_SET_CHANENABLESTATE => (Short, "MOD_SET_CHANENABLESTATE"),
        MOD_REQ_CHANENABLESTATE => (Short, "MOD_REQ_CHANENABLESTATE"),
        MOD_GET_CHANENABLESTATE => (Short, "MOD_GET_CHANENABLESTATE"),
        MOD_IDENTIFY => (Short, "MOD_IDENTIFY"),
        MOT_SET_POSCOUNTER => (Long(6), "MOT_SET_POSCOUNTER"),
        MOT_REQ_POSCOUNTER => (Short, "MOT_REQ_POSCOUNTER"),
        MOT_GET_POSCOUNTER => (Long(6), "MOT_GET_POSCOUNTER"),
        MOT_SET_VELPARAMS => (Long(14), "MOT_SET_VELPARAMS"),
        MOT_REQ_VELPARAMS => (Short, "MOT_REQ_VELPARAMS"),
        MOT_GET_VELPARAMS => (Long(14), "MOT_GET_VELPARAMS"),
        MOT_REQ_STATUSBITS => (Short, "MOT_REQ_STATUSBITS"),
        MOT_GET_STATUSBITS => (Long(6), "MOT_GET_STATUSBITS"),
        MOT_SET_HOMEPARAMS => (Long(14), "MOT_SET_HOMEPARAMS"),
        MOT_REQ_HOMEPARAMS => (Short, "MOT_REQ_HOMEPARAMS"),
        MOT_GET_HOMEPARAMS => (Long(14), "MOT_GET_HOMEPARAMS"),
        MOT_MOVE_HOME => (Short, "MOT_MOVE_HOME"),
        MOT_MOVE_HOMED => (Short, "MOT_MOVE_HOMED"),
        MOT_MOVE_RELATIVE => (ShortOrLong(6), "MOT_MOVE_RELATIVE"),
        MOT_MOVE_ABSOLUTE => (ShortOrLong(6), "MOT_MOVE_ABSOLUTE"),
        MOT_SET_MOVERELPARAMS => (Long(6), "MOT_SET_MOVERELPARAMS"),
        MOT_REQ_MOVERELPARAMS => (Short, "MOT_REQ_MOVERELPARAMS"),
        MOT_GET_MOVERELPARAMS => (Long(6), "MOT_GET_MOVERELPARAMS"),
        MOT_SET_MOVEABSPARAMS => (Long(6), "MOT_SET_MOVEABSPARAMS"),
        MOT_REQ_MOVEABSPARAMS => (Short, "MOT_REQ_MOVEABSPARAMS"),
        MOT_GET_MOVEABSPARAMS => (Long(6), "MOT_GET_MOVEABSPARAMS"),
        MOT_MOVE_COMPLETED => (ShortOrLong(14), "MOT_MOVE_COMPLETED"),
        MOT_MOVE_STOP => (Short, "MOT_MOVE_STOP"),
        MOT_MOVE_STOPPED => (ShortOrLong(14), "MOT_MOVE_STOPPED"),
        MOT_SUSPEND_ENDOFMOVEMSGS => (Short, "MOT_SUSPEND_ENDOFMOVEMSGS"),
        MOT_RESUME_ENDOFMOVEMSGS => (Short, "MOT_RESUME_ENDOFMOVEMSGS"),
        MOT_REQ_STATUSUPDATE => (Short, "MOT_REQ_STATUSUPDATE"),
        MOT_GET_STATUSUPDATE => (LongEither(14, 28), "MOT_GET_STATUSUPDATE"),
        MOT_REQ_USTATUSUPDATE => (Short, "MOT_REQ_USTATUSUPDATE"),
        MOT_GET_USTATUSUPDATE => (Long(14), "MOT_GET_USTATUSUPDATE"),
        MOT_ACK_USTATUSUPDATE => (Short, "MOT_ACK_USTATUSUPDATE"),
        MOT_SET_TSTACTUATORTYPE => (Short, "MOT_SET_TSTACTUATORTYPE"),
        _ => return None,
    })
}

/// The protocol name of a message id ("MOT_MOVE_COMPLETED"), if this codec knows it.
pub fn message_name(message_id: u16) -> Option<&'static str> {
    shape(message_id).map(|(_, n)| n)
}

/// Reply to HW_REQ_INFO (84 data bytes).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct HwInfo {
    pub serial_number: u32,
    /// Model, e.g. "KST101" (NUL padding removed).
    pub model: String,
    pub hw_type: u16,
    /// Firmware version bytes as sent: `[minor, interim, major, unused]`.
    pub firmware: [u8; 4],
    /// Free-text notes (NUL padding removed).
    pub notes: String,
    pub hw_version: u16,
    pub mod_state: u16,
    pub channels: u16,
}

impl HwInfo {
    /// "major.interim.minor".
    pub fn firmware_version(&self) -> String {
        format!(
            "{}.{}.{}",
            self.firmware[2], self.firmware[1], self.firmware[0]
        )
    }
}

/// The 14-byte status block of MOT_GET_STATUSUPDATE and of long MOVE_COMPLETED/STOPPED.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct StatusBlock {
    pub channel: u16,
    /// Position in microsteps.
    pub position: i32,
    /// Encoder count (steppers without encoder: 0).
    pub encoder: i32,
    pub status: u32,
}

/// The 14-byte block of MOT_GET_USTATUSUPDATE.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct UStatusBlock {
    pub channel: u16,
    pub position: i32,
    /// Velocity in device units (signed).
    pub velocity: i16,
    /// Motor current in mA.
    pub current_ma: i16,
    pub status: u32,
}

/// MOT_SET/GET_VELPARAMS payload, in device units.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct VelParams {
    pub channel: u16,
    pub min_velocity: i32,
    pub acceleration: i32,
    pub max_velocity: i32,
}

/// MOT_SET/GET_HOMEPARAMS payload, in device units.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct HomeParams {
    pub channel: u16,
    /// 1 forward, 2 reverse.
    pub direction: u16,
    /// 1 reverse hardware limit, 4 forward hardware limit.
    pub limit_switch: u16,
    pub velocity: i32,
    /// Offset from the limit switch, microsteps.
    pub offset: i32,
}

/// Stop mode of MOT_MOVE_STOP (param2).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StopMode {
    Immediate = 1,
    Profiled = 2,
}

/// A typed APT message.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Message {
    ModIdentify {
        channel: u8,
    },
    SetChanEnableState {
        channel: u8,
        enable: bool,
    },
    ReqChanEnableState {
        channel: u8,
    },
    GetChanEnableState {
        channel: u8,
        enabled: bool,
    },
    HwReqInfo,
    HwGetInfo(HwInfo),
    HwStartUpdateMsgs,
    HwStopUpdateMsgs,
    HwNoFlashProgramming,
    /// HW_RESPONSE: the controller reports an error (short form).
    HwResponse {
        param1: u8,
        param2: u8,
    },
    /// HW_RICHRESPONSE: an error with a code and text.
    HwRichResponse {
        message_id: u16,
        code: u16,
        notes: String,
    },
    MoveHome {
        channel: u8,
    },
    MoveHomed {
        channel: u8,
    },
    SetHomeParams(HomeParams),
    ReqHomeParams {
        channel: u8,
    },
    GetHomeParams(HomeParams),
    MoveAbsolute {
        channel: u16,
        position: i32,
    },
    MoveRelative {
        channel: u16,
        distance: i32,
    },
    /// Short MOT_MOVE_ABSOLUTE: move to the position stored by MOT_SET_MOVEABSPARAMS.
    MoveAbsoluteStored {
        channel: u8,
    },
    /// Short MOT_MOVE_RELATIVE: move by the distance stored by MOT_SET_MOVERELPARAMS.
    MoveRelativeStored {
        channel: u8,
    },
    SetMoveAbsParams {
        channel: u16,
        position: i32,
    },
    ReqMoveAbsParams {
        channel: u8,
    },
    GetMoveAbsParams {
        channel: u16,
        position: i32,
    },
    SetMoveRelParams {
        channel: u16,
        distance: i32,
    },
    ReqMoveRelParams {
        channel: u8,
    },
    GetMoveRelParams {
        channel: u16,
        distance: i32,
    },
    /// Short form carries only the channel; the long form a status block.
    MoveCompleted {
        channel: u16,
        status: Option<StatusBlock>,
    },
    MoveStopped {
        channel: u16,
        status: Option<StatusBlock>,
    },
    MoveStop {
        channel: u8,
        mode: StopMode,
    },
    ReqStatusUpdate {
        channel: u8,
    },
    GetStatusUpdate(StatusBlock),
    ReqUStatusUpdate {
        channel: u8,
    },
    GetUStatusUpdate(UStatusBlock),
    AckUStatusUpdate,
    ReqStatusBits {
        channel: u8,
    },
    GetStatusBits {
        channel: u16,
        status: u32,
    },
    SetVelParams(VelParams),
    ReqVelParams {
        channel: u8,
    },
    GetVelParams(VelParams),
    SetPosCounter {
        channel: u16,
        position: i32,
    },
    ReqPosCounter {
        channel: u8,
    },
    GetPosCounter {
        channel: u16,
        position: i32,
    },
    SetTstActuatorType {
        actuator: u8,
    },
    SuspendEndOfMoveMsgs,
    ResumeEndOfMoveMsgs,
}

impl Message {
    /// The message id.
    pub fn id(&self) -> u16 {
        use id::*;
        use Message::*;
        match self {
            ModIdentify { .. } => MOD_IDENTIFY,
            SetChanEnableState { .. } => MOD_SET_CHANENABLESTATE,
            ReqChanEnableState { .. } => MOD_REQ_CHANENABLESTATE,
            GetChanEnableState { .. } => MOD_GET_CHANENABLESTATE,
            HwReqInfo => HW_REQ_INFO,
            HwGetInfo(_) => HW_GET_INFO,
            HwStartUpdateMsgs => HW_START_UPDATEMSGS,
            HwStopUpdateMsgs => HW_STOP_UPDATEMSGS,
            HwNoFlashProgramming => HW_NO_FLASH_PROGRAMMING,
            HwResponse { .. } => HW_RESPONSE,
            HwRichResponse { .. } => HW_RICHRESPONSE,
            MoveHome { .. } => MOT_MOVE_HOME,
            MoveHomed { .. } => MOT_MOVE_HOMED,
            SetHomeParams(_) => MOT_SET_HOMEPARAMS,
            ReqHomeParams { .. } => MOT_REQ_HOMEPARAMS,
            GetHomeParams(_) => MOT_GET_HOMEPARAMS,
            MoveAbsolute { .. } => MOT_MOVE_ABSOLUTE,
            MoveRelative { .. } => MOT_MOVE_RELATIVE,
            MoveAbsoluteStored { .. } => MOT_MOVE_ABSOLUTE,
            MoveRelativeStored { .. } => MOT_MOVE_RELATIVE,
            SetMoveAbsParams { .. } => MOT_SET_MOVEABSPARAMS,
            ReqMoveAbsParams { .. } => MOT_REQ_MOVEABSPARAMS,
            GetMoveAbsParams { .. } => MOT_GET_MOVEABSPARAMS,
            SetMoveRelParams { .. } => MOT_SET_MOVERELPARAMS,
            ReqMoveRelParams { .. } => MOT_REQ_MOVERELPARAMS,
            GetMoveRelParams { .. } => MOT_GET_MOVERELPARAMS,
            MoveCompleted { .. } => MOT_MOVE_COMPLETED,
            MoveStopped { .. } => MOT_MOVE_STOPPED,
            MoveStop { .. } => MOT_MOVE_STOP,
            ReqStatusUpdate { .. } => MOT_REQ_STATUSUPDATE,
            GetStatusUpdate(_) => MOT_GET_STATUSUPDATE,
            ReqUStatusUpdate { .. } => MOT_REQ_USTATUSUPDATE,
            GetUStatusUpdate(_) => MOT_GET_USTATUSUPDATE,
            AckUStatusUpdate => MOT_ACK_USTATUSUPDATE,
            ReqStatusBits { .. } => MOT_REQ_STATUSBITS,
            GetStatusBits { .. } => MOT_GET_STATUSBITS,
            SetVelParams(_) => MOT_SET_VELPARAMS,
            ReqVelParams { .. } => MOT_REQ_VELPARAMS,
            GetVelParams(_) => MOT_GET_VELPARAMS,
            SetPosCounter { .. } => MOT_SET_POSCOUNTER,
            ReqPosCounter { .. } => MOT_REQ_POSCOUNTER,
            GetPosCounter { .. } => MOT_GET_POSCOUNTER,
            SetTstActuatorType { .. } => MOT_SET_TSTACTUATORTYPE,
            SuspendEndOfMoveMsgs => MOT_SUSPEND_ENDOFMOVEMSGS,
            ResumeEndOfMoveMsgs => MOT_RESUME_ENDOFMOVEMSGS,
        }
    }

    /// The protocol name ("MOT_MOVE_ABSOLUTE").
    pub fn name(&self) -> &'static str {
        message_name(self.id()).unwrap_or("unknown")
    }
}

/// A message with its addresses.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Packet {
    pub dest: u8,
    pub source: u8,
    pub message: Message,
}

impl Packet {
    /// A packet from the host to the controller at `dest`.
    pub fn to_device(dest: u8, message: Message) -> Packet {
        Packet {
            dest,
            source: HOST,
            message,
        }
    }

    /// A packet from the controller at `source` to the host.
    pub fn from_device(source: u8, message: Message) -> Packet {
        Packet {
            dest: HOST,
            source,
            message,
        }
    }
}

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

impl fmt::Display for Packet {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} 0x{:02x}->0x{:02x}",
            self.message.name(),
            self.source,
            self.dest
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

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
