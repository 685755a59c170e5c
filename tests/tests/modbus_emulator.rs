//! The emulated Modbus y stage (fringe_sim::ModbusEmulator) against the real ModbusStage
//! driver over Modbus TCP, Modbus RTU on a pseudo-terminal and in process, and against an
//! independent client from PyPI (pymodbus, driven by tests/python/modbus_client.py).

use fringe_tests::{loopback, python, python_script, require_python_module};

use fringe_rig::ByteLink;
use fringe_rig::Kinematics;
use fringe_rig::SerialLink;
use fringe_rig::TcpLink;
use fringe_rig::{Axis, AxisError, SoftLimits, StopMode};
use fringe_rig::{Framing, ModbusStage, RegisterMap, StageOptions};
use fringe_rig::{Millimetres, MillimetresPerSecond, MillimetresPerSecondSquared};
use fringe_sim::ModbusEmulator;
use fringe_sim::{MotorSpec, SimMotor};
use std::process::Command;
use std::sync::Arc;
use std::time::{Duration, Instant};

fn motor(power_up_mm: f64) -> Arc<SimMotor> {
    Arc::new(SimMotor::new(MotorSpec {
        name: "y".into(),
        travel: Millimetres(50.0),
        power_up_position: Millimetres(power_up_mm),
        kinematics: Kinematics {
            velocity: MillimetresPerSecond(5.0),
            acceleration: MillimetresPerSecondSquared(50.0),
        },
    }))
}

fn map(name: &str) -> RegisterMap {
    RegisterMap::load(name).expect("built-in map")
}

fn options() -> StageOptions {
    StageOptions {
        response_timeout: Duration::from_secs(1),
        poll_interval: Duration::from_millis(20),
        limits: Some(SoftLimits {
            min: Millimetres(-10.0),
            max: Millimetres(20.0),
        }),
        ..StageOptions::default()
    }
}

fn stage(link: Box<dyn ByteLink>, framing: Framing, map_name: &str) -> ModbusStage {
    ModbusStage::new("y", link, framing, map(map_name), options())
}

/// Absolute and relative moves end exactly on target (one step is 1/200 or 1/2000 mm), the
/// motor really moved, and soft limits stop a move before anything is sent.
fn moves_and_limits(y: &mut ModbusStage, emulator: &ModbusEmulator, steps_per_mm: f64) {
    let step = 1.0 / steps_per_mm;
    let t0 = Instant::now();
    let s = y
        .move_to(Millimetres(2.5), Duration::from_secs(5))
        .expect("move");
    // 2.5 mm at 5 mm/s with 50 mm/s^2 ramps: 0.6 s.
    assert!(
        t0.elapsed() >= Duration::from_millis(500),
        "{:?}",
        t0.elapsed()
    );
    assert!((s.position.0 - 2.5).abs() <= step, "{s}");
    assert!(!s.moving);
    let truth = emulator.motor().status_at(fringe_rig::HostTime::now());
    assert!((truth.position.0 - 2.5).abs() < 1e-9, "{truth:?}");
    let s = y
        .move_by(Millimetres(-1.0), Duration::from_secs(5))
        .expect("relative");
    assert!((s.position.0 - 1.5).abs() <= step, "{s}");
    assert!((y.status().expect("status").position.0 - 1.5).abs() <= step);
    let requests = emulator.requests();
    assert!(matches!(
        y.begin_move_to(Millimetres(25.0)),
        Err(AxisError::SoftLimit { .. })
    ));
    assert_eq!(
        emulator.requests(),
        requests,
        "nothing sent past a soft limit"
    );
}

#[test]
fn driver_over_modbus_tcp_with_two_clients() {
    let emulator =
        ModbusEmulator::spawn_tcp(loopback(), map("oriental-az"), motor(10.0)).expect("emulator");
    let addr = emulator.addr().expect("tcp").to_string();
    let link = TcpLink::connect(&addr, Duration::from_secs(1)).expect("connect");
    let mut y = stage(Box::new(link), Framing::Tcp, "oriental-az");
    moves_and_limits(&mut y, &emulator, 200.0);

    // A second client watches the first one's move.
    let watcher = TcpLink::connect(&addr, Duration::from_secs(1)).expect("connect");
    let mut w = stage(Box::new(watcher), Framing::Tcp, "oriental-az");
    y.begin_move_to(Millimetres(0.0)).expect("start");
    std::thread::sleep(Duration::from_millis(100));
    let seen = w.status().expect("watch");
    assert!(seen.moving && seen.flags.contains(&"MOVE"), "{seen}");
    let s = y.wait_idle(Duration::from_secs(5)).expect("done");
    assert_eq!(s.position, Millimetres(0.0));
    assert_eq!(w.status().expect("watch").position, Millimetres(0.0));

    // The AZ map has no stop value: the driver says so instead of sending anything.
    let err = y.stop(StopMode::Profiled).expect_err("no stop register");
    assert!(err.to_string().contains("defines no stop value"), "{err}");

    // A drive alarm surfaces as a fault naming the map's alarm bit.
    emulator.set_alarm(true);
    let err = y
        .move_to(Millimetres(1.0), Duration::from_secs(2))
        .expect_err("alarm");
    assert!(
        matches!(&err, AxisError::Fault { flags, .. } if flags.contains(&"ALM-A (alarm)")),
        "{err}"
    );
    emulator.clear_alarm();
    y.move_to(Millimetres(1.0), Duration::from_secs(5))
        .expect("after reset");

    // A driver whose map names a register the drive lacks gets the drive's exception.
    let mut wrong = map("oriental-az");
    wrong.registers.feedback_position = 0x0300;
    let link = TcpLink::connect(&addr, Duration::from_secs(1)).expect("connect");
    let mut bad = ModbusStage::new("y", Box::new(link), Framing::Tcp, wrong, options());
    let err = bad.status().expect_err("exception");
    assert!(err.to_string().contains("illegal data address"), "{err}");
}

/// A move at a chosen speed (a slide) writes that speed and acceleration with the move, which
/// the drive runs; the next move writes the map's profile again; a speed above the profile's is
/// refused with nothing sent.
#[test]
fn a_move_at_a_chosen_speed_writes_it_and_the_next_move_the_maps_profile() {
    let emulator =
        ModbusEmulator::spawn_tcp(loopback(), map("oriental-az"), motor(10.0)).expect("emulator");
    let addr = emulator.addr().expect("tcp").to_string();
    let link = TcpLink::connect(&addr, Duration::from_secs(1)).expect("connect");
    let mut y = stage(Box::new(link), Framing::Tcp, "oriental-az");
    let slow = Kinematics {
        velocity: MillimetresPerSecond(1.0),
        acceleration: MillimetresPerSecondSquared(10.0),
    };
    let from = y.status().expect("status").position.0;
    let t0 = Instant::now();
    y.begin_move_to_at(Millimetres(from + 1.0), slow)
        .expect("a speed within the profile");
    let k = emulator.motor().kinematics();
    assert!((k.velocity.0 - 1.0).abs() < 1e-9, "{k:?}");
    assert!((k.acceleration.0 - 10.0).abs() < 1e-9, "{k:?}");
    let s = y.wait_idle(Duration::from_secs(5)).expect("slow move");
    // 1 mm at 1 mm/s with 10 mm/s^2 ramps: 1.1 s (5 mm/s would take 0.3 s).
    let took = t0.elapsed().as_secs_f64();
    assert!((1.08..1.4).contains(&took), "the 1.1 s move took {took} s");
    assert!((s.position.0 - (from + 1.0)).abs() <= 1.0 / 200.0, "{s}");
    y.move_to(Millimetres(from), Duration::from_secs(5))
        .expect("back at the profile's speed");
    let k = emulator.motor().kinematics();
    assert!((k.velocity.0 - 5.0).abs() < 1e-9, "{k:?}");
    let requests = emulator.requests();
    let fast = Kinematics {
        velocity: MillimetresPerSecond(6.0),
        acceleration: MillimetresPerSecondSquared(10.0),
    };
    let err = y
        .begin_move_to_at(Millimetres(from + 1.0), fast)
        .expect_err("faster than the profile");
    assert!(matches!(err, AxisError::Motion { .. }), "{err}");
    assert_eq!(emulator.requests(), requests, "nothing sent");
}

#[test]
fn driver_over_modbus_rtu_on_a_pseudo_terminal() {
    let m = map("leadshine-pr");
    let emulator = ModbusEmulator::spawn_rtu_pty(m.clone(), motor(1.0)).expect("emulator");
    let path = emulator.pty_path().expect("pty").to_string();
    // A driver addressing another slave id gets silence, as on a real RS-485 bus.
    let other = SerialLink::open(&path, &m.serial_settings(None)).expect("open pty");
    let mut wrong = ModbusStage::new(
        "y",
        Box::new(other),
        Framing::Rtu,
        m.clone(),
        StageOptions {
            slave: Some(7),
            response_timeout: Duration::from_millis(200),
            ..options()
        },
    );
    assert!(matches!(
        wrong.status(),
        Err(AxisError::NotAnswering { .. })
    ));
    drop(wrong);
    let link = SerialLink::open(&path, &m.serial_settings(None)).expect("open pty");
    let mut y = stage(Box::new(link), Framing::Rtu, "leadshine-pr");

    // Homing runs to the reverse switch 1 mm away and zeroes the counter.
    let s = y.home(Duration::from_secs(5)).expect("home");
    assert!(s.homed && s.flags.contains(&"homing completed"), "{s}");
    assert_eq!(s.position, Millimetres(0.0));
    moves_and_limits(&mut y, &emulator, 2000.0);

    // An emergency stop mid-move leaves the stage between start and target.
    y.begin_move_to(Millimetres(15.0)).expect("start");
    std::thread::sleep(Duration::from_millis(400));
    y.stop(StopMode::Immediate).expect("stop");
    let s = y.wait_idle(Duration::from_secs(2)).expect("stopped");
    assert!(
        !s.moving && s.position.0 > 1.6 && s.position.0 < 14.0,
        "{s}"
    );
    // The driver kept the silent interval before every request: the drive dropped none.
    assert_eq!(emulator.frames_too_soon(), 0);
}

/// The emulated drive keeps the documented RTU timing: the reply comes a turnaround after the
/// request plus both frames' time on the wire, and a request sent within the silent interval
/// after a reply is dropped, as an RS-485 drive drops it; after a silence the drive answers again.
#[test]
fn the_rtu_drive_keeps_the_documented_timing_and_drops_a_frame_sent_too_soon() {
    let m = map("leadshine-pr");
    let emulator = ModbusEmulator::spawn_rtu_pty(m.clone(), motor(1.0)).expect("emulator");
    let timing = emulator.rtu_timing();
    assert_eq!(timing.baud, 38_400);
    assert_eq!(timing.turnaround, Duration::from_micros(1_160));
    let path = emulator.pty_path().expect("pty").to_string();
    let mut link = SerialLink::open(&path, &m.serial_settings(None)).expect("open pty");
    // Read the two feedback registers (0x602A, 0x602B): 8 bytes out, 9 back.
    let request = fringe_rig::modbus::rtu_frame(1, &[0x03, 0x60, 0x2A, 0x00, 0x02]);
    let exchange = |link: &mut SerialLink| -> (Vec<u8>, Duration) {
        let sent = Instant::now();
        link.write_all(&request).expect("write");
        let mut reply = Vec::new();
        let mut buf = [0u8; 64];
        while reply.len() < 9 && sent.elapsed() < Duration::from_millis(300) {
            let n = link
                .read(&mut buf, Duration::from_millis(20))
                .expect("read");
            reply.extend_from_slice(&buf[..n]);
        }
        (reply, sent.elapsed())
    };
    let (reply, took) = exchange(&mut link);
    assert_eq!(reply.len(), 9, "{reply:?}");
    // 2.29 ms + 1.16 ms + 2.58 ms at 38400 baud.
    assert!(took >= Duration::from_micros(6_000), "{took:?}");
    // The next request at once, inside the 1.75 ms silent interval: no answer. (A test thread
    // that loses its core for longer than the interval sends in time: try again after a pause.)
    let mut dropped = 0;
    for _ in 0..5 {
        std::thread::sleep(Duration::from_millis(20));
        let (reply, _) = exchange(&mut link);
        assert_eq!(
            reply.len(),
            9,
            "after a silence the drive answers: {reply:?}"
        );
        let (reply, _) = exchange(&mut link);
        if reply.is_empty() {
            dropped += 1;
            break;
        }
        assert_eq!(reply.len(), 9, "{reply:?}");
    }
    assert_eq!(
        dropped, 1,
        "a request sent at once after a reply was answered 5 times"
    );
    assert_eq!(emulator.frames_too_soon(), 1);
    // After a silence the drive takes frames again.
    std::thread::sleep(Duration::from_millis(20));
    let (reply, _) = exchange(&mut link);
    assert_eq!(reply.len(), 9, "{reply:?}");
    assert_eq!(emulator.frames_too_soon(), 1);
}

#[test]
fn driver_in_process_both_framings_and_overtravel_alarm() {
    for framing in [Framing::Tcp, Framing::Rtu] {
        let (emulator, link) =
            ModbusEmulator::spawn_in_process(map("leadshine-pr"), motor(10.0), framing)
                .expect("emulator");
        let mut y = stage(Box::new(link), framing, "leadshine-pr");
        moves_and_limits(&mut y, &emulator, 2000.0);
        drop(y);
        assert_eq!(emulator.frames_too_soon(), 0, "{framing}");
    }

    // Past the end of travel: the carriage stops on the limit switch and the drive alarms.
    let (emulator, link) =
        ModbusEmulator::spawn_in_process(map("oriental-az"), motor(48.0), Framing::Tcp)
            .expect("emulator");
    let mut y = stage(Box::new(link), Framing::Tcp, "oriental-az");
    let err = y
        .move_to(Millimetres(5.0), Duration::from_secs(5))
        .expect_err("over-travel");
    assert!(matches!(err, AxisError::Fault { .. }), "{err}");
    let truth = emulator.motor().status_at(fringe_rig::HostTime::now());
    assert!(
        truth.forward_limit && (truth.position.0 - 2.0).abs() < 1e-9,
        "{truth:?}"
    );
}

#[test]
fn pymodbus_from_pypi_moves_the_tcp_emulator() {
    require_python_module("pymodbus");
    let motor = motor(10.0);
    let emulator =
        ModbusEmulator::spawn_tcp(loopback(), map("oriental-az"), motor.clone()).expect("emulator");
    let port = emulator.addr().expect("tcp").port();
    let script = python_script("modbus_client.py");
    let out = Command::new(python())
        .arg(&script)
        .arg(port.to_string())
        .output()
        .expect("run modbus_client.py");
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        out.status.success(),
        "pymodbus client failed:\n{stdout}\n{stderr}"
    );
    let has = |s: &str| assert!(stdout.contains(s), "`{s}` not in:\n{stdout}\n{stderr}");
    has("{\"step\": \"start\", \"position\": 0}");
    has("{\"step\": \"moved\", \"position\": 500, \"status\": 32,");
    has("{\"step\": \"input\", \"position\": 500}");
    has("{\"step\": \"missing\", \"exception\": 2}");
    let polls = stdout
        .split("\"polls_moving\": ")
        .nth(1)
        .and_then(|r| r.split('}').next())
        .and_then(|n| n.trim().parse::<u32>().ok())
        .expect("polls_moving");
    assert!(polls >= 5, "the move takes 0.6 s: {polls} polls saw MOVE");
    let truth = motor.status_at(fringe_rig::HostTime::now());
    assert!((truth.position.0 - 2.5).abs() < 1e-9, "{truth:?}");
}
