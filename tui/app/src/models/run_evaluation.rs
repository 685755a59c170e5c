//! A model's figures on one run, through the run's own profile (the Runs screen's `e`).

use fringe_sensor_models::dataset::DatasetError;
use fringe_sensor_models::eval::{evaluate, EvalError, Evaluation};
use fringe_sensor_models::BackendKind;
use fringe_sensor_models::ModelError;
use std::path::Path;

/// A run that could not be evaluated.
#[derive(Debug, thiserror::Error)]
pub enum RunEvaluationError {
    #[error(transparent)]
    Model(#[from] ModelError),
    #[error("{0}")]
    Data(#[from] DatasetError),
    #[error(transparent)]
    Eval(#[from] EvalError),
}

/// The evaluation of the model `model` (a file or a built-in name) on the run `dir`, run by
/// `backend` on `threads` threads; `progress` hears (frames done, in all).
pub fn evaluate_run(
    dir: &Path,
    model: &Path,
    backend: BackendKind,
    threads: usize,
    progress: &dyn Fn(usize, usize),
) -> Result<Evaluation, RunEvaluationError> {
    let model = fringe_sensor_models::builtin::open(model)?;
    let source = fringe_sensor_models::dataset::read(dir)?;
    let mut predictor = fringe_sensor_models::Predictor::new(&model, backend, threads)?;
    Ok(evaluate(
        &model,
        &mut predictor,
        std::slice::from_ref(&source),
        None,
        None,
        progress,
    )?)
}
