//! The policies that pick, open and judge models, one for every command and the commissioning:
//!
//! - [`choice`]: a model argument opened (a built-in name or a file), and the model a command
//!   runs when none is given (the unit's commissioned model, else the one that ships for its
//!   design).
//! - [`labelled_data`]: the labelled frames a model is evaluated or adapted on, read and
//!   checked; what they agree on of their sensor; frames it would see at another scale.
//! - [`adapted_card`]: the card of weights adapted to a unit: the unit, and how they were adapted;
//!   [`adaptation`]: a model adapted to a unit and written (`fringe adapt`).
//! - [`training`]: an architecture named on the command line; a training resumed from its
//!   checkpoint's data and settings (cargo feature `torch`).
//! - [`two_stage`]: a two-stage model joined from a model that finds the contact and window
//!   networks (`fringe model pair`); [`onnx_export`]: a model's ONNX graph written with its card
//!   (`fringe model export`); [`image_prediction`]: a model run on image files (`fringe model
//!   run`).
//! - [`run_evaluation`]: a model's figures on one run (the Runs screen).
//! - [`verdict`]: a spec given by name (`paper`) or file, and an evaluation's verdict against it
//!   in lines.

pub mod adaptation;
pub mod adapted_card;
pub mod choice;
pub mod image_prediction;
pub mod labelled_data;
pub mod onnx_export;
pub mod run_evaluation;
pub mod training;
pub mod two_stage;
pub mod verdict;
