//! A two-stage model joined (`fringe model pair`): a model that finds the contact (the keypoint
//! CNN) and window networks trained with `fringe train --force-window` (a force network, a
//! contact network or both), copied into one directory with the first's card naming them.

use crate::models::choice::{open_model, ChoiceError};
use fringe_sensor_models::builtin;
use fringe_sensor_models::ModelCard;
use fringe_sensor_models::{Model, ModelError};
use fringe_sensor_models::{ModelFileError, StateDict};
use std::path::{Path, PathBuf};

/// The file names of a two-stage model in its directory.
const PAIR_CONTACT: &str = "model.safetensors";
const PAIR_FORCE: &str = "force.safetensors";
const PAIR_CONTACT_NET: &str = "contact.safetensors";

/// The networks to join.
pub struct Networks<'a> {
    /// The model that finds the contact and the shape (a file or `builtin:NAME`).
    pub contact_model: &'a Path,
    /// The force network, if any.
    pub force_model: Option<&'a Path>,
    /// The contact network, if any.
    pub contact: Option<&'a Path>,
}

/// A two-stage model written.
pub struct Paired {
    /// Its first network's file, which names the others.
    pub path: PathBuf,
    /// The model that finds the contact, as given.
    pub contact_model: Model,
    /// The two-stage model, opened from `path`.
    pub joined: Model,
}

/// Networks that cannot be joined, or a two-stage model that could not be written.
#[derive(Debug, thiserror::Error)]
pub enum TwoStageError {
    #[error(transparent)]
    Open(#[from] ChoiceError),
    #[error(transparent)]
    Model(#[from] ModelError),
    #[error(
        "give a force network (FORCE_MODEL), a contact network (--contact) or both: a \
         two-stage model reads a window about the contact with at least one"
    )]
    NoWindowNetwork,
    #[error(
        "{}: a two-stage model is made of weights files (.safetensors, .pth): export ONNX \
         afterwards",
        .0.display()
    )]
    NotWeights(PathBuf),
    #[error(
        "{}: a force network cannot find the contact: give the model that finds it first \
         (the keypoint CNN)",
        .0.display()
    )]
    FindsNoContact(PathBuf),
    #[error("{}: already a two-stage model", .0.display())]
    AlreadyTwoStage(PathBuf),
    #[error(
        "{}: not a force network (its card has no force_window_mm): train one with \
         `fringe train --force-window MM`",
        .0.display()
    )]
    NotForceNetwork(PathBuf),
    #[error(
        "{}: not a contact network (its card does not say refines_contact): train \
         one with `fringe train --arch keypoint --force-window MM`",
        .0.display()
    )]
    NotContactNetwork(PathBuf),
    #[error("{}: cannot create", .path.display())]
    Create {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{}: cannot write", .path.display())]
    WriteWeights {
        path: PathBuf,
        #[source]
        source: ModelFileError,
    },
    #[error(transparent)]
    Card(#[from] serde_json::Error),
    #[error("{}: cannot write", .path.display())]
    WriteCard {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
}

/// Writes the two-stage model of `nets` into `out`: the networks' weights and cards, the
/// contact model's card naming its window networks, then opens it to check they run together.
/// `warn` hears each network opened without its card.
pub fn pair(
    nets: &Networks<'_>,
    out: &Path,
    warn: &mut dyn FnMut(String),
) -> Result<Paired, TwoStageError> {
    let mut open = |path: &Path| -> Result<Model, TwoStageError> {
        let m = open_model(path)?;
        if let Some(w) = m.missing_card_warning() {
            warn(w);
        }
        Ok(m)
    };
    let contact = open(nets.contact_model)?;
    if nets.force_model.is_none() && nets.contact.is_none() {
        return Err(TwoStageError::NoWindowNetwork);
    }
    let weights_c = weights_of(&contact)?;
    if contact.force_window_mm().is_some() {
        return Err(TwoStageError::FindsNoContact(
            nets.contact_model.to_path_buf(),
        ));
    }
    if contact.force.is_some() || contact.contact_refiner.is_some() {
        return Err(TwoStageError::AlreadyTwoStage(
            nets.contact_model.to_path_buf(),
        ));
    }
    let design = contact.card.as_ref().and_then(|c| c.variant.clone());
    let of = format!("the contact model {}", nets.contact_model.display());
    let force = match nets.force_model {
        Some(path) => {
            let net = open(path)?;
            if net.force_window_mm().is_none() {
                return Err(TwoStageError::NotForceNetwork(path.to_path_buf()));
            }
            net.check_design(design.as_deref(), &of)?;
            Some(net)
        }
        None => None,
    };
    let refiner = match nets.contact {
        Some(path) => {
            let net = open(path)?;
            if !net.card.as_ref().is_some_and(|c| c.refines_contact) || net.force.is_some() {
                return Err(TwoStageError::NotContactNetwork(path.to_path_buf()));
            }
            net.check_design(design.as_deref(), &of)?;
            Some(net)
        }
        None => None,
    };
    // Every network is checked before anything is written.
    for net in force.iter().chain(&refiner) {
        weights_of(net)?;
    }
    std::fs::create_dir_all(out).map_err(|source| TwoStageError::Create {
        path: out.to_path_buf(),
        source,
    })?;
    let mut card = contact.travelling_card();
    for (net, file, slot) in [
        (&refiner, PAIR_CONTACT_NET, &mut card.contact_model),
        (&force, PAIR_FORCE, &mut card.force_model),
    ] {
        if let Some(net) = net {
            write_network(&out.join(file), weights_of(net)?, &net.travelling_card())?;
            *slot = Some(file.to_string());
        }
    }
    let path = out.join(PAIR_CONTACT);
    write_network(&path, weights_c, &card)?;
    let joined = builtin::open(&path)?;
    Ok(Paired {
        path,
        contact_model: contact,
        joined,
    })
}

/// The weights of a network joined into a two-stage model.
fn weights_of(net: &Model) -> Result<&StateDict, TwoStageError> {
    net.weights()
        .ok_or_else(|| TwoStageError::NotWeights(net.path.clone()))
}

/// A network into `path`: its weights with the card embedded, and the card beside it
/// (`<file>.json`), as training writes them (a two-stage model's networks, a model with its
/// slip head).
pub(crate) fn write_network(
    path: &Path,
    weights: &StateDict,
    card: &ModelCard,
) -> Result<(), TwoStageError> {
    fringe_sensor_models::write_safetensors_with_card(path, weights, Some(card)).map_err(
        |source| TwoStageError::WriteWeights {
            path: path.to_path_buf(),
            source,
        },
    )?;
    let [json, _] = ModelCard::candidates(path);
    let text = serde_json::to_string_pretty(card)?;
    std::fs::write(&json, text + "\n").map_err(|source| TwoStageError::WriteCard {
        path: json.clone(),
        source,
    })
}
