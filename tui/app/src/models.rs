//! The policies that pick, open and judge models, one for every command and the commissioning:
//!
//! - `choice`: a model argument opened (a built-in name or a file), and the model a command
//!   runs when none is given (the unit's commissioned model, else the one that ships for its
//!   design).
//! - `labelled_data`: the labelled frames a model is evaluated or adapted on, read and
//!   checked; what they agree on of their sensor; frames it would see at another scale.
//! - `adapted_card`: the card of weights adapted to a unit: the unit, and how they were adapted;
//!   `adaptation`: a model adapted to a unit and written (`fringe adapt`).
//! - `training`: an architecture named on the command line; a training resumed from its
//!   checkpoint's data and settings (cargo feature `torch`).
//! - `two_stage`: a two-stage model joined from a model that finds the contact and window
//!   networks (`fringe model pair`); `onnx_export`: a model's ONNX graph written with its card
//!   (`fringe model export`); `image_prediction`: a model run on image files (`fringe model
//!   run`).
//! - `run_evaluation`: a model's figures on one run (the Runs screen).
//! - `slip_fit`: a model's slip head fitted on runs of slides and written with it (`fringe
//!   model slip`).
//! - `verdict`: a spec given by name (`paper`) or file, and an evaluation's verdict against it
//!   in lines.

pub(crate) mod adaptation;
pub(crate) mod adapted_card;
pub(crate) mod choice;
pub(crate) mod image_prediction;
pub(crate) mod labelled_data;
pub(crate) mod onnx_export;
pub(crate) mod run_evaluation;
pub(crate) mod slip_fit;
pub(crate) mod training;
pub(crate) mod two_stage;
pub(crate) mod verdict;

pub use adaptation::{adapt, AdaptRequest, AdaptationError, AdaptedModel};
pub use adapted_card::AdaptedWriteError;
pub use choice::{
    choose_model, default_model_path, open_model, profiles_dir, ChoiceError, ChoiceNote, ForSensor,
};
pub use image_prediction::{ImagePredictionError, ImagePredictor, ImageRun};
pub use labelled_data::{agreed, read_sources, scale_warnings, LabelledDataError};
pub use onnx_export::{export as export_onnx, Exported, OnnxExportError};
pub use run_evaluation::{evaluate_run, RunEvaluationError};
pub use slip_fit::{fit_slip, SlipFitFailure, SlipFitRequest, SlipFitted};
pub use training::architecture;
#[cfg(feature = "torch")]
pub use training::{
    prepare as prepare_training, Prepared as PreparedTraining, ResumeError, TrainRequest,
    TrainingError,
};
pub use two_stage::{pair, Networks, Paired, TwoStageError};
pub use verdict::{lines as verdict_lines, load as load_spec, PAPER};
