//! A simulated Net F/T on loopback with the load given in raw counts, for tests and the receive
//! benchmark ([`SimNetFt`], a thin wrapper around the emulated box
//! [`crate::emulators::netft_emulator::NetFtEmulator`]), and the small HTTP server that serves a
//! `netftapi2.xml` page ([`SimHttp`]).

pub use crate::emulators::netft_emulator::SimHttp;
use crate::emulators::netft_emulator::{NetFtEmulator, NetFtEmulatorConfig};
use fringe_rig::netft::Request;
use fringe_rig::HostTime;
use fringe_rig::Wrench;
use std::io;
use std::net::SocketAddr;
use std::sync::Arc;

/// Counts (Fx..Tz) for a given internal sample number.
pub(crate) type CountsFn = Arc<dyn Fn(u32) -> [i32; 6] + Send + Sync>;

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
