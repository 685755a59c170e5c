//! A model's card: the JSON sidecar beside a model file (`model.safetensors.json` or
//! `model.json`) saying what the weights alone cannot: the shape class names, the input size and
//! colour, the preprocessing and sensor it was trained for. Training writes it; every field is
//! optional, and fields this version does not know are kept.

use crate::arch::Architecture;
use crate::contact_window::FORCE_WINDOW_MM;
use crate::preprocess::{Colour, INPUT_SIZES, MAX_CROP_RADIUS_PX};
use std::path::{Path, PathBuf};

/// The key under which a model file carries its card: in a safetensors header's `__metadata__`
/// and in an ONNX graph's `metadata_props` (the card as JSON).
pub(crate) const CARD_METADATA_KEY: &str = "fringe.model_card";

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
    #[error(
        "{path}: the model card's {field} is {value}, but {allowed}: correct it in the card \
         (it describes the model beside it)"
    )]
    Field {
        path: String,
        field: &'static str,
        value: String,
        allowed: String,
    },
}

/// The preprocessing names a card may give.
pub(crate) const PREPROCESSING_NAMES: [&str; 3] =
    ["profile", "reference-layered", "reference-integrated"];
/// The sensor designs a card may name.
pub(crate) const VARIANTS: [&str; 2] = ["layered", "integrated"];
/// The largest frame side a card may give, px.
const MAX_FRAME_SIDE_PX: u32 = 100_000;

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
    /// The force head's Fx and Fy are the signed tangential force the indenter applies to the
    /// surface, N, in the sensor's frame (the contact's axes): trained on runs that record it
    /// (`FrameRecord::shear`). Without it (every model trained before 2026-12-07, and models
    /// trained on presses alone) they are magnitudes no loss trained, and the model has no shear.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub shear: bool,
    /// The slip head fitted after the network ([`crate::slip_head`]): stick, partial or gross
    /// slip from the model's readings of a frame and the two before it. Only with `shear`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub slip: Option<crate::slip_head::SlipHead>,
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

    /// A card carried in a model file's metadata (`path` names the file in messages), its
    /// fields checked ([`ModelCard::parse`]).
    pub fn embedded(path: &Path, text: &str) -> Result<ModelCard, CardError> {
        ModelCard::parse(
            &format!("{} (the card in its metadata)", path.display()),
            text,
        )
    }

    /// The card in the file `path`, its fields checked ([`ModelCard::parse`]).
    pub fn read(path: &Path) -> Result<ModelCard, CardError> {
        let shown = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|source| CardError::Read {
            path: shown.clone(),
            source,
        })?;
        ModelCard::parse(&shown, &text)
    }

    /// A card from its JSON text (`shown` names it in messages), every field checked
    /// ([`ModelCard::check`]): a card is refused when it is read, never half-used.
    pub fn parse(shown: &str, text: &str) -> Result<ModelCard, CardError> {
        let card: ModelCard = serde_json::from_str(text).map_err(|source| CardError::Parse {
            path: shown.to_string(),
            source,
        })?;
        card.check(shown)?;
        Ok(card)
    }

    /// Refuses a field outside what it can mean (`shown` names the card): a known network,
    /// shape classes named once each, an input size the preprocessing makes, a known
    /// preprocessing and sensor design, a crop and frame size a camera can have, a force
    /// window of [`FORCE_WINDOW_MM`], and names that name something.
    pub fn check(&self, shown: &str) -> Result<(), CardError> {
        let refuse = |field: &'static str, value: String, allowed: String| {
            Err(CardError::Field {
                path: shown.to_string(),
                field,
                value,
                allowed,
            })
        };
        let one_of = |names: &[&str]| {
            let quoted: Vec<String> = names.iter().map(|n| format!("\"{n}\"")).collect();
            format!("it is one of {}", quoted.join(", "))
        };
        if let Some(a) = &self.architecture {
            if Architecture::from_name(a).is_none() {
                let names: Vec<&str> = Architecture::ALL.iter().map(|a| a.name()).collect();
                return refuse("architecture", format!("{a:?}"), one_of(&names));
            }
        }
        if let Some(classes) = &self.classes {
            if classes.is_empty() {
                return refuse(
                    "classes",
                    "[]".into(),
                    "it names the network's shape classes (\"None\" first)".into(),
                );
            }
            for (i, c) in classes.iter().enumerate() {
                if c.trim().is_empty() || c.chars().any(char::is_control) {
                    return refuse(
                        "classes",
                        format!("{c:?} at {i}"),
                        "each class has a printable name".into(),
                    );
                }
                if classes[..i].contains(c) {
                    return refuse(
                        "classes",
                        format!("{c:?} twice"),
                        "each class is named once".into(),
                    );
                }
            }
        }
        if let Some(n) = self.input_size {
            if !INPUT_SIZES.contains(&n) {
                return refuse(
                    "input_size",
                    n.to_string(),
                    format!("it is {} to {} px", INPUT_SIZES.start(), INPUT_SIZES.end()),
                );
            }
        }
        if let Some(p) = &self.preprocessing {
            if !PREPROCESSING_NAMES.contains(&p.as_str()) {
                return refuse(
                    "preprocessing",
                    format!("{p:?}"),
                    one_of(&PREPROCESSING_NAMES),
                );
            }
        }
        for (field, name) in [
            ("sensor_id", &self.sensor_id),
            ("force_model", &self.force_model),
            ("contact_model", &self.contact_model),
        ] {
            if let Some(n) = name {
                if n.trim().is_empty() || n.chars().any(char::is_control) {
                    return refuse(field, format!("{n:?}"), "it is a printable name".into());
                }
            }
        }
        if let Some(v) = &self.variant {
            if !VARIANTS.contains(&v.as_str()) {
                return refuse("variant", format!("{v:?}"), one_of(&VARIANTS));
            }
        }
        if let Some(d) = self.crop_diameter_px {
            let max = 2.0 * MAX_CROP_RADIUS_PX;
            if !(2.0..=max).contains(&d) {
                return refuse(
                    "crop_diameter_px",
                    number(d),
                    format!("it is 2 to {max} px"),
                );
            }
        }
        if let Some([w, h]) = self.frame_size {
            if !(1..=MAX_FRAME_SIDE_PX).contains(&w) || !(1..=MAX_FRAME_SIDE_PX).contains(&h) {
                return refuse(
                    "frame_size",
                    format!("[{w}, {h}]"),
                    format!("each side is 1 to {MAX_FRAME_SIDE_PX} px"),
                );
            }
        }
        if let Some(mm) = self.force_window_mm {
            if !FORCE_WINDOW_MM.contains(&mm) {
                return refuse(
                    "force_window_mm",
                    number(mm),
                    format!(
                        "a window is {} to {} mm across (24 mm holds a press of the 8 N range)",
                        FORCE_WINDOW_MM.start(),
                        FORCE_WINDOW_MM.end()
                    ),
                );
            }
        }
        if let Some(head) = &self.slip {
            if !self.shear {
                return refuse(
                    "slip",
                    "a slip head".into(),
                    "a slip head reads the shear: only a card that says \"shear\": true has one"
                        .into(),
                );
            }
            if let Err(e) = head.check() {
                return refuse("slip", "a slip head".into(), e.to_string());
            }
        }
        if self.force_window_mm.is_none() && self.refines_contact {
            return refuse(
                "refines_contact",
                "true".into(),
                "only a window network (with force_window_mm) places the contact".into(),
            );
        }
        Ok(())
    }
}

/// A number as a card's reader would write it: 1e300, not three hundred digits.
fn number(v: f64) -> String {
    if v != 0.0 && !(1e-3..1e6).contains(&v.abs()) {
        format!("{v:e}")
    } else {
        v.to_string()
    }
}
