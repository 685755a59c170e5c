//! Checkpoints: `<name>.safetensors` (the network's state dict under the reference names, which
//! PyTorch loads into the reference classes with `load_state_dict`), `<name>.safetensors.json`
//! (the model card: architecture, classes, preprocessing, sensor, and under `training` the
//! runs, split, settings, epoch and losses) and `<name>.optimizer.safetensors` (Adam's state),
//! each written through a temporary file renamed into place.

use super::error::TrainError;
use crate::model_card::ModelCard;
use crate::weights::safetensors_file::{
    read_safetensors, write_safetensors, write_safetensors_with_card,
};
use crate::weights::state_dict::StateDict;
use std::path::{Path, PathBuf};

/// One epoch's figures.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct EpochRecord {
    pub epoch: usize,
    /// Mean training loss over the epoch's batches.
    pub train_loss: f64,
    /// The same loss on the validation side.
    pub val_loss: f64,
    pub val_fz_rmse_n: f64,
    /// Contact and shape figures: of untrained heads in a force network's record
    /// (`force_window_mm`), which trains Fz alone.
    pub val_contact_rmse_mm: f64,
    pub val_shape_accuracy: f64,
    /// Shear RMSE along x and y on the validation side, N (absent where the data knows no
    /// shear, and in records before shear heads).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub val_shear_rmse_n: Option<[f64; 2]>,
    /// The learning rate of the epoch (absent in records before schedules).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lr: Option<f64>,
    pub seconds: f64,
    pub images_per_second: f64,
}

/// What a checkpoint says of the training that made it (the card's `training` field).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct TrainingRecord {
    pub data: Vec<PathBuf>,
    /// The split file (beside the checkpoint).
    pub split: PathBuf,
    pub pipeline: crate::augment::Pipeline,
    /// The training inputs were the pipeline's augmented copies (absent in records before
    /// fine-tuning: they always were); else each frame once, as recorded.
    #[serde(default = "augmented_before")]
    pub augmented: bool,
    /// Batch norm kept the running statistics the training started with.
    #[serde(default)]
    pub batch_norm_frozen: bool,
    pub epochs: usize,
    pub batch: usize,
    pub lr: f64,
    /// How the rate changed over the epochs (absent in records before schedules: constant).
    #[serde(default)]
    pub schedule: crate::lr_schedule::Schedule,
    pub seed: u64,
    /// Epochs completed.
    pub epoch: usize,
    /// Batches of the next epoch already trained (an interrupted epoch), and their loss sum.
    #[serde(default)]
    pub batch_in_epoch: usize,
    #[serde(default)]
    pub loss_sum_in_epoch: f64,
    /// Batches trained in all (the batch norms' `num_batches_tracked`).
    pub batches_trained: u64,
    pub train_frames: usize,
    pub train_inputs: usize,
    pub val_frames: usize,
    pub test_frames: usize,
    /// Where each source's preprocessing geometry came from.
    pub profiles: Vec<String>,
    pub history: Vec<EpochRecord>,
    /// Test-side figures of the final model (fringe eval's).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub evaluation: Option<serde_json::Value>,
    /// The training side's every Nth frame was trained on (absent in records before: all).
    #[serde(default = "every_frame", skip_serializing_if = "is_every_frame")]
    pub every: usize,
    /// The weights the training started from (`--init`), when not a random initialisation.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub init: Option<PathBuf>,
    /// The network reads the force from a window of this side (mm) about the contact, not the
    /// whole disc (`--force-window`; absent in records before force windows).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub force_window_mm: Option<f64>,
}

/// Records before fine-tuning trained on augmented copies.
fn augmented_before() -> bool {
    true
}

/// The three files of a checkpoint.
#[derive(Debug, Clone, PartialEq)]
pub struct Checkpoint {
    pub weights: PathBuf,
}

impl Checkpoint {
    pub fn new(dir: &Path, name: &str) -> Checkpoint {
        Checkpoint {
            weights: dir.join(format!("{name}.safetensors")),
        }
    }

    /// From the weights file's path.
    pub fn at(weights: &Path) -> Checkpoint {
        Checkpoint {
            weights: weights.to_path_buf(),
        }
    }

    pub fn card(&self) -> PathBuf {
        let mut p = self.weights.as_os_str().to_owned();
        p.push(".json");
        PathBuf::from(p)
    }

    pub fn optimizer(&self) -> PathBuf {
        self.weights.with_extension("optimizer.safetensors")
    }

    pub(crate) fn write(
        &self,
        weights: &StateDict,
        card: &ModelCard,
        optimizer: Option<&StateDict>,
    ) -> Result<(), TrainError> {
        // The weights carry their card too, so that a copy without the JSON still runs right.
        write_safetensors_with_card(&self.weights, weights, Some(card))?;
        if let Some(o) = optimizer {
            write_safetensors(self.optimizer(), o)?;
        }
        let path = self.card();
        let text =
            serde_json::to_string_pretty(card).map_err(|e| TrainError::Internal(e.to_string()))?;
        let temp = path.with_extension("json.tmp");
        std::fs::write(&temp, text + "\n")
            .and_then(|()| std::fs::rename(&temp, &path))
            .map_err(|source| TrainError::Write {
                path: path.display().to_string(),
                source,
            })
    }

    /// Reads the weights, the card with its training record, and the optimiser state.
    pub(crate) fn read(
        &self,
    ) -> Result<(StateDict, ModelCard, TrainingRecord, StateDict), TrainError> {
        let shown = self.weights.display().to_string();
        let weights = read_safetensors(&self.weights)?;
        let card_path = self.card();
        let card = ModelCard::read(&card_path).map_err(|e| TrainError::Checkpoint {
            path: shown.clone(),
            message: format!("{e} (a training checkpoint has its card beside it)"),
        })?;
        let record: TrainingRecord = card
            .other
            .get("training")
            .cloned()
            .ok_or_else(|| TrainError::Checkpoint {
                path: card_path.display().to_string(),
                message: "no `training` record: not a training checkpoint".into(),
            })
            .and_then(|v| {
                serde_json::from_value(v).map_err(|e| TrainError::Checkpoint {
                    path: card_path.display().to_string(),
                    message: format!("damaged `training` record: {e}"),
                })
            })?;
        let optimizer = read_safetensors(self.optimizer()).map_err(|e| TrainError::Checkpoint {
            path: shown,
            message: format!(
                "its optimiser state cannot be read ({e}); resume from a checkpoint that has one"
            ),
        })?;
        Ok((weights, card, record, optimizer))
    }
}

fn every_frame() -> usize {
    1
}

fn is_every_frame(n: &usize) -> bool {
    *n == 1
}
