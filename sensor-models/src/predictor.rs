//! From frames to predictions: the one path `fringe model run`, `fringe eval` (and everything
//! that evaluates: training's test figures, unit checks, certificates) and live validation take.
//!
//! A model is one network, or two (a two-stage model, its card naming a `force_model`): the
//! first finds the contact and the shape on the whole disc, the second reads the force from a
//! window about the contact the first found ([`crate::contact_window`]); a frame the first finds
//! without contact reads no force. Both run on the same backend.

use crate::backend::{Backend, BackendKind, InferenceError};
use crate::contact_window::{ContactWindow, WindowError};
use crate::model::{Model, ModelError};
use crate::prediction::{predictions, ForceVector, Prediction};
use crate::preprocess::{Colour, FrameRef, PreprocessError, Preprocessing, Preprocessor};
use fringe_calibration::profile::Profile;

/// Why frames could not be turned into predictions.
#[derive(Debug, thiserror::Error)]
pub enum PredictError {
    #[error("{model}: {source}")]
    Inference {
        model: String,
        source: InferenceError,
    },
    #[error("{model}: {source}")]
    Window { model: String, source: WindowError },
    #[error("{model}: the force window of frame {index} of the batch: {source}")]
    Frame {
        model: String,
        index: usize,
        source: PreprocessError,
    },
    #[error(
        "{model}: a two-stage model reads the force from the frame itself, and {frames} frames \
         came with {inputs} network inputs"
    )]
    Frames {
        model: String,
        frames: usize,
        inputs: usize,
    },
    #[error("{model}: the network gave {got} predictions for {want} inputs")]
    Outputs {
        model: String,
        got: usize,
        want: usize,
    },
}

/// The force network of a two-stage model, on its backend.
struct ForceStage {
    backend: Box<dyn Backend>,
    path: String,
    window_mm: f64,
    input_size: u32,
    colour: Colour,
    /// The window's preprocessing, its centre moved for each frame (its buffers kept).
    pre: Option<Preprocessor>,
    input: Vec<f32>,
}

/// A model's networks on a backend, turning frames into predictions.
pub struct Predictor {
    disc: Box<dyn Backend>,
    path: String,
    classes: Vec<String>,
    input_size: u32,
    force: Option<ForceStage>,
}

impl Predictor {
    /// `model`'s networks on the backend `kind`, `threads` threads each. A force network is
    /// refused on its own: it reads a window about a contact some other network finds.
    pub fn new(model: &Model, kind: BackendKind, threads: usize) -> Result<Predictor, ModelError> {
        if model
            .card
            .as_ref()
            .is_some_and(|c| c.force_window_mm.is_some())
        {
            return Err(ModelError::ForceNetworkAlone {
                path: model.path.display().to_string(),
            });
        }
        let force = match &model.force {
            Some(f) => Some(ForceStage {
                backend: f.backend(kind, threads)?,
                path: f.path.display().to_string(),
                window_mm: f
                    .force_window_mm()
                    .ok_or_else(|| ModelError::NotAForceNetwork {
                        path: f.path.display().to_string(),
                        of: model.path.display().to_string(),
                    })?,
                input_size: f.input_size,
                colour: f.colour,
                pre: None,
                input: Vec::new(),
            }),
            None => None,
        };
        Ok(Predictor {
            disc: model.backend(kind, threads)?,
            path: model.path.display().to_string(),
            classes: model.classes.clone(),
            input_size: model.input_size,
            force,
        })
    }

    /// The backend's name (`tract`, `onnxruntime`, `torch`).
    pub fn backend_name(&self) -> &'static str {
        self.disc.name()
    }

    /// Whether [`Predictor::predict`] needs the frames themselves (a two-stage model's force
    /// network reads them), not only their whole-disc inputs.
    pub fn needs_frames(&self) -> bool {
        self.force.is_some()
    }

    /// The predictions of `n` frames whose whole-disc inputs (preprocessed by `disc`, one after
    /// another) are `input`. A two-stage model reads the force of each frame the first network
    /// finds in contact from `frames[i]`, in the window about that contact (`profile` gives the
    /// registration that places it); a one-network model needs no frames (pass none).
    pub fn predict(
        &mut self,
        input: &[f32],
        n: usize,
        frames: &[FrameRef<'_>],
        disc: &Preprocessing,
        profile: Option<&Profile>,
    ) -> Result<Vec<Prediction>, PredictError> {
        let raw =
            self.disc
                .run(input, n, self.input_size)
                .map_err(|source| PredictError::Inference {
                    model: self.path.clone(),
                    source,
                })?;
        let mut out = predictions(&raw, &self.classes);
        if out.len() != n {
            return Err(PredictError::Outputs {
                model: self.path.clone(),
                got: out.len(),
                want: n,
            });
        }
        if let Some(stage) = &mut self.force {
            if frames.len() != n {
                return Err(PredictError::Frames {
                    model: self.path.clone(),
                    frames: frames.len(),
                    inputs: n,
                });
            }
            stage.read_force(&mut out, frames, disc, profile)?;
        }
        Ok(out)
    }
}

impl ForceStage {
    /// Replaces the force of every prediction in contact by the force network's reading of the
    /// window about its contact, all windows of the batch in one run. A frame the first network
    /// finds without contact reads no force: by the label rules its force is below the contact
    /// threshold, the force network reads presses only, and the first network's own force head
    /// (trained beside its contact and shape heads) reads about 0.25 N at rest on the layered
    /// sensor (BENCHMARKS.md, "Two-stage models").
    fn read_force(
        &mut self,
        out: &mut [Prediction],
        frames: &[FrameRef<'_>],
        disc: &Preprocessing,
        profile: Option<&Profile>,
    ) -> Result<(), PredictError> {
        for p in out.iter_mut().filter(|p| p.contact.is_none()) {
            p.force = ForceVector::from_array([0.0; 7]);
        }
        let pressed: Vec<usize> = (0..out.len())
            .filter(|&i| out[i].contact.is_some())
            .collect();
        if pressed.is_empty() {
            return Ok(());
        }
        let window = profile
            .ok_or_else(|| WindowError::Reference {
                sensor: disc.sensor.clone(),
            })
            .and_then(|p| ContactWindow::from_profile(p, self.window_mm))
            .map_err(|source| PredictError::Window {
                model: self.path.clone(),
                source,
            })?;
        let per = 3 * (self.input_size as usize).pow(2);
        self.input.resize(per * pressed.len(), 0.0);
        for (k, &i) in pressed.iter().enumerate() {
            let [x, y] = out[i].contact_raw.map(|v| v.value());
            let config = window
                .preprocessing(disc, [x, y], self.input_size, self.colour)
                .map_err(|source| PredictError::Window {
                    model: self.path.clone(),
                    source,
                })?;
            let pre = match &mut self.pre {
                Some(p) => {
                    p.config = config;
                    p
                }
                slot => slot.insert(Preprocessor::new(config)),
            };
            pre.run_into(frames[i], 0.0, &mut self.input[k * per..(k + 1) * per])
                .map_err(|source| PredictError::Frame {
                    model: self.path.clone(),
                    index: i,
                    source,
                })?;
        }
        let raw = self
            .backend
            .run(&self.input, pressed.len(), self.input_size)
            .map_err(|source| PredictError::Inference {
                model: self.path.clone(),
                source,
            })?;
        if raw.force.len() != pressed.len() {
            return Err(PredictError::Outputs {
                model: self.path.clone(),
                got: raw.force.len(),
                want: pressed.len(),
            });
        }
        for (&i, force) in pressed.iter().zip(&raw.force) {
            out[i].force = ForceVector::from_array(*force);
        }
        Ok(())
    }
}
