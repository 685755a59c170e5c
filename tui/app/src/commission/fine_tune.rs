//! Step 3's libtorch candidate (`--fine-tune`, builds with the `torch` feature): every layer of
//! the adapted model trained again on the rounds' frames with one fold of presses kept out, kept
//! only when it beats the heads alone on that fold. Stopped (Ctrl-C, the screen's `s`), it goes
//! on from its checkpoint when the commissioning is resumed; finished, a resume reuses it.

#[cfg(feature = "torch")]
use super::pruning::frames_kept;
use super::scans::Commissioning;
use crate::workflow_error::{refuse, WorkflowError};
use fringe_sensor_models::Model;
use fringe_sensor_models::StateDict;
use std::path::PathBuf;

type Result<T> = std::result::Result<T, WorkflowError>;

/// The fine-tuning's directory in the commissioning's.
#[cfg(feature = "torch")]
const DIR: &str = "fine-tune";

/// What a fine-tuning that ran did, for the model's card.
#[cfg(feature = "torch")]
const ABOUT: &str = "every layer trained again with libtorch from the heads fitted on the training presses (Adam, cosine rate, frames as recorded), one fold of presses held out; kept only when it beat those heads on the fold";

/// What the fine-tuning found.
pub(crate) struct FineTune {
    /// The fine-tuned weights, when they beat the heads alone on the held-out presses.
    pub kept: Option<StateDict>,
    /// The whole record, for the model's card.
    pub record: serde_json::Value,
}

/// Whether this build can fine-tune; the error says how to get one that can.
pub(crate) fn available() -> Result<()> {
    if cfg!(feature = "torch") {
        Ok(())
    } else {
        refuse!(
            "--fine-tune trains with libtorch, and this fringe was built without it: build with `cargo build --release --features torch` (README.md, \"Training\": LIBTORCH from `pip install torch --no-deps`), or leave --fine-tune out to adapt the heads alone"
        )
    }
}

#[cfg(not(feature = "torch"))]
pub(crate) fn run(
    _c: &mut Commissioning<'_>,
    _base: &Model,
    _runs: &[PathBuf],
) -> Result<Option<FineTune>> {
    available()?;
    Ok(None)
}

/// Fine-tunes `base` on the frames of `runs` (resumed from the journal's checkpoint when it was
/// stopped on the same runs, reused when it finished on them).
#[cfg(feature = "torch")]
pub(crate) fn run(
    c: &mut Commissioning<'_>,
    base: &Model,
    runs: &[PathBuf],
) -> Result<Option<FineTune>> {
    use fringe_sensor_models::adapt::held_out_presses;
    use fringe_sensor_models::dataset;
    use fringe_sensor_models::TrainEvent;
    use fringe_sensor_models::{
        fine_tune, finished_fine_tune as finished, FineTuneConfig, FineTuneEvent, FineTuneOutcome,
        MIN_HELD_OUT,
    };
    use std::sync::atomic::{AtomicBool, Ordering};
    use std::time::Instant;

    let out = c.dir.join(DIR);
    let started = Instant::now();
    let config = FineTuneConfig {
        seed: c.journal.options.seed,
        threads: c.threads,
        ..FineTuneConfig::default()
    };
    let outcome = match finished(&out).filter(|f| same_runs(&f.runs, runs)) {
        Some(done) => {
            c.say(format!(
                "step 3: full fine-tuning done before on these runs ({}): reused",
                out.display()
            ));
            done
        }
        None => {
            let sources = runs
                .iter()
                .map(|r| dataset::read(r))
                .collect::<std::result::Result<Vec<_>, _>>()?;
            let samples: Vec<_> = sources
                .iter()
                .flat_map(|s| s.samples.iter().cloned())
                .collect();
            let held_out = held_out_presses(&samples, 5, config.seed);
            let presses = samples
                .iter()
                .map(|s| s.press.as_str())
                .collect::<std::collections::BTreeSet<_>>()
                .len();
            if held_out.len() < MIN_HELD_OUT {
                let why = format!(
                    "{presses} presses, {} held out: at least {MIN_HELD_OUT} held out are needed to tell whether fine-tuning beats the heads alone (about {} presses; a larger --budget gives more)",
                    held_out.len(),
                    5 * MIN_HELD_OUT
                );
                c.say(format!(
                    "step 3: no full fine-tuning: {why}; the heads alone are kept"
                ));
                return Ok(Some(FineTune {
                    kept: None,
                    record: serde_json::json!({ "skipped": why }),
                }));
            }
            frames_kept(c, runs, "full fine-tuning (--fine-tune)")?;
            let resume = c
                .journal
                .fine_tune_checkpoint
                .as_ref()
                .map(|p| c.dir.join(p))
                .filter(|p| p.is_file() && checkpoint_of(p, runs));
            c.say(format!(
                "step 3: full fine-tuning with libtorch on {} of {} presses ({} held out), {} epochs from rate {:e}{}",
                match config.every {
                    1 => "every frame".to_string(),
                    n => format!("1 frame in {n}"),
                },
                presses,
                held_out.len(),
                config.epochs,
                config.lr,
                match &resume {
                    Some(p) => format!(", going on from {}", p.display()),
                    None => String::new(),
                }
            ));
            let batch = config.batch;
            let host = &mut *c.host;
            // The operator's stop, looked at after every batch (the loop checks it next).
            let stop = AtomicBool::new(false);
            let mut events = |e: FineTuneEvent| {
                match e {
                FineTuneEvent::Features { done, total } => {
                    host.frames("reading the heads' features", done, total)
                }
                FineTuneEvent::Train(TrainEvent::Preparing { side, done, total }) => host.frames(
                    if side == "training" {
                        "preparing the fine-tuning inputs"
                    } else {
                        "preparing the held-out inputs"
                    },
                    done,
                    total,
                ),
                FineTuneEvent::Train(TrainEvent::Batch {
                    batch: b, batches, ..
                }) => {
                    if host.stop_requested() {
                        stop.store(true, Ordering::Relaxed);
                    }
                    host.frames(
                        "fine-tuning (this epoch's inputs)",
                        (b * batch).min(batches * batch),
                        batches * batch,
                    )
                }
                FineTuneEvent::Train(TrainEvent::Epoch(r)) => host.say(format!(
                    "  epoch {}: loss {:.4}, half the held-out presses: Fz RMSE {:.3} N, contact RMSE {:.2} mm, shape accuracy {:.1} % ({:.0} s)",
                    r.epoch,
                    r.train_loss,
                    r.val_fz_rmse_n,
                    r.val_contact_rmse_mm,
                    100.0 * r.val_shape_accuracy,
                    r.seconds
                )),
                FineTuneEvent::Evaluating {
                    candidate,
                    done,
                    total,
                } => host.frames(
                    if candidate == "heads" {
                        "scoring the heads alone on the held-out presses"
                    } else {
                        "scoring the fine-tuned network on the held-out presses"
                    },
                    done,
                    total,
                ),
                FineTuneEvent::Train(_) => {}
            }
            };
            let result = fine_tune(
                base,
                &sources,
                &held_out,
                &config,
                &out,
                resume.as_deref(),
                &stop,
                &mut events,
            )?;
            match result {
                FineTuneOutcome::Interrupted { checkpoint } => {
                    let relative = checkpoint
                        .strip_prefix(&c.dir)
                        .unwrap_or(&checkpoint)
                        .display()
                        .to_string();
                    c.journal.fine_tune_checkpoint = Some(relative);
                    c.journal.write(&c.dir)?;
                    c.compute_s += started.elapsed().as_secs_f64();
                    refuse!(
                        "stopped during the full fine-tuning (saved {}); go on with: fringe commission --resume {}",
                        checkpoint.display(),
                        c.dir.display()
                    );
                }
                FineTuneOutcome::Finished(done) => {
                    c.journal.fine_tune_checkpoint = None;
                    c.journal.write(&c.dir)?;
                    *done
                }
            }
        }
    };
    c.compute_s += started.elapsed().as_secs_f64();
    c.say(format!(
        "  on {} held-out presses ({} frames): heads alone {}",
        outcome.held_out_presses,
        outcome.held_out_frames,
        outcome.heads_only.describe()
    ));
    c.say(format!(
        "  fine-tuned: {} ({})",
        outcome.fine_tuned.describe(),
        if outcome.kept {
            "kept"
        } else {
            "no better: the heads alone are kept"
        }
    ));
    let kept = if outcome.kept {
        Some(fringe_sensor_models::read_weights(&outcome.model)?)
    } else {
        None
    };
    let mut record = serde_json::to_value(&outcome)?;
    if let serde_json::Value::Object(m) = &mut record {
        m.insert("about".into(), ABOUT.into());
    }
    Ok(Some(FineTune { kept, record }))
}

/// Whether the checkpoint `path` was trained on `runs`.
#[cfg(feature = "torch")]
fn checkpoint_of(path: &std::path::Path, runs: &[PathBuf]) -> bool {
    use fringe_sensor_models::ModelCard;
    use fringe_sensor_models::{Checkpoint, TrainingRecord};
    ModelCard::read(&Checkpoint::at(path).card())
        .ok()
        .and_then(|card| card.other.get("training").cloned())
        .and_then(|t| serde_json::from_value::<TrainingRecord>(t).ok())
        .is_some_and(|r| same_runs(&r.data, runs))
}

/// Whether `a` and `b` are the same runs of the commissioning (by their names in `runs/`: the
/// directory may have been reached by another path since).
#[cfg(feature = "torch")]
fn same_runs(a: &[PathBuf], b: &[PathBuf]) -> bool {
    let names = |v: &[PathBuf]| -> Vec<Option<std::ffi::OsString>> {
        v.iter().map(|p| p.file_name().map(Into::into)).collect()
    };
    names(a) == names(b)
}
