//! Live validation: a trained model run on the frames a scan records, each prediction set against
//! the label the scan writes for the same frame (the force averaged over its exposure window by
//! the run's synchronisation, the contact point and indenter of the press), with the paper's
//! metrics kept as it goes. The terminal UI shows the state; `fringe validate --no-tui` writes
//! the same evaluation as a report.
//!
//! Threads: the recorder hands each labelled frame to a one-frame mailbox ([`ValidationTap`]) and
//! returns at once; one worker takes the newest frame, preprocesses it, runs the network and
//! publishes a [`ValidationState`]. When the network is slower than the camera the frames it
//! could not take are counted as skipped, never queued.

use fringe_calibration::profile::Profile;
use fringe_rig::acquire::record_tap::RecordTap;
use fringe_rig::camera::Frame;
use fringe_rig::store::documents::FrameRecord;
use fringe_sensor_models::backend::Backend;
use fringe_sensor_models::dataset::{from_record, Sample};
use fringe_sensor_models::eval::{keys, score, Evaluation, Row};
use fringe_sensor_models::metrics::{Errors, Metrics};
use fringe_sensor_models::model::{Model, ModelError};
use fringe_sensor_models::prediction::{predictions, Prediction};
use fringe_sensor_models::preprocess::{tensor_image, thumbnail, FrameRef, Preprocessor};
use std::collections::VecDeque;
use std::sync::{Arc, Condvar, Mutex, MutexGuard};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// Predicted and measured Fz kept for the chart.
pub const HISTORY: usize = 600;
/// Side of the raw-frame picture published with each prediction, px.
pub const THUMBNAIL_PX: u32 = 96;

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
    /// Predictions per second over the last second.
    pub loop_hz: f64,
    /// Preprocessing plus inference of the newest frame, ms.
    pub latency_ms: f64,
    pub history: VecDeque<FzPoint>,
    pub latest: Option<Latest>,
    /// Running errors over every frame.
    pub errors: Errors,
    /// By grid cell, in the order first seen.
    pub cells: Vec<CellErrors>,
    /// Why the worker stopped, if it failed.
    pub failure: Option<String>,
}

#[derive(Default)]
struct Mailbox {
    next: Option<(Frame, FrameRecord)>,
    offered: u64,
    skipped: u64,
    closed: bool,
    busy: bool,
}

struct Shared {
    mailbox: Mutex<Mailbox>,
    wake: Condvar,
    state: Mutex<ValidationState>,
    evaluation: Mutex<Evaluation>,
    frames: Mutex<Vec<ValidatedFrame>>,
}

fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|p| p.into_inner())
}

/// The recorder's side: hands labelled frames to the worker without waiting.
pub struct ValidationTap(Arc<Shared>);

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
        m.offered += 1;
        if m.next.replace((frame.clone(), record.clone())).is_some() {
            m.skipped += 1;
        }
        drop(m);
        self.0.wake.notify_one();
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
    /// Starts the worker for `model` on `backend`; the tap goes into the scan's setup.
    pub fn start(
        model: Model,
        backend: Box<dyn Backend>,
        source: FrameSource,
    ) -> Result<(LiveValidation, Arc<dyn RecordTap>), ModelError> {
        let preprocessing = model.preprocessing(Some(&source.profile), None)?;
        let state = ValidationState {
            model: format!("{} ({})", model.path.display(), model.describe()),
            backend: backend.name(),
            offered: 0,
            ran: 0,
            skipped: 0,
            loop_hz: 0.0,
            latency_ms: 0.0,
            history: VecDeque::with_capacity(HISTORY),
            latest: None,
            errors: Errors::default(),
            cells: Vec::new(),
            failure: None,
        };
        let shared = Arc::new(Shared {
            mailbox: Mutex::new(Mailbox::default()),
            wake: Condvar::new(),
            state: Mutex::new(state),
            evaluation: Mutex::new(Evaluation {
                metrics: Metrics::new(model.classes.clone()),
                rows: Vec::new(),
                skipped: 0,
            }),
            frames: Mutex::new(Vec::new()),
        });
        let worker = Worker {
            shared: shared.clone(),
            model,
            backend,
            pre: Preprocessor::new(preprocessing),
            source,
            started: Instant::now(),
            recent: VecDeque::new(),
            pictured: None,
        };
        let handle = std::thread::Builder::new()
            .name("live-validation".into())
            .spawn(move || worker.run())
            .map_err(|e| ModelError::Backend {
                path: "live validation".into(),
                source: fringe_sensor_models::backend::InferenceError::Run {
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

    /// The state now (a copy: the worker goes on).
    pub fn state(&self) -> ValidationState {
        let mut s = lock(&self.shared.state).clone();
        let m = lock(&self.shared.mailbox);
        s.offered = m.offered;
        s.skipped = m.skipped;
        s
    }

    /// Finishes the frame in hand (up to `timeout`), stops the worker and returns the
    /// evaluation of every frame it ran on, with the frames it skipped counted.
    pub fn finish(mut self, timeout: Duration) -> Validation {
        let deadline = Instant::now() + timeout;
        loop {
            let m = lock(&self.shared.mailbox);
            if (m.next.is_none() && !m.busy) || Instant::now() >= deadline {
                break;
            }
            drop(m);
            std::thread::sleep(Duration::from_millis(5));
        }
        self.close();
        let state = self.state();
        let mut evaluation = lock(&self.shared.evaluation).clone();
        evaluation.skipped = state.skipped as usize;
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
            if m.next.take().is_some() {
                m.skipped += 1;
            }
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

struct Worker {
    shared: Arc<Shared>,
    model: Model,
    backend: Box<dyn Backend>,
    pre: Preprocessor,
    source: FrameSource,
    started: Instant,
    recent: VecDeque<Instant>,
    /// When the pictures of the newest prediction were last made (at most [`PICTURE_RATE_HZ`]).
    pictured: Option<Instant>,
}

/// Pictures (frame and network input) made per second at most: the screen needs no more, and
/// every frame's pictures would take time from inference.
pub const PICTURE_RATE_HZ: f64 = 10.0;

impl Worker {
    fn run(mut self) {
        let mut input = vec![0f32; self.pre.config.tensor_len()];
        loop {
            let (frame, record) = {
                let mut m = lock(&self.shared.mailbox);
                m.busy = false;
                loop {
                    if let Some(next) = m.next.take() {
                        m.busy = true;
                        break next;
                    }
                    if m.closed {
                        return;
                    }
                    m = self.shared.wake.wait(m).unwrap_or_else(|p| p.into_inner());
                }
            };
            if let Err(why) = self.one(&frame, &record, &mut input) {
                lock(&self.shared.state).failure = Some(why);
                let mut m = lock(&self.shared.mailbox);
                m.closed = true;
                m.busy = false;
                return;
            }
        }
    }

    fn one(
        &mut self,
        frame: &Frame,
        record: &FrameRecord,
        input: &mut [f32],
    ) -> Result<(), String> {
        let t0 = Instant::now();
        let format = Some(frame.format);
        let Some(label) = from_record(
            record,
            &self.source.run_id,
            record.file.clone().into(),
            format,
        ) else {
            return Ok(());
        };
        let fref = FrameRef {
            width: frame.width,
            height: frame.height,
            format: frame.format,
            data: &frame.data,
        };
        self.pre
            .run_into(fref, 0.0, input)
            .map_err(|e| format!("frame {}: {e}", frame.id))?;
        let size = self.pre.config.input_size;
        let raw = self
            .backend
            .run(input, 1, size)
            .map_err(|e| format!("{}: {e}", self.model.path.display()))?;
        let latency_ms = t0.elapsed().as_secs_f64() * 1e3;
        let Some(prediction) = predictions(&raw, &self.model.classes).into_iter().next() else {
            return Err(format!(
                "{}: the network gave no prediction",
                self.model.path.display()
            ));
        };
        let shape_true = self.model.classes.iter().position(|c| *c == label.shape);
        let now = Instant::now();
        self.recent.push_back(now);
        while self
            .recent
            .front()
            .is_some_and(|t| now.duration_since(*t) > Duration::from_secs(1))
        {
            self.recent.pop_front();
        }
        let due = self
            .pictured
            .is_none_or(|t| now.duration_since(t).as_secs_f64() >= 1.0 / PICTURE_RATE_HZ);
        let pictures = if due {
            self.pictured = Some(now);
            Some((
                thumbnail(fref, THUMBNAIL_PX).map_err(|e| format!("frame {}: {e}", frame.id))?,
                tensor_image(input, size).unwrap_or_default(),
            ))
        } else {
            None
        };
        let mut state = lock(&self.shared.state);
        state.ran += 1;
        state.loop_hz = self.recent.len() as f64;
        state.latency_ms = latency_ms;
        if state.history.len() == HISTORY {
            state.history.pop_front();
        }
        state.history.push_back(FzPoint {
            t_s: self.started.elapsed().as_secs_f64(),
            measured_n: label.fz(),
            predicted_n: prediction.force.fz.value(),
        });
        // A label whose indenter the model does not know is shown, not scored.
        if let Some(shape_true) = shape_true {
            let scored = score(&self.model.classes, shape_true, &label, &prediction);
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
            let mut eval = lock(&self.shared.evaluation);
            eval.metrics.add(&scored, &keys(&label));
            eval.rows.push(Row {
                scored,
                stage_mm: label.stage_mm,
            });
        }
        lock(&self.shared.frames).push(ValidatedFrame {
            frame_id: frame.id,
            record_index: record.index,
            t_s: self.started.elapsed().as_secs_f64(),
            label: label.clone(),
            prediction: prediction.clone(),
            latency_ms,
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
        Ok(())
    }
}
