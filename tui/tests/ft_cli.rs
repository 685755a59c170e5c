//! `fringe ft ... stream` against a simulated Net F/T on loopback (UDP RDT + HTTP
//! netftapi2.xml), checking the CSV rows and the printed sample count, rate and lost packets.

mod common;
use common::{fringe_command, printed_figure, scratch};

use fringe_rig::ForceSensor;
use fringe_rig::{netft::Command, NetFt, NetFtConfig, NetFtOptions};
use fringe_rig::{ReplayDatagramLink, ReplayOptions, Trace};
use fringe_sim::{SimHttp, SimNetFt, SimOptions};
use std::sync::Arc;
use std::time::Duration;

const XML: &str = "<?xml version=\"1.0\"?><netft><cfgcpf>1000000</cfgcpf><cfgcpt>1000</cfgcpt><scfgfu>N</scfgfu><scfgtu>N-mm</scfgtu><comrdtrate>1000</comrdtrate></netft>";

#[test]
fn stream_reads_the_configuration_page_and_writes_csv() {
    let options = SimOptions {
        rate_hz: 1000.0,
        // Fz = (n mod 1000) N, Tx = 2.5 N m (2500 N mm), others fixed.
        counts: Arc::new(|n| {
            [
                250_000,
                -1_000_000,
                (n % 1000) as i32 * 1_000_000,
                2_500_000,
                0,
                -1_000,
            ]
        }),
        ..SimOptions::default()
    };
    let sim = SimNetFt::spawn(options).expect("sim");
    let http = SimHttp::spawn("/netftapi2.xml", XML.to_string()).expect("http");
    let dir = scratch("stream");
    let csv = dir.join("ft.csv");
    let traces = dir.join("traces");
    let out = fringe_command()
        .args([
            "--record-trace",
            traces.to_str().expect("utf8"),
            "ft",
            "--netft",
            &sim.addr().to_string(),
        ])
        .args([
            "--config-url",
            &http.url("/netftapi2.xml"),
            "stream",
            "--seconds",
            "0.5",
            "--csv",
        ])
        .arg(&csv)
        .output()
        .expect("run fringe");
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "fringe failed:\n{stdout}\n{stderr}");

    let count = printed_figure(&stdout, "samples: ");
    let rate = printed_figure(&stdout, "rate: ");
    assert_eq!(printed_figure(&stdout, "lost packets: "), 0.0, "{stdout}");
    assert!(
        (350.0..=520.0).contains(&count),
        "about 500 samples in 0.5 s at 1 kHz: {stdout}"
    );
    assert!(
        (900.0..=1100.0).contains(&rate),
        "rate near 1000 Hz: {stdout}"
    );

    let text = std::fs::read_to_string(&csv).expect("csv");
    let mut lines = text.lines();
    assert_eq!(
        lines.next(),
        Some("host_time_s,rdt_sequence,ft_sequence,fx_n,fy_n,fz_n,tx_nm,ty_nm,tz_nm")
    );
    let rows: Vec<Vec<f64>> = lines
        .map(|l| {
            l.split(',')
                .map(|v| v.parse::<f64>().expect("number"))
                .collect()
        })
        .collect();
    assert_eq!(rows.len() as f64, count);
    for (i, r) in rows.iter().enumerate() {
        assert_eq!(r.len(), 9);
        assert_eq!(r[1], (i + 1) as f64, "rdt sequence counts from 1");
        let n = r[2];
        assert_eq!(r[3], 0.25);
        assert_eq!(r[4], -1.0);
        assert_eq!(r[5], n % 1000.0, "Fz follows the sample number");
        assert_eq!(r[6], 2.5, "2500 N mm = 2.5 N m");
        assert_eq!(r[8], -0.001);
        if i > 0 {
            assert!(r[0] >= rows[i - 1][0], "host time is monotonic");
            assert_eq!(r[2], rows[i - 1][2] + 1.0, "ft sequence is consecutive");
        }
    }

    let trace = std::fs::read_to_string(traces.join("netft.trace")).expect("trace recorded");
    assert!(
        trace.contains("# device: netft") && trace.contains("> 12 34 00 02 00 00 00 00"),
        "{trace}"
    );
    // The recorded trace replays through the driver: same requests, same samples.
    let recorded = Trace::load(&traces.join("netft.trace")).expect("parse recorded trace");
    let (link, handle) = ReplayDatagramLink::new(
        recorded,
        ReplayOptions {
            speed: f64::INFINITY,
        },
    );
    let config = NetFtConfig::new(1e6, 1e3, "N", "N-mm", "test").expect("config");
    let mut replayed = NetFt::new(link, config, NetFtOptions::default());
    replayed.start().expect("replay start");
    let mut fz = Vec::new();
    while let Some(s) = replayed
        .next_sample(Duration::from_millis(20))
        .expect("replayed sample")
    {
        fz.push(s.wrench.fz.0);
    }
    replayed.stop().expect("replay stop");
    handle.finish().expect("the driver sent what was recorded");
    assert!(
        fz.len() as f64 >= count,
        "{} replayed, {count} in the CSV",
        fz.len()
    );
    assert!(
        rows.iter().zip(&fz).all(|(r, f)| r[5] == *f),
        "replayed Fz equals the CSV"
    );

    let report = sim.finish().expect("sim report");
    assert_eq!(
        report.requests.first().map(|r| r.command),
        Some(Command::RealTime)
    );
    assert_eq!(
        report.requests.last().map(|r| r.command),
        Some(Command::Stop)
    );
}

#[test]
fn counts_given_on_the_command_line_skip_the_configuration_page() {
    let sim = SimNetFt::spawn(SimOptions {
        rate_hz: 500.0,
        ignore_starts: 1,
        counts: Arc::new(|_| [2_000, 0, 0, 0, 0, 30]),
        ..SimOptions::default()
    })
    .expect("sim");
    let dir = scratch("cpf");
    let csv = dir.join("ft.csv");
    let out = fringe_command()
        .args([
            "ft",
            "--netft",
            &sim.addr().to_string(),
            "--cpf",
            "1000",
            "--cpt",
            "1000",
        ])
        .args([
            "--force-unit",
            "lbf",
            "--torque-unit",
            "lbf-in",
            "stream",
            "--seconds",
            "0.2",
            "--csv",
        ])
        .arg(&csv)
        .output()
        .expect("run fringe");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = std::fs::read_to_string(&csv).expect("csv");
    let row: Vec<f64> = text
        .lines()
        .nth(1)
        .expect("a row")
        .split(',')
        .map(|v| v.parse().expect("num"))
        .collect();
    assert!(
        (row[3] - 2.0 * 4.448_221_615_260_5).abs() < 1e-9,
        "2 lbf in N: {row:?}"
    );
    assert!(
        (row[8] - 0.03 * 0.112_984_829_027_617).abs() < 1e-12,
        "0.03 lbf-in in N m: {row:?}"
    );
    let report = sim.finish().expect("report");
    let starts = report
        .requests
        .iter()
        .filter(|r| r.command == Command::RealTime)
        .count();
    assert_eq!(starts, 2, "the ignored start request was sent again");
}

#[test]
fn unreachable_sensor_ends_with_one_line_saying_what_to_check() {
    // A closed loopback port: the configuration page cannot be fetched.
    let out = fringe_command()
        .args([
            "ft",
            "--netft",
            "127.0.0.1:9",
            "--config-url",
            "http://127.0.0.1:1/netftapi2.xml",
        ])
        .args(["stream", "--seconds", "1", "--csv", "/dev/null"])
        .output()
        .expect("run fringe");
    assert!(!out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
    assert!(
        stderr.contains("http://127.0.0.1:1/netftapi2.xml") && stderr.contains("--cpf"),
        "{stderr}"
    );

    // Nothing answers RDT: the start retries run out.
    let silent = std::net::UdpSocket::bind("127.0.0.1:0").expect("bind");
    let addr = silent.local_addr().expect("addr").to_string();
    let csv_dir = scratch("silent");
    let csv = csv_dir.join("ft.csv");
    let out = fringe_command()
        .args([
            "ft", "--netft", &addr, "--cpf", "1000000", "--cpt", "1000000",
        ])
        .args(["stream", "--seconds", "1", "--csv"])
        .arg(&csv)
        .output()
        .expect("run fringe");
    assert!(!out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
    assert!(
        stderr.contains(&addr) && stderr.contains("start requests") && stderr.contains("powered"),
        "{stderr}"
    );
    assert!(!csv.exists(), "a CSV with only its header was left behind");
}

#[test]
fn durations_no_clock_can_hold_are_refused_naming_the_option() {
    let out = fringe_command()
        .args(["ft", "--netft", "127.0.0.1:9", "--cpf", "1", "--cpt", "1"])
        .args(["stream", "--seconds", "1e300", "--csv", "/dev/null"])
        .output()
        .expect("run fringe");
    assert!(!out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("--seconds") && stderr.contains("1e300") && !stderr.contains("panicked"),
        "{stderr}"
    );
}

#[test]
fn bias_sends_the_software_bias_command_and_reads_zero_after_it() {
    let sim = SimNetFt::spawn(SimOptions {
        rate_hz: 1000.0,
        counts: Arc::new(|_| [5_000_000, -3_000_000, 1_000_000, 200_000, 0, 7]),
        ..SimOptions::default()
    })
    .expect("sim");
    let out = fringe_command()
        .args([
            "ft",
            "--netft",
            &sim.addr().to_string(),
            "--cpf",
            "1000000",
            "--cpt",
            "1000000",
            "bias",
        ])
        .output()
        .expect("run fringe");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(stdout.contains("software bias sent"), "{stdout}");
    assert!(
        stdout.contains("Fx 0.0000 N  Fy 0.0000 N  Fz 0.0000 N"),
        "{stdout}"
    );
    let report = sim.finish().expect("report");
    let commands: Vec<Command> = report.requests.iter().map(|r| r.command).collect();
    assert_eq!(
        commands,
        vec![Command::RealTime, Command::SoftwareBias, Command::Stop]
    );
}
