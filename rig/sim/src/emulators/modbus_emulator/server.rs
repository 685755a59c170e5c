//! [`ModbusEmulator`]: a [`ModbusCore`] served on threads over Modbus TCP, Modbus RTU on a
//! pseudo-terminal, or an in-process byte pipe.

use super::core::ModbusCore;
use super::framing::{lock, rtu_exchange, tcp_exchange};
use super::line_timing::{RtuLine, RtuTiming};
use crate::physics::motion::SimMotor;
use fringe_rig::ByteLink;
use fringe_rig::Framing;
use fringe_rig::PtyDevice;
use fringe_rig::RegisterMap;
use fringe_rig::{byte_pair, MemoryByteLink};
use std::io::{self, Read, Write};
use std::net::{SocketAddr, TcpListener, TcpStream};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// Runs one byte-stream connection until `stop`, the peer closing, or an error.
fn serve_link<L: ByteLink>(
    mut link: L,
    framing: Framing,
    core: Arc<Mutex<ModbusCore>>,
    slave: u8,
    line: Line,
) {
    let mut buf = Vec::new();
    let mut chunk = [0u8; 512];
    // The RTU inter-frame gap is 3.5 characters (1.75 ms above 19200 baud); reads wake at least
    // this often, and a read that finds nothing ends whatever frame was arriving.
    let gap = Duration::from_millis(5);
    let mut rtu = RtuLine::new(line.timing);
    while !line.stop.load(Ordering::Relaxed) {
        let n = match link.read(&mut chunk, gap) {
            Ok(n) => n,
            Err(_) => return,
        };
        let arrived = Instant::now();
        let replies = match framing {
            Framing::Rtu => {
                if n == 0 {
                    rtu.silence();
                }
                let mut started_dropping = false;
                if n > 0 && !rtu.accept(arrived, &mut started_dropping) {
                    if started_dropping {
                        line.frames_too_soon.fetch_add(1, Ordering::Relaxed);
                    }
                    buf.clear();
                    continue;
                }
                buf.extend_from_slice(&chunk[..n]);
                let before = buf.len();
                let replies = rtu_exchange(&mut buf, &core, slave, n == 0);
                let request_bytes = before - buf.len();
                let mut start = arrived;
                for r in &replies {
                    let done = rtu.timing().reply_done(start, request_bytes, r.len());
                    sleep_until(done);
                    // The reply has left the drive when the write starts: the driver cannot
                    // have it any sooner (a thread that loses its core after the write must
                    // not make the driver's next frame look early).
                    start = Instant::now();
                    if link.write_all(r).is_err() {
                        return;
                    }
                    rtu.sent(start);
                }
                continue;
            }
            Framing::Tcp => {
                buf.extend_from_slice(&chunk[..n]);
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

fn sleep_until(t: Instant) {
    let now = Instant::now();
    if t > now {
        std::thread::sleep(t - now);
    }
}

/// What a serving thread shares with the emulator handle.
#[derive(Clone)]
struct Line {
    timing: RtuTiming,
    stop: Arc<AtomicBool>,
    frames_too_soon: Arc<AtomicU64>,
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
    line: Line,
    threads: Vec<JoinHandle<()>>,
}

impl ModbusEmulator {
    /// A drive with the documented RTU timing of its map's line speed.
    fn new(map: RegisterMap, motor: Arc<SimMotor>) -> ModbusEmulator {
        let timing = RtuTiming::documented(map.serial_settings(None).baud);
        ModbusEmulator {
            core: Arc::new(Mutex::new(ModbusCore::new(map, motor))),
            addr: None,
            pty_path: None,
            line: Line {
                timing,
                stop: Arc::new(AtomicBool::new(false)),
                frames_too_soon: Arc::new(AtomicU64::new(0)),
            },
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
        let (core, line, slave) = (
            emulator.core.clone(),
            emulator.line.clone(),
            emulator.slave(),
        );
        let stop = line.stop.clone();
        let accept = std::thread::Builder::new()
            .name("modbus-emulator-tcp".into())
            .spawn(move || {
                let mut clients: Vec<JoinHandle<()>> = Vec::new();
                while !stop.load(Ordering::Relaxed) {
                    match listener.accept() {
                        Ok((stream, _)) => {
                            let _ = stream.set_nonblocking(false);
                            let _ = stream.set_nodelay(true);
                            let (core, line) = (core.clone(), line.clone());
                            let spawned = std::thread::Builder::new()
                                .name("modbus-emulator-client".into())
                                .spawn(move || {
                                    serve_link(Conn(stream), Framing::Tcp, core, slave, line)
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
        let (core, line, slave) = (self.core.clone(), self.line.clone(), self.slave());
        let h = std::thread::Builder::new()
            .name("modbus-emulator".into())
            .spawn(move || serve_link(link, framing, core, slave, line))?;
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

    /// The drive's RTU timing.
    pub fn rtu_timing(&self) -> RtuTiming {
        self.line.timing
    }

    /// RTU frames dropped because they began inside the silent interval after a reply.
    pub fn frames_too_soon(&self) -> u64 {
        self.line.frames_too_soon.load(Ordering::Relaxed)
    }

    /// Stops serving.
    pub fn stop(mut self) {
        self.shutdown();
    }

    fn shutdown(&mut self) {
        self.line.stop.store(true, Ordering::SeqCst);
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
