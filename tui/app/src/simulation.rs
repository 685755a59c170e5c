//! The simulator's own jobs, outside a rig (cargo feature `sim`): what `fringe sim ...` runs.
//!
//! - `dataset`: a synthetic training dataset in the reference layout, rendered straight from
//!   the simulator (`fringe sim dataset`).
//! - `render`: one simulated sensor frame written as a PNG (`fringe sim render`).
//! - `demo`: the demonstration's simulated rig and plan, and its end (`fringe demo`).
//! - `selfcheck`: the Net F/T driver against the simulated box on loopback (the self-check of
//!   `fringe` with no command).

pub(crate) mod dataset;
pub(crate) mod demo;
pub(crate) mod render;
pub(crate) mod selfcheck;

pub use dataset::{
    write_dataset, DatasetError, DatasetEvent, DatasetWritten, Rendered as DatasetRendered,
};
pub use demo::{completed as demo_completed, Demo, DemoError};
pub use render::{render_png, RenderError, Rendered};
pub use selfcheck::{netft_selfcheck, SelfCheck, SelfCheckError};
