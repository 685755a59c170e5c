//! Work on the opened rig: scans, the rig controlled by hand, and what is shown live.
//!
//! - `scan`: a scan session (profile -> contact origin, operator, progress, truth scoring);
//!   re-exported as `ScanSession`; `truth_score`: how a simulated run's labels match the truth;
//!   [`scan_target`]: the run a scan goes to (new, or resumed).
//! - `calibration_scan`: the calibration scan's built-in grid and contact-finding tuning;
//!   `calibration_images`: the optical part of a profile from a folder of no-contact images.
//! - `plans`: the built-in scan plans, by name, and each one's summary on a rig (`fringe plans`).
//! - `disk_space`: room on disk for a scan: the camera frame a size estimate assumes, a run's
//!   expected size, and the refusal (by the session, before anything moves) of a run that will
//!   not fit. `disc_cutout`: the part of each frame stored when only the disc's square is kept.
//! - `rig_control`: the rig outside a scan: device states, jog, home, stop, tare, the force and
//!   the newest frame; `jog_guard`: which of those motions the force allows.
//! - `live_view`: the newest frame as a small picture and the labels, for displays.
//! - `live_validation`: a trained model run on the frames a scan records, against their labels;
//!   `model_pace`: whether a model keeps up with the camera, said before the rig moves;
//!   `validation_report`: its report (`fringe validate --report DIR`) and every frame
//!   validated.
//! - `worker_failure`: a worker thread's panic caught as text, and one injected for tests.

pub(crate) mod calibration_images;
pub(crate) mod calibration_scan;
pub(crate) mod disc_cutout;
pub(crate) mod disk_space;
pub(crate) mod jog_guard;
pub(crate) mod live_validation;
pub(crate) mod live_view;
pub(crate) mod model_pace;
pub(crate) mod plans;
pub(crate) mod rig_control;
pub(crate) mod scan;
pub(crate) mod scan_target;
pub(crate) mod truth_score;
pub(crate) mod validation_report;
pub(crate) mod worker_failure;

pub use calibration_images::{
    choose_no_contact, fit_disc, image_files, write_profile, CalibrationImagesError,
};
pub use calibration_scan::{
    calibrate_run, calibration_plan, completed as calibration_completed, spot_settings,
    CalibrationGrid, CalibrationPlan, CalibrationPlanError, CalibrationResult, CalibrationRunError,
    Incomplete as CalibrationIncomplete, WrittenProfile, DEFAULT_MAX_FRAMES,
};
pub use disc_cutout::RecordingError;
pub use disk_space::{FrameSize, Recording, RoomError, RoomForecast};
pub use jog_guard::AxisId;
pub use live_validation::{
    CellErrors, FrameSource, FzPoint, Latest, LiveValidation, ValidatedFrame, Validation,
    ValidationState, BACKLOG_FRAMES, THREADS_PER_NETWORK,
};
pub use live_view::{LabelPoint, LiveView, ViewState};
pub use plans::{
    by_name as builtin_plan, read_file as read_plan_file, scan_plan, summaries as plan_summaries,
    BuiltinPlan, PlanFileError, PlanFit, PlanSummary, ScanPlanError, ALL as BUILTIN_PLANS, DEMO,
    SHORT_GRID,
};
pub use rig_control::{
    AxisState, BenchCommand, BenchPhase, BenchSession, BenchState, CameraState, ForcePoint,
    ForceState,
};
pub use scan_target::{scan_target, ScanTarget};
pub use validation_report::{
    write as write_validation_report, ValidationReportError, Written as WrittenValidationReport,
};
pub use worker_failure::{guarded, panic_text};
