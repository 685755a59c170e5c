//! The units a lab holds, by name: a unit chosen by its id or its file (`--unit FILE|ID`) and
//! put on the rig (the simulated bench carries it; a real rig must hold it), and every unit known
//! with its design, certificate, last check, the next check due and the model `validate` uses
//! for it (`fringe units`, the Units screen).
//!
//! - `unit_ref`: what `--unit` names, a unit's id or one of its files, read to the unit's id.
//! - `on_rig`: the rig with that unit on it, or why not.
//! - `listing`: every unit known under the rig's profiles (and the simulated bench's units), each
//!   with what a person asks of it.
//! - `schedule`: when a unit's next check is due (the policy, [`CHECK_EVERY_DAYS`]).
//! - `error`: why a unit could not be had.

pub(crate) mod error;
pub(crate) mod listing;
pub(crate) mod on_rig;
pub(crate) mod schedule;
pub(crate) mod unit_ref;

pub use error::UnitError;
pub use listing::{list, when, CertificateView, CheckView, UnitView, Units, ValidateModel};
pub use on_rig::carrying;
pub use schedule::{next_check, NextCheck, CHECK_EVERY_DAYS};
pub use unit_ref::UnitRef;
