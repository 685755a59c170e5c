//! A model's slip head fitted (`fringe model slip`): the model run over runs of slides, press
//! by press, and a slip head ([`fringe_sensor_models::SlipHead`]) fitted on its readings
//! against the runs' slip labels; the model written again with the head in its card.

use crate::models::choice::{open_model, ChoiceError};
use crate::models::labelled_data::{read_sources, LabelledDataError};
use crate::models::two_stage::{write_network, TwoStageError};
use fringe_sensor_models::eval::{
    evaluate, slip_onsets, slip_sequences, EvalError, SLIP_ONSET_TOLERANCE_FRAMES,
};
use fringe_sensor_models::{
    fit_slip_head, BackendKind, ModelCard, ModelError, OnsetScore, Predictor, SlipFitError,
    SlipHead,
};
use std::path::{Path, PathBuf};

/// What to fit.
pub struct SlipFitRequest<'a> {
    /// The model (a weights file or `builtin:NAME`) with shear heads.
    pub model: &'a Path,
    /// Runs of slides whose frames know their slip.
    pub data: &'a [PathBuf],
    /// The model file to write (its card beside it, `<file>.json`).
    pub out: &'a Path,
    pub threads: usize,
}

/// A slip head fitted and written.
pub struct SlipFitted {
    pub path: PathBuf,
    pub head: SlipHead,
    /// Frames the head was fitted on (a label and a reading), and presses.
    pub frames: usize,
    pub presses: usize,
    /// The written model's onsets on the fitting data itself (not a held-out figure).
    pub on_fitting_data: Option<OnsetScore>,
}

/// Why no slip head was fitted.
#[derive(Debug, thiserror::Error)]
pub enum SlipFitFailure {
    #[error(transparent)]
    Open(#[from] ChoiceError),
    #[error(transparent)]
    Model(#[from] ModelError),
    #[error(transparent)]
    Data(#[from] LabelledDataError),
    #[error(transparent)]
    Eval(#[from] EvalError),
    #[error("{data}: {source}")]
    Fit { data: String, source: SlipFitError },
    #[error(
        "{}: a two-stage model: fit the slip head on a one-network model with shear heads \
         (its force is the slip head's input)",
        .0.display()
    )]
    TwoStage(PathBuf),
    #[error(
        "{}: the slip head is written with the model's weights, and this model has none \
         (an ONNX graph or TorchScript module): give its weights file",
        .0.display()
    )]
    NotWeights(PathBuf),
    #[error(transparent)]
    Write(#[from] TwoStageError),
}

/// Fits the slip head of `r.model` on `r.data` and writes the model with it to `r.out`;
/// `progress` hears (frames done, frames in all) of the model's run over the data.
pub fn fit_slip(
    r: &SlipFitRequest<'_>,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<SlipFitted, SlipFitFailure> {
    let model = open_model(r.model)?;
    model.require_shear()?;
    if model.force.is_some() || model.contact_refiner.is_some() {
        return Err(SlipFitFailure::TwoStage(r.model.to_path_buf()));
    }
    let weights = model
        .weights()
        .ok_or_else(|| SlipFitFailure::NotWeights(r.model.to_path_buf()))?;
    let sources = read_sources(r.data, "fit the slip head on")?;
    // The readings of the network alone: a head already in the card plays no part.
    let mut bare = open_model(r.model)?;
    if let Some(card) = &mut bare.card {
        card.slip = None;
    }
    let mut predictor = Predictor::new(&bare, BackendKind::Tract, r.threads)?;
    let eval = evaluate(&bare, &mut predictor, &sources, None, None, |d, t| {
        progress(d, t)
    })?;
    let sequences = slip_sequences(&eval.rows);
    let shown: Vec<String> = r.data.iter().map(|d| d.display().to_string()).collect();
    let head = fit_slip_head(&sequences, SLIP_ONSET_TOLERANCE_FRAMES).map_err(|source| {
        SlipFitFailure::Fit {
            data: shown.join(", "),
            source,
        }
    })?;
    let frames = sequences
        .iter()
        .flat_map(|s| s.readings.iter().zip(&s.labels))
        .filter(|(r, l)| r.is_some() && l.is_some())
        .count();
    let mut card: ModelCard = model.travelling_card();
    card.slip = Some(head.clone());
    card.other.insert(
        "slip_fit".into(),
        serde_json::json!({
            "data": shown,
            "frames": frames,
            "presses": sequences.len(),
            "confirm_frames": head.confirm_frames,
            "tolerance_frames": SLIP_ONSET_TOLERANCE_FRAMES,
            "fringe_version": env!("CARGO_PKG_VERSION"),
        }),
    );
    write_network(r.out, weights, &card)?;
    // The head as written, over its own data: how well it fits (a held-out figure is
    // `fringe eval` on other units' runs).
    let written = open_model(r.out)?;
    let mut predictor = Predictor::new(&written, BackendKind::Tract, r.threads)?;
    let again = evaluate(&written, &mut predictor, &sources, None, None, |_, _| {})?;
    Ok(SlipFitted {
        path: r.out.to_path_buf(),
        head,
        frames,
        presses: sequences.len(),
        on_fitting_data: slip_onsets(&again.rows),
    })
}
