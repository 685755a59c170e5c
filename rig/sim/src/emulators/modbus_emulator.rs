//! An emulated Modbus y stage: a drive described by a [`RegisterMap`] (the shipped `oriental-az`
//! and `leadshine-pr` maps, or any other) moving a [`SimMotor`], served over Modbus TCP, Modbus RTU
//! on a pseudo-terminal, or an in-process byte pipe, so the real [`fringe_rig::ModbusStage`]
//! driver and third-party clients (pymodbus) run against it unchanged.
//!
//! [`ModbusCore`] is sans-io: a request PDU goes in, the response PDU comes out. It answers read
//! holding / input registers (0x03 / 0x04), write single register (0x06) and write multiple
//! registers (0x10) on the registers the map names, with the exceptions a drive gives: 0x01 for
//! other function codes, 0x02 for registers the map does not have (or writes to the read-only
//! feedback and status registers), 0x03 for bad counts and values the drive cannot act on. Writing
//! the trigger's start value applies the target, operation type, speed and acceleration registers
//! to the motor; its stop / emergency-stop values stop it; the map's homing writes start homing.
//! The status register shows the map's moving, ready, homed and alarm bits. A move that ends on a
//! limit switch raises the alarm (over-travel), as does [`ModbusEmulator::set_alarm`]; while in
//! alarm the drive refuses to start motion.
//!
//! - [`core`]: the sans-io drive: a request PDU in, the response PDU out, host time passed in.
//! - [`framing`]: Modbus TCP and RTU request frames taken off a byte buffer and answered by a
//!   core (sans-io: bytes in, reply frames out).
//! - [`line_timing`]: the drive's timing on an RTU line (turnaround, characters on the wire, the
//!   silent interval between frames), as documented.
//! - [`server`]: [`ModbusEmulator`], a core on threads over TCP, RTU on a pseudo-terminal or an
//!   in-process byte pipe.
//!
//! Over RTU (pseudo-terminal or in process) the drive keeps the documented timing of its line
//! speed (the map's `[serial] baud`): it replies a turnaround after the request plus both
//! frames' time on the wire, and drops a frame that starts less than 3.5 characters after its
//! own reply, as a drive on RS-485 does; a driver must keep the silent interval. Modbus TCP
//! answers as soon as the request is in (no drive documents a response time there).

pub(crate) mod core;
pub(crate) mod framing;
pub(crate) mod line_timing;
pub(crate) mod server;

pub use self::server::ModbusEmulator;
