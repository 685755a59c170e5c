//! The running stream (see the namespace): the camera read on its own thread (timestamp latches
//! taken between frames), a worker that places each frame's exposure by the camera clock, runs
//! the model on it and sends its messages out, an image thread for the lower-rate pictures, and
//! on the simulated bench the robot.
//!
//! Frames wait for the worker in arrival order; when more than [`BACKLOG_FRAMES`] wait, the
//! oldest is skipped and counted (a robot wants the newest contact state, not a growing delay).

use crate::rig::error::RigError;
use crate::rig::file::RigConfig;
use crate::rig::open::OpenCamera;
use crate::stream::health_watch::{HealthWatch, Said, StreamHealth, FREE_CONFIDENCE};
use crate::stream::latency::{figures, FrameLatency, LatencyFigures};
use crate::stream::outlets::{put_one, McapOutlet, Messages, Published, Ros2Outlet};
use crate::stream::request::StreamRequest;
use crate::stream::stream_error::StreamError;
use fringe_calibration::Profile;
use fringe_rig::reference_layout::NO_CONTACT;
use fringe_rig::{CameraClock, CameraClockOptions, CameraStream, Frame, HostTime};
use fringe_ros2::{CompressedImage, Header, Publisher};
use fringe_sensor_models::{Errors, FrameRef, Model, Prediction, Predictor, Preprocessor};
use std::collections::VecDeque;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// Frames that may wait for the model before the oldest is skipped: 100 ms at 50 fps, enough to
/// ride over a slow frame now and then without adding a growing delay.
pub const BACKLOG_FRAMES: usize = 5;

/// The latency a running stream shows is over this many frames (10 s at 50 fps).
pub const RECENT_FRAMES: usize = 500;

/// The predicted Fz a running stream keeps for its chart, s.
pub const HISTORY_SECONDS: f64 = 10.0;

/// Room the recording keeps on its disk: below it, the recording is closed (its summary and
/// index written, so that it reads back whole) and the stream goes on publishing. It holds the
/// chunk being filled (at most 768 KiB before compression) and the summary many times over.
pub const RECORDING_RESERVE_BYTES: u64 = 16_000_000;

/// How often the recording's disk is looked at.
const DISK_CHECK_PERIOD: Duration = Duration::from_secs(1);

/// The camera clock is latched this often between frame reads.
const LATCH_PERIOD: Duration = Duration::from_millis(250);

/// What a running stream shows.
#[derive(Debug, Clone, Default)]
pub struct StreamState {
    /// The model, as `fringe model info` names it, and its backend.
    pub model: String,
    pub backend: &'static str,
    /// The camera and the unit.
    pub camera: String,
    pub sensor: String,
    /// Frames the camera delivered, and those it lost (gaps in its frame ids).
    pub frames: u64,
    pub dropped_by_camera: u64,
    /// Frames the model ran on, and those it was too busy for.
    pub ran: u64,
    pub skipped: u64,
    /// Predictions a second over the last second.
    pub rate_hz: f64,
    /// The newest prediction and its latency (exposure end to published), ms.
    pub latest: Option<Prediction>,
    pub latest_latency_ms: Option<f64>,
    /// The latency over the last [`RECENT_FRAMES`] frames the camera clock placed.
    pub recent_latency: Option<LatencyFigures>,
    /// (seconds since the start, predicted Fz in N) of the last [`HISTORY_SECONDS`].
    pub fz_history: VecDeque<(f64, f64)>,
    /// On the simulated bench: the true Fz of the frames scored so far, as `fz_history`
    /// (the truth is gathered about once a second, so it trails the predictions).
    pub true_fz: VecDeque<(f64, f64)>,
    /// On the simulated bench: frames scored against the truth so far, and their errors as
    /// `fringe eval` computes them.
    pub truth: Option<(usize, Errors)>,
    /// Whether a Zenoh router or peer is connected (`None`: not publishing).
    pub connected: Option<bool>,
    /// The namespace the topics are under (`None`: not publishing).
    pub namespace: Option<String>,
    pub published: Published,
    /// The recording, when one is made.
    pub mcap: Option<PathBuf>,
    /// On the simulated bench: the robot's presses so far.
    pub robot_presses: Option<usize>,
    /// The unit's health figures, measured on frames the model calls free (every 30 s).
    pub health: Option<StreamHealth>,
    /// Warnings, each said once (the front end shows them as they come).
    pub warnings: Vec<String>,
    /// Why the worker stopped, if it failed.
    pub failure: Option<String>,
    /// Seconds since the stream started.
    pub elapsed_s: f64,
}

/// What a finished stream leaves.
#[derive(Debug, Clone)]
pub struct StreamSummary {
    pub state: StreamState,
    /// Exposure end to published, with each stage (frames whose exposure the camera clock placed).
    pub latency: Option<LatencyFigures>,
    /// Whether timestamp latches calibrated the camera clock (else readout was assumed).
    pub clock_calibrated: bool,
    /// The recording written.
    pub mcap: Option<PathBuf>,
    /// On the simulated bench: the exposure ends the camera clock placed against the truth's,
    /// median and 99th percentile of the distance, µs.
    pub exposure_error_us: Option<[f64; 2]>,
    /// On the simulated bench: frames scored against the truth, and the errors as `fringe eval`
    /// computes them.
    pub truth: Option<(usize, Errors)>,
}

fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|p| p.into_inner())
}

/// A frame waiting for the worker.
struct Waiting {
    frame: Frame,
}

/// A frame picked for the image topic.
struct ImageJob {
    frame: Frame,
    stamp_unix_ns: i64,
}

struct Shared {
    state: Mutex<StreamState>,
    stop: Arc<AtomicBool>,
    /// Each frame's latency, and (device timestamp, prediction) for the truth.
    latencies: Mutex<Vec<FrameLatency>>,
    /// Each frame streamed, for the truth.
    #[cfg(feature = "sim")]
    streamed: Mutex<Vec<crate::stream::robot_truth::Streamed>>,
    calibrated: AtomicBool,
    mcap: Mutex<Option<McapOutlet>>,
    /// The recording, once closed before the stream ended (its disk filled up, or a write
    /// failed; the warning says whether it was closed whole).
    closed_early: Mutex<Option<PathBuf>>,
    /// Whether predictions are kept for scoring against the truth (the simulated robot's).
    #[cfg(feature = "sim")]
    keep_streamed: bool,
}

impl Shared {
    fn warn(&self, line: String) {
        let mut s = lock(&self.state);
        if !s.warnings.contains(&line) {
            s.warnings.push(line);
        }
    }

    /// Closes the recording before the stream ends, because `why`: its summary and index
    /// written when the disk still takes them, so that it reads back whole; the stream goes on
    /// publishing. Said once.
    fn close_recording(&self, why: &str) {
        let Some(recording) = lock(&self.mcap).take() else {
            return;
        };
        let at_s = lock(&self.state).elapsed_s;
        let path = recording.path().to_path_buf();
        *lock(&self.closed_early) = Some(path.clone());
        let line = match recording.finish() {
            Ok(_) => {
                format!(
                    "{why}: the recording {} was closed at {at_s:.0} s and reads back whole; the stream goes on without it",
                    path.display()
                )
            }
            Err(e) => {
                format!(
                    "{why}: the recording {} could not be closed ({e}); what it holds up to its last whole chunk reads with a streaming MCAP reader; the stream goes on without it",
                    path.display()
                )
            }
        };
        self.warn(line);
    }
}

/// Why the recording at `path` cannot go on: its disk has less room than it keeps.
fn disk_short(path: &std::path::Path) -> Option<String> {
    let dir = path.parent().filter(|d| !d.as_os_str().is_empty());
    let free = fringe_rig::store::available_bytes(dir.unwrap_or(std::path::Path::new("."))).ok()?;
    (free < RECORDING_RESERVE_BYTES).then(|| {
        format!(
            "the disk holding {} has {} left (the recording keeps {})",
            path.display(),
            fringe_rig::store::human_bytes(free),
            fringe_rig::store::human_bytes(RECORDING_RESERVE_BYTES)
        )
    })
}

/// A running stream.
pub struct Stream {
    shared: Arc<Shared>,
    worker: Option<JoinHandle<()>>,
    imager: Option<JoinHandle<()>>,
    camera: Option<CameraStream>,
    #[cfg(feature = "sim")]
    classes: Vec<String>,
    #[cfg(feature = "sim")]
    frame_id: String,
    /// On the simulated bench: how far the camera clock placed exposures from the truth.
    exposure_error_us: Option<[f64; 2]>,
    #[cfg(feature = "sim")]
    robot: Option<crate::stream::robot_truth::RobotTruth>,
    /// On the simulated bench: the stream scored against the truth as it goes.
    #[cfg(feature = "sim")]
    live: Mutex<crate::stream::robot_truth::LiveScore>,
    /// Kept alive while the stream runs (the simulated bench films the sensor).
    #[cfg(feature = "sim")]
    _sim: Option<crate::rig::simulated::SimBench>,
}

/// The unit's calibration profile: the one on file, or on the simulated bench its design's.
fn profile_of(config: &RigConfig, sensor: &str) -> Result<Profile, StreamError> {
    crate::rig::unit_profile(config, sensor)
        .map_err(RigError::Config)?
        .ok_or_else(|| StreamError::NoProfile {
            sensor: sensor.to_string(),
            dir: config.profile_dir(),
        })
}

impl Stream {
    /// Opens the camera, the model, the node and the recording, and starts streaming; the notes
    /// say what was opened and anything the operator should know.
    pub fn start(request: StreamRequest) -> Result<(Stream, Vec<String>), StreamError> {
        let StreamRequest {
            config,
            model,
            backend,
            threads,
            mut ros2,
            mcap,
            image_hz,
            robot_seed,
        } = request;
        ros2.check().map_err(StreamError::Settings)?;
        let mut notes = Vec::new();
        let OpenCamera {
            camera,
            settings,
            free_run_note,
            sensor_id,
            description,
            #[cfg(feature = "sim")]
            sim,
        } = config.open_camera()?;
        notes.extend(free_run_note);
        let profile = profile_of(&config, &sensor_id)?;
        let preprocessing = model.preprocessing(Some(&profile), None)?;
        if let Some(w) = model.scale_warning(&preprocessing) {
            notes.push(w);
        }
        let predictor = Predictor::new(&model, backend, threads)?;
        let tick_hz = camera.info().tick_frequency;
        let (node, image_publisher) = if ros2.publish {
            let (n, i) = Ros2Outlet::open(&ros2)?;
            notes.push(format!(
                "{}: topics {}",
                ros2.describe(),
                crate::stream::outlets::TOPICS
                    .iter()
                    .filter(|(t, _)| image_hz > 0.0 || !t.starts_with("image"))
                    .map(|(t, ty)| format!("{}/{t} ({ty})", ros2.namespace.trim_end_matches('/')))
                    .collect::<Vec<_>>()
                    .join(", ")
            ));
            (Some(n), Some(i))
        } else {
            (None, None)
        };
        if let Some(why) = mcap.as_deref().and_then(disk_short) {
            return Err(StreamError::Settings(format!(
                "--mcap: {why}: free some space or record elsewhere"
            )));
        }
        let recording = match &mcap {
            Some(path) => Some(McapOutlet::create(
                path,
                &ros2.namespace,
                cfg!(feature = "sim") && config.is_simulated(),
            )?),
            None => None,
        };
        #[cfg(feature = "sim")]
        let classes = model.classes.clone();
        let state = StreamState {
            model: format!("{} ({})", model.path.display(), model.describe()),
            backend: predictor.backend_name(),
            camera: description,
            sensor: sensor_id,
            connected: node.as_ref().map(|_| false),
            namespace: ros2.publish.then(|| ros2.namespace.clone()),
            mcap: mcap.clone(),
            ..StreamState::default()
        };
        let shared = Arc::new(Shared {
            state: Mutex::new(state),
            stop: Arc::new(AtomicBool::new(false)),
            latencies: Mutex::new(Vec::new()),
            #[cfg(feature = "sim")]
            streamed: Mutex::new(Vec::new()),
            calibrated: AtomicBool::new(false),
            mcap: Mutex::new(recording),
            closed_early: Mutex::new(None),
            #[cfg(feature = "sim")]
            keep_streamed: config.is_simulated(),
        });
        #[cfg(feature = "sim")]
        let robot = match &sim {
            Some(sim) => {
                let r = crate::stream::robot_truth::RobotTruth::start(sim, &classes, robot_seed)?;
                notes.push(format!(
                    "simulated bench: the simulator's robot presses the sensor at random places and forces with {} (seed {robot_seed}); each frame is scored against the simulator's truth",
                    r.shapes.join(", ")
                ));
                Some(r)
            }
            None => None,
        };
        #[cfg(not(feature = "sim"))]
        let _ = robot_seed;
        let camera_stream = CameraStream::spawn_with_latches(camera, &settings, LATCH_PERIOD)?;
        let clock = CameraClock::new(
            CameraClockOptions::new(settings.exposure, tick_hz as f64),
            Some(camera_stream.subscribe_latches()),
        );
        let (image_tx, image_rx) = crossbeam_channel::bounded::<ImageJob>(1);
        let imager = if image_hz > 0.0 {
            Some(spawn_imager(
                shared.clone(),
                image_publisher,
                image_rx,
                ros2.frame_id.clone(),
            )?)
        } else {
            None
        };
        let started = Instant::now();
        let health = {
            let to = shared.clone();
            HealthWatch::start(
                profile.clone(),
                Box::new(move |said| match said {
                    Said::Figures(h) => lock(&to.state).health = Some(h),
                    Said::Warning(w) => to.warn(w),
                }),
                shared.stop.clone(),
                started,
            )
            .map_err(|source| StreamError::Thread {
                what: "health watch",
                source,
            })?
        };
        let worker = Worker {
            shared: shared.clone(),
            health,
            frames: camera_stream.frames().clone(),
            clock,
            pre: Preprocessor::new(preprocessing),
            predictor,
            model,
            profile,
            node,
            frame_id: ros2.frame_id.clone(),
            image_every: (image_hz > 0.0).then(|| Duration::from_secs_f64(1.0 / image_hz)),
            image_tx,
            last_image: None,
            waiting: VecDeque::new(),
            last_id: None,
            recent: VecDeque::new(),
            started,
            connected_checked: None,
            disk_checked: None,
        };
        let worker = std::thread::Builder::new()
            .name("stream".into())
            .spawn(move || worker.run())
            .map_err(|source| StreamError::Thread {
                what: "stream",
                source,
            })?;
        Ok((
            Stream {
                shared,
                worker: Some(worker),
                imager,
                camera: Some(camera_stream),
                #[cfg(feature = "sim")]
                classes,
                #[cfg(feature = "sim")]
                frame_id: ros2.frame_id.clone(),
                exposure_error_us: None,
                #[cfg(feature = "sim")]
                robot,
                #[cfg(feature = "sim")]
                live: Mutex::default(),
                #[cfg(feature = "sim")]
                _sim: sim,
            },
            notes,
        ))
    }

    /// The state now (a copy: the stream goes on).
    pub fn state(&self) -> StreamState {
        let mut s = lock(&self.shared.state).clone();
        #[cfg(feature = "sim")]
        if let Some(r) = &self.robot {
            s.robot_presses = Some(r.presses());
            let mut live = lock(&self.live);
            r.score_new(&self.classes, &lock(&self.shared.streamed), &mut live);
            s.truth = Some((live.n, live.errors.clone()));
            s.true_fz = live.true_fz.clone();
        }
        {
            let latencies = lock(&self.shared.latencies);
            s.recent_latency = figures(&latencies[latencies.len().saturating_sub(RECENT_FRAMES)..]);
        }
        if let Some(e) = self.camera.as_ref().and_then(|c| c.error()) {
            s.failure.get_or_insert(format!("camera: {e}"));
        }
        s
    }

    /// Whether the stream stopped by itself (the worker or the camera failed).
    pub fn failed(&self) -> bool {
        self.state().failure.is_some()
    }

    /// Stops the robot, scores the stream against the truth and puts the truth in `recording`
    /// beside the predictions, frame by frame, stamped alike.
    #[cfg(feature = "sim")]
    #[allow(clippy::type_complexity)]
    fn score_truth(
        &mut self,
        mut recording: Option<McapOutlet>,
    ) -> Result<(Option<McapOutlet>, Option<(usize, Errors)>), StreamError> {
        let Some(r) = self.robot.as_mut() else {
            return Ok((recording, None));
        };
        r.stop();
        let scored = r.score(&self.classes, &lock(&self.shared.streamed));
        if let Some(m) = recording.as_mut() {
            for (stamp, sample) in &scored.frames {
                m.write_truth(*stamp, sample, &self.frame_id)?;
            }
        }
        self.exposure_error_us = scored.exposure_error_us;
        Ok((recording, Some((scored.frames.len(), scored.errors))))
    }

    /// Stops the stream: the camera, the worker, the robot; finishes the recording; the summary.
    pub fn finish(mut self) -> Result<StreamSummary, StreamError> {
        self.shared.stop.store(true, Ordering::Relaxed);
        if let Some(w) = self.worker.take() {
            let _ = w.join();
        }
        if let Some(i) = self.imager.take() {
            let _ = i.join();
        }
        let camera_error = self.camera.take().and_then(|c| c.stop().err());
        let recording = lock(&self.shared.mcap).take();
        #[cfg(feature = "sim")]
        let (recording, truth) = self.score_truth(recording)?;
        #[cfg(not(feature = "sim"))]
        let truth = None;
        let mut state = self.state();
        // The whole stream scored, the frames the live score was still waiting for among them.
        if truth.is_some() {
            state.truth = truth.clone();
        }
        if let Some(e) = camera_error {
            state.warnings.push(format!("camera: stopping it: {e}"));
        }
        let mcap = match recording {
            Some(r) => Some(r.finish()?),
            None => lock(&self.shared.closed_early).clone(),
        };
        let latency = figures(&lock(&self.shared.latencies));
        Ok(StreamSummary {
            state,
            latency,
            clock_calibrated: self.shared.calibrated.load(Ordering::Relaxed),
            mcap,
            exposure_error_us: self.exposure_error_us,
            truth,
        })
    }
}

impl Drop for Stream {
    fn drop(&mut self) {
        self.shared.stop.store(true, Ordering::Relaxed);
        if let Some(w) = self.worker.take() {
            let _ = w.join();
        }
        if let Some(i) = self.imager.take() {
            let _ = i.join();
        }
        if let Some(c) = self.camera.take() {
            let _ = c.stop();
        }
        // A recording not finished is finished here, so that its summary is written.
        if let Some(r) = lock(&self.shared.mcap).take() {
            let _ = r.finish();
        }
    }
}

/// The image thread: PNG-encodes the frames picked for the image topic and publishes and
/// records them, away from the worker (encoding a full frame takes longer than a frame period).
fn spawn_imager(
    shared: Arc<Shared>,
    mut publisher: Option<Publisher<CompressedImage>>,
    jobs: crossbeam_channel::Receiver<ImageJob>,
    frame_id: String,
) -> Result<JoinHandle<()>, StreamError> {
    std::thread::Builder::new()
        .name("stream-images".into())
        .spawn(move || {
            while !shared.stop.load(Ordering::Relaxed) {
                let Ok(job) = jobs.recv_timeout(Duration::from_millis(100)) else {
                    continue;
                };
                let data = match png(&job.frame) {
                    Ok(d) => d,
                    Err(e) => {
                        shared.warn(format!("image topic: {e}"));
                        continue;
                    }
                };
                let msg = CompressedImage {
                    header: Header::at_unix_nanos(job.stamp_unix_ns.max(0) as u64, &frame_id),
                    format: "png".into(),
                    data,
                };
                let now = HostTime::now().unix_nanos();
                if let Some(p) = publisher.as_mut() {
                    match put_one(p, &msg, now) {
                        Ok(()) => lock(&shared.state).published.image += 1,
                        Err(e) => shared.warn(format!("image topic: {e}")),
                    }
                }
                let written = lock(&shared.mcap)
                    .as_mut()
                    .map(|m| m.write_image(&msg, now));
                if let Some(Err(e)) = written {
                    shared.close_recording(&format!("recording an image failed ({e})"));
                }
            }
        })
        .map_err(|source| StreamError::Thread {
            what: "image",
            source,
        })
}

/// A frame as PNG (fast compression; colour as the camera gives it, Bayer frames demosaiced),
/// as `sensor_msgs/CompressedImage` carries it.
fn png(frame: &Frame) -> Result<Vec<u8>, String> {
    use image::ImageEncoder;
    let picture =
        fringe_sensor_models::thumbnail(FrameRef::from(frame), frame.width.max(frame.height))
            .map_err(|e| e.to_string())?;
    let mut out = Vec::new();
    image::codecs::png::PngEncoder::new_with_quality(
        &mut out,
        image::codecs::png::CompressionType::Fast,
        image::codecs::png::FilterType::Sub,
    )
    .write_image(
        picture.as_raw(),
        picture.width(),
        picture.height(),
        image::ExtendedColorType::Rgb8,
    )
    .map_err(|e| e.to_string())?;
    Ok(out)
}

struct Worker {
    shared: Arc<Shared>,
    health: HealthWatch,
    frames: crossbeam_channel::Receiver<Frame>,
    clock: CameraClock,
    pre: Preprocessor,
    predictor: Predictor,
    model: Model,
    profile: Profile,
    node: Option<Ros2Outlet>,
    frame_id: String,
    image_every: Option<Duration>,
    image_tx: crossbeam_channel::Sender<ImageJob>,
    last_image: Option<Instant>,
    waiting: VecDeque<Waiting>,
    last_id: Option<u64>,
    recent: VecDeque<Instant>,
    started: Instant,
    connected_checked: Option<Instant>,
    disk_checked: Option<Instant>,
}

impl Worker {
    fn run(mut self) {
        let mut input = vec![0f32; self.pre.config.tensor_len()];
        while !self.shared.stop.load(Ordering::Relaxed) {
            if self.waiting.is_empty() {
                match self.frames.recv_timeout(Duration::from_millis(100)) {
                    Ok(f) => self.arrived(f),
                    Err(crossbeam_channel::RecvTimeoutError::Timeout) => {
                        self.check_connected();
                        continue;
                    }
                    Err(crossbeam_channel::RecvTimeoutError::Disconnected) => break,
                }
            }
            while let Ok(f) = self.frames.try_recv() {
                self.arrived(f);
            }
            let Some(next) = self.waiting.pop_front() else {
                continue;
            };
            if let Err(why) = self.one(next, &mut input) {
                lock(&self.shared.state).failure = Some(why);
                break;
            }
            self.check_connected();
        }
        // The worker is done (stopped, failed or the camera gone): so is everything else.
        self.shared.stop.store(true, Ordering::Relaxed);
        self.health.join();
    }

    /// A frame from the camera: into the clock fit and the queue (the oldest waiting skipped
    /// when the queue is full).
    fn arrived(&mut self, frame: Frame) {
        self.clock.observe(&frame);
        let mut s = lock(&self.shared.state);
        s.frames += 1;
        if let Some(last) = self.last_id {
            s.dropped_by_camera += frame.id.saturating_sub(last + 1);
        }
        self.last_id = Some(frame.id);
        self.waiting.push_back(Waiting { frame });
        while self.waiting.len() > BACKLOG_FRAMES {
            self.waiting.pop_front();
            s.skipped += 1;
        }
    }

    /// Closes the recording, whole, once its disk has less room than it keeps (looked at once
    /// a second).
    fn check_disk(&mut self) {
        if self
            .disk_checked
            .is_some_and(|t| t.elapsed() < DISK_CHECK_PERIOD)
        {
            return;
        }
        self.disk_checked = Some(Instant::now());
        let path = lock(&self.shared.mcap)
            .as_ref()
            .map(|m| m.path().to_path_buf());
        if let Some(why) = path.as_deref().and_then(disk_short) {
            self.shared.close_recording(&why);
        }
    }

    fn check_connected(&mut self) {
        let Some(node) = &self.node else {
            return;
        };
        if self
            .connected_checked
            .is_some_and(|t| t.elapsed() < Duration::from_secs(1))
        {
            return;
        }
        self.connected_checked = Some(Instant::now());
        let now = node.connected();
        let mut s = lock(&self.shared.state);
        if s.connected != Some(now) {
            s.connected = Some(now);
        }
    }

    /// Runs the model on one frame and sends its messages out.
    fn one(&mut self, w: Waiting, input: &mut [f32]) -> Result<(), String> {
        let frame = &w.frame;
        let taken = Instant::now();
        let exposure = self.clock.exposure(frame);
        let fref = FrameRef::from(frame);
        self.pre
            .run_into(fref, 0.0, input)
            .map_err(|e| format!("frame {}: {e}", frame.id))?;
        let prediction = self
            .predictor
            .predict(input, 1, &[fref], &self.pre.config, Some(&self.profile))
            .map_err(|e| e.to_string())?
            .into_iter()
            .next()
            .ok_or_else(|| {
                format!(
                    "{}: the network gave no prediction",
                    self.model.path.display()
                )
            })?;
        let modelled = Instant::now();
        if prediction.shape == NO_CONTACT && prediction.confidence() >= FREE_CONFIDENCE {
            self.health.offer(frame, prediction.force.fz.value());
        }
        // The header's stamp: the middle of the exposure (the arrival until the clock is fitted).
        let stamp = exposure.map_or(frame.host_arrival.0 as f64, |e| {
            (e.host_ns[0] + e.host_ns[1]) / 2.0
        });
        let stamp_unix_ns = HostTime(stamp.max(0.0) as u64).unix_nanos();
        let messages = Messages::of(&prediction, stamp_unix_ns, &self.frame_id);
        let now_unix = HostTime::now().unix_nanos();
        let mut published = Published::default();
        if let Some(node) = self.node.as_mut() {
            if let Err(e) = node.put(&messages, now_unix, &mut published) {
                published.failed += 1;
                self.shared.warn(format!("publishing: {e}"));
            }
        }
        let written = lock(&self.shared.mcap)
            .as_mut()
            .map(|m| m.write(&messages, now_unix));
        if let Some(Err(e)) = written {
            self.shared
                .close_recording(&format!("recording failed ({e})"));
        }
        self.check_disk();
        let done = HostTime::now();
        if let Some(every) = self.image_every {
            if self.last_image.is_none_or(|t| t.elapsed() >= every) {
                self.last_image = Some(Instant::now());
                let _ = self.image_tx.try_send(ImageJob {
                    frame: w.frame.clone(),
                    stamp_unix_ns,
                });
            }
        }
        // Where the time went, from the end of the exposure.
        let latency_ms = exposure.map(|e| {
            let ms = |a: f64, b: f64| ((b - a) * 1e-6).max(0.0);
            let arrival = frame.host_arrival.0 as f64;
            let taken_ns = HostTime::from_instant(taken).0 as f64;
            let modelled_ns = HostTime::from_instant(modelled).0 as f64;
            self.shared
                .calibrated
                .store(e.calibrated, Ordering::Relaxed);
            FrameLatency {
                stages_ms: [
                    ms(e.host_ns[1], arrival),
                    ms(arrival, taken_ns),
                    ms(taken_ns, modelled_ns),
                    ms(modelled_ns, done.0 as f64),
                ],
            }
        });
        if let Some(l) = latency_ms {
            lock(&self.shared.latencies).push(l);
        }
        #[cfg(feature = "sim")]
        if self.shared.keep_streamed {
            lock(&self.shared.streamed).push(crate::stream::robot_truth::Streamed {
                ticks: frame.device_timestamp,
                stamp_unix_ns,
                exposure_host_ns: exposure.map(|e| e.host_ns),
                t_s: self.started.elapsed().as_secs_f64(),
                prediction: prediction.clone(),
            });
        }
        let now = Instant::now();
        self.recent.push_back(now);
        while self
            .recent
            .front()
            .is_some_and(|t| now.duration_since(*t) > Duration::from_secs(1))
        {
            self.recent.pop_front();
        }
        let elapsed_s = self.started.elapsed().as_secs_f64();
        let mut s = lock(&self.shared.state);
        s.ran += 1;
        s.rate_hz = self.recent.len() as f64;
        s.fz_history
            .push_back((elapsed_s, prediction.force.fz.value()));
        while s
            .fz_history
            .front()
            .is_some_and(|(t, _)| elapsed_s - t > HISTORY_SECONDS)
        {
            s.fz_history.pop_front();
        }
        s.latest = Some(prediction);
        s.latest_latency_ms = latency_ms.map(|l| l.total_ms());
        s.published.wrench += published.wrench;
        s.published.contact += published.contact;
        s.published.shape += published.shape;
        s.published.failed += published.failed;
        s.elapsed_s = elapsed_s;
        Ok(())
    }
}
