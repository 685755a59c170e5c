//! Full fine-tuning (cargo feature `torch`): every layer of an adapted model trained again on a
//! unit's frames with libtorch, from the heads fitted on those frames, at a low rate for a few
//! epochs; one fold of presses is kept out of it. Both candidates, the heads alone (fitted on
//! the same training presses) and the fine-tuned network, are then scored on that fold by
//! `fringe eval`'s own evaluation, and the fine-tuned network is kept only when it does better.

use super::held_out::HeldOut;
use super::{fit_heads, AdaptConfig, AdaptError, Features};
use crate::augment::Pipeline;
use crate::backend::BackendKind;
use crate::dataset::Source;
use crate::eval::{evaluate, EvalError};
use crate::lr_schedule::Schedule;
use crate::model::{Model, ModelError};
use crate::model_card::ModelCard;
use crate::predictor::Predictor;
use crate::preprocess::Colour;
use crate::split::{Split, SplitSpec};
use crate::train::{train, Checkpoint, EpochRecord, Outcome, TrainConfig, TrainError, TrainEvent};
use crate::weights::safetensors_file::write_safetensors_with_card;
use fringe_rig::reference_layout::NO_CONTACT;
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use std::time::Instant;

/// The heads fitted on the training presses, the fine-tuning's start, in its directory.
pub(crate) const HEADS: &str = "heads.safetensors";
/// What a finished fine-tuning found, in its directory.
pub(crate) const OUTCOME: &str = "outcome.json";
/// Held-out presses needed to judge a fine-tuning against the heads alone: on fewer, which
/// wins is chance (measured: on 2 presses of a small commissioning the fine-tuned network won,
/// then read contact at twice the acceptance's error at other positions).
pub const MIN_HELD_OUT: usize = 6;

/// How to fine-tune.
#[derive(Debug, Clone)]
pub struct FineTuneConfig {
    pub epochs: usize,
    /// The first epoch's rate; a cosine schedule takes it down to a hundredth.
    pub lr: f64,
    pub batch: usize,
    /// Every how many frames of a press are used (neighbours at 50 Hz are nearly the same
    /// picture).
    pub every: usize,
    /// Seed of the heads' folds, the batch order and libtorch.
    pub seed: u64,
    pub threads: usize,
}

impl Default for FineTuneConfig {
    fn default() -> FineTuneConfig {
        FineTuneConfig {
            epochs: 10,
            // A tenth of the rate the shipped models were trained with: the base's features are
            // moved, not relearnt.
            lr: 1e-4,
            batch: 32,
            every: 1,
            seed: 42,
            threads: 2,
        }
    }
}

/// What the fine-tuning is doing, for progress.
#[derive(Debug, Clone)]
pub enum FineTuneEvent {
    /// Features read for the heads' fit on the training presses.
    Features { done: usize, total: usize },
    /// The training loop's own events.
    Train(TrainEvent),
    /// Frames of the held-out presses evaluated (`candidate`: "heads" or "fine-tuned").
    Evaluating {
        candidate: &'static str,
        done: usize,
        total: usize,
    },
}

/// The outcome: both candidates on the held-out presses, and which is kept.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub struct FineTuned {
    /// The fine-tuned weights (with their card beside them).
    pub model: PathBuf,
    /// The data it was trained and scored on.
    pub runs: Vec<PathBuf>,
    /// The heads alone, fitted on the training presses, on the held-out presses.
    pub heads_only: HeldOut,
    /// The fine-tuned network on the held-out presses.
    pub fine_tuned: HeldOut,
    /// The fine-tuned network did better on the held-out presses.
    pub kept: bool,
    pub held_out_presses: usize,
    pub held_out_frames: usize,
    pub train_frames: usize,
    pub epochs: usize,
    pub lr: f64,
    pub pipeline: String,
    /// Trained on augmented copies (else each frame once, as recorded).
    pub augmented: bool,
    /// Batch norm kept the base's running statistics.
    pub frozen_batch_norm: bool,
    /// Validation figures by epoch (half the held-out presses).
    pub history: Vec<EpochRecord>,
    /// Wall time of this part (features, training, both evaluations), s.
    pub seconds: f64,
}

/// Finished, or stopped with a checkpoint to go on from.
pub enum FineTuneOutcome {
    Finished(Box<FineTuned>),
    Interrupted { checkpoint: PathBuf },
}

/// Why a fine-tuning could not run.
#[derive(Debug, thiserror::Error)]
pub enum FineTuneError {
    #[error(transparent)]
    Train(#[from] TrainError),
    #[error(transparent)]
    Adapt(#[from] AdaptError),
    #[error(transparent)]
    Eval(#[from] EvalError),
    #[error(transparent)]
    Model(#[from] ModelError),
    #[error(transparent)]
    Card(#[from] crate::model_card::CardError),
    #[error("{0}: only the paper's networks by their weights can be fine-tuned; this one is not recognised as one")]
    NotTrainable(String),
    #[error("the base model's classes {base:?} are not the data's {data:?}: fine-tune on presses of every indenter the base knows")]
    Classes {
        base: Vec<String>,
        data: Vec<String>,
    },
    #[error("{held_out} held-out presses and {train} training presses: fine-tuning needs at least {MIN_HELD_OUT} held out to be judged, and 2 to train on")]
    TooFew { held_out: usize, train: usize },
    #[error("{path}: {message}")]
    Write { path: String, message: String },
}

/// Fine-tunes `base` on the frames of `sources` with the presses `held_out` kept out, in `out`
/// (resumed from `resume`, a checkpoint of an earlier call with the same arguments). `stop`
/// (Ctrl-C) ends it after the current batch with a checkpoint.
#[allow(clippy::too_many_arguments)]
pub fn fine_tune(
    base: &Model,
    sources: &[Source],
    held_out: &[String],
    config: &FineTuneConfig,
    out: &Path,
    resume: Option<&Path>,
    stop: &AtomicBool,
    events: &mut dyn FnMut(FineTuneEvent),
) -> Result<FineTuneOutcome, FineTuneError> {
    let started = Instant::now();
    let (Some(arch), Some(base_weights)) = (base.arch, base.weights()) else {
        return Err(FineTuneError::NotTrainable(base.path.display().to_string()));
    };
    let held: BTreeSet<&str> = held_out.iter().map(String::as_str).collect();
    let sources: Vec<Source> = sources.iter().map(|s| every(s, config.every)).collect();
    let (train_sources, held_sources) = parted(&sources, &held);
    check_classes(base, &sources)?;
    let split = split_of(&sources, &held, config.seed)?;
    std::fs::create_dir_all(out).map_err(|e| write_error(out, &e))?;
    let heads = out.join(HEADS);
    if resume.is_none() {
        // The start: the heads alone, fitted on the training presses as the heads-only
        // adaptation fits them.
        let features =
            Features::read(base, &train_sources, None, config.threads, |done, total| {
                events(FineTuneEvent::Features { done, total })
            })?;
        let adapt = AdaptConfig {
            folds: 5,
            seed: config.seed,
            threads: config.threads,
        };
        let fitted = fit_heads(base_weights, &features, &adapt)?;
        write_safetensors_with_card(&heads, &fitted.weights, base.card.as_ref())
            .map_err(|e| write_error(&heads, &e))?;
    }
    let pipeline = pipeline_of(base);
    let train_config = TrainConfig {
        arch,
        pipeline,
        epochs: config.epochs,
        batch: config.batch,
        lr: config.lr,
        schedule: Schedule::Cosine,
        seed: config.seed,
        input_size: base.input_size,
        threads: config.threads,
        out: out.to_path_buf(),
        init: Some(heads.clone()),
        split: Some(split),
        // Each frame as recorded: the base learnt turned and noisy copies; a unit's own optical
        // pattern (LED, residual birefringence, centre) is fixed in the image, and turning it
        // teaches the network to ignore what adaptation is for.
        augment: false,
        // The heads it starts from were fitted to features normalised with the base's
        // statistics; a few hundred batches of one unit would replace them.
        freeze_batch_norm: true,
        force_window_mm: None,
        every: 1,
    };
    let (model, history) = match train(&train_config, &sources, None, resume, stop, &mut |e| {
        events(FineTuneEvent::Train(e))
    })? {
        Outcome::Interrupted { checkpoint } => {
            return Ok(FineTuneOutcome::Interrupted { checkpoint })
        }
        Outcome::Finished { model, .. } | Outcome::ForceNetwork { model, .. } => {
            let history = trained_history(&model)?;
            (model, history)
        }
    };
    let heads_only = held_out_figures(&heads, &held_sources, config.threads, "heads", events)?;
    let fine_tuned = held_out_figures(&model, &held_sources, config.threads, "fine-tuned", events)?;
    let outcome = FineTuned {
        model,
        runs: sources.iter().map(|s| s.path.clone()).collect(),
        kept: fine_tuned.spec_units < heads_only.spec_units,
        heads_only,
        fine_tuned,
        held_out_presses: held.len(),
        held_out_frames: held_sources.iter().map(|s| s.samples.len()).sum(),
        train_frames: train_sources.iter().map(|s| s.samples.len()).sum(),
        epochs: config.epochs,
        lr: config.lr,
        pipeline: pipeline.name().to_string(),
        augmented: train_config.augment,
        frozen_batch_norm: train_config.freeze_batch_norm,
        history,
        seconds: started.elapsed().as_secs_f64(),
    };
    let path = out.join(OUTCOME);
    let text = serde_json::to_string_pretty(&outcome).map_err(|e| FineTuneError::Write {
        path: path.display().to_string(),
        message: e.to_string(),
    })?;
    std::fs::write(&path, text + "\n").map_err(|e| write_error(&path, &e))?;
    Ok(FineTuneOutcome::Finished(Box::new(outcome)))
}

/// A finished fine-tuning's outcome in `out`, when there is one (its model's path taken in
/// `out`, wherever `out` is now).
pub fn finished(out: &Path) -> Option<FineTuned> {
    let text = std::fs::read_to_string(out.join(OUTCOME)).ok()?;
    let mut outcome: FineTuned = serde_json::from_str(&text).ok()?;
    outcome.model = out.join(outcome.model.file_name()?);
    outcome.model.is_file().then_some(outcome)
}

fn write_error(path: &Path, e: &dyn std::fmt::Display) -> FineTuneError {
    FineTuneError::Write {
        path: path.display().to_string(),
        message: e.to_string(),
    }
}

/// `source` with every `n`th frame of it.
fn every(source: &Source, n: usize) -> Source {
    Source {
        samples: source.samples.iter().step_by(n.max(1)).cloned().collect(),
        ..source.clone()
    }
}

/// The sources' frames of training presses, and of held-out ones.
fn parted(sources: &[Source], held: &BTreeSet<&str>) -> (Vec<Source>, Vec<Source>) {
    let side = |keep_held: bool| {
        sources
            .iter()
            .map(|s| Source {
                samples: s
                    .samples
                    .iter()
                    .filter(|x| held.contains(x.press.as_str()) == keep_held)
                    .cloned()
                    .collect(),
                ..s.clone()
            })
            .collect()
    };
    (side(false), side(true))
}

/// The base must know the data's classes in the training's order ("None", then sorted).
fn check_classes(base: &Model, sources: &[Source]) -> Result<(), FineTuneError> {
    let shapes: BTreeSet<&str> = sources
        .iter()
        .flat_map(|s| s.samples.iter().map(|x| x.shape.as_str()))
        .filter(|s| *s != NO_CONTACT)
        .collect();
    let data: Vec<String> = std::iter::once(NO_CONTACT)
        .chain(shapes)
        .map(String::from)
        .collect();
    if data != base.classes {
        return Err(FineTuneError::Classes {
            base: base.classes.clone(),
            data,
        });
    }
    Ok(())
}

/// Training presses on the training side; the held-out ones dealt alternately to validation
/// (watched by epoch) and test.
fn split_of(sources: &[Source], held: &BTreeSet<&str>, seed: u64) -> Result<Split, FineTuneError> {
    let presses: BTreeSet<&str> = sources
        .iter()
        .flat_map(|s| s.samples.iter().map(|x| x.press.as_str()))
        .collect();
    let train: BTreeSet<String> = presses
        .iter()
        .filter(|p| !held.contains(*p))
        .map(|p| p.to_string())
        .collect();
    let held_in: Vec<&str> = presses
        .iter()
        .copied()
        .filter(|p| held.contains(p))
        .collect();
    if held_in.len() < MIN_HELD_OUT || train.len() < 2 {
        return Err(FineTuneError::TooFew {
            held_out: held_in.len(),
            train: train.len(),
        });
    }
    let deal = |k: usize| -> BTreeSet<String> {
        held_in
            .iter()
            .skip(k)
            .step_by(2)
            .map(|p| p.to_string())
            .collect()
    };
    let n = presses.len() as f64;
    let (val, test) = (deal(0), deal(1));
    Ok(Split {
        spec: SplitSpec {
            seed,
            fractions: [
                train.len() as f64 / n,
                val.len() as f64 / n,
                test.len() as f64 / n,
            ],
        },
        by: "run and grid point (a commissioning's fine-tuning: one fold of presses held out)"
            .to_string(),
        train,
        val,
        test,
        strata: Default::default(),
    })
}

/// The augmentation the base was trained with (its card's training record), else the paper's
/// best for its colour.
fn pipeline_of(base: &Model) -> Pipeline {
    base.card
        .as_ref()
        .and_then(|c| c.other.get("training"))
        .and_then(|t| t.get("pipeline"))
        .and_then(|p| p.as_str())
        .and_then(|p| p.parse::<Pipeline>().ok())
        .filter(|p| p.colour() == base.colour)
        .unwrap_or(match base.colour {
            Colour::Grey => Pipeline::Gray10,
            Colour::Rgb => Pipeline::Rgb3,
        })
}

/// The epochs' validation figures from the final model's card (read alone: the model is opened
/// once, to be scored).
fn trained_history(model: &Path) -> Result<Vec<EpochRecord>, FineTuneError> {
    let card = ModelCard::read(&Checkpoint::at(model).card())?;
    Ok(card
        .other
        .get("training")
        .and_then(|t| t.get("history"))
        .cloned()
        .and_then(|h| serde_json::from_value(h).ok())
        .unwrap_or_default())
}

/// The model in `weights` on the held-out frames, by `fringe eval`'s evaluation.
fn held_out_figures(
    weights: &Path,
    held: &[Source],
    threads: usize,
    candidate: &'static str,
    events: &mut dyn FnMut(FineTuneEvent),
) -> Result<HeldOut, FineTuneError> {
    let model = Model::open(weights)?;
    let mut predictor = Predictor::new(&model, BackendKind::Tract, threads.max(1))?;
    let e = evaluate(&model, &mut predictor, held, None, None, |done, total| {
        events(FineTuneEvent::Evaluating {
            candidate,
            done,
            total,
        })
    })?;
    Ok(HeldOut::of(&e.metrics.all))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dataset::Sample;

    fn source(presses: &[&str]) -> Source {
        let samples = presses
            .iter()
            .flat_map(|p| {
                (0..4).map(move |k| Sample {
                    image: PathBuf::from(format!("{p}-{k}.png")),
                    storage: None,
                    force: [0.0, 0.0, k as f64, 0.0, 0.0, 0.0, 0.0],
                    shape: if k == 0 { NO_CONTACT } else { "pentagon" }.into(),
                    contact: (k > 0).then_some([0.0, 0.0]),
                    shear: None,
                    slip: None,
                    press: p.to_string(),
                    stage_mm: None,
                })
            })
            .collect();
        Source {
            path: PathBuf::from("runs/round-1"),
            samples,
            profile: None,
            sensor_id: None,
            variant: None,
            skipped: 0,
        }
    }

    /// The held-out presses never train: they are dealt to validation and test, every other
    /// press trains; too few of either is refused, saying how many there were.
    #[test]
    fn the_held_out_fold_never_trains() {
        let sources = [source(&["a", "b", "c", "d", "e", "f", "g", "h", "i", "j"])];
        let held: BTreeSet<&str> = ["b", "c", "e", "f", "h", "i"].into_iter().collect();
        let split = split_of(&sources, &held, 7).expect("split");
        assert_eq!(split.train, ["a", "d", "g", "j"].map(String::from).into());
        assert_eq!(split.val, ["b", "e", "h"].map(String::from).into());
        assert_eq!(split.test, ["c", "f", "i"].map(String::from).into());
        let (train, held_sources) = parted(&sources, &held);
        assert!(train[0]
            .samples
            .iter()
            .all(|s| !held.contains(s.press.as_str())));
        assert_eq!(held_sources[0].samples.len(), 24);
        let few: BTreeSet<&str> = ["b", "c", "e", "f", "h"].into_iter().collect();
        let e = split_of(&sources, &few, 7).expect_err("five held out");
        assert!(e.to_string().contains("5 held-out presses"), "{e}");
    }

    /// Every `n`th frame is kept, the first of each source included.
    #[test]
    fn every_nth_frame_is_kept() {
        let s = every(&source(&["a", "b"]), 3);
        let kept: Vec<String> = s
            .samples
            .iter()
            .map(|x| x.image.display().to_string())
            .collect();
        assert_eq!(kept, ["a-0.png", "a-3.png", "b-2.png"]);
    }
}
