//! The sans-io drive: a request PDU goes in, the response PDU comes out, with the host time passed
//! in. The registers are the [`RegisterMap`]'s; motion is a shared [`SimMotor`]. No I/O and no
//! threads; [`super::framing`] and [`super::server`] put it on a link.

use crate::physics::motion::{Kinematics, SimMotor};
use fringe_rig::HostTime;
use fringe_rig::{
    modbus::{Field, Role},
    RegisterMap,
};
use fringe_rig::{Millimetres, MillimetresPerSecond, MillimetresPerSecondSquared};
use std::collections::HashMap;
use std::sync::Arc;

/// Modbus exception codes the emulated drive answers with.
pub(crate) const ILLEGAL_FUNCTION: u8 = 0x01;
pub(crate) const ILLEGAL_DATA_ADDRESS: u8 = 0x02;
pub(crate) const ILLEGAL_DATA_VALUE: u8 = 0x03;

/// How a register is used.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kind {
    /// Holds what is written.
    Plain,
    /// Feedback position (read-only), word 0 or 1.
    Feedback(u8),
    /// Status (read-only), word index.
    Status(u8),
}

/// A Modbus request as a drive receives it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum ServerRequest {
    /// 0x03 or 0x04.
    Read {
        function: u8,
        start: u16,
        count: u16,
    },
    /// 0x06.
    WriteSingle { address: u16, value: u16 },
    /// 0x10.
    WriteMultiple { start: u16, values: Vec<u16> },
}

/// Decodes a request PDU; `Err` is the exception code to answer with.
pub fn decode_request_pdu(pdu: &[u8]) -> Result<ServerRequest, u8> {
    let word = |i: usize| -> Result<u16, u8> {
        match (pdu.get(i), pdu.get(i + 1)) {
            (Some(&h), Some(&l)) => Ok(u16::from_be_bytes([h, l])),
            _ => Err(ILLEGAL_DATA_VALUE),
        }
    };
    match pdu.first() {
        Some(&f @ (0x03 | 0x04)) => {
            let count = word(3)?;
            if pdu.len() != 5 || count == 0 || count > 125 {
                return Err(ILLEGAL_DATA_VALUE);
            }
            Ok(ServerRequest::Read {
                function: f,
                start: word(1)?,
                count,
            })
        }
        Some(0x06) => {
            if pdu.len() != 5 {
                return Err(ILLEGAL_DATA_VALUE);
            }
            Ok(ServerRequest::WriteSingle {
                address: word(1)?,
                value: word(3)?,
            })
        }
        Some(0x10) => {
            let count = word(3)?;
            let bytes = pdu.get(5).copied().ok_or(ILLEGAL_DATA_VALUE)? as usize;
            if count == 0 || count > 123 || bytes != 2 * count as usize || pdu.len() != 6 + bytes {
                return Err(ILLEGAL_DATA_VALUE);
            }
            let values = (0..count as usize)
                .map(|i| word(6 + 2 * i))
                .collect::<Result<Vec<_>, _>>()?;
            Ok(ServerRequest::WriteMultiple {
                start: word(1)?,
                values,
            })
        }
        _ => Err(ILLEGAL_FUNCTION),
    }
}

/// The sans-io drive.
pub struct ModbusCore {
    map: RegisterMap,
    motor: Arc<SimMotor>,
    kinds: HashMap<u16, Kind>,
    values: HashMap<u16, u16>,
    injected_alarm: bool,
    /// A move ended on a limit switch (over-travel alarm), cleared by [`ModbusCore::clear_alarm`].
    overtravel: bool,
    /// The last motion command was a positioning move (not homing, not a stop).
    last_was_move: bool,
    requests: u64,
}

impl ModbusCore {
    /// A drive with `map`'s registers moving `motor`; speed and acceleration registers start at
    /// the map's profile (or the motor's kinematics).
    pub fn new(map: RegisterMap, motor: Arc<SimMotor>) -> ModbusCore {
        let mut kinds = HashMap::new();
        let mut plain = |address: u16, words: u8| {
            for k in 0..u16::from(words) {
                kinds.insert(address.wrapping_add(k), Kind::Plain);
            }
        };
        for w in &map.preset {
            plain(w.address, w.words);
        }
        if let Some(op) = &map.operation {
            plain(op.address, op.words);
        }
        plain(map.registers.target_position, 2);
        for f in [
            map.registers.speed,
            map.registers.acceleration,
            map.registers.deceleration,
        ]
        .into_iter()
        .flatten()
        {
            plain(f.address, f.words);
        }
        plain(map.trigger.address, map.trigger.words);
        if let Some(h) = &map.homing {
            for w in &h.writes {
                plain(w.address, w.words);
            }
        }
        let fb = map.registers.feedback_position;
        kinds.insert(fb, Kind::Feedback(0));
        kinds.insert(fb.wrapping_add(1), Kind::Feedback(1));
        for k in 0..map.status.words {
            kinds.insert(
                map.status.address.wrapping_add(u16::from(k)),
                Kind::Status(k),
            );
        }
        let mut core = ModbusCore {
            kinds,
            values: HashMap::new(),
            injected_alarm: false,
            overtravel: false,
            last_was_move: false,
            requests: 0,
            map,
            motor,
        };
        let k = core.motor.kinematics();
        let (speed, accel, decel) = match core.map.profile {
            Some(p) => (p.speed_mm_s, p.accel_mm_s2, p.decel_mm_s2),
            None => (k.velocity.0, k.acceleration.0, k.acceleration.0),
        };
        for (field, physical) in [
            (core.map.registers.speed, speed),
            (core.map.registers.acceleration, accel),
            (core.map.registers.deceleration, decel),
        ] {
            if let Some(f) = field {
                let raw = if f.inverse {
                    f.scale / physical
                } else {
                    f.scale * physical
                };
                let regs = core.map.encode(raw.round().max(1.0) as i64, f.words);
                core.store(f.address, &regs);
            }
        }
        core
    }

    /// The register map.
    pub fn map(&self) -> &RegisterMap {
        &self.map
    }

    /// The motor the drive moves.
    pub fn motor(&self) -> &Arc<SimMotor> {
        &self.motor
    }

    /// Requests answered so far.
    pub fn requests(&self) -> u64 {
        self.requests
    }

    /// Raises (or lowers) an injected alarm.
    pub fn set_alarm(&mut self, on: bool) {
        self.injected_alarm = on;
    }

    /// Clears every alarm (the drive's alarm reset).
    pub fn clear_alarm(&mut self) {
        self.injected_alarm = false;
        self.overtravel = false;
        // Acknowledged: the carriage may rest on the switch and move away from it.
        self.last_was_move = false;
    }

    fn store(&mut self, address: u16, regs: &[u16]) {
        for (k, v) in regs.iter().enumerate() {
            self.values.insert(address.wrapping_add(k as u16), *v);
        }
    }

    fn load(&self, address: u16, words: u8) -> u32 {
        let regs: Vec<u16> = (0..u16::from(words))
            .map(|k| {
                self.values
                    .get(&address.wrapping_add(k))
                    .copied()
                    .unwrap_or(0)
            })
            .collect();
        self.map.decode_unsigned(&regs)
    }

    fn signed(&self, address: u16, words: u8) -> i64 {
        let v = self.load(address, words);
        if words == 1 {
            i64::from(v as u16 as i16)
        } else {
            i64::from(v as i32)
        }
    }

    /// The alarm state at `now`.
    fn alarm(&mut self, now: HostTime) -> bool {
        let s = self.motor.status_at(now);
        if self.last_was_move && !s.moving && (s.forward_limit || s.reverse_limit) {
            self.overtravel = true;
        }
        self.injected_alarm || self.overtravel
    }

    /// The status register's value at `now`.
    pub fn status_word(&mut self, now: HostTime) -> u32 {
        let alarm = self.alarm(now);
        let s = self.motor.status_at(now);
        self.map
            .status
            .bits
            .iter()
            .filter(|b| match b.role {
                Role::Moving => s.moving,
                Role::Alarm => alarm,
                Role::Ready => !s.moving && !alarm,
                Role::Homed => s.homed,
                Role::Info => false,
            })
            .fold(0, |acc, b| acc | b.mask)
    }

    fn feedback_steps(&self, now: HostTime) -> i32 {
        let p = self.motor.status_at(now).position.0 * self.map.steps_per_mm;
        p.round().clamp(f64::from(i32::MIN), f64::from(i32::MAX)) as i32
    }

    fn read(&mut self, start: u16, count: u16, now: HostTime) -> Result<Vec<u16>, u8> {
        let mut out = Vec::with_capacity(count as usize);
        let status = self.map.status.words;
        for k in 0..count {
            let address = start.checked_add(k).ok_or(ILLEGAL_DATA_ADDRESS)?;
            let value = match self.kinds.get(&address).copied() {
                None => return Err(ILLEGAL_DATA_ADDRESS),
                Some(Kind::Plain) => self.values.get(&address).copied().unwrap_or(0),
                Some(Kind::Feedback(w)) => {
                    self.map.encode(i64::from(self.feedback_steps(now)), 2)[w as usize]
                }
                Some(Kind::Status(w)) => {
                    let word = self.status_word(now);
                    self.map.encode(i64::from(word), status)[w as usize]
                }
            };
            out.push(value);
        }
        Ok(out)
    }

    fn write(&mut self, start: u16, values: &[u16], now: HostTime) -> Result<(), u8> {
        for k in 0..values.len() {
            let address = start.checked_add(k as u16).ok_or(ILLEGAL_DATA_ADDRESS)?;
            if self.kinds.get(&address) != Some(&Kind::Plain) {
                return Err(ILLEGAL_DATA_ADDRESS);
            }
        }
        let before: Vec<(u16, Option<u16>)> = (0..values.len())
            .map(|k| {
                let a = start.wrapping_add(k as u16);
                (a, self.values.get(&a).copied())
            })
            .collect();
        self.store(start, values);
        let touched = |address: u16, words: u8| {
            address < start.wrapping_add(values.len() as u16)
                && start < address.wrapping_add(u16::from(words))
        };
        let mut result = Ok(());
        let t = self.map.trigger.clone();
        if touched(t.address, t.words) {
            result = self.trigger(self.signed(t.address, t.words), now);
        }
        if let Some(h) = self.map.homing.clone() {
            for w in &h.writes {
                if touched(w.address, w.words) && self.signed(w.address, w.words) == w.value {
                    self.start_homing(now);
                }
            }
        }
        if result.is_err() {
            // The drive rejects the command: the register keeps its old value.
            for (a, v) in before {
                match v {
                    Some(v) => self.values.insert(a, v),
                    None => self.values.remove(&a),
                };
            }
        }
        result
    }

    fn physical(&self, field: Option<Field>) -> Result<Option<f64>, u8> {
        let Some(f) = field else { return Ok(None) };
        let raw = f64::from(self.load(f.address, f.words));
        if raw <= 0.0 {
            return Err(ILLEGAL_DATA_VALUE);
        }
        Ok(Some(if f.inverse {
            f.scale / raw
        } else {
            raw / f.scale
        }))
    }

    fn trigger(&mut self, value: i64, now: HostTime) -> Result<(), u8> {
        let t = &self.map.trigger;
        if value == t.start {
            return self.start_move(now);
        }
        if Some(value) == t.estop {
            self.motor.stop(now, true);
            self.last_was_move = false;
            return Ok(());
        }
        if Some(value) == t.stop {
            self.motor.stop(now, false);
            self.last_was_move = false;
            return Ok(());
        }
        if value == 0 {
            // Releasing the trigger input.
            return Ok(());
        }
        // Homing through the trigger register (Leadshine) is handled by the homing writes.
        let homing = self.map.homing.as_ref().is_some_and(|h| {
            h.writes
                .iter()
                .any(|w| w.address == t.address && w.value == value)
        });
        if homing {
            Ok(())
        } else {
            Err(ILLEGAL_DATA_VALUE)
        }
    }

    fn start_move(&mut self, now: HostTime) -> Result<(), u8> {
        let relative = match &self.map.operation {
            None => false,
            Some(op) => {
                let v = self.signed(op.address, op.words);
                if v == op.absolute {
                    false
                } else if Some(v) == op.relative {
                    true
                } else {
                    return Err(ILLEGAL_DATA_VALUE);
                }
            }
        };
        let speed = self.physical(self.map.registers.speed)?;
        let accel = self.physical(self.map.registers.acceleration)?;
        self.physical(self.map.registers.deceleration)?;
        if self.alarm(now) {
            // A drive in alarm accepts the write but does not move.
            return Ok(());
        }
        let k = self.motor.kinematics();
        self.motor.set_kinematics(Kinematics {
            velocity: speed.map_or(k.velocity, MillimetresPerSecond),
            acceleration: accel.map_or(k.acceleration, MillimetresPerSecondSquared),
        });
        let steps = self.signed(self.map.registers.target_position, 2);
        let mm = Millimetres(steps as f64 / self.map.steps_per_mm);
        if relative {
            self.motor.move_by(now, mm);
        } else {
            self.motor.move_to(now, mm);
        }
        self.last_was_move = true;
        Ok(())
    }

    fn start_homing(&mut self, now: HostTime) {
        if self.alarm(now) {
            return;
        }
        let speed = self
            .physical(self.map.registers.speed)
            .ok()
            .flatten()
            .map_or(self.motor.kinematics().velocity, MillimetresPerSecond);
        self.motor.home(now, speed);
        self.last_was_move = false;
    }

    /// Answers one request PDU at `now` with the response PDU.
    pub fn handle_pdu(&mut self, pdu: &[u8], now: HostTime) -> Vec<u8> {
        self.requests += 1;
        let function = pdu.first().copied().unwrap_or(0);
        let result = decode_request_pdu(pdu).and_then(|request| match request {
            ServerRequest::Read {
                function,
                start,
                count,
            } => self.read(start, count, now).map(|values| {
                let mut out = vec![function, (values.len() * 2) as u8];
                for v in values {
                    out.extend_from_slice(&v.to_be_bytes());
                }
                out
            }),
            ServerRequest::WriteSingle { address, value } => {
                self.write(address, &[value], now).map(|()| pdu.to_vec())
            }
            ServerRequest::WriteMultiple { start, values } => {
                self.write(start, &values, now).map(|()| {
                    let mut out = vec![0x10];
                    out.extend_from_slice(&start.to_be_bytes());
                    out.extend_from_slice(&(values.len() as u16).to_be_bytes());
                    out
                })
            }
        });
        match result {
            Ok(response) => response,
            Err(code) => vec![function | 0x80, code],
        }
    }
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;
    use crate::physics::motion::MotorSpec;

    fn motor() -> Arc<SimMotor> {
        Arc::new(SimMotor::new(MotorSpec {
            name: "y".into(),
            travel: Millimetres(50.0),
            power_up_position: Millimetres(10.0),
            kinematics: Kinematics {
                velocity: MillimetresPerSecond(5.0),
                acceleration: MillimetresPerSecondSquared(50.0),
            },
        }))
    }

    pub(crate) fn core(map: &str) -> ModbusCore {
        ModbusCore::new(RegisterMap::load(map).expect("map"), motor())
    }

    fn after(t: HostTime, s: f64) -> HostTime {
        HostTime(t.0 + (s * 1e9) as u64)
    }

    #[test]
    fn oriental_move_via_registers_and_exceptions() {
        let mut c = core("oriental-az");
        let t0 = HostTime::now();
        // Operation type absolute, target 600 steps (3 mm), then trigger 1.
        let w = |c: &mut ModbusCore, start: u16, values: &[u16], t| {
            let mut pdu = vec![0x10];
            pdu.extend_from_slice(&start.to_be_bytes());
            pdu.extend_from_slice(&(values.len() as u16).to_be_bytes());
            pdu.push((values.len() * 2) as u8);
            for v in values {
                pdu.extend_from_slice(&v.to_be_bytes());
            }
            c.handle_pdu(&pdu, t)
        };
        assert_eq!(
            w(&mut c, 0x005A, &[0, 1, 0, 600], t0),
            [0x10, 0x00, 0x5A, 0x00, 0x04]
        );
        assert_eq!(w(&mut c, 0x0066, &[0, 1], t0)[0], 0x10);
        let read = |c: &mut ModbusCore, start: u16, n: u16, t| {
            let mut pdu = vec![0x03];
            pdu.extend_from_slice(&start.to_be_bytes());
            pdu.extend_from_slice(&n.to_be_bytes());
            c.handle_pdu(&pdu, t)
        };
        let moving = read(&mut c, 0x007E, 2, after(t0, 0.1));
        assert_eq!(moving[..2], [0x03, 4]);
        assert_ne!(
            u16::from_be_bytes([moving[4], moving[5]]) & 0x2000,
            0,
            "MOVE bit"
        );
        let done = after(t0, 2.0);
        assert_eq!(read(&mut c, 0x0120, 2, done), [0x03, 4, 0, 0, 0x02, 0x58]);
        let status = read(&mut c, 0x007E, 2, done);
        assert_eq!(
            u16::from_be_bytes([status[4], status[5]]) & 0x2020,
            0x0020,
            "READY, not MOVE"
        );
        // Input registers read the same.
        assert_eq!(
            read(&mut c, 0x0120, 2, done)[2..],
            c.handle_pdu(&[0x04, 0x01, 0x20, 0, 2], done)[2..]
        );
        // Exceptions: unknown register, read-only register, bad count, unknown function, bad value.
        assert_eq!(read(&mut c, 0x0200, 1, done), [0x83, 0x02]);
        assert_eq!(
            read(&mut c, 0x0120, 3, done),
            [0x83, 0x02],
            "0x0122 does not exist"
        );
        assert_eq!(c.handle_pdu(&[0x06, 0x01, 0x20, 0, 1], done), [0x86, 0x02]);
        assert_eq!(read(&mut c, 0x0120, 0, done), [0x83, 0x03]);
        assert_eq!(c.handle_pdu(&[0x2B, 0x0E, 0x01, 0x00], done), [0xAB, 0x01]);
        assert_eq!(
            w(&mut c, 0x0066, &[0, 7], done),
            [0x90, 0x03],
            "unknown trigger value"
        );
        assert_eq!(
            w(&mut c, 0x005E, &[0, 0], done)[0],
            0x10,
            "speed 0 is stored..."
        );
        assert_eq!(
            w(&mut c, 0x0066, &[0, 1], done),
            [0x90, 0x03],
            "...but refused at the trigger"
        );
    }

    #[test]
    fn overtravel_and_injected_alarms_block_motion() {
        let mut c = core("leadshine-pr");
        let t0 = HostTime::now();
        // 100 mm is past the 50 mm travel: the move ends on the forward limit switch.
        let steps = 200_000u32;
        let pdu = |regs: &[(u16, u16)]| -> Vec<Vec<u8>> {
            regs.iter()
                .map(|(a, v)| {
                    [
                        vec![0x06],
                        a.to_be_bytes().to_vec(),
                        v.to_be_bytes().to_vec(),
                    ]
                    .concat()
                })
                .collect()
        };
        for p in pdu(&[
            (0x6200, 1),
            (0x6201, (steps >> 16) as u16),
            (0x6202, steps as u16),
            (0x6002, 0x10),
        ]) {
            assert_eq!(c.handle_pdu(&p, t0), p, "echo");
        }
        let end = after(t0, 30.0);
        let alarm = c.status_word(end);
        assert_eq!(alarm & 0x0001, 1, "fault bit after over-travel: {alarm:#x}");
        c.clear_alarm();
        assert_eq!(c.status_word(end) & 0x0003, 0x0002, "enabled again");
        c.set_alarm(true);
        let pos = c.motor().status_at(end).position;
        for p in pdu(&[(0x6201, 0), (0x6202, 0), (0x6002, 0x10)]) {
            c.handle_pdu(&p, end);
        }
        assert_eq!(
            c.motor().status_at(after(end, 5.0)).position,
            pos,
            "no motion in alarm"
        );
    }
}
