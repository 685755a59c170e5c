//! A simulated Net F/T on loopback with the load given in raw counts, for tests and the receive
//! benchmark ([`SimNetFt`], a thin wrapper around the emulated box
//! [`crate::netft_emulator::NetFtEmulator`]), and the small HTTP server that serves a
//! `netftapi2.xml` page ([`SimHttp`]).

use crate::netft_emulator::{NetFtEmulator, NetFtEmulatorConfig};
use fringe_rig::clock::HostTime;
use fringe_rig::netft::rdt::Request;
use fringe_rig::units::Wrench;
use std::io::{self, Read, Write};
use std::net::{SocketAddr, TcpListener};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::Duration;

/// Counts (Fx..Tz) for a given internal sample number.
pub type CountsFn = Arc<dyn Fn(u32) -> [i32; 6] + Send + Sync>;

/// How the simulated sensor behaves.
#[derive(Clone)]
pub struct SimOptions {
    /// Records per second.
    pub rate_hz: f64,
    /// Records per datagram when asked for buffered mode.
    pub buffered_records: usize,
    /// The first `ignore_starts` start requests are ignored (lost on the way).
    pub ignore_starts: u32,
    /// `ft_sequence` of the first record (the sensor has been up a while).
    pub ft_sequence_start: u32,
    /// The load, in counts, at internal sample `n`.
    pub counts: CountsFn,
}

impl Default for SimOptions {
    fn default() -> Self {
        SimOptions {
            rate_hz: 7000.0,
            buffered_records: 10,
            ignore_starts: 0,
            ft_sequence_start: 1000,
            counts: Arc::new(|n| {
                let n = n as i32;
                [n, -n, 2 * n, 1000, -1000, 0]
            }),
        }
    }
}

/// What the simulated sensor did.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct SimReport {
    /// Every request received, in order.
    pub requests: Vec<Request>,
    /// Records sent.
    pub records_sent: u64,
}

/// A running simulated sensor on loopback; stops when dropped or on [`SimNetFt::finish`].
///
/// A thin wrapper around the emulated box [`NetFtEmulator`]: one count per newton and per newton
/// metre, the internal clock at the output rate (so `ft_sequence` steps by one per record) and the
/// load given in counts per internal sample number.
pub struct SimNetFt {
    emulator: NetFtEmulator,
}

impl SimNetFt {
    /// Binds a UDP socket on 127.0.0.1 (ephemeral port) and starts serving.
    pub fn spawn(options: SimOptions) -> io::Result<SimNetFt> {
        let rate = options.rate_hz.max(1.0);
        let config = NetFtEmulatorConfig {
            counts_per_force: 1.0,
            counts_per_torque: 1.0,
            force_unit: "N".into(),
            torque_unit: "N-m".into(),
            rdt_rate_hz: rate,
            internal_rate_hz: rate,
            buffered_records: options.buffered_records.max(1),
            ft_sequence_at_power_up: options.ft_sequence_start,
            range: None,
            ignore_starts: options.ignore_starts,
            ..NetFtEmulatorConfig::default()
        };
        let power_up = HostTime::now();
        let counts = options.counts;
        let ft0 = options.ft_sequence_start;
        // Host time back to the internal sample number (sample times are whole nanoseconds).
        let reading = move |t: HostTime| {
            let n = (t.since(power_up).as_nanos() as f64 * rate / 1e9).round() as u64;
            let c = counts(ft0.wrapping_add(n as u32));
            Wrench::from_array(c.map(f64::from))
        };
        let loopback = SocketAddr::from(([127, 0, 0, 1], 0));
        let emulator =
            NetFtEmulator::spawn_udp_at(loopback, None, config, Box::new(reading), power_up)?;
        Ok(SimNetFt { emulator })
    }

    /// The RDT address to connect to.
    pub fn addr(&self) -> SocketAddr {
        self.emulator
            .addr()
            .unwrap_or_else(|| SocketAddr::from(([127, 0, 0, 1], 0)))
    }

    /// Stops the simulator and reports what it did.
    pub fn finish(self) -> io::Result<SimReport> {
        let report = self.emulator.stop()?;
        Ok(SimReport {
            requests: report.requests,
            records_sent: report.records_sent,
        })
    }
}

/// A tiny HTTP server on 127.0.0.1 answering every GET of `path` with `body` (and 404
/// otherwise); stops when dropped.
pub struct SimHttp {
    addr: SocketAddr,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
}

impl SimHttp {
    /// Serves on 127.0.0.1, an ephemeral port.
    pub fn spawn(path: &str, body: String) -> io::Result<SimHttp> {
        SimHttp::bind(SocketAddr::from(([127, 0, 0, 1], 0)), path, body)
    }

    /// Serves on `addr` (port 0 = ephemeral).
    pub fn bind(addr: SocketAddr, path: &str, body: String) -> io::Result<SimHttp> {
        let listener = TcpListener::bind(addr)?;
        listener.set_nonblocking(true)?;
        let addr = listener.local_addr()?;
        let stop = Arc::new(AtomicBool::new(false));
        let flag = stop.clone();
        let path = path.to_string();
        let thread = std::thread::Builder::new()
            .name("sim-http".into())
            .spawn(move || {
                while !flag.load(Ordering::Relaxed) {
                    match listener.accept() {
                        Ok((mut conn, _)) => {
                            let _ = answer(&mut conn, &path, &body);
                        }
                        Err(_) => std::thread::sleep(Duration::from_millis(5)),
                    }
                }
            })?;
        Ok(SimHttp {
            addr,
            stop,
            thread: Some(thread),
        })
    }

    /// The address it listens on.
    pub fn addr(&self) -> SocketAddr {
        self.addr
    }

    /// `http://IP:PORT` + `path`.
    pub fn url(&self, path: &str) -> String {
        format!("http://{}{path}", self.addr)
    }
}

fn answer(conn: &mut std::net::TcpStream, path: &str, body: &str) -> io::Result<()> {
    conn.set_nonblocking(false)?;
    conn.set_read_timeout(Some(Duration::from_secs(2)))?;
    let mut req = Vec::new();
    let mut chunk = [0u8; 1024];
    while !req.windows(4).any(|w| w == b"\r\n\r\n") {
        let n = conn.read(&mut chunk)?;
        if n == 0 {
            break;
        }
        req.extend_from_slice(&chunk[..n]);
    }
    let text = String::from_utf8_lossy(&req);
    let wanted = text
        .lines()
        .next()
        .and_then(|l| l.split_whitespace().nth(1))
        .unwrap_or("");
    let reply = if wanted == path {
        format!(
            "HTTP/1.1 200 OK\r\nContent-Type: text/xml\r\nContent-Length: {}\r\nConnection: close\r\n\r\n{body}",
            body.len()
        )
    } else {
        "HTTP/1.1 404 Not Found\r\nContent-Length: 0\r\nConnection: close\r\n\r\n".to_string()
    };
    conn.write_all(reply.as_bytes())
}

impl Drop for SimHttp {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::SeqCst);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}
