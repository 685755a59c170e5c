//! The plots of fringe's reports, drawn in one place: calibration (registration residuals, the
//! contact overlay), evaluation (predicted against measured Fz, contact errors, the confusion
//! matrix, training losses), commissioning (learning curve, press map) and health (each figure
//! over the checks). The domain code builds the data; this crate draws it with
//! [plotters](https://docs.rs/plotters) into an [`image::RgbImage`] (the caller writes the PNG).
//!
//! Every chart has a title, axes labelled with their units, ticks at round values and a legend
//! when it shows more than one named series. Text is set in DejaVu Sans, embedded in the binary
//! (`fonts/`, its licence beside it), so no font is looked up on the system.
//!
//! Everything is re-exported here except the colours, which keep their module as a namespace
//! ([`palette`]: `palette::BLUE`, `palette::SERIES`), and the self-contained HTML page the
//! reports embed their plots in ([`html`]: `html::Page`, `html::escape`).

#![warn(unreachable_pub)]
#![warn(unnameable_types)]

mod canvas;
mod error;
mod font;
pub mod html;
mod matrix;
mod overlay;
pub mod palette;
mod panels;
mod ticks;
mod xy;

pub use error::PlotError;
pub use matrix::Matrix;
pub use overlay::{overlay, Mark};
pub use palette::Colour;
pub use panels::panels;
pub use xy::{Axis, Chart, Corner, Series};
