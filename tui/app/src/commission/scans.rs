//! A commissioning under way ([`Commissioning`]) and the one way its scans run: started,
//! resumed from a checkpoint, taken as done, or set aside and pressed again.

use super::host::Host;
use super::journal::{completed, run_state, Journal, RunState, ScanEntry};
use crate::rig::file::RigConfig;
use crate::session::scan::ProfileUse;
use crate::workflow_error::{refuse, Context, WorkflowError};
use fringe_rig::store::ExitStatus;
use fringe_rig::Plan;
use fringe_rig::RunTarget;
use fringe_sensor_models::Spec;
use std::path::{Path, PathBuf};
use std::time::Instant;

type Result<T> = std::result::Result<T, WorkflowError>;

/// A commissioning under way: where it lives and what it was asked.
pub(crate) struct Commissioning<'a> {
    pub(crate) dir: PathBuf,
    pub(crate) journal: Journal,
    pub(crate) config: RigConfig,
    pub(crate) spec: Spec,
    /// Who runs the scans and hears what happens.
    pub(crate) host: &'a mut dyn Host,
    pub(crate) threads: usize,
    /// Computation time so far (features, fits, evaluation), s.
    pub(crate) compute_s: f64,
}

impl Commissioning<'_> {
    /// Tells the operator `line`.
    pub(crate) fn say(&mut self, line: String) {
        self.host.say(line);
    }
}

/// The bench time `plan` is estimated to take on the rig, s.
pub(crate) fn estimate_s(plan: &str, config: &RigConfig) -> Result<f64> {
    let limits = config.limits()?;
    let program =
        Plan::parse(plan, "commissioning plan")?.program(&limits, "commissioning plan")?;
    Ok(program.estimate(&limits).total.as_secs_f64())
}

/// Runs (or resumes, or takes as done) the scan of `entry` into the directory's `runs/`; its
/// run directory and the bench time it took now, s. An error unless it completed.
pub(crate) fn scan(
    c: &mut Commissioning<'_>,
    entry: &ScanEntry,
    profile_use: ProfileUse,
) -> Result<(PathBuf, f64)> {
    let root = c.dir.join("runs");
    let run_dir = root.join(&entry.run_id);
    let state = run_state(&run_dir)?;
    if completed(&state) {
        return Ok((run_dir, 0.0));
    }
    let target = match state {
        RunState::Absent => RunTarget::New {
            root,
            run_id: entry.run_id.clone(),
        },
        RunState::Unfinished => {
            if let Some(stop) = fringe_rig::store::RunWriter::finish_cut_close(&run_dir)? {
                if stop.exit_status == ExitStatus::Completed {
                    return Ok((run_dir, 0.0));
                }
            }
            // Taken before the rig is opened: beside another writer, no device opens.
            let target = RunTarget::resume(&run_dir)?;
            c.say(format!("resuming the run {}", run_dir.display()));
            target
        }
        // Closed failed (interrupted, a device error): resumed from its checkpoint.
        RunState::Ended(stop) if stop.exit_status == ExitStatus::Failed => {
            let target = RunTarget::resume(&run_dir)?;
            c.say(format!(
                "resuming the run {} ({})",
                run_dir.display(),
                stop.reason
            ));
            target
        }
        // Aborted by the operator: kept aside, pressed again.
        RunState::Ended(stop) => {
            let kept = set_aside(&run_dir)?;
            c.say(format!(
                "the scan {} ended {} ({}); it is kept as {} and pressed again",
                entry.run_id,
                format!("{:?}", stop.exit_status).to_lowercase(),
                stop.reason,
                kept.display()
            ));
            RunTarget::New {
                root,
                run_id: entry.run_id.clone(),
            }
        }
    };
    let limits = c.config.limits()?;
    let program = Plan::parse(&entry.plan, &entry.run_id)?.program(&limits, &entry.run_id)?;
    let started = Instant::now();
    let end = c
        .host
        .scan(&c.config, program, entry.plan.clone(), target, profile_use)?;
    if !end.completed {
        refuse!(
            "the scan {} stopped ({}); resume the commissioning to finish it: fringe commission --resume {}",
            end.run_dir.display(),
            end.reason,
            c.dir.display()
        );
    }
    Ok((end.run_dir, started.elapsed().as_secs_f64()))
}

/// Moves a run that ended without completing out of the way (`<run>.stopped-N`), kept whole.
pub(crate) fn set_aside(run_dir: &Path) -> Result<PathBuf> {
    for n in 1..1000 {
        let to = run_dir.with_extension(format!("stopped-{n}"));
        if !to.exists() {
            std::fs::rename(run_dir, &to)
                .with_context(|| format!("cannot move {} aside", run_dir.display()))?;
            return Ok(to);
        }
    }
    refuse!("{}: too many stopped runs beside it", run_dir.display())
}
