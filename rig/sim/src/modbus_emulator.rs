//! An emulated Modbus y stage: a drive described by a [`RegisterMap`] (the shipped `oriental-az`
//! and `leadshine-pr` maps, or any other) moving a [`SimMotor`], served over Modbus TCP, Modbus RTU
//! on a pseudo-terminal, or an in-process byte pipe, so the real [`fringe_rig::modbus::ModbusStage`]
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

use crate::motion::{Kinematics, SimMotor};
use fringe_rig::clock::HostTime;
use fringe_rig::modbus::codec::{crc16, rtu_frame, tcp_frame, TcpHeader};
use fringe_rig::modbus::map::{Field, RegisterMap, Role};
use fringe_rig::modbus::Framing;
use fringe_rig::transport::memory::{byte_pair, MemoryByteLink};
use fringe_rig::transport::pty::PtyDevice;
use fringe_rig::transport::ByteLink;
use fringe_rig::units::{Millimetres, MillimetresPerSecond, MillimetresPerSecondSquared};
use std::collections::HashMap;
use std::io::{self, Read, Write};
use std::net::{SocketAddr, TcpListener, TcpStream};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::thread::JoinHandle;
use std::time::Duration;

/// Modbus exception codes the emulated drive answers with.
pub const ILLEGAL_FUNCTION: u8 = 0x01;
pub const ILLEGAL_DATA_ADDRESS: u8 = 0x02;
pub const ILLEGAL_DATA_VALUE: u8 = 0x03;

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

/// The length of the RTU request frame starting at `buf[0]` (slave id), once enough bytes are
/// there to know it; `Some(None)` for a function code this drive does not know.
fn rtu_request_len(buf: &[u8]) -> Option<Option<usize>> {
    match buf.get(1)? {
        0x03 | 0x04 | 0x06 => Some(Some(8)),
        0x10 => buf.get(6).map(|&n| Some(9 + n as usize)),
        _ => Some(None),
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

fn lock(core: &Mutex<ModbusCore>) -> MutexGuard<'_, ModbusCore> {
    // Every request leaves the core consistent, so a poisoned lock is still usable.
    core.lock().unwrap_or_else(|e| e.into_inner())
}

/// Takes one Modbus TCP request off the front of `buf` and answers it; `Err` for a byte stream
/// that is not Modbus TCP (the connection is to be closed).
fn tcp_exchange(
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
fn rtu_exchange(
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

/// Runs one byte-stream connection until `stop`, the peer closing, or an error.
fn serve_link<L: ByteLink>(
    mut link: L,
    framing: Framing,
    core: Arc<Mutex<ModbusCore>>,
    slave: u8,
    stop: Arc<AtomicBool>,
) {
    let mut buf = Vec::new();
    let mut chunk = [0u8; 512];
    // The RTU inter-frame gap is 3.5 characters (1.75 ms above 19200 baud); a pseudo-terminal has
    // no timing, so a pause of a few milliseconds ends a frame.
    let gap = Duration::from_millis(5);
    while !stop.load(Ordering::Relaxed) {
        let n = match link.read(&mut chunk, gap) {
            Ok(n) => n,
            Err(_) => return,
        };
        buf.extend_from_slice(&chunk[..n]);
        let replies = match framing {
            Framing::Rtu => rtu_exchange(&mut buf, &core, slave, n == 0),
            Framing::Tcp => {
                let mut replies = Vec::new();
                loop {
                    match tcp_exchange(&mut buf, &core, slave) {
                        Ok(Some(r)) => replies.push(r),
                        Ok(None) => break,
                        Err(()) => return,
                    }
                }
                replies
            }
        };
        for r in replies {
            if link.write_all(&r).is_err() {
                return;
            }
        }
    }
}

/// A TCP connection as a [`ByteLink`] for [`serve_link`] (read returns an error when closed).
struct Conn(TcpStream);

impl ByteLink for Conn {
    fn write_all(&mut self, bytes: &[u8]) -> io::Result<()> {
        self.0.write_all(bytes)
    }
    fn read(&mut self, buf: &mut [u8], timeout: Duration) -> io::Result<usize> {
        self.0
            .set_read_timeout(Some(timeout.max(Duration::from_millis(1))))?;
        match self.0.read(buf) {
            Ok(0) => Err(io::ErrorKind::ConnectionAborted.into()),
            Ok(n) => Ok(n),
            Err(e)
                if matches!(
                    e.kind(),
                    io::ErrorKind::WouldBlock | io::ErrorKind::TimedOut
                ) =>
            {
                Ok(0)
            }
            Err(e) => Err(e),
        }
    }
    fn describe(&self) -> String {
        "modbus tcp client".into()
    }
}

/// A running emulated Modbus stage; stops when dropped or on [`ModbusEmulator::stop`].
pub struct ModbusEmulator {
    core: Arc<Mutex<ModbusCore>>,
    addr: Option<SocketAddr>,
    pty_path: Option<String>,
    stop: Arc<AtomicBool>,
    threads: Vec<JoinHandle<()>>,
}

impl ModbusEmulator {
    fn new(map: RegisterMap, motor: Arc<SimMotor>) -> ModbusEmulator {
        ModbusEmulator {
            core: Arc::new(Mutex::new(ModbusCore::new(map, motor))),
            addr: None,
            pty_path: None,
            stop: Arc::new(AtomicBool::new(false)),
            threads: Vec::new(),
        }
    }

    fn slave(&self) -> u8 {
        lock(&self.core).map().slave
    }

    /// Serves Modbus TCP on `addr` (port 0 = ephemeral; drives use 502), any number of clients.
    pub fn spawn_tcp(
        addr: SocketAddr,
        map: RegisterMap,
        motor: Arc<SimMotor>,
    ) -> io::Result<ModbusEmulator> {
        let listener = TcpListener::bind(addr).map_err(|e| {
            io::Error::new(
                e.kind(),
                format!("emulated Modbus stage: cannot bind tcp {addr}: {e}"),
            )
        })?;
        listener.set_nonblocking(true)?;
        let mut emulator = ModbusEmulator::new(map, motor);
        emulator.addr = Some(listener.local_addr()?);
        let (core, stop, slave) = (
            emulator.core.clone(),
            emulator.stop.clone(),
            emulator.slave(),
        );
        let accept = std::thread::Builder::new()
            .name("modbus-emulator-tcp".into())
            .spawn(move || {
                let mut clients: Vec<JoinHandle<()>> = Vec::new();
                while !stop.load(Ordering::Relaxed) {
                    match listener.accept() {
                        Ok((stream, _)) => {
                            let _ = stream.set_nonblocking(false);
                            let _ = stream.set_nodelay(true);
                            let (core, stop) = (core.clone(), stop.clone());
                            let spawned = std::thread::Builder::new()
                                .name("modbus-emulator-client".into())
                                .spawn(move || {
                                    serve_link(Conn(stream), Framing::Tcp, core, slave, stop)
                                });
                            if let Ok(h) = spawned {
                                clients.push(h);
                            }
                            clients.retain(|h| !h.is_finished());
                        }
                        Err(_) => std::thread::sleep(Duration::from_millis(5)),
                    }
                }
                for h in clients {
                    let _ = h.join();
                }
            })?;
        emulator.threads.push(accept);
        Ok(emulator)
    }

    /// Serves Modbus RTU on a new pseudo-terminal; clients open [`ModbusEmulator::pty_path`].
    pub fn spawn_rtu_pty(map: RegisterMap, motor: Arc<SimMotor>) -> io::Result<ModbusEmulator> {
        let pty = PtyDevice::open()?;
        let mut emulator = ModbusEmulator::new(map, motor);
        emulator.pty_path = Some(pty.slave_path().to_string());
        emulator.spawn_link(pty, Framing::Rtu)?;
        Ok(emulator)
    }

    /// Serves `framing` on an in-process byte pipe; the returned link is the driver's end.
    pub fn spawn_in_process(
        map: RegisterMap,
        motor: Arc<SimMotor>,
        framing: Framing,
    ) -> io::Result<(ModbusEmulator, MemoryByteLink)> {
        let (driver_end, drive_end) = byte_pair("modbus y stage", "emulated Modbus stage");
        let mut emulator = ModbusEmulator::new(map, motor);
        emulator.spawn_link(drive_end, framing)?;
        Ok((emulator, driver_end))
    }

    fn spawn_link<L: ByteLink + 'static>(&mut self, link: L, framing: Framing) -> io::Result<()> {
        let (core, stop, slave) = (self.core.clone(), self.stop.clone(), self.slave());
        let h = std::thread::Builder::new()
            .name("modbus-emulator".into())
            .spawn(move || serve_link(link, framing, core, slave, stop))?;
        self.threads.push(h);
        Ok(())
    }

    /// The Modbus TCP address (TCP emulators).
    pub fn addr(&self) -> Option<SocketAddr> {
        self.addr
    }

    /// The pseudo-terminal to open (RTU emulators).
    pub fn pty_path(&self) -> Option<&str> {
        self.pty_path.as_deref()
    }

    /// The motor the drive moves (shared with the bench).
    pub fn motor(&self) -> Arc<SimMotor> {
        lock(&self.core).motor().clone()
    }

    /// Raises or lowers an injected drive alarm.
    pub fn set_alarm(&self, on: bool) {
        lock(&self.core).set_alarm(on);
    }

    /// Resets every alarm (injected and over-travel).
    pub fn clear_alarm(&self) {
        lock(&self.core).clear_alarm();
    }

    /// Requests answered so far.
    pub fn requests(&self) -> u64 {
        lock(&self.core).requests()
    }

    /// Stops serving.
    pub fn stop(mut self) {
        self.shutdown();
    }

    fn shutdown(&mut self) {
        self.stop.store(true, Ordering::SeqCst);
        for h in self.threads.drain(..) {
            let _ = h.join();
        }
    }
}

impl Drop for ModbusEmulator {
    fn drop(&mut self) {
        self.shutdown();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::motion::MotorSpec;

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

    fn core(map: &str) -> ModbusCore {
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
