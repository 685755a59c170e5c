//! `fringe-app`: what every front end of fringe needs, above the engine crates. The command line
//! and the terminal UI are thin layers over it.
//!
//! The surface, re-exported here:
//! - [`RigConfig`], [`RigSource`]: the rig file, read and checked (or the simulated bench when
//!   there is none); module `rig_file` (private), with the file's sections reached through
//!   [`RigConfig`].
//! - [`OpenRig`], [`RigError`]: opening the devices it describes, real or simulated; modules
//!   `open_rig` and `rig_error` (private), the bench it describes in `rig_bench`, its device
//!   sections as descriptions in `rig_devices`.
//! - The one opener of real devices: [`device_spec`] (what a device is and how it is reached,
//!   from a rig file section or a command's flags), [`device_open`] (opening it), [`host_port`]
//!   (`HOST[:PORT]`, IPv6 included).
//! - [`ScanSession`] and its [`ProfileUse`], [`Note`], [`SessionEnd`], [`SessionError`]: a scan
//!   on the opened rig (profile -> origin, operator, progress, truth scoring); module
//!   `scan_session` (private); [`TruthScore`] in `truth_score` (private).
//!
//! And the public modules (the three above and):
//! - [`bench_session`]: the bench outside a scan: device states, jog, home, stop, tare, the
//!   force and the newest frame.
//! - [`disk_room`]: room on disk for a scan: the camera frame a size estimate assumes, a run's
//!   expected size, and the refusal (by the session, before anything moves) of a run that will
//!   not fit.
//! - [`live_validation`]: a trained model run on the frames a scan records, against their labels.
//! - [`keeping_up`]: whether a model keeps up with the camera, said before the bench moves.
//! - [`live_view`]: the newest frame as a small picture and the labels, for displays.
//! - [`plans`]: the built-in scan plans.
//! - [`calibration_scan`]: the calibration scan's built-in grid and contact-finding tuning.
//! - [`commission`]: commissioning a unit, the whole job (calibration, rounds of presses, the
//!   adaptation, acceptance) with where to press, its plans, its journal and its certificate (and
//!   the unit's commissioned model).
//! - [`models`]: the policies that pick, open and judge models (which model runs, an adapted
//!   model's card, a spec and the verdict against it).
//! - [`health`]: a unit's health check against its certificate: the check's presses, the
//!   figures and their thresholds, the verdict, the unit's history.
//! - [`worker_failure`]: a worker thread's panic caught as text, and one injected for tests.
//! - [`workflow_error`]: how a workflow (commissioning, a health check) fails, its causes kept.
//! - `sim_bench`: the simulated bench behind a rig file (public with the cargo feature `sim`, a
//!   default).
//!
//! Inside this crate, files import from the defining module, never through these re-exports.
#![warn(unreachable_pub)]

pub mod bench_session;
pub mod calibration_scan;
pub mod commission;
pub mod daq_bringup;
pub mod device_open;
pub mod device_spec;
pub mod disk_room;
pub mod health;
pub mod host_port;
pub mod jog_guard;
pub mod keeping_up;
pub mod live_validation;
pub mod live_view;
pub mod models;
mod open_rig;
pub mod plans;
mod recording_part;
mod rig_bench;
mod rig_devices;
mod rig_error;
mod rig_file;
mod scan_session;
#[cfg(feature = "sim")]
pub mod sim_bench;
#[cfg(not(feature = "sim"))]
#[path = "no_sim_bench.rs"]
mod sim_bench;
mod truth_score;
pub mod worker_failure;
pub mod workflow_error;

pub use open_rig::OpenRig;
pub use rig_error::RigError;
pub use rig_file::{RigConfig, RigSource, SensorVariant};
pub use scan_session::{Note, ProfileUse, ScanSession, SessionEnd, SessionError};
pub use truth_score::TruthScore;
