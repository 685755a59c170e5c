//! The emulated APT stepper controller (fringe_sim::AptEmulator) against the real
//! ThorlabsAxis driver (in process and over a pseudo-terminal), against raw bytes, and against
//! two independent clients from PyPI (thorlabs-apt-device, tests/python/apt_device_client.py,
//! and pyLabLib's KinesisMotor, tests/python/apt_pylablib_client.py), run with FRINGE_PYTHON.

use fringe_rig::apt::encode;
use fringe_rig::apt::USB_UNIT;
use fringe_rig::apt::{Flow, StreamDecoder};
use fringe_rig::apt::{Message, Packet};
use fringe_rig::byte_pair;
use fringe_rig::ByteLink;
use fringe_rig::HostTime;
use fringe_rig::Kinematics;
use fringe_rig::{
    apt::{open_serial, Actuator},
    AptConfig, Controller, ThorlabsAxis,
};
use fringe_rig::{Axis, AxisError, SoftLimits, StopMode};
use fringe_rig::{Millimetres, MillimetresPerSecond, MillimetresPerSecondSquared};
use fringe_sim::{AptEmulator, AptEmulatorConfig, KeepAlive};
use fringe_sim::{MotorSpec, SimMotor};
use fringe_tests::{python, python_script};
use std::process::Command;
use std::sync::Arc;
use std::time::{Duration, Instant};

fn zfs25() -> Actuator {
    Actuator::by_name("ZFS25B").expect("ZFS25B is a known actuator")
}

/// One encoder count (microstep) of the ZFS25, in mm.
fn one_step() -> f64 {
    1.0 / zfs25().microsteps_per_mm
}

fn motor(power_up: f64) -> Arc<SimMotor> {
    Arc::new(SimMotor::new(MotorSpec {
        name: "x".into(),
        travel: Millimetres(25.0),
        power_up_position: Millimetres(power_up),
        kinematics: Kinematics {
            velocity: MillimetresPerSecond(1.0),
            acceleration: MillimetresPerSecondSquared(1.0),
        },
    }))
}

/// A driver configuration: 2 mm/s, 4 mm/s^2, homing at 2 mm/s.
fn driver_config() -> AptConfig {
    let mut c = AptConfig::new("x", Controller::Kst101, zfs25());
    c.velocity = MillimetresPerSecond(2.0);
    c.acceleration = MillimetresPerSecondSquared(4.0);
    c.home.velocity = MillimetresPerSecond(2.0);
    c
}

fn emulator_config(keepalive_timeout: Duration) -> AptEmulatorConfig {
    let mut c = AptEmulatorConfig::kst101(zfs25());
    c.keepalive = KeepAlive::Required {
        timeout: keepalive_timeout,
    };
    c
}

fn timed<T>(f: impl FnOnce() -> T) -> (T, f64) {
    let t0 = Instant::now();
    let r = f();
    (r, t0.elapsed().as_secs_f64())
}

#[test]
fn real_driver_connects_homes_and_moves_with_the_trapezoid_timing() {
    let m = motor(1.0);
    let (host, device) = byte_pair("apt-x", "apt-x-emulator");
    let emu = AptEmulator::spawn(
        emulator_config(Duration::from_secs(3)),
        m.clone(),
        Box::new(device),
    )
    .expect("spawn");
    let mut axis = ThorlabsAxis::connect(Box::new(host), driver_config())
        .expect("the driver's read-back of enable, velocity and home parameters passes");
    let info = axis.info().expect("HW_GET_INFO").clone();
    assert_eq!(info.model, "KST101");
    assert_eq!(info.serial_number, 26_000_001);
    // The velocity parameters reached the motor in mm/s.
    let k = m.kinematics();
    assert!((k.velocity.0 - 2.0).abs() < 1e-6, "{k:?}");
    assert!((k.acceleration.0 - 4.0).abs() < 1e-3, "{k:?}");

    // Homing over 1 mm at 2 mm/s and 4 mm/s^2 is a triangle peaking at 2 mm/s: 1 s.
    let (st, took) = timed(|| axis.home(Duration::from_secs(5)).expect("home"));
    assert!(st.homed && !st.moving, "{st}");
    assert!(st.position.0.abs() <= one_step(), "{st}");
    assert!((0.98..1.15).contains(&took), "homing took {took} s");
    assert!(m.true_position_at(HostTime::now()).0.abs() < 1e-9);

    // 3 mm: 0.5 s ramps of 0.5 mm each, 2 mm cruise in 1 s: 2 s in all.
    let (st, took) = timed(|| {
        axis.move_to(Millimetres(3.0), Duration::from_secs(5))
            .expect("move")
    });
    assert!(
        (st.position.0 - 3.0).abs() <= one_step(),
        "{st} vs 3 mm within one count"
    );
    assert!((1.98..2.15).contains(&took), "the 2 s move took {took} s");
    assert!((m.true_position_at(HostTime::now()).0 - 3.0).abs() <= one_step());

    // -1 mm: a triangle peaking at 2 mm/s, 1 s.
    let (st, took) = timed(|| {
        axis.move_by(Millimetres(-1.0), Duration::from_secs(5))
            .expect("move by")
    });
    assert!((st.position.0 - 2.0).abs() <= one_step(), "{st}");
    assert!((0.98..1.15).contains(&took), "the 1 s move took {took} s");
    let again = axis.status().expect("status");
    assert!((again.position.0 - 2.0).abs() <= one_step() && again.homed && !again.moving);
    drop(axis);
    let counters = emu.stop().expect("emulator ran without link errors");
    assert_eq!(counters.motions, 3);
    assert_eq!(counters.refused, 0);
}

/// Homing right after connecting, before the controller's first status update (which a K-Cube
/// sends up to one period after HW_START_UPDATEMSGS), at the documented 100 ms cadence with and
/// without jitter: the driver waits for the motion's end and reports the status after it.
#[test]
fn homing_before_the_first_status_update_ends_homed_and_idle_at_the_real_cadence() {
    for (jitter_ms, seed) in [(0, 1), (30, 7), (30, 99)] {
        let m = motor(0.4);
        let (host, device) = byte_pair("apt-x", "apt-x-emulator");
        let mut config = emulator_config(Duration::from_secs(3));
        config.update_jitter = Duration::from_millis(jitter_ms);
        config.jitter_seed = seed;
        let _emu = AptEmulator::spawn(config, m.clone(), Box::new(device)).expect("spawn");
        let mut axis = ThorlabsAxis::connect(Box::new(host), driver_config()).expect("connect");
        let st = axis
            .home(Duration::from_secs(5))
            .unwrap_or_else(|e| panic!("jitter {jitter_ms} ms: home: {e}"));
        assert!(
            st.homed && !st.moving,
            "jitter {jitter_ms} ms: the status after MOT_MOVE_HOMED: {st}"
        );
        let again = axis.status().expect("status");
        assert!(again.homed && !again.moving, "{again}");
        // A short move ends with the controller's own final status.
        let st = axis
            .move_to(Millimetres(0.2), Duration::from_secs(5))
            .expect("move");
        assert!(
            !st.moving && (st.position.0 - 0.2).abs() <= one_step(),
            "{st}"
        );
    }
}

#[test]
fn profiled_stop_brakes_and_immediate_stop_holds() {
    let m = motor(1.0);
    let (host, device) = byte_pair("apt-x", "apt-x-emulator");
    let _emu = AptEmulator::spawn(
        emulator_config(Duration::from_secs(3)),
        m.clone(),
        Box::new(device),
    )
    .expect("spawn");
    let mut axis = ThorlabsAxis::connect(Box::new(host), driver_config()).expect("connect");
    axis.begin_move_to(Millimetres(10.0)).expect("begin move");
    std::thread::sleep(Duration::from_millis(800));
    let before = m.status_at(HostTime::now());
    assert!(
        before.moving && (before.velocity.0 - 2.0).abs() < 1e-6,
        "{before:?}"
    );
    axis.stop(StopMode::Profiled).expect("stop");
    let (st, took) = timed(|| axis.wait_idle(Duration::from_secs(3)).expect("stopped"));
    // Braking from 2 mm/s at 4 mm/s^2 takes 0.5 s over 0.5 mm.
    let braked = st.position.0 - before.position.0;
    assert!((0.45..0.56).contains(&braked), "braked over {braked} mm");
    assert!((0.4..0.65).contains(&took), "profiled stop took {took} s");
    assert!(!st.moving);

    axis.begin_move_to(Millimetres(0.0))
        .expect("begin move back");
    std::thread::sleep(Duration::from_millis(700));
    let before = m.status_at(HostTime::now());
    axis.stop(StopMode::Immediate).expect("stop now");
    let (st, took) = timed(|| axis.wait_idle(Duration::from_secs(3)).expect("stopped"));
    assert!(took < 0.1, "immediate stop took {took} s");
    let drift = (st.position.0 - before.position.0).abs();
    assert!(
        drift < 0.05,
        "moved {drift} mm after an immediate stop at 2 mm/s"
    );
    assert!(!m.status_at(HostTime::now()).moving);
}

#[test]
fn updates_arrive_at_10_hz_and_continue_while_the_driver_sends_keepalives() {
    let m = motor(1.0);
    let (host, device) = byte_pair("apt-x", "apt-x-emulator");
    // A 1 s keep-alive timeout: 2.2 s of updates prove the driver's 0.9 s keep-alive works.
    let emu = AptEmulator::spawn(
        emulator_config(Duration::from_secs(1)),
        m.clone(),
        Box::new(device),
    )
    .expect("spawn");
    let mut axis = ThorlabsAxis::connect(Box::new(host), driver_config()).expect("connect");
    std::thread::sleep(Duration::from_millis(100));
    let start = emu.counters();
    std::thread::sleep(Duration::from_millis(2200));
    let end = emu.counters();
    let updates = end.status_updates - start.status_updates;
    assert!(
        (20..=24).contains(&updates),
        "{updates} update messages in 2.2 s"
    );
    assert!(end.keepalives >= 2, "{end:?}");
    assert_eq!(end.updates_lapsed, 0);
    assert!(emu.updates_running());
    let st = axis.status().expect("status from the update messages");
    assert!(!st.moving && !st.homed);
}

/// Reads packets from the device for `dur`, with their arrival times (s from `t0`).
fn collect(link: &mut dyn ByteLink, t0: Instant, dur: Duration) -> Vec<(f64, Packet)> {
    let mut d = StreamDecoder::new(Flow::FromDevice);
    let mut out = Vec::new();
    let mut buf = [0u8; 256];
    let end = Instant::now() + dur;
    while Instant::now() < end {
        let n = link
            .read(&mut buf, Duration::from_millis(10))
            .expect("read");
        d.push(&buf[..n]);
        while let Some(p) = d.next_packet() {
            out.push((t0.elapsed().as_secs_f64(), p));
        }
    }
    out
}

#[test]
fn withheld_keepalives_end_the_update_messages_and_bytes_may_split_or_merge() {
    let m = motor(1.0);
    let (mut host, device) = byte_pair("raw-host", "apt-x-emulator");
    let emu = AptEmulator::spawn(emulator_config(Duration::from_secs(1)), m, Box::new(device))
        .expect("spawn");
    let to = |m: Message| encode(&Packet::to_device(USB_UNIT, m));
    // Garbage, an unknown message (MOT_REQ_JOGPARAMS), then HW_REQ_INFO split across writes
    // and merged with HW_START_UPDATEMSGS.
    let mut stream = vec![0x00, 0xff, 0x13];
    stream.extend_from_slice(&[0x17, 0x04, 0x01, 0x00, 0x50, 0x01]);
    stream.extend(to(Message::HwReqInfo));
    stream.extend(to(Message::HwStartUpdateMsgs));
    let t0 = Instant::now();
    for chunk in stream.chunks(4) {
        host.write_all(chunk).expect("write");
    }
    let got = collect(&mut host, t0, Duration::from_millis(1800));
    assert!(
        matches!(&got[0].1.message, Message::HwGetInfo(i) if i.model == "KST101"),
        "{:?}",
        got[0]
    );
    let updates: Vec<f64> = got
        .iter()
        .filter(|(_, p)| matches!(p.message, Message::GetStatusUpdate(_)))
        .map(|(t, _)| *t)
        .collect();
    assert!(
        (9..=12).contains(&updates.len()),
        "updates in the 1 s before the keep-alive lapsed: {updates:?}"
    );
    let last = updates.last().copied().unwrap_or(0.0);
    assert!(
        (0.85..1.2).contains(&last),
        "the last update came at {last} s"
    );
    let c = emu.counters();
    assert_eq!(c.updates_lapsed, 1);
    assert!(!emu.updates_running());
    assert_eq!(c.unknown, 1, "{c:?}");
    assert!(c.dropped_bytes >= 3, "{c:?}");

    // Restarted, and acknowledged every 0.5 s, they keep coming.
    host.write_all(&to(Message::HwStartUpdateMsgs))
        .expect("restart");
    let t1 = Instant::now();
    let mut n = 0;
    for _ in 0..4 {
        host.write_all(&to(Message::AckUStatusUpdate)).expect("ack");
        n += collect(&mut host, t1, Duration::from_millis(500))
            .iter()
            .filter(|(_, p)| matches!(p.message, Message::GetStatusUpdate(_)))
            .count();
    }
    assert!(
        (19..=22).contains(&n),
        "{n} updates in 2 s with keep-alives"
    );
    assert!(emu.updates_running());

    // A disabled channel refuses to move, like the real one.
    host.write_all(&to(Message::SetChanEnableState {
        channel: 1,
        enable: false,
    }))
    .expect("disable");
    host.write_all(&to(Message::MoveRelative {
        channel: 1,
        distance: 100_000,
    }))
    .expect("move");
    let got = collect(&mut host, t1, Duration::from_millis(300));
    assert!(!got.iter().any(|(_, p)| matches!(
        p.message,
        Message::MoveCompleted { .. } | Message::MoveStopped { .. }
    )));
    assert_eq!(emu.counters().refused, 1);
}

#[test]
fn soft_limits_refuse_before_sending_and_the_hard_limit_is_a_fault() {
    let m = motor(0.5);
    let (host, device) = byte_pair("apt-x", "apt-x-emulator");
    let emu = AptEmulator::spawn(
        emulator_config(Duration::from_secs(3)),
        m.clone(),
        Box::new(device),
    )
    .expect("spawn");
    let mut config = driver_config();
    config.soft_limits = Some(SoftLimits {
        min: Millimetres(-1.0),
        max: Millimetres(5.0),
    });
    let mut axis = ThorlabsAxis::connect(Box::new(host), config).expect("connect");
    let err = axis
        .move_to(Millimetres(6.0), Duration::from_secs(2))
        .expect_err("past the soft limit");
    assert!(matches!(err, AxisError::SoftLimit { .. }), "{err}");
    std::thread::sleep(Duration::from_millis(50));
    assert_eq!(emu.counters().motions, 0, "nothing was sent");
    // -1 mm is inside the soft limits but 0.5 mm past the reverse limit switch.
    let err = axis
        .move_to(Millimetres(-1.0), Duration::from_secs(3))
        .expect_err("the carriage stops on the switch");
    let AxisError::Fault { flags, .. } = &err else {
        panic!("{err}")
    };
    assert!(flags.contains(&"reverse limit switch"), "{err}");
    assert!(m.true_position_at(HostTime::now()).0.abs() < 1e-9);
}

/// A move at a chosen speed (a slide) sets the controller's velocity parameters and reads them
/// back, runs the slower trapezoid, and the next move at the configured kinematics sets those
/// back first; a speed above the configured one is refused with nothing sent.
#[test]
fn a_move_at_a_chosen_speed_runs_at_it_and_the_next_move_at_the_configured_one() {
    let m = motor(1.0);
    let (host, device) = byte_pair("apt-x", "apt-x-emulator");
    let emu = AptEmulator::spawn(
        emulator_config(Duration::from_secs(3)),
        m.clone(),
        Box::new(device),
    )
    .expect("spawn");
    let mut axis = ThorlabsAxis::connect(Box::new(host), driver_config()).expect("connect");
    axis.home(Duration::from_secs(5)).expect("home");
    let slow = Kinematics {
        velocity: MillimetresPerSecond(0.5),
        acceleration: MillimetresPerSecondSquared(2.0),
    };
    // 1 mm at 0.5 mm/s, 2 mm/s^2: 0.25 s ramps of 0.0625 mm, 0.875 mm of cruise in 1.75 s:
    // 2.25 s.
    let (_, setting) = timed(|| {
        axis.begin_move_to_at(Millimetres(1.0), slow)
            .expect("the velocity parameters are set and read back")
    });
    let (st, took) = timed(|| axis.wait_idle(Duration::from_secs(5)).expect("slow move"));
    assert!((st.position.0 - 1.0).abs() <= one_step(), "{st}");
    assert!(
        (2.23..2.4).contains(&took),
        "the 2.25 s slow move took {took} s (sent after {setting} s)"
    );
    let k = m.kinematics();
    assert!((k.velocity.0 - 0.5).abs() < 1e-6, "{k:?}");
    // Back at the configured 2 mm/s, 4 mm/s^2: 0.5 mm is a triangle of 2 sqrt(0.5 / 4) s.
    let (st, took) = timed(|| {
        axis.move_to(Millimetres(0.5), Duration::from_secs(5))
            .expect("move at the configured kinematics")
    });
    assert!((st.position.0 - 0.5).abs() <= one_step(), "{st}");
    assert!(
        (0.69..0.85).contains(&took),
        "the 0.71 s move took {took} s"
    );
    assert!((m.kinematics().velocity.0 - 2.0).abs() < 1e-6);
    let motions = emu.counters().motions;
    let fast = Kinematics {
        velocity: MillimetresPerSecond(3.0),
        acceleration: MillimetresPerSecondSquared(4.0),
    };
    let err = axis
        .begin_move_to_at(Millimetres(1.0), fast)
        .expect_err("above the configured speed");
    assert!(matches!(err, AxisError::Motion { .. }), "{err}");
    assert!(
        err.to_string()
            .contains("exceed the configured 2.0000 mm/s"),
        "{err}"
    );
    std::thread::sleep(Duration::from_millis(50));
    assert_eq!(emu.counters().motions, motions, "nothing was sent");
    assert!((m.kinematics().velocity.0 - 2.0).abs() < 1e-6);
}

#[test]
fn real_driver_over_a_pseudo_terminal() {
    let m = motor(1.0);
    let emu = AptEmulator::spawn_pty(emulator_config(Duration::from_secs(3)), m.clone())
        .expect("spawn on a pty");
    let path = emu.slave_path().expect("a pty emulator has a slave path");
    assert!(path.starts_with("/dev/"), "{path}");
    let link = open_serial(path).expect("open the pty like a serial port");
    let mut axis = ThorlabsAxis::connect(Box::new(link), driver_config()).expect("connect");
    let st = axis
        .move_by(Millimetres(0.5), Duration::from_secs(3))
        .expect("move");
    assert!((st.position.0 - 0.5).abs() <= one_step(), "{st}");
    assert!((m.true_position_at(HostTime::now()).0 - 1.5).abs() <= one_step());
    drop(axis);
    let c = emu.stop().expect("no link error");
    assert_eq!(c.motions, 1);
}

#[test]
fn real_driver_polls_a_bsc203_bay() {
    let m = motor(1.0);
    let (host, device) = byte_pair("apt-y", "bsc203-bay1");
    let mut dc = driver_config();
    dc.controller = Controller::Bsc203;
    dc.bay = Some(1);
    let config = AptEmulatorConfig::matching(&dc).expect("bay 1 is a rack bay");
    assert_eq!(config.address, 0x22);
    let emu = AptEmulator::spawn(config, m, Box::new(device)).expect("spawn");
    let mut axis = ThorlabsAxis::connect(Box::new(host), dc).expect("connect to bay 1");
    assert_eq!(axis.info().map(|i| i.model.as_str()), Some("BSC203"));
    let st = axis
        .move_to(Millimetres(-0.25), Duration::from_secs(3))
        .expect("move");
    assert!((st.position.0 + 0.25).abs() <= one_step(), "{st}");
    assert_eq!(emu.counters().status_updates, 0, "a polled controller");
}

#[test]
fn thorlabs_apt_device_from_pypi_drives_the_emulator_on_a_pty() {
    let m = motor(0.5);
    let emu = AptEmulator::spawn_pty(emulator_config(Duration::from_millis(1500)), m.clone())
        .expect("spawn on a pty");
    let path = emu.slave_path().expect("slave path").to_string();
    let a = zfs25();
    let target = a.to_steps(Millimetres(1.0)).expect("steps");
    let out = Command::new(python())
        .arg(python_script("apt_device_client.py"))
        .arg(&path)
        .arg(target.to_string())
        // 2 mm/s and 4 mm/s^2 in device units.
        .arg(
            a.velocity_to_device(MillimetresPerSecond(2.0))
                .expect("v")
                .to_string(),
        )
        .arg(
            a.acceleration_to_device(MillimetresPerSecondSquared(4.0))
                .expect("a")
                .to_string(),
        )
        .output()
        .unwrap_or_else(|e| {
            panic!(
                "cannot start {} ({e}); run scripts/test, which sets FRINGE_PYTHON",
                python()
            )
        });
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "the thorlabs-apt-device client failed ({}): {}\n{stdout}\nrun scripts/test to install \
         tests/python/requirements.txt (thorlabs-apt-device) into .venv\nemulator: {:?}",
        out.status,
        String::from_utf8_lossy(&out.stderr),
        emu.counters()
    );
    let field = |name: &str| -> String {
        stdout
            .lines()
            .find_map(|l| l.strip_prefix(&format!("{name}=")))
            .unwrap_or_else(|| panic!("no {name}= in the client's output:\n{stdout}"))
            .to_string()
    };
    assert_eq!(field("homed"), "True");
    assert_eq!(field("position"), target.to_string());
    assert_eq!(field("moving"), "False");
    assert_eq!(field("channel_enabled"), "True");
    let updates: u32 = field("updates").parse().expect("a count");
    // The client ran > 2.5 s with update messages and its own 0.9 s keep-alive.
    assert!(updates >= 20, "{updates} status updates seen by the client");
    let c = emu.stop().expect("no link error");
    assert_eq!(c.updates_lapsed, 0, "{c:?}");
    assert_eq!(c.identify, 1);
    assert!(c.unknown >= 2, "jog/general move parameter requests: {c:?}");
    assert!((m.true_position_at(HostTime::now()).0 - 1.0).abs() <= one_step());
}

/// Most of this test's time is pyLabLib's import (numpy, scipy, pandas): several seconds.
#[test]
fn pylablib_kinesis_motor_drives_the_emulator_on_a_pty() {
    let m = motor(0.5);
    let emu = AptEmulator::spawn_pty(emulator_config(Duration::from_secs(3)), m.clone())
        .expect("spawn on a pty");
    let path = emu.slave_path().expect("slave path").to_string();
    let target = zfs25().to_steps(Millimetres(0.25)).expect("steps");
    let out = Command::new(python())
        .arg(python_script("apt_pylablib_client.py"))
        .arg(&path)
        .arg(target.to_string())
        .output()
        .unwrap_or_else(|e| {
            panic!(
                "cannot start {} ({e}); run scripts/test, which sets FRINGE_PYTHON",
                python()
            )
        });
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "the pylablib client failed ({}): {}\n{stdout}\nrun scripts/test to install \
         tests/python/requirements.txt (pylablib) into .venv\nemulator: {:?}",
        out.status,
        String::from_utf8_lossy(&out.stderr),
        emu.counters()
    );
    let field = |name: &str| -> String {
        stdout
            .lines()
            .find_map(|l| l.strip_prefix(&format!("{name}=")))
            .unwrap_or_else(|| panic!("no {name}= in the client's output:\n{stdout}"))
            .to_string()
    };
    assert_eq!(field("model"), "KST101");
    assert_eq!(field("homed"), "True");
    assert_eq!(field("position"), target.to_string());
    let status = field("status");
    assert!(
        status.contains("enabled") && status.contains("homed") && !status.contains("moving"),
        "{status}"
    );
    assert!((m.true_position_at(HostTime::now()).0 - 0.25).abs() <= one_step());
    let c = emu.stop().expect("no link error");
    assert_eq!(c.motions, 2, "{c:?}");
}

/// Two stops in a row (a watcher's, then the cleanup's) are acknowledged twice; the second,
/// late MOT_MOVE_STOPPED must not end the next move as a fault (seen in the scan's retract).
#[test]
fn a_late_stop_acknowledgement_does_not_fail_the_next_move() {
    let m = motor(1.0);
    let (host, device) = byte_pair("apt-x", "apt-x-emulator");
    let _emu = AptEmulator::spawn(
        emulator_config(Duration::from_secs(3)),
        m.clone(),
        Box::new(device),
    )
    .expect("spawn");
    let mut axis = ThorlabsAxis::connect(Box::new(host), driver_config()).expect("connect");
    for round in 0..3 {
        axis.begin_move_to(Millimetres(8.0)).expect("begin move");
        std::thread::sleep(Duration::from_millis(300));
        axis.stop(StopMode::Immediate).expect("first stop");
        // The first acknowledgement is on its way when the second stop goes out.
        std::thread::sleep(Duration::from_millis(150));
        axis.stop(StopMode::Immediate).expect("second stop");
        let st = axis
            .move_to(Millimetres(2.0), Duration::from_secs(10))
            .unwrap_or_else(|e| panic!("round {round}: the move after two stops failed: {e}"));
        assert!((st.position.0 - 2.0).abs() < 2.0 * one_step(), "{st:?}");
    }
}
