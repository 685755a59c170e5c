//! The simulated bench end to end: contact on the bench, the F/T reading through a simulated DAQ
//! and an ATI `.cal` matrix, the simulated camera's clock, frame ids and drops, and the exposure
//! strobe seen by the DAQ, all scored against the ground truth.

use fringe_rig::atical::{CalibratedSensor, Calibration};
use fringe_rig::HostTime;
use fringe_rig::{Camera, CameraSettings, Frame, TriggerMode};
use fringe_rig::{ForceSample, ForceSensor};
use fringe_rig::{Millimetres, MillimetresPerSecond, MillimetresPerSecondSquared, Wrench};
use fringe_sim::SimFtSensor;
use fringe_sim::{ground_truth::FrameFate, TruthLog};
use fringe_sim::{Bench, BenchConfig};
use fringe_sim::{ExposureSchedule, SimCamera, SimCameraConfig, FRAME_MEMORY};
use fringe_sim::{FrameRenderer, Scene, SceneSource};
use fringe_sim::{SimDaq, SimDaqConfig};
use std::path::PathBuf;
use std::sync::Arc;
use std::time::{Duration, Instant};

fn cal() -> Calibration {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("data")
        .join("mini40-v1.0.cal");
    Calibration::load(&path).expect("shipped test .cal")
}

/// A 16 x 8 test renderer: every pixel encodes the contact force (10 DN per newton), optionally
/// slow.
struct TinyRenderer {
    delay: Duration,
}

impl FrameRenderer for TinyRenderer {
    fn width(&self) -> u32 {
        16
    }
    fn height(&self) -> u32 {
        8
    }
    fn render(&mut self, scene: &Scene, _frame_index: u64, out: &mut Vec<u8>) {
        std::thread::sleep(self.delay);
        let level = scene
            .contact
            .map_or(0.0, |c| c.force.0 * 10.0)
            .clamp(0.0, 255.0) as u8;
        out.clear();
        out.resize(16 * 8 * 3, level);
    }
}

fn no_contact() -> Arc<dyn SceneSource> {
    struct Empty;
    impl SceneSource for Empty {
        fn scene_at(&self, _t: HostTime) -> Scene {
            Scene::default()
        }
    }
    Arc::new(Empty)
}

fn drain(camera: &mut SimCamera) -> Vec<Frame> {
    let mut frames = Vec::new();
    while let Some(f) = camera.next_frame(Duration::from_millis(1)).expect("frame") {
        frames.push(f);
    }
    frames
}

/// The known wrench the DAQ test feeds through the gauges.
fn known_wrench(t: HostTime) -> Wrench {
    let s = t.seconds();
    Wrench::from_array([
        1.5 * (7.0 * s).sin(),
        -2.0,
        -6.0 + 3.0 * (3.0 * s).cos(),
        0.05,
        -0.03 * (5.0 * s).sin(),
        0.01,
    ])
}

/// Theil-Sen slope of y against x (robust to late outliers).
fn theil_sen(points: &[(f64, f64)]) -> f64 {
    let mut slopes = Vec::new();
    for i in 0..points.len() {
        for j in i + 1..points.len() {
            let dx = points[j].0 - points[i].0;
            if dx.abs() > 0.1 {
                slopes.push((points[j].1 - points[i].1) / dx);
            }
        }
    }
    slopes.sort_by(|a, b| a.total_cmp(b));
    slopes[slopes.len() / 2]
}

#[test]
fn camera_clock_ids_drops_latch_and_strobe_agree_with_the_truth() {
    let truth = TruthLog::new();
    let schedule = ExposureSchedule::new();
    let drift_ppm = 1000.0;
    let mut camera = SimCamera::new(
        SimCameraConfig {
            clock_drift_ppm: drift_ppm,
            arrival_jitter_ms: 0.0,
            drop_probability: 0.2,
            host_buffers: 200,
            seed: 5,
            ..SimCameraConfig::default()
        },
        no_contact(),
        Box::new(TinyRenderer {
            delay: Duration::ZERO,
        }),
    )
    .with_schedule(schedule.clone())
    .with_truth(truth.clone());
    let calibration = cal();
    let daq = SimDaq::new(
        SimDaqConfig::default(),
        &calibration,
        Box::new(known_wrench),
    )
    .expect("daq")
    .with_strobe(schedule);
    let lsb = daq.lsb_volts();
    let daq_clock = daq.clock();
    let mut sensor = CalibratedSensor::new(daq, calibration.clone());

    sensor.start().expect("daq start");
    camera.start().expect("camera start");
    let mut samples: Vec<ForceSample> = Vec::new();
    let began = Instant::now();
    while began.elapsed() < Duration::from_millis(1300) {
        if let Some(s) = sensor
            .next_sample(Duration::from_millis(50))
            .expect("sample")
        {
            samples.push(s);
        }
    }
    let latches: Vec<_> = (0..20)
        .map(|_| camera.latch_timestamp().expect("latch"))
        .collect();
    camera.stop().expect("camera stop");
    sensor.stop().expect("daq stop");
    let frames = drain(&mut camera);
    let stats = camera.stats();
    let clock = camera.clock();

    // Frame timing: 20 ms apart on the device clock, ids skip over the dropped frames.
    assert!(frames.len() >= 40, "{} frames", frames.len());
    for pair in frames.windows(2) {
        let ids = pair[1].id - pair[0].id;
        assert!(ids >= 1);
        assert_eq!(
            pair[1].device_timestamp - pair[0].device_timestamp,
            ids * 20_000_000,
            "ids {} -> {}",
            pair[0].id,
            pair[1].id
        );
    }
    let last_id = frames.last().expect("frames").id;
    let missing = last_id + 1 - frames.len() as u64;
    assert!(
        missing >= 3,
        "drop probability 0.2 lost only {missing} of {last_id}"
    );
    let recorded = truth.frames();
    let dropped: Vec<u64> = recorded
        .iter()
        .filter(|f| f.fate == FrameFate::Dropped && f.id <= last_id)
        .map(|f| f.id)
        .collect();
    assert_eq!(
        dropped.len() as u64,
        missing,
        "truth lists every skipped id"
    );
    assert!(dropped.iter().all(|id| frames.iter().all(|f| f.id != *id)));
    assert_eq!(stats.delivered, frames.len() as u64);
    assert!(stats.dropped >= missing);

    // Drift recovered from device timestamps against host arrivals (jitter 0).
    let points: Vec<(f64, f64)> = frames
        .iter()
        .map(|f| {
            let ticks = f.device_timestamp as f64;
            (ticks * 1e-9, (f.host_arrival.0 as f64 - ticks) * 1e-9)
        })
        .collect();
    let slope = theil_sen(&points);
    let estimated_ppm = -slope / (1.0 + slope) * 1e6;
    assert!(
        (estimated_ppm - drift_ppm).abs() < 250.0,
        "estimated {estimated_ppm} ppm, true {drift_ppm}"
    );
    // Arrival is exposure end + 5 ms readout (+ scheduling): never earlier.
    for f in &frames {
        let end = clock.host_at(f.device_timestamp + 2_000_000);
        assert!(
            f.host_arrival.0 >= end.0 + 5_000_000 - 1_000,
            "frame {}",
            f.id
        );
    }

    // Latches bracket the true device clock.
    for l in &latches {
        let at = clock.host_at(l.device_ticks);
        assert!(
            at.0 + 1 >= l.host_before.0 && at.0 <= l.host_after.0 + 1,
            "{l:?} latched at {at:?}"
        );
        assert!(l.host_after.0 - l.host_before.0 < 20_000_000);
    }

    // The DAQ: consecutive indices, the known wrench within the gauge quantisation.
    assert!(samples.len() > 5000, "{} samples in 1.3 s", samples.len());
    let dc = daq_clock.get().expect("daq started");
    let m = calibration.matrix;
    for s in &samples {
        let want = known_wrench(dc.sample_time(s.device_tick)).to_array();
        let got = s.wrench.to_array();
        for i in 0..6 {
            let bound = (0..6).map(|j| m[(i, j)].abs()).sum::<f64>() * lsb / 2.0 + 1e-9;
            assert!(
                (got[i] - want[i]).abs() <= bound,
                "axis {i} sample {}: {} vs {} (bound {bound})",
                s.device_tick,
                got[i],
                want[i]
            );
        }
    }
    for pair in samples.windows(2) {
        assert_eq!(pair[1].device_tick, pair[0].device_tick + 1);
    }

    // The strobe: one high run per exposure, 2 ms long, starting within a sample of the exposure.
    let first_t = dc.sample_time(samples[0].device_tick);
    let last_t = dc.sample_time(samples.last().expect("samples").device_tick);
    let mut runs: Vec<(HostTime, usize)> = Vec::new();
    let mut current: Option<(HostTime, usize)> = None;
    for s in &samples {
        let high = s.strobe.expect("strobe channel").0 > 1.5;
        match (&mut current, high) {
            (None, true) => current = Some((dc.sample_time(s.device_tick), 1)),
            (Some((_, n)), true) => *n += 1,
            (Some(run), false) => {
                runs.push(*run);
                current = None;
            }
            (None, false) => {}
        }
    }
    let exposures: Vec<_> = recorded
        .iter()
        .filter(|f| f.exposure_start > first_t && f.exposure_end < last_t)
        .collect();
    let complete: Vec<_> = runs.iter().filter(|r| r.0 > first_t).collect();
    assert!(exposures.len() >= 40, "{} exposures", exposures.len());
    assert_eq!(complete.len(), exposures.len(), "strobe runs vs exposures");
    eprintln!(
        "{} frames, {missing} ids skipped, drift estimated {estimated_ppm:.0} ppm (true {drift_ppm}), \
         {} scans, {} strobe runs for {} exposures",
        frames.len(),
        samples.len(),
        complete.len(),
        exposures.len()
    );
    let period = 200_000u64;
    for (run, exp) in complete.iter().zip(&exposures) {
        assert!(
            (9..=11).contains(&run.1),
            "run of {} samples for 2 ms",
            run.1
        );
        assert!(run.0 >= exp.exposure_start && run.0 .0 - exp.exposure_start.0 <= period + 1);
    }
}

#[test]
fn slow_renderer_drops_frames_but_keeps_the_schedule() {
    let mut camera = SimCamera::new(
        SimCameraConfig {
            arrival_jitter_ms: 0.0,
            ..SimCameraConfig::default()
        },
        no_contact(),
        Box::new(TinyRenderer {
            delay: Duration::from_millis(45),
        }),
    );
    camera.start().expect("start");
    std::thread::sleep(Duration::from_millis(1200));
    camera.stop().expect("stop");
    let frames = drain(&mut camera);
    let stats = camera.stats();
    // About 60 exposures at 50 fps, at most 27 rendered, FRAME_MEMORY waiting: the rest dropped.
    assert!(stats.exposures >= 50, "{stats:?}");
    assert!(
        stats.render_busy >= stats.exposures - (1200 / 45 + 2) - FRAME_MEMORY as u64 - 1,
        "{stats:?}"
    );
    assert!(stats.render_busy >= 15, "{stats:?}");
    assert!(
        frames.len() as u64 <= 1200 / 45 + 2,
        "{} frames",
        frames.len()
    );
    assert!(frames.len() >= 5);
    assert!(frames.windows(2).any(|p| p[1].id > p[0].id + 1), "ids skip");
    for p in frames.windows(2) {
        assert_eq!(
            (p[1].device_timestamp - p[0].device_timestamp) % 20_000_000,
            0
        );
    }
}

#[test]
fn software_trigger_exposes_once_per_trigger() {
    let mut camera = SimCamera::new(
        SimCameraConfig::default(),
        no_contact(),
        Box::new(TinyRenderer {
            delay: Duration::ZERO,
        }),
    );
    let settings = CameraSettings {
        trigger: TriggerMode::Software,
        ..CameraSettings::default()
    };
    camera.configure(&settings).expect("software trigger");
    assert!(camera.trigger().is_err(), "trigger before start");
    camera.start().expect("start");
    for _ in 0..4 {
        camera.trigger().expect("trigger");
        std::thread::sleep(Duration::from_millis(30));
    }
    // Too soon after the last one: ignored (max 160 fps).
    camera.trigger().expect("trigger");
    camera.trigger().expect("overtrigger");
    std::thread::sleep(Duration::from_millis(30));
    let mut frames = Vec::new();
    while let Some(f) = camera
        .next_frame(Duration::from_millis(100))
        .expect("frame")
    {
        frames.push(f);
    }
    camera.stop().expect("stop");
    assert_eq!(
        frames.iter().map(|f| f.id).collect::<Vec<_>>(),
        vec![0, 1, 2, 3, 4]
    );
    assert_eq!(camera.stats().triggers_ignored, 1);
    for p in frames[..4].windows(2) {
        let gap = p[1].device_timestamp - p[0].device_timestamp;
        assert!((29_000_000..60_000_000).contains(&gap), "{gap}");
    }
    let mut bad = settings.clone();
    bad.exposure.0 = 30_000.0;
    assert!(
        camera.configure(&bad).is_err(),
        "exposure longer than the frame period"
    );
}

#[test]
fn surface_height_variation_shifts_first_contact() {
    let bench = Bench::new(BenchConfig::default());
    let (a, b) = (
        (Millimetres(-12.0), Millimetres(5.0)),
        (Millimetres(10.0), Millimetres(-9.0)),
    );
    let (ha, hb) = (
        bench.surface_height(a.0, a.1),
        bench.surface_height(b.0, b.1),
    );
    assert!(
        (ha.0 - hb.0).abs() > 0.003,
        "heights {ha} {hb} hardly differ"
    );
    let za = bench.z_first_contact(a.0, a.1);
    let zb = bench.z_first_contact(b.0, b.1);
    // z grows downwards: a higher surface is met earlier (smaller z).
    assert!(((zb.0 - za.0) - (ha.0 - hb.0)).abs() < 1e-12);
    // Pressing at a, 5 um short of its first contact touches nothing; 20 um past it does.
    let t0 = HostTime::now();
    let zero = bench.motor_z().zero_offset().0;
    let (x, y) = bench.stage_xy_for(a.0, a.1);
    bench
        .motor_x()
        .move_to(t0, Millimetres(x.0 - bench.motor_x().zero_offset().0));
    bench
        .motor_y()
        .move_to(t0, Millimetres(y.0 - bench.motor_y().zero_offset().0));
    bench
        .motor_z()
        .move_to(t0, Millimetres(za.0 - 0.005 - zero));
    let t1 = HostTime(t0.0 + 30_000_000_000);
    assert!(bench.scene_at(t1).contact.is_none());
    bench
        .motor_z()
        .move_to(t1, Millimetres(za.0 + 0.020 - zero));
    let t2 = HostTime(t1.0 + 5_000_000_000);
    let c = bench
        .scene_at(t2)
        .contact
        .expect("touching 20 um past first contact");
    assert!(c.force.0 > 0.05 && c.force.0 < 1.0, "{c:?}");
}

#[test]
fn lowering_z_over_the_sensor_reads_growing_force_through_the_daq() {
    let mut config = BenchConfig::default();
    config.z.power_up_mm = 14.0; // 1 mm above the surface
    let bench = Bench::new(config.clone());
    let z = bench.motor_z();
    z.set_kinematics(fringe_rig::Kinematics {
        velocity: MillimetresPerSecond(2.5),
        acceleration: MillimetresPerSecondSquared(50.0),
    });
    // Put the indenter over (4, -3) mm first (moves in simulated time, instantly done by t0).
    let (x, y) = bench.stage_xy_for(Millimetres(4.0), Millimetres(-3.0));
    let fast = fringe_rig::Kinematics {
        velocity: MillimetresPerSecond(20.0),
        acceleration: MillimetresPerSecondSquared(100.0),
    };
    bench.motor_x().set_kinematics(fast);
    bench.motor_y().set_kinematics(fast);
    let start = HostTime::now();
    bench.motor_x().move_to(start, Millimetres(x.0 - 25.0));
    bench.motor_y().move_to(start, Millimetres(y.0 - 25.0));
    let ft = SimFtSensor::new(bench.clone(), config.ft_noise);
    let calibration = cal();
    let daq = SimDaq::new(SimDaqConfig::default(), &calibration, Box::new(ft)).expect("daq");
    let daq_clock = daq.clock();
    let mut sensor = CalibratedSensor::new(daq, calibration).with_bias_scans(250);
    // Let x and y arrive (4 mm at 20 mm/s) before taring and pressing.
    std::thread::sleep(Duration::from_millis(400));
    sensor.start().expect("start");
    sensor.bias().expect("tare without contact");
    let depth = 1.0;
    let target = bench.z_for_depth(Millimetres(4.0), Millimetres(-3.0), Millimetres(depth));
    let t_move = HostTime::now();
    z.move_to(t_move, Millimetres(target.0 - z.zero_offset().0));
    let mut samples = Vec::new();
    let began = Instant::now();
    while began.elapsed() < Duration::from_millis(1100) {
        if let Some(s) = sensor
            .next_sample(Duration::from_millis(50))
            .expect("sample")
        {
            samples.push(s);
        }
    }
    sensor.stop().expect("stop");
    let dc = daq_clock.get().expect("started");
    let mut arrived = t_move;
    while z.status_at(arrived).moving {
        arrived = HostTime(arrived.0 + 1_000_000);
    }
    assert!(
        arrived.0 - t_move.0 < 1_000_000_000,
        "z arrives within the sampling"
    );
    // 50 ms means of Fz while z moves: start near zero, fall (compression is negative).
    let means: Vec<f64> = samples
        .chunks(250)
        .filter(|c| c.len() == 250 && dc.sample_time(c[249].device_tick) < arrived)
        .map(|c| c.iter().map(|s| s.wrench.fz.0).sum::<f64>() / 250.0)
        .collect();
    assert!(means[0].abs() < 0.2, "tared, not touching: {means:?}");
    let last = samples
        .iter()
        .rev()
        .take(250)
        .map(|s| s.wrench.fz.0)
        .sum::<f64>()
        / 250.0;
    assert!(last < -4.0, "pressing 1 mm: {last} after {means:?}");
    assert!(means.len() >= 8, "{means:?}");
    let mut deepest = f64::INFINITY;
    for m in &means {
        // Never rises by more than the noise of a 50 ms mean while pressing down.
        assert!(*m < deepest + 0.1 || deepest == f64::INFINITY, "{means:?}");
        deepest = deepest.min(*m);
    }
    let t_end = HostTime::now();
    let truth = bench.truth_at(t_end);
    assert!(
        (last + truth.normal_force.0).abs() < 0.6,
        "{last} vs {truth:?}"
    );
    let scene = bench.scene_at(t_end);
    let c = scene.contact.expect("pressing");
    assert!(
        (c.x.0 - 4.0).abs() < 1e-9 && (c.y.0 + 3.0).abs() < 1e-9,
        "{c:?}"
    );
    // The moments of the off-centre tip: M = r x F, r = (0.4, +0.25, 35) mm in the F/T frame.
    let tail: Vec<&ForceSample> = samples.iter().rev().take(250).collect();
    let tx = tail.iter().map(|s| s.wrench.tx.0).sum::<f64>() / 250.0;
    let ty = tail.iter().map(|s| s.wrench.ty.0).sum::<f64>() / 250.0;
    let fz = tail.iter().map(|s| s.wrench.fz.0).sum::<f64>() / 250.0;
    assert!((tx - 0.00025 * fz).abs() < 0.001, "tx {tx} fz {fz}");
    assert!((ty + 0.0004 * fz).abs() < 0.001, "ty {ty} fz {fz}");
}

#[test]
fn frames_show_the_scene_at_mid_exposure() {
    use fringe_rig::Newtons;
    use fringe_sim::Contact;
    use fringe_sim::Shape;
    /// Force = host milliseconds modulo 20, so the rendered level (10 DN per N) tells the instant.
    struct Clockwork;
    impl SceneSource for Clockwork {
        fn scene_at(&self, t: HostTime) -> Scene {
            Scene {
                contact: Some(Contact {
                    shape: Shape::DEFAULT_PENTAGON,
                    force: Newtons((t.0 % 20_000_000) as f64 * 1e-6),
                    x: Millimetres(0.0),
                    y: Millimetres(0.0),
                    angle_deg: 0.0,
                    shear: None,
                }),
            }
        }
    }
    let truth = TruthLog::new();
    let mut camera = SimCamera::new(
        SimCameraConfig::default(),
        Arc::new(Clockwork),
        Box::new(TinyRenderer {
            delay: Duration::ZERO,
        }),
    )
    .with_truth(truth.clone());
    camera.start().expect("start");
    std::thread::sleep(Duration::from_millis(300));
    camera.stop().expect("stop");
    let frames = drain(&mut camera);
    assert!(frames.len() >= 10);
    let clock = camera.clock();
    for f in &frames {
        let mid = clock.host_at(f.device_timestamp + 1_000_000);
        let want = ((mid.0 % 20_000_000) as f64 * 1e-5) as u8;
        assert!(
            (f.data[0] as i32 - want as i32).abs() <= 1,
            "frame {}: level {} for mid-exposure level {want}",
            f.id,
            f.data[0]
        );
        let t = truth
            .frames()
            .into_iter()
            .find(|r| r.id == f.id)
            .expect("truth of every frame");
        assert_eq!(t.fate, FrameFate::Delivered);
        assert_eq!(t.exposure_start_ticks, f.device_timestamp);
        assert_eq!(t.arrival, Some(f.host_arrival));
        // The camera's native BayerRG8 unless configured otherwise: one byte per pixel.
        assert_eq!(f.format, fringe_rig::PixelFormat::BayerRg8);
        assert_eq!(f.data.len(), 16 * 8);
    }
}
