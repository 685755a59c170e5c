//! `fringe` with no command: a self-check that needs no hardware.
//!
//! It runs the real Net F/T driver over real UDP against the built-in simulated Net F/T box on
//! loopback (a two-second press rising to 5 N), reports what arrived, lists the serial ports of
//! this machine and points to the bring-up commands. The full simulated bench (axes, camera,
//! renderer) replaces this with a short grid scan.

use crate::global::Global;
use anyhow::Context;
use fringe_rig::force::ForceSensor;
use fringe_rig::netft::{NetFt, NetFtConfig, NetFtOptions};
use fringe_rig::transport::udp::UdpLink;
use fringe_sim::emulators::netft_box::{SimNetFt, SimOptions};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// Counts per newton and per newton metre of the simulated box.
const COUNTS_PER_UNIT: f64 = 1_000_000.0;
const RATE_HZ: f64 = 5000.0;
const PRESS_SECONDS: f64 = 2.0;
const PEAK_NEWTONS: f64 = 5.0;

pub fn run(global: &Global) -> anyhow::Result<()> {
    println!(
        "fringe {}: no command given, running the self-check on the simulated Net F/T",
        env!("CARGO_PKG_VERSION")
    );
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
    let sim = SimNetFt::spawn(options).context("cannot start the simulated Net F/T on loopback")?;
    let addr = sim.addr().to_string();
    let link = UdpLink::connect(&addr).with_context(|| format!("cannot open udp {addr}"))?;
    let link = fringe_rig::trace::record_datagrams(
        Box::new(link),
        global.record_trace.as_deref(),
        "netft",
    )
    .context("cannot create the trace file")?;
    let config = NetFtConfig::new(COUNTS_PER_UNIT, COUNTS_PER_UNIT, "N", "N-m", "self-check")?;
    let mut ft = NetFt::new(link, config, NetFtOptions::default());
    ft.start()?;
    let started = Instant::now();
    let (mut count, mut peak) = (0u64, 0.0f64);
    while started.elapsed() < Duration::from_secs_f64(PRESS_SECONDS) {
        if let Some(sample) = ft.next_sample(Duration::from_millis(100))? {
            count += 1;
            peak = peak.max(-sample.wrench.fz.0);
        }
    }
    ft.stop()?;
    let stats = ft.stats();
    let secs = started.elapsed().as_secs_f64();
    println!(
        "  Net F/T driver over udp {addr}: {count} samples in {secs:.2} s ({:.0} Hz), {} lost, {} out of order, peak |Fz| {:.2} N",
        count as f64 / secs,
        stats.lost,
        stats.out_of_order,
        peak
    );
    println!();
    crate::cmd::devices::run(crate::cmd::devices::DevicesArgs {}, global)?;
    println!();
    println!("bench bring-up commands (see `fringe --help` and README.md):");
    println!("  fringe axis --port PATH --actuator ZFS25 status|home|move MM|move-rel MM|stop");
    println!("  fringe ft --netft HOST stream --seconds 10 --csv ft.csv");
    println!("  fringe ystage --modbus-tcp HOST:PORT --map oriental-az status|home|move MM");
    println!("  fringe camera --aravis ID grab --count 10 --out frames/   (build with --features aravis)");
    Ok(())
}
