//! A unit's health over its life: a short check against what it was accepted with (its
//! commissioning certificate), the verdict with its evidence, and the unit's history.
//!
//! - `check_plan`: the check's presses, a fixed subset of the acceptance positions, sized to
//!   the bench time a check may take.
//! - `model_errors`: the model's errors at the check's positions, and at the same positions of
//!   the acceptance scan.
//! - `figures`: every figure compared (optics, light, surface, force zero, the model's errors),
//!   its threshold and the verdict: ok, calibrate again, commission again, or replace the unit.
//! - [`reference`]: which calibration each no-contact figure is compared with (the geometry with
//!   the newest, the light and the surface always with the commissioning's).
//! - `history`: every check appended to `<profiles>/<sensor>.health.jsonl`, read back with
//!   damaged lines reported and passed over.
//! - `check`: the check itself (`fringe check`): the unit's certificate found, its presses
//!   run through a [`crate::commission::host::Host`], every figure compared, the verdict
//!   appended to the history.
//! - `history_plot`: the history as one picture, each figure over the checks' dates.
//! - `check_report`: a check's report, one self-contained HTML page
//!   (`<profiles>/<sensor>.checks/`).
//!
//! The measurements compared (a frame set's optics, light and surface signature) belong to
//! calibration: `fringe_calibration::health`.

pub(crate) mod check;
pub(crate) mod check_plan;
pub(crate) mod check_report;
pub(crate) mod figures;
pub(crate) mod history;
pub(crate) mod history_plot;
pub(crate) mod model_errors;
pub(crate) mod reference;
#[cfg(test)]
mod test_change;

pub use check::{run, unit as unit_to_check, Checked};
pub use check_plan::CheckPlanError;
pub use figures::{assess, Assessment, Figure, Measured, Rule, Thresholds, Verdict};
pub use history::{history_path, read as read_history, Entry, History, HistoryError};
pub use history_plot::{write as write_history_plot, HistoryPlotError};
pub use model_errors::ModelErrors;
