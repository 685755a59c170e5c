//! `fringe.Run`: a run directory read through fringe's run reader ([`RunReader`]) and decoded by
//! its frame codecs, so Python gets the frames and labels fringe itself reads, bit for bit.

use crate::errors::{run_error, FrameError};
use crate::inputs::{colour_named, inputs_array};
use crate::labels::labels_dict;
use fringe_calibration::Profile;
use fringe_rig::store::{FrameRecord, FrameStorage, RunReader, StartDocument, StoredFrame};
use fringe_rig::{slip_labels, Slip};
use fringe_sensor_models::dataset::{self, Sample};
use fringe_sensor_models::eval::frame_ref;
use fringe_sensor_models::{Preprocessing, Preprocessor};
use numpy::{IntoPyArray, PyArray1, PyArrayDyn, PyArrayMethods};
use pyo3::exceptions::{PyIndexError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::PathBuf;

/// A run, opened: its start document and frame records are read once, its frames when asked.
#[pyclass(module = "fringe._native", frozen)]
pub struct Run {
    reader: RunReader,
    start: StartDocument,
    storage: FrameStorage,
    records: Vec<FrameRecord>,
    profile: Option<Profile>,
    closed: bool,
}

/// Why one frame could not be read: the message names the run, the record and its file.
pub(crate) struct Unreadable(String);

impl Unreadable {
    pub(crate) fn into_py(self) -> PyErr {
        FrameError::new_err(self.0)
    }
}

impl Run {
    pub(crate) fn start(&self) -> &StartDocument {
        &self.start
    }

    pub(crate) fn profile(&self) -> Option<&Profile> {
        self.profile.as_ref()
    }

    /// The record at `index` (negative counts from the end, as Python's do).
    pub(crate) fn record_at(&self, index: isize) -> PyResult<usize> {
        let n = self.records.len() as isize;
        let i = if index < 0 { index + n } else { index };
        if (0..n).contains(&i) {
            Ok(i as usize)
        } else {
            Err(PyIndexError::new_err(format!(
                "frame {index} of {}: the run has {n} frames",
                self.reader.dir().display()
            )))
        }
    }

    /// Every index of `indices` checked (all frames when `None`).
    pub(crate) fn indices(&self, indices: Option<Vec<isize>>) -> PyResult<Vec<usize>> {
        match indices {
            None => Ok((0..self.records.len()).collect()),
            Some(v) => v.into_iter().map(|i| self.record_at(i)).collect(),
        }
    }

    /// The frames fringe trains and evaluates on, by record, with their samples (the label rules
    /// of `fringe train` and `fringe eval`).
    pub(crate) fn samples(&self) -> Vec<(usize, Sample)> {
        let slips = slip_labels(&self.records);
        self.records
            .iter()
            .zip(slips)
            .enumerate()
            .filter_map(|(i, (r, slip))| {
                dataset::from_record(r, &self.start.run_id, self.reader.frame_path(r), None, slip)
                    .map(|s| (i, s))
            })
            .collect()
    }

    /// The stored frame of record `i`, decoded by the run's codec.
    pub(crate) fn stored(&self, i: usize) -> Result<StoredFrame, Unreadable> {
        let r = &self.records[i];
        let named = || {
            format!(
                "{}: frame {} ({})",
                self.reader.dir().display(),
                r.index,
                self.reader.frame_path(r).display()
            )
        };
        match self.reader.stored_frame(&self.storage, r) {
            Ok(Ok(frame)) => Ok(frame),
            Ok(Err(reason)) => Err(Unreadable(format!(
                "{} is {reason}: skip it (on_damaged=\"skip\") or check the run with `fringe runs verify`",
                named()
            ))),
            Err(e) => Err(Unreadable(format!("{}: {e}", named()))),
        }
    }

    /// Reads and preprocesses the frames `indices` with `config` on up to four threads; a frame
    /// that cannot be read is an error, or left out when `skip_damaged`. The inputs (CHW, one
    /// after another), the indices kept, and the frames when `keep_frames`.
    pub(crate) fn prepare(
        &self,
        config: &Preprocessing,
        indices: &[usize],
        skip_damaged: bool,
        keep_frames: bool,
    ) -> Result<Prepared, String> {
        let per = config.tensor_len();
        let workers = std::thread::available_parallelism()
            .map_or(1, |n| n.get().min(4))
            .min(indices.len().max(1));
        let share = indices.len().div_ceil(workers).max(1);
        let parts = std::thread::scope(|scope| {
            let running: Vec<_> = indices
                .chunks(share)
                .map(|chunk| {
                    scope.spawn(move || {
                        let mut pre = Preprocessor::new(config.clone());
                        let mut part = Prepared::default();
                        for &i in chunk {
                            let frame = match self.stored(i) {
                                Ok(f) => f,
                                Err(_) if skip_damaged => continue,
                                Err(Unreadable(m)) => return Err(m),
                            };
                            let start = part.inputs.len();
                            part.inputs.resize(start + per, 0.0);
                            pre.run_into(frame_ref(&frame), 0.0, &mut part.inputs[start..])
                                .map_err(|e| {
                                    format!(
                                        "{}: frame {}: {e}",
                                        self.reader.dir().display(),
                                        self.records[i].index
                                    )
                                })?;
                            part.kept.push(i);
                            if keep_frames {
                                part.frames.push(frame);
                            }
                        }
                        Ok(part)
                    })
                })
                .collect();
            running
                .into_iter()
                .map(|r| r.join().unwrap_or_else(|p| std::panic::resume_unwind(p)))
                .collect::<Result<Vec<Prepared>, String>>()
        })?;
        let mut all = Prepared::default();
        for p in parts {
            all.inputs.extend(p.inputs);
            all.kept.extend(p.kept);
            all.frames.extend(p.frames);
        }
        Ok(all)
    }
}

/// Frames as NumPy arrays.
type Frames<'py> = Vec<Bound<'py, PyArrayDyn<u8>>>;

/// One axis of a wrench.
type Axis = fn(&fringe_rig::Wrench) -> f64;

/// Frames read and preprocessed.
#[derive(Default)]
pub(crate) struct Prepared {
    pub(crate) inputs: Vec<f32>,
    pub(crate) kept: Vec<usize>,
    pub(crate) frames: Vec<StoredFrame>,
}

/// A frame's pixels as NumPy holds them: rows x columns (one channel) or rows x columns x 3.
fn frame_array<'py>(py: Python<'py>, f: StoredFrame) -> PyResult<Bound<'py, PyArrayDyn<u8>>> {
    let channels = f.format.bytes_per_pixel();
    let mut shape = vec![f.height as usize, f.width as usize];
    if channels > 1 {
        shape.push(channels);
    }
    f.data.into_pyarray(py).reshape(shape)
}

/// A column of floats, NaN where the record has none.
fn column<'py>(
    py: Python<'py>,
    records: &[FrameRecord],
    of: impl Fn(&FrameRecord) -> Option<f64>,
) -> Bound<'py, PyArray1<f64>> {
    records
        .iter()
        .map(|r| of(r).unwrap_or(f64::NAN))
        .collect::<Vec<f64>>()
        .into_pyarray(py)
}

#[pymethods]
impl Run {
    /// Opens the run in `path`: its start document (a newer layout than this fringe reads is
    /// refused) and its frame records (a torn last line, a run still being written, is left
    /// out).
    #[new]
    fn new(path: PathBuf) -> PyResult<Self> {
        let reader = RunReader::at(&path);
        let start = reader.start().map_err(run_error)?;
        let records = reader.frames().map_err(run_error)?;
        let profile = dataset::run_profile(&reader, &start).map_err(run_error)?;
        let closed = reader.is_closed();
        Ok(Run {
            storage: start.frame_storage(),
            reader,
            start,
            records,
            profile,
            closed,
        })
    }

    fn __len__(&self) -> usize {
        self.records.len()
    }

    /// The run directory.
    #[getter]
    fn path(&self) -> PathBuf {
        self.reader.dir().to_path_buf()
    }

    /// Whether the run was closed whole (its stop document and manifest written): a run still
    /// being written, or one a crash cut off, is read as far as it was recorded.
    #[getter]
    fn closed(&self) -> bool {
        self.closed
    }

    /// The start document as JSON (plan, rig, sensor, sync method, how frames are stored), with
    /// what fringe reads from it: `frame_storage` (for runs of layout 1 too) and `variant`.
    fn start_json(&self) -> PyResult<String> {
        let mut v = serde_json::to_value(&self.start).map_err(run_error)?;
        if let Some(o) = v.as_object_mut() {
            o.insert(
                "frame_storage".into(),
                serde_json::to_value(self.storage).map_err(run_error)?,
            );
            o.insert(
                "variant".into(),
                serde_json::to_value(self.start.sensor_variant()).map_err(run_error)?,
            );
            o.insert(
                "profile".into(),
                serde_json::to_value(&self.profile).map_err(run_error)?,
            );
        }
        Ok(v.to_string())
    }

    /// The stop document as JSON, or `None` while the run has not ended.
    fn stop_json(&self) -> PyResult<Option<String>> {
        let stop = self.reader.stop().map_err(run_error)?;
        stop.map(|s| serde_json::to_string(&s).map_err(run_error))
            .transpose()
    }

    /// The events as JSON lines' values, one JSON array.
    fn events_json(&self) -> PyResult<String> {
        let events = self.reader.events().map_err(run_error)?;
        serde_json::to_string(&events).map_err(run_error)
    }

    /// Frame `index` as stored: NumPy `uint8`, rows x columns for one-channel formats (Mono8,
    /// the raw BayerRG8 mosaic), rows x columns x 3 for RGB8; a disc-crop run's frames are the
    /// stored cutout. Raises FrameError naming the file when it is missing or damaged.
    fn frame<'py>(&self, py: Python<'py>, index: isize) -> PyResult<Bound<'py, PyArrayDyn<u8>>> {
        let i = self.record_at(index)?;
        let frame = py.detach(|| self.stored(i)).map_err(Unreadable::into_py)?;
        frame_array(py, frame)
    }

    /// Frames `indices` as stored, decoded with the interpreter released; a damaged frame raises
    /// FrameError, or is left out when `skip_damaged`. Returns (frames, indices kept).
    #[pyo3(signature = (indices, skip_damaged = false))]
    fn frames<'py>(
        &self,
        py: Python<'py>,
        indices: Vec<isize>,
        skip_damaged: bool,
    ) -> PyResult<(Frames<'py>, Vec<usize>)> {
        let indices = self.indices(Some(indices))?;
        let read = py.detach(|| {
            let mut out = Vec::with_capacity(indices.len());
            for &i in &indices {
                match self.stored(i) {
                    Ok(f) => out.push((i, f)),
                    Err(_) if skip_damaged => {}
                    Err(e) => return Err(e),
                }
            }
            Ok(out)
        });
        let read = read.map_err(Unreadable::into_py)?;
        let kept = read.iter().map(|(i, _)| *i).collect();
        let frames = read
            .into_iter()
            .map(|(_, f)| frame_array(py, f))
            .collect::<PyResult<Vec<_>>>()?;
        Ok((frames, kept))
    }

    /// One column per label, one row per frame record: as recorded (forces signed, N and N m,
    /// averaged over the frame's exposure; NaN where a record has none).
    fn label_columns<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let r = &self.records;
        let d = PyDict::new(py);
        let u64s = |of: fn(&FrameRecord) -> u64| r.iter().map(of).collect::<Vec<u64>>();
        d.set_item("index", u64s(|r| r.index).into_pyarray(py))?;
        d.set_item("frame_id", u64s(|r| r.frame_id).into_pyarray(py))?;
        d.set_item("point", u64s(|r| r.point).into_pyarray(py))?;
        d.set_item(
            "valid",
            r.iter()
                .map(|r| r.valid)
                .collect::<Vec<bool>>()
                .into_pyarray(py),
        )?;
        let axes: [(&str, Axis); 6] = [
            ("fx", |w| w.fx.0),
            ("fy", |w| w.fy.0),
            ("fz", |w| w.fz.0),
            ("mx", |w| w.tx.0),
            ("my", |w| w.ty.0),
            ("mz", |w| w.tz.0),
        ];
        for (name, of) in axes {
            d.set_item(name, column(py, r, |rec| rec.wrench.as_ref().map(of)))?;
        }
        d.set_item(
            "contact_x_mm",
            column(py, r, |rec| rec.contact.map(|c| c[0])),
        )?;
        d.set_item(
            "contact_y_mm",
            column(py, r, |rec| rec.contact.map(|c| c[1])),
        )?;
        d.set_item(
            "shape",
            r.iter().map(|r| r.shape.clone()).collect::<Vec<String>>(),
        )?;
        d.set_item("shear_x_n", column(py, r, |rec| rec.shear.map(|q| q[0])))?;
        d.set_item("shear_y_n", column(py, r, |rec| rec.shear.map(|q| q[1])))?;
        d.set_item(
            "slip",
            slip_labels(r)
                .into_iter()
                .map(|s| s.map(Slip::name))
                .collect::<Vec<Option<&str>>>(),
        )?;
        d.set_item(
            "exposure_start_ns",
            column(py, r, |rec| rec.exposure.map(|e| e.start_ns)),
        )?;
        d.set_item(
            "exposure_end_ns",
            column(py, r, |rec| rec.exposure.map(|e| e.end_ns)),
        )?;
        d.set_item(
            "exposure_error_ns",
            column(py, r, |rec| rec.exposure.map(|e| e.error_ns)),
        )?;
        d.set_item(
            "exposure_start_tick",
            column(py, r, |rec| rec.exposure_ticks.map(|t| t[0])),
        )?;
        d.set_item(
            "exposure_end_tick",
            column(py, r, |rec| rec.exposure_ticks.map(|t| t[1])),
        )?;
        d.set_item(
            "host_arrival_ns",
            u64s(|r| r.host_arrival_ns).into_pyarray(py),
        )?;
        d.set_item(
            "device_timestamp",
            u64s(|r| r.device_timestamp).into_pyarray(py),
        )?;
        for (name, of) in [
            (
                "commanded_x_mm",
                (|r: &FrameRecord| r.commanded.x.0) as fn(&FrameRecord) -> f64,
            ),
            ("commanded_y_mm", |r| r.commanded.y.0),
            ("commanded_z_mm", |r| r.commanded.z.0),
            ("measured_x_mm", |r| r.measured.x.0),
            ("measured_y_mm", |r| r.measured.y.0),
            ("measured_z_mm", |r| r.measured.z.0),
        ] {
            d.set_item(name, column(py, r, |rec| Some(of(rec))))?;
        }
        d.set_item(
            "file",
            r.iter().map(|r| r.file.clone()).collect::<Vec<String>>(),
        )?;
        d.set_item(
            "notes",
            r.iter()
                .map(|r| r.notes.join("; "))
                .collect::<Vec<String>>(),
        )?;
        Ok(d)
    }

    /// The frames fringe trains and evaluates on, with the labels it trains them to (the label
    /// rules of `fringe train` and `fringe eval`: force magnitudes [Fx Fy Fz Mx My Mz |F|], no
    /// contact under the noise floor), and the press each belongs to (frames of one press never
    /// land on two sides of a split).
    fn training_labels<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let samples = self.samples();
        labels_dict(py, samples.iter().map(|(i, s)| (*i as u64, s)))
    }

    /// What a network sees of frames `indices` (all when `None`): float32, frames x 3 x size x
    /// size, preprocessed by fringe's one preprocessing with this run's calibration profile,
    /// at `size` px in `colour` ("grey" or "rgb"). Returns (inputs, indices kept).
    #[pyo3(signature = (size, colour, indices = None, skip_damaged = false))]
    fn inputs_at<'py>(
        &self,
        py: Python<'py>,
        size: u32,
        colour: &str,
        indices: Option<Vec<isize>>,
        skip_damaged: bool,
    ) -> PyResult<(Bound<'py, PyArrayDyn<f32>>, Vec<usize>)> {
        let profile = self.profile.as_ref().ok_or_else(|| {
            run_error(format!(
                "{}: the run has no calibration profile, so its frames have no optical centre \
                 to crop about: give a model whose card names its preprocessing",
                self.reader.dir().display()
            ))
        })?;
        let config = Preprocessing::from_profile(profile, colour_named(colour)?, size)
            .map_err(|e| PyValueError::new_err(e.to_string()))?;
        let indices = self.indices(indices)?;
        let prepared = py
            .detach(|| self.prepare(&config, &indices, skip_damaged, false))
            .map_err(FrameError::new_err)?;
        inputs_array(py, prepared.inputs, prepared.kept.len(), size).map(|a| (a, prepared.kept))
    }
}
