//! The Net F/T driver keeps up with 7 kHz on loopback UDP without losing a record (a one-second
//! version of `cargo run -p fringe-sim --example netft_bench`, see BENCHMARKS.md).

use fringe_rig::ForceSensor;
use fringe_rig::UdpLink;
use fringe_rig::{NetFt, NetFtConfig, NetFtOptions};
use fringe_sim::{SimNetFt, SimOptions};
use std::time::{Duration, Instant};

#[test]
fn seven_kilohertz_for_one_second_without_loss() {
    let sim = SimNetFt::spawn(SimOptions {
        rate_hz: 7000.0,
        ..SimOptions::default()
    })
    .expect("sim");
    let link = UdpLink::connect(&sim.addr().to_string()).expect("udp");
    let config = NetFtConfig::new(1e6, 1e6, "N", "N-m", "test").expect("config");
    let mut ft = NetFt::new(link, config, NetFtOptions::default());
    ft.start().expect("start");
    let t0 = Instant::now();
    let mut received = 0u64;
    let mut ticks = Vec::with_capacity(8000);
    while t0.elapsed() < Duration::from_secs(1) {
        if let Some(s) = ft.next_sample(Duration::from_millis(100)).expect("sample") {
            received += 1;
            ticks.push(s.device_tick);
        }
    }
    ft.stop().expect("stop");
    while let Some(s) = ft.next_sample(Duration::from_millis(50)).expect("tail") {
        received += 1;
        ticks.push(s.device_tick);
    }
    let report = sim.finish().expect("sim report");
    assert_eq!(ft.stats().lost, 0, "{:?}", ft.stats());
    assert_eq!(received, report.records_sent);
    assert!(
        received >= 6500,
        "about 7000 records in one second, got {received}"
    );
    assert!(
        ticks.windows(2).all(|w| w[1] == w[0] + 1),
        "ft_sequence consecutive"
    );
}
