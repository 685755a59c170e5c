//! The emulated Net F/T box (fringe_sim::NetFtEmulator) against the real NetFt driver, in
//! process and over loopback UDP with the configuration read over HTTP, and against an independent
//! client from PyPI (pynetft, driven by tests/python/netft_client.py).

use fringe_tests::{loopback, python, python_script, require_python_module};

use fringe_rig::DatagramLink;
use fringe_rig::HostTime;
use fringe_rig::UdpLink;
use fringe_rig::Wrench;
use fringe_rig::{
    netft::{fetch_config, Command},
    NetFt, NetFtOptions,
};
use fringe_rig::{ForceError, ForceSample, ForceSensor};
use fringe_sim::ForceReading;
use fringe_sim::{NetFtEmulator, NetFtEmulatorConfig};
use std::process::Command as Process;
use std::time::{Duration, Instant};

const LOAD: [f64; 6] = [1.5, -2.25, 10.0, 0.05, -0.02, 0.001];

fn constant(w: [f64; 6]) -> Box<dyn ForceReading> {
    Box::new(move |_| Wrench::from_array(w))
}

/// Streams for `seconds`, then stops and drains; returns every sample.
fn stream<L: DatagramLink>(ft: &mut NetFt<L>, seconds: f64) -> Vec<ForceSample> {
    ft.start().expect("start");
    let t0 = Instant::now();
    let mut got = Vec::with_capacity(15_000);
    while t0.elapsed() < Duration::from_secs_f64(seconds) {
        if let Some(s) = ft.next_sample(Duration::from_millis(100)).expect("sample") {
            got.push(s);
        }
    }
    ft.stop().expect("stop");
    while let Some(s) = ft.next_sample(Duration::from_millis(50)).expect("tail") {
        got.push(s);
    }
    got
}

fn assert_continuous(samples: &[ForceSample], rate: f64, seconds: f64) {
    let n = samples.len() as f64;
    assert!(
        n >= rate * seconds * 0.9 && n <= rate * (seconds + 0.2),
        "{n} samples in {seconds} s at {rate} Hz"
    );
    for w in samples.windows(2) {
        assert_eq!(w[1].transport_seq, w[0].transport_seq.map(|s| s + 1));
        assert_eq!(
            w[1].device_tick,
            w[0].device_tick + 1,
            "ft_sequence at 7 kHz"
        );
    }
    assert_eq!(samples[0].transport_seq, Some(1));
}

fn assert_wrench(w: &Wrench, want: [f64; 6], tol: f64) {
    for (got, want) in w.to_array().iter().zip(want) {
        assert!((got - want).abs() <= tol, "{:?} vs {want:?}", w.to_array());
    }
}

#[test]
fn driver_in_process_at_7khz_loses_nothing_and_scales_counts_back() {
    let config = NetFtEmulatorConfig::default();
    let driver_config = config.driver_config().expect("page");
    let (emulator, link) =
        NetFtEmulator::spawn_in_process(config, constant(LOAD)).expect("emulator");
    let mut ft = NetFt::new(link, driver_config, NetFtOptions::default());
    let samples = stream(&mut ft, 1.5);
    assert_eq!(ft.stats().lost, 0, "{:?}", ft.stats());
    assert_continuous(&samples, 7000.0, 1.5);
    for s in &samples {
        assert_eq!(s.status, 0);
        assert_wrench(&s.wrench, LOAD, 1e-6);
    }
    // A second stream restarts rdt_sequence; ft_sequence keeps running since power-up.
    let last_tick = samples.last().map(|s| s.device_tick).unwrap_or(0);
    std::thread::sleep(Duration::from_millis(100));
    let again = stream(&mut ft, 0.2);
    assert_eq!(again[0].transport_seq, Some(1));
    assert!(
        again[0].device_tick >= last_tick + 600,
        "{} after {last_tick}",
        again[0].device_tick
    );
    let report = emulator.stop().expect("report");
    assert_eq!(report.records_sent, (samples.len() + again.len()) as u64);
    assert_eq!(
        report.requests.last().map(|r| r.command),
        Some(Command::Stop)
    );
}

#[test]
fn driver_over_udp_reads_the_configuration_page_and_keeps_up() {
    // Imperial units: the driver must take them from netftapi2.xml to get newtons back.
    let config = NetFtEmulatorConfig {
        counts_per_force: 100_000.0,
        counts_per_torque: 10_000.0,
        force_unit: "lbf".into(),
        torque_unit: "lbf-in".into(),
        ..NetFtEmulatorConfig::default()
    };
    let emulator =
        NetFtEmulator::spawn_udp(loopback(), None, config, constant(LOAD)).expect("emulator");
    let url = emulator.http_url().expect("http");
    let driver_config = fetch_config(&url, Duration::from_secs(2)).expect("netftapi2.xml");
    assert_eq!(driver_config.rdt_rate.map(|r| r.0), Some(7000.0));
    let addr = emulator.addr().expect("udp").to_string();
    for mode in [Command::RealTime, Command::Buffered] {
        let link = UdpLink::connect(&addr).expect("udp");
        let mut ft = NetFt::new(
            link,
            driver_config.clone(),
            NetFtOptions {
                mode,
                ..NetFtOptions::default()
            },
        );
        let samples = stream(&mut ft, 1.0);
        assert_eq!(ft.stats().lost, 0, "{mode:?}: {:?}", ft.stats());
        assert_continuous(&samples, 7000.0, 1.0);
        // One count is 1e-5 lbf (45 uN) and 1e-4 lbf-in (11 uN m).
        assert_wrench(&samples[samples.len() / 2].wrench, LOAD, 3e-5);
    }
}

#[test]
fn software_bias_zeroes_the_reading() {
    let config = NetFtEmulatorConfig {
        rdt_rate_hz: 1000.0,
        ..NetFtEmulatorConfig::default()
    };
    let driver_config = config.driver_config().expect("page");
    // A load that drifts slowly: the bias removes its value at the bias command.
    let start = HostTime::now();
    let reading = move |t: HostTime| {
        let mut w = LOAD;
        w[2] += 0.001 * t.since(start).as_secs_f64();
        Wrench::from_array(w)
    };
    let (_emulator, link) =
        NetFtEmulator::spawn_in_process(config, Box::new(reading)).expect("emulator");
    let mut ft = NetFt::new(link, driver_config, NetFtOptions::default());
    ft.start().expect("start");
    let before = ft
        .next_sample(Duration::from_secs(1))
        .expect("ok")
        .expect("sample");
    assert!((before.wrench.fz.0 - LOAD[2]).abs() < 1e-3);
    ft.bias().expect("bias");
    let t0 = Instant::now();
    let mut zeroed = None;
    while t0.elapsed() < Duration::from_secs(1) {
        let s = ft
            .next_sample(Duration::from_millis(100))
            .expect("ok")
            .expect("sample");
        if s.wrench.fx.0 == 0.0 {
            zeroed = Some(s);
            break;
        }
    }
    let s = zeroed.expect("the reading went to zero within a second of the bias");
    assert_wrench(&s.wrench, [0.0; 6], 2e-5);
    ft.stop().expect("stop");
}

#[test]
fn start_waits_out_a_burst_of_loss_instead_of_giving_up_at_the_first_lost_datagram() {
    use fringe_sim::{FaultDevice, FaultKind, FaultSpec, FaultTrigger, Faults, FaultyDatagrams};
    let config = NetFtEmulatorConfig::default();
    let (_emulator, link) =
        NetFtEmulator::spawn_in_process(config.clone(), constant(LOAD)).expect("emulator");
    let loss = FaultTrigger::new(
        FaultSpec {
            device: FaultDevice::Force,
            fault: FaultKind::Loss,
            after: 0.0,
            while_moving: false,
            while_streaming: false,
            duration: Some(0.25),
        },
        None,
    );
    let link = FaultyDatagrams::new(link, Faults::new(vec![loss]));
    let mut ft = NetFt::new(
        link,
        config.driver_config().expect("page"),
        NetFtOptions::default(),
    );
    let t0 = Instant::now();
    // Every datagram of the first 0.25 s is lost; five requests 100 ms apart outlast that.
    ft.start().expect("streaming once the burst is over");
    assert!(
        t0.elapsed() >= Duration::from_millis(200),
        "{:?}",
        t0.elapsed()
    );
    let s = ft
        .next_sample(Duration::from_secs(1))
        .expect("ok")
        .expect("sample");
    assert_wrench(&s.wrench, LOAD, 1e-6);
}

/// A transducer with a power-up offset of 5 N in Fx per power cycle on top of [`LOAD`].
struct PowerCycled(u32);

impl ForceReading for PowerCycled {
    fn reading_at(&mut self, _t: HostTime) -> Wrench {
        let mut w = LOAD;
        w[0] += 5.0 * f64::from(self.0);
        Wrench::from_array(w)
    }

    fn power_cycle(&mut self) {
        self.0 += 1;
    }
}

#[test]
fn a_box_that_reboots_is_asked_to_stream_again_and_its_restart_is_counted() {
    let config = NetFtEmulatorConfig {
        rdt_rate_hz: 1000.0,
        ..NetFtEmulatorConfig::default()
    };
    let emulator =
        NetFtEmulator::spawn_udp(loopback(), None, config.clone(), Box::new(PowerCycled(0)))
            .expect("emulator");
    let addr = emulator.addr().expect("udp address");
    let link = UdpLink::connect(&addr.to_string()).expect("udp link");
    let mut ft = NetFt::new(
        link,
        config.driver_config().expect("page"),
        NetFtOptions::default(),
    );
    ft.start().expect("start");
    ft.bias().expect("bias");
    std::thread::sleep(Duration::from_millis(100));
    let down = Duration::from_millis(700);
    let mut rebooted_at = None;
    let mut samples = Vec::new();
    let t0 = Instant::now();
    // The box's counter begins again from its power-up value, so the reboot shows as the counter
    // going back only if the box ran longer before the reboot than after it until the new
    // stream's first record. That record comes at the driver's restart request (it asks again
    // every 0.5 s of silence: about 0.3 s after the box is up), later on a loaded machine. A
    // reboot after 0.3 s left a 0.1 s margin, which a busy CI machine overran once: the box runs
    // 1.5 s first.
    let reboot_after = Duration::from_millis(1500);
    while t0.elapsed() < reboot_after + Duration::from_millis(2700) {
        if rebooted_at.is_none() && t0.elapsed() > reboot_after {
            emulator.power_switch().reboot(down);
            rebooted_at = Some(HostTime::now());
        }
        if let Some(s) = ft.next_sample(Duration::from_millis(20)).expect("no error") {
            samples.push(s);
        }
    }
    ft.stop().expect("stop");
    let rebooted_at = rebooted_at.expect("rebooted");
    // The box's counter begins again at power-up: that splits the stream (records sent just
    // before the reboot can be read after the test noted its time, so host time cannot).
    let split = samples
        .windows(2)
        .position(|w| w[1].device_tick < w[0].device_tick)
        .map_or(samples.len(), |i| i + 1);
    let (before, after): (Vec<&ForceSample>, Vec<&ForceSample>) = (
        samples[..split].iter().collect(),
        samples[split..].iter().collect(),
    );
    assert!(
        after.first().is_none_or(|f| f.host_time >= rebooted_at),
        "a record of the new stream came before the reboot"
    );
    let (Some(last), Some(first)) = (before.last(), after.first()) else {
        panic!(
            "samples on both sides of the reboot: {} and {}",
            before.len(),
            after.len()
        );
    };
    assert_wrench(&last.wrench, [0.0; 6], 2e-5);
    let gap = first.host_time.since(last.host_time);
    // Down 0.7 s, then asked again within the driver's 0.5 s restart interval.
    assert!(
        gap >= down && gap < down + Duration::from_millis(700),
        "stream back {gap:?} after the last sample before the reboot"
    );
    assert_eq!(first.transport_seq, Some(1), "a new stream");
    assert!(first.device_tick < last.device_tick, "counter began again");
    let mut want = LOAD;
    want[0] += 5.0;
    assert_wrench(&first.wrench, want, 2e-5);
    assert!(
        after.len() > 1000,
        "{} samples after the reboot",
        after.len()
    );
    assert_eq!(ft.stats().restarts, 1, "{:?}", ft.stats());
    let report = emulator.stop().expect("report");
    assert_eq!(report.reboots, 1);
    let starts = report
        .requests
        .iter()
        .filter(|r| r.command == Command::RealTime)
        .count();
    assert!(starts >= 2, "{:?}", report.requests);
}

#[test]
fn records_lost_in_a_burst_longer_than_the_restart_interval_are_all_counted() {
    use fringe_sim::{FaultDevice, FaultKind, FaultSpec, FaultTrigger, Faults, FaultyDatagrams};
    // 1000 records/s from a box sampling at 7 kHz: ft_sequence steps by 7 between records.
    let config = NetFtEmulatorConfig {
        rdt_rate_hz: 1000.0,
        ..NetFtEmulatorConfig::default()
    };
    let driver_config = config.driver_config().expect("page");
    let (_emulator, link) =
        NetFtEmulator::spawn_in_process(config, constant(LOAD)).expect("emulator");
    // Every datagram lost for 0.8 s, longer than the driver's 0.5 s restart interval: the
    // driver asks again mid-burst and the new stream numbers its records from 1.
    let burst = FaultSpec {
        device: FaultDevice::Force,
        fault: FaultKind::Loss,
        after: 0.4,
        while_moving: false,
        while_streaming: false,
        duration: Some(0.8),
    };
    let link = FaultyDatagrams::new(link, Faults::new(vec![FaultTrigger::new(burst, None)]));
    let mut ft = NetFt::new(link, driver_config, NetFtOptions::default());
    let samples = stream(&mut ft, 2.0);
    let stats = ft.stats();
    let restarted = samples
        .windows(2)
        .any(|w| w[1].transport_seq < w[0].transport_seq);
    assert!(
        restarted,
        "the driver sent its start request again: {stats:?}"
    );
    assert_eq!(stats.restarts, 0, "no device restart: {stats:?}");
    assert!(
        (700..=900).contains(&stats.lost),
        "0.8 s of a 1000 Hz stream lost, {} counted: {stats:?}",
        stats.lost
    );
}

#[test]
fn saturation_and_injected_faults_surface_as_driver_errors() {
    // In process: Fz beyond the Mini40's 120 N range saturates the transducer.
    let mut over = LOAD;
    over[2] = 150.0;
    let config = NetFtEmulatorConfig::default();
    let driver_config = config.driver_config().expect("page");
    let (_e, link) = NetFtEmulator::spawn_in_process(config, constant(over)).expect("emulator");
    let mut ft = NetFt::new(link, driver_config, NetFtOptions::default());
    ft.start().expect("start");
    match ft.next_sample(Duration::from_secs(1)) {
        Err(ForceError::Status { status, .. }) => assert_eq!(status, 0x8002_0000),
        other => panic!("expected a status error, got {other:?}"),
    }

    // Over UDP: a fault injected while streaming.
    let config = NetFtEmulatorConfig {
        rdt_rate_hz: 1000.0,
        ..NetFtEmulatorConfig::default()
    };
    let driver_config = config.driver_config().expect("page");
    let emulator =
        NetFtEmulator::spawn_udp(loopback(), None, config, constant(LOAD)).expect("emulator");
    let link = UdpLink::connect(&emulator.addr().expect("udp").to_string()).expect("udp");
    let mut ft = NetFt::new(link, driver_config, NetFtOptions::default());
    ft.start().expect("start");
    for _ in 0..50 {
        ft.next_sample(Duration::from_secs(1))
            .expect("healthy")
            .expect("sample");
    }
    emulator.inject_status(0x8000_0004);
    let t0 = Instant::now();
    let err = loop {
        match ft.next_sample(Duration::from_millis(100)) {
            Err(e) => break e,
            Ok(_) => assert!(t0.elapsed() < Duration::from_secs(1), "no status error"),
        }
    };
    let text = err.to_string();
    assert!(
        text.contains("0x80000004") && text.contains("bit 31"),
        "{text}"
    );
}

#[test]
fn pynetft_from_pypi_reads_forces_and_biases_the_udp_emulator() {
    require_python_module("pynetft");
    // The common ATI combination: counts per N and per N mm.
    let config = NetFtEmulatorConfig {
        counts_per_force: 1_000_000.0,
        counts_per_torque: 1_000.0,
        force_unit: "N".into(),
        torque_unit: "N-mm".into(),
        rdt_rate_hz: 1000.0,
        ..NetFtEmulatorConfig::default()
    };
    let emulator =
        NetFtEmulator::spawn_udp(loopback(), None, config, constant(LOAD)).expect("emulator");
    let rdt = emulator.addr().expect("udp");
    let http = emulator.http_addr().expect("http");
    let out = Process::new(python())
        .arg(python_script("netft_client.py"))
        .args([
            "127.0.0.1",
            &rdt.port().to_string(),
            &http.port().to_string(),
            "300",
        ])
        .output()
        .expect("run netft_client.py");
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        out.status.success(),
        "pynetft client failed:\n{stdout}\n{stderr}"
    );
    let line = |phase: &str| -> String {
        stdout
            .lines()
            .find(|l| l.contains(&format!("\"phase\": \"{phase}\"")))
            .unwrap_or_else(|| panic!("no {phase} line in:\n{stdout}\n{stderr}"))
            .to_string()
    };
    let numbers = |l: &str, key: &str| -> Vec<f64> {
        let from = l.find(&format!("\"{key}\": [")).expect("key") + key.len() + 5;
        let to = from + l[from..].find(']').expect("]");
        l[from..to]
            .split(',')
            .map(|v| v.trim().parse().expect("number"))
            .collect()
    };
    let streamed = line("stream");
    assert!(streamed.contains("\"count\": 300"), "{streamed}");
    assert!(streamed.contains("\"force_unit\": \"N\""), "{streamed}");
    assert!(streamed.contains("\"torque_unit\": \"N-mm\""), "{streamed}");
    assert!(streamed.contains("\"status_nonzero\": 0"), "{streamed}");
    assert!(streamed.contains("\"ft_increasing\": true"), "{streamed}");
    assert!(streamed.contains("\"rdt_increasing\": true"), "{streamed}");
    // Forces in N; torques in the box's N mm.
    let want = [
        LOAD[0],
        LOAD[1],
        LOAD[2],
        LOAD[3] * 1e3,
        LOAD[4] * 1e3,
        LOAD[5] * 1e3,
    ];
    for (got, want) in numbers(&streamed, "mean").iter().zip(want) {
        assert!((got - want).abs() < 1e-3, "{streamed}");
    }
    let biased = line("biased");
    assert!(biased.contains("\"count\": 300"), "{biased}");
    assert!(
        numbers(&biased, "mean").iter().all(|v| v.abs() < 1e-9),
        "{biased}"
    );
    // Before the bias: a clean stream by pynetft's own accounting.
    let before = line("health_before_bias");
    for key in [
        "lost",
        "out_of_order",
        "duplicates",
        "malformed",
        "device_errors",
        "ft_stall",
        "ft_backward",
    ] {
        assert!(before.contains(&format!("\"{key}\": 0")), "{key}: {before}");
    }
    assert!(before.contains("Net F/T (fringe emulator)"), "{before}");
    // pynetft restarts streaming after its bias command; the box numbers the new stream from 1
    // again (pynetft counts those as out of order), but nothing is lost and the device clock
    // never stalls or runs backwards.
    let after = line("health");
    for key in [
        "lost",
        "malformed",
        "device_errors",
        "ft_stall",
        "ft_backward",
    ] {
        assert!(after.contains(&format!("\"{key}\": 0")), "{key}: {after}");
    }
    assert!(after.contains("\"fault\": \"none\""), "{after}");
    let report = emulator.stop().expect("report");
    let commands: Vec<Command> = report.requests.iter().map(|r| r.command).collect();
    assert_eq!(commands.first(), Some(&Command::RealTime), "{commands:?}");
    assert!(commands.contains(&Command::SoftwareBias), "{commands:?}");
}
