//! The Net F/T box on a thread: on a UDP socket (replying to whoever sent the start request) with
//! its HTTP configuration page, or on an in-process datagram pipe.

use super::core::{EmulatorConfigError, NetFtCore, NetFtEmulatorConfig, NetFtReport};
use super::http_page::SimHttp;
use crate::scene::ForceReading;
use fringe_rig::DatagramLink;
use fringe_rig::HostTime;
use fringe_rig::{datagram_pair, MemoryDatagramLink};
use std::io;
use std::net::{SocketAddr, UdpSocket};
use std::sync::atomic::{AtomicBool, AtomicU32, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::Duration;

/// Where a server thread receives requests and sends records.
trait Port {
    type Peer: Clone;
    /// Waits at most `timeout` for a request.
    fn recv(
        &mut self,
        buf: &mut [u8],
        timeout: Duration,
    ) -> io::Result<Option<(usize, Self::Peer)>>;
    fn send(&mut self, bytes: &[u8], to: &Self::Peer) -> io::Result<()>;
}

struct UdpPort(UdpSocket);

impl UdpPort {
    /// A request already waiting on the (non-blocking) socket.
    fn try_recv(&mut self, buf: &mut [u8]) -> io::Result<Option<(usize, SocketAddr)>> {
        loop {
            return match self.0.recv_from(buf) {
                Ok(got) => Ok(Some(got)),
                Err(e) if e.kind() == io::ErrorKind::WouldBlock => Ok(None),
                // An ICMP unreachable from an earlier send to a client that went away.
                Err(e)
                    if matches!(
                        e.kind(),
                        io::ErrorKind::ConnectionRefused | io::ErrorKind::Interrupted
                    ) =>
                {
                    continue
                }
                Err(e) => Err(e),
            };
        }
    }
}

impl Port for UdpPort {
    type Peer = SocketAddr;

    fn recv(
        &mut self,
        buf: &mut [u8],
        timeout: Duration,
    ) -> io::Result<Option<(usize, SocketAddr)>> {
        use std::os::fd::AsRawFd;
        if let Some(got) = self.try_recv(buf)? {
            return Ok(Some(got));
        }
        if timeout.is_zero() {
            return Ok(None);
        }
        if timeout < Duration::from_millis(1) {
            // poll(2) counts whole milliseconds; below that a sleep is precise enough.
            std::thread::sleep(timeout);
        } else {
            let mut pfd = libc::pollfd {
                fd: self.0.as_raw_fd(),
                events: libc::POLLIN,
                revents: 0,
            };
            let ms = timeout.as_millis().min(1000) as libc::c_int;
            // SAFETY: one valid pollfd on a socket we own.
            unsafe { libc::poll(&mut pfd, 1, ms) };
        }
        self.try_recv(buf)
    }

    fn send(&mut self, bytes: &[u8], to: &SocketAddr) -> io::Result<()> {
        match self.0.send_to(bytes, to) {
            Ok(_) => Ok(()),
            // The client's socket is gone: a real box keeps streaming into the void.
            Err(e) if e.kind() == io::ErrorKind::ConnectionRefused => Ok(()),
            // The socket buffer is full: the datagram is lost, as on a busy network.
            Err(e) if e.kind() == io::ErrorKind::WouldBlock => Ok(()),
            Err(e) => Err(e),
        }
    }
}

struct MemoryPort(MemoryDatagramLink);

impl Port for MemoryPort {
    type Peer = ();

    fn recv(&mut self, buf: &mut [u8], timeout: Duration) -> io::Result<Option<(usize, ())>> {
        Ok(self.0.recv(buf, timeout)?.map(|n| (n, ())))
    }

    fn send(&mut self, bytes: &[u8], _to: &()) -> io::Result<()> {
        self.0.send(bytes)
    }
}

/// Longest wait between checks of the stop flag (and of the power switch).
const IDLE_WAIT: Duration = Duration::from_millis(5);

/// Reboots a running emulated box from another thread (a fault injection): see
/// [`NetFtCore::reboot`].
#[derive(Clone, Default)]
pub struct PowerSwitch(Arc<Mutex<Option<Duration>>>);

impl PowerSwitch {
    /// The box goes down now (within the server's 5 ms poll) and is up again `down` later.
    pub fn reboot(&self, down: Duration) {
        *self.0.lock().unwrap_or_else(|e| e.into_inner()) = Some(down);
    }

    fn take(&self) -> Option<Duration> {
        self.0.lock().unwrap_or_else(|e| e.into_inner()).take()
    }
}

fn serve<T: Port>(
    mut port: T,
    mut core: NetFtCore<T::Peer>,
    stop: Arc<AtomicBool>,
    power: PowerSwitch,
) -> io::Result<NetFtReport> {
    // The box keeps its own time, whatever else the host runs: real-time when allowed (the
    // driver's reader says so when it is not).
    let _ = fringe_rig::raise_current_thread("emulated Net F/T");
    let mut out = Vec::new();
    let mut buf = [0u8; 512];
    while !stop.load(Ordering::Relaxed) {
        let now = HostTime::now();
        if let Some(down) = power.take() {
            core.reboot(now, down);
        }
        core.poll(now, &mut out);
        for d in out.drain(..) {
            port.send(&d.bytes, &d.to)?;
        }
        let wait = match core.next_due() {
            Some(due) => due.since(HostTime::now()).min(IDLE_WAIT),
            None => IDLE_WAIT,
        };
        match port.recv(&mut buf, wait) {
            Ok(Some((n, from))) => {
                core.handle(HostTime::now(), &buf[..n], from, &mut out);
                for d in out.drain(..) {
                    port.send(&d.bytes, &d.to)?;
                }
            }
            Ok(None) => {}
            // In process: the driver's end was dropped; nothing more will come.
            Err(e) if e.kind() == io::ErrorKind::BrokenPipe => break,
            Err(e) => return Err(e),
        }
    }
    Ok(core.report().clone())
}

/// A running emulated Net F/T; stops when dropped or on [`NetFtEmulator::stop`].
pub struct NetFtEmulator {
    addr: Option<SocketAddr>,
    http: Option<SimHttp>,
    config: NetFtEmulatorConfig,
    injected: Arc<AtomicU32>,
    power: PowerSwitch,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<io::Result<NetFtReport>>>,
}

fn invalid(e: EmulatorConfigError) -> io::Error {
    io::Error::new(io::ErrorKind::InvalidInput, e)
}

impl NetFtEmulator {
    /// Serves RDT on UDP `rdt_addr` (port 0 = ephemeral; the box's own port is
    /// [`fringe_rig::netft::DEFAULT_PORT`]) and `netftapi2.xml` over HTTP on `http_addr` (`None`: the same
    /// IP, an ephemeral port).
    pub fn spawn_udp(
        rdt_addr: SocketAddr,
        http_addr: Option<SocketAddr>,
        config: NetFtEmulatorConfig,
        reading: Box<dyn ForceReading>,
    ) -> io::Result<NetFtEmulator> {
        Self::spawn_udp_at(rdt_addr, http_addr, config, reading, HostTime::now())
    }

    /// [`NetFtEmulator::spawn_udp`] for a box that powered up at `power_up`.
    pub fn spawn_udp_at(
        rdt_addr: SocketAddr,
        http_addr: Option<SocketAddr>,
        config: NetFtEmulatorConfig,
        reading: Box<dyn ForceReading>,
        power_up: HostTime,
    ) -> io::Result<NetFtEmulator> {
        let core = NetFtCore::new(config.clone(), reading, power_up).map_err(invalid)?;
        let socket = UdpSocket::bind(rdt_addr).map_err(|e| {
            io::Error::new(
                e.kind(),
                format!("emulated Net F/T: cannot bind udp {rdt_addr}: {e}"),
            )
        })?;
        socket.set_nonblocking(true)?;
        let addr = socket.local_addr()?;
        // Without an address given, the page is served over TCP on the RDT port's number (where
        // fringe's Net F/T client looks when nothing listens on port 80, which a real box uses),
        // else, that port being taken, on an ephemeral one.
        let page = || config.netftapi2_xml();
        let http = match http_addr {
            Some(at) => SimHttp::bind(at, "/netftapi2.xml", page()),
            None => SimHttp::bind(addr, "/netftapi2.xml", page()).or_else(|_| {
                SimHttp::bind(SocketAddr::new(addr.ip(), 0), "/netftapi2.xml", page())
            }),
        }
        .map_err(|e| {
            let at = http_addr.unwrap_or(addr);
            io::Error::new(
                e.kind(),
                format!("emulated Net F/T: cannot serve http on {at}: {e}"),
            )
        })?;
        let mut emulator = Self::new_handle(Some(addr), Some(http), config, &core);
        let (stop, power) = (emulator.stop.clone(), emulator.power.clone());
        emulator.thread = Some(
            std::thread::Builder::new()
                .name("netft-emulator".into())
                .spawn(move || serve(UdpPort(socket), core, stop, power))?,
        );
        Ok(emulator)
    }

    /// Runs the box on an in-process datagram pipe; the returned link is the driver's end.
    pub fn spawn_in_process(
        config: NetFtEmulatorConfig,
        reading: Box<dyn ForceReading>,
    ) -> io::Result<(NetFtEmulator, MemoryDatagramLink)> {
        let core = NetFtCore::new(config.clone(), reading, HostTime::now()).map_err(invalid)?;
        let (driver_end, box_end) = datagram_pair("netft", "emulated Net F/T");
        let mut emulator = Self::new_handle(None, None, config, &core);
        let (stop, power) = (emulator.stop.clone(), emulator.power.clone());
        emulator.thread = Some(
            std::thread::Builder::new()
                .name("netft-emulator".into())
                .spawn(move || serve(MemoryPort(box_end), core, stop, power))?,
        );
        Ok((emulator, driver_end))
    }

    fn new_handle<P: Clone>(
        addr: Option<SocketAddr>,
        http: Option<SimHttp>,
        config: NetFtEmulatorConfig,
        core: &NetFtCore<P>,
    ) -> NetFtEmulator {
        NetFtEmulator {
            addr,
            http,
            config,
            injected: core.injected_status(),
            power: PowerSwitch::default(),
            stop: Arc::new(AtomicBool::new(false)),
            thread: None,
        }
    }

    /// The RDT address (UDP emulators).
    pub fn addr(&self) -> Option<SocketAddr> {
        self.addr
    }

    /// The address of the HTTP server (UDP emulators).
    pub fn http_addr(&self) -> Option<SocketAddr> {
        self.http.as_ref().map(SimHttp::addr)
    }

    /// `http://IP:PORT/netftapi2.xml` (UDP emulators).
    pub fn http_url(&self) -> Option<String> {
        self.http.as_ref().map(|h| h.url("/netftapi2.xml"))
    }

    /// The configuration the box was started with.
    pub fn config(&self) -> &NetFtEmulatorConfig {
        &self.config
    }

    /// Sets a status word OR-ed into every following record (0 clears it): a fault injection.
    pub fn inject_status(&self, status: u32) {
        self.injected.store(status, Ordering::Relaxed);
    }

    /// The switch that reboots this box.
    pub fn power_switch(&self) -> PowerSwitch {
        self.power.clone()
    }

    /// Stops the box and reports what it did.
    pub fn stop(mut self) -> io::Result<NetFtReport> {
        self.stop.store(true, Ordering::SeqCst);
        match self.thread.take().map(JoinHandle::join) {
            Some(Ok(report)) => report,
            Some(Err(_)) => Err(io::Error::other("the emulated Net F/T thread panicked")),
            None => Ok(NetFtReport::default()),
        }
    }
}

impl Drop for NetFtEmulator {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::SeqCst);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}
