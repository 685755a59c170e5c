//! The Modbus y stage driver replayed against hand-built traces (tests/traces/ystage/, made by
//! tests/python/make_ystage_traces.py): the driver must send exactly the recorded frames and
//! interpret the recorded replies.

use fringe_rig::Millimetres;
use fringe_rig::{Axis, AxisError, SoftLimits};
use fringe_rig::{Framing, ModbusStage, RegisterMap, StageOptions};
use fringe_rig::{ReplayHandle, ReplayLink, ReplayOptions, Trace};
use std::path::Path;
use std::time::Duration;

fn stage(trace: &str, map: &str, framing: Framing) -> (ModbusStage, ReplayHandle) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("traces/ystage")
        .join(trace);
    let trace = Trace::load(&path).expect("trace loads");
    let (link, handle) = ReplayLink::new(
        trace,
        ReplayOptions {
            speed: f64::INFINITY,
        },
    );
    let options = StageOptions {
        response_timeout: Duration::from_millis(200),
        poll_interval: Duration::from_millis(1),
        limits: Some(SoftLimits {
            min: Millimetres(-5.0),
            max: Millimetres(50.0),
        }),
        ..StageOptions::default()
    };
    let map = RegisterMap::load(map).expect("built-in map");
    (
        ModbusStage::new("y", Box::new(link), framing, map, options),
        handle,
    )
}

#[test]
fn oriental_az_absolute_move_over_tcp() {
    let (mut y, handle) = stage("az-tcp-move.trace", "oriental-az", Framing::Tcp);
    let status = y
        .move_to(Millimetres(2.5), Duration::from_secs(2))
        .expect("move succeeds");
    assert_eq!(status.position, Millimetres(2.5));
    assert!(!status.moving);
    assert_eq!(status.flags, vec!["READY", "IN-POS"]);
    let report = handle
        .finish()
        .expect("driver sent exactly the recorded frames");
    assert_eq!(report.unread_replies, 0);
}

#[test]
fn leadshine_relative_move_over_rtu() {
    let (mut y, handle) = stage("leadshine-rtu-move.trace", "leadshine-pr", Framing::Rtu);
    let status = y
        .move_by(Millimetres(0.5), Duration::from_secs(2))
        .expect("move succeeds");
    assert_eq!(status.position, Millimetres(1.5));
    assert!(
        status.flags.contains(&"path completed"),
        "{:?}",
        status.flags
    );
    assert!(status.faults.is_empty());
    handle
        .finish()
        .expect("driver sent exactly the recorded frames");
}

#[test]
fn alarm_bit_fails_the_move_naming_the_alarm() {
    let (mut y, handle) = stage("az-tcp-alarm.trace", "oriental-az", Framing::Tcp);
    let err = y
        .move_to(Millimetres(1.0), Duration::from_secs(2))
        .expect_err("alarm must fail the move");
    assert!(matches!(err, AxisError::Fault { .. }), "{err:?}");
    let msg = err.to_string();
    assert!(
        msg.contains("ALM-A (alarm)")
            && msg.contains("axis y")
            && msg.contains("moving to 1.0000 mm"),
        "{msg}"
    );
    handle
        .finish()
        .expect("driver sent exactly the recorded frames");
}

#[test]
fn exception_response_is_reported_with_its_meaning() {
    let (mut y, handle) = stage(
        "leadshine-rtu-exception.trace",
        "leadshine-pr",
        Framing::Rtu,
    );
    let err = y
        .begin_move_to(Millimetres(1.0))
        .expect_err("exception must fail the move");
    let msg = err.to_string();
    assert!(
        msg.contains("exception 0x02") && msg.contains("illegal data address"),
        "{msg}"
    );
    assert!(msg.contains("0x6200") && msg.contains("slave 1"), "{msg}");
    assert!(
        msg.contains("Modbus RTU over replay of"),
        "endpoint named: {msg}"
    );
    handle
        .finish()
        .expect("driver sent exactly the recorded frames");
}

#[test]
fn missing_reply_times_out_naming_the_request() {
    let (mut y, handle) = stage("az-tcp-timeout.trace", "oriental-az", Framing::Tcp);
    let started = std::time::Instant::now();
    let err = y.status().expect_err("no reply must time out");
    assert!(started.elapsed() >= Duration::from_millis(200));
    assert!(matches!(err, AxisError::NotAnswering { .. }), "{err:?}");
    let msg = err.to_string();
    assert!(
        msg.contains("no answer")
            && msg.contains("read holding registers 0x007E x2")
            && msg.contains("unit id"),
        "{msg}"
    );
    handle
        .finish()
        .expect("driver sent exactly the recorded frames");
}

#[test]
fn soft_limits_are_checked_before_anything_is_sent() {
    // The timeout trace expects only a status read; a refused move must send nothing at all.
    let (mut y, handle) = stage("az-tcp-timeout.trace", "oriental-az", Framing::Tcp);
    let err = y
        .begin_move_to(Millimetres(80.0))
        .expect_err("outside the limits");
    assert!(matches!(err, AxisError::SoftLimit { .. }), "{err:?}");
    assert!(!handle.all_sent());
    let msg = handle.finish().expect_err("nothing was sent").to_string();
    assert!(msg.contains("never sent"), "{msg}");
}

#[test]
fn homing_without_a_homing_operation_is_a_clear_error() {
    let (mut y, _handle) = stage("az-tcp-timeout.trace", "oriental-az", Framing::Tcp);
    let msg = y
        .begin_home()
        .expect_err("oriental-az defines no homing")
        .to_string();
    assert!(
        msg.contains("defines no homing operation") && msg.contains("[homing]"),
        "{msg}"
    );
}
