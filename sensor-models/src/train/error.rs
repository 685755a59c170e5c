//! Why a training stopped: one error type for the training modules.

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
    #[error("{path}: {source}")]
    Window {
        path: String,
        source: crate::contact_window::WindowError,
    },
    #[error(
        "{first} is of the {design} sensor design and {other} of the {other_design}: a model \
         reads one design; train one model per design"
    )]
    MixedDesigns {
        first: String,
        design: String,
        other: String,
        other_design: String,
    },
    #[error("no labelled frames in {0}")]
    NoFrames(String),
    #[error("the split left no {0} frames (in contact, for a force network): give more data (each side needs at least one press)")]
    EmptySide(&'static str),
    #[error(transparent)]
    Split(#[from] crate::split::SplitError),
    #[error(transparent)]
    Data(#[from] crate::training_set::TrainingSetError),
    #[error("{path}: {message}")]
    Checkpoint { path: String, message: String },
    #[error(transparent)]
    Weights(#[from] crate::weights::error::ModelFileError),
    #[error(transparent)]
    Eval(#[from] crate::eval::EvalError),
    #[error(transparent)]
    Model(#[from] crate::model::ModelError),
    #[error("{path}: {source}")]
    Write {
        path: String,
        source: std::io::Error,
    },
    #[error(transparent)]
    State(#[from] crate::torch_net::state::StateError),
    #[error("libtorch: {0}")]
    Torch(#[from] tch::TchError),
    #[error("{0}")]
    Internal(String),
}
