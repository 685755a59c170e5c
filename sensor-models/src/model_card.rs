//! A model's card: the JSON sidecar beside a model file (`model.safetensors.json` or
//! `model.json`) saying what the weights alone cannot: the shape class names, the input size and
//! colour, the preprocessing and sensor it was trained for. Training writes it; every field is
//! optional, and fields this version does not know are kept.

use crate::preprocess::Colour;
use std::path::{Path, PathBuf};

/// The key under which a model file carries its card: in a safetensors header's `__metadata__`
/// and in an ONNX graph's `metadata_props` (the card as JSON).
pub const CARD_METADATA_KEY: &str = "fringe.model_card";

/// Where a model's card came from.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum CardSource {
    /// The JSON file beside the model.
    Beside(PathBuf),
    /// The model file's own metadata.
    Embedded,
    /// Compiled into fringe with the model.
    Builtin,
    /// Neither: input size, colour, classes and preprocessing are guesses.
    Missing,
}

/// Why a model card could not be read.
#[derive(Debug, thiserror::Error)]
pub enum CardError {
    #[error("{path}: {source}")]
    Read {
        path: String,
        source: std::io::Error,
    },
    #[error(
        "{path}: not a model card: {source} (delete or fix it; it describes the model beside it)"
    )]
    Parse {
        path: String,
        source: serde_json::Error,
    },
}

/// The card's fields.
#[derive(Debug, Clone, PartialEq, Default, serde::Serialize, serde::Deserialize)]
pub struct ModelCard {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub architecture: Option<String>,
    /// Shape class names, "None" first.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub classes: Option<Vec<String>>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub input_size: Option<u32>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub colour: Option<Colour>,
    /// "profile" (fringe's, from the sensor's calibration profile), "reference-layered" or
    /// "reference-integrated" (the reference pipeline's geometry).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub preprocessing: Option<String>,
    /// The sensor unit the model was trained or adapted for (a commissioned model's unit).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sensor_id: Option<String>,
    /// The sensor design the model is for: `layered` or `integrated`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub variant: Option<String>,
    /// The sensor's crop across, in pixels of the frames the model was trained on: frames that
    /// show the sensor much coarser than this give figures the model never earned.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub crop_diameter_px: Option<f64>,
    /// The size of the frames the model was trained on.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub frame_size: Option<[u32; 2]>,
    /// The network is the force network of a two-stage model: it reads the force from a window
    /// of this side (mm) about the contact, not the whole disc, and is run only through the
    /// model whose card names it as `force_model`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub force_window_mm: Option<f64>,
    /// A force network whose contact head reads where the press lies from its window's centre
    /// (mm, the label's axes): the two-stage model's contact is the first network's moved by
    /// this offset. Without it (force networks trained before 2026-11-29's second half) the
    /// first network's contact stands.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub refines_contact: bool,
    /// A two-stage model: this network finds the contact and the shape, and the force network
    /// in this file (beside the card, or `builtin:NAME`) reads the force from a window about
    /// that contact.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub force_model: Option<String>,
    /// A two-stage model whose contact a window network of its own places (the file beside the
    /// card, or `builtin:NAME`): one trained with `fringe train --force-window` as the keypoint
    /// CNN, its card saying `refines_contact`. Its window is centred on this network's contact,
    /// the force network's on the contact it places.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub contact_model: Option<String>,
    /// Everything else (training runs, split, losses, figures).
    #[serde(flatten)]
    pub other: serde_json::Map<String, serde_json::Value>,
}

impl ModelCard {
    /// The card paths tried for `model`: `<file>.json`, then `<stem>.json`.
    pub fn candidates(model: &Path) -> [PathBuf; 2] {
        let mut full = model.as_os_str().to_owned();
        full.push(".json");
        [PathBuf::from(full), model.with_extension("json")]
    }

    /// The card beside `model` and its path, if there is one.
    pub fn find(model: &Path) -> Result<Option<(ModelCard, PathBuf)>, CardError> {
        for p in Self::candidates(model) {
            if p.is_file() && p != model {
                return Self::read(&p).map(|c| Some((c, p)));
            }
        }
        Ok(None)
    }

    /// A card carried in a model file's metadata (`path` names the file in messages).
    pub fn embedded(path: &Path, text: &str) -> Result<ModelCard, CardError> {
        serde_json::from_str(text).map_err(|source| CardError::Parse {
            path: format!("{} (the card in its metadata)", path.display()),
            source,
        })
    }

    pub fn read(path: &Path) -> Result<ModelCard, CardError> {
        let shown = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|source| CardError::Read {
            path: shown.clone(),
            source,
        })?;
        serde_json::from_str(&text).map_err(|source| CardError::Parse {
            path: shown,
            source,
        })
    }
}
