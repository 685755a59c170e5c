//! The bench outside a scan, for a front end: the rig opened, the F/T sensor and the camera
//! streaming, the axes polled, and jog / home / stop / tare carried out on a worker thread that
//! publishes a [`BenchState`] snapshot. The front end only sends [`BenchCommand`]s and reads the
//! snapshot, so it never waits on a device.
//!
//! Safety: every move goes through the axis drivers, which refuse targets outside the soft
//! limits. While a motion into or across the sensor runs, every force sample is checked (not
//! every poll): the first one over the bench's ceiling stops it at once. Over the ceiling, moves
//! into or across the sensor are refused and moves away from it (z up, homing z) are allowed
//! and never stopped for force ([`crate::session::jog_guard`]). While the F/T reads a load (against its
//! no-contact reading, taken with z at its home), moves across the sensor and the tare are
//! refused, and a move across is stopped at the first reading of one. Closing the session stops
//! any motion before the devices are released.

use crate::rig::error::RigError;
use crate::rig::file::RigConfig;
pub(crate) use crate::session::jog_guard::AxisId;
use crate::session::jog_guard::{Heading, JogGuard, Polled, Refused};
use fringe_rig::scan::PressSettings;
use fringe_rig::scan::LOAD_SAMPLES;
use fringe_rig::BenchLimits;
use fringe_rig::CameraStream;
use fringe_rig::Devices;
use fringe_rig::ForceStream;
use fringe_rig::FrameGaps;
use fringe_rig::Millimetres;
use fringe_rig::Operator;
use fringe_rig::{Axis, AxisError, StopMode};
use fringe_rig::{CameraError, CameraSettings, Frame};
use fringe_rig::{ForceError, StreamStats};
use fringe_sensor_models::{thumbnail, FrameRef};
use std::collections::VecDeque;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{channel, Receiver, Sender};
use std::sync::{Arc, Mutex, MutexGuard};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// How often the axes are polled and the snapshot refreshed.
const TICK: Duration = Duration::from_millis(50);
/// How often the force is checked while a motion into or across the sensor runs (the F/T
/// sends a sample every 0.2 ms; the stream hands them over as they come).
const GUARD_TICK: Duration = Duration::from_millis(1);
/// Pictures made per second at most.
const PICTURE_HZ: f64 = 10.0;
/// Seconds of force kept for the chart.
pub(crate) const CHART_SECONDS: f64 = 20.0;
/// Force points per second kept for the chart.
const CHART_HZ: f64 = 50.0;
/// Messages kept.
const MESSAGES: usize = 50;

/// What the front end asks of the bench.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum BenchCommand {
    /// Move an axis by a distance (within its soft limits).
    Jog { axis: AxisId, by: Millimetres },
    /// Home an axis.
    Home(AxisId),
    /// Stop every axis at once.
    Stop,
    /// Re-zero the F/T sensor: refused while it reads a load, or before its no-contact reading
    /// is known (z homed).
    Tare,
}

/// One axis as last polled.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct AxisState {
    /// Driver and port ("Thorlabs KST101 on /dev/ttyUSB0", "simulated").
    pub endpoint: String,
    pub position_mm: Option<f64>,
    pub homed: bool,
    pub moving: bool,
    /// Soft limits, mm.
    pub limits_mm: (f64, f64),
    /// Status flags that mean trouble (limit switch, motion error).
    pub faults: Vec<String>,
    /// Moved by hand (a manual y stage): not jogged from here.
    pub manual: bool,
}

/// The F/T sensor as last read.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ForceState {
    pub device: String,
    pub fz_n: f64,
    /// |F| of the force vector, N.
    pub f_n: f64,
    /// Samples received per second over the last second.
    pub rate_hz: f64,
    pub received: u64,
    pub lost: u64,
    /// Times the sensor's own sample counter started again (it rebooted, losing its bias).
    pub restarts: u64,
    /// The ceiling that stops a jog, N.
    pub max_n: f64,
    /// The highest |F| of any sample since the bench opened or was last tared, N.
    pub peak_n: f64,
}

/// The camera as last read.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct CameraState {
    pub device: String,
    /// Frames per second over the last second.
    pub fps: f64,
    pub frames: u64,
    /// Frames the camera numbered but that never arrived.
    pub dropped: u64,
    pub frame_id: u64,
}

/// A force point of the chart.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ForcePoint {
    /// Seconds since the session opened.
    pub t_s: f64,
    pub fz_n: f64,
    pub f_n: f64,
}

/// Where the session is.
#[derive(Debug, Clone, PartialEq, Default)]
pub enum BenchPhase {
    #[default]
    Opening,
    Ready,
    /// The rig could not be opened, or a stream failed: the message says which device.
    Failed(String),
    Closed,
}

/// Everything a front end shows of the bench.
#[derive(Debug, Clone, Default)]
pub struct BenchState {
    pub phase: BenchPhase,
    /// One line per device.
    pub devices: Vec<String>,
    pub axes: [AxisState; 3],
    pub force: ForceState,
    pub camera: CameraState,
    pub picture: Option<image::RgbImage>,
    pub chart: VecDeque<ForcePoint>,
    /// What was done and what went wrong, newest last.
    pub messages: VecDeque<String>,
}

impl BenchState {
    fn say(&mut self, line: impl Into<String>) {
        let line = line.into();
        if self.messages.back() == Some(&line) {
            return;
        }
        if self.messages.len() == MESSAGES {
            self.messages.pop_front();
        }
        self.messages.push_back(line);
    }
}

/// What the bench could not do; each names the device and what to do.
#[derive(Debug, thiserror::Error)]
pub(crate) enum BenchError {
    #[error("cannot open the rig: {0}")]
    Rig(#[from] RigError),
    #[error(transparent)]
    Force(#[from] ForceError),
    #[error(transparent)]
    Camera(#[from] CameraError),
    #[error(transparent)]
    Axis(#[from] AxisError),
    /// Several axes failed to stop.
    #[error("{}", .0.iter().map(|e| e.to_string()).collect::<Vec<_>>().join("; "))]
    Stop(Vec<AxisError>),
    #[error(transparent)]
    Refused(#[from] Refused),
    #[error("axis {axis}: moved by hand on this bench; {what}")]
    MovedByHand {
        axis: &'static str,
        what: &'static str,
    },
    #[error("{axis}: not moved: the F/T sensor is not streaming, so the force ceiling cannot be watched")]
    ForceUnwatched { axis: &'static str },
    #[error("the F/T sensor is not streaming")]
    NotStreaming,
}

fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|p| p.into_inner())
}

/// The bench, opened on its own thread.
pub struct BenchSession {
    commands: Sender<BenchCommand>,
    state: Arc<Mutex<BenchState>>,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
}

impl BenchSession {
    /// Opens the rig `config` describes on a new thread (the snapshot says Opening until the
    /// devices answer); pictures are `picture_px` on a side. A stage moved by hand asks
    /// `stage_operator`, the front end's (this session never moves nor polls it).
    pub fn open(
        config: RigConfig,
        picture_px: u32,
        stage_operator: Box<dyn Operator>,
    ) -> std::io::Result<BenchSession> {
        let state = Arc::new(Mutex::new(BenchState::default()));
        let stop = Arc::new(AtomicBool::new(false));
        let (tx, rx) = channel();
        let thread = {
            let (state, stop) = (state.clone(), stop.clone());
            std::thread::Builder::new()
                .name("bench".into())
                .spawn(move || {
                    let opened = run(&config, stage_operator, picture_px, &state, &stop, &rx);
                    if let Err(e) = opened {
                        lock(&state).phase = BenchPhase::Failed(e.to_string());
                    }
                })?
        };
        Ok(BenchSession {
            commands: tx,
            state,
            stop,
            thread: Some(thread),
        })
    }

    /// Asks the bench to do something; the outcome appears in the snapshot's messages.
    pub fn send(&self, command: BenchCommand) {
        // The worker only goes away when the session closes.
        let _ = self.commands.send(command);
    }

    /// The newest snapshot.
    pub fn state(&self) -> BenchState {
        lock(&self.state).clone()
    }

    /// Stops any motion, releases the devices and waits for the worker.
    pub fn close(mut self) {
        self.shut();
    }

    fn shut(&mut self) {
        self.stop.store(true, Ordering::SeqCst);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

impl Drop for BenchSession {
    fn drop(&mut self) {
        self.shut();
    }
}

/// The worker: opens the rig, then polls and obeys until told to stop.
fn run(
    config: &RigConfig,
    stage_operator: Box<dyn Operator>,
    picture_px: u32,
    state: &Mutex<BenchState>,
    stop: &AtomicBool,
    commands: &Receiver<BenchCommand>,
) -> Result<(), BenchError> {
    // The rest of the opened rig (a simulated bench) lives until the devices are released.
    let rig = config.open(None, stage_operator)?;
    let mut bench = Worker::start(
        rig.devices,
        &rig.limits,
        &rig.camera_settings,
        picture_px,
        state,
    )?;
    while !stop.load(Ordering::SeqCst) {
        let tick = Instant::now();
        bench.tick(commands);
        let period = if bench.guard.guarding() {
            GUARD_TICK
        } else {
            TICK
        };
        let spent = tick.elapsed();
        if spent < period {
            std::thread::sleep(period - spent);
        }
    }
    bench.close();
    Ok(())
}

/// The open bench as the worker holds it between ticks.
struct Worker<'a> {
    state: &'a Mutex<BenchState>,
    axes: HeldAxes,
    /// None only while a tare restarts the stream, or after a tare failed to restart it.
    force: Option<ForceStream>,
    camera: CameraStream,
    max_force_n: f64,
    manual_y: bool,
    picture_px: u32,
    started: Instant,
    guard: JogGuard,
    polled_at: Option<Instant>,
    meter: Meters,
    last_picture: Option<Instant>,
    /// The newest frame not yet made into a picture.
    newest: Option<Frame>,
}

/// The bench's axes (x, y, z), stopped where they are when the bench's thread panics (a jog
/// under way included).
struct HeldAxes([Box<dyn Axis>; 3]);

impl std::ops::Deref for HeldAxes {
    type Target = [Box<dyn Axis>; 3];
    fn deref(&self) -> &Self::Target {
        &self.0
    }
}

impl std::ops::DerefMut for HeldAxes {
    fn deref_mut(&mut self) -> &mut Self::Target {
        &mut self.0
    }
}

impl Drop for HeldAxes {
    fn drop(&mut self) {
        let [x, y, z] = &mut self.0;
        fringe_rig::scan::stop_if_panicking([z.as_mut(), x.as_mut(), y.as_mut()]);
    }
}

/// The force samples of one tick, checked against the ceiling.
struct ForceBatch {
    /// The highest |F|, N.
    peak: f64,
    /// Axes stopped for force.
    stopped: Vec<&'static str>,
    /// The |F| of the last sample that stopped an axis, N.
    over: Option<f64>,
    /// Points for the chart.
    points: Vec<ForcePoint>,
}

impl<'a> Worker<'a> {
    /// Starts the F/T and camera streams on the opened devices and shows them in the snapshot.
    fn start(
        devices: Devices,
        limits: &BenchLimits,
        camera_settings: &CameraSettings,
        picture_px: u32,
        state: &'a Mutex<BenchState>,
    ) -> Result<Worker<'a>, BenchError> {
        let axes: [Box<dyn Axis>; 3] = [devices.x, devices.y, devices.z];
        show_axes(&mut lock(state), &devices.description, limits, &axes);
        let force = ForceStream::spawn(devices.force)?;
        let camera_device = devices.camera.info().id;
        let camera = CameraStream::spawn(devices.camera, camera_settings)?;
        {
            let mut s = lock(state);
            s.force.device = force.monitor().device().to_string();
            s.camera.device = camera_device;
            s.phase = BenchPhase::Ready;
            s.say("bench open: jog, home and tare from here; a scan takes the devices over");
        }
        let started = Instant::now();
        Ok(Worker {
            state,
            axes: HeldAxes(axes),
            force: Some(force),
            camera,
            max_force_n: limits.max_force.0,
            manual_y: limits.manual_y,
            picture_px,
            started,
            // A load is told as the scan's approach tells first contact, by default.
            guard: JogGuard::new(
                limits.max_force.0,
                PressSettings::default().contact_threshold,
            ),
            polled_at: None,
            meter: Meters::new(started),
            last_picture: None,
            newest: None,
        })
    }

    /// One tick: the commands obeyed, the force checked, the axes polled when due, the camera
    /// read, the snapshot refreshed.
    fn tick(&mut self, commands: &Receiver<BenchCommand>) {
        for command in commands.try_iter() {
            let outcome = obey(
                command,
                &mut self.axes,
                &mut self.force,
                &mut self.guard,
                self.state,
            );
            if let Err(e) = outcome {
                lock(self.state).say(e.to_string());
            }
        }
        // Force first: every sample drained (the stream keeps them all for a recorder) and
        // checked against the ceiling.
        self.watch_force();
        // Axes, at the poll rate.
        if self.polled_at.is_none_or(|t| t.elapsed() >= TICK) {
            self.polled_at = Some(Instant::now());
            self.poll_axes();
        }
        self.read_camera();
        self.meter.publish(&mut lock(self.state));
    }

    /// Drains the F/T stream, stopping axes over the ceiling, and shows the force.
    fn watch_force(&mut self) {
        let Some(f) = &self.force else {
            return;
        };
        let batch = check_samples(
            f,
            &mut self.guard,
            &mut self.axes,
            &mut self.meter,
            self.started,
        );
        if let Some(total) = batch.over {
            lock(self.state).say(format!(
                "force {total:.2} N over the ceiling {:.2} N: {} stopped; moves into or \
                 across the sensor are refused until it is under; retract z (←, or h)",
                self.max_force_n,
                batch.stopped.join(", ")
            ));
        }
        let stats = f.monitor().stats();
        // Contact: Fz against the no-contact reading, averaged as the scan averages it, once
        // the stream (new after a tare) has sent that many samples.
        let reading = f
            .monitor()
            .mean_of_last(LOAD_SAMPLES)
            .filter(|_| stats.received >= LOAD_SAMPLES as u64);
        if let Some((_, mean)) = reading {
            if let Some(stop) = self.guard.reading(mean[2], stats.restarts) {
                for id in &stop.axes {
                    let _ = self.axes[id.index()].stop(StopMode::Immediate);
                }
                lock(self.state).say(stop.to_string());
            }
        }
        show_force(&mut lock(self.state), f, stats, batch, self.started);
    }

    /// Polls every axis the bench moves (a stage moved by hand is asked, not polled).
    fn poll_axes(&mut self) {
        for (i, axis) in self.axes.iter_mut().enumerate() {
            // A stage moved by hand is asked, not polled: its reading is the operator's.
            if i == AxisId::Y.index() && self.manual_y {
                continue;
            }
            let polled = axis.status();
            let mut s = lock(self.state);
            match polled {
                Ok(st) => {
                    let a = &mut s.axes[i];
                    a.position_mm = Some(st.position.0);
                    a.homed = st.homed;
                    a.moving = st.moving;
                    a.faults = st.faults.iter().map(|f| f.to_string()).collect();
                    self.guard.polled(
                        AxisId::ALL[i],
                        Polled {
                            moving: st.moving,
                            homed: st.homed,
                            position_mm: st.position.0,
                        },
                    );
                }
                Err(e) => {
                    s.axes[i].position_mm = None;
                    s.say(e.to_string());
                }
            }
        }
    }

    /// Camera: the newest frame kept, ids counted for drops, and a picture made when due.
    fn read_camera(&mut self) {
        for frame in self.camera.frames().try_iter() {
            self.meter.gaps.observe(frame.id);
            self.meter.frames += 1;
            self.newest = Some(frame);
        }
        if let Some(e) = self.camera.error() {
            lock(self.state).phase = BenchPhase::Failed(e);
        }
        let due = self
            .last_picture
            .is_none_or(|t| t.elapsed().as_secs_f64() >= 1.0 / PICTURE_HZ);
        if due {
            if let Some(frame) = self.newest.take() {
                self.last_picture = Some(Instant::now());
                let picture = thumbnail(FrameRef::from(&frame), self.picture_px).ok();
                let mut s = lock(self.state);
                s.picture = picture;
                s.camera.frame_id = frame.id;
            }
        }
    }

    /// Stops any motion and the streams, and says the bench is closed.
    fn close(mut self) {
        for axis in self.axes.iter_mut() {
            let _ = axis.stop(StopMode::Profiled);
        }
        let _ = self.camera.stop();
        if let Some(f) = self.force.take() {
            let _ = f.stop();
        }
        lock(self.state).phase = BenchPhase::Closed;
    }
}

/// Shows the devices and the axes' endpoints and limits in the snapshot.
fn show_axes(
    s: &mut BenchState,
    description: &[String],
    limits: &BenchLimits,
    axes: &[Box<dyn Axis>; 3],
) {
    s.devices = description.to_vec();
    for (i, l) in [&limits.x, &limits.y, &limits.z].into_iter().enumerate() {
        s.axes[i].limits_mm = (l.min.0, l.max.0);
        s.axes[i].endpoint = axes[i].endpoint();
    }
    s.axes[AxisId::Y.index()].manual = limits.manual_y;
    s.force.max_n = limits.max_force.0;
}

/// Checks every sample the stream has handed over against the ceiling, stopping at once the
/// axes the guard names, and keeps the chart's points.
fn check_samples(
    f: &ForceStream,
    guard: &mut JogGuard,
    axes: &mut [Box<dyn Axis>; 3],
    meter: &mut Meters,
    started: Instant,
) -> ForceBatch {
    let mut batch = ForceBatch {
        peak: 0.0,
        stopped: Vec::new(),
        over: None,
        points: Vec::new(),
    };
    for sample in f.samples().try_iter() {
        let w = sample.wrench;
        let fz = w.fz.0;
        let total = (w.fx.0 * w.fx.0 + w.fy.0 * w.fy.0 + fz * fz).sqrt();
        batch.peak = batch.peak.max(total);
        for id in guard.sample(total) {
            let _ = axes[id.index()].stop(StopMode::Immediate);
            batch.stopped.push(id.name());
            batch.over = Some(total);
        }
        meter.force_samples += 1;
        let t = started.elapsed().as_secs_f64();
        if t - meter.last_point_s >= 1.0 / CHART_HZ {
            meter.last_point_s = t;
            batch.points.push(ForcePoint {
                t_s: t,
                fz_n: fz,
                f_n: total,
            });
        }
    }
    batch
}

/// Shows a tick's force in the snapshot: the latest and peak force, the chart, the stream's
/// counts, a restart of the sensor and a failed stream.
fn show_force(
    s: &mut BenchState,
    f: &ForceStream,
    stats: StreamStats,
    batch: ForceBatch,
    started: Instant,
) {
    s.force.peak_n = s.force.peak_n.max(batch.peak);
    if let Some(p) = batch.points.last() {
        s.force.fz_n = p.fz_n;
        s.force.f_n = p.f_n;
    }
    s.chart.extend(batch.points);
    let now = started.elapsed().as_secs_f64();
    while s.chart.front().is_some_and(|p| now - p.t_s > CHART_SECONDS) {
        s.chart.pop_front();
    }
    s.force.received = stats.received;
    s.force.lost = stats.lost;
    if stats.restarts > s.force.restarts {
        let device = f.monitor().device().to_string();
        s.say(format!(
            "{device}: the F/T sensor restarted (its sample counter began again): its bias is gone, and moves across the sensor wait for its no-contact reading: home z (z, then h), then press t to tare again"
        ));
    }
    s.force.restarts = stats.restarts;
    if let Some(e) = f.monitor().error() {
        s.phase = BenchPhase::Failed(e);
    }
}

/// Rates over the last second.
struct Meters {
    window_start: Instant,
    force_samples: u64,
    frames: u64,
    frames_total: u64,
    gaps: FrameGaps,
    last_point_s: f64,
}

impl Meters {
    fn new(now: Instant) -> Meters {
        Meters {
            window_start: now,
            force_samples: 0,
            frames: 0,
            frames_total: 0,
            gaps: FrameGaps::default(),
            last_point_s: f64::NEG_INFINITY,
        }
    }

    fn publish(&mut self, s: &mut BenchState) {
        s.camera.dropped = self.gaps.dropped();
        let elapsed = self.window_start.elapsed().as_secs_f64();
        if elapsed >= 1.0 {
            s.force.rate_hz = self.force_samples as f64 / elapsed;
            s.camera.fps = self.frames as f64 / elapsed;
            self.frames_total += self.frames;
            s.camera.frames = self.frames_total;
            self.force_samples = 0;
            self.frames = 0;
            self.window_start = Instant::now();
        }
    }
}

fn obey(
    command: BenchCommand,
    axes: &mut [Box<dyn Axis>; 3],
    force: &mut Option<ForceStream>,
    guard: &mut JogGuard,
    state: &Mutex<BenchState>,
) -> Result<(), BenchError> {
    match command {
        BenchCommand::Jog { axis, by } => {
            if lock(state).axes[axis.index()].manual {
                return Err(BenchError::MovedByHand {
                    axis: axis.name(),
                    what: "it is not jogged from here",
                });
            }
            let heading = Heading::of_jog(axis, by.0);
            guard.admit(axis, heading)?;
            if heading != Heading::Away && force.is_none() {
                return Err(BenchError::ForceUnwatched { axis: axis.name() });
            }
            axes[axis.index()].begin_move_by(by)?;
            guard.begun(axis, heading);
            lock(state).say(format!("{}: moving by {:+.3} mm", axis.name(), by.0));
        }
        BenchCommand::Home(axis) => {
            if lock(state).axes[axis.index()].manual {
                return Err(BenchError::MovedByHand {
                    axis: axis.name(),
                    what: "nothing to home",
                });
            }
            guard.admit(axis, Heading::of_home(axis))?;
            axes[axis.index()].begin_home()?;
            guard.homing_begun(axis);
            lock(state).say(format!("{}: homing", axis.name()));
        }
        BenchCommand::Stop => {
            let mut failed = Vec::new();
            for axis in axes.iter_mut() {
                if let Err(e) = axis.stop(StopMode::Immediate) {
                    failed.push(e);
                }
            }
            guard.stopped_all();
            if !failed.is_empty() {
                return Err(BenchError::Stop(failed));
            }
            lock(state).say("every axis stopped");
        }
        BenchCommand::Tare => {
            if force.is_none() {
                return Err(BenchError::NotStreaming);
            }
            // Never a no-contact offset under load: it would hide the load from the ceiling.
            guard.admit_tare()?;
            let Some(stream) = force.take() else {
                return Err(BenchError::NotStreaming);
            };
            let mut sensor = stream.stop()?;
            // A sensor biased on the host (a DAQ, a Net F/T in host-bias mode) takes its bias
            // from a running acquisition: started for it, stopped again before the stream
            // starts it anew.
            let biased = sensor
                .start()
                .and_then(|()| sensor.bias())
                .and_then(|()| sensor.stop());
            // The zero may have moved: the no-contact reading is read again from the new stream.
            guard.tared();
            *force = Some(ForceStream::spawn(sensor)?);
            biased?;
            lock(state).force.peak_n = 0.0;
            lock(state).say("F/T sensor tared (bias set to the present load)");
        }
    }
    Ok(())
}
