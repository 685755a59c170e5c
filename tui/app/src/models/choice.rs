//! Which model runs: a model argument opened (`default`, `builtin:NAME` or a file), and the model
//! a command runs when none is given.

use crate::commission::certificate::commissioned_model;
use crate::rig::file::RigConfig;
use fringe_sensor_models::builtin;
use fringe_sensor_models::{Model, ModelError};
use std::path::{Path, PathBuf};

/// A model that could not be opened or chosen.
#[derive(Debug, thiserror::Error)]
pub enum ChoiceError {
    /// The file does not exist (and is no built-in name).
    #[error("{}: no such model file (`default` is the model that ships with fringe)", .0.display())]
    NoSuchFile(PathBuf),
    #[error(transparent)]
    Model(#[from] ModelError),
}

/// Opens a model argument: a built-in model (`default`, `builtin:NAME`) or a model file,
/// naming the file when it is missing. A model without a card says so in
/// [`Model::missing_card_warning`], for the caller to show.
pub fn open_model(path: &Path) -> Result<Model, ChoiceError> {
    if builtin::named(path).is_none() && !path.exists() {
        return Err(ChoiceError::NoSuchFile(path.to_path_buf()));
    }
    Ok(builtin::open(path)?)
}

/// Where profiles and commissionings live for a command that opens no rig: the rig file's
/// `profiles` (./rig.toml), else `profiles`; `note` hears why the rig file could not say.
pub fn profiles_dir(note: &mut dyn FnMut(ChoiceNote)) -> PathBuf {
    match RigConfig::resolve(None) {
        Ok((config, _)) => config.profile_dir(),
        Err(e) => {
            note(ChoiceNote::Warning(format!(
                "{e}; looking for commissioned models in profiles/"
            )));
            PathBuf::from("profiles")
        }
    }
}

/// The sensor a model is chosen for: where its profiles live, its unit and its design, as far as
/// they are known.
pub struct ForSensor<'a> {
    pub profiles: &'a Path,
    pub unit: Option<&'a str>,
    pub variant: Option<&'a str>,
    /// Whose design `variant` is, in messages ("this sensor", "the data's sensor").
    pub whose: &'a str,
}

/// What the choice tells the operator, as it goes.
pub enum ChoiceNote {
    /// Which commissioned model was taken.
    Commissioned(String),
    /// A warning (without the `warning: ` the caller puts before it).
    Warning(String),
}

/// Where the model a command runs without `--model` is (not opened): the newest passing
/// commissioning's model of the unit under `profiles`, else the model that ships for the
/// sensor's design (an error for a design none ships for). `note` hears which commissioned model
/// was taken and why a certificate was passed over.
pub fn default_model_path(
    sensor: &ForSensor<'_>,
    note: &mut dyn FnMut(ChoiceNote),
) -> Result<PathBuf, ChoiceError> {
    if let Some(unit) = sensor.unit {
        let (found, notes) = commissioned_model(sensor.profiles, unit);
        for n in notes {
            note(ChoiceNote::Warning(n));
        }
        if let Some(c) = found {
            note(ChoiceNote::Commissioned(format!(
                "model: sensor {unit}'s commissioned model {} (certificate of {}; give --model to run another)",
                c.model.display(),
                c.certificate.issued_utc
            )));
            return Ok(c.model);
        }
    }
    Ok(builtin::for_design(sensor.variant)?)
}

/// The model a command runs when `given` is `None`: the newest passing commissioning's model of
/// the unit under `profiles`, else the model that ships for the sensor's design. A model whose
/// card names another design than the sensor's is refused; one adapted to another unit is run
/// with a warning. `note` hears what the operator is told, as it comes.
pub fn choose_model(
    given: Option<&Path>,
    sensor: &ForSensor<'_>,
    note: &mut dyn FnMut(ChoiceNote),
) -> Result<Model, ChoiceError> {
    let path = match given {
        Some(p) => p.to_path_buf(),
        None => default_model_path(sensor, note)?,
    };
    let model = open_model(&path)?;
    if let Some(w) = model.missing_card_warning() {
        note(ChoiceNote::Warning(w));
    }
    model.check_design(sensor.variant, sensor.whose)?;
    let adapted_to = model
        .card
        .as_ref()
        .filter(|c| c.other.contains_key("adaptation"))
        .and_then(|c| c.sensor_id.clone());
    if let (Some(for_unit), Some(unit)) = (adapted_to, sensor.unit) {
        if for_unit != unit {
            note(ChoiceNote::Warning(format!(
                "{} was adapted to sensor {for_unit}, and this is sensor {unit}: its figures here are not the ones it was accepted with",
                model.path.display()
            )));
        }
    }
    Ok(model)
}
