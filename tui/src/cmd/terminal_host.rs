//! The terminal's side of a workflow that runs scans (`fringe commission`, `fringe check`): the
//! [`Host`] of the command line.

use crate::cmd::frames_progress::FramesProgress;
use crate::cmd::scan::execute;
use crate::global::Global;
use fringe_app::commission::{Host, ScanEnded};
use fringe_app::workflow_error::BoxError;
use fringe_app::{ProfileUse, RigConfig};
use fringe_rig::store::ExitStatus;
use fringe_rig::RunTarget;
use fringe_rig::ScanProgram;

/// The terminal's side of a commissioning or a health check: scans run as `fringe scan` runs
/// them (Ctrl-C closes a run resumable, prompts on the terminal unless `--yes`), lines on
/// stdout, progress, warnings and notes on stderr.
pub struct Terminal<'a> {
    global: &'a Global,
    yes: bool,
    progress: Option<(&'static str, FramesProgress)>,
}

impl<'a> Terminal<'a> {
    /// Scans with `global`'s options, every operator prompt answered "continue" when `yes`.
    pub fn new(global: &'a Global, yes: bool) -> Terminal<'a> {
        Terminal {
            global,
            yes,
            progress: None,
        }
    }

    fn end_progress(&mut self) {
        if let Some((_, p)) = self.progress.take() {
            p.finish();
        }
    }
}

impl Host for Terminal<'_> {
    fn scan(
        &mut self,
        config: &RigConfig,
        program: ScanProgram,
        plan_text: String,
        target: RunTarget,
        profile_use: ProfileUse,
    ) -> Result<ScanEnded, BoxError> {
        self.end_progress();
        let end = execute(
            config,
            program,
            plan_text,
            target,
            self.yes,
            profile_use,
            self.global,
            &mut |_| Ok(()),
        )?;
        let o = end.outcome;
        Ok(ScanEnded {
            completed: o.status == ExitStatus::Completed,
            reason: o.reason,
            run_dir: o.run_dir,
        })
    }

    fn say(&mut self, line: String) {
        self.end_progress();
        println!("{line}");
    }

    fn notice(&mut self, line: String) {
        eprintln!("{line}");
    }

    fn stop_requested(&mut self) -> bool {
        crate::signals::catch(
            &[crate::signals::Signal::Interrupt],
            crate::signals::Again::Ends,
        )
        .load(std::sync::atomic::Ordering::SeqCst)
    }

    fn frames(&mut self, what: &'static str, done: usize, total: usize) {
        if self.progress.as_ref().is_some_and(|(w, _)| *w != what) {
            self.end_progress();
        }
        let (_, p) = self
            .progress
            .get_or_insert_with(|| (what, FramesProgress::new(what)));
        p.show(done, total);
        if done >= total {
            self.end_progress();
        }
    }

    fn frames_end(&mut self) {
        self.end_progress();
    }

    fn unattended(&self) -> bool {
        self.yes
    }
}
