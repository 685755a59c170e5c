//! A model evaluated on labelled frames: the Table-2 metrics, their breakdown by grid position
//! and force level, and every row kept for plots.

use crate::dataset::{Sample, Source};
use crate::metrics::{Metrics, Scored};
use crate::model::{Model, ModelError};
use crate::prediction::Prediction;
use crate::predictor::{PredictError, Predictor};
use crate::preprocess::{FrameRef, PreprocessError, Preprocessing, Preprocessor, ReferenceSensor};
use crate::slip_head::{OnsetScore, Reading, Sequence, SlipTracker};
use fringe_calibration::Profile;
use fringe_rig::reference_layout::CONTACT_THRESHOLD;
use fringe_rig::store::{read_plain, StoredFrame};

/// Frames run through the network at once. The network's sums run in an order that depends on
/// the batch's size, so whoever wants `fringe eval`'s predictions bit for bit runs these batches
/// (the Python package does).
pub const BATCH: usize = 8;

/// One evaluated frame.
#[derive(Debug, Clone, PartialEq)]
pub struct Row {
    pub scored: Scored,
    pub stage_mm: Option<[f64; 2]>,
    /// The press the frame belongs to (rows of one press are in time order).
    pub press: String,
}

/// The outcome of an evaluation.
#[derive(Debug, Clone)]
pub struct Evaluation {
    pub metrics: Metrics,
    pub rows: Vec<Row>,
    /// Records left out by the sources (no trustworthy label).
    pub skipped: usize,
    /// Frames live validation offered the model and skipped while it was busy (the newest
    /// frames are run); 0 for a stored run, whose every frame is run.
    pub skipped_busy: usize,
    /// Some frame's label knows its shear (a model with shear heads is scored on it).
    pub labels_know_shear: bool,
}

/// Why an evaluation stopped.
#[derive(Debug, thiserror::Error)]
pub enum EvalError {
    #[error(transparent)]
    Model(#[from] ModelError),
    #[error("{path}: {source}")]
    Frame {
        path: String,
        source: PreprocessError,
    },
    #[error("{path}: {message}")]
    Image { path: String, message: String },
    #[error(
        "{source_path}: shape {shape:?} is not one of the model's classes ({classes}): \
         evaluate with a model trained on that indenter"
    )]
    Shape {
        source_path: String,
        shape: String,
        classes: String,
    },
    #[error("{path}: {source}")]
    Inference {
        path: String,
        source: crate::backend::InferenceError,
    },
    #[error("{path}: {source}")]
    Predict { path: String, source: PredictError },
}

/// A prediction against its sample's label; `shape_true` is the label's index in `classes`
/// (one scoring for evaluation and live validation).
pub fn score(classes: &[String], shape_true: usize, s: &Sample, p: &Prediction) -> Scored {
    Scored {
        fz_true: s.fz(),
        fz_pred: p.force.fz.value(),
        shape_true,
        shape_pred: classes.iter().position(|c| *c == p.shape).unwrap_or(0),
        contact_true: s.contact,
        contact_pred: p.contact_raw.map(|v| v.value()),
        shear_true: s.shear,
        shear_pred: p.shear.map(|q| q.map(|v| v.value())),
        slip_true: s.slip,
        slip_pred: p.slip,
    }
}

/// Frames a reported slip onset may be from its label's: 40 ms at the camera's 50 Hz (issue
/// 65's goal).
pub const SLIP_ONSET_TOLERANCE_FRAMES: usize = 2;

/// The slip onsets reported against the labels', press by press (rows of one press are in time
/// order): `None` when no row has both a label and a reported state.
pub fn slip_onsets(rows: &[Row]) -> Option<OnsetScore> {
    let mut score = OnsetScore::default();
    let mut start = 0;
    while start < rows.len() {
        let press = &rows[start].press;
        let end = start
            + rows[start..]
                .iter()
                .take_while(|r| r.press == *press)
                .count();
        let labels: Vec<_> = rows[start..end]
            .iter()
            .map(|r| r.scored.slip_true)
            .collect();
        let said: Vec<_> = rows[start..end]
            .iter()
            .map(|r| r.scored.slip_pred)
            .collect();
        score.add(&labels, &said, SLIP_ONSET_TOLERANCE_FRAMES);
        start = end;
    }
    (score.frames > 0).then_some(score)
}

/// The slip head's fitting data from an evaluation's rows: each press's readings and labels.
pub fn slip_sequences(rows: &[Row]) -> Vec<Sequence> {
    let mut out: Vec<Sequence> = Vec::new();
    let mut press: Option<&str> = None;
    for r in rows {
        if press != Some(r.press.as_str()) {
            press = Some(r.press.as_str());
            out.push(Sequence {
                readings: Vec::new(),
                labels: Vec::new(),
            });
        }
        if let Some(s) = out.last_mut() {
            s.readings.push(Reading::of(&r.scored));
            s.labels.push(r.scored.slip_true);
        }
    }
    out
}

/// Grid position and force level keys of a row, for the breakdowns.
pub fn keys(s: &Sample) -> Vec<String> {
    let mut k = Vec::with_capacity(2);
    if let Some([x, y]) = s.stage_mm {
        k.push(format!("grid x {x:.1} y {y:.1} mm"));
    }
    k.push(force_level(s.fz()));
    k
}

/// The force level a label falls in: no contact, or |Fz| rounded to the nearest newton.
pub fn force_level(fz: f64) -> String {
    if fz < CONTACT_THRESHOLD.0 {
        "force none".to_string()
    } else {
        format!("force {:.0} N", fz.round().max(1.0))
    }
}

/// Reads a sample's frame file as the camera delivered it, as its run stored it (or as an
/// ordinary image file).
pub fn read_frame(s: &Sample) -> Result<StoredFrame, EvalError> {
    match &s.storage {
        Some(storage) => storage.read(&s.image),
        None => read_plain(&s.image),
    }
    .map_err(|e| EvalError::Image {
        path: s.image.display().to_string(),
        message: e.to_string(),
    })
}

/// The preprocessing's view of a stored frame.
pub fn frame_ref(f: &StoredFrame) -> FrameRef<'_> {
    FrameRef {
        width: f.width,
        height: f.height,
        format: f.format,
        data: &f.data,
        cutout: f.cutout,
    }
}

/// A batch of frames ready for the network: their inputs (CHW, concatenated), their samples,
/// each label's shape as an index into the model's classes, the preprocessing and profile that
/// made the inputs, and the frames themselves when asked for (a two-stage model reads them).
pub struct Batch<'a> {
    pub input: Vec<f32>,
    pub samples: &'a [Sample],
    pub shapes: Vec<usize>,
    pub preprocessing: &'a Preprocessing,
    pub profile: Option<&'a Profile>,
    pub frames: Vec<StoredFrame>,
}

/// Reads `samples`' frames and preprocesses them into `out`, one network input after another;
/// the frames, when `keep`.
fn prepare(
    samples: &[Sample],
    out: &mut [f32],
    pre: &mut Preprocessor,
    keep: bool,
) -> Result<Vec<StoredFrame>, EvalError> {
    let per = pre.config.tensor_len();
    let mut kept = Vec::new();
    for (s, out) in samples.iter().zip(out.chunks_exact_mut(per)) {
        let frame = read_frame(s)?;
        pre.run_into(frame_ref(&frame), 0.0, out)
            .map_err(|source| EvalError::Frame {
                path: s.image.display().to_string(),
                source,
            })?;
        if keep {
            kept.push(frame);
        }
    }
    Ok(kept)
}

/// Preprocesses the frames of `sources` in batches of up to `BATCH` and hands each batch to
/// `each` (with its decoded frames when `keep_frames`); each source's frames are preprocessed
/// with its run's profile, else `profile`, else the reference geometry `reference` (the one
/// preparation for evaluation and adaptation).
pub fn for_each_batch(
    model: &Model,
    sources: &[Source],
    profile: Option<&Profile>,
    reference: Option<ReferenceSensor>,
    keep_frames: bool,
    mut each: impl FnMut(Batch<'_>) -> Result<(), EvalError>,
) -> Result<(), EvalError> {
    for source in sources {
        let chosen = if reference.is_some() {
            None
        } else {
            source.profile.as_ref().or(profile)
        };
        let config = model.preprocessing(chosen, reference)?;
        let per = config.tensor_len();
        // Each batch's frames are read and preprocessed on as many threads as there are cores
        // (up to 4): decoding the frame files is most of an evaluation's time.
        let workers = std::thread::available_parallelism().map_or(1, |n| n.get().min(4));
        let mut pres: Vec<Preprocessor> = (0..workers)
            .map(|_| Preprocessor::new(config.clone()))
            .collect();
        for chunk in source.samples.chunks(BATCH) {
            let mut input = vec![0f32; per * chunk.len()];
            let shapes = chunk
                .iter()
                .map(|s| {
                    model
                        .classes
                        .iter()
                        .position(|c| *c == s.shape)
                        .ok_or_else(|| EvalError::Shape {
                            source_path: source.path.display().to_string(),
                            shape: s.shape.clone(),
                            classes: model.classes.join(", "),
                        })
                })
                .collect::<Result<Vec<usize>, EvalError>>()?;
            let share = chunk.len().div_ceil(workers);
            let frames = std::thread::scope(|scope| {
                let running: Vec<_> = chunk
                    .chunks(share)
                    .zip(input.chunks_mut((per * share).max(1)))
                    .zip(pres.iter_mut())
                    .map(|((samples, out), pre)| {
                        scope.spawn(move || prepare(samples, out, pre, keep_frames))
                    })
                    .collect();
                // The first error in the batch's order.
                running
                    .into_iter()
                    .map(|r| r.join().unwrap_or_else(|p| std::panic::resume_unwind(p)))
                    .collect::<Result<Vec<Vec<StoredFrame>>, EvalError>>()
            })?;
            each(Batch {
                input,
                samples: chunk,
                shapes,
                preprocessing: &config,
                profile: chosen,
                frames: frames.into_iter().flatten().collect(),
            })?;
        }
    }
    Ok(())
}

/// Evaluates `model` through `predictor` (its networks on a backend) over `sources`; each
/// source's frames are preprocessed with its run's profile, else `profile`, else the reference
/// geometry `reference`. `progress` hears (frames done, frames in all).
pub fn evaluate(
    model: &Model,
    predictor: &mut Predictor,
    sources: &[Source],
    profile: Option<&Profile>,
    reference: Option<ReferenceSensor>,
    mut progress: impl FnMut(usize, usize),
) -> Result<Evaluation, EvalError> {
    for s in sources {
        model.check_design(
            s.variant.as_deref(),
            &format!("the data in {}", s.path.display()),
        )?;
    }
    let total: usize = sources.iter().map(|s| s.samples.len()).sum();
    let mut metrics = Metrics::new(model.classes.clone());
    let mut rows = Vec::with_capacity(total);
    let mut done = 0;
    let keep = predictor.needs_frames();
    // The slip head reads each press's frames in order, from its first.
    let mut slip = model.slip_head().map(SlipTracker::new);
    let mut press: Option<String> = None;
    for_each_batch(model, sources, profile, reference, keep, |batch| {
        let frames: Vec<FrameRef<'_>> = batch.frames.iter().map(frame_ref).collect();
        let predicted = predictor
            .predict(
                &batch.input,
                batch.samples.len(),
                &frames,
                batch.preprocessing,
                batch.profile,
            )
            .map_err(|source| EvalError::Predict {
                path: batch.samples[0].image.display().to_string(),
                source,
            })?;
        for ((s, mut p), shape_true) in batch.samples.iter().zip(predicted).zip(batch.shapes) {
            if let Some(t) = &mut slip {
                if press.as_deref() != Some(s.press.as_str()) {
                    t.reset();
                    press = Some(s.press.clone());
                }
                p.slip = t.next(Reading::of_prediction(&p));
            }
            let scored = score(&model.classes, shape_true, s, &p);
            metrics.add(&scored, &keys(s));
            rows.push(Row {
                scored,
                stage_mm: s.stage_mm,
                press: s.press.clone(),
            });
        }
        done += batch.samples.len();
        progress(done, total);
        Ok(())
    })?;
    Ok(Evaluation {
        metrics,
        rows,
        skipped: sources.iter().map(|s| s.skipped).sum(),
        skipped_busy: 0,
        labels_know_shear: sources
            .iter()
            .any(|s| s.samples.iter().any(|x| x.shear.is_some())),
    })
}
