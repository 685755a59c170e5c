//! Training a network (`fringe train`): an architecture named on the command line, and (builds
//! with the cargo feature `torch`) a training resumed from its checkpoint, which takes the
//! checkpoint's data and settings.

use fringe_sensor_models::Architecture;

/// The architecture named `s`; the error lists the names there are.
pub fn architecture(s: &str) -> Result<Architecture, String> {
    Architecture::from_name(s).ok_or_else(|| {
        let names: Vec<&str> = Architecture::ALL.iter().map(|a| a.name()).collect();
        format!("unknown architecture `{s}`: use {}", names.join(", "))
    })
}

#[cfg(feature = "torch")]
pub use with_torch::{resume_settings, ResumeError};

#[cfg(feature = "torch")]
mod with_torch {
    use super::architecture;
    use fringe_sensor_models::{CardError, ModelCard};
    use fringe_sensor_models::{Checkpoint, TrainConfig, TrainingRecord};
    use std::path::{Path, PathBuf};

    /// A checkpoint a training cannot resume from.
    #[derive(Debug, thiserror::Error)]
    pub enum ResumeError {
        #[error("--resume {}: no such checkpoint", .0.display())]
        NoCheckpoint(PathBuf),
        #[error(transparent)]
        Card(#[from] CardError),
        #[error(transparent)]
        Record(#[from] serde_json::Error),
        #[error("{}: not a checkpoint written by fringe train (its card has no training record)", .0.display())]
        NoRecord(PathBuf),
        #[error("--resume {}: the checkpoint was trained on {then:?}, not {now:?}: resume with the same data (or none, to take it from the checkpoint)", checkpoint.display())]
        OtherData {
            checkpoint: PathBuf,
            then: Vec<PathBuf>,
            now: Vec<PathBuf>,
        },
        #[error("{0}")]
        Architecture(String),
    }

    /// Takes the data (when none is named) and the settings from checkpoint `cp`'s card;
    /// `epochs` (--epochs) may extend the training.
    pub fn resume_settings(
        cp: &Path,
        epochs: Option<usize>,
        config: &mut TrainConfig,
        data: &mut Vec<PathBuf>,
    ) -> Result<(), ResumeError> {
        if !cp.is_file() {
            return Err(ResumeError::NoCheckpoint(cp.to_path_buf()));
        }
        let card = ModelCard::read(&Checkpoint::at(cp).card())?;
        let record: TrainingRecord = card
            .other
            .get("training")
            .cloned()
            .map(serde_json::from_value)
            .transpose()?
            .ok_or_else(|| ResumeError::NoRecord(cp.to_path_buf()))?;
        if data.is_empty() {
            *data = record.data.clone();
        } else if *data != record.data {
            return Err(ResumeError::OtherData {
                checkpoint: cp.to_path_buf(),
                then: record.data,
                now: data.clone(),
            });
        }
        // Settings come from the checkpoint; --epochs may extend the training.
        config.pipeline = record.pipeline;
        config.augment = record.augmented;
        config.freeze_batch_norm = record.batch_norm_frozen;
        config.batch = record.batch;
        config.lr = record.lr;
        config.schedule = record.schedule;
        config.seed = record.seed;
        config.force_window_mm = record.force_window_mm;
        if let Some(arch) = card.architecture.as_deref() {
            config.arch = architecture(arch).map_err(ResumeError::Architecture)?;
        }
        if let Some(size) = card.input_size {
            config.input_size = size;
        }
        config.out = cp
            .parent()
            .map(PathBuf::from)
            .unwrap_or_else(|| PathBuf::from("."));
        config.epochs = epochs.unwrap_or(record.epochs);
        Ok(())
    }
}
