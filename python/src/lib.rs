//! `fringe._native`: the Rust half of the `fringe` Python package (python/fringe). Runs are read
//! through fringe's own run reader and frame codecs, frames become network inputs through the one
//! preprocessing, and models run on fringe's inference backend: Python sees what fringe sees.
//!
//! - [`run`]: a run directory (`fringe.Run`): its documents, frames as stored, labels, events,
//!   and network inputs.
//! - [`source`]: a run or a reference-layout dataset read as `fringe train` reads it, and the
//!   inputs it trains on (`fringe.torch.Dataset`), split by press.
//! - [`model`]: a model (`fringe.Model`): opened or chosen as the command line does, run on
//!   frames or inputs.
//! - [`inputs`], [`labels`]: network inputs and training labels as Python gets them, shared by
//!   the above.
//! - [`errors`]: the exceptions Python sees.
//!
//! Long work (decoding, preprocessing, inference) runs with the interpreter released, so the
//! threads of a `DataLoader` worker, or of any Python program, go on meanwhile.

mod errors;
mod inputs;
mod labels;
mod model;
mod run;
mod source;

use pyo3::prelude::*;

#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add_class::<run::Run>()?;
    m.add_class::<model::Model>()?;
    m.add_class::<source::Source>()?;
    m.add_function(wrap_pyfunction!(source::split_sources, m)?)?;
    m.add_function(wrap_pyfunction!(source::expand_inputs, m)?)?;
    m.add("FringeError", py.get_type::<errors::FringeError>())?;
    m.add("RunError", py.get_type::<errors::RunError>())?;
    m.add("FrameError", py.get_type::<errors::FrameError>())?;
    m.add("ModelError", py.get_type::<errors::ModelError>())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add("LAYOUT_VERSION", fringe_rig::store::LAYOUT_VERSION)?;
    Ok(())
}
