//! Net F/T RDT receive benchmark: a simulated sensor streams on loopback UDP at a fixed rate
//! and the real driver ([`NetFt`] over [`UdpLink`]) receives it.
//!
//! ```text
//! cargo run -p fringe-sim --example netft_bench -- [SECONDS] [RATE_HZ] [buffered]
//! ```
//!
//! Prints the records sent and received, lost and out-of-order counts and the achieved rate.
//! Exits non-zero if any record was lost.

use fringe_rig::ForceSensor;
use fringe_rig::UdpLink;
use fringe_rig::{netft::Command, NetFt, NetFtConfig, NetFtOptions};
use fringe_sim::{SimNetFt, SimOptions};
use std::process::ExitCode;
use std::time::{Duration, Instant};

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let seconds: f64 = args.first().and_then(|s| s.parse().ok()).unwrap_or(10.0);
    let rate: f64 = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(7000.0);
    let buffered = args.iter().any(|a| a == "buffered");
    match run(seconds, rate, buffered) {
        Ok(true) => ExitCode::SUCCESS,
        Ok(false) => ExitCode::FAILURE,
        Err(e) => {
            eprintln!("netft_bench: {e}");
            ExitCode::FAILURE
        }
    }
}

fn run(seconds: f64, rate: f64, buffered: bool) -> Result<bool, Box<dyn std::error::Error>> {
    let sim = SimNetFt::spawn(SimOptions {
        rate_hz: rate,
        ..SimOptions::default()
    })?;
    let link = UdpLink::connect(&sim.addr().to_string())?;
    let config = NetFtConfig::new(1e6, 1e6, "N", "N-m", "bench")?;
    let mode = if buffered {
        Command::Buffered
    } else {
        Command::RealTime
    };
    let mut ft = NetFt::new(
        link,
        config,
        NetFtOptions {
            mode,
            ..NetFtOptions::default()
        },
    );
    ft.start()?;
    let t0 = Instant::now();
    let duration = Duration::from_secs_f64(seconds);
    let mut received = 0u64;
    let mut first = None;
    let mut last = None;
    let mut checksum = 0.0;
    while t0.elapsed() < duration {
        if let Some(s) = ft.next_sample(Duration::from_millis(100))? {
            received += 1;
            checksum += s.wrench.fz.0;
            first.get_or_insert(s.host_time);
            last = Some(s.host_time);
        }
    }
    ft.stop()?;
    // Let the simulator see the stop, then collect whatever was still in flight.
    while let Some(s) = ft.next_sample(Duration::from_millis(50))? {
        received += 1;
        checksum += s.wrench.fz.0;
        last = Some(s.host_time);
    }
    let report = sim.finish()?;
    let stats = ft.stats();
    let span = match (first, last) {
        (Some(a), Some(b)) => b.since(a).as_secs_f64(),
        _ => 0.0,
    };
    println!("mode: {}", if buffered { "buffered" } else { "real-time" });
    println!("target rate: {rate} Hz for {seconds} s");
    println!("sent: {}", report.records_sent);
    println!("received: {received}");
    println!("lost: {}", stats.lost);
    println!("out of order: {}", stats.out_of_order);
    println!(
        "achieved rate: {:.1} Hz",
        if span > 0.0 {
            (received.saturating_sub(1)) as f64 / span
        } else {
            0.0
        }
    );
    println!("(checksum {checksum:.3})");
    Ok(stats.lost == 0 && received == report.records_sent)
}
