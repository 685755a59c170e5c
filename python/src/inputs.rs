//! Network inputs as Python gets them: a colour by name, and inputs as a NumPy array (frames x 3 x
//! size x size), shared by runs, training sources and models.

use fringe_sensor_models::Colour;
use numpy::{IntoPyArray, PyArrayDyn, PyArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

/// A colour by name.
pub(crate) fn colour_named(name: &str) -> PyResult<Colour> {
    match name {
        "grey" | "gray" => Ok(Colour::Grey),
        "rgb" => Ok(Colour::Rgb),
        other => Err(PyValueError::new_err(format!(
            "colour {other:?}: give \"grey\" or \"rgb\""
        ))),
    }
}

/// Inputs as NumPy: frames x 3 x size x size.
pub(crate) fn inputs_array(
    py: Python<'_>,
    inputs: Vec<f32>,
    n: usize,
    size: u32,
) -> PyResult<Bound<'_, PyArrayDyn<f32>>> {
    let s = size as usize;
    inputs.into_pyarray(py).reshape(vec![n, 3, s, s])
}
