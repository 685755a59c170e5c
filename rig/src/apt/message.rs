//! The typed APT messages and packets (a message with its addresses), with their payload
//! blocks. Plain data, no I/O; [`super::codec`] turns them into frames and back.

use super::ids::{id, message_name, HOST};
use std::fmt;

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
