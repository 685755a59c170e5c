//! `fringe-app`: what every front end of fringe needs, above the engine crates. The command line
//! and the terminal UI are thin layers over it. Its modules are concepts:
//!
//! - [`rig`]: the device door. The rig file read and checked, the rig it describes opened (real
//!   drivers, or the simulated rig under the cargo feature `sim`), and the one opener of real
//!   devices that the rig and the bring-up commands share (`rig::force` for every F/T interface).
//! - [`bringup`]: the bring-up commands' workflows on one device (`fringe ft`, `daq`, ...).
//! - [`session`]: work on the opened rig: scan sessions, the calibration scan, the built-in plans,
//!   the rig controlled by hand outside a scan, live view and live validation, room on disk.
//! - [`commission`]: commissioning a unit, the whole job (calibration, rounds of presses, the
//!   adaptation, acceptance), with where to press, its plans, its journal and its certificate
//!   (and the unit's commissioned model).
//! - `simulation`: the simulator's own jobs outside a rig (`fringe sim dataset`; cargo feature
//!   `sim`).
//! - [`health`]: a unit's health check against its certificate: the check's presses, the
//!   figures and their thresholds, the verdict, the unit's history.
//! - [`models`]: the policies that pick, open and judge models (which model runs, an adapted
//!   model's card, the data a model is judged on, a spec and the verdict against it; training,
//!   a two-stage model joined, an ONNX export, a model run on images).
//! - [`runs`]: the run store's jobs as a person sees them (the runs in a directory).
//! - [`stream`]: a unit off the bench: the camera and the unit's model only, each frame's
//!   prediction published as ROS 2 messages over Zenoh and recorded to MCAP (`fringe stream`).
//! - [`units`]: the units a lab holds, by name: a unit chosen by its id or file and put on the
//!   rig, and every unit known with its certificate, last check, next check and model.
//! - [`workflow_error`]: how a workflow (commissioning, a health check) fails, its causes kept.
//!
//! The surface: the concept modules above are public namespaces, each a curated `pub use` list
//! of what other crates use (`fringe_app::session::ValidationState`,
//! `fringe_app::commission::Journal`) and of every type its functions hand out; the files inside
//! them are private, so no public path is deeper than one level. Where a file's name said what a
//! bare item does, the namespace re-exports it by a clearer name (`health::read_history`,
//! `session::write_validation_report`, `models::export_onnx`, `bringup::bias_daq` and
//! `bringup::bias_netft`). At the root: [`RigConfig`], [`RigSource`], [`SensorVariant`] (the rig
//! file, `rig::file`), [`OpenRig`] (`rig::open`), [`RigError`] (`rig::error`), [`ScanSession`]
//! and its [`ProfileUse`], [`Note`], [`SessionEnd`], [`SessionError`] (`session::scan`),
//! [`TruthScore`] (`session::truth_score`).
//!
//! Inside this crate, files import from the defining module, never through these re-exports.
#![warn(unreachable_pub)]
#![warn(unnameable_types)]

pub mod bringup;
pub mod commission;
pub mod health;
pub mod models;
pub mod rig;
pub mod runs;
pub mod session;
#[cfg(feature = "sim")]
pub mod simulation;
pub mod stream;
pub mod units;
pub mod workflow_error;

pub use rig::error::RigError;
pub use rig::file::{RigConfig, RigSource, SensorVariant};
pub use rig::open::OpenRig;
pub use session::scan::{Note, ProfileUse, ScanSession, SessionEnd, SessionError};
pub use session::truth_score::TruthScore;
