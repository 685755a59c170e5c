//! The self-check that needs no hardware (`fringe` with no command and no simulated bench): the
//! real Net F/T driver over real UDP against the simulated Net F/T box on loopback, a
//! two-second press rising to 5 N, and what arrived.

use fringe_rig::record_datagrams;
use fringe_rig::UdpLink;
use fringe_rig::{ForceError, ForceSensor, StreamStats};
use fringe_rig::{NetFt, NetFtConfig, NetFtOptions};
use fringe_sim::{SimNetFt, SimOptions};
use std::io;
use std::path::Path;
use std::sync::Arc;
use std::time::{Duration, Instant};

/// Counts per newton and per newton metre of the simulated box.
const COUNTS_PER_UNIT: f64 = 1_000_000.0;
const RATE_HZ: f64 = 5000.0;
const PRESS_SECONDS: f64 = 2.0;
const PEAK_NEWTONS: f64 = 5.0;

/// Why the self-check could not run.
#[derive(Debug, thiserror::Error)]
pub enum SelfCheckError {
    #[error("cannot start the simulated Net F/T on loopback")]
    Start(#[source] io::Error),
    #[error("cannot open udp {addr}")]
    Udp {
        addr: String,
        #[source]
        source: io::Error,
    },
    #[error("cannot create the trace file")]
    Trace(#[source] io::Error),
    #[error("{0}")]
    Force(#[source] ForceError),
}

/// What the driver received from the simulated box.
#[derive(Debug)]
pub struct SelfCheck {
    /// The simulated box's loopback address.
    pub addr: String,
    pub samples: u64,
    /// Seconds the press was read for.
    pub seconds: f64,
    pub stats: StreamStats,
    /// The largest |Fz| read, N.
    pub peak_n: f64,
}

/// Runs the press; `record_trace` records the driver's datagrams to `DIR/netft.trace`.
pub fn netft_selfcheck(record_trace: Option<&Path>) -> Result<SelfCheck, SelfCheckError> {
    let options = SimOptions {
        rate_hz: RATE_HZ,
        counts: Arc::new(|n| {
            let t = n as f64 / RATE_HZ;
            let phase = (std::f64::consts::PI * t / PRESS_SECONDS).sin();
            let fz = -PEAK_NEWTONS * phase * phase;
            [0, 0, (fz * COUNTS_PER_UNIT) as i32, 0, 0, 0]
        }),
        ..SimOptions::default()
    };
    let sim = SimNetFt::spawn(options).map_err(SelfCheckError::Start)?;
    let addr = sim.addr().to_string();
    let link = UdpLink::connect(&addr).map_err(|source| SelfCheckError::Udp {
        addr: addr.clone(),
        source,
    })?;
    let link =
        record_datagrams(Box::new(link), record_trace, "netft").map_err(SelfCheckError::Trace)?;
    let config = NetFtConfig::new(COUNTS_PER_UNIT, COUNTS_PER_UNIT, "N", "N-m", "self-check")
        .map_err(SelfCheckError::Force)?;
    let mut ft = NetFt::new(link, config, NetFtOptions::default());
    ft.start().map_err(SelfCheckError::Force)?;
    let started = Instant::now();
    let (mut samples, mut peak_n) = (0u64, 0.0f64);
    while started.elapsed() < Duration::from_secs_f64(PRESS_SECONDS) {
        if let Some(sample) = ft
            .next_sample(Duration::from_millis(100))
            .map_err(SelfCheckError::Force)?
        {
            samples += 1;
            peak_n = peak_n.max(-sample.wrench.fz.0);
        }
    }
    ft.stop().map_err(SelfCheckError::Force)?;
    Ok(SelfCheck {
        addr,
        samples,
        seconds: started.elapsed().as_secs_f64(),
        stats: ft.stats(),
        peak_n,
    })
}
