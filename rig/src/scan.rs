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
//! - [`silence`]: the F/T stream's silence as a watching thread can vouch for it (a pause of the
//!   host is not the sensor going quiet).
//! - [`clearance`]: no load at the safe height, at a tare or on a lateral move.
//! - [`offset_check`]: the zero-load check against the sensor's profile, called at every offset
//!   measurement.
//! - [`origin`]: the stage position of the sensor centre, origin of contact labels.
//! - [`panic_stop`]: axes stopped when the thread that moves them panics (the scan's, the
//!   bench's).
//! - [`resume_check`]: what a resume may not change (plan, sync, sensor, camera, geometry).
//! - [`sidecar`]: files a caller adds to a run (the engine never names where they come from).
//! - [`slide`]: slides after a press (directions, distance, speeds), and how the stage axes
//!   share one straight trapezoid.
//! - [`press`]: first contact found by force, closed-loop presses to force targets on the F/T
//!   reading, retract; every step checks the force ceiling and a cancel flag.

pub(crate) mod clearance;
pub(crate) mod control;
pub(crate) mod engine;
pub(crate) mod failure;
pub(crate) mod offset_check;
pub(crate) mod origin;
pub(crate) mod panic_stop;
pub(crate) mod plan;
pub(crate) mod press;
pub(crate) mod resume_check;
pub(crate) mod setup;
pub(crate) mod sidecar;
pub(crate) mod silence;
pub(crate) mod slide;
pub(crate) mod watchers;

pub use clearance::{Clearance, Motion, UnderLoad, LOAD_SAMPLES};
pub use control::{Phase, Request, ScanProgress, Status};
pub use engine::new_run_id;
pub use engine::recording::{labeler_for, LATCH_PERIOD};
pub use offset_check::OffsetCheck;
pub use panic_stop::stop_if_panicking;
pub use plan::{
    ApproachSection, Axis1d, Estimate, FtRating, GridSection, IndentationSection, IndenterSection,
    Order, SafetySection, ScanPoint, Targets,
};
pub use press::{approach, press_to, retract, ForceGuard, PressError, PressPoint, PressSettings};
pub use sidecar::RunSidecar;
pub use slide::{Direction, Slide, SlideMotion, SlideSection};
pub use watchers::{WatchSettings, REPRESS_EVENT, STOPPED_BY_WATCHERS_EVENT};
