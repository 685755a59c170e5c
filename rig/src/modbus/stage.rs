//! `ModbusStage`: a y stage driven through Modbus holding registers, as described by a
//! [`RegisterMap`].
//!
//! A move writes the map's presets, operation type, target, speed and accelerations (contiguous
//! registers merged into one write-multiple), then the trigger. Waiting polls the status and
//! feedback-position registers until the stage is idle at its target, an alarm bit is set, or the
//! timeout passes.

use super::codec::{self, CodecError, Framing, Parsed, Reply, Request, TcpHeader};
use super::map::{Profile, RegisterMap, Role, Write};
use crate::axis::{Axis, AxisError, AxisStatus, Kinematics, SoftLimits, StopMode};
use crate::transport::ByteLink;
use crate::units::{Millimetres, MillimetresPerSecond, MillimetresPerSecondSquared};
use std::time::{Duration, Instant};

/// Driver settings that are not part of the register map.
#[derive(Debug, Clone, PartialEq)]
pub struct StageOptions {
    /// Slave (unit) id; the map's when `None`.
    pub slave: Option<u8>,
    /// Checked before any move is sent.
    pub limits: Option<SoftLimits>,
    /// How long to wait for each reply.
    pub response_timeout: Duration,
    /// Pause between status polls while waiting for a motion.
    pub poll_interval: Duration,
    /// How long a triggered stage may stay idle away from its target before that is an error.
    pub start_grace: Duration,
    /// The RTU line's speed when it is not the map's (`[serial] baud`): it sets the silent
    /// interval kept between frames.
    pub baud: Option<u32>,
}

impl Default for StageOptions {
    fn default() -> Self {
        StageOptions {
            slave: None,
            limits: None,
            response_timeout: Duration::from_millis(500),
            poll_interval: Duration::from_millis(50),
            start_grace: Duration::from_millis(1000),
            baud: None,
        }
    }
}

#[derive(Debug, Clone, Copy)]
enum MotionKind {
    Move { target_steps: i64 },
    Home,
    Stopping,
}

#[derive(Debug, Clone, Copy)]
struct Motion {
    kind: MotionKind,
    started: Instant,
    seen_moving: bool,
}

struct Bit {
    name: &'static str,
    mask: u32,
    role: Role,
}

/// One poll of the stage.
struct Poll {
    raw: u32,
    steps: i64,
}

/// A Modbus y stage.
pub struct ModbusStage {
    axis: String,
    link: Box<dyn ByteLink>,
    framing: Framing,
    map: RegisterMap,
    slave: u8,
    options: StageOptions,
    bits: Vec<Bit>,
    transaction: u16,
    rx: Vec<u8>,
    motion: Option<Motion>,
    homed: bool,
    /// RTU: the silence every frame must follow (3.5 characters), and when the line last carried
    /// a frame (the end of the last reply, or of a request that got none).
    silent_interval: Duration,
    line_busy_until: Option<Instant>,
}

impl ModbusStage {
    /// A stage named `axis` on `link`, speaking `framing`, described by `map`.
    ///
    /// The status bit names of the map are kept for the life of the process (they are reported
    /// as `&'static str` flags); a stage is opened a handful of times per run.
    pub fn new(
        axis: &str,
        link: Box<dyn ByteLink>,
        framing: Framing,
        map: RegisterMap,
        options: StageOptions,
    ) -> ModbusStage {
        let bits = map
            .status
            .bits
            .iter()
            .map(|b| Bit {
                name: Box::leak(b.name.clone().into_boxed_str()),
                mask: b.mask,
                role: b.role,
            })
            .collect();
        let silent_interval = match framing {
            Framing::Rtu => {
                codec::rtu_silent_interval(options.baud.unwrap_or(map.serial_settings(None).baud))
            }
            Framing::Tcp => Duration::ZERO,
        };
        ModbusStage {
            axis: axis.to_string(),
            slave: options.slave.unwrap_or(map.slave),
            silent_interval,
            line_busy_until: None,
            link,
            framing,
            map,
            options,
            bits,
            transaction: 0,
            rx: Vec::new(),
            motion: None,
            homed: false,
        }
    }

    /// The register map in use.
    pub fn map(&self) -> &RegisterMap {
        &self.map
    }

    fn device_error(&self, message: String) -> AxisError {
        AxisError::Device {
            axis: self.axis.clone(),
            endpoint: self.endpoint(),
            message,
        }
    }

    /// Sends `request` and returns the reply's registers (empty for writes). On an RTU line the
    /// request waits for the silent interval after the last frame first: a drive takes a frame
    /// that follows the previous one sooner as part of it, and answers neither.
    fn transact(&mut self, request: &Request) -> Result<Vec<u16>, AxisError> {
        if let Some(busy) = self.line_busy_until {
            let free = busy + self.silent_interval;
            let now = Instant::now();
            if now < free {
                std::thread::sleep(free - now);
            }
        }
        let result = self.exchange(request);
        if self.framing == Framing::Rtu {
            self.line_busy_until = Some(Instant::now());
        }
        result
    }

    fn exchange(&mut self, request: &Request) -> Result<Vec<u16>, AxisError> {
        request
            .validate()
            .map_err(|e| self.device_error(e.to_string()))?;
        let frame = match self.framing {
            Framing::Rtu => {
                self.rx.clear();
                self.link.purge().map_err(|e| self.io_error(e))?;
                codec::encode_rtu(self.slave, request)
            }
            Framing::Tcp => {
                self.transaction = self.transaction.wrapping_add(1);
                codec::encode_tcp(
                    TcpHeader {
                        transaction: self.transaction,
                        unit: self.slave,
                    },
                    request,
                )
            }
        };
        self.link.write_all(&frame).map_err(|e| self.io_error(e))?;
        let deadline = Instant::now() + self.options.response_timeout;
        loop {
            match self.take_frame(request)? {
                Some(Reply::Registers(values)) => return Ok(values),
                Some(Reply::Written) => return Ok(Vec::new()),
                Some(Reply::Exception(code)) => {
                    return Err(self.device_error(format!(
                        "slave {} refused \"{request}\" with Modbus {code}",
                        self.slave
                    )))
                }
                None => {}
            }
            let now = Instant::now();
            if now >= deadline {
                return Err(self.no_reply(request));
            }
            let mut buf = [0u8; 512];
            let n = self
                .link
                .read(&mut buf, deadline - now)
                .map_err(|e| self.io_error(e))?;
            if n == 0 && Instant::now() >= deadline {
                return Err(self.no_reply(request));
            }
            self.rx.extend_from_slice(&buf[..n]);
        }
    }

    /// Takes one complete reply out of the receive buffer, if there is one.
    fn take_frame(&mut self, request: &Request) -> Result<Option<Reply>, AxisError> {
        loop {
            let parsed = match self.framing {
                Framing::Rtu => codec::parse_rtu(&self.rx).map(|p| match p {
                    Parsed::Incomplete => Parsed::Incomplete,
                    Parsed::Frame {
                        header,
                        response,
                        len,
                    } => Parsed::Frame {
                        header: (header, 0),
                        response,
                        len,
                    },
                }),
                Framing::Tcp => codec::parse_tcp(&self.rx).map(|p| match p {
                    Parsed::Incomplete => Parsed::Incomplete,
                    Parsed::Frame {
                        header,
                        response,
                        len,
                    } => Parsed::Frame {
                        header: (header.unit, header.transaction),
                        response,
                        len,
                    },
                }),
            };
            let (unit, transaction, response, len) = match parsed {
                Ok(Parsed::Incomplete) => return Ok(None),
                Ok(Parsed::Frame {
                    header: (unit, transaction),
                    response,
                    len,
                }) => (unit, transaction, response, len),
                Err(e) => {
                    self.rx.clear();
                    return Err(self.garbled(request, &e));
                }
            };
            self.rx.drain(..len);
            if self.framing == Framing::Tcp && transaction != self.transaction {
                // A late reply to an earlier request that had timed out: skip it.
                continue;
            }
            if unit != self.slave {
                return Err(self.device_error(format!(
                    "reply to \"{request}\" came from slave {unit}, expected slave {} (check --slave and the drive's address)",
                    self.slave
                )));
            }
            return codec::match_reply(request, &response)
                .map(Some)
                .map_err(|e| self.garbled(request, &e));
        }
    }

    fn garbled(&self, request: &Request, e: &CodecError) -> AxisError {
        self.device_error(format!(
            "bad reply from slave {} to \"{request}\": {e}",
            self.slave
        ))
    }

    fn no_reply(&self, request: &Request) -> AxisError {
        let check = match self.framing {
            Framing::Rtu => {
                let s = self.map.serial_settings(None);
                format!(
                    "check the RS-485 wiring, the slave id and the line settings (map says {} baud, parity {:?}, {} stop bit(s))",
                    s.baud, s.parity, s.stop_bits
                )
            }
            Framing::Tcp => {
                "check the unit id and that the device serves Modbus TCP on this port".to_string()
            }
        };
        AxisError::NotAnswering {
            axis: self.axis.clone(),
            endpoint: self.endpoint(),
            what: format!(
                "no reply from slave {} to \"{request}\" within {:?} ({check})",
                self.slave, self.options.response_timeout
            ),
            waited: self.options.response_timeout,
        }
    }

    fn io_error(&self, source: std::io::Error) -> AxisError {
        AxisError::Io {
            axis: self.axis.clone(),
            endpoint: self.endpoint(),
            source,
        }
    }

    /// Writes registers: contiguous runs merged into one write-multiple, single registers with
    /// write-single.
    fn write_registers(&mut self, mut regs: Vec<(u16, u16)>) -> Result<(), AxisError> {
        regs.sort_by_key(|&(a, _)| a);
        regs.dedup_by(|later, earlier| {
            if later.0 == earlier.0 {
                earlier.1 = later.1;
                true
            } else {
                false
            }
        });
        let mut i = 0;
        while i < regs.len() {
            let start = regs[i].0;
            let mut values = vec![regs[i].1];
            while let Some(&(a, v)) = regs.get(i + values.len()) {
                if u32::from(a) != u32::from(start) + values.len() as u32
                    || values.len() >= codec::MAX_WRITE as usize
                {
                    break;
                }
                values.push(v);
            }
            i += values.len();
            let request = if values.len() == 1 {
                Request::WriteSingle {
                    address: start,
                    value: values[0],
                }
            } else {
                Request::WriteMultiple { start, values }
            };
            self.transact(&request)?;
        }
        Ok(())
    }

    /// Writes a field's value at its address; 32-bit fields always go as a write-multiple.
    fn write_value(&mut self, address: u16, words: u8, value: i64) -> Result<(), AxisError> {
        let values = self.map.encode(value, words);
        let request = if values.len() == 1 {
            Request::WriteSingle {
                address,
                value: values[0],
            }
        } else {
            Request::WriteMultiple {
                start: address,
                values,
            }
        };
        self.transact(&request).map(|_| ())
    }

    fn fixed_write(&mut self, w: &Write) -> Result<(), AxisError> {
        self.write_value(w.address, w.words, w.value)?;
        if let Some(r) = w.release {
            self.write_value(w.address, w.words, r)?;
        }
        Ok(())
    }

    fn push(&self, regs: &mut Vec<(u16, u16)>, address: u16, words: u8, value: i64) {
        for (k, v) in self.map.encode(value, words).into_iter().enumerate() {
            regs.push((address.wrapping_add(k as u16), v));
        }
    }

    fn to_steps(&self, mm: Millimetres) -> Result<i64, AxisError> {
        let steps = (mm.0 * self.map.steps_per_mm).round();
        if steps.is_finite() && steps >= f64::from(i32::MIN) && steps <= f64::from(i32::MAX) {
            Ok(steps as i64)
        } else {
            Err(self.device_error(format!(
                "{mm:.4} is {steps} steps at {} steps/mm, outside the 32-bit position range",
                self.map.steps_per_mm
            )))
        }
    }

    fn to_mm(&self, steps: i64) -> Millimetres {
        Millimetres(steps as f64 / self.map.steps_per_mm)
    }

    /// Starts an absolute move to `target` (checked against the soft limits by the caller) with
    /// `profile` written with it.
    fn start_move_to(
        &mut self,
        target: Millimetres,
        profile: Option<Profile>,
    ) -> Result<(), AxisError> {
        let steps = self.to_steps(target)?;
        self.send_move(steps, false, profile)?;
        self.start(MotionKind::Move {
            target_steps: steps,
        });
        Ok(())
    }

    /// Sends one positioning command: `steps` absolute or relative, then the trigger.
    fn send_move(
        &mut self,
        steps: i64,
        relative: bool,
        profile: Option<Profile>,
    ) -> Result<(), AxisError> {
        let mut regs = Vec::new();
        for w in self.map.preset.clone() {
            self.push(&mut regs, w.address, w.words, w.value);
        }
        if let Some(op) = self.map.operation.clone() {
            let value = if relative {
                op.relative.unwrap_or(op.absolute)
            } else {
                op.absolute
            };
            self.push(&mut regs, op.address, op.words, value);
        }
        self.push(&mut regs, self.map.registers.target_position, 2, steps);
        if let Some(profile) = profile {
            for (field, physical) in [
                (self.map.registers.speed, profile.speed_mm_s),
                (self.map.registers.acceleration, profile.accel_mm_s2),
                (self.map.registers.deceleration, profile.decel_mm_s2),
            ] {
                if let Some(f) = field {
                    let raw = if f.inverse {
                        f.scale / physical
                    } else {
                        f.scale * physical
                    };
                    let max = if f.words == 1 {
                        f64::from(u16::MAX)
                    } else {
                        f64::from(u32::MAX)
                    };
                    let raw = raw.round().clamp(1.0, max) as i64;
                    self.push(&mut regs, f.address, f.words, raw);
                }
            }
        }
        self.write_registers(regs)?;
        let t = self.map.trigger.clone();
        self.write_value(t.address, t.words, t.start)
    }

    fn poll(&mut self) -> Result<Poll, AxisError> {
        let status = &self.map.status;
        let request = Request::ReadHolding {
            start: status.address,
            count: u16::from(status.words),
        };
        let regs = self.transact(&request)?;
        let raw = self.map.decode_unsigned(&regs);
        let request = Request::ReadHolding {
            start: self.map.registers.feedback_position,
            count: 2,
        };
        let regs = self.transact(&request)?;
        let steps = i64::from(self.map.decode_unsigned(&regs) as i32);
        Ok(Poll { raw, steps })
    }

    fn has(&self, raw: u32, role: Role) -> bool {
        self.bits
            .iter()
            .any(|b| b.role == role && raw & b.mask == b.mask)
    }

    fn defines(&self, role: Role) -> bool {
        self.bits.iter().any(|b| b.role == role)
    }

    fn to_status(&self, poll: &Poll) -> AxisStatus {
        let set: Vec<&Bit> = self
            .bits
            .iter()
            .filter(|b| poll.raw & b.mask == b.mask)
            .collect();
        AxisStatus {
            position: self.to_mm(poll.steps),
            moving: self.has(poll.raw, Role::Moving),
            homed: if self.defines(Role::Homed) {
                self.has(poll.raw, Role::Homed)
            } else {
                self.homed
            },
            flags: set.iter().map(|b| b.name).collect(),
            faults: set
                .iter()
                .filter(|b| b.role == Role::Alarm)
                .map(|b| b.name)
                .collect(),
        }
    }

    fn motion_name(&self, kind: MotionKind) -> String {
        match kind {
            MotionKind::Move { target_steps } => {
                format!("moving to {:.4}", self.to_mm(target_steps))
            }
            MotionKind::Home => "homing".to_string(),
            MotionKind::Stopping => "stopping".to_string(),
        }
    }

    fn start(&mut self, kind: MotionKind) {
        self.motion = Some(Motion {
            kind,
            started: Instant::now(),
            seen_moving: false,
        });
    }

    /// Decides whether `motion` has ended given one poll; errors for a stage that stopped short.
    fn finished(&mut self, motion: &mut Motion, poll: &Poll) -> Result<bool, AxisError> {
        let moving = self.has(poll.raw, Role::Moving);
        motion.seen_moving |= moving;
        if moving {
            return Ok(false);
        }
        if matches!(motion.kind, MotionKind::Stopping) {
            // A drive may drop "ready" after an emergency stop; not moving is enough here.
            return Ok(true);
        }
        if self.defines(Role::Ready) && !self.has(poll.raw, Role::Ready) {
            return Ok(false);
        }
        let grace_over = motion.started.elapsed() >= self.options.start_grace;
        match motion.kind {
            MotionKind::Move { target_steps } => {
                let off = (poll.steps - target_steps).unsigned_abs();
                if off <= u64::from(self.map.tolerance_steps) {
                    Ok(true)
                } else if motion.seen_moving {
                    Err(self.device_error(format!(
                        "motion ended at {:.4}, {off} steps from the target {:.4} (check the map's steps_per_mm and feedback_position, and the drive's limits)",
                        self.to_mm(poll.steps),
                        self.to_mm(target_steps)
                    )))
                } else if grace_over {
                    Err(self.device_error(format!(
                        "the stage did not start moving within {:?} of the trigger (check the map's trigger and operation registers and that the drive is enabled)",
                        self.options.start_grace
                    )))
                } else {
                    Ok(false)
                }
            }
            MotionKind::Home => {
                if self.defines(Role::Homed) {
                    Ok(self.has(poll.raw, Role::Homed))
                } else {
                    Ok(motion.seen_moving || grace_over)
                }
            }
            MotionKind::Stopping => Ok(true),
        }
    }
}

impl Axis for ModbusStage {
    fn name(&self) -> &str {
        &self.axis
    }

    fn endpoint(&self) -> String {
        format!(
            "{} over {}, slave {}, map {}",
            self.framing,
            self.link.describe(),
            self.slave,
            self.map.source
        )
    }

    fn begin_home(&mut self) -> Result<(), AxisError> {
        let Some(homing) = self.map.homing.clone() else {
            return Err(self.device_error(format!(
                "the register map {} defines no homing operation (add a [homing] section with the writes that start it, or move to a known position instead)",
                self.map.source
            )));
        };
        for w in &homing.writes {
            self.fixed_write(w)?;
        }
        self.homed = false;
        self.start(MotionKind::Home);
        Ok(())
    }

    fn begin_move_to(&mut self, target: Millimetres) -> Result<(), AxisError> {
        if let Some(limits) = self.options.limits {
            limits.check(&self.axis, target)?;
        }
        self.start_move_to(target, self.map.profile)
    }

    fn begin_move_to_at(
        &mut self,
        target: Millimetres,
        motion: Kinematics,
    ) -> Result<(), AxisError> {
        let (Some(profile), Some(_)) = (self.map.profile, self.map.registers.speed) else {
            return Err(AxisError::Motion {
                axis: self.axis.clone(),
                message: format!(
                    "the register map {} writes no speed with a move ([profile] and registers.speed): the stage cannot move at a chosen speed; nothing was sent",
                    self.map.source
                ),
            });
        };
        motion.check_within(
            &self.axis,
            &Kinematics {
                velocity: MillimetresPerSecond(profile.speed_mm_s),
                acceleration: MillimetresPerSecondSquared(
                    profile.accel_mm_s2.min(profile.decel_mm_s2),
                ),
            },
        )?;
        if let Some(limits) = self.options.limits {
            limits.check(&self.axis, target)?;
        }
        let chosen = Profile {
            speed_mm_s: motion.velocity.0,
            accel_mm_s2: motion.acceleration.0,
            decel_mm_s2: motion.acceleration.0,
        };
        self.start_move_to(target, Some(chosen))
    }

    fn begin_move_by(&mut self, delta: Millimetres) -> Result<(), AxisError> {
        let poll = self.poll()?;
        let target = self.to_mm(poll.steps) + delta;
        if let Some(limits) = self.options.limits {
            limits.check(&self.axis, target)?;
        }
        let delta_steps = self.to_steps(delta)?;
        let relative = self
            .map
            .operation
            .as_ref()
            .is_some_and(|o| o.relative.is_some());
        let target_steps = poll.steps + delta_steps;
        self.send_move(
            if relative { delta_steps } else { target_steps },
            relative,
            self.map.profile,
        )?;
        self.start(MotionKind::Move { target_steps });
        Ok(())
    }

    fn wait_idle(&mut self, timeout: Duration) -> Result<AxisStatus, AxisError> {
        let deadline = Instant::now() + timeout;
        loop {
            let poll = self.poll()?;
            let status = self.to_status(&poll);
            let Some(mut motion) = self.motion else {
                return Ok(status);
            };
            if !status.faults.is_empty() {
                self.motion = None;
                return Err(AxisError::Fault {
                    axis: self.axis.clone(),
                    endpoint: self.endpoint(),
                    what: self.motion_name(motion.kind),
                    flags: status.faults,
                });
            }
            let done = self.finished(&mut motion, &poll);
            self.motion = Some(motion);
            match done {
                Ok(true) => {
                    if matches!(motion.kind, MotionKind::Home) {
                        self.homed = true;
                    }
                    self.motion = None;
                    return Ok(self.to_status(&poll));
                }
                Ok(false) => {}
                Err(e) => {
                    self.motion = None;
                    return Err(e);
                }
            }
            let now = Instant::now();
            if now >= deadline {
                return Err(AxisError::Timeout {
                    axis: self.axis.clone(),
                    endpoint: self.endpoint(),
                    what: format!(
                        "the end of {} (now at {:.4})",
                        self.motion_name(motion.kind),
                        status.position
                    ),
                    timeout,
                    flags: status.flags,
                });
            }
            std::thread::sleep(self.options.poll_interval.min(deadline - now));
        }
    }

    fn stop(&mut self, mode: StopMode) -> Result<(), AxisError> {
        let t = &self.map.trigger;
        let value = match mode {
            StopMode::Profiled => t.stop.or(t.estop),
            StopMode::Immediate => t.estop.or(t.stop),
        };
        let Some(value) = value else {
            return Err(self.device_error(format!(
                "the register map {} defines no stop value (add trigger.stop or trigger.estop)",
                self.map.source
            )));
        };
        let (address, words) = (t.address, t.words);
        self.write_value(address, words, value)?;
        self.start(MotionKind::Stopping);
        Ok(())
    }

    fn status(&mut self) -> Result<AxisStatus, AxisError> {
        let poll = self.poll()?;
        Ok(self.to_status(&poll))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use std::collections::VecDeque;
    use std::io;

    /// Hands out canned replies, one per read, and keeps what was written.
    struct Canned {
        replies: VecDeque<Vec<u8>>,
        sent: Vec<Vec<u8>>,
    }

    impl ByteLink for Canned {
        fn write_all(&mut self, bytes: &[u8]) -> io::Result<()> {
            self.sent.push(bytes.to_vec());
            Ok(())
        }
        fn read(&mut self, buf: &mut [u8], _timeout: Duration) -> io::Result<usize> {
            let Some(mut r) = self.replies.pop_front() else {
                return Ok(0);
            };
            let n = r.len().min(buf.len());
            buf[..n].copy_from_slice(&r[..n]);
            if n < r.len() {
                self.replies.push_front(r.split_off(n));
            }
            Ok(n)
        }
        fn describe(&self) -> String {
            "canned".into()
        }
    }

    fn stage(framing: Framing, replies: Vec<Vec<u8>>) -> ModbusStage {
        let link = Canned {
            replies: replies.into(),
            sent: Vec::new(),
        };
        let options = StageOptions {
            response_timeout: Duration::from_millis(5),
            poll_interval: Duration::from_millis(1),
            start_grace: Duration::ZERO,
            ..StageOptions::default()
        };
        let map = RegisterMap::load("leadshine-pr").expect("map");
        ModbusStage::new("y", Box::new(link), framing, map, options)
    }

    fn rtu_reply(pdu: &[u8]) -> Vec<u8> {
        codec::rtu_frame(1, pdu)
    }

    #[test]
    fn stage_that_never_starts_is_reported() {
        let replies = vec![
            rtu_reply(&[0x10, 0x62, 0x00, 0x00, 0x06]),
            rtu_reply(&[0x06, 0x60, 0x02, 0x00, 0x10]),
            rtu_reply(&[0x03, 0x02, 0x00, 0x02]),
            rtu_reply(&[0x03, 0x04, 0x00, 0x00, 0x00, 0x00]),
        ];
        let mut y = stage(Framing::Rtu, replies);
        let err = y
            .move_to(Millimetres(1.0), Duration::from_secs(1))
            .expect_err("never moved");
        assert!(err.to_string().contains("did not start moving"), "{err}");
    }

    #[test]
    fn reply_from_another_slave_is_an_error() {
        let mut y = stage(
            Framing::Rtu,
            vec![codec::rtu_frame(2, &[0x03, 0x02, 0x00, 0x02])],
        );
        let msg = y.status().expect_err("wrong slave").to_string();
        assert!(msg.contains("came from slave 2, expected slave 1"), "{msg}");
    }

    #[test]
    fn stale_tcp_reply_is_skipped() {
        let stale = codec::tcp_frame(
            TcpHeader {
                transaction: 9,
                unit: 1,
            },
            &[0x03, 0x02, 0x00, 0x04],
        );
        let status = codec::tcp_frame(
            TcpHeader {
                transaction: 1,
                unit: 1,
            },
            &[0x03, 0x02, 0x00, 0x02],
        );
        let pos = codec::tcp_frame(
            TcpHeader {
                transaction: 2,
                unit: 1,
            },
            &[0x03, 0x04, 0, 0, 0x0F, 0xA0],
        );
        let mut y = stage(Framing::Tcp, vec![[stale, status].concat(), pos]);
        let s = y.status().expect("status");
        assert_eq!(s.position, Millimetres(2.0));
        assert!(!s.moving && s.flags == vec!["enabled"], "{s:?}");
    }

    proptest! {
        #[test]
        fn garbage_replies_never_panic(replies in proptest::collection::vec(proptest::collection::vec(any::<u8>(), 0..40), 0..6), tcp in any::<bool>()) {
            let mut y = stage(if tcp { Framing::Tcp } else { Framing::Rtu }, replies);
            let _ = y.status();
            let _ = y.move_by(Millimetres(0.5), Duration::from_millis(20));
        }
    }
}
