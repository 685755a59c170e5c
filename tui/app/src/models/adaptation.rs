//! A model adapted to one sensor unit (`fringe adapt`), in pure Rust: its heads fitted again on
//! the unit's labelled frames, written with the card that says so beside the base model's.

use crate::models::adapted_card::{adapted_card, write_adapted, AdaptedWriteError};
use crate::models::choice::{open_model, ChoiceError};
use crate::models::labelled_data::{read_sources, LabelledDataError};
use fringe_calibration::{Profile, ProfileError};
use fringe_sensor_models::adapt::{adapt_heads, AdaptConfig, AdaptError, Adapted};
use fringe_sensor_models::Model;
use std::path::{Path, PathBuf};

/// An adaptation as the command line asks for it.
pub struct AdaptRequest<'a> {
    /// The model to start from (a file or a built-in name).
    pub model: &'a Path,
    /// The unit's labelled frames: run directories or reference-layout datasets.
    pub data: &'a [PathBuf],
    /// The adapted weights (a new `.safetensors` file).
    pub out: &'a Path,
    /// Calibration profile for data that carries none.
    pub profile: Option<&'a Path>,
    /// Cross-validation folds over presses.
    pub folds: u64,
    /// Seed of the presses' assignment to folds.
    pub seed: u64,
    /// Inference threads.
    pub threads: usize,
}

/// A model adapted and written.
pub struct AdaptedModel {
    /// The base model.
    pub base: Model,
    /// The heads fitted again: the frames and presses used, each head's figure before and after.
    pub adapted: Adapted,
    /// The card written beside the weights.
    pub card: PathBuf,
}

/// An adaptation refused or failed.
#[derive(Debug, thiserror::Error)]
pub enum AdaptationError {
    #[error(
        "--out {}: the adapted weights are written as safetensors: name the file *.safetensors",
        .0.display()
    )]
    NotSafetensors(PathBuf),
    #[error(
        "--out {}: the file exists; choose a new name (an adapted model never overwrites another)",
        .0.display()
    )]
    Exists(PathBuf),
    #[error(transparent)]
    Open(#[from] ChoiceError),
    #[error(transparent)]
    Profile(#[from] ProfileError),
    #[error(transparent)]
    Data(#[from] LabelledDataError),
    #[error(transparent)]
    Adapt(#[from] AdaptError),
    #[error(transparent)]
    Write(#[from] AdaptedWriteError),
}

/// Adapts the model of `r` to the unit whose frames `r.data` holds and writes it to `r.out`;
/// `warn` hears a model that is a copy of another, `progress` the frames read (done, total).
pub fn adapt(
    r: &AdaptRequest<'_>,
    warn: &mut dyn FnMut(String),
    progress: &mut dyn FnMut(usize, usize),
) -> Result<AdaptedModel, AdaptationError> {
    if r.out.extension().and_then(|e| e.to_str()) != Some("safetensors") {
        return Err(AdaptationError::NotSafetensors(r.out.to_path_buf()));
    }
    if r.out.exists() {
        return Err(AdaptationError::Exists(r.out.to_path_buf()));
    }
    let base = open_model(r.model)?;
    if let Some(w) = base.missing_card_warning() {
        warn(w);
    }
    if let Some(w) = base.copy_warning() {
        warn(w);
    }
    let profile = match r.profile {
        Some(p) => Some(Profile::load(p)?),
        None => None,
    };
    let sources = read_sources(r.data, "adapt on")?;
    let config = AdaptConfig {
        folds: r.folds as usize,
        seed: r.seed,
        threads: r.threads,
    };
    let adapted = adapt_heads(&base, &sources, profile.as_ref(), &config, |done, total| {
        progress(done, total)
    })?;
    let unit = sources
        .iter()
        .find_map(|s| s.sensor_id.clone())
        .or_else(|| profile.as_ref().map(|p| p.sensor_id.clone()));
    let card = adapted_card(&base, &adapted, r.data, r.folds, r.seed, unit.as_deref());
    let card = write_adapted(r.out, &adapted.weights, &card)?;
    Ok(AdaptedModel {
        base,
        adapted,
        card,
    })
}
