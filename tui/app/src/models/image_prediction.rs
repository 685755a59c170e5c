//! A model run on image files (`fringe model run`): each a full sensor frame, preprocessed as
//! the model's card, a calibration profile or the reference pipeline says.

use crate::models::choice::{open_model, ChoiceError};
use fringe_calibration::{Profile, ProfileError};
use fringe_rig::store::read_plain;
use fringe_rig::store::FrameFileError;
use fringe_sensor_models::eval::frame_ref;
use fringe_sensor_models::BackendKind;
use fringe_sensor_models::ModelError;
use fringe_sensor_models::Prediction;
use fringe_sensor_models::{PredictError, Predictor};
use fringe_sensor_models::{PreprocessError, Preprocessing, ReferenceSensor};
use std::path::{Path, PathBuf};

/// How the images are read.
pub struct ImageRun<'a> {
    /// The model argument (a file or a built-in name).
    pub model: &'a Path,
    /// The sensor's calibration profile, if given.
    pub profile: Option<&'a Path>,
    /// Preprocess as the reference code does for this sensor.
    pub reference: Option<ReferenceSensor>,
    pub backend: BackendKind,
    pub threads: usize,
}

/// A model that could not run on an image.
#[derive(Debug, thiserror::Error)]
pub enum ImagePredictionError {
    #[error(transparent)]
    Open(#[from] ChoiceError),
    #[error(transparent)]
    Model(#[from] ModelError),
    #[error(transparent)]
    Profile(#[from] ProfileError),
    #[error(transparent)]
    Frame(#[from] FrameFileError),
    #[error("{}: {error}", .image.display())]
    Preprocess {
        image: PathBuf,
        error: PreprocessError,
    },
    #[error(transparent)]
    Predict(#[from] PredictError),
    #[error("{}: the model gave no output", .0.display())]
    NoOutput(PathBuf),
}

/// A model ready to run on images.
pub struct ImagePredictor {
    profile: Option<Profile>,
    config: Preprocessing,
    predictor: Predictor,
}

impl ImagePredictor {
    /// Opens the model of `run` and its preprocessing; `warn` hears a model without its card
    /// and one that would see the frames at another scale.
    pub fn open(
        run: &ImageRun<'_>,
        warn: &mut dyn FnMut(String),
    ) -> Result<ImagePredictor, ImagePredictionError> {
        let m = open_model(run.model)?;
        if let Some(w) = m.missing_card_warning() {
            warn(w);
        }
        let profile = match run.profile {
            Some(p) => Some(Profile::load(p)?),
            None => None,
        };
        let config = m.preprocessing(profile.as_ref(), run.reference)?;
        if let Some(w) = m.scale_warning(&config) {
            warn(w);
        }
        let predictor = Predictor::new(&m, run.backend, run.threads)?;
        Ok(ImagePredictor {
            profile,
            config,
            predictor,
        })
    }

    /// The model's prediction on the frame in file `image`; `warn` hears a frame the
    /// preprocessing does not cover.
    pub fn predict(
        &mut self,
        image: &Path,
        warn: &mut dyn FnMut(String),
    ) -> Result<Prediction, ImagePredictionError> {
        let frame = read_plain(image)?;
        if let Some(warning) = self.config.coverage_warning(frame.width, frame.height) {
            warn(format!("{}: {warning}", image.display()));
        }
        let fref = frame_ref(&frame);
        let tensor = self
            .config
            .run(fref)
            .map_err(|error| ImagePredictionError::Preprocess {
                image: image.to_path_buf(),
                error,
            })?;
        let predicted =
            self.predictor
                .predict(&tensor, 1, &[fref], &self.config, self.profile.as_ref())?;
        predicted
            .into_iter()
            .next()
            .ok_or_else(|| ImagePredictionError::NoOutput(image.to_path_buf()))
    }
}
