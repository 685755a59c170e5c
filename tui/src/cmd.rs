//! One module per `fringe` subcommand. Each parses its arguments with clap and calls into the
//! engine crates; none holds device or protocol logic of its own.

pub mod adapt;
pub mod arg_values;
pub mod axis;
pub mod calibrate;
pub mod camera;
pub mod check;
pub mod commission;
pub mod daq;
#[cfg(feature = "sim")]
pub mod demo;
pub mod devices;
pub mod eval;
pub mod frames_progress;
pub mod ft;
pub mod limits;
pub mod model;
pub mod plans;
pub mod runs;
pub mod scan;
#[cfg(feature = "sim")]
pub mod selfcheck;
#[cfg(feature = "sim")]
pub mod sim_dataset;
#[cfg(feature = "sim")]
pub mod sim_render;
#[cfg(feature = "sim")]
pub mod sim_serve;
pub mod stream;
pub mod terminal_host;
pub mod terminal_prompt;
pub mod train;
pub mod unit_arg;
pub mod units;
pub mod validate;
pub mod ystage;
