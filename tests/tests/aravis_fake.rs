//! The Aravis backend against the Aravis fake GigE Vision camera (`arv-fake-gv-camera-0.8`,
//! Debian package aravis-tools) on loopback. Run with `scripts/test aravis`.
#![cfg(feature = "aravis")]

use fringe_rig::{list_cameras, AravisCamera};
use fringe_rig::{Camera, CameraError, CameraSettings, PixelFormat, Roi, TriggerMode};
use fringe_rig::{Decibels, Hertz, Microseconds};
use std::process::{Child, Command, Stdio};
use std::sync::{Mutex, MutexGuard};
use std::time::{Duration, Instant};

const FAKE_ID: &str = "Aravis-Fake-GV01";
/// Opened by address: opened by id, Aravis may pick the route of another interface (e.g. eth0)
/// as the stream destination, and the fake on loopback cannot reach it.
const FAKE_ADDRESS: &str = "127.0.0.1";

/// The fake listens on the fixed GigE Vision port, so one test at a time.
static FAKE_LOCK: Mutex<()> = Mutex::new(());

/// A running fake camera process, killed on drop.
struct FakeGvCamera {
    child: Child,
    _lock: MutexGuard<'static, ()>,
}

impl FakeGvCamera {
    fn start() -> FakeGvCamera {
        let lock = FAKE_LOCK.lock().unwrap_or_else(|p| p.into_inner());
        let child = Command::new("arv-fake-gv-camera-0.8")
            .args(["-i", "127.0.0.1"])
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .expect(
                "arv-fake-gv-camera-0.8 not found: apt install aravis-tools (see scripts/test)",
            );
        FakeGvCamera { child, _lock: lock }
    }

    /// Opens the fake, retrying while it starts up.
    fn open(&self) -> AravisCamera {
        let deadline = Instant::now() + Duration::from_secs(5);
        loop {
            match AravisCamera::open(Some(FAKE_ADDRESS)) {
                Ok(cam) => return cam,
                Err(e) if Instant::now() > deadline => {
                    panic!("the fake camera did not come up: {e}")
                }
                Err(_) => std::thread::sleep(Duration::from_millis(100)),
            }
        }
    }
}

impl Drop for FakeGvCamera {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

fn settings(trigger: TriggerMode, rate: f64) -> CameraSettings {
    CameraSettings {
        exposure: Microseconds(1000.0),
        gain: Decibels(0.0),
        frame_rate: Hertz(rate),
        roi: Some(Roi {
            x: 0,
            y: 0,
            width: 64,
            height: 48,
        }),
        pixel_format: PixelFormat::Mono8,
        trigger,
        exposure_active_line: None,
    }
}

#[test]
fn aravis_lists_and_identifies_the_fake_camera() {
    let fake = FakeGvCamera::start();
    let cam = fake.open();
    let info = cam.info();
    assert_eq!(info.id, FAKE_ID);
    assert!(!info.model.is_empty(), "{info:?}");
    let listed = list_cameras().expect("list");
    assert!(listed.iter().any(|d| d.id == FAKE_ID), "{listed:?}");
}

#[test]
fn aravis_configure_reads_back_exposure_rate_and_roi() {
    let fake = FakeGvCamera::start();
    let mut cam = fake.open();
    let mut s = settings(TriggerMode::FreeRun, 20.0);
    s.exposure = Microseconds(3000.0);
    cam.configure(&s).expect("configure");
    let applied = cam.applied_settings().expect("applied").clone();
    assert!(
        (applied.exposure.value() - 3000.0).abs() < 1.0,
        "{applied:?}"
    );
    assert!(
        (applied.frame_rate.value() - 20.0).abs() < 0.01,
        "{applied:?}"
    );
    assert_eq!(applied.roi, s.roi);
    assert_eq!(applied.pixel_format, PixelFormat::Mono8);
}

#[test]
fn aravis_free_run_frames_have_increasing_ids_and_timestamps_at_the_frame_rate() {
    let fake = FakeGvCamera::start();
    let mut cam = fake.open();
    let rate = 25.0;
    cam.configure(&settings(TriggerMode::FreeRun, rate))
        .expect("configure");
    cam.start().expect("start");
    let mut frames = Vec::new();
    while frames.len() < 11 {
        let f = cam
            .next_frame(Duration::from_secs(2))
            .expect("frame")
            .expect("a frame within 2 s");
        assert_eq!((f.width, f.height, f.format), (64, 48, PixelFormat::Mono8));
        assert_eq!(f.data.len(), 64 * 48);
        frames.push(f);
    }
    cam.stop().expect("stop");
    for w in frames.windows(2) {
        assert!(w[1].id > w[0].id, "ids {} then {}", w[0].id, w[1].id);
        assert!(w[1].host_arrival > w[0].host_arrival);
    }
    // Device timestamps (ns) advance by about one frame period per frame id. Aravis' fake
    // camera stamps a frame when its own thread makes it, so on a loaded machine a frame can
    // come late (one stretched interval: 54.6 ms in place of 40 in one CI run); the typical
    // interval, the median over ten, is the rate the camera was set to.
    let mut periods: Vec<f64> = frames
        .windows(2)
        .map(|w| {
            (w[1].device_timestamp as f64 - w[0].device_timestamp as f64)
                / (w[1].id - w[0].id) as f64
        })
        .collect();
    periods.sort_by(f64::total_cmp);
    let period_ns = periods[periods.len() / 2];
    let expected = 1e9 / rate;
    assert!(
        (period_ns - expected).abs() < 0.2 * expected,
        "median period {period_ns} ns, expected {expected}; all: {periods:?}"
    );
}

#[test]
fn aravis_software_trigger_gives_one_frame_per_trigger() {
    let fake = FakeGvCamera::start();
    let mut cam = fake.open();
    cam.configure(&settings(TriggerMode::Software, 25.0))
        .expect("configure");
    cam.start().expect("start");
    // No trigger, no frame.
    assert!(cam
        .next_frame(Duration::from_millis(300))
        .expect("wait")
        .is_none());
    let mut ids = Vec::new();
    for _ in 0..3 {
        cam.trigger().expect("trigger");
        let f = cam
            .next_frame(Duration::from_secs(2))
            .expect("frame")
            .expect("a frame per trigger");
        ids.push(f.id);
        assert!(
            cam.next_frame(Duration::from_millis(200))
                .expect("wait")
                .is_none(),
            "extra frame after one trigger"
        );
    }
    cam.stop().expect("stop");
    assert!(ids.windows(2).all(|w| w[1] == w[0] + 1), "ids {ids:?}");
}

#[test]
fn aravis_timestamp_latch_or_a_clear_error_naming_the_feature() {
    let fake = FakeGvCamera::start();
    let mut cam = fake.open();
    match cam.latch_timestamp() {
        Ok(l) => {
            assert!(l.host_after >= l.host_before);
            let l2 = cam.latch_timestamp().expect("second latch");
            assert!(l2.device_ticks > l.device_ticks);
        }
        Err(e @ CameraError::Feature { .. }) => {
            let msg = e.to_string();
            assert!(
                msg.contains("TimestampLatch") && msg.contains(FAKE_ID),
                "{msg}"
            );
        }
        Err(e) => panic!("unexpected error: {e}"),
    }
}

#[test]
fn aravis_missing_exposure_active_line_is_named() {
    let fake = FakeGvCamera::start();
    let mut cam = fake.open();
    let mut s = settings(TriggerMode::FreeRun, 25.0);
    s.exposure_active_line = Some("Line2".into());
    let msg = cam
        .configure(&s)
        .expect_err("the fake has no output lines")
        .to_string();
    assert!(msg.contains("LineSelector"), "{msg}");
}
