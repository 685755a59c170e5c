//! The labels `fringe train` trains a frame to, as the dict `training_labels()` gives (one array
//! per label, one row per labelled frame): shared by `fringe.Run` and the training sources.

use fringe_sensor_models::dataset::Sample;
use numpy::{IntoPyArray, PyArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// The dict of `training_labels()` from each sample with its frame index.
pub(crate) fn labels_dict<'py, 'a>(
    py: Python<'py>,
    samples: impl Iterator<Item = (u64, &'a Sample)>,
) -> PyResult<Bound<'py, PyDict>> {
    let mut index = Vec::new();
    let mut force = Vec::new();
    let mut contact = Vec::new();
    let mut stage = Vec::new();
    let mut shape = Vec::new();
    let mut press = Vec::new();
    let mut shear = Vec::new();
    let mut slip = Vec::new();
    for (i, s) in samples {
        shear.extend(s.shear.unwrap_or([f64::NAN; 2]));
        slip.push(s.slip.map(|s| s.name()));
        index.push(i);
        force.extend(s.force);
        contact.extend(s.contact.unwrap_or([f64::NAN; 2]));
        stage.extend(s.stage_mm.unwrap_or([f64::NAN; 2]));
        shape.push(s.shape.clone());
        press.push(s.press.clone());
    }
    let n = index.len();
    let d = PyDict::new(py);
    d.set_item("index", index.into_pyarray(py))?;
    d.set_item("force", force.into_pyarray(py).reshape([n, 7])?)?;
    d.set_item("contact_mm", contact.into_pyarray(py).reshape([n, 2])?)?;
    d.set_item("stage_mm", stage.into_pyarray(py).reshape([n, 2])?)?;
    d.set_item("shape", shape)?;
    d.set_item("press", press)?;
    d.set_item("shear_n", shear.into_pyarray(py).reshape([n, 2])?)?;
    d.set_item("slip", slip)?;
    Ok(d)
}
