//! Camera traces: the committed trace under tests/traces/camera/ replayed through ReplayCamera,
//! and a RecordingCamera round trip.
//!
//! The committed trace was written by `generate_committed_camera_trace` (ignored; run it with
//! `cargo test -p fringe-tests --test camera_replay -- --ignored` to regenerate).

use fringe_rig::HostTime;
use fringe_rig::{
    Camera, CameraError, CameraInfo, CameraSettings, Frame, PixelFormat, TimestampLatch,
    TriggerMode,
};
use fringe_rig::{CameraTrace, CameraTraceWriter, RecordingCamera, ReplayCamera, ReplayPace};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

const W: u32 = 16;
const H: u32 = 12;
/// Frame 4 was dropped.
const IDS: [u64; 5] = [1, 2, 3, 5, 6];
const PERIOD_NS: u64 = 20_000_000;
const T0_NS: u64 = 1_000_000_000;

fn committed_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("traces/camera")
}

/// The settings the committed trace was filmed with (a Mono8 camera).
fn mono8() -> CameraSettings {
    CameraSettings {
        pixel_format: PixelFormat::Mono8,
        ..Default::default()
    }
}

fn pixels(id: u64) -> Vec<u8> {
    (0..H)
        .flat_map(|y| (0..W).map(move |x| ((x * 13 + y * 7) as u64 + id * 29) as u8))
        .collect()
}

/// The frames of the committed trace, host arrival relative to the recording start.
fn expected_frames() -> Vec<Frame> {
    IDS.iter()
        .map(|&id| Frame {
            id,
            device_timestamp: T0_NS + (id - 1) * PERIOD_NS,
            // arrival 3 ms after the exposure, with a little jitter
            host_arrival: HostTime((id - 1) * PERIOD_NS + 3_000_000 + id * 1_234),
            width: W,
            height: H,
            format: PixelFormat::Mono8,
            data: pixels(id),
        })
        .collect()
}

fn info() -> CameraInfo {
    CameraInfo {
        vendor: "Synthetic".into(),
        model: "Test".into(),
        serial: "0001".into(),
        id: "Synthetic-Test-0001".into(),
        tick_frequency: 1_000_000_000,
    }
}

#[test]
#[ignore = "regenerates tests/traces/camera; run only to change the committed trace"]
fn generate_committed_camera_trace() {
    let dir = committed_dir();
    let mut w = CameraTraceWriter::create(&dir, "camera", &info(), HostTime(0)).expect("create");
    w.configured(&mono8()).expect("configured");
    for f in expected_frames() {
        w.frame(&f).expect("frame");
    }
    w.latch(&TimestampLatch {
        host_before: HostTime(150_000_000),
        device_ticks: 1_147_000_000,
        host_after: HostTime(150_080_000),
    })
    .expect("latch");
}

fn drain(cam: &mut dyn Camera) -> Vec<Frame> {
    let mut out = Vec::new();
    while let Some(f) = cam
        .next_frame(Duration::from_millis(500))
        .expect("next frame")
    {
        out.push(f);
    }
    out
}

#[test]
fn committed_camera_trace_replays_ids_timestamps_gaps_and_pixels() {
    let trace = CameraTrace::load(&committed_dir()).expect("load committed trace");
    assert_eq!(trace.info, info());
    assert_eq!(trace.configured.len(), 1);
    assert!(
        trace.configured[0].contains("mono8"),
        "{:?}",
        trace.configured
    );
    let expected = expected_frames();
    // Host arrival offsets are kept to the nanosecond.
    let offsets: Vec<u64> = trace
        .frames
        .iter()
        .map(|f| f.host_offset.as_nanos() as u64)
        .collect();
    assert_eq!(
        offsets,
        expected
            .iter()
            .map(|f| f.host_arrival.nanos())
            .collect::<Vec<_>>()
    );

    let mut cam = ReplayCamera::new(trace, ReplayPace::AsFastAsPossible);
    cam.configure(&mono8()).expect("configure");
    cam.start().expect("start");
    let frames = drain(&mut cam);
    assert_eq!(frames.len(), expected.len());
    for (got, want) in frames.iter().zip(&expected) {
        assert_eq!(
            (got.id, got.device_timestamp),
            (want.id, want.device_timestamp)
        );
        assert_eq!(
            (got.width, got.height, got.format),
            (W, H, PixelFormat::Mono8)
        );
        assert_eq!(got.data, want.data, "pixels of frame {}", want.id);
    }
    // The dropped frame is visible as a gap in the ids, and in the device timestamps.
    let gaps: Vec<u64> = frames.windows(2).map(|w| w[1].id - w[0].id).collect();
    assert_eq!(gaps, vec![1, 1, 2, 1]);
    assert_eq!(
        frames[3].device_timestamp - frames[2].device_timestamp,
        2 * PERIOD_NS
    );

    let latch = cam.latch_timestamp().expect("recorded latch");
    assert_eq!(latch.device_ticks, 1_147_000_000);
    assert_eq!(
        latch.host_after.since(latch.host_before),
        Duration::from_micros(80)
    );
    assert!(
        cam.latch_timestamp().is_err(),
        "only one latch was recorded"
    );
}

#[test]
fn paced_replay_keeps_the_recorded_arrival_times() {
    let mut cam = ReplayCamera::open(&committed_dir(), ReplayPace::Recorded).expect("open");
    cam.configure(&mono8()).expect("configure");
    let t0 = Instant::now();
    cam.start().expect("start");
    let frames = drain(&mut cam);
    let elapsed = t0.elapsed();
    let last = expected_frames()
        .last()
        .map(|f| f.host_arrival.nanos())
        .unwrap_or(0);
    assert_eq!(frames.len(), IDS.len());
    assert!(
        elapsed >= Duration::from_nanos(last),
        "replayed in {elapsed:?}, recorded over {last} ns"
    );
    assert!(
        elapsed < Duration::from_nanos(last) + Duration::from_millis(500),
        "{elapsed:?}"
    );
    // Arrival spacing follows the recording (2 periods across the dropped frame).
    let spacing = frames[3].host_arrival.since(frames[2].host_arrival);
    assert!(spacing >= Duration::from_millis(35), "{spacing:?}");
}

#[test]
fn replay_in_software_trigger_mode_gives_one_frame_per_trigger() {
    let mut cam = ReplayCamera::open(&committed_dir(), ReplayPace::AsFastAsPossible).expect("open");
    let s = CameraSettings {
        trigger: TriggerMode::Software,
        ..mono8()
    };
    cam.configure(&s).expect("configure");
    cam.start().expect("start");
    assert!(cam
        .next_frame(Duration::from_millis(20))
        .expect("wait")
        .is_none());
    cam.trigger().expect("trigger");
    assert_eq!(
        cam.next_frame(Duration::from_millis(20))
            .expect("frame")
            .map(|f| f.id),
        Some(1)
    );
    assert!(cam
        .next_frame(Duration::from_millis(20))
        .expect("wait")
        .is_none());
}

/// A camera delivering given frames, for recording.
struct ScriptedCamera {
    frames: std::vec::IntoIter<Frame>,
    ticks: u64,
}

impl Camera for ScriptedCamera {
    fn info(&self) -> CameraInfo {
        info()
    }
    fn configure(&mut self, _: &CameraSettings) -> Result<(), CameraError> {
        Ok(())
    }
    fn start(&mut self) -> Result<(), CameraError> {
        Ok(())
    }
    fn trigger(&mut self) -> Result<(), CameraError> {
        Ok(())
    }
    fn next_frame(&mut self, _: Duration) -> Result<Option<Frame>, CameraError> {
        let mut f = self.frames.next();
        if let Some(f) = &mut f {
            std::thread::sleep(Duration::from_millis(2));
            f.host_arrival = HostTime::now();
        }
        Ok(f)
    }
    fn stop(&mut self) -> Result<(), CameraError> {
        Ok(())
    }
    fn latch_timestamp(&mut self) -> Result<TimestampLatch, CameraError> {
        self.ticks += 1_000;
        let host_before = HostTime::now();
        Ok(TimestampLatch {
            host_before,
            device_ticks: self.ticks,
            host_after: HostTime::now(),
        })
    }
}

#[test]
fn recording_camera_round_trip_replays_what_was_delivered() {
    let dir = std::env::temp_dir().join(format!("fringe-camera-roundtrip-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let mut originals = expected_frames();
    // Include colour and Bayer frames: every format must survive the PNG files.
    originals[1].format = PixelFormat::Rgb8;
    originals[1].data = (0..W * H * 3).map(|i| (i * 7 % 256) as u8).collect();
    originals[2].format = PixelFormat::BayerRg8;
    let scripted = ScriptedCamera {
        frames: originals.clone().into_iter(),
        ticks: 0,
    };
    let mut rec = RecordingCamera::new(scripted, &dir, "camera").expect("recorder");
    rec.configure(&CameraSettings::default())
        .expect("configure");
    rec.start().expect("start");
    let delivered = drain(&mut rec);
    let latch = rec.latch_timestamp().expect("latch");
    rec.stop().expect("stop");
    assert_eq!(delivered.len(), originals.len());

    let trace = CameraTrace::load(&dir).expect("load recorded trace");
    assert_eq!(trace.info, info());
    // Host arrival differences survive to the nanosecond.
    for (pair, rec_pair) in delivered.windows(2).zip(trace.frames.windows(2)) {
        assert_eq!(
            pair[1].host_arrival.since(pair[0].host_arrival),
            rec_pair[1].host_offset - rec_pair[0].host_offset
        );
    }
    let mut replay = ReplayCamera::new(trace, ReplayPace::AsFastAsPossible);
    replay
        .configure(&CameraSettings::default())
        .expect("configure");
    replay.start().expect("start");
    let replayed = drain(&mut replay);
    assert_eq!(replayed.len(), delivered.len());
    for (r, d) in replayed.iter().zip(&delivered) {
        assert_eq!(
            (
                r.id,
                r.device_timestamp,
                r.width,
                r.height,
                r.format,
                &r.data
            ),
            (
                d.id,
                d.device_timestamp,
                d.width,
                d.height,
                d.format,
                &d.data
            )
        );
    }
    assert_eq!(
        replay.latch_timestamp().expect("latch").device_ticks,
        latch.device_ticks
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_pixel_format_the_replayed_camera_does_not_offer_is_refused_naming_what_it_offers() {
    let mut cam = ReplayCamera::open(&committed_dir(), ReplayPace::AsFastAsPossible).expect("open");
    let e = cam
        .configure(&CameraSettings {
            pixel_format: PixelFormat::BayerRg8,
            ..Default::default()
        })
        .expect_err("the trace holds mono8 frames only");
    let text = e.to_string();
    assert!(
        text.contains("PixelFormat") && text.contains("bayerrg8") && text.contains("offers mono8"),
        "{text}"
    );
}
