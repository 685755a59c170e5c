//! `fringe.Model`: a model opened as the command line opens it (a file, `default`,
//! `builtin:NAME`) or chosen for a run as `fringe eval` chooses, run on fringe's inference
//! backend with its card's preprocessing.

use crate::errors::{model_error, FrameError};
use crate::inputs::inputs_array;
use crate::run::Run;
use fringe_app::models::{choose_model, open_model, profiles_dir, ChoiceNote, ForSensor};
use fringe_calibration::Profile;
use fringe_rig::store::StoredFrame;
use fringe_rig::PixelFormat;
use fringe_sensor_models::eval::{frame_ref, BATCH};
use fringe_sensor_models::{BackendKind, Prediction, Predictor, Preprocessing};
use numpy::{IntoPyArray, PyArrayDyn, PyArrayMethods, PyReadonlyArrayDyn, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// A model and its predictor (the network on its backend).
#[pyclass(module = "fringe._native", frozen)]
pub struct Model {
    model: fringe_sensor_models::Model,
    predictor: Mutex<Predictor>,
    /// What opening or choosing it said: the commissioned model taken, warnings.
    notes: Vec<String>,
}

fn note_text(n: ChoiceNote) -> String {
    match n {
        ChoiceNote::Commissioned(s) => s,
        ChoiceNote::Warning(s) => format!("warning: {s}"),
    }
}

impl Model {
    fn ready(
        model: fringe_sensor_models::Model,
        mut notes: Vec<String>,
        backend: &str,
        threads: usize,
    ) -> PyResult<Model> {
        let kind: BackendKind =
            backend
                .parse()
                .map_err(|e: fringe_sensor_models::UnknownBackend| {
                    PyValueError::new_err(e.to_string())
                })?;
        if let Some(w) = model.missing_card_warning() {
            notes.push(format!("warning: {w}"));
        }
        let predictor = Predictor::new(&model, kind, threads.max(1)).map_err(model_error)?;
        Ok(Model {
            model,
            predictor: Mutex::new(predictor),
            notes,
        })
    }

    /// The preprocessing for frames of `profile` (a run's, a given one), else the card's.
    fn preprocessing(&self, profile: Option<&Profile>) -> PyResult<Preprocessing> {
        self.model.preprocessing(profile, None).map_err(model_error)
    }

    /// Runs the network on `n` preprocessed inputs (with their frames for a two-stage model).
    fn run_batches(
        &self,
        inputs: &[f32],
        frames: &[StoredFrame],
        config: &Preprocessing,
        profile: Option<&Profile>,
    ) -> Result<Vec<Prediction>, String> {
        let per = config.tensor_len();
        let n = inputs.len() / per;
        let mut predictor = self.predictor.lock().unwrap_or_else(|p| p.into_inner());
        let needs_frames = predictor.needs_frames();
        let mut out = Vec::with_capacity(n);
        for start in (0..n).step_by(BATCH) {
            let end = (start + BATCH).min(n);
            let refs: Vec<_> = if needs_frames {
                frames[start..end].iter().map(frame_ref).collect()
            } else {
                Vec::new()
            };
            let p = predictor
                .predict(
                    &inputs[start * per..end * per],
                    end - start,
                    &refs,
                    config,
                    profile,
                )
                .map_err(|e| e.to_string())?;
            out.extend(p);
        }
        Ok(out)
    }

    fn predictions<'py>(
        &self,
        py: Python<'py>,
        predicted: Vec<Prediction>,
        index: Option<Vec<usize>>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        let n = predicted.len();
        let col = |of: fn(&Prediction) -> f64| predicted.iter().map(of).collect::<Vec<f64>>();
        d.set_item("fx", col(|p| p.force.fx.0).into_pyarray(py))?;
        d.set_item("fy", col(|p| p.force.fy.0).into_pyarray(py))?;
        d.set_item("fz", col(|p| p.force.fz.0).into_pyarray(py))?;
        d.set_item("mx", col(|p| p.force.mx.0).into_pyarray(py))?;
        d.set_item("my", col(|p| p.force.my.0).into_pyarray(py))?;
        d.set_item("mz", col(|p| p.force.mz.0).into_pyarray(py))?;
        d.set_item("ft", col(|p| p.force.ft.0).into_pyarray(py))?;
        // A model with shear heads: the signed shear in the sensor's frame, as `run.labels()`
        // names it (fx and fy are then the same numbers).
        if self.model.has_shear() {
            let shear = |k: usize| {
                predicted
                    .iter()
                    .map(|p| p.shear.map_or(f64::NAN, |q| q[k].0))
                    .collect::<Vec<f64>>()
            };
            d.set_item("shear_x_n", shear(0).into_pyarray(py))?;
            d.set_item("shear_y_n", shear(1).into_pyarray(py))?;
        }
        d.set_item(
            "contact_x_mm",
            col(|p| p.contact.map_or(f64::NAN, |c| c[0].0)).into_pyarray(py),
        )?;
        d.set_item(
            "contact_y_mm",
            col(|p| p.contact.map_or(f64::NAN, |c| c[1].0)).into_pyarray(py),
        )?;
        d.set_item(
            "contact_raw_x_mm",
            col(|p| p.contact_raw[0].0).into_pyarray(py),
        )?;
        d.set_item(
            "contact_raw_y_mm",
            col(|p| p.contact_raw[1].0).into_pyarray(py),
        )?;
        d.set_item(
            "shape",
            predicted
                .iter()
                .map(|p| p.shape.clone())
                .collect::<Vec<String>>(),
        )?;
        let classes = self.model.classes.len();
        let probabilities: Vec<f64> = predicted
            .iter()
            .flat_map(|p| p.probabilities.iter().map(|(_, v)| *v))
            .collect();
        d.set_item(
            "probabilities",
            probabilities.into_pyarray(py).reshape([n, classes])?,
        )?;
        if let Some(index) = index {
            d.set_item(
                "index",
                index
                    .into_iter()
                    .map(|i| i as u64)
                    .collect::<Vec<u64>>()
                    .into_pyarray(py),
            )?;
        }
        Ok(d)
    }
}

fn pixel_format_named(name: &str) -> PyResult<PixelFormat> {
    fringe_rig::parse_format_name(name).ok_or_else(|| {
        PyValueError::new_err(format!(
            "pixel format {name:?}: give \"rgb8\", \"mono8\" or \"bayerrg8\" (a run's run.pixel_format)"
        ))
    })
}

#[pymethods]
impl Model {
    /// Opens a model as the command line does: a .pth / .pt, .safetensors or .onnx file (its
    /// card beside it or inside it), `default`, or `builtin:NAME`.
    #[new]
    #[pyo3(signature = (name_or_path, backend = "tract", threads = 2))]
    fn new(name_or_path: PathBuf, backend: &str, threads: usize) -> PyResult<Self> {
        let model = open_model(&name_or_path).map_err(model_error)?;
        Model::ready(model, Vec::new(), backend, threads)
    }

    /// The model `fringe eval` runs on `run` without `--model`: its sensor's newest passing
    /// commissioned model under `profiles` (default: the rig file's profiles, as for the
    /// command), else the model that ships for the sensor's design; a model of another design
    /// is refused.
    #[staticmethod]
    #[pyo3(signature = (run, profiles = None, backend = "tract", threads = 2))]
    fn for_run(
        run: &Run,
        profiles: Option<PathBuf>,
        backend: &str,
        threads: usize,
    ) -> PyResult<Self> {
        let mut notes = Vec::new();
        let profiles = match profiles {
            Some(p) => p,
            None => profiles_dir(&mut |n| notes.push(note_text(n))),
        };
        let variant = run.start().sensor_variant();
        let model = choose_model(
            None,
            &ForSensor {
                profiles: &profiles,
                unit: Some(run.start().sensor_id.as_str()),
                variant: variant.as_deref(),
                whose: "the data's sensor",
            },
            &mut |n| notes.push(note_text(n)),
        )
        .map_err(model_error)?;
        Model::ready(model, notes, backend, threads)
    }

    /// What opening or choosing the model said (the commissioned model taken; warnings).
    #[getter]
    fn notes(&self) -> Vec<String> {
        self.notes.clone()
    }

    #[getter]
    fn path(&self) -> PathBuf {
        self.model.path.clone()
    }

    /// The shape classes, in the order of the probabilities ("None" first).
    #[getter]
    fn classes(&self) -> Vec<String> {
        self.model.classes.clone()
    }

    /// The network's input side, px.
    #[getter]
    fn input_size(&self) -> u32 {
        self.model.input_size
    }

    /// "grey" or "rgb".
    #[getter]
    fn colour(&self) -> &'static str {
        self.model.colour.name()
    }

    /// The architecture fringe recognises the network as, if any.
    #[getter]
    fn arch(&self) -> Option<String> {
        self.model.arch.as_ref().map(|a| a.to_string())
    }

    /// The model card as JSON, if the model has one.
    fn card_json(&self) -> PyResult<Option<String>> {
        self.model
            .card
            .as_ref()
            .map(|c| serde_json::to_string(c).map_err(model_error))
            .transpose()
    }

    /// What the model sees of `run`'s frames `indices` (all when `None`): float32, frames x 3
    /// x size x size, preprocessed with the run's calibration profile exactly as `fringe eval`
    /// feeds them. Returns (inputs, indices kept).
    #[pyo3(signature = (run, indices = None, skip_damaged = false))]
    fn inputs_of<'py>(
        &self,
        py: Python<'py>,
        run: &Run,
        indices: Option<Vec<isize>>,
        skip_damaged: bool,
    ) -> PyResult<(Bound<'py, PyArrayDyn<f32>>, Vec<usize>)> {
        let config = self.preprocessing(run.profile())?;
        let indices = run.indices(indices)?;
        let prepared = py
            .detach(|| run.prepare(&config, &indices, skip_damaged, false))
            .map_err(FrameError::new_err)?;
        let n = prepared.kept.len();
        inputs_array(py, prepared.inputs, n, config.input_size).map(|a| (a, prepared.kept))
    }

    /// The model's predictions on `run`'s frames `indices` (all when `None`), preprocessed with
    /// the run's profile: a dict of arrays (fx fy fz mx my mz ft as magnitudes, contact_x_mm
    /// contact_y_mm NaN where no contact is predicted, shape, probabilities, index).
    #[pyo3(signature = (run, indices = None, skip_damaged = false))]
    fn predict_run<'py>(
        &self,
        py: Python<'py>,
        run: &Run,
        indices: Option<Vec<isize>>,
        skip_damaged: bool,
    ) -> PyResult<Bound<'py, PyDict>> {
        self.model
            .check_design(run.start().sensor_variant().as_deref(), "the run's sensor")
            .map_err(model_error)?;
        let config = self.preprocessing(run.profile())?;
        let indices = run.indices(indices)?;
        let (predicted, kept) = py.detach(|| {
            let needs_frames = self.predictor.lock().map_or(true, |p| p.needs_frames());
            let prepared = run
                .prepare(&config, &indices, skip_damaged, needs_frames)
                .map_err(FrameError::new_err)?;
            let predicted = self
                .run_batches(&prepared.inputs, &prepared.frames, &config, run.profile())
                .map_err(model_error)?;
            Ok::<_, PyErr>((predicted, prepared.kept))
        })?;
        self.predictions(py, predicted, Some(kept))
    }

    /// The model's predictions on sensor frames as the camera gives them (rows x columns, or
    /// rows x columns x 3, `uint8`, in `pixel_format`), preprocessed with the calibration
    /// profile in file `profile`, else as the model's card says.
    #[pyo3(signature = (frames, pixel_format = "rgb8", profile = None))]
    fn predict_frames<'py>(
        &self,
        py: Python<'py>,
        frames: Vec<PyReadonlyArrayDyn<'py, u8>>,
        pixel_format: &str,
        profile: Option<PathBuf>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let format = pixel_format_named(pixel_format)?;
        let profile = profile
            .as_deref()
            .map(|p: &Path| Profile::load(p).map_err(model_error))
            .transpose()?;
        let config = self.preprocessing(profile.as_ref())?;
        let mut stored = Vec::with_capacity(frames.len());
        for (k, f) in frames.iter().enumerate() {
            let shape = f.shape();
            let channels = format.bytes_per_pixel();
            let fits = match shape {
                [_, _] => channels == 1,
                [_, _, c] => *c == channels,
                _ => false,
            };
            if !fits {
                return Err(PyValueError::new_err(format!(
                    "frame {k} has shape {shape:?}: a {pixel_format} frame is rows x columns{}",
                    if channels == 1 { "" } else { " x 3" }
                )));
            }
            stored.push(StoredFrame {
                width: shape[1] as u32,
                height: shape[0] as u32,
                format,
                data: f.as_array().iter().copied().collect(),
                cutout: None,
            });
        }
        let predicted = py.detach(|| {
            let mut inputs = vec![0f32; config.tensor_len() * stored.len()];
            for (frame, out) in stored
                .iter()
                .zip(inputs.chunks_exact_mut(config.tensor_len()))
            {
                let tensor = config.run(frame_ref(frame)).map_err(|e| e.to_string())?;
                out.copy_from_slice(&tensor);
            }
            self.run_batches(&inputs, &stored, &config, profile.as_ref())
        });
        let predicted = predicted.map_err(model_error)?;
        self.predictions(py, predicted, None)
    }

    /// The model's predictions on inputs already preprocessed for it (frames x 3 x size x size,
    /// float32, as `inputs_of` gives them), run in batches of eight as `fringe eval` runs them. A two-stage model reads the frames themselves:
    /// give it frames (`predict_frames`) or a run (`predict_run`).
    fn predict_inputs<'py>(
        &self,
        py: Python<'py>,
        inputs: PyReadonlyArrayDyn<'py, f32>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let s = self.model.input_size as usize;
        let shape = inputs.shape().to_vec();
        if shape.len() != 4 || shape[1..] != [3, s, s] {
            return Err(PyValueError::new_err(format!(
                "inputs of shape {shape:?}: this model takes frames x 3 x {s} x {s}"
            )));
        }
        if self.model.force.is_some() || self.model.contact_refiner.is_some() {
            return Err(model_error(format!(
                "{} is a two-stage model: it reads the force from the frames themselves; give it \
                 frames (predict) or a run (predict_run)",
                self.model.path.display()
            )));
        }
        let data: Vec<f32> = inputs.as_array().iter().copied().collect();
        let per = 3 * s * s;
        let predicted = py
            .detach(|| {
                let mut predictor = self.predictor.lock().unwrap_or_else(|p| p.into_inner());
                let mut out = Vec::with_capacity(shape[0]);
                for chunk in data.chunks(BATCH * per) {
                    out.extend(predictor.predict_inputs(chunk, chunk.len() / per)?);
                }
                Ok::<_, fringe_sensor_models::PredictError>(out)
            })
            .map_err(model_error)?;
        self.predictions(py, predicted, None)
    }
}
