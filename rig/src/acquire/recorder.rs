//! The recorder: one thread that takes every force sample and every frame, labels frames through
//! the run's synchronisation method and writes the run store, so the scan never waits on a disk.
//!
//! - Every force sample goes to `force.bin` (the raw stream at full rate).
//! - Every frame is counted (id gaps are dropped frames); frames arriving while the scan says it is
//!   filming ([`FrameContext`]) are labelled, saved losslessly and get a frame record.
//! - The scan sends events and asks for checkpoints through the recorder; a checkpoint first
//!   finishes the frames still waiting for their labels, then makes everything durable.

use super::frame_gaps::FrameGaps;
use super::labeler::{FrameLabeler, LabelOutcome};
use super::record_tap::RecordTap;
use crate::axis::Kinematics;
use crate::camera::Frame;
use crate::clock::HostTime;
use crate::force::ForceSample;
use crate::reference_layout::{in_contact, NO_CONTACT};
use crate::store::documents::{Exposure, FrameRecord, Position};
use crate::store::error::StoreError;
use crate::store::run_writer::RunWriter;
use crate::sync::one_way::{self, OneWayOptions};
use crate::units::Millimetres;
use crate::units::Wrench;
use crossbeam_channel::{bounded, select, unbounded, Receiver, Sender};
use std::collections::VecDeque;
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// What the scan is doing while a frame is exposed.
#[derive(Debug, Clone, PartialEq)]
pub struct Filming {
    /// Grid point (and repetition) index in the program.
    pub point: u64,
    pub commanded: Position,
    /// Latest measured axis positions.
    pub measured: Position,
    /// Contact point in mm relative to the sensor centre (sensor frame) if the indenter touches.
    pub contact: [f64; 2],
    /// Indenter mounted.
    pub shape: String,
    /// Raw no-contact reading subtracted from every label.
    pub tare: [f64; 6],
    /// The indenter is sliding: a frame's stage position and contact are where the slide had
    /// taken it at the middle of the frame's exposure, not `commanded` and `contact`.
    pub slide: Option<SlidePath>,
}

/// A slide under way: the straight trapezoid the stage axes were sent, from when.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SlidePath {
    /// When the axes were sent the slide.
    pub sent: HostTime,
    /// The stage position (x, y) it starts from, and the contact there.
    pub from: [f64; 2],
    pub contact_from: [f64; 2],
    /// The unit vector along the slide (x, y), its length (mm) and its trapezoid.
    pub unit: [f64; 2],
    pub distance: f64,
    pub along: Kinematics,
}

impl SlidePath {
    /// The stage position (x, y) and the contact at `t`.
    pub fn at(&self, t: HostTime) -> ([f64; 2], [f64; 2]) {
        let elapsed = if t >= self.sent {
            t.since(self.sent).as_secs_f64()
        } else {
            0.0
        };
        let s = self.along.travelled(self.distance, elapsed);
        let moved = [self.unit[0] * s, self.unit[1] * s];
        (
            [self.from[0] + moved[0], self.from[1] + moved[1]],
            [
                self.contact_from[0] + moved[0],
                self.contact_from[1] + moved[1],
            ],
        )
    }
}

/// Shared between the scan (writer) and the recorder (reader): `None` when not filming.
#[derive(Debug, Clone, Default)]
pub struct FrameContext(Arc<Mutex<Option<Filming>>>);

impl FrameContext {
    pub fn set(&self, filming: Option<Filming>) {
        *self.0.lock().unwrap_or_else(|p| p.into_inner()) = filming;
    }

    /// Updates the measured positions of the current filming state, if any.
    pub fn set_measured(&self, measured: Position) {
        if let Some(f) = self.0.lock().unwrap_or_else(|p| p.into_inner()).as_mut() {
            f.measured = measured;
        }
    }

    pub fn get(&self) -> Option<Filming> {
        self.0.lock().unwrap_or_else(|p| p.into_inner()).clone()
    }
}

/// Counts and rates, readable while the recorder runs.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RecorderStats {
    pub frames_seen: u64,
    /// Frames written with a label.
    pub frames_recorded: u64,
    /// Frames written without a label (no window found).
    pub frames_unlabelled: u64,
    /// Frame ids skipped by the camera.
    pub dropped_frames: u64,
    pub force_samples: u64,
    /// Frames per second over the last second.
    pub frame_rate_hz: f64,
    /// The newest label written (tared).
    pub last_label: Option<Wrench>,
    /// The synchronisation method's current estimate of its label-time error (1 sigma), ns.
    pub sync_error_ns: Option<f64>,
}

enum Command {
    Event {
        kind: String,
        point: Option<u64>,
        message: String,
    },
    /// Checkpoint before point `.0`.
    Checkpoint(u64, Sender<Result<RecorderStats, StoreError>>),
    /// Cut the records made since the last checkpoint.
    Rollback(Sender<Result<u64, StoreError>>),
}

/// A checkpoint or rollback the recorder could not make.
#[derive(Debug, thiserror::Error)]
pub enum RecorderError {
    #[error("the recorder has stopped")]
    Stopped,
    #[error("the recorder did not {what} within {timeout:?}")]
    Timeout {
        what: &'static str,
        timeout: Duration,
    },
    #[error(transparent)]
    Store(#[from] StoreError),
}

/// Why the recorder stopped early, with the run's writer when it survived.
#[derive(thiserror::Error)]
#[error("{error}")]
pub struct RecorderFailure {
    pub error: StoreError,
    pub writer: Option<Box<RunWriter>>,
}

impl std::fmt::Debug for RecorderFailure {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RecorderFailure")
            .field("error", &self.error)
            .field(
                "writer",
                &self.writer.as_ref().map(|w| w.dir().to_path_buf()),
            )
            .finish()
    }
}

/// The recorder thread.
pub struct Recorder {
    commands: Sender<Command>,
    stats: Arc<Mutex<RecorderStats>>,
    handle: Option<JoinHandle<Result<(RunWriter, RecorderStats), RecorderFailure>>>,
}

/// A checkpoint asked for and not yet confirmed.
pub struct PendingCheckpoint(Receiver<Result<RecorderStats, StoreError>>);

impl PendingCheckpoint {
    /// Waits up to `timeout` for the checkpoint to be made.
    pub fn wait(self, timeout: Duration) -> Result<RecorderStats, RecorderError> {
        Ok(self
            .0
            .recv_timeout(timeout)
            .map_err(|_| RecorderError::Timeout {
                what: "checkpoint",
                timeout,
            })??)
    }
}

impl Recorder {
    /// Starts recording into `writer` from the two streams until both close.
    pub fn spawn(
        writer: RunWriter,
        samples: Receiver<ForceSample>,
        frames: Receiver<Frame>,
        labeler: Box<dyn FrameLabeler>,
        context: FrameContext,
        taps: Vec<Arc<dyn RecordTap>>,
    ) -> Result<Recorder, StoreError> {
        let (commands, command_rx) = unbounded();
        let stats = Arc::new(Mutex::new(RecorderStats::default()));
        let dir = writer.dir().to_path_buf();
        let mut state = State {
            writer,
            labeler,
            context,
            taps,
            pending: VecDeque::new(),
            stats: stats.clone(),
            local: RecorderStats::default(),
            gaps: FrameGaps::default(),
            arrivals: VecDeque::new(),
            recent_ticks: VecDeque::new(),
            batch: Vec::with_capacity(256),
        };
        let handle = std::thread::Builder::new()
            .name("recorder".into())
            .spawn(move || match state.run(samples, frames, command_rx) {
                Ok(()) => Ok((state.writer, state.local)),
                Err(error) => Err(RecorderFailure {
                    error,
                    writer: Some(Box::new(state.writer)),
                }),
            })
            .map_err(|e| StoreError::io(dir, e))?;
        Ok(Recorder {
            commands,
            stats,
            handle: Some(handle),
        })
    }

    /// Appends an event to the run (asynchronously).
    pub fn event(&self, kind: &str, point: Option<u64>, message: &str) {
        let _ = self.commands.send(Command::Event {
            kind: kind.into(),
            point,
            message: message.into(),
        });
    }

    /// Finishes the frames waiting for labels, makes the run durable and records a checkpoint
    /// before point `next_point`; waits up to `timeout`.
    pub fn checkpoint(
        &self,
        next_point: u64,
        timeout: Duration,
    ) -> Result<RecorderStats, RecorderError> {
        self.checkpoint_begin(next_point)?.wait(timeout)
    }

    /// Asks for the checkpoint before point `next_point` without waiting for it: the recorder
    /// makes it once the frames before it are labelled and durable, while the caller goes on
    /// (moving to the next point). Commands are handled in order, so a later rollback cuts
    /// back to this checkpoint.
    pub fn checkpoint_begin(&self, next_point: u64) -> Result<PendingCheckpoint, RecorderError> {
        let (tx, rx) = bounded(1);
        self.commands
            .send(Command::Checkpoint(next_point, tx))
            .map_err(|_| RecorderError::Stopped)?;
        Ok(PendingCheckpoint(rx))
    }

    /// Cuts the frame records made since the last checkpoint (a point that is done again);
    /// returns how many. Stop filming first.
    pub fn rollback(&self, timeout: Duration) -> Result<u64, RecorderError> {
        let (tx, rx) = bounded(1);
        self.commands
            .send(Command::Rollback(tx))
            .map_err(|_| RecorderError::Stopped)?;
        Ok(rx
            .recv_timeout(timeout)
            .map_err(|_| RecorderError::Timeout {
                what: "roll back",
                timeout,
            })??)
    }

    /// A reader of the recorder's counters for other threads (watchers, progress).
    pub fn stats_source(&self) -> impl Fn() -> RecorderStats + Send + 'static {
        let stats = self.stats.clone();
        move || stats.lock().unwrap_or_else(|p| p.into_inner()).clone()
    }

    pub fn stats(&self) -> RecorderStats {
        self.stats.lock().unwrap_or_else(|p| p.into_inner()).clone()
    }

    /// Waits for the recorder to drain both streams (stop them first) and returns the writer;
    /// a recorder stopped by an error (a full disk, say) hands its writer back with the error,
    /// so the caller can still close the run.
    pub fn finish(mut self) -> Result<(RunWriter, RecorderStats), RecorderFailure> {
        let handle = self.handle.take();
        drop(self.commands);
        match handle.map(|h| h.join()) {
            Some(Ok(result)) => result,
            _ => Err(RecorderFailure {
                error: StoreError::Content {
                    path: "recorder".into(),
                    message: "the recorder thread panicked".into(),
                },
                writer: None,
            }),
        }
    }
}

struct State {
    writer: RunWriter,
    labeler: Box<dyn FrameLabeler>,
    context: FrameContext,
    taps: Vec<Arc<dyn RecordTap>>,
    pending: VecDeque<(Frame, Filming)>,
    stats: Arc<Mutex<RecorderStats>>,
    local: RecorderStats,
    gaps: FrameGaps,
    arrivals: VecDeque<HostTime>,
    batch: Vec<ForceSample>,
    /// The device tick and host arrival of the newest force samples ([`RECENT_TICKS`] of them):
    /// where a frame's exposure window, given in ticks, lies on the host's time base.
    recent_ticks: VecDeque<(u64, HostTime)>,
}

/// Force samples whose host arrival is kept to place exposure windows (2 s at 5 kHz).
const RECENT_TICKS: usize = 10_000;

impl State {
    fn run(
        &mut self,
        samples: Receiver<ForceSample>,
        frames: Receiver<Frame>,
        commands: Receiver<Command>,
    ) -> Result<(), StoreError> {
        let (mut samples_open, mut frames_open, mut commands_open) = (true, true, true);
        type Reply = Sender<Result<RecorderStats, StoreError>>;
        let mut checkpoints: Vec<(u64, Reply, Instant)> = Vec::new();
        while samples_open || frames_open || !self.pending.is_empty() {
            select! {
                recv(samples) -> s => match s {
                    Ok(s) => self.sample(s)?,
                    Err(_) => samples_open = false,
                },
                recv(frames) -> f => match f {
                    Ok(frame) => self.frame(frame),
                    Err(_) => frames_open = false,
                },
                recv(commands) -> c => match c {
                    Ok(Command::Event { kind, point, message }) => {
                        self.writer.append_event(&kind, point, &message)?
                    }
                    Ok(Command::Checkpoint(point, reply)) => {
                        checkpoints.push((point, reply, Instant::now()))
                    }
                    Ok(Command::Rollback(reply)) => {
                        // Frames of the abandoned attempt still waiting for labels go too.
                        self.pending.clear();
                        let cut = self.writer.rollback();
                        if let Ok(n) = cut {
                            self.local.frames_recorded = self.local.frames_recorded.saturating_sub(n);
                            if n > 0 {
                                let first = self.writer.next_index();
                                for tap in &self.taps {
                                    tap.cut(first);
                                }
                            }
                        }
                        let _ = reply.send(cut);
                    }
                    Err(_) => commands_open = false,
                },
                default(Duration::from_millis(20)) => {}
            }
            if !commands_open && !samples_open && !frames_open && self.pending.is_empty() {
                break;
            }
            self.label_pending(!samples_open)?;
            // A checkpoint waits for the pending frames (at most half a second), then syncs.
            if !checkpoints.is_empty() {
                let waited = checkpoints[0].2.elapsed();
                if self.pending.is_empty() || waited > Duration::from_millis(500) {
                    self.flush_force()?;
                    for (point, reply, _) in checkpoints.drain(..) {
                        let result = self.writer.checkpoint_at(point);
                        let _ = reply.send(result.map(|_| self.local.clone()));
                    }
                }
            }
            self.publish();
        }
        self.flush_force()?;
        self.publish();
        for (point, reply, _) in checkpoints.drain(..) {
            let result = self.writer.checkpoint_at(point);
            let _ = reply.send(result.map(|_| self.local.clone()));
        }
        Ok(())
    }

    fn sample(&mut self, s: ForceSample) -> Result<(), StoreError> {
        self.labeler.push_sample(&s);
        // A device restart starts its ticks again: the old ones no longer place anything.
        if self
            .recent_ticks
            .back()
            .is_some_and(|(t, _)| *t >= s.device_tick)
        {
            self.recent_ticks.clear();
        }
        if self.recent_ticks.len() >= RECENT_TICKS {
            self.recent_ticks.pop_front();
        }
        self.recent_ticks.push_back((s.device_tick, s.host_time));
        self.batch.push(s);
        if self.batch.len() >= 250 {
            self.flush_force()?;
        }
        Ok(())
    }

    /// Host time of the force stream's `tick`: the one-way fit of the newest samples' ticks
    /// and arrivals (`sync::one_way`, as the clock-fit method maps them), so samples that
    /// arrive in blocks (a DAQ read) are placed by the least-delayed of them, not by when
    /// their block came; `None` without a second of samples to fit.
    fn host_time_of_tick(&mut self, tick: f64) -> Option<HostTime> {
        let (&first, &last) = (self.recent_ticks.front()?, self.recent_ticks.back()?);
        let ticks = last.0.saturating_sub(first.0);
        let span_ns = last.1 .0 as f64 - first.1 .0 as f64;
        if ticks == 0 || span_ns < 1e9 {
            return None;
        }
        let options = OneWayOptions {
            clock: "force sample counter".into(),
            nominal_ns_per_tick: span_ns / ticks as f64,
            max_early_ns: 5e6,
        };
        let fit = one_way::fit(self.recent_ticks.make_contiguous(), &options).ok()?;
        Some(HostTime(fit.map.host_ns_f(tick).round().max(0.0) as u64))
    }

    fn flush_force(&mut self) -> Result<(), StoreError> {
        if !self.batch.is_empty() {
            self.writer.append_force(&self.batch)?;
            self.local.force_samples = self.writer.force_samples();
            self.batch.clear();
        }
        Ok(())
    }

    fn frame(&mut self, frame: Frame) {
        self.labeler.observe_frame(&frame);
        self.local.frames_seen += 1;
        self.gaps.observe(frame.id);
        self.local.dropped_frames = self.gaps.dropped();
        self.arrivals.push_back(frame.host_arrival);
        while self
            .arrivals
            .front()
            .is_some_and(|t| frame.host_arrival.0.saturating_sub(t.0) > 1_000_000_000)
        {
            self.arrivals.pop_front();
        }
        self.local.frame_rate_hz = self.arrivals.len() as f64;
        for tap in &self.taps {
            tap.seen(&frame);
        }
        if let Some(filming) = self.context.get() {
            self.pending.push_back((frame, filming));
        }
    }

    fn label_pending(&mut self, stream_closed: bool) -> Result<(), StoreError> {
        while let Some((frame, _)) = self.pending.front() {
            let outcome = self.labeler.label(frame);
            if outcome == LabelOutcome::NotYet && !stream_closed {
                break;
            }
            let Some((frame, filming)) = self.pending.pop_front() else {
                break;
            };
            self.write(&frame, &filming, outcome)?;
        }
        Ok(())
    }

    fn write(
        &mut self,
        frame: &Frame,
        filming: &Filming,
        outcome: LabelOutcome,
    ) -> Result<(), StoreError> {
        let index = self.writer.next_index();
        let mut notes = Vec::new();
        let (wrench, exposure_ticks, exposure) = match outcome {
            LabelOutcome::Ready(label) => {
                let m = label.mean.mean;
                let tared: [f64; 6] = std::array::from_fn(|k| m[k] - filming.tare[k]);
                if label.mean.max_spacing
                    > 2.5 * (label.window_ticks[1] - label.window_ticks[0]).max(1.0)
                {
                    notes.push("force samples missing inside the exposure window".to_string());
                }
                (
                    Some(Wrench::from_array(tared)),
                    Some(label.window_ticks),
                    label.window_host_ns.map(|[start_ns, end_ns]| Exposure {
                        start_ns,
                        end_ns,
                        error_ns: label.error_ns,
                    }),
                )
            }
            LabelOutcome::NotYet => {
                notes.push("the force stream ended before the exposure window".to_string());
                (None, None, None)
            }
            LabelOutcome::Unmatched(why) => {
                notes.push(why);
                (None, None, None)
            }
        };
        let file = self.writer.save_frame_image(frame, index)?;
        let in_contact = wrench.is_some_and(|w| in_contact(w.fz));
        // A sliding indenter is where its slide had taken it mid-exposure: on the host's time
        // base as the method gives it, else through the fit of the force samples' ticks to
        // their arrivals (else, last, the frame's arrival).
        let (commanded, contact) = match &filming.slide {
            Some(path) => {
                let mid = match (exposure, exposure_ticks) {
                    (Some(e), _) => HostTime(((e.start_ns + e.end_ns) / 2.0).max(0.0) as u64),
                    (None, Some([a, b])) => self
                        .host_time_of_tick((a + b) / 2.0)
                        .unwrap_or(frame.host_arrival),
                    (None, None) => frame.host_arrival,
                };
                let ([x, y], contact) = path.at(mid);
                let commanded = Position {
                    x: Millimetres(x),
                    y: Millimetres(y),
                    ..filming.commanded
                };
                (commanded, contact)
            }
            None => (filming.commanded, filming.contact),
        };
        let record = FrameRecord {
            index,
            frame_id: frame.id,
            file,
            device_timestamp: frame.device_timestamp,
            host_arrival_ns: frame.host_arrival.0,
            exposure,
            exposure_ticks,
            point: filming.point,
            commanded,
            measured: filming.measured,
            wrench,
            shear: wrench
                .zip(self.writer.ft_axes())
                .map(|(w, axes)| axes.surface_shear([w.fx.0, w.fy.0, w.fz.0])),
            shape: if in_contact {
                filming.shape.clone()
            } else {
                NO_CONTACT.into()
            },
            contact: in_contact.then_some(contact),
            valid: wrench.is_some() && notes.is_empty(),
            notes,
        };
        self.writer.append_frame(&record)?;
        for tap in &self.taps {
            tap.recorded(frame, &record);
        }
        if wrench.is_some() {
            self.local.frames_recorded += 1;
            self.local.last_label = wrench;
        } else {
            self.local.frames_unlabelled += 1;
        }
        Ok(())
    }

    fn publish(&mut self) {
        self.local.sync_error_ns = self.labeler.estimated_error_ns();
        *self.stats.lock().unwrap_or_else(|p| p.into_inner()) = self.local.clone();
    }
}
