//! The NI-DAQmx driver against a fake `libnidaqmx.so` loaded through the driver's own loader
//! (tests/fake-nidaqmx: NI's documented behaviour, a hardware-paced sample clock, the overflow
//! error, an unplug). Each test has its own device, so they run side by side in one process.

use fringe_rig::atical::{CalibratedSensor, Calibration, GaugeSource};
use fringe_rig::nidaqmx::{DaqError, DaqSettings, Library, NiDaq, Setting};
use fringe_rig::ForceSensor;
use fringe_rig::{Hertz, Volts};
use fringe_tests::fake_nidaqmx;
use std::ffi::{c_char, c_int, CString};
use std::path::{Path, PathBuf};
use std::sync::{Arc, OnceLock};
use std::time::{Duration, Instant};

/// One ADC step of a 16-bit converter over +-10 V: volts on this step read back exactly.
const LSB: f64 = 20.0 / 65536.0;
const GAUGE_STEPS: [f64; 6] = [1640.0, -820.0, 3277.0, 410.0, -2048.0, 96.0];

/// The fake's devices: one per test, all USB-6218s.
const CONFIG: &str = r#"
[[device]]
name = "Count1"
[device.volts]
ai0 = 0.50048828125
ai1 = -0.250244140625
ai2 = 1.000061035156250
ai3 = 0.1251220703125
ai4 = -0.625
ai5 = 0.029296875
[device.square.ai7]
high = 3.3
low = 0.0
frequency_hz = 50.0
duty = 0.3

[[device]]
name = "Slow1"

[[device]]
name = "Unplug1"

[[device]]
name = "Bad1"

[[device]]
name = "Timed1"
unplug_after_s = 0.5
"#;

fn library() -> Arc<Library> {
    static LIB: OnceLock<Arc<Library>> = OnceLock::new();
    LIB.get_or_init(|| {
        let dir = std::env::temp_dir().join(format!("fringe-nidaqmx-fake-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("temp dir");
        let config = dir.join("fake.toml");
        std::fs::write(&config, CONFIG).expect("write the fake's configuration");
        // Read by the fake at its first call, which comes after this.
        std::env::set_var("FRINGE_FAKE_NIDAQMX", &config);
        Library::load(Some(&fake_nidaqmx())).expect("load the fake libnidaqmx.so")
    })
    .clone()
}

fn settings(device: &str) -> DaqSettings {
    DaqSettings {
        device: device.into(),
        ..DaqSettings::default()
    }
}

fn mini40() -> Calibration {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("data/mini40-v1.0.cal");
    Calibration::load(&path).expect("the Mini40 .cal")
}

/// Pulls the cable of the fake's device `name` through the fake's own control function.
fn unplug(name: &str) {
    let _ = library();
    let lib = unsafe { libloading::Library::new(fake_nidaqmx()) }.expect("the fake again");
    let f: libloading::Symbol<unsafe extern "C" fn(*const c_char, c_int) -> c_int> =
        unsafe { lib.get(b"fringe_fake_nidaqmx_unplug") }.expect("the fake's unplug");
    let name = CString::new(name).expect("name");
    assert_eq!(unsafe { f(name.as_ptr(), 1) }, 0, "no device {name:?}");
}

#[test]
fn a_stream_gets_the_samples_the_elapsed_time_gives_and_the_cal_conversion_is_exact() {
    assert_eq!(
        CONFIG.matches("ai").count() - 1,
        GAUGE_STEPS.len(),
        "the configured gauge volts"
    );
    let daq = NiDaq::open(
        &library(),
        DaqSettings {
            strobe: Some("ai7".into()),
            ..settings("Count1")
        },
    )
    .expect("open Count1");
    let cal = mini40();
    let mut sensor = CalibratedSensor::new(daq, cal.clone());
    sensor.start().expect("start");
    let started = Instant::now();
    let (mut n, mut strobe_high, mut first_index, mut last_index) = (0u64, 0u64, None, 0u64);
    let mut wrench = [0.0; 6];
    while started.elapsed() < Duration::from_secs(2) {
        if let Some(s) = sensor
            .next_sample(Duration::from_millis(50))
            .expect("sample")
        {
            n += 1;
            first_index.get_or_insert(s.device_tick);
            last_index = s.device_tick;
            wrench = s.wrench.to_array();
            if s.strobe.expect("the strobe channel").0 > 1.5 {
                strobe_high += 1;
            }
        }
    }
    let elapsed = started.elapsed().as_secs_f64();
    sensor.stop().expect("stop");
    // Scans arrive in 10 ms blocks: the count the elapsed time gives, within 1 % and a block.
    let expected = elapsed * 5000.0;
    assert!(
        (n as f64 - expected).abs() <= expected * 0.01 + 50.0,
        "{n} samples in {elapsed:.3} s at 5 kHz"
    );
    assert_eq!(
        last_index - first_index.unwrap_or(0) + 1,
        n,
        "no sample lost"
    );
    assert_eq!(sensor.stats().lost, 0);
    // The gauges read exactly the configured volts (steps of the ADC), so the wrench is the .cal
    // matrix times them, to the last bit.
    let volts: [f64; 6] = std::array::from_fn(|i| GAUGE_STEPS[i] * LSB);
    let expected = cal.convert(volts, [0.0; 6], None);
    assert_eq!(wrench, expected, "the .cal conversion of the gauges");
    // The strobe: a 30 % duty square wave.
    let duty = strobe_high as f64 / n as f64;
    assert!(
        (duty - 0.3).abs() < 0.02,
        "strobe high {duty:.3} of the time"
    );
}

#[test]
fn a_reader_that_falls_behind_restarts_the_task_and_counts_what_was_lost() {
    let daq = NiDaq::open(
        &library(),
        DaqSettings {
            buffer_scans: Some(500),
            ..settings("Slow1")
        },
    )
    .expect("open Slow1");
    let mut sensor = CalibratedSensor::new(daq, mini40());
    sensor.start().expect("start");
    let read_for = |sensor: &mut CalibratedSensor<NiDaq>, d: Duration| {
        let until = Instant::now() + d;
        let mut got = Vec::new();
        while Instant::now() < until {
            if let Some(s) = sensor.next_sample(Duration::from_millis(20)).expect("read") {
                got.push(s.device_tick);
            }
        }
        got
    };
    let before = read_for(&mut sensor, Duration::from_millis(200));
    // 0.5 s without reading: 2500 scans into a 500-scan buffer.
    std::thread::sleep(Duration::from_millis(500));
    let after = read_for(&mut sensor, Duration::from_millis(300));
    assert!(
        !before.is_empty() && !after.is_empty(),
        "samples before and after"
    );
    let all: Vec<u64> = before.iter().chain(&after).copied().collect();
    let gaps: Vec<u64> = all
        .windows(2)
        .filter(|w| w[1] != w[0] + 1)
        .map(|w| w[1] - w[0] - 1)
        .collect();
    assert_eq!(gaps.len(), 1, "one gap in the sample index: {gaps:?}");
    let jump = gaps[0];
    let stats = sensor.stats();
    assert_eq!(stats.lost, jump, "the loss is the gap in the sample index");
    // 0.5 s at 5 kHz was not read; at most the 500 scans left in the buffer are not lost.
    assert!(
        (1900..=2700).contains(&jump),
        "{jump} samples lost over a 0.5 s stall"
    );
    assert_eq!(sensor.source().stats().overruns, 1, "one restart");
}

#[test]
fn an_unplugged_device_is_a_one_line_error_within_a_second() {
    let daq = NiDaq::open(&library(), settings("Unplug1")).expect("open Unplug1");
    let mut sensor = CalibratedSensor::new(daq, mini40());
    sensor.start().expect("start");
    for _ in 0..20 {
        sensor.next_sample(Duration::from_millis(20)).expect("read");
    }
    unplug("Unplug1");
    let pulled = Instant::now();
    let error = loop {
        match sensor.next_sample(Duration::from_millis(20)) {
            Ok(_) => assert!(pulled.elapsed() < Duration::from_secs(1), "still reading"),
            Err(e) => break e.to_string(),
        }
    };
    assert!(pulled.elapsed() < Duration::from_secs(1));
    assert!(!error.contains('\n'), "one line: {error}");
    assert!(error.contains("Unplug1 is gone"), "{error}");
    assert!(error.contains("-201003"), "NI's status: {error}");
}

#[test]
fn a_device_unplugged_while_streaming_stops_the_stream_by_itself() {
    let daq = NiDaq::open(&library(), settings("Timed1")).expect("open Timed1");
    let mut daq = daq;
    daq.start().expect("start");
    let started = Instant::now();
    let error = loop {
        match daq.next_reading(Duration::from_millis(20)) {
            Ok(_) => assert!(started.elapsed() < Duration::from_secs(2), "never failed"),
            Err(e) => break e.to_string(),
        }
    };
    let t = started.elapsed();
    assert!(
        t > Duration::from_millis(450) && t < Duration::from_millis(1500),
        "the error came {t:?} after the start; the cable was pulled at 0.5 s"
    );
    assert!(error.contains("unplugged or powered off"), "{error}");
}

fn refused(settings: DaqSettings) -> DaqError {
    NiDaq::open(&library(), settings).expect_err("refused")
}

#[test]
fn wrong_names_and_rates_are_refused_naming_the_setting() {
    let e = refused(settings("Nope9"));
    assert_eq!(e.setting(), Some(Setting::Device), "{e}");
    assert!(
        e.to_string().contains("no NI device is named \"Nope9\""),
        "{e}"
    );
    let e = refused(DaqSettings {
        gauges: "ai30:35".into(),
        ..settings("Bad1")
    });
    assert_eq!(e.setting(), Some(Setting::Gauges), "{e}");
    assert!(e.to_string().contains("-200170"), "{e}");
    let e = refused(DaqSettings {
        strobe: Some("ai8".into()),
        ..settings("Bad1")
    });
    assert_eq!(
        e.setting(),
        Some(Setting::Strobe),
        "a differential ai8: {e}"
    );
    let e = refused(DaqSettings {
        rate: Hertz(50_000.0),
        strobe: Some("ai7".into()),
        ..settings("Bad1")
    });
    assert_eq!(e.setting(), Some(Setting::Rate), "{e}");
    assert!(e.to_string().contains("DAQmx_SampClk_Rate"), "{e}");
    let e = refused(DaqSettings {
        range: Volts(15.0),
        ..settings("Bad1")
    });
    assert_eq!(e.setting(), Some(Setting::Range), "{e}");
    assert!(e.to_string().contains("DAQmx_AI_Max"), "{e}");
    // Every refusal left the device free: a good task opens on it.
    NiDaq::open(&library(), settings("Bad1")).expect("the good settings");
    let e = refused(settings("Nope9"));
    assert!(!e.to_string().contains('\n'), "one line: {e}");
}

#[test]
fn a_machine_without_ni_daqmx_is_told_what_to_install() {
    let e = Library::load(Some(Path::new("/nonexistent/libnidaqmx.so"))).expect_err("no library");
    let text = e.to_string();
    assert_eq!(e.setting(), Some(Setting::Library));
    assert!(text.contains("/nonexistent/libnidaqmx.so"), "{text}");
    assert!(text.contains("install NI-DAQmx for Linux"), "{text}");
    assert!(!text.contains('\n'), "one line: {text}");
}
