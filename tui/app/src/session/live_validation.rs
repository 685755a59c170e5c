//! Live validation: a trained model run on the frames a scan records, each prediction set against
//! the label the scan writes for the same frame (the force averaged over its exposure window by
//! the run's synchronisation, the contact point and indenter of the press), with the paper's
//! metrics kept as it goes. The terminal UI shows the state; `fringe validate --no-tui` writes
//! the same evaluation as a report.
//!
//! Threads: the recorder hands each labelled frame to a short queue ([`ValidationTap`]) and
//! returns at once; one worker takes the frames in order, preprocesses each, runs the network and
//! publishes a [`ValidationState`]. The queue holds at most [`BACKLOG_FRAMES`]: a frame that took
//! the worker longer than the camera's period (a slow frame now and then, on 2 cores shared with
//! the camera and the recorder) leaves the next ones waiting, and the worker catches up; only when
//! the network is slower than the camera for longer than the queue lasts is the oldest waiting
//! frame counted as skipped (the newest frames are kept). How long each frame waited is kept.
//!
//! The figures are over the frames the run keeps: when the scan cuts the records of an
//! interrupted point (to press it again), the frames of those records are taken out of the
//! counts and the metrics ([`RecordTap::cut`]), and their number is reported as `cut`.

use crate::session::worker_failure::{guarded, inject};
use fringe_calibration::Profile;
use fringe_rig::store::FrameRecord;
use fringe_rig::Frame;
use fringe_rig::RecordTap;
use fringe_sensor_models::dataset::{from_record, Sample};
use fringe_sensor_models::eval::{keys, score, Evaluation, Row};
use fringe_sensor_models::Prediction;
use fringe_sensor_models::{tensor_image, thumbnail, FrameRef, PreprocessError, Preprocessor};
use fringe_sensor_models::{Errors, Metrics};
use fringe_sensor_models::{Model, ModelError};
use fringe_sensor_models::{PredictError, Predictor};
use fringe_sensor_models::{Reading, SlipTracker};
use std::collections::VecDeque;
use std::path::PathBuf;
use std::sync::{Arc, Condvar, Mutex, MutexGuard};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// Inference threads per network in live validation by default: on 2 cores beside the camera and
/// the recorder, one thread tended to skip fewer frames than two (BENCHMARKS.md, "Live
/// validation").
pub const THREADS_PER_NETWORK: usize = 1;

/// Labelled frames that may wait for the worker by default: at 50 fps, 200 ms of frames. With one
/// frame (the newest only) a model needing 6-16 ms of the 20 ms a frame allows still skipped 1-9
/// frames of 1546, each after a rare slow frame, and with 5 one stall of 96 ms still cost a
/// frame (BENCHMARKS.md, "Live validation").
pub const BACKLOG_FRAMES: usize = 10;

/// The worker thread's name (and the name that injects a panic into it,
/// [`crate::session::worker_failure`]).
pub(crate) const WORKER_NAME: &str = "live-validation";

/// Predicted and measured Fz kept for the chart.
pub(crate) const HISTORY: usize = 600;
/// Side of the raw-frame picture published with each prediction, px.
pub(crate) const THUMBNAIL_PX: u32 = 96;

/// One point of the Fz chart.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FzPoint {
    /// Seconds since validation started.
    pub t_s: f64,
    pub measured_n: f64,
    pub predicted_n: f64,
}

/// The newest prediction with its label and pictures.
#[derive(Debug, Clone)]
pub struct Latest {
    pub prediction: Prediction,
    pub label: Sample,
    /// The whole frame, small (RGB).
    pub frame: image::RgbImage,
    /// What the network saw (RGB).
    pub input: image::RgbImage,
}

/// One frame the network ran on, for reports.
#[derive(Debug, Clone)]
pub struct ValidatedFrame {
    /// The camera's frame id and the run's record index.
    pub frame_id: u64,
    pub record_index: u64,
    /// Seconds since validation started.
    pub t_s: f64,
    pub label: Sample,
    pub prediction: Prediction,
    /// Preprocessing plus inference, ms.
    pub latency_ms: f64,
    /// From the recorder's offer to the worker taking it, ms.
    pub waited_ms: f64,
}

/// What a finished live validation leaves.
#[derive(Debug, Clone)]
pub struct Validation {
    /// The paper's metrics over every frame scored (skipped frames counted in `skipped`).
    pub evaluation: Evaluation,
    pub state: ValidationState,
    pub frames: Vec<ValidatedFrame>,
}

/// Errors of one grid cell (stage position of the press).
#[derive(Debug, Clone, PartialEq)]
pub struct CellErrors {
    pub stage_mm: [f64; 2],
    pub errors: Errors,
}

/// What live validation publishes.
#[derive(Debug, Clone)]
pub struct ValidationState {
    /// The model, as `fringe model info` names it.
    pub model: String,
    pub backend: &'static str,
    /// Labelled frames the recorder offered.
    pub offered: u64,
    /// Frames the network ran on.
    pub ran: u64,
    /// Labelled frames the network was too busy to take.
    pub skipped: u64,
    /// Labelled frames offered, then cut from the run with the records of an interrupted point
    /// (not in `offered`, `ran`, `skipped` nor the metrics).
    pub cut: u64,
    /// Predictions per second over the last second.
    pub loop_hz: f64,
    /// Preprocessing plus inference of the newest frame, ms.
    pub latency_ms: f64,
    /// How long the newest frame waited for the worker, ms.
    pub waited_ms: f64,
    /// Frames waiting for the worker now.
    pub waiting: usize,
    /// Frames that may wait before the oldest is skipped (as started).
    pub backlog: usize,
    pub history: VecDeque<FzPoint>,
    pub latest: Option<Latest>,
    /// Running errors over every frame.
    pub errors: Errors,
    /// By grid cell, in the order first seen.
    pub cells: Vec<CellErrors>,
    /// Why the worker stopped, if it failed.
    pub failure: Option<String>,
    /// Set before the scan when the model is slower than the camera allows: its time per frame
    /// against the frame period, in one line (`crate::session::model_pace`).
    pub behind: Option<String>,
}

/// Why the validation worker stopped.
#[derive(Debug, thiserror::Error)]
pub(crate) enum ValidationError {
    #[error("frame {frame}: {source}")]
    Frame {
        frame: u64,
        #[source]
        source: PreprocessError,
    },
    #[error("{source}")]
    Inference {
        #[source]
        source: PredictError,
    },
    #[error("{}: the network gave no prediction", .model.display())]
    NoPrediction { model: PathBuf },
}

/// A labelled frame handed to the worker, with the cut generation it belongs to.
struct Offer {
    frame: Frame,
    record: FrameRecord,
    generation: u64,
    offered_at: Instant,
}

#[derive(Default)]
struct Mailbox {
    /// Frames waiting for the worker, oldest first; at most `backlog`.
    waiting: VecDeque<Offer>,
    backlog: usize,
    /// Record indices of the frames offered, and of those skipped, that the run still holds.
    offered: Vec<u64>,
    skipped: Vec<u64>,
    cut: u64,
    /// Goes up with every cut: a frame taken before a cut is not published after it.
    generation: u64,
    closed: bool,
    busy: bool,
}

impl Mailbox {
    /// Queues `offer`; when `backlog` frames already wait, the oldest of them is skipped.
    fn put(&mut self, offer: Offer) {
        self.offered.push(offer.record.index);
        self.waiting.push_back(offer);
        while self.waiting.len() > self.backlog.max(1) {
            if let Some(old) = self.waiting.pop_front() {
                self.skipped.push(old.record.index);
            }
        }
    }

    /// True when no frame waits and the worker is idle.
    fn idle(&self) -> bool {
        self.waiting.is_empty() && !self.busy
    }
}

/// Lock order: `mailbox`, then `state`, `evaluation`, `frames`.
struct Shared {
    mailbox: Mutex<Mailbox>,
    wake: Condvar,
    state: Mutex<ValidationState>,
    evaluation: Mutex<Evaluation>,
    frames: Mutex<Vec<ValidatedFrame>>,
    classes: Vec<String>,
}

impl Shared {
    /// Adds one prediction to the running errors, the grid cells and the evaluation. A label
    /// whose indenter the model does not know is shown, not scored.
    fn tally(
        &self,
        state: &mut ValidationState,
        evaluation: &mut Evaluation,
        label: &Sample,
        prediction: &Prediction,
    ) {
        let Some(shape_true) = self.classes.iter().position(|c| *c == label.shape) else {
            return;
        };
        let scored = score(&self.classes, shape_true, label, prediction);
        state.errors.add(&scored);
        if let Some(stage) = label.stage_mm {
            match state.cells.iter_mut().find(|c| c.stage_mm == stage) {
                Some(c) => c.errors.add(&scored),
                None => {
                    let mut errors = Errors::default();
                    errors.add(&scored);
                    state.cells.push(CellErrors {
                        stage_mm: stage,
                        errors,
                    });
                }
            }
        }
        evaluation.metrics.add(&scored, &keys(label));
        evaluation.labels_know_shear |= label.shear.is_some();
        evaluation.rows.push(Row {
            scored,
            stage_mm: label.stage_mm,
            press: label.press.clone(),
        });
    }

    /// Forgets the frames of records `first` and later (cut from the run): the counts, errors,
    /// cells and evaluation are made again from the frames the run keeps. Called with the
    /// mailbox locked.
    fn forget_from(&self, first: u64) {
        let mut state = lock(&self.state);
        let mut evaluation = lock(&self.evaluation);
        let mut frames = lock(&self.frames);
        frames.retain(|f| f.record_index < first);
        state.ran = frames.len() as u64;
        state.errors = Errors::default();
        state.cells.clear();
        *evaluation = Evaluation {
            metrics: Metrics::new(self.classes.clone()),
            rows: Vec::new(),
            skipped: 0,
            skipped_busy: 0,
            labels_know_shear: false,
        };
        for f in frames.iter() {
            self.tally(&mut state, &mut evaluation, &f.label, &f.prediction);
        }
    }
}

fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|p| p.into_inner())
}

/// The recorder's side: hands labelled frames to the worker without waiting.
pub(crate) struct ValidationTap(Arc<Shared>);

impl std::fmt::Debug for ValidationTap {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("ValidationTap")
    }
}

impl RecordTap for ValidationTap {
    fn recorded(&self, frame: &Frame, record: &FrameRecord) {
        if record.wrench.is_none() || !record.valid {
            return;
        }
        let mut m = lock(&self.0.mailbox);
        if m.closed {
            return;
        }
        let offer = Offer {
            frame: frame.clone(),
            record: record.clone(),
            generation: m.generation,
            offered_at: Instant::now(),
        };
        m.put(offer);
        drop(m);
        self.0.wake.notify_one();
    }

    fn cut(&self, first: u64) {
        let mut m = lock(&self.0.mailbox);
        let before = m.offered.len();
        m.offered.retain(|&i| i < first);
        m.skipped.retain(|&i| i < first);
        m.cut += (before - m.offered.len()) as u64;
        m.waiting.retain(|o| o.record.index < first);
        m.generation += 1;
        self.0.forget_from(first);
    }
}

/// A model validating live frames.
pub struct LiveValidation {
    shared: Arc<Shared>,
    worker: Option<JoinHandle<()>>,
}

/// How frames are read and which run they belong to.
#[derive(Debug, Clone)]
pub struct FrameSource {
    /// The run's id (names the presses of the labels).
    pub run_id: String,
    /// The calibration profile whose geometry crops the frames.
    pub profile: Profile,
}

impl LiveValidation {
    /// Starts the worker for `model` on `predictor` (its networks on a backend), with at most
    /// `backlog` frames waiting for it ([`BACKLOG_FRAMES`]; 1 keeps only the newest); the tap
    /// goes into the scan's setup.
    pub fn start(
        model: Model,
        predictor: Predictor,
        source: FrameSource,
        backlog: usize,
    ) -> Result<(LiveValidation, Arc<dyn RecordTap>), ModelError> {
        let preprocessing = model.preprocessing(Some(&source.profile), None)?;
        let state = ValidationState {
            model: format!("{} ({})", model.path.display(), model.describe()),
            backend: predictor.backend_name(),
            offered: 0,
            ran: 0,
            skipped: 0,
            cut: 0,
            loop_hz: 0.0,
            latency_ms: 0.0,
            waited_ms: 0.0,
            waiting: 0,
            backlog: backlog.max(1),
            history: VecDeque::with_capacity(HISTORY),
            latest: None,
            errors: Errors::default(),
            cells: Vec::new(),
            failure: None,
            behind: None,
        };
        let shared = Arc::new(Shared {
            mailbox: Mutex::new(Mailbox {
                backlog,
                ..Mailbox::default()
            }),
            wake: Condvar::new(),
            state: Mutex::new(state),
            evaluation: Mutex::new(Evaluation {
                metrics: Metrics::new(model.classes.clone()),
                rows: Vec::new(),
                skipped: 0,
                skipped_busy: 0,
                labels_know_shear: false,
            }),
            frames: Mutex::new(Vec::new()),
            classes: model.classes.clone(),
        });
        let model_slip = model
            .slip_head()
            .map(|head| (SlipTracker::new(head), String::new()));
        let worker = Worker {
            shared: shared.clone(),
            model,
            predictor,
            pre: Preprocessor::new(preprocessing),
            source,
            started: Instant::now(),
            recent: VecDeque::new(),
            pictured: None,
            slip: model_slip,
        };
        let handle = std::thread::Builder::new()
            .name(WORKER_NAME.into())
            .spawn(move || worker.run())
            .map_err(|e| ModelError::Backend {
                path: "live validation".into(),
                source: fringe_sensor_models::InferenceError::Run {
                    backend: "thread",
                    detail: e.to_string(),
                },
            })?;
        let tap = Arc::new(ValidationTap(shared.clone())) as Arc<dyn RecordTap>;
        Ok((
            LiveValidation {
                shared,
                worker: Some(handle),
            },
            tap,
        ))
    }

    /// Records that the model is slower than the camera allows (`line`, shown while it runs).
    pub fn set_behind(&self, line: String) {
        lock(&self.shared.state).behind = Some(line);
    }

    /// The state now (a copy: the worker goes on).
    pub fn state(&self) -> ValidationState {
        let mut s = lock(&self.shared.state).clone();
        let m = lock(&self.shared.mailbox);
        s.offered = m.offered.len() as u64;
        s.skipped = m.skipped.len() as u64;
        s.cut = m.cut;
        s.waiting = m.waiting.len();
        s
    }

    /// Finishes the frames in hand and waiting (up to `timeout`), stops the worker and returns the
    /// evaluation of every frame it ran on, with the frames it skipped counted.
    pub fn finish(mut self, timeout: Duration) -> Validation {
        let deadline = Instant::now() + timeout;
        loop {
            let m = lock(&self.shared.mailbox);
            if m.idle() || Instant::now() >= deadline {
                break;
            }
            drop(m);
            std::thread::sleep(Duration::from_millis(5));
        }
        self.close();
        let state = self.state();
        let mut evaluation = lock(&self.shared.evaluation).clone();
        evaluation.skipped_busy = state.skipped as usize;
        let frames = std::mem::take(&mut *lock(&self.shared.frames));
        Validation {
            evaluation,
            state,
            frames,
        }
    }

    fn close(&mut self) {
        {
            let mut m = lock(&self.shared.mailbox);
            m.closed = true;
            let left: Vec<u64> = m.waiting.drain(..).map(|o| o.record.index).collect();
            m.skipped.extend(left);
        }
        self.shared.wake.notify_all();
        if let Some(h) = self.worker.take() {
            let _ = h.join();
        }
    }
}

impl Drop for LiveValidation {
    fn drop(&mut self) {
        self.close();
    }
}

/// How long one frame took: waiting for the worker, then preprocessing and inference.
#[derive(Debug, Clone, Copy)]
struct Timing {
    latency_ms: f64,
    waited_ms: f64,
}

struct Worker {
    shared: Arc<Shared>,
    model: Model,
    predictor: Predictor,
    pre: Preprocessor,
    source: FrameSource,
    started: Instant,
    recent: VecDeque<Instant>,
    /// When the pictures of the newest prediction were last made (at most [`PICTURE_RATE_HZ`]).
    pictured: Option<Instant>,
    /// The model's slip head over the frames of the current press (a model with one), and
    /// the press.
    slip: Option<(SlipTracker, String)>,
}

/// Pictures (frame and network input) made per second at most: the screen needs no more, and
/// every frame's pictures would take time from inference.
pub(crate) const PICTURE_RATE_HZ: f64 = 10.0;

impl Worker {
    fn run(mut self) {
        let mut input = vec![0f32; self.pre.config.tensor_len()];
        loop {
            let offer = {
                let mut m = lock(&self.shared.mailbox);
                m.busy = false;
                loop {
                    if let Some(next) = m.waiting.pop_front() {
                        m.busy = true;
                        break next;
                    }
                    if m.closed {
                        return;
                    }
                    m = self.shared.wake.wait(m).unwrap_or_else(|p| p.into_inner());
                }
            };
            // A panic (a defect, not a frame's error) stops the worker as an error does: its
            // owner sees the failure, and the frames waiting are not left to wait for a worker
            // that is gone.
            let outcome = guarded("live validation", || {
                inject(WORKER_NAME);
                self.one(&offer, &mut input).map_err(|e| e.to_string())
            })
            .and_then(|r| r);
            if let Err(why) = outcome {
                lock(&self.shared.state).failure = Some(why);
                let mut m = lock(&self.shared.mailbox);
                m.closed = true;
                m.busy = false;
                return;
            }
        }
    }

    /// Runs the network on one offered frame and publishes its prediction against the frame's
    /// label (a frame without a label, or cut from the run meanwhile, is passed over).
    fn one(&mut self, offer: &Offer, input: &mut [f32]) -> Result<(), ValidationError> {
        let (frame, record) = (&offer.frame, &offer.record);
        let t0 = Instant::now();
        let waited_ms = t0.duration_since(offer.offered_at).as_secs_f64() * 1e3;
        // The frame is at hand: the label's sample needs no file storage to read it from.
        let Some(label) = from_record(
            record,
            &self.source.run_id,
            record.file.clone().into(),
            None,
            None,
        ) else {
            return Ok(());
        };
        let fref = FrameRef::from(frame);
        let Some(mut prediction) = self.infer(fref, frame.id, input)?.into_iter().next() else {
            return Err(ValidationError::NoPrediction {
                model: self.model.path.clone(),
            });
        };
        if let Some((tracker, press)) = &mut self.slip {
            // The slip head reads the frames of one press in order (a frame skipped while the
            // model was busy is not read).
            if *press != label.press {
                tracker.reset();
                press.clone_from(&label.press);
            }
            prediction.slip = tracker.next(Reading::of_prediction(&prediction));
        }
        let latency_ms = t0.elapsed().as_secs_f64() * 1e3;
        let now = Instant::now();
        self.count_rate(now);
        let pictures = self.pictures(now, fref, frame.id, input)?;
        // Held while the prediction is published: a cut waits for it, then takes it out.
        let mailbox = lock(&self.shared.mailbox);
        if mailbox.generation != offer.generation {
            // Its record was cut from the run while the network ran.
            return Ok(());
        }
        self.publish(
            offer,
            label,
            prediction,
            Timing {
                latency_ms,
                waited_ms,
            },
            pictures,
        );
        Ok(())
    }

    /// Preprocesses frame `frame_id` into `input` and runs the model's networks on it.
    fn infer(
        &mut self,
        fref: FrameRef,
        frame_id: u64,
        input: &mut [f32],
    ) -> Result<Vec<Prediction>, ValidationError> {
        self.pre
            .run_into(fref, 0.0, input)
            .map_err(|source| ValidationError::Frame {
                frame: frame_id,
                source,
            })?;
        self.predictor
            .predict(
                input,
                1,
                &[fref],
                &self.pre.config,
                Some(&self.source.profile),
            )
            .map_err(|source| ValidationError::Inference { source })
    }

    /// Counts a prediction made at `now` in the rate over the last second.
    fn count_rate(&mut self, now: Instant) {
        self.recent.push_back(now);
        while self
            .recent
            .front()
            .is_some_and(|t| now.duration_since(*t) > Duration::from_secs(1))
        {
            self.recent.pop_front();
        }
    }

    /// The frame's and the network input's pictures, when they are due (at most
    /// [`PICTURE_RATE_HZ`]).
    fn pictures(
        &mut self,
        now: Instant,
        fref: FrameRef,
        frame_id: u64,
        input: &[f32],
    ) -> Result<Option<(image::RgbImage, image::RgbImage)>, ValidationError> {
        let due = self
            .pictured
            .is_none_or(|t| now.duration_since(t).as_secs_f64() >= 1.0 / PICTURE_RATE_HZ);
        if !due {
            return Ok(None);
        }
        self.pictured = Some(now);
        let frame = thumbnail(fref, THUMBNAIL_PX).map_err(|source| ValidationError::Frame {
            frame: frame_id,
            source,
        })?;
        let size = self.pre.config.input_size;
        Ok(Some((frame, tensor_image(input, size).unwrap_or_default())))
    }

    /// Publishes a prediction: the counts, the chart, the metrics, the frame for reports and
    /// the newest prediction (with the last pictures when none were made for it).
    fn publish(
        &self,
        offer: &Offer,
        label: Sample,
        prediction: Prediction,
        timing: Timing,
        pictures: Option<(image::RgbImage, image::RgbImage)>,
    ) {
        let mut state = lock(&self.shared.state);
        state.ran += 1;
        state.loop_hz = self.recent.len() as f64;
        state.latency_ms = timing.latency_ms;
        state.waited_ms = timing.waited_ms;
        if state.history.len() == HISTORY {
            state.history.pop_front();
        }
        state.history.push_back(FzPoint {
            t_s: self.started.elapsed().as_secs_f64(),
            measured_n: label.fz(),
            predicted_n: prediction.force.fz.value(),
        });
        self.shared.tally(
            &mut state,
            &mut lock(&self.shared.evaluation),
            &label,
            &prediction,
        );
        lock(&self.shared.frames).push(ValidatedFrame {
            frame_id: offer.frame.id,
            record_index: offer.record.index,
            t_s: self.started.elapsed().as_secs_f64(),
            label: label.clone(),
            prediction: prediction.clone(),
            latency_ms: timing.latency_ms,
            waited_ms: timing.waited_ms,
        });
        // Between pictures the newest prediction is shown with the last pictures.
        let (frame_picture, input_picture) = match (pictures, state.latest.take()) {
            (Some(p), _) => p,
            (None, Some(old)) => (old.frame, old.input),
            (None, None) => Default::default(),
        };
        state.latest = Some(Latest {
            prediction,
            label,
            frame: frame_picture,
            input: input_picture,
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use fringe_calibration::{ImageSize, Optical};
    use fringe_rig::store::Position;
    use fringe_rig::HostTime;
    use fringe_rig::PixelFormat;
    use fringe_rig::{Millimetres, Newtons, Wrench};
    use fringe_sensor_models::BackendKind;
    use std::path::Path;

    const SIDE: u32 = 64;

    fn profile() -> Profile {
        let c = f64::from(SIDE) / 2.0;
        Profile {
            sensor_id: "test".into(),
            created_utc: "2026-01-01T00:00:00Z".into(),
            source: "test".into(),
            image: ImageSize {
                width: SIDE,
                height: SIDE,
            },
            optical: Optical {
                centre_x_px: c,
                centre_y_px: c,
                shift_x_px: 0.0,
                shift_y_px: 0.0,
                radius_px: c - 2.0,
                crop_radius_px: c - 4.0,
                sigma_x_px: 0.0,
                sigma_y_px: 0.0,
                sigma_radius_px: 0.0,
                residual_rms_px: 0.0,
                frames: 1,
            },
            registration: None,
            force_offsets: None,
        }
    }

    fn frame(id: u64) -> Frame {
        Frame {
            id,
            device_timestamp: id,
            host_arrival: HostTime::now(),
            width: SIDE,
            height: SIDE,
            format: PixelFormat::Mono8,
            data: vec![(id % 200) as u8; (SIDE * SIDE) as usize],
        }
    }

    /// A labelled record: index `index`, pressed with `fz` N (the F/T reads the press negative).
    fn record(index: u64, fz: f64) -> FrameRecord {
        let at = |v: f64| Position {
            x: Millimetres(v),
            y: Millimetres(25.0),
            z: Millimetres(14.0),
        };
        FrameRecord {
            index,
            frame_id: index,
            file: format!("frames/{index:06}.png"),
            device_timestamp: index,
            host_arrival_ns: index,
            exposure: None,
            exposure_ticks: None,
            point: index / 4,
            commanded: at(12.5),
            measured: at(12.5),
            wrench: Some(Wrench {
                fz: Newtons(-fz),
                ..Wrench::default()
            }),
            shear: None,
            shape: "pentagon".into(),
            contact: Some([0.0, 0.0]),
            valid: true,
            notes: Vec::new(),
        }
    }

    /// Offers `frame` as record `index` and waits until the worker has taken it (none is
    /// skipped).
    fn offer(tap: &Arc<dyn RecordTap>, live: &LiveValidation, frame: &Frame, index: u64, fz: f64) {
        tap.recorded(frame, &record(index, fz));
        let t0 = Instant::now();
        while t0.elapsed() < Duration::from_secs(60) {
            let m = lock(&live.shared.mailbox);
            if m.idle() {
                return;
            }
            drop(m);
            std::thread::sleep(Duration::from_millis(2));
        }
        panic!("the worker did not take frame {index}");
    }

    /// Live validation of the committed custom-CNN fixture on 64 px frames, with the default
    /// queue.
    fn fixture_validation() -> (LiveValidation, Arc<dyn RecordTap>) {
        let weights = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../sensor-models/tests/fixtures/custom/model.safetensors");
        let model = Model::open(&weights).expect("fixture model");
        let predictor = Predictor::new(&model, BackendKind::Tract, 1).expect("tract");
        let source = FrameSource {
            run_id: "run".into(),
            profile: profile(),
        };
        LiveValidation::start(model, predictor, source, BACKLOG_FRAMES).expect("start")
    }

    #[test]
    fn frames_of_records_cut_from_the_run_leave_the_counts_and_the_metrics() {
        let (live, tap) = fixture_validation();
        // Records 0..4 are kept; 4..8 belong to a point that is interrupted, cut and done again
        // with other labels under the same indices.
        for i in 0..8 {
            offer(&tap, &live, &frame(i), i, if i < 4 { 1.0 } else { 7.0 });
        }
        assert_eq!(live.state().ran, 8);
        tap.cut(4);
        let s = live.state();
        assert_eq!((s.offered, s.ran, s.cut), (4, 4, 4));
        for i in 4..10 {
            offer(&tap, &live, &frame(i), i, 2.0);
        }
        let v = live.finish(Duration::from_secs(30));
        assert_eq!(v.state.offered, 10);
        assert_eq!(v.state.ran + v.state.skipped, 10);
        assert_eq!(v.state.cut, 4);
        let mut indices: Vec<u64> = v.frames.iter().map(|f| f.record_index).collect();
        indices.sort_unstable();
        assert_eq!(indices, (0..10).collect::<Vec<_>>());
        // No label of the cut attempt (7 N) is left in the frames or in the metrics.
        assert!(v.frames.iter().all(|f| (f.label.fz() - 7.0).abs() > 1.0));
        assert_eq!(v.evaluation.rows.len(), 10);
        assert!(v
            .evaluation
            .rows
            .iter()
            .all(|r| (r.scored.fz_true - 7.0).abs() > 1.0));
        assert_eq!(v.state.errors.n, 10);
    }

    /// With the queue full, a new frame pushes out the oldest waiting one, which is counted as
    /// skipped: the frames kept are the newest, in the order they came.
    #[test]
    fn a_full_queue_skips_its_oldest_frame_and_keeps_the_newest() {
        let mut m = Mailbox {
            backlog: 3,
            ..Mailbox::default()
        };
        for i in 0..5 {
            m.put(Offer {
                frame: frame(i),
                record: record(i, 1.0),
                generation: 0,
                offered_at: Instant::now(),
            });
        }
        let waiting: Vec<u64> = m.waiting.iter().map(|o| o.record.index).collect();
        assert_eq!(waiting, [2, 3, 4]);
        assert_eq!(m.skipped, [0, 1]);
        assert_eq!(m.offered, [0, 1, 2, 3, 4]);
    }

    /// Frames that come faster than the network runs (a burst after a slow frame) wait for the
    /// worker instead of being skipped, and are all run in the order they came.
    #[test]
    fn a_burst_the_queue_holds_is_run_in_full_and_in_order() {
        let (live, tap) = fixture_validation();
        let n = BACKLOG_FRAMES as u64;
        // Offered back to back, without waiting for the worker.
        let offering = Instant::now();
        for i in 0..n {
            tap.recorded(&frame(i), &record(i, 1.0 + i as f64));
        }
        let offering_ms = offering.elapsed().as_secs_f64() * 1e3;
        let v = live.finish(Duration::from_secs(30));
        assert_eq!(v.state.failure, None);
        assert_eq!((v.state.offered, v.state.ran, v.state.skipped), (n, n, 0));
        let order: Vec<u64> = v.frames.iter().map(|f| f.record_index).collect();
        assert_eq!(order, (0..n).collect::<Vec<_>>());
        // The last frame waited while the worker ran every frame before it. The worker can
        // have started on the first frame at most the offering's span before the last frame
        // was offered (a loaded machine can stretch that span past a millisecond).
        let (last, before) = v.frames.split_last().expect("frames");
        let ran_before: f64 = before.iter().map(|f| f.latency_ms).sum();
        assert!(
            last.waited_ms >= ran_before - offering_ms - 0.01,
            "waited {} ms; the frames before it ran for {ran_before} ms; offering took \
             {offering_ms} ms",
            last.waited_ms
        );
    }

    /// A two-stage model's window networks run live on the frame the first network read: its
    /// live predictions are those it makes of the same frames one by one, offline.
    #[cfg(feature = "sim")]
    #[test]
    fn a_two_stage_models_live_predictions_are_those_it_makes_frame_by_frame() {
        use fringe_sim::dataset::{pressed_frame, shape_named};
        use fringe_sim::Renderer;
        use fringe_sim::SensorConfig;
        use fringe_sim::{Contact, FrameRenderer};

        let sensor = SensorConfig::layered();
        let profile = crate::rig::simulated::sensor_profile(
            &sensor,
            &sensor.id,
            "the simulated layered sensor's design geometry".into(),
            [0.0, 0.0],
        );
        let mut renderer = Renderer::new(sensor.clone()).expect("renderer");
        let tip = shape_named(&sensor, "pentagon").expect("pentagon");
        // Presses at several places and forces, and one frame without contact.
        let presses = [
            Some((3.0, [0.0, 0.0])),
            Some((6.5, [4.0, -3.0])),
            None,
            Some((1.5, [-6.0, 2.0])),
            Some((8.0, [2.0, 7.0])),
        ];
        let frames: Vec<Frame> = presses
            .iter()
            .enumerate()
            .map(|(i, press)| {
                let contact = press.map(|(f, [x, y])| {
                    (
                        "pentagon",
                        Contact {
                            shape: tip,
                            force: Newtons(f),
                            x: Millimetres(x),
                            y: Millimetres(y),
                            angle_deg: 0.0,
                            shear: None,
                        },
                    )
                });
                let f = pressed_frame(3, i as u64, contact);
                let mut data = Vec::new();
                renderer.render_as(&f.scene, f.render_index, PixelFormat::Mono8, &mut data);
                Frame {
                    id: i as u64,
                    device_timestamp: i as u64,
                    host_arrival: HostTime::now(),
                    width: renderer.width(),
                    height: renderer.height(),
                    format: PixelFormat::Mono8,
                    data,
                }
            })
            .collect();

        let spec = Path::new("builtin:layered-two-stage");
        let model = fringe_sensor_models::builtin::open(spec).expect("two-stage model");
        let config = model
            .preprocessing(Some(&profile), None)
            .expect("preprocessing");
        let mut pre = Preprocessor::new(config.clone());
        let mut offline = Predictor::new(&model, BackendKind::Tract, 1).expect("tract");
        // Its first network alone (the same weights).
        let keypoint = fringe_sensor_models::builtin::open(Path::new("builtin:layered-keypoint"))
            .expect("keypoint CNN");
        let mut first_alone = Predictor::new(&keypoint, BackendKind::Tract, 1).expect("tract");
        let mut input = vec![0f32; config.tensor_len()];
        let mut expected = Vec::new();
        let mut moved_by_windows = 0;
        for frame in &frames {
            pre.run_into(FrameRef::from(frame), 0.0, &mut input)
                .expect("input");
            let at = |p: &mut Predictor| {
                p.predict(&input, 1, &[FrameRef::from(frame)], &config, Some(&profile))
                    .expect("prediction")
                    .remove(0)
            };
            let whole = at(&mut offline);
            let first = at(&mut first_alone);
            if (whole.force.fz.value() - first.force.fz.value()).abs() > 0.01 {
                moved_by_windows += 1;
            }
            expected.push(whole);
        }
        // The window networks change what the first network alone says.
        assert!(
            moved_by_windows >= 3,
            "{moved_by_windows} of {}",
            frames.len()
        );

        let predictor = Predictor::new(&model, BackendKind::Tract, 1).expect("tract");
        let source = FrameSource {
            run_id: "run".into(),
            profile: profile.clone(),
        };
        let (live, tap) =
            LiveValidation::start(model, predictor, source, BACKLOG_FRAMES).expect("start");
        for (i, frame) in frames.iter().enumerate() {
            offer(&tap, &live, frame, i as u64, 2.0);
        }
        let v = live.finish(Duration::from_secs(60));
        assert_eq!(v.state.failure, None);
        assert_eq!((v.state.ran, v.state.skipped), (5, 0));
        for f in &v.frames {
            let want = &expected[f.record_index as usize];
            let got = &f.prediction;
            assert!(
                (got.force.fz.value() - want.force.fz.value()).abs() < 1e-4,
                "frame {}: Fz {} live, {} frame by frame",
                f.record_index,
                got.force.fz.value(),
                want.force.fz.value()
            );
            assert_eq!(got.contact, want.contact, "frame {}", f.record_index);
        }
    }
}
