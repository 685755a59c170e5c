//! `fringe-app`: what every front end of fringe needs, above the engine crates. The command line
//! and the terminal UI are thin layers over it.
//!
//! - [`plans`]: the built-in scan plans.
//! - [`rig_file`]: the rig file, read and checked (or the simulated bench when there is none).
//! - [`calibration_scan`]: the calibration scan's built-in grid and contact-finding tuning.
//! - [`open_rig`]: opening the devices it describes, real or simulated.
//! - [`scan_session`]: a scan on the opened rig: profile -> origin, operator, progress, truth
//!   scoring.
//! - [`sim_bench`]: the simulated bench behind a rig file (cargo feature `sim`, a default).
#![warn(unreachable_pub)]

pub mod calibration_scan;
pub mod open_rig;
pub mod plans;
pub mod rig_file;
pub mod scan_session;
#[cfg(feature = "sim")]
pub mod sim_bench;
#[cfg(not(feature = "sim"))]
#[path = "no_sim_bench.rs"]
mod sim_bench;

pub use open_rig::{OpenRig, RigError};
pub use rig_file::{RigConfig, RigSource};
pub use scan_session::{Note, ProfileUse, ScanSession, SessionEnd, SessionError, TruthScore};
