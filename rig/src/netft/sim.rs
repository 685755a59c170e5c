//! A simulated Net F/T on loopback: answers RDT requests over UDP like the real box, paced at a
//! configurable rate, and serves a `netftapi2.xml` page over HTTP. Used by tests, the receive
//! benchmark and bench-free development.

use super::rdt::{encode_datagram, Command, Record, Request};
use std::io::{self, Read, Write};
use std::net::{SocketAddr, TcpListener, UdpSocket};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

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

/// A running simulated sensor; stops when dropped or on [`SimNetFt::finish`].
pub struct SimNetFt {
    addr: SocketAddr,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<io::Result<SimReport>>>,
}

impl SimNetFt {
    /// Binds a UDP socket on 127.0.0.1 (ephemeral port) and starts serving.
    pub fn spawn(options: SimOptions) -> io::Result<SimNetFt> {
        let socket = UdpSocket::bind("127.0.0.1:0")?;
        let addr = socket.local_addr()?;
        let stop = Arc::new(AtomicBool::new(false));
        let flag = stop.clone();
        let thread = std::thread::Builder::new()
            .name("sim-netft".into())
            .spawn(move || serve(socket, options, flag))?;
        Ok(SimNetFt {
            addr,
            stop,
            thread: Some(thread),
        })
    }

    /// The RDT address to connect to.
    pub fn addr(&self) -> SocketAddr {
        self.addr
    }

    /// Stops the simulator and reports what it did.
    pub fn finish(mut self) -> io::Result<SimReport> {
        self.stop.store(true, Ordering::SeqCst);
        match self.thread.take().map(|t| t.join()) {
            Some(Ok(r)) => r,
            Some(Err(_)) => Err(io::Error::other("the simulated Net F/T thread panicked")),
            None => Ok(SimReport::default()),
        }
    }
}

impl Drop for SimNetFt {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::SeqCst);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

struct Stream {
    peer: SocketAddr,
    mode: Command,
    next_rdt: u32,
    remaining: Option<u32>,
    next_due: Instant,
}

fn serve(socket: UdpSocket, options: SimOptions, stop: Arc<AtomicBool>) -> io::Result<SimReport> {
    let period = Duration::from_secs_f64(1.0 / options.rate_hz.max(1.0));
    let mut report = SimReport::default();
    let mut stream: Option<Stream> = None;
    let mut ft_sequence = options.ft_sequence_start;
    let mut bias = [0i32; 6];
    let mut ignored = 0u32;
    let mut buf = [0u8; 64];
    socket.set_read_timeout(Some(Duration::from_millis(5)))?;
    let mut records = Vec::with_capacity(options.buffered_records.max(1));
    while !stop.load(Ordering::Relaxed) {
        // Requests: block briefly when idle, poll while streaming.
        socket.set_nonblocking(stream.is_some())?;
        match socket.recv_from(&mut buf) {
            Ok((n, from)) => {
                if let Ok(req) = Request::decode(&buf[..n]) {
                    report.requests.push(req);
                    match req.command {
                        Command::RealTime | Command::Buffered => {
                            if ignored < options.ignore_starts {
                                ignored += 1;
                            } else {
                                stream = Some(Stream {
                                    peer: from,
                                    mode: req.command,
                                    next_rdt: 1,
                                    remaining: (req.sample_count > 0).then_some(req.sample_count),
                                    next_due: Instant::now(),
                                });
                            }
                        }
                        Command::Stop => stream = None,
                        Command::SoftwareBias => bias = (options.counts)(ft_sequence),
                        Command::MultiUnit | Command::ResetThresholdLatch => {}
                    }
                }
            }
            Err(e)
                if matches!(
                    e.kind(),
                    io::ErrorKind::WouldBlock | io::ErrorKind::TimedOut
                ) => {}
            Err(e) => return Err(e),
        }
        let Some(s) = stream.as_mut() else { continue };
        let now = Instant::now();
        if now < s.next_due {
            let wait = s.next_due - now;
            if wait > Duration::from_micros(200) {
                std::thread::sleep(wait - Duration::from_micros(100));
            } else {
                std::thread::yield_now();
            }
            continue;
        }
        // Send everything that is due (catching up after a late wake-up).
        let per_datagram = if s.mode == Command::Buffered {
            options.buffered_records.max(1)
        } else {
            1
        };
        while s.next_due <= now && s.remaining != Some(0) {
            records.clear();
            while records.len() < per_datagram && s.remaining != Some(0) {
                let c = (options.counts)(ft_sequence);
                records.push(Record {
                    rdt_sequence: s.next_rdt,
                    ft_sequence,
                    status: 0,
                    counts: std::array::from_fn(|i| c[i].wrapping_sub(bias[i])),
                });
                s.next_rdt = s.next_rdt.wrapping_add(1);
                ft_sequence = ft_sequence.wrapping_add(1);
                s.next_due += period;
                if let Some(r) = s.remaining.as_mut() {
                    *r -= 1;
                }
            }
            socket.send_to(&encode_datagram(&records), s.peer)?;
            report.records_sent += records.len() as u64;
        }
        if s.remaining == Some(0) {
            stream = None;
        }
    }
    // Record requests that arrived before the stop but were not read yet (a final stop).
    socket.set_nonblocking(true)?;
    while let Ok((n, _)) = socket.recv_from(&mut buf) {
        if let Ok(req) = Request::decode(&buf[..n]) {
            report.requests.push(req);
        }
    }
    Ok(report)
}

/// A tiny HTTP server on 127.0.0.1 answering every GET of `path` with `body` (and 404
/// otherwise); stops when dropped.
pub struct SimHttp {
    addr: SocketAddr,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
}

impl SimHttp {
    pub fn spawn(path: &str, body: String) -> io::Result<SimHttp> {
        let listener = TcpListener::bind("127.0.0.1:0")?;
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

    /// `http://127.0.0.1:PORT` + `path`.
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
