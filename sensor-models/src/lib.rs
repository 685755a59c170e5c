//! `fringe-sensor-models`: the models of the photoelastic sensor.
//!
//! - `preprocess`: the one preprocessing, from a camera frame or image file to a network
//!   input, driven by the sensor's calibration profile (or the reference pipeline's geometry).
//! - `arch`: the paper's two networks (custom CNN, ResNet-18 multitask), recognised from the
//!   weight keys.
//! - [`builtin`]: the models that ship inside fringe (`default`), and [`builtin::open`] for a
//!   model argument that names one of them or a file.
//! - `contact_window`: the window about the contact a two-stage model reads the force from.
//! - `model`: a model file with its card, ready to run; `model_card`: the JSON sidecar.
//! - [`onnx_graph`]: a network's ONNX graph built from its weights.
//! - `backend`: inference backends behind one trait (tract by default); `prediction`: their
//!   outputs in units; `predictor`: frames to predictions, the one path (two-stage models
//!   included).
//! - [`dataset`]: labelled frames from runs and reference-layout datasets, with the label rules.
//! - `split` (cargo feature `torch`): train / validation / test by physical indentation;
//!   `augment`: the paper's augmentation pipelines; `training_input`: the 8-bit inputs training
//!   takes, one at a time; `training_set` (feature `torch`): a split side's network inputs and
//!   targets.
//! - `torch_net` (cargo feature `torch`): the networks in libtorch, built from `arch`; `train`
//!   (same feature): the training loop on libtorch, checkpoints, resume.
//! - [`adapt`]: a model adapted to one sensor unit in pure Rust (its heads fitted again on the
//!   unit's labelled frames).
//! - `metrics`: the paper's Table-2 figures; [`eval`]: a model over a dataset; [`report`]: its
//!   markdown and plots; `acceptance`: an evaluation against a spec, with a verdict.
//! - `weights`: weights by name as PyTorch's `state_dict()` holds them, and the readers of
//!   every weights file users have (`torch.save` zip and legacy, safetensors), by content.
//!
//! The surface is curated: what other crates use is re-exported here, at the root (the model
//! and its card, preprocessing, backends, predictions, metrics, acceptance, weight files,
//! training and fine-tuning), except six modules kept public as namespaces, whose items read
//! with their module's name: [`adapt`] (`adapt::AdaptConfig`, `adapt::fit_heads`), [`builtin`]
//! (`builtin::open`, `builtin::DEFAULT`), [`dataset`] (`dataset::read`, `dataset::Sample`),
//! [`eval`] (`eval::evaluate`, `eval::Row`), [`onnx_graph`] (`onnx_graph::build`) and [`report`]
//! (`report::write`). Every type the public API hands out is re-exported too, so all of it can
//! be named (`unnameable_types` is warned). Inside this crate, files import from the defining module, never through
//! these re-exports.
#![warn(unreachable_pub)]
#![warn(unnameable_types)]

mod acceptance;
pub mod adapt;
mod arch;
mod augment;
mod backend;
pub mod builtin;
mod contact_window;
pub mod dataset;
pub mod eval;
mod lr_schedule;
mod metrics;
mod model;
mod model_card;
pub mod onnx_graph;
mod prediction;
mod predictor;
mod preprocess;
pub mod report;
mod slip_head;
mod smoothing;
mod split;
#[cfg(feature = "torch")]
mod torch_net;
#[cfg(feature = "torch")]
mod train;
mod training_input;
#[cfg(feature = "torch")]
mod training_set;
mod weights;

pub use acceptance::{
    judge, Check, ForceRange, Spec, SpecError, Thresholds, Verdict, Weak as WeakGroup,
};
#[cfg(feature = "torch")]
pub use adapt::fine_tune::FineTuned;
#[cfg(feature = "torch")]
pub use adapt::fine_tune::{
    fine_tune, finished as finished_fine_tune, FineTuneConfig, FineTuneError, FineTuneEvent,
    FineTuneOutcome, MIN_HELD_OUT,
};
pub use adapt::last_block::{train_last_block, BlockConfig, BlockFit, BlockInputs};
pub use arch::{recognise, ArchError, Architecture, Conv, Keypoints, Layer};
pub use augment::{add_noise, augmentation, rotate_label, Augmentation, Pipeline, UnknownPipeline};
#[cfg(feature = "onnxruntime")]
pub use backend::onnxruntime::OrtBackend;
pub use backend::tract::{profile as profile_tract, OpProfile, OpTime, TractBackend};
pub use backend::{Backend, BackendKind, InferenceError, RawOutputs, UnknownBackend};
pub use contact_window::{WindowError, FORCE_WINDOW_MM};
pub use lr_schedule::Schedule;
pub use metrics::{Errors, MacroScores, Metrics, Scored};
pub use model::{Model, ModelError, Source as ModelSource};
pub use model_card::{CardError, CardSource, ModelCard};
pub use prediction::{ForceVector, Prediction};
pub use predictor::{PredictError, Predictor};
pub use preprocess::{
    rotate_contact, tensor_image, thumbnail, Centre, Colour, FrameRef, PreprocessError,
    Preprocessing, Preprocessor, ReferenceSensor,
};
pub use slip_head::{
    fit as fit_slip_head, FitError as SlipFitError, OnsetScore, Reading, Sequence, SlipHead,
    SlipHeadError, SlipTracker,
};
pub use smoothing::{Smoothing, SmoothingError};
pub use split::{Side, Split, SplitError, SplitSpec};
#[cfg(feature = "torch")]
pub use torch_net::state::StateError;
#[cfg(feature = "torch")]
#[cfg(feature = "torch")]
pub use train::{
    train, Checkpoint, EpochRecord, Outcome as TrainOutcome, TrainConfig, TrainError, TrainEvent,
    TrainingRecord,
};
pub use training_input::{expand_inputs, stored_len, stored_planes, InputMaker};
#[cfg(feature = "torch")]
pub use training_set::TrainingSetError;
pub use weights::error::{ModelFileError, ModelFileErrorKind};
pub use weights::format::{detect_format, read_weights, WeightsFormat};
pub use weights::pickle::{
    parse as parse_pickle, parse_prefix as parse_pickle_prefix, PickleError, Value as PickleValue,
};
pub use weights::safetensors_file::{
    card_in_safetensors, read_safetensors, write_safetensors, write_safetensors_with_card,
};
pub use weights::state_dict::StateDict;
pub use weights::tensor::{StoredType, Tensor};
pub use weights::torch_file::read_torch;
