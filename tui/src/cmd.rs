//! One module per `fringe` subcommand. Each parses its arguments with clap and calls into the
//! engine crates; none holds device or protocol logic of its own.

pub mod arg_values;
pub mod axis;
pub mod calibrate;
pub mod camera;
pub mod demo;
pub mod devices;
pub mod ft;
pub mod limits;
pub mod runs;
pub mod scan;
pub mod selfcheck;
pub mod sim_render;
pub mod sim_serve;
pub mod ystage;
