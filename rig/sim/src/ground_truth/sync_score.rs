//! The three synchronisation methods run side by side on one simulated bench and scored against
//! the ground truth.
//!
//! One bench (indenter pressing the sensor centre again and again), one simulated DAQ (5 kHz
//! gauges and the exposure strobe through the simulated Mini40's `.cal` matrix) and one simulated
//! camera (a tiny renderer: timing is what matters here). The force stream and the camera stream
//! (latched every [`LATCH_PERIOD`]) run on their threads as in a scan; every sample and frame goes
//! to all three labelers, built by [`labeler_for`] as the scan engine builds them.
//!
//! Scores, per method, over the frames that arrived after the warm-up:
//!
//! - **label time**: the middle of the window the label averaged over, in the force stream's
//!   sample index, turned into true host time by the simulated DAQ's sample clock (ground truth),
//!   minus the middle of the true exposure window. One time base (true host time) for all methods:
//!   the error is where in the force signal the label really looked.
//! - **label Fz**: the labelled Fz (tared by the mean label of the frames with no true contact)
//!   minus the true Fz averaged over the true exposure window (bench truth every millisecond), for
//!   frames in contact by their true |Fz| ([`in_contact`], during presses).

use crate::bench::{Bench, BenchConfig};
use crate::emulators::camera_emulator::{ExposureSchedule, SimCamera, SimCameraConfig};
use crate::emulators::daq_emulator::{SimDaq, SimDaqConfig};
use crate::ground_truth::records::{BenchRecorder, FrameTruth, TruthLog, TruthRecord, TruthSink};
use crate::physics::ft_sensor::SimFtSensor;
use crate::physics::motion::{Kinematics, SimMotor};
use crate::rig::SIM_CAL;
use crate::scene::{FrameRenderer, LoadSource, Scene, SceneSource};
use crossbeam_channel::{select, Receiver};
use fringe_rig::atical::{CalibratedSensor, Calibration};
use fringe_rig::mean_over;
use fringe_rig::reference_layout::in_contact;
use fringe_rig::scan::{labeler_for, LATCH_PERIOD};
use fringe_rig::CameraStream;
use fringe_rig::ForceSample;
use fringe_rig::ForceStream;
use fringe_rig::HostTime;
use fringe_rig::SyncMethod;
use fringe_rig::TriggerTiming;
use fringe_rig::{Camera, CameraSettings, Frame, TriggerMode};
use fringe_rig::{ExposureLabel, FrameLabeler, LabelOutcome};
use fringe_rig::{
    Hertz, Microseconds, Millimetres, MillimetresPerSecond, MillimetresPerSecondSquared, Newtons,
};
use std::collections::{HashMap, VecDeque};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// What to simulate.
#[derive(Debug, Clone, PartialEq)]
pub struct SyncBenchConfig {
    /// Seconds of frames scored (after the warm-up).
    pub seconds: f64,
    /// Seconds of streaming before frames are scored (the fits' start-up; a scan homes and
    /// approaches for longer than this before it films).
    pub warm_up_s: f64,
    pub seed: u64,
    /// Camera clock rate error, ppm.
    pub camera_drift_ppm: f64,
    /// DAQ sample clock rate error, ppm.
    pub force_drift_ppm: f64,
    /// Host arrival jitter of frames and of force blocks, uniform in [0, this], ms.
    pub arrival_jitter_ms: f64,
    /// Camera exposure end to arrival, ms (readout and transfer).
    pub readout_ms: f64,
    /// Press depth into the gel, mm.
    pub press_depth_mm: f64,
    /// One press (down, hold, up, wait), s.
    pub press_period_s: f64,
    /// The camera triggered by the DAQ's counter (Line1) instead of free running; adds the
    /// `trigger` method to those scored.
    pub daq_trigger: bool,
}

impl Default for SyncBenchConfig {
    /// 20 s scored after 3 s, 100 ppm drifts (camera slow, DAQ fast), 0-3 ms jitter, 5 ms
    /// readout, 1 mm presses every 2 s.
    fn default() -> Self {
        SyncBenchConfig {
            seconds: 20.0,
            warm_up_s: 3.0,
            seed: 7,
            camera_drift_ppm: 100.0,
            force_drift_ppm: -100.0,
            arrival_jitter_ms: 3.0,
            readout_ms: 5.0,
            press_depth_mm: 1.0,
            press_period_s: 2.0,
            daq_trigger: false,
        }
    }
}

/// One method's score.
#[derive(Debug, Clone, PartialEq)]
pub struct MethodScore {
    pub method: SyncMethod,
    /// Frames scored (labelled and matched with their truth).
    pub frames: usize,
    /// Frames that got no label (unmatched or never ready).
    pub unlabelled: usize,
    /// Why the first of them got none.
    pub first_unlabelled: Option<String>,
    /// Label time error (label window middle - true exposure middle), ns.
    pub time_rms_ns: f64,
    pub time_max_ns: f64,
    pub time_mean_ns: f64,
    /// Frames in contact scored for Fz.
    pub fz_frames: usize,
    /// Labelled Fz (tared) - true mean Fz over the true window, N.
    pub fz_rms_n: f64,
    pub fz_max_n: f64,
    /// The labeler's own estimate of its error at the end, ns.
    pub estimated_error_ns: Option<f64>,
}

/// The outcome of a run.
#[derive(Debug, Clone, PartialEq)]
pub struct SyncBenchReport {
    pub scores: Vec<MethodScore>,
    /// Frames the camera delivered while scoring.
    pub frames_delivered: usize,
    /// Force samples received.
    pub force_samples: u64,
    /// Why the camera could not be latched, if it could not.
    pub latch_error: Option<String>,
}

/// An 8 x 8 grey frame: only the timing of frames matters here.
struct Blank;

impl FrameRenderer for Blank {
    fn width(&self) -> u32 {
        8
    }
    fn height(&self) -> u32 {
        8
    }
    fn render(&mut self, _scene: &Scene, _frame_index: u64, out: &mut Vec<u8>) {
        out.clear();
        out.resize(8 * 8 * 3, 128);
    }
}

/// A labelled frame: (method index, device timestamp, label).
type Labelled = (usize, u64, ExposureLabel);

struct Lane {
    labeler: Box<dyn FrameLabeler>,
    pending: VecDeque<Frame>,
    unlabelled: usize,
    /// Why the first unlabelled frame got no label.
    why: Option<String>,
}

impl Lane {
    fn poll(&mut self, index: usize, closed: bool, out: &mut Vec<Labelled>) {
        while let Some(frame) = self.pending.front() {
            match self.labeler.label(frame) {
                LabelOutcome::NotYet if !closed => break,
                LabelOutcome::Ready(label) => out.push((index, frame.device_timestamp, label)),
                LabelOutcome::NotYet => {
                    self.unlabelled += 1;
                    self.why
                        .get_or_insert_with(|| format!("frame {}: never ready", frame.id));
                }
                LabelOutcome::Unmatched(why) => {
                    self.unlabelled += 1;
                    self.why.get_or_insert(format!("frame {}: {why}", frame.id));
                }
            }
            self.pending.pop_front();
        }
    }
}

/// A part of the synchronisation bench that could not start or stop.
#[derive(Debug, thiserror::Error)]
#[error("{part}: {message}")]
pub struct SyncBenchError {
    /// The device or thread that failed.
    pub part: &'static str,
    pub message: String,
}

impl SyncBenchError {
    fn new(part: &'static str, e: impl std::fmt::Display) -> SyncBenchError {
        SyncBenchError {
            part,
            message: e.to_string(),
        }
    }
}

/// Runs the bench for `config.warm_up_s + config.seconds` and scores the three methods.
pub fn run(config: &SyncBenchConfig) -> Result<SyncBenchReport, SyncBenchError> {
    let truth = TruthLog::new();
    let sink: Arc<dyn TruthSink> = truth.clone();
    let mut bench_config = BenchConfig {
        seed: config.seed,
        ..BenchConfig::default()
    };
    bench_config.ft_noise.seed = config.seed.wrapping_add(1);
    let bench = Bench::new(bench_config.clone());
    let presses = Presses::over_centre(&bench, config.press_depth_mm);
    // Let the stages arrive before anything is recorded.
    std::thread::sleep(Duration::from_millis(1500));

    let schedule = ExposureSchedule::new();
    let mut settings = CameraSettings::default();
    let mut sensor = force_sensor(config, &bench, &bench_config, &schedule, &sink)?;
    let mut camera = camera(config, &bench, schedule, &sink);
    let mut trigger = None;
    if config.daq_trigger {
        let line = "Line1";
        settings.trigger = TriggerMode::Hardware(line.into());
        let daq_config = SimDaqConfig::default();
        let camera_config = SimCameraConfig::default();
        trigger = Some(TriggerTiming {
            scan_rate: Hertz(daq_config.rate_hz),
            frame_rate: settings.frame_rate,
            delay: Microseconds(camera_config.trigger_latency_us + camera_config.line_response_us),
            exposure: settings.exposure,
        });
        let cal = sensor.calibration().clone();
        let daq = sensor
            .into_source()
            .with_camera_trigger(settings.frame_rate);
        camera = camera.with_trigger_input(line, daq.trigger_line());
        sensor = CalibratedSensor::new(daq, cal);
    }
    let tick_hz = camera.info().tick_frequency as f64;
    let recorder = BenchRecorder::spawn(bench.clone(), sink.clone(), Duration::from_millis(1))
        .map_err(|e| SyncBenchError::new("bench truth recorder", e))?;

    let stream =
        ForceStream::spawn(Box::new(sensor)).map_err(|e| SyncBenchError::new("force stream", e))?;
    let cameras = CameraStream::spawn_with_latches(Box::new(camera), &settings, LATCH_PERIOD)
        .map_err(|e| SyncBenchError::new("camera stream", e))?;
    // Every method the bench's wiring allows (`trigger` needs the camera triggered by the DAQ).
    let mut lanes: Vec<Lane> = SyncMethod::ALL
        .iter()
        .filter_map(|&m| {
            labeler_for(m, trigger, &settings, tick_hz, &cameras)
                .ok()
                .map(|labeler| Lane {
                    labeler,
                    pending: VecDeque::new(),
                    unlabelled: 0,
                    why: None,
                })
        })
        .collect();
    let samples: Receiver<_> = stream.samples().clone();
    let frames: Receiver<Frame> = cameras.frames().clone();
    let mut labelled: Vec<Labelled> = Vec::new();
    let delivered = label_while_pressing(
        config,
        &presses,
        (&samples, &frames),
        &mut lanes,
        &mut labelled,
    );
    let latch_error = cameras.latch_error();
    let force_samples = stop_streams(cameras, stream, &samples, &mut lanes, &mut labelled)?;
    recorder.stop();
    let scores = score(&truth.records(), &lanes, &labelled)?;
    Ok(SyncBenchReport {
        scores,
        frames_delivered: delivered,
        force_samples,
        latch_error,
    })
}

/// The indenter over the sensor centre, pressing it: the z motor and its two positions.
struct Presses {
    z: Arc<SimMotor>,
    above: Millimetres,
    pressed: Millimetres,
}

impl Presses {
    /// Sends the stages (fast) over the sensor centre with the indenter just above the gel, and
    /// gives z its pressing speed; `depth_mm` is how deep a press goes.
    fn over_centre(bench: &Bench, depth_mm: f64) -> Presses {
        let (cx, cy) = (Millimetres(0.0), Millimetres(0.0));
        let above = bench.z_for_depth(cx, cy, Millimetres(-0.3));
        let pressed = bench.z_for_depth(cx, cy, Millimetres(depth_mm));
        let fast = Kinematics {
            velocity: MillimetresPerSecond(20.0),
            acceleration: MillimetresPerSecondSquared(200.0),
        };
        let (x, y) = bench.stage_xy_for(cx, cy);
        let t0 = HostTime::now();
        for (motor, target) in [
            (bench.motor_x(), x),
            (bench.motor_y(), y),
            (bench.motor_z(), above),
        ] {
            motor.set_kinematics(fast);
            let target = Millimetres(target.0 - motor.zero_offset().0);
            motor.move_to(t0, target);
        }
        let z = bench.motor_z();
        z.set_kinematics(Kinematics {
            velocity: MillimetresPerSecond(5.0),
            acceleration: MillimetresPerSecondSquared(100.0),
        });
        Presses { z, above, pressed }
    }

    /// Starts z down into the gel (`down`) or back up above it.
    fn move_z(&self, down: bool) {
        let mm = if down { self.pressed } else { self.above };
        self.z
            .move_to(HostTime::now(), Millimetres(mm.0 - self.z.zero_offset().0));
    }
}

/// The simulated Mini40 behind the simulated DAQ (its clock drifting and its blocks arriving
/// with jitter as configured, the strobe from `schedule`) and the `.cal` math.
fn force_sensor(
    config: &SyncBenchConfig,
    bench: &Arc<Bench>,
    bench_config: &BenchConfig,
    schedule: &Arc<ExposureSchedule>,
    sink: &Arc<dyn TruthSink>,
) -> Result<CalibratedSensor<SimDaq>, SyncBenchError> {
    let load: Arc<dyn LoadSource> = bench.clone();
    let ft = SimFtSensor::new(load, bench_config.ft_noise).with_truth(sink.clone());
    let cal = Calibration::parse(SIM_CAL, "simulated Mini40 (built-in .cal)")
        .map_err(|e| SyncBenchError::new("F/T calibration", e))?;
    let daq_config = SimDaqConfig {
        clock_drift_ppm: config.force_drift_ppm,
        arrival_jitter_ms: config.arrival_jitter_ms,
        seed: config.seed.wrapping_add(4),
        ..SimDaqConfig::default()
    };
    let daq = SimDaq::new(daq_config, &cal, Box::new(ft))
        .map_err(|e| SyncBenchError::new("simulated DAQ", e))?
        .with_strobe(schedule.clone())
        .with_truth(sink.clone());
    Ok(CalibratedSensor::new(daq, cal))
}

/// The simulated camera (blank frames, drifting clock, jittered arrivals, no drops) exposing on
/// `schedule`.
fn camera(
    config: &SyncBenchConfig,
    bench: &Arc<Bench>,
    schedule: Arc<ExposureSchedule>,
    sink: &Arc<dyn TruthSink>,
) -> SimCamera {
    let camera_config = SimCameraConfig {
        seed: config.seed.wrapping_add(2),
        clock_drift_ppm: config.camera_drift_ppm,
        arrival_jitter_ms: config.arrival_jitter_ms,
        readout_ms: config.readout_ms,
        drop_probability: 0.0,
        ..SimCameraConfig::default()
    };
    let scene: Arc<dyn SceneSource> = bench.clone();
    SimCamera::new(camera_config, scene, Box::new(Blank))
        .with_schedule(schedule)
        .with_truth(sink.clone())
}

/// Feeds the force samples and frames (`streams`) to every lane for the warm-up and the scored
/// time, pressing every half period, and labels what the lanes can; the number of frames
/// delivered while scoring.
fn label_while_pressing(
    config: &SyncBenchConfig,
    presses: &Presses,
    streams: (&Receiver<ForceSample>, &Receiver<Frame>),
    lanes: &mut [Lane],
    labelled: &mut Vec<Labelled>,
) -> usize {
    let (samples, frames) = streams;
    let started = Instant::now();
    let scored_from = started + Duration::from_secs_f64(config.warm_up_s.max(0.0));
    let end = scored_from + Duration::from_secs_f64(config.seconds.max(0.0));
    let half = Duration::from_secs_f64(config.press_period_s.max(0.2) / 2.0);
    let mut next_move = started + half;
    let mut down = false;
    let mut delivered = 0;
    while Instant::now() < end {
        if Instant::now() >= next_move {
            down = !down;
            presses.move_z(down);
            next_move += half;
        }
        select! {
            recv(samples) -> s => {
                if let Ok(s) = s {
                    feed_sample(lanes, s);
                }
            }
            recv(frames) -> f => {
                if let Ok(frame) = f {
                    let scored = Instant::now() >= scored_from;
                    delivered += usize::from(scored);
                    feed_frame(lanes, &frame, scored);
                }
            }
            default(Duration::from_millis(20)) => {}
        }
        for (i, lane) in lanes.iter_mut().enumerate() {
            lane.poll(i, false, labelled);
        }
    }
    delivered
}

/// Stops the camera stream, lets the force stream cover the last windows and stops it, feeding
/// the lanes every sample left, then labels or gives up on every frame still pending; the
/// number of force samples received.
fn stop_streams(
    cameras: CameraStream,
    stream: ForceStream,
    samples: &Receiver<ForceSample>,
    lanes: &mut [Lane],
    labelled: &mut Vec<Labelled>,
) -> Result<u64, SyncBenchError> {
    cameras
        .stop()
        .map_err(|e| SyncBenchError::new("camera stream", e))?;
    let tail = Instant::now() + Duration::from_millis(100);
    while Instant::now() < tail {
        if let Ok(s) = samples.recv_timeout(Duration::from_millis(10)) {
            feed_sample(lanes, s);
        }
    }
    let force_samples = stream.monitor().stats().received;
    stream
        .stop()
        .map_err(|e| SyncBenchError::new("force stream", e))?;
    while let Ok(s) = samples.try_recv() {
        feed_sample(lanes, s);
    }
    for (i, lane) in lanes.iter_mut().enumerate() {
        lane.poll(i, true, labelled);
    }
    Ok(force_samples)
}

/// Gives a force sample to every lane's labeler.
fn feed_sample(lanes: &mut [Lane], s: ForceSample) {
    for lane in lanes.iter_mut() {
        lane.labeler.push_sample(&s);
    }
}

/// Shows a frame to every lane's labeler, and queues it for labelling if it is `scored`.
fn feed_frame(lanes: &mut [Lane], frame: &Frame, scored: bool) {
    for lane in lanes.iter_mut() {
        lane.labeler.observe_frame(frame);
        if scored {
            lane.pending.push_back(frame.clone());
        }
    }
}

fn rms(v: &[f64]) -> f64 {
    (v.iter().map(|e| e * e).sum::<f64>() / v.len().max(1) as f64).sqrt()
}

/// One labelled frame against its truth: (label time error in ns, labelled Fz, true Fz).
type Row = (f64, f64, Option<f64>);

/// The ground truth the labels are scored against.
struct ScoringTruth {
    /// The DAQ's first sample, true host time.
    daq_start: HostTime,
    /// The DAQ's true sample period, ns.
    sample_ns: f64,
    /// Every frame's truth by its exposure-start device timestamp.
    frames: HashMap<u64, FrameTruth>,
    /// The bench's true wrench over time: (host time ns, wrench).
    bench: Vec<(f64, [f64; 6])>,
}

impl ScoringTruth {
    /// The truth from the records of a run, which must hold the DAQ clock.
    fn from_records(records: &[TruthRecord]) -> Result<ScoringTruth, SyncBenchError> {
        let daq = records
            .iter()
            .rev()
            .find_map(|r| match r {
                TruthRecord::DaqClock {
                    start,
                    rate_hz,
                    drift_ppm,
                } => Some((*start, *rate_hz, *drift_ppm)),
                _ => None,
            })
            .ok_or_else(|| SyncBenchError::new("ground truth", "no DAQ clock recorded"))?;
        let frames = records
            .iter()
            .filter_map(|r| match r {
                TruthRecord::Frame(f) => Some((f.exposure_start_ticks, *f)),
                _ => None,
            })
            .collect();
        let bench = records
            .iter()
            .filter_map(|r| match r {
                TruthRecord::Bench { truth, wrench } => Some((truth.t.0 as f64, wrench.to_array())),
                _ => None,
            })
            .collect();
        Ok(ScoringTruth {
            daq_start: daq.0,
            sample_ns: 1e9 / (daq.1 * (1.0 + daq.2 * 1e-6)),
            frames,
            bench,
        })
    }

    /// The true host time (ns) of a position in the force stream's sample index.
    fn true_host(&self, ticks: f64) -> f64 {
        self.daq_start.0 as f64 + ticks * self.sample_ns
    }

    /// The true Fz averaged over a frame's true exposure window.
    fn true_fz(&self, f: &FrameTruth) -> Option<f64> {
        mean_over(
            &self.bench,
            f.exposure_start.0 as f64,
            f.exposure_end.0 as f64,
        )
        .ok()
        .map(|m| m.mean[2])
    }

    /// The frame labelled `label` (by its device timestamp `ts`) against its truth, if it has
    /// one.
    fn row(&self, ts: u64, label: &ExposureLabel) -> Option<Row> {
        let f = self.frames.get(&ts)?;
        let mid_ticks = 0.5 * (label.window_ticks[0] + label.window_ticks[1]);
        let mid_true = 0.5 * (f.exposure_start.0 as f64 + f.exposure_end.0 as f64);
        Some((
            self.true_host(mid_ticks) - mid_true,
            label.mean.mean[2],
            self.true_fz(f),
        ))
    }
}

/// Every method's score from the ground truth `records`.
fn score(
    records: &[TruthRecord],
    lanes: &[Lane],
    labelled: &[Labelled],
) -> Result<Vec<MethodScore>, SyncBenchError> {
    let truth = ScoringTruth::from_records(records)?;
    Ok(lanes
        .iter()
        .enumerate()
        .map(|(i, lane)| {
            let rows: Vec<Row> = labelled
                .iter()
                .filter(|l| l.0 == i)
                .filter_map(|(_, ts, label)| truth.row(*ts, label))
                .collect();
            method_score(lane, &rows)
        })
        .collect())
}

/// A method's score from its lane and its labelled frames against their truth: Fz is tared by
/// the mean label of the frames with no true contact and scored over the frames in contact.
fn method_score(lane: &Lane, rows: &[Row]) -> MethodScore {
    let errors: Vec<f64> = rows.iter().map(|r| r.0).collect();
    let free: Vec<f64> = rows
        .iter()
        .filter(|r| r.2 == Some(0.0))
        .map(|r| r.1)
        .collect();
    let tare = free.iter().sum::<f64>() / free.len().max(1) as f64;
    let fz_errors: Vec<f64> = rows
        .iter()
        .filter_map(|r| match r.2 {
            Some(t) if in_contact(Newtons(t)) => Some(r.1 - tare - t),
            _ => None,
        })
        .collect();
    MethodScore {
        method: lane.labeler.method(),
        frames: rows.len(),
        unlabelled: lane.unlabelled,
        first_unlabelled: lane.why.clone(),
        time_rms_ns: rms(&errors),
        time_max_ns: errors.iter().fold(0.0, |m, e| m.max(e.abs())),
        time_mean_ns: errors.iter().sum::<f64>() / errors.len().max(1) as f64,
        fz_frames: fz_errors.len(),
        fz_rms_n: rms(&fz_errors),
        fz_max_n: fz_errors.iter().fold(0.0, |m, e| m.max(e.abs())),
        estimated_error_ns: lane.labeler.estimated_error_ns(),
    }
}
