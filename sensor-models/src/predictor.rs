//! From frames to predictions: the one path `fringe model run`, `fringe eval` (and everything
//! that evaluates: training's test figures, unit checks, certificates) and live validation take.
//!
//! A model is one network, or a two-stage model: its card names a `force_model`, a
//! `contact_model` or both. The first network finds the contact and the shape on the whole
//! disc; the window networks read a window about that contact ([`crate::contact_window`]). A
//! contact network (its card saying `refines_contact`) reads where the press lies from its
//! window's centre, which moves the contact; then the force network reads the force in a window
//! about the contact so placed (and, without a contact network, moves the contact itself when
//! its card says `refines_contact`). A frame the first network finds without contact reads no
//! force. Every network runs on the same backend.

use crate::backend::{Backend, BackendKind, InferenceError};
use crate::contact_window::{ContactWindow, WindowError};
use crate::model::{Model, ModelError};
use crate::prediction::{predictions, ForceVector, Prediction};
use crate::preprocess::{Colour, FrameRef, PreprocessError, Preprocessing, Preprocessor};
use fringe_calibration::Profile;
use fringe_rig::{Millimetres, Newtons};
use std::time::{Duration, Instant};

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

/// A window network of a two-stage model, on its backend.
struct WindowStage {
    backend: Box<dyn Backend>,
    path: String,
    window_mm: f64,
    /// Its force head gives the model's force (the force network's).
    reads_force: bool,
    /// Its force head's Fx, Fy are the signed shear (its card's `shear`).
    shear: bool,
    /// Its contact head reads the press's offset from the window's centre (a card saying
    /// `refines_contact`): the model's contact is moved by it.
    reads_contact: bool,
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
    /// Inference threads of each network.
    threads: usize,
    /// The window networks in the order they run: the contact network (placing the contact the
    /// force network's window is then centred on), then the force network.
    windows: Vec<WindowStage>,
    /// The force the model gives carries the signed shear ([`Model::has_shear`]).
    shear: bool,
}

impl Predictor {
    /// `model`'s networks on the backend `kind`, `threads` threads each. A force network is
    /// refused on its own: it reads a window about a contact some other network finds.
    pub fn new(model: &Model, kind: BackendKind, threads: usize) -> Result<Predictor, ModelError> {
        model.check_runs_alone()?;
        let stage = |net: &Model, reads_force: bool, reads_contact: bool| {
            Ok::<_, ModelError>(WindowStage {
                backend: net.backend(kind, threads)?,
                path: net.path.display().to_string(),
                window_mm: net
                    .force_window_mm()
                    .ok_or_else(|| ModelError::NotAWindowNetwork {
                        path: net.path.display().to_string(),
                        of: model.path.display().to_string(),
                    })?,
                reads_force,
                reads_contact,
                shear: net.card.as_ref().is_some_and(|c| c.shear),
                input_size: net.input_size,
                colour: net.colour,
                pre: None,
                input: Vec::new(),
            })
        };
        let refines = |net: &Model| net.card.as_ref().is_some_and(|c| c.refines_contact);
        let mut windows = Vec::new();
        if let Some(c) = &model.contact_refiner {
            windows.push(stage(c, false, refines(c))?);
        }
        if let Some(f) = &model.force {
            let reads_contact = model.contact_refiner.is_none() && refines(f);
            windows.push(stage(f, true, reads_contact)?);
        }
        Ok(Predictor {
            disc: model.backend(kind, threads)?,
            path: model.path.display().to_string(),
            classes: model.classes.clone(),
            input_size: model.input_size,
            threads,
            windows,
            shear: model.has_shear(),
        })
    }

    /// Inference threads of each network.
    pub fn threads(&self) -> usize {
        self.threads
    }

    /// How long this machine takes to run the model on one frame, networks alone: the median
    /// of `runs` runs (after one to warm up) of every network it has on a blank input, the whole
    /// disc's and each window network's, as a frame in contact runs them. Preprocessing is not
    /// in it.
    pub fn time_per_frame(&mut self, runs: usize) -> Result<Duration, PredictError> {
        fn once(
            backend: &mut dyn Backend,
            path: &str,
            input: &[f32],
            size: u32,
        ) -> Result<(), PredictError> {
            backend
                .run(input, 1, size)
                .map(|_| ())
                .map_err(|source| PredictError::Inference {
                    model: path.to_string(),
                    source,
                })
        }
        let blank = |size: u32| vec![0f32; 3 * (size as usize).pow(2)];
        let disc = blank(self.input_size);
        let windows: Vec<Vec<f32>> = self.windows.iter().map(|w| blank(w.input_size)).collect();
        let runs = runs.max(1);
        let mut times = Vec::with_capacity(runs);
        for i in 0..=runs {
            let start = Instant::now();
            once(&mut *self.disc, &self.path, &disc, self.input_size)?;
            for (w, input) in self.windows.iter_mut().zip(&windows) {
                once(&mut *w.backend, &w.path, input, w.input_size)?;
            }
            if i > 0 {
                times.push(start.elapsed());
            }
        }
        times.sort();
        Ok(times[times.len() / 2])
    }

    /// The backend's name (`tract`, `onnxruntime`, `torch`).
    pub fn backend_name(&self) -> &'static str {
        self.disc.name()
    }

    /// Whether [`Predictor::predict`] needs the frames themselves (a two-stage model's window
    /// networks read them), not only their whole-disc inputs.
    pub fn needs_frames(&self) -> bool {
        !self.windows.is_empty()
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
        let mut out = self.disc_predictions(input, n)?;
        if !self.windows.is_empty() && frames.len() != n {
            return Err(PredictError::Frames {
                model: self.path.clone(),
                frames: frames.len(),
                inputs: n,
            });
        }
        for stage in &mut self.windows {
            stage.read(&mut out, frames, disc, profile)?;
        }
        Ok(out)
    }

    /// Whether the model's force head gives the signed shear (the card's `shear` of the network
    /// that reads the force: a two-stage model's force network).
    pub fn has_shear(&self) -> bool {
        self.shear
    }

    /// The predictions of `n` inputs made elsewhere (preprocessed for this model, one after
    /// another) by a one-network model; a two-stage model, which reads the frames themselves,
    /// is refused ([`PredictError::Frames`]: give it frames through [`Predictor::predict`]).
    pub fn predict_inputs(
        &mut self,
        input: &[f32],
        n: usize,
    ) -> Result<Vec<Prediction>, PredictError> {
        if !self.windows.is_empty() {
            return Err(PredictError::Frames {
                model: self.path.clone(),
                frames: 0,
                inputs: n,
            });
        }
        self.disc_predictions(input, n)
    }

    /// The whole-disc network's predictions of `n` inputs.
    fn disc_predictions(
        &mut self,
        input: &[f32],
        n: usize,
    ) -> Result<Vec<Prediction>, PredictError> {
        let raw =
            self.disc
                .run(input, n, self.input_size)
                .map_err(|source| PredictError::Inference {
                    model: self.path.clone(),
                    source,
                })?;
        let out = predictions(&raw, &self.classes, self.shear);
        if out.len() != n {
            return Err(PredictError::Outputs {
                model: self.path.clone(),
                got: out.len(),
                want: n,
            });
        }
        Ok(out)
    }
}

impl WindowStage {
    /// Runs the network on the window about each prediction's contact, all windows of the batch
    /// in one run: a force network's reading replaces the force of every prediction in
    /// contact, and a network that reads it moves the contact by the press's offset from the
    /// window's centre. A frame the first network
    /// finds without contact reads no force: by the label rules its force is below the contact
    /// threshold, the force network reads presses only, and the first network's own force head
    /// (trained beside its contact and shape heads) reads about 0.25 N at rest on the layered
    /// sensor (BENCHMARKS.md, "Two-stage models").
    fn read(
        &mut self,
        out: &mut [Prediction],
        frames: &[FrameRef<'_>],
        disc: &Preprocessing,
        profile: Option<&Profile>,
    ) -> Result<(), PredictError> {
        if self.reads_force {
            for p in out.iter_mut().filter(|p| p.contact.is_none()) {
                p.force = ForceVector::from_array([0.0; 7]);
                p.shear = self.shear.then_some([Newtons(0.0); 2]);
            }
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
        if raw.contact.len() != pressed.len() {
            return Err(PredictError::Outputs {
                model: self.path.clone(),
                got: raw.contact.len(),
                want: pressed.len(),
            });
        }
        for ((&i, force), offset) in pressed.iter().zip(&raw.force).zip(&raw.contact) {
            let p = &mut out[i];
            if self.reads_force {
                p.force = ForceVector::from_array(*force);
                p.shear = self
                    .shear
                    .then(|| [Newtons(f64::from(force[0])), Newtons(f64::from(force[1]))]);
            }
            if self.reads_contact {
                let [x, y] = p.contact_raw;
                p.contact_raw = [
                    Millimetres(x.value() + f64::from(offset[0])),
                    Millimetres(y.value() + f64::from(offset[1])),
                ];
                p.contact = Some(p.contact_raw);
            }
        }
        Ok(())
    }
}
