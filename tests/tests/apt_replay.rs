//! Replays hand-built APT traces (tests/traces/apt/*.trace) through `ThorlabsAxis`.

use fringe_rig::{apt::Timeouts, AptConfig, Controller};
use fringe_rig::{
    apt::{Actuator, LimitPolarity},
    ThorlabsAxis,
};
use fringe_rig::{Axis, AxisError, SoftLimits, StopMode};
use fringe_rig::{Millimetres, MillimetresPerSecond, MillimetresPerSecondSquared};
use fringe_rig::{ReplayHandle, ReplayLink, ReplayOptions, Trace};
use std::time::{Duration, Instant};

const ZFS: f64 = 24.0 * 2048.0 * 400.0 / 9.0;

fn fast() -> ReplayOptions {
    ReplayOptions {
        speed: f64::INFINITY,
    }
}

fn replay(name: &str, options: ReplayOptions) -> (ReplayLink, ReplayHandle) {
    let path = format!("{}/traces/apt/{name}", env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(&path).expect("trace file");
    let trace = Trace::parse(&text, name).expect("trace parses");
    ReplayLink::new(trace, options)
}

/// The K-Cube configuration every KST101 trace was built for: ZFS25, 1 mm/s, 1 mm/s^2, homing
/// in reverse at 1 mm/s, soft limits 0..25 mm.
fn kcube() -> AptConfig {
    let mut c = AptConfig::new(
        "x",
        Controller::Kst101,
        Actuator::by_name("ZFS25").expect("ZFS25"),
    );
    c.soft_limits = Some(SoftLimits {
        min: Millimetres(0.0),
        max: Millimetres(25.0),
    });
    c.timeouts = Timeouts {
        reply: Duration::from_millis(500),
        ..Timeouts::default()
    };
    c
}

fn connect(name: &str, config: AptConfig, options: ReplayOptions) -> (ThorlabsAxis, ReplayHandle) {
    let (link, handle) = replay(name, options);
    match ThorlabsAxis::connect(Box::new(link), config) {
        Ok(axis) => (axis, handle),
        Err(e) => panic!("connect failed: {e}\nreplay: {:?}", handle.finish()),
    }
}

fn close(axis: ThorlabsAxis, handle: ReplayHandle) -> fringe_rig::ReplayReport {
    drop(axis);
    handle
        .finish()
        .unwrap_or_else(|e| panic!("replay mismatch: {e}"))
}

fn near(a: Millimetres, b: f64) -> bool {
    (a.0 - b).abs() < 1e-6
}

const WAIT: Duration = Duration::from_secs(3);

#[test]
fn connect_identifies_enables_sets_and_reads_back_parameters() {
    let (mut axis, handle) = connect("connect.trace", kcube(), fast());
    let info = axis.info().expect("HW_GET_INFO was read").clone();
    assert_eq!(info.model, "KST101");
    assert_eq!(info.serial_number, 26_000_001);
    assert_eq!(info.firmware_version(), "1.0.4");
    assert_eq!(info.channels, 1);
    let status = axis.status().expect("status from the first update message");
    assert!(near(status.position, 1.0), "{status}");
    assert!(status.homed);
    assert!(!status.moving);
    assert!(status.flags.contains(&"channel enabled") && status.flags.contains(&"settled"));
    assert!(status.faults.is_empty(), "{:?}", status.faults);
    let report = close(axis, handle);
    assert_eq!(report.unread_replies, 0);
}

#[test]
fn a_velocity_read_back_mismatch_refuses_the_connection() {
    let (link, handle) = replay("connect_mismatch.trace", fast());
    let err = match ThorlabsAxis::connect(Box::new(link), kcube()) {
        Ok(_) => panic!("a mismatch must refuse the connection"),
        Err(e) => e,
    };
    assert!(matches!(err, AxisError::Mismatch { .. }), "{err}");
    let text = err.to_string();
    assert!(
        text.contains("axis x (replay of connect_mismatch.trace)"),
        "{text}"
    );
    assert!(text.contains("acceleration: expected 24032"), "{text}");
    assert!(text.contains("read back 24000"), "{text}");
    assert!(
        !text.contains("max velocity"),
        "only the differing field is named: {text}"
    );
    handle.finish().expect("nothing sent after the mismatch");
}

#[test]
fn a_home_parameter_mismatch_refuses_the_connection() {
    let (link, handle) = replay("connect_home_mismatch.trace", fast());
    let err = match ThorlabsAxis::connect(Box::new(link), kcube()) {
        Ok(_) => panic!("a mismatch must refuse the connection"),
        Err(e) => e,
    };
    let text = err.to_string();
    assert!(
        text.contains("home direction: expected 2, read back 0"),
        "{text}"
    );
    assert!(
        text.contains("home limit switch: expected 1, read back 0"),
        "{text}"
    );
    assert!(!text.contains("home velocity"), "{text}");
    handle.finish().expect("nothing sent after the mismatch");
}

#[test]
fn homing_waits_for_move_homed() {
    let (mut axis, handle) = connect("home.trace", kcube(), fast());
    let status = axis.home(WAIT).expect("homed");
    assert!(near(status.position, 0.0), "{status}");
    assert!(status.homed);
    close(axis, handle);
}

#[test]
fn absolute_and_relative_moves_in_millimetres() {
    let (mut axis, handle) = connect("moves.trace", kcube(), fast());
    let s = axis.move_to(Millimetres(5.0), WAIT).expect("absolute move");
    assert!(near(s.position, 10_922_667.0 / ZFS), "{s}");
    assert!(!s.moving);
    let s = axis
        .move_by(Millimetres(-1.5), WAIT)
        .expect("relative move");
    assert!((s.position.0 - 3.5).abs() < 1e-6, "{s}");
    let report = close(axis, handle);
    assert_eq!(report.unread_replies, 0);
}

#[test]
fn profiled_and_immediate_stops() {
    let (mut axis, handle) = connect("stop.trace", kcube(), fast());
    axis.begin_move_to(Millimetres(20.0)).expect("move starts");
    axis.stop(StopMode::Profiled).expect("stop sent");
    let s = axis.wait_idle(WAIT).expect("MOVE_STOPPED ends the wait");
    assert!((s.position.0 - 1.25).abs() < 1e-6, "{s}");
    axis.begin_move_to(Millimetres(10.0)).expect("move starts");
    axis.stop(StopMode::Immediate).expect("stop sent");
    let s = axis
        .wait_idle(WAIT)
        .expect("short MOVE_STOPPED ends the wait");
    assert!((s.position.0 - 2.1).abs() < 1e-6, "{s}");
    close(axis, handle);
}

#[test]
fn keep_alive_is_sent_at_least_once_a_second_while_updates_run() {
    // Paced replay: the 25 update messages arrive at 10 Hz over 2.5 s after HW_START_UPDATEMSGS.
    let start = Instant::now();
    let (mut axis, handle) = connect("keepalive.trace", kcube(), ReplayOptions::default());
    let connected = start.elapsed();
    let mut last = Millimetres(-1.0);
    while start.elapsed() < connected + Duration::from_millis(2700) {
        let s = axis.status().expect("status");
        assert!(
            s.position >= last,
            "positions go forward: {} then {}",
            last,
            s.position
        );
        last = s.position;
        std::thread::sleep(Duration::from_millis(50));
    }
    assert!(
        (last.0 - 2.5).abs() < 1e-6,
        "the last update (2.5 mm) was seen: {last}"
    );
    let report = close(axis, handle);
    let times: Vec<Duration> = report
        .unordered_sent
        .iter()
        .inspect(|(bytes, _)| assert_eq!(bytes, &vec![0x92, 0x04, 0x00, 0x00, 0x50, 0x01]))
        .map(|(_, t)| *t)
        .collect();
    assert!(times.len() >= 2, "keep-alives sent at {times:?}");
    assert!(
        times[0] <= connected + Duration::from_secs(1),
        "first keep-alive at {:?}",
        times[0]
    );
    for w in times.windows(2) {
        assert!(
            w[1] - w[0] <= Duration::from_secs(1),
            "gap {:?} in {times:?}",
            w[1] - w[0]
        );
    }
    let tail = report.elapsed - *times.last().expect("at least one");
    assert!(
        tail <= Duration::from_millis(1050),
        "no keep-alive for {tail:?} before the end"
    );
}

#[test]
fn error_bits_end_the_move_with_an_error_naming_them() {
    let (mut axis, handle) = connect("error_bits.trace", kcube(), fast());
    let err = axis
        .move_to(Millimetres(24.0), WAIT)
        .expect_err("motion error");
    assert!(matches!(err, AxisError::Fault { .. }), "{err}");
    let text = err.to_string();
    assert!(
        text.contains("axis x (replay of error_bits.trace)"),
        "{text}"
    );
    assert!(text.contains("motion error"), "{text}");
    assert!(text.contains("forward limit switch"), "{text}");
    assert!(
        !text.contains("0x"),
        "bits are named, not printed in hex: {text}"
    );
    close(axis, handle);

    let mut config = kcube();
    config.limit_polarity = LimitPolarity::Bit0Reverse;
    let (mut axis, handle) = connect("error_bits.trace", config, fast());
    let text = axis
        .move_to(Millimetres(24.0), WAIT)
        .expect_err("motion error")
        .to_string();
    assert!(
        text.contains("reverse limit switch"),
        "bit 0 named by the configured polarity: {text}"
    );
    close(axis, handle);
}

#[test]
fn a_move_stopped_on_a_limit_switch_is_an_error() {
    let (mut axis, handle) = connect("limit_stop.trace", kcube(), fast());
    let text = axis
        .move_to(Millimetres(0.0), WAIT)
        .expect_err("limit")
        .to_string();
    assert!(text.contains("reverse limit switch"), "{text}");
    assert!(text.contains("moving to 0.0000 mm"), "{text}");
    close(axis, handle);
}

#[test]
fn a_lost_move_completed_times_out_with_the_status_bits() {
    let (mut axis, handle) = connect("lost_completed.trace", kcube(), fast());
    let t0 = Instant::now();
    let err = axis
        .move_to(Millimetres(5.0), Duration::from_millis(300))
        .expect_err("timeout");
    assert!(t0.elapsed() < Duration::from_secs(2));
    assert!(matches!(err, AxisError::Timeout { .. }), "{err}");
    let text = err.to_string();
    assert!(text.contains("MOT_MOVE_COMPLETED"), "{text}");
    assert!(text.contains("moving forward"), "{text}");
    assert!(
        text.contains("axis x (replay of lost_completed.trace)"),
        "{text}"
    );
    close(axis, handle);
}

#[test]
fn corrupted_bytes_between_messages_are_skipped() {
    let (mut axis, handle) = connect("corrupted.trace", kcube(), fast());
    let s = axis
        .move_to(Millimetres(5.0), WAIT)
        .expect("move completes despite garbage");
    assert!(near(s.position, 10_922_667.0 / ZFS), "{s}");
    let report = close(axis, handle);
    assert_eq!(report.unread_replies, 0);
}

#[test]
fn bsc203_bay_is_polled_and_sends_the_public_velparams_frame() {
    let drv = Actuator::by_name("DRV250").expect("DRV250");
    let mut config = AptConfig::new("z", Controller::Bsc203, drv);
    config.bay = Some(1);
    config.velocity = MillimetresPerSecond(13_421_773.0 / (409_600.0 * 53.68));
    config.acceleration = MillimetresPerSecondSquared(13_744.0 / (409_600.0 * 53.68 * 204.94e-6));
    config.timeouts = Timeouts {
        reply: Duration::from_millis(500),
        poll_period: Duration::from_millis(20),
        ..Timeouts::default()
    };
    let (mut axis, handle) = connect("bsc_poll.trace", config, fast());
    assert_eq!(axis.info().map(|i| i.model.as_str()), Some("BSC203"));
    let s = axis.status().expect("polled status (28-byte reply)");
    assert!(near(s.position, 1.0), "{s}");
    let s = axis.move_to(Millimetres(2.0), WAIT).expect("polled move");
    assert!(near(s.position, 2.0), "{s}");
    assert!(s.flags.contains(&"settled"));
    let report = close(axis, handle);
    assert_eq!(report.unread_replies, 0);
    assert!(
        report.unordered_sent.is_empty(),
        "no keep-alive on a BSC20x"
    );
}

#[test]
fn soft_limits_refuse_moves_before_anything_is_sent() {
    let (mut axis, handle) = connect("connect.trace", kcube(), fast());
    for target in [30.0, -0.5, f64::NAN] {
        let err = axis
            .begin_move_to(Millimetres(target))
            .expect_err("outside the soft limits");
        assert!(
            matches!(
                err,
                AxisError::SoftLimit { .. } | AxisError::NotANumber { .. }
            ),
            "{err}"
        );
        assert!(err.to_string().contains("nothing was sent"), "{err}");
    }
    let err = axis
        .begin_move_by(Millimetres(24.5))
        .expect_err("1 mm + 24.5 mm is past 25 mm");
    assert!(err.to_string().contains("target 25.5000 mm"), "{err}");
    // The replay fails on any byte beyond the trace, so a clean finish proves nothing was sent.
    close(axis, handle);
}

#[test]
fn public_example_frames_identify_move_and_complete() {
    let (mut axis, handle) = connect("public_examples.trace", kcube(), fast());
    axis.identify().expect("MOD_IDENTIFY");
    let s = axis
        .move_to(Millimetres(27_306_600.0 / ZFS), WAIT)
        .expect("PnPQ MOVE_COMPLETED");
    assert!(near(s.position, 27_306_600.0 / ZFS), "{s}");
    assert!(
        (s.position.0 - 12.5).abs() < 1e-4,
        "about 12.5 mm on a ZFS: {s}"
    );
    let s = axis
        .move_to(Millimetres(2048.0 / ZFS), WAIT)
        .expect("yaq move to 2048");
    assert!(near(s.position, 2048.0 / ZFS), "{s}");
    let report = close(axis, handle);
    assert_eq!(report.unread_replies, 0);
}

#[test]
fn a_fault_bit_from_before_the_move_does_not_fail_the_next_move() {
    // Paced: the first status after the move arrives 0.1 s after it, so the driver looks at the
    // old status (with its motion error) several times while waiting.
    let (mut axis, handle) = connect("stale_fault.trace", kcube(), ReplayOptions::default());
    let t0 = Instant::now();
    loop {
        let s = axis.status().expect("status");
        if near(s.position, 43_690_667.0 / ZFS) {
            assert!(s.faults.contains(&"motion error"), "{s}");
            break;
        }
        assert!(
            t0.elapsed() < Duration::from_secs(2),
            "the stale status never arrived"
        );
        std::thread::sleep(Duration::from_millis(5));
    }
    let s = axis
        .move_to(Millimetres(10.0), WAIT)
        .expect("a fresh status clears the old fault");
    assert!(near(s.position, 21_845_333.0 / ZFS), "{s}");
    assert!(s.faults.is_empty());
    close(axis, handle);
}

#[test]
fn a_controller_error_report_ends_the_wait_with_its_text() {
    let (mut axis, handle) = connect("rich_response.trace", kcube(), fast());
    let err = axis.home(WAIT).expect_err("the controller refused to home");
    let text = err.to_string();
    assert!(
        text.contains("axis x (replay of rich_response.trace)"),
        "{text}"
    );
    assert!(
        text.contains("error 10 about message 0x0443: Homing not possible: no stage connected"),
        "{text}"
    );
    close(axis, handle);
}
