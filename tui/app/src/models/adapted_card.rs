//! The card of weights adapted to a unit (`fringe adapt`, commissioning): the base model's card
//! with the unit they were adapted to, and how; the weights written with it.

use fringe_sensor_models::adapt::Adapted;
use fringe_sensor_models::Model;
use fringe_sensor_models::ModelCard;
use fringe_sensor_models::{write_safetensors_with_card, ModelFileError, StateDict};
use std::path::{Path, PathBuf};

/// Adapted weights that could not be written.
#[derive(Debug, thiserror::Error)]
pub enum AdaptedWriteError {
    #[error(transparent)]
    Weights(#[from] ModelFileError),
    #[error("the model card")]
    Card(#[source] serde_json::Error),
    #[error("cannot write {}", path.display())]
    Write {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
}

/// Adapted `weights` written to `path` (safetensors) with `card` in them and beside them
/// (`<path>.json`, as `fringe adapt` and commissioning write them); the card's path.
pub(crate) fn write_adapted(
    path: &Path,
    weights: &StateDict,
    card: &ModelCard,
) -> Result<PathBuf, AdaptedWriteError> {
    write_safetensors_with_card(path, weights, Some(card))?;
    let card_path = path.with_extension("json");
    let text = serde_json::to_string_pretty(card).map_err(AdaptedWriteError::Card)?;
    std::fs::write(&card_path, text + "\n").map_err(|source| AdaptedWriteError::Write {
        path: card_path.clone(),
        source,
    })?;
    Ok(card_path)
}

/// The base model's card for the adapted weights: the unit they were adapted to, and how
/// (adapted on `data`, `folds` folds over presses seeded with `seed`).
pub(crate) fn adapted_card(
    model: &Model,
    adapted: &Adapted,
    data: &[PathBuf],
    folds: u64,
    seed: u64,
    unit: Option<&str>,
) -> ModelCard {
    let mut card = model.travelling_card();
    if let Some(unit) = unit {
        card.sensor_id = Some(unit.to_string());
    }
    if let Some(training) = card.other.remove("training") {
        card.other.insert("base_training".into(), training);
    }
    let data: Vec<String> = data.iter().map(|d| shown(d)).collect();
    card.other.insert(
        "adaptation".into(),
        serde_json::json!({
            "method": "heads",
            "about": "the network's heads fitted again on the unit's frames (pure Rust), each \
                      pulled towards the base model's by cross-validation over presses",
            "base": shown(&model.path),
            "data": data,
            "frames": adapted.frames,
            "presses": adapted.presses,
            "folds": folds,
            "seed": seed,
            "heads": adapted.heads,
            "fringe_version": env!("CARGO_PKG_VERSION"),
        }),
    );
    card
}

fn shown(p: &Path) -> String {
    p.display().to_string()
}
