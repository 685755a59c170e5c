//! APT addresses, message ids and how each id is framed (short, long and its data length).
//! Constants and a table, no I/O.

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
pub(crate) fn is_controller_address(a: u8) -> bool {
    a == RACK || a == USB_UNIT || (0x21..=0x2A).contains(&a)
}

/// No APT data packet is longer than this.
pub(crate) const MAX_DATA_LEN: usize = 255;

/// Message ids.
pub(crate) mod id {
    pub(crate) const HW_REQ_INFO: u16 = 0x0005;
    pub(crate) const HW_GET_INFO: u16 = 0x0006;
    pub(crate) const HW_START_UPDATEMSGS: u16 = 0x0011;
    pub(crate) const HW_STOP_UPDATEMSGS: u16 = 0x0012;
    pub(crate) const HW_NO_FLASH_PROGRAMMING: u16 = 0x0018;
    pub(crate) const HW_RESPONSE: u16 = 0x0080;
    pub(crate) const HW_RICHRESPONSE: u16 = 0x0081;
    pub(crate) const MOD_SET_CHANENABLESTATE: u16 = 0x0210;
    pub(crate) const MOD_REQ_CHANENABLESTATE: u16 = 0x0211;
    pub(crate) const MOD_GET_CHANENABLESTATE: u16 = 0x0212;
    pub(crate) const MOD_IDENTIFY: u16 = 0x0223;
    pub(crate) const MOT_SET_POSCOUNTER: u16 = 0x0410;
    pub(crate) const MOT_REQ_POSCOUNTER: u16 = 0x0411;
    pub(crate) const MOT_GET_POSCOUNTER: u16 = 0x0412;
    pub(crate) const MOT_SET_VELPARAMS: u16 = 0x0413;
    pub(crate) const MOT_REQ_VELPARAMS: u16 = 0x0414;
    pub(crate) const MOT_GET_VELPARAMS: u16 = 0x0415;
    pub(crate) const MOT_REQ_STATUSBITS: u16 = 0x0429;
    pub(crate) const MOT_GET_STATUSBITS: u16 = 0x042A;
    pub(crate) const MOT_SET_HOMEPARAMS: u16 = 0x0440;
    pub(crate) const MOT_REQ_HOMEPARAMS: u16 = 0x0441;
    pub(crate) const MOT_GET_HOMEPARAMS: u16 = 0x0442;
    pub(crate) const MOT_SET_MOVERELPARAMS: u16 = 0x0445;
    pub(crate) const MOT_REQ_MOVERELPARAMS: u16 = 0x0446;
    pub(crate) const MOT_GET_MOVERELPARAMS: u16 = 0x0447;
    pub(crate) const MOT_MOVE_HOME: u16 = 0x0443;
    pub(crate) const MOT_MOVE_HOMED: u16 = 0x0444;
    pub(crate) const MOT_MOVE_RELATIVE: u16 = 0x0448;
    pub(crate) const MOT_SET_MOVEABSPARAMS: u16 = 0x0450;
    pub(crate) const MOT_REQ_MOVEABSPARAMS: u16 = 0x0451;
    pub(crate) const MOT_GET_MOVEABSPARAMS: u16 = 0x0452;
    pub(crate) const MOT_MOVE_ABSOLUTE: u16 = 0x0453;
    pub(crate) const MOT_MOVE_COMPLETED: u16 = 0x0464;
    pub(crate) const MOT_MOVE_STOP: u16 = 0x0465;
    pub(crate) const MOT_MOVE_STOPPED: u16 = 0x0466;
    pub(crate) const MOT_SUSPEND_ENDOFMOVEMSGS: u16 = 0x046B;
    pub(crate) const MOT_RESUME_ENDOFMOVEMSGS: u16 = 0x046C;
    pub(crate) const MOT_REQ_STATUSUPDATE: u16 = 0x0480;
    pub(crate) const MOT_GET_STATUSUPDATE: u16 = 0x0481;
    pub(crate) const MOT_REQ_USTATUSUPDATE: u16 = 0x0490;
    pub(crate) const MOT_GET_USTATUSUPDATE: u16 = 0x0491;
    pub(crate) const MOT_ACK_USTATUSUPDATE: u16 = 0x0492;
    pub(crate) const MOT_SET_TSTACTUATORTYPE: u16 = 0x04FE;
}

/// How a message id is framed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Shape {
    Short,
    /// Long with exactly this many data bytes.
    Long(usize),
    /// Long with either of these lengths (the first is the one we encode).
    LongEither(usize, usize),
    /// Short, or long with this many data bytes.
    ShortOrLong(usize),
}

/// How `message_id` is framed and its protocol name, if this codec knows it.
pub(super) fn shape(message_id: u16) -> Option<(Shape, &'static str)> {
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
pub(crate) fn message_name(message_id: u16) -> Option<&'static str> {
    shape(message_id).map(|(_, n)| n)
}
