//! A source of training data as `fringe train` reads it (`dataset::read`): a run, or a
//! reference-layout dataset (`0.images/` + `0.labels.csv`, as `fringe export` and `fringe sim
//! dataset` write). `fringe.torch.Dataset` makes its inputs here, from the same samples, frame
//! reader, preprocessing and augmentation as `fringe train`, so its inputs are `fringe train`'s.

use crate::errors::{run_error, FrameError};
use crate::inputs::{colour_named, inputs_array};
use crate::labels::labels_dict;
use fringe_rig::store::{RunReader, StoredFrame};
use fringe_sensor_models::dataset::{self, Sample, Source as Samples};
use fringe_sensor_models::eval::{frame_ref, read_frame};
use fringe_sensor_models::expand_inputs as expand_inputs_into;
use fringe_sensor_models::{augmentation, rotate_label, Colour, Pipeline, Preprocessing};
use fringe_sensor_models::{stored_len, stored_planes, InputMaker};
use fringe_sensor_models::{Side, Split, SplitSpec};
use numpy::{IntoPyArray, PyArray1, PyArrayDyn, PyArrayMethods, PyUntypedArrayMethods};
use pyo3::exceptions::{PyIndexError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::PathBuf;

/// Training inputs as kept, 8-bit, as a NumPy array.
type Levels<'py> = Bound<'py, PyArrayDyn<u8>>;

/// Contact labels, frames x 2, as a NumPy array.
type Contacts<'py> = Bound<'py, PyArrayDyn<f64>>;

/// A run or a reference-layout dataset, its labelled frames read as `fringe train` reads them.
#[pyclass(module = "fringe._native", frozen)]
pub struct Source {
    source: Samples,
    /// Each sample's frame: its record's index in a run, its row in a dataset's labels.
    index: Vec<u64>,
}

impl Source {
    /// Sample `k`'s frame, read as `fringe train` reads it.
    fn frame(&self, k: usize) -> Result<StoredFrame, String> {
        read_frame(&self.source.samples[k]).map_err(|e| {
            format!(
                "{}: frame {}: {e}: check the data with `fringe runs verify` (a run) or replace \
                 the file",
                self.source.path.display(),
                self.index[k]
            )
        })
    }
}

#[pymethods]
impl Source {
    /// Opens `path`, a run or a reference-layout dataset, as `fringe train` does.
    #[new]
    fn new(path: PathBuf) -> PyResult<Self> {
        let source = dataset::read(&path).map_err(run_error)?;
        let run = RunReader::at(&path);
        let index = if run.is_run() {
            let start = run.start().map_err(run_error)?;
            let records = run.frames().map_err(run_error)?;
            records
                .iter()
                .enumerate()
                .filter(|(_, r)| {
                    dataset::from_record(r, &start.run_id, PathBuf::new(), None, None).is_some()
                })
                .map(|(i, _)| i as u64)
                .collect::<Vec<u64>>()
        } else {
            (0..source.samples.len() as u64).collect()
        };
        if index.len() != source.samples.len() {
            return Err(run_error(format!(
                "{}: the run changed while it was opened: open it again",
                path.display()
            )));
        }
        Ok(Source { source, index })
    }

    fn __len__(&self) -> usize {
        self.source.samples.len()
    }

    #[getter]
    fn path(&self) -> PathBuf {
        self.source.path.clone()
    }

    #[getter]
    fn sensor_id(&self) -> Option<String> {
        self.source.sensor_id.clone()
    }

    #[getter]
    fn variant(&self) -> Option<String> {
        self.source.variant.clone()
    }

    /// The calibration profile its frames are preprocessed with, as JSON, or `None`.
    fn profile_json(&self) -> PyResult<Option<String>> {
        self.source
            .profile
            .as_ref()
            .map(|p| serde_json::to_string(p).map_err(run_error))
            .transpose()
    }

    /// The labelled frames with the labels `fringe train` trains them to, and their presses;
    /// `index` is each frame's record (a run) or row (a dataset).
    fn training_labels<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        labels_dict(
            py,
            self.index.iter().copied().zip(self.source.samples.iter()),
        )
    }

    /// The inputs `fringe train` trains on, as it keeps them (8-bit grey levels: inputs x
    /// planes x size x size, one plane for grey, three for RGB), and their contact labels.
    /// For each (sample, item, copy) of `wanted` (sample: the position in `training_labels()`):
    /// the frame preprocessed at `size` px, and with a `pipeline` (the paper's offline
    /// augmentation, as `fringe train --pipeline` makes it) turned by the copy's angle about
    /// the optical centre and made noisy, the angle and noise drawn from (`seed`, item, copy)
    /// alone, its contact label turned with it (NaN without contact). Without a pipeline, the
    /// frame as it is in `colour`. A frame wanted for several copies in a row is read once.
    /// Returns (inputs, contacts).
    #[pyo3(signature = (size, pipeline, colour, seed, wanted))]
    fn training_inputs<'py>(
        &self,
        py: Python<'py>,
        size: u32,
        pipeline: Option<&str>,
        colour: &str,
        seed: u64,
        wanted: Vec<(usize, usize, usize)>,
    ) -> PyResult<(Levels<'py>, Contacts<'py>)> {
        let pipeline: Option<Pipeline> = pipeline
            .map(|p| {
                p.parse()
                    .map_err(|e: fringe_sensor_models::UnknownPipeline| {
                        PyValueError::new_err(e.to_string())
                    })
            })
            .transpose()?;
        let colour = pipeline.map_or_else(|| colour_named(colour), |p| Ok(p.colour()))?;
        let path = self.source.path.display();
        let profile = self.source.profile.as_ref().ok_or_else(|| {
            run_error(format!(
                "{path}: no calibration profile (a run recorded without one, or a dataset \
                 without profile.toml), so its frames have no optical centre to crop and turn \
                 about: export it again with `fringe export`, which writes the profile"
            ))
        })?;
        let config = Preprocessing::from_profile(profile, colour, size)
            .map_err(|e| PyValueError::new_err(e.to_string()))?;
        let mirror = profile.registration.as_ref().is_some_and(|r| r.mirror);
        let n = self.source.samples.len();
        if let Some(&(k, _, _)) = wanted.iter().find(|w| w.0 >= n) {
            return Err(PyIndexError::new_err(format!(
                "frame {k} of {path}: it has {n} labelled frames"
            )));
        }
        let per = stored_len(colour, size);
        let noise = pipeline.map_or(0.0, Pipeline::noise_dn);
        let made = py.detach(|| {
            let mut maker = InputMaker::new();
            let mut levels = vec![0u8; per * wanted.len()];
            let mut contacts = Vec::with_capacity(2 * wanted.len());
            let mut read: Option<(usize, StoredFrame)> = None;
            for (&(k, item, copy), out) in wanted.iter().zip(levels.chunks_exact_mut(per)) {
                let frame = match read {
                    Some((at, ref f)) if at == k => f,
                    _ => &read.insert((k, self.frame(k)?)).1,
                };
                let aug = pipeline.map(|_| augmentation(seed, item, copy));
                maker
                    .make(frame_ref(frame), config.clone(), aug, noise, out)
                    .map_err(|e| format!("{path}: frame {}: {e}", self.index[k]))?;
                let angle = aug.map_or(0.0, |a| a.rotation_deg);
                let c = self.source.samples[k]
                    .contact
                    .map(|c| rotate_label(c, angle, mirror))
                    .unwrap_or([f64::NAN; 2]);
                contacts.extend(c);
            }
            Ok::<_, String>((levels, contacts))
        });
        let (levels, contacts) = made.map_err(FrameError::new_err)?;
        let (n, s) = (wanted.len(), size as usize);
        Ok((
            levels
                .into_pyarray(py)
                .reshape(vec![n, stored_planes(colour), s, s])?,
            contacts.into_pyarray(py).reshape(vec![n, 2])?,
        ))
    }
}

/// Training inputs as `fringe train` keeps them (inputs x planes x size x size, 8-bit) as the
/// normalised floats a network takes: inputs x 3 x size x size, grey repeated.
#[pyfunction]
pub fn expand_inputs<'py>(
    py: Python<'py>,
    levels: numpy::PyReadonlyArrayDyn<'py, u8>,
) -> PyResult<Bound<'py, PyArrayDyn<f32>>> {
    let shape = levels.shape().to_vec();
    let (n, planes, size) = match shape[..] {
        [n, p @ (1 | 3), h, w] if h == w => (n, p, h),
        _ => {
            return Err(PyValueError::new_err(format!(
                "inputs of shape {shape:?}: give inputs x planes (1 or 3) x size x size"
            )))
        }
    };
    let colour = if planes == 1 {
        Colour::Grey
    } else {
        Colour::Rgb
    };
    let size = u32::try_from(size).map_err(|e| PyValueError::new_err(e.to_string()))?;
    let levels = levels
        .as_slice()
        .map_err(|e| PyValueError::new_err(e.to_string()))?;
    let out = py.detach(|| {
        let mut out = Vec::new();
        expand_inputs_into(levels, colour, size, &mut out);
        out
    });
    inputs_array(py, out, n, size)
}

/// fringe's split by press over the labelled frames of `sources` (the split of `fringe train`:
/// no press on two sides, each stratum of shape and force level shared by the fractions): for
/// each source, the side of each of its `training_labels()` frames, 0 train, 1 validation, 2
/// test.
#[pyfunction]
#[pyo3(signature = (sources, seed = 42, fractions = (0.8, 0.1, 0.1)))]
pub fn split_sources<'py>(
    py: Python<'py>,
    sources: Vec<PyRef<'py, Source>>,
    seed: u64,
    fractions: (f64, f64, f64),
) -> PyResult<Vec<Bound<'py, PyArray1<u8>>>> {
    let all: Vec<Sample> = sources
        .iter()
        .flat_map(|s| s.source.samples.iter().cloned())
        .collect();
    let spec = SplitSpec {
        seed,
        fractions: [fractions.0, fractions.1, fractions.2],
    };
    let split = Split::new(&all, spec).map_err(|e| PyValueError::new_err(e.to_string()))?;
    Ok(sources
        .iter()
        .map(|source| {
            source
                .source
                .samples
                .iter()
                .map(|s| match split.side_of(&s.press) {
                    Some(Side::Train) => 0,
                    Some(Side::Val) => 1,
                    Some(Side::Test) | None => 2,
                })
                .collect::<Vec<u8>>()
                .into_pyarray(py)
        })
        .collect())
}
