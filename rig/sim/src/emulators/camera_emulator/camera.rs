//! [`SimCamera`]: the simulated camera on threads. A timing thread opens exposures (free run or
//! software trigger) and announces them on the [`ExposureSchedule`]; a render thread renders the
//! scene in the middle of each exposure; a delivery thread hands frames to the host after the
//! readout and jitter. See [`super`] for the model.

use super::frame::{finish_frame, render_format};
use super::timing::{DeviceClock, ExposureSchedule, ExposureWindow, TriggerInput};
use crate::ground_truth::records::{FrameFate, FrameTruth, TruthRecord, TruthSink};
use crate::physics::ft_sensor::mix_seed;
use crate::scene::{FrameRenderer, SceneSource};
use crossbeam_channel::{bounded, unbounded, Receiver, RecvTimeoutError, Sender, TrySendError};
use fringe_rig::HostTime;
use fringe_rig::Slip;
use fringe_rig::{
    Camera, CameraError, CameraInfo, CameraSettings, Frame, Roi, TimestampLatch, TriggerMode,
};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::Duration;

/// Exposures that can wait for the renderer (besides the one being rendered): 160 ms at 50 fps.
/// Frames are matched to their force by clock, not by arrival, so the extra delay a waiting frame
/// takes costs nothing but that delay. On an idle 2-core machine a whole scan at 50 fps delays no
/// frame by more than 10 ms after its readout; with two other busy processes taking the cores the
/// renderer fell up to 90 ms behind and 3 waiting exposures (60 ms) lost a frame (BENCHMARKS.md,
/// "Recording"). A real camera has no renderer to wait for.
pub const FRAME_MEMORY: usize = 8;
/// How the simulated camera behaves beyond its [`CameraSettings`].
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default)]
pub struct SimCameraConfig {
    /// Seed of drops, jitter and latch delays.
    pub seed: u64,
    pub serial: String,
    /// Device clock reading at host time 0, s (the camera has been up a while).
    pub clock_offset_s: f64,
    /// Device clock rate error, ppm.
    pub clock_drift_ppm: f64,
    /// Exposure end to host arrival, ms (sensor readout and USB transfer).
    pub readout_ms: f64,
    /// Extra arrival delay, uniform in [0, this], ms.
    pub arrival_jitter_ms: f64,
    /// Probability that a frame is lost on the way (its id is skipped).
    pub drop_probability: f64,
    /// Fastest frame rate the camera can run, Hz.
    pub max_frame_rate_hz: f64,
    /// Trigger to exposure start (Basler's exposure start delay), us.
    pub trigger_latency_us: f64,
    /// A hardware trigger line's response time, added to the delay for a line trigger, us.
    pub line_response_us: f64,
    /// Round trip of a timestamp latch exchange, us.
    pub latch_round_trip_us: f64,
    /// Frames the host side buffers before dropping.
    pub host_buffers: usize,
}

impl Default for SimCameraConfig {
    fn default() -> Self {
        SimCameraConfig {
            seed: 1,
            serial: "SIM40000001".into(),
            clock_offset_s: 4321.0,
            clock_drift_ppm: 25.0,
            readout_ms: 5.0,
            arrival_jitter_ms: 3.0,
            drop_probability: 0.0,
            max_frame_rate_hz: 160.0,
            trigger_latency_us: 20.0,
            // Basler ace manuals give 1.5 us as an input line's response time in their example.
            line_response_us: 1.5,
            latch_round_trip_us: 150.0,
            host_buffers: 16,
        }
    }
}

/// Counters of a simulated camera since `start`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct SimCameraStats {
    pub exposures: u64,
    pub delivered: u64,
    /// Lost at random (drop probability).
    pub dropped: u64,
    /// Lost because the renderer was busy.
    pub render_busy: u64,
    /// Lost because the host buffers were full.
    pub no_buffer: u64,
    pub triggers_ignored: u64,
}

struct Job {
    window: ExposureWindow,
    start_ticks: u64,
    end_ticks: u64,
}

struct Shared {
    config: SimCameraConfig,
    settings: CameraSettings,
    clock: DeviceClock,
    schedule: Arc<ExposureSchedule>,
    truth: Option<Arc<dyn TruthSink>>,
    stats: Arc<Mutex<SimCameraStats>>,
    stop: Arc<AtomicBool>,
    name: String,
}

impl Shared {
    fn stats(&self) -> std::sync::MutexGuard<'_, SimCameraStats> {
        self.stats.lock().unwrap_or_else(|e| e.into_inner())
    }

    fn exposure_ticks(&self) -> u64 {
        (self.settings.exposure.0 * 1e3).round().max(1.0) as u64
    }

    fn job(&self, id: u64, start_ticks: u64) -> Job {
        let end_ticks = start_ticks + self.exposure_ticks();
        Job {
            window: ExposureWindow {
                id,
                start: self.clock.host_at(start_ticks),
                end: self.clock.host_at(end_ticks),
            },
            start_ticks,
            end_ticks,
        }
    }

    fn record(&self, job: &Job, arrival: Option<HostTime>, fate: FrameFate, seen: Seen) {
        let (contact, shear) = seen;
        if let Some(sink) = &self.truth {
            sink.record(TruthRecord::Frame(FrameTruth {
                id: job.window.id,
                exposure_start: job.window.start,
                exposure_end: job.window.end,
                exposure_start_ticks: job.start_ticks,
                exposure_end_ticks: job.end_ticks,
                arrival,
                fate,
                contact,
                shear,
            }));
        }
    }
}

/// Sleeps until host time `t`; false if `stop` was raised meanwhile.
fn sleep_until(t: HostTime, stop: &AtomicBool) -> bool {
    loop {
        if stop.load(Ordering::Relaxed) {
            return false;
        }
        let now = HostTime::now();
        if now >= t {
            return true;
        }
        std::thread::sleep(t.since(now).min(Duration::from_millis(5)));
    }
}
struct Running {
    stop: Arc<AtomicBool>,
    frames: Receiver<Frame>,
    triggers: Option<Sender<Job>>,
    shared: Arc<Shared>,
    timing: JoinHandle<()>,
    render: JoinHandle<Box<dyn FrameRenderer>>,
    delivery: JoinHandle<()>,
    next_id: Arc<Mutex<(u64, Option<HostTime>)>>,
}

/// The simulated camera.
pub struct SimCamera {
    config: SimCameraConfig,
    settings: CameraSettings,
    clock: DeviceClock,
    scene: Arc<dyn SceneSource>,
    renderer: Option<Box<dyn FrameRenderer>>,
    width: u32,
    height: u32,
    schedule: Arc<ExposureSchedule>,
    truth: Option<Arc<dyn TruthSink>>,
    stats: Arc<Mutex<SimCameraStats>>,
    latch_rng: StdRng,
    running: Option<Running>,
    /// Frames delivered before the last stop and not fetched yet.
    leftover: Option<Receiver<Frame>>,
    /// What is wired to a trigger line ("Line1").
    trigger_input: Option<(String, Arc<dyn TriggerInput>)>,
}

impl SimCamera {
    /// A camera looking at `scene` through `renderer`, with the default settings (free run, 50 Hz,
    /// 2000 us, RGB8 full frame).
    pub fn new(
        config: SimCameraConfig,
        scene: Arc<dyn SceneSource>,
        renderer: Box<dyn FrameRenderer>,
    ) -> SimCamera {
        let clock = DeviceClock {
            reference: HostTime(0),
            ticks_at_ref: (config.clock_offset_s.max(0.0) * 1e9) as u64,
            drift_ppm: config.clock_drift_ppm,
        };
        SimCamera {
            latch_rng: StdRng::seed_from_u64(mix_seed(config.seed, 0x1a7c)),
            width: renderer.width(),
            height: renderer.height(),
            config,
            settings: CameraSettings::default(),
            clock,
            scene,
            renderer: Some(renderer),
            schedule: ExposureSchedule::new(),
            truth: None,
            stats: Arc::new(Mutex::new(SimCameraStats::default())),
            running: None,
            leftover: None,
            trigger_input: None,
        }
    }

    /// Wires `input` to the camera's trigger line `line` ("Line1"): with the trigger mode set to
    /// that line, each rising edge starts an exposure.
    pub fn with_trigger_input(mut self, line: &str, input: Arc<dyn TriggerInput>) -> SimCamera {
        self.trigger_input = Some((line.to_string(), input));
        self
    }

    /// Shares an exposure schedule (give the same one to the DAQ emulator for the strobe).
    pub fn with_schedule(mut self, schedule: Arc<ExposureSchedule>) -> SimCamera {
        self.schedule = schedule;
        self
    }

    /// Records every exposure and the clock into `sink`.
    pub fn with_truth(mut self, sink: Arc<dyn TruthSink>) -> SimCamera {
        self.truth = Some(sink);
        self
    }

    /// The exposure schedule this camera writes.
    pub fn schedule(&self) -> Arc<ExposureSchedule> {
        self.schedule.clone()
    }

    /// The device clock (ground truth).
    pub fn clock(&self) -> DeviceClock {
        self.clock
    }

    /// Counters since the last start.
    pub fn stats(&self) -> SimCameraStats {
        *self.stats.lock().unwrap_or_else(|e| e.into_inner())
    }

    pub fn settings(&self) -> &CameraSettings {
        &self.settings
    }

    fn name(&self) -> String {
        format!("sim {}", self.config.serial)
    }

    fn feature(&self, feature: &str, message: String) -> CameraError {
        CameraError::Feature {
            camera: self.name(),
            feature: feature.into(),
            message,
        }
    }

    /// What the threads of an acquisition share, with its `stop` flag.
    fn shared(&self, stop: Arc<AtomicBool>) -> Arc<Shared> {
        Arc::new(Shared {
            config: self.config.clone(),
            settings: self.settings.clone(),
            clock: self.clock,
            schedule: self.schedule.clone(),
            truth: self.truth.clone(),
            stats: self.stats.clone(),
            stop,
            name: self.name(),
        })
    }

    /// Records the device clock into the ground truth, if any.
    fn record_clock(&self) {
        if let Some(sink) = &self.truth {
            sink.record(TruthRecord::CameraClock {
                t: HostTime::now(),
                ticks_at_ref: self.clock.ticks_at_ref,
                reference: self.clock.reference,
                drift_ppm: self.clock.drift_ppm,
            });
        }
    }

    /// Starts a thread of this camera named `name` running `f`.
    fn spawn<T: Send + 'static>(
        &self,
        name: &str,
        f: impl FnOnce() -> T + Send + 'static,
    ) -> Result<JoinHandle<T>, CameraError> {
        std::thread::Builder::new()
            .name(name.into())
            .spawn(f)
            .map_err(|source| CameraError::Io {
                camera: self.name(),
                source,
            })
    }

    /// Starts the timing thread sending exposures to `render`: in free run it opens them at
    /// the frame rate, noting the next id in `next_id`; otherwise it waits for the software
    /// triggers sent on the sender returned.
    fn spawn_timing(
        &self,
        shared: Arc<Shared>,
        render: Sender<Job>,
        next_id: Arc<Mutex<(u64, Option<HostTime>)>>,
    ) -> Result<(Option<Sender<Job>>, JoinHandle<()>), CameraError> {
        if self.settings.trigger == TriggerMode::FreeRun {
            let timing = self.spawn("sim-camera-timing", move || {
                timing_free_run(shared, render, next_id)
            })?;
            Ok((None, timing))
        } else if let (TriggerMode::Hardware(_), Some((_, input))) =
            (&self.settings.trigger, &self.trigger_input)
        {
            let input = input.clone();
            let timing = self.spawn("sim-camera-timing", move || {
                timing_hardware(shared, render, next_id, input)
            })?;
            Ok((None, timing))
        } else {
            let (trig_tx, trig_rx) = unbounded::<Job>();
            let timing = self.spawn("sim-camera-timing", move || {
                timing_triggered(shared, render, trig_rx)
            })?;
            Ok((Some(trig_tx), timing))
        }
    }

    fn roi(&self) -> Roi {
        self.settings.roi.unwrap_or(Roi {
            x: 0,
            y: 0,
            width: self.width,
            height: self.height,
        })
    }
}

fn timing_free_run(
    shared: Arc<Shared>,
    render: Sender<Job>,
    next_id: Arc<Mutex<(u64, Option<HostTime>)>>,
) {
    let period_ticks = (1e9 / shared.settings.frame_rate.0).round() as u64;
    let first = shared
        .clock
        .ticks_at(HostTime(HostTime::now().0 + 2_000_000));
    let mut rng = StdRng::seed_from_u64(mix_seed(shared.config.seed, 0xd40b));
    let job_for = |k: u64| shared.job(k, first + k * period_ticks);
    shared.schedule.push(job_for(0).window);
    shared.schedule.push(job_for(1).window);
    let mut k = 0;
    loop {
        let job = job_for(k);
        // Windows are published two periods ahead, so the strobe never misses a start even when
        // this thread wakes late.
        shared.schedule.push(job_for(k + 2).window);
        if let Ok(mut n) = next_id.lock() {
            *n = (k + 1, Some(job.window.start));
        }
        if !sleep_until(job.window.end, &shared.stop) {
            return;
        }
        dispatch(&shared, &render, job, &mut rng);
        k += 1;
    }
}

/// Exposes on the rising edges of the trigger line: each window is published 2 ms before its
/// edge (the edges are known ahead), then handed to the renderer when it ends.
fn timing_hardware(
    shared: Arc<Shared>,
    render: Sender<Job>,
    next_id: Arc<Mutex<(u64, Option<HostTime>)>>,
    input: Arc<dyn TriggerInput>,
) {
    let mut rng = StdRng::seed_from_u64(mix_seed(shared.config.seed, 0xd40b));
    let delay_ns =
        ((shared.config.trigger_latency_us + shared.config.line_response_us).max(0.0) * 1e3) as u64;
    let min_gap_ns = (1e9 / shared.config.max_frame_rate_hz.max(1e-3)) as u64;
    let mut after = HostTime::now();
    let mut id = 0;
    let mut last_start: Option<HostTime> = None;
    loop {
        if shared.stop.load(Ordering::Relaxed) {
            return;
        }
        let Some(edge) = input.next_edge(after) else {
            std::thread::sleep(Duration::from_millis(1));
            after = HostTime::now();
            continue;
        };
        if !sleep_until(HostTime(edge.0.saturating_sub(2_000_000)), &shared.stop) {
            return;
        }
        after = HostTime(edge.0 + 1);
        let start = HostTime(edge.0 + delay_ns);
        if last_start.is_some_and(|last| start.0 < last.0 + min_gap_ns) {
            shared.stats().triggers_ignored += 1;
            continue;
        }
        last_start = Some(start);
        let job = shared.job(id, shared.clock.ticks_at(start));
        shared.schedule.push(job.window);
        id += 1;
        if let Ok(mut n) = next_id.lock() {
            *n = (id, Some(job.window.start));
        }
        if !sleep_until(job.window.end, &shared.stop) {
            return;
        }
        dispatch(&shared, &render, job, &mut rng);
    }
}

fn timing_triggered(shared: Arc<Shared>, render: Sender<Job>, triggers: Receiver<Job>) {
    let mut rng = StdRng::seed_from_u64(mix_seed(shared.config.seed, 0xd40b));
    loop {
        if shared.stop.load(Ordering::Relaxed) {
            return;
        }
        match triggers.recv_timeout(Duration::from_millis(20)) {
            Ok(job) => {
                if !sleep_until(job.window.end, &shared.stop) {
                    return;
                }
                dispatch(&shared, &render, job, &mut rng);
            }
            Err(RecvTimeoutError::Timeout) => {}
            Err(RecvTimeoutError::Disconnected) => return,
        }
    }
}

fn dispatch(shared: &Shared, render: &Sender<Job>, job: Job, rng: &mut StdRng) {
    shared.stats().exposures += 1;
    if rng.gen::<f64>() < shared.config.drop_probability {
        shared.stats().dropped += 1;
        shared.record(&job, None, FrameFate::Dropped, (None, None));
        return;
    }
    match render.try_send(job) {
        Ok(()) => {}
        Err(TrySendError::Full(job)) | Err(TrySendError::Disconnected(job)) => {
            shared.stats().render_busy += 1;
            shared.record(&job, None, FrameFate::RenderBusy, (None, None));
        }
    }
}

/// What an exposure saw at its middle, for the ground truth: the contact (normal force, x, y)
/// and its tangential force with how it holds.
type Seen = (Option<(f64, f64, f64)>, Option<([f64; 2], Slip)>);

struct Rendered {
    job: Job,
    frame: Frame,
    due: HostTime,
    seen: Seen,
}

fn render_loop(
    shared: Arc<Shared>,
    scene: Arc<dyn SceneSource>,
    mut renderer: Box<dyn FrameRenderer>,
    jobs: Receiver<Job>,
    out: Sender<Rendered>,
    roi: Roi,
) -> Box<dyn FrameRenderer> {
    let mut image = Vec::new();
    let width = renderer.width();
    let format = render_format(&shared.settings);
    while let Ok(job) = jobs.recv() {
        if shared.stop.load(Ordering::Relaxed) {
            break;
        }
        let mid = HostTime(job.window.start.0 + (job.window.end.0 - job.window.start.0) / 2);
        let scene_now = scene.scene_at(mid);
        renderer.render_as(&scene_now, job.window.id, format, &mut image);
        let expected = (width * renderer.height()) as usize * format.bytes_per_pixel();
        image.resize(expected, 0);
        let data = finish_frame(&mut image, width, &shared.settings, roi);
        let mut jitter_rng =
            StdRng::seed_from_u64(mix_seed(shared.config.seed, job.window.id ^ 0x717e));
        let jitter_ns = shared.config.arrival_jitter_ms.max(0.0) * 1e6 * jitter_rng.gen::<f64>();
        let due = HostTime(
            job.window.end.0 + (shared.config.readout_ms.max(0.0) * 1e6 + jitter_ns) as u64,
        );
        let frame = Frame {
            id: job.window.id,
            device_timestamp: job.start_ticks,
            host_arrival: due,
            width: roi.width,
            height: roi.height,
            format: shared.settings.pixel_format,
            data,
        };
        let contact = scene_now.contact.map(|c| (c.force.0, c.x.0, c.y.0));
        let shear = scene_now.contact.map(|c| {
            let q = c.shear.map_or([0.0; 2], |s| {
                let (sin, cos) = s.direction_deg.to_radians().sin_cos();
                [s.force.0 * cos, s.force.0 * sin]
            });
            (q, c.slip_state())
        });
        if out
            .send(Rendered {
                job,
                frame,
                due,
                seen: (contact, shear),
            })
            .is_err()
        {
            break;
        }
    }
    renderer
}

fn delivery_loop(shared: Arc<Shared>, rendered: Receiver<Rendered>, frames: Sender<Frame>) {
    while let Ok(mut r) = rendered.recv() {
        if !sleep_until(r.due, &shared.stop) {
            return;
        }
        let arrival = HostTime::now();
        r.frame.host_arrival = arrival;
        match frames.try_send(r.frame) {
            Ok(()) => {
                shared.stats().delivered += 1;
                shared.record(&r.job, Some(arrival), FrameFate::Delivered, r.seen);
            }
            Err(_) => {
                shared.stats().no_buffer += 1;
                shared.record(&r.job, None, FrameFate::NoBuffer, r.seen);
            }
        }
    }
}

impl Camera for SimCamera {
    fn info(&self) -> CameraInfo {
        CameraInfo {
            vendor: "fringe".into(),
            model: "daA1920-160uc (simulated)".into(),
            serial: self.config.serial.clone(),
            id: format!("sim-{}", self.config.serial),
            tick_frequency: 1_000_000_000,
        }
    }

    fn configure(&mut self, settings: &CameraSettings) -> Result<(), CameraError> {
        if self.running.is_some() {
            return Err(CameraError::Device {
                camera: self.name(),
                message: "cannot change settings while acquiring; stop first".into(),
            });
        }
        let rate = settings.frame_rate.0;
        if !(rate > 0.0 && rate <= self.config.max_frame_rate_hz) {
            return Err(self.feature(
                "AcquisitionFrameRate",
                format!(
                    "{rate} Hz is outside 0..{} Hz",
                    self.config.max_frame_rate_hz
                ),
            ));
        }
        let exposure = settings.exposure.0;
        if !(exposure > 0.0 && exposure * 1e-6 < 1.0 / rate) {
            return Err(self.feature(
                "ExposureTime",
                format!(
                    "{exposure} us must be positive and shorter than the frame period at {rate} Hz"
                ),
            ));
        }
        if let TriggerMode::Hardware(line) = &settings.trigger {
            match &self.trigger_input {
                Some((wired, _)) if wired == line => {}
                Some((wired, _)) => {
                    return Err(self.feature(
                        "TriggerSource",
                        format!("{line}: nothing is wired to it (the trigger is on {wired})"),
                    ))
                }
                None => {
                    return Err(self.feature(
                        "TriggerSource",
                        format!("{line}: nothing is wired to the simulated camera's trigger input; use free run or software trigger"),
                    ))
                }
            }
        }
        if let Some(roi) = settings.roi {
            if roi.width == 0
                || roi.height == 0
                || roi.x + roi.width > self.width
                || roi.y + roi.height > self.height
            {
                return Err(self.feature(
                    "Width/Height/OffsetX/OffsetY",
                    format!(
                        "ROI {roi:?} does not fit the {}x{} sensor",
                        self.width, self.height
                    ),
                ));
            }
        }
        self.settings = settings.clone();
        Ok(())
    }

    fn start(&mut self) -> Result<(), CameraError> {
        if self.running.is_some() {
            return Ok(());
        }
        let Some(renderer) = self.renderer.take() else {
            return Err(CameraError::Device {
                camera: self.name(),
                message: "renderer lost after a failed stop; create the camera again".into(),
            });
        };
        *self.stats.lock().unwrap_or_else(|e| e.into_inner()) = SimCameraStats::default();
        self.leftover = None;
        let stop = Arc::new(AtomicBool::new(false));
        let shared = self.shared(stop.clone());
        self.record_clock();
        let (job_tx, job_rx) = bounded::<Job>(FRAME_MEMORY);
        let (rendered_tx, rendered_rx) = unbounded::<Rendered>();
        let (frame_tx, frame_rx) = bounded::<Frame>(self.config.host_buffers.max(1));
        let roi = self.roi();
        let next_id = Arc::new(Mutex::new((0u64, None)));
        let scene = self.scene.clone();
        let s = shared.clone();
        let render = self.spawn("sim-camera-render", move || {
            render_loop(s, scene, renderer, job_rx, rendered_tx, roi)
        })?;
        let s = shared.clone();
        let delivery = self.spawn("sim-camera-delivery", move || {
            delivery_loop(s, rendered_rx, frame_tx)
        })?;
        let (triggers, timing) = self.spawn_timing(shared.clone(), job_tx, next_id.clone())?;
        self.running = Some(Running {
            stop,
            frames: frame_rx,
            triggers,
            shared,
            timing,
            render,
            delivery,
            next_id,
        });
        Ok(())
    }

    fn trigger(&mut self) -> Result<(), CameraError> {
        let name = self.name();
        let Some(run) = &self.running else {
            return Err(CameraError::Device {
                camera: name,
                message: "trigger before start; start acquisition first".into(),
            });
        };
        let Some(triggers) = &run.triggers else {
            return Err(CameraError::Feature {
                camera: name,
                feature: "TriggerSoftware".into(),
                message: "needs TriggerMode software (the camera is in free run)".into(),
            });
        };
        let shared = &run.shared;
        let min_gap_ns = (1e9 / shared.config.max_frame_rate_hz.max(1e-3)) as u64;
        let mut ids = run.next_id.lock().unwrap_or_else(|e| e.into_inner());
        // Read the clock and publish the window under the schedule's lock (see ExposureSchedule).
        let job = {
            let mut q = shared.schedule.lock();
            let now = HostTime::now();
            let start = HostTime(now.0 + (shared.config.trigger_latency_us.max(0.0) * 1e3) as u64);
            if ids.1.is_some_and(|last| start.0 < last.0 + min_gap_ns) {
                drop(q);
                shared.stats().triggers_ignored += 1;
                return Ok(());
            }
            let job = shared.job(ids.0, shared.clock.ticks_at(start));
            q.push_back(job.window);
            job
        };
        *ids = (ids.0 + 1, Some(job.window.start));
        triggers.send(job).map_err(|_| CameraError::Device {
            camera: shared.name.clone(),
            message: "acquisition thread ended; stop and start again".into(),
        })
    }

    fn next_frame(&mut self, timeout: Duration) -> Result<Option<Frame>, CameraError> {
        let Some(run) = &self.running else {
            // After a stop, frames already delivered can still be fetched.
            if let Some(left) = &self.leftover {
                return Ok(left.try_recv().ok());
            }
            return Err(CameraError::Device {
                camera: self.name(),
                message: "no acquisition running; call start first".into(),
            });
        };
        match run.frames.recv_timeout(timeout) {
            Ok(f) => Ok(Some(f)),
            Err(RecvTimeoutError::Timeout) => Ok(None),
            Err(RecvTimeoutError::Disconnected) => Err(CameraError::Device {
                camera: self.name(),
                message: "acquisition threads ended; stop and start again".into(),
            }),
        }
    }

    fn stop(&mut self) -> Result<(), CameraError> {
        let Some(run) = self.running.take() else {
            return Ok(());
        };
        run.stop.store(true, Ordering::Relaxed);
        drop(run.triggers);
        self.leftover = Some(run.frames);
        let timing_ok = run.timing.join().is_ok();
        let renderer = run.render.join();
        let delivery_ok = run.delivery.join().is_ok();
        match renderer {
            Ok(r) => self.renderer = Some(r),
            Err(_) => {
                return Err(CameraError::Device {
                    camera: self.name(),
                    message: "the renderer panicked; create the camera again".into(),
                })
            }
        }
        if !(timing_ok && delivery_ok) {
            return Err(CameraError::Device {
                camera: self.name(),
                message: "an acquisition thread panicked".into(),
            });
        }
        Ok(())
    }

    fn latch_timestamp(&mut self) -> Result<TimestampLatch, CameraError> {
        let host_before = HostTime::now();
        let u: f64 = self.latch_rng.gen::<f64>();
        let round_trip = self.config.latch_round_trip_us.max(0.0) * (0.5 + u);
        std::thread::sleep(Duration::from_nanos((round_trip * 1e3) as u64));
        let host_after = HostTime::now();
        let v: f64 = self.latch_rng.gen::<f64>();
        let latch = HostTime(host_before.0 + (v * (host_after.0 - host_before.0) as f64) as u64);
        Ok(TimestampLatch {
            host_before,
            device_ticks: self.clock.ticks_at(latch),
            host_after,
        })
    }
}

impl Drop for SimCamera {
    fn drop(&mut self) {
        let _ = Camera::stop(self);
    }
}
