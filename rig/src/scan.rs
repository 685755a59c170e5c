//! Scans: moving the indenter and pressing under force control.
//!
//! - [`plan`]: scan plans (plan.toml), validation against the bench, point order, estimates.
//! - [`setup`]: what a scan is given besides the devices ([`setup::ScanSetup`]).
//! - [`engine`]: running a scan program on a bench into a run (threads, checkpoints, pause,
//!   resume, abort, crash recovery): the run's lifecycle in `engine.rs`, the recorder's wiring
//!   in `engine/recording.rs`, and the runner of the points in `engine/runner.rs` with its work
//!   in `points.rs`, `no_contact.rs`, `motions.rs` and `indentation.rs` beside it.
//! - [`control`]: pause/resume/abort requests, operator prompts, progress.
//! - [`watchers`]: force ceiling, F/T silence and camera drops, acted on at once.
//! - [`clearance`]: no load at the safe height, at a tare or on a lateral move.
//! - [`offset_check`]: the zero-load check against the sensor's profile, called at every offset
//!   measurement.
//! - [`origin`]: the stage position of the sensor centre, origin of contact labels.
//! - [`panic_stop`]: axes stopped when the thread that moves them panics (the scan's, the
//!   bench's).
//! - [`resume_check`]: what a resume may not change (plan, sync, sensor, camera, geometry).
//! - [`sidecar`]: files a caller adds to a run (the engine never names where they come from).
//! - [`press`]: first contact found by force, closed-loop presses to force targets on the F/T
//!   reading, retract; every step checks the force ceiling and a cancel flag.

pub mod clearance;
pub mod control;
pub mod engine;
pub mod failure;
pub mod offset_check;
pub mod origin;
pub mod panic_stop;
pub mod plan;
pub mod press;
pub(crate) mod resume_check;
pub(crate) mod setup;
pub mod sidecar;
pub mod watchers;
