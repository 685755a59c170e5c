//! Training the paper's networks on fringe's runs and datasets (cargo feature `torch`: libtorch
//! through tch, from the PyPI `torch` wheel; CPU by default, CUDA when libtorch has it and a GPU
//! is there).
//!
//! The data side is this crate's own and needs no libtorch: the split by press
//! ([`crate::split`]), the augmentation pipelines ([`crate::augment`]) and the prepared inputs
//! ([`crate::training_set`]). The networks are [`crate::torch_net`]'s (inference runs them
//! too). Here: Adam as PyTorch computes it with its state by name (`adam`), checkpoints
//! (`checkpoint`: `.safetensors` that PyTorch loads into the reference classes, a model card
//! beside it, the optimiser state in a third file) and the loop (`trainer`), with its
//! learning-rate schedule ([`crate::lr_schedule`]).

mod adam;
mod checkpoint;
mod error;
mod trainer;

pub use checkpoint::{Checkpoint, EpochRecord, TrainingRecord};
pub use error::TrainError;
pub use trainer::{train, Outcome, TrainConfig, TrainEvent};
