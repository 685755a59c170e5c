//! What a commissioning (and a health check) needs from whoever runs it, the terminal (`fringe
//! commission`, `fringe check`) or the Commission screen: its scans run on the bench, its lines
//! and progress shown, each round's learning shown as it comes.

use super::certificate::CurvePoint;
use super::press_choice::{PressedPoint, UsableDisc};
use crate::rig::file::RigConfig;
use crate::session::scan::ProfileUse;
use crate::workflow_error::BoxError;
use fringe_rig::RunTarget;
use fringe_rig::ScanProgram;
use std::path::PathBuf;

/// How a scan the host ran ended.
pub struct ScanEnded {
    pub completed: bool,
    /// Why it stopped, when it did not complete.
    pub reason: String,
    pub run_dir: PathBuf,
}

/// The side of a commissioning that meets the operator.
pub trait Host {
    /// Runs `program` on the rig into `target` (a new run or one resumed from its checkpoint)
    /// and waits for its end. An error when it could not run at all.
    fn scan(
        &mut self,
        config: &RigConfig,
        program: ScanProgram,
        plan_text: String,
        target: RunTarget,
        profile_use: ProfileUse,
    ) -> Result<ScanEnded, BoxError>;

    /// A line of what the commissioning does or found.
    fn say(&mut self, line: String);

    /// A warning or a note beside the lines (on the terminal: stderr), as shown
    /// (`warning: ...`, `note: ...`).
    fn notice(&mut self, line: String);

    /// `done` of `total` frames of `what` (features read, frames evaluated); `done == total` ends it.
    fn frames(&mut self, what: &'static str, done: usize, total: usize);

    /// The frames shown last are done with (a computation ended): their progress ends.
    fn frames_end(&mut self) {}

    /// Whether the operator asked to stop (Ctrl-C, the screen's `s`): asked between batches of
    /// a computation that can stop with a checkpoint (only full fine-tuning, in `torch` builds).
    fn stop_requested(&mut self) -> bool;

    /// Whether the scans' operator prompts are answered without a person (`--yes`): then a scan
    /// the engine stopped by itself (a point the watchers kept interrupting) is resumed by the
    /// job, a bounded number of times, instead of waiting for someone to resume it.
    fn unattended(&self) -> bool {
        false
    }

    /// A round was scored and learnt from: the learning curve and every press so far with its
    /// error, on the usable disc.
    fn learnt(&mut self, _curve: &[CurvePoint], _pressed: &[PressedPoint], _disc: &UsableDisc) {}
}
