//! Commissioning a sensor unit (`fringe commission`): calibration, presses chosen where the model
//! is weakest, the model adapted to the unit, and acceptance against a spec on held-out presses,
//! kept as a certificate beside the unit's profile.
//!
//! - [`press_choice`]: the usable disc in stage mm and where to press next.
//! - [`press_plan`]: the scan plan of a round or of the acceptance scan.
//! - [`press_errors`]: a round's presses scored by the model before it adapted on them.
//! - [`journal`]: what has been done, for `--resume`.
//! - [`certificate`]: the outcome, and the unit's commissioned model.

pub mod certificate;
pub mod journal;
pub mod press_choice;
pub mod press_errors;
pub mod press_plan;
