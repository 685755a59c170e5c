//! `fringe daq` against the workspace's fake `libnidaqmx.so` (tests/fake-nidaqmx: NI's
//! documented behaviour with a hardware-paced sample clock, an unplug), loaded through
//! `--library` as a real NI-DAQmx would be: the CSV's rows and their forces, the count against
//! the elapsed time, and one-line errors for a wrong device, a missing library and a pulled cable.

mod common;
use common::{fringe_command, printed_figure, scratch};

use fringe_rig::atical::Calibration;
use std::path::{Path, PathBuf};
use std::process::Output;
use std::time::{Duration, Instant};

/// The fake library, built beside the `fringe` binary (a workspace member).
fn fake_library() -> PathBuf {
    let lib = Path::new(env!("CARGO_BIN_EXE_fringe")).with_file_name("libnidaqmx.so");
    assert!(
        lib.exists(),
        "{} is missing: build it with `cargo build -p fringe-fake-nidaqmx` (scripts/test builds it before the tests)",
        lib.display()
    );
    lib
}

fn cal() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/data/mini40-v1.0.cal")
}

/// Gauge volts on ADC steps of a 16-bit converter over +-10 V: they read back exactly.
const LSB: f64 = 20.0 / 65536.0;
const STEPS: [f64; 6] = [1640.0, -820.0, 3277.0, 410.0, -2048.0, 96.0];

fn config(dir: &Path, extra: &str) -> PathBuf {
    let volts: Vec<String> = STEPS
        .iter()
        .enumerate()
        .map(|(i, s)| format!("ai{i} = {}", s * LSB))
        .collect();
    let text = format!(
        "[[device]]\nname = \"Dev1\"\n{extra}\n[device.volts]\n{}\n[device.square.ai7]\nhigh = 3.3\nlow = 0.0\nfrequency_hz = 50.0\nduty = 0.3\n",
        volts.join("\n")
    );
    let path = dir.join("fake.toml");
    std::fs::write(&path, text).expect("write the fake's devices");
    path
}

fn daq(dir: &Path, extra: &str, args: &[&str]) -> Output {
    fringe_command()
        .env("FRINGE_FAKE_NIDAQMX", config(dir, extra))
        .arg("daq")
        .arg("--library")
        .arg(fake_library())
        .arg("--cal")
        .arg(cal())
        .args(args)
        .output()
        .expect("run fringe")
}

#[test]
fn a_stream_writes_every_sample_with_the_cal_conversion_and_counts_them_against_the_time() {
    let dir = scratch("daq-stream");
    let csv = dir.join("daq.csv");
    let out = daq(
        &dir,
        "",
        &[
            "--strobe",
            "ai7",
            "stream",
            "--seconds",
            "2",
            "--csv",
            csv.to_str().expect("utf8"),
        ],
    );
    let printed = String::from_utf8_lossy(&out.stdout).to_string();
    assert!(
        out.status.success(),
        "{printed}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let samples = printed_figure(&printed, "samples: ");
    let expected = printed_figure(&printed, "expected: ");
    assert!(
        (samples - expected).abs() <= 0.01 * expected + 50.0,
        "{samples} samples where the elapsed time gives {expected}"
    );
    assert!(expected > 9000.0, "{printed}");
    assert_eq!(printed_figure(&printed, "lost samples: "), 0.0);
    assert_eq!(printed_figure(&printed, "overruns: "), 0.0);

    let text = std::fs::read_to_string(&csv).expect("the CSV");
    let mut lines = text.lines();
    assert_eq!(
        lines.next(),
        Some("host_time_s,sample_index,fx_n,fy_n,fz_n,tx_nm,ty_nm,tz_nm,strobe_v")
    );
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|v| v.parse().expect("a number")).collect())
        .collect();
    assert_eq!(rows.len() as f64, samples, "a row per sample");
    let calibration = Calibration::load(&cal()).expect("the .cal");
    let want = calibration.convert(STEPS.map(|s| s * LSB), [0.0; 6], None);
    for (k, row) in rows.iter().enumerate() {
        assert_eq!(row[1], k as f64, "consecutive sample indices");
        for axis in 0..6 {
            // The CSV prints each force to its shortest exact decimal: it parses back exactly.
            assert_eq!(row[2 + axis], want[axis], "row {k} axis {axis}");
        }
    }
    let high = rows.iter().filter(|r| r[8] > 1.5).count() as f64 / rows.len() as f64;
    assert!(
        (high - 0.3).abs() < 0.02,
        "strobe high {high:.3} of the time"
    );
}

#[test]
fn a_wrong_device_and_a_missing_library_are_one_line_naming_the_flag() {
    let dir = scratch("daq-refused");
    let csv = dir.join("x.csv");
    let args = [
        "stream",
        "--seconds",
        "1",
        "--csv",
        csv.to_str().expect("utf8"),
    ];
    let out = daq(&dir, "", &[&["--device", "Dev7"][..], &args[..]].concat());
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr).trim().to_string();
    assert_eq!(err.lines().count(), 1, "one line: {err}");
    assert!(err.contains("--device") && err.contains("Dev7"), "{err}");
    assert!(!csv.exists(), "no CSV for a device that never opened");

    let out = fringe_command()
        .args(["daq", "--library", "/nonexistent/libnidaqmx.so.1", "--cal"])
        .arg(cal())
        .args(args)
        .output()
        .expect("run fringe");
    let err = String::from_utf8_lossy(&out.stderr).trim().to_string();
    assert!(!out.status.success());
    assert_eq!(err.lines().count(), 1, "one line: {err}");
    for part in [
        "/nonexistent/libnidaqmx.so.1",
        "install NI-DAQmx for Linux",
        "--library",
    ] {
        assert!(err.contains(part), "{part:?} in {err}");
    }
}

#[test]
fn a_pulled_cable_ends_the_stream_with_one_line_within_a_second() {
    let dir = scratch("daq-unplug");
    let csv = dir.join("daq.csv");
    let started = Instant::now();
    let out = daq(
        &dir,
        "unplug_after_s = 1.0",
        &[
            "stream",
            "--seconds",
            "10",
            "--csv",
            csv.to_str().expect("utf8"),
        ],
    );
    let took = started.elapsed();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr).trim().to_string();
    assert_eq!(err.lines().count(), 1, "one line: {err}");
    assert!(
        err.contains("Dev1 is gone (unplugged or powered off?)"),
        "{err}"
    );
    // Pulled 1 s after the start: the error within a second of it, not at the end of the 10 s.
    assert!(took < Duration::from_secs(5), "took {took:?}");
    let rows = std::fs::read_to_string(&csv)
        .expect("the samples before the pull")
        .lines()
        .count();
    assert!(
        rows > 4000,
        "{rows} rows kept from the second before the pull"
    );
}
