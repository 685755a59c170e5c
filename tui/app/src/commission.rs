//! Commissioning a sensor unit (`fringe commission`, the Commission screen): calibration, presses
//! chosen where the model is weakest, the model adapted to the unit, and acceptance against a
//! spec on held-out presses, kept as a certificate beside the unit's profile.
//!
//! The job, step by step:
//! - `job`: a commissioning asked ([`job::Request`]), prepared (its directory and journal,
//!   nothing moves) and run to its verdict; step 1, the calibration.
//! - `scans` (private): a commissioning under way and the one way its scans run (started,
//!   resumed, taken as done, or set aside and pressed again).
//! - `rounds`: steps 2 and 3, rounds of presses where the model is weakest, each scored
//!   before it is adapted on, and the base model's checks.
//! - `last_block`, `fine_tune` (private): step 3's other candidates, the custom CNN's last block
//!   (pure Rust) and every layer (libtorch, the cargo feature `torch`).
//! - `acceptance`: steps 4 and 5, the adapted model written, the acceptance scan judged, the
//!   report and the certificate.
//! - `pruning`: what a passing commissioning keeps (the rounds' frames pruned, their features
//!   kept) unless `--keep-runs`.
//! - `cost`: what a commissioning will take (presses, bench time, computation, disk), told
//!   before anything moves and by `--dry-run`.
//! - `host`: what a commissioning needs from whoever runs it (scans, lines, progress).
//!
//! How they fail: `workflow_error`, beside this module.
//!
//! What they use:
//! - `press_choice`: the usable disc in stage mm and where to press next.
//! - `press_plan`: the scan plan of a round or of the acceptance scan.
//! - `press_errors`: a round's presses scored by the model before it adapted on them.
//! - `journal`: what has been done, for `--resume`.
//! - `certificate`: the outcome, and the unit's commissioned model.

pub(crate) mod acceptance;
pub(crate) mod certificate;
pub(crate) mod cost;
mod fine_tune;
pub(crate) mod host;
pub(crate) mod job;
pub(crate) mod journal;
mod last_block;
pub(crate) mod press_choice;
pub(crate) mod press_errors;
pub(crate) mod press_plan;
mod pruning;
pub(crate) mod rounds;
pub(crate) mod scans;

pub use acceptance::Accepted;
pub use certificate::{
    commissioned_model, unfinished, Certificate, CertificateError, Commissioned, CurvePoint,
    Figures, ModelRef, UsedRuns,
};
pub use cost::{Cost, ScanCost};
pub use host::{Host, ScanEnded};
pub use job::{
    dry_run, prepare, run, NewCommissioning, Prepared, Request, DEFAULT_ACCEPTANCE_PRESSES,
    DEFAULT_ROUND_PRESSES, DEFAULT_SEED,
};
pub use journal::{FrameSettings, Journal, JournalError, Options, ScanEntry};
pub use press_choice::{
    choose as choose_presses, DiscError, PressedPoint, UsableDisc, COVERAGE_MM, LATTICE_MM,
    REACH_FRACTION,
};
pub use press_errors::{round_errors, RoundErrors};
pub use press_plan::PressPlanError;
pub use rounds::DEFAULT_BUDGET_MIN;
