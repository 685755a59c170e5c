//! Training the paper's networks on fringe's runs and datasets (cargo feature `torch`: libtorch
//! through tch, from the PyPI `torch` wheel; CPU by default, CUDA when libtorch has it and a GPU
//! is there).
//!
//! The data side is this crate's own and needs no libtorch: the split by press
//! ([`crate::split`]), the augmentation pipelines ([`crate::augment`]) and the prepared inputs
//! ([`crate::training_set`]). Here: the networks with the reference's parameter names
//! (`net`), Adam as PyTorch computes it with its state by name (`adam`), checkpoints
//! (`checkpoint`: `.safetensors` that PyTorch loads into the reference classes, a model card
//! beside it, the optimiser state in a third file) and the loop (`trainer`).

mod adam;
mod checkpoint;
mod net;
mod tensors;
mod trainer;

pub use checkpoint::{Checkpoint, EpochRecord, TrainingRecord};
pub use trainer::{train, Outcome, TrainConfig, TrainEvent};

/// Why a training stopped.
#[derive(Debug, thiserror::Error)]
pub enum TrainError {
    #[error("{path}: no calibration profile: train on runs recorded with a profile, or give --profile FILE for datasets that carry none")]
    NoProfile { path: String },
    #[error("{path}: the calibration profile cannot be used: {source}")]
    Profile {
        path: String,
        source: crate::preprocess::PreprocessError,
    },
    #[error("no labelled frames in {0}")]
    NoFrames(String),
    #[error("the split left no {0} frames: give more data (each side needs at least one press)")]
    EmptySide(&'static str),
    #[error(transparent)]
    Split(#[from] crate::split::SplitError),
    #[error(transparent)]
    Data(#[from] crate::training_set::TrainingSetError),
    #[error("{path}: {message}")]
    Checkpoint { path: String, message: String },
    #[error(transparent)]
    Weights(#[from] crate::model_file_error::ModelFileError),
    #[error(transparent)]
    Eval(#[from] crate::eval::EvalError),
    #[error(transparent)]
    Model(#[from] crate::model::ModelError),
    #[error("{path}: {source}")]
    Write {
        path: String,
        source: std::io::Error,
    },
    #[error("libtorch: {0}")]
    Torch(#[from] tch::TchError),
    #[error("{0}")]
    Internal(String),
}
