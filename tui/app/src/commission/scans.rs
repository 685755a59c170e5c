//! A commissioning under way ([`Commissioning`]) and the one way its scans run: started,
//! resumed from a checkpoint, taken as done, or set aside and pressed again.

use super::host::Host;
use super::journal::{completed, run_state, Journal, RunState, ScanEntry};
use crate::rig::file::RigConfig;
use crate::session::scan::ProfileUse;
use crate::workflow_error::{refuse, Context, WorkflowError};
use fringe_rig::scan::STOPPED_BY_WATCHERS_EVENT;
use fringe_rig::store::ExitStatus;
use fringe_rig::store::RunReader;
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
    /// Keep every round's frames after a pass (`--keep-runs`); else they are pruned.
    pub(crate) keep_runs: bool,
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
    let started = Instant::now();
    let mut target = target;
    let mut resumed_alone = 0;
    loop {
        let program = Plan::parse(&entry.plan, &entry.run_id)?.program(&limits, &entry.run_id)?;
        let end = c
            .host
            .scan(&c.config, program, entry.plan.clone(), target, profile_use)?;
        if end.completed {
            return Ok((end.run_dir, started.elapsed().as_secs_f64()));
        }
        // Unattended, a stop the engine made by itself (a point the watchers kept interrupting:
        // camera drops on a busy machine) is resumed here, a bounded number of times.
        if c.host.unattended()
            && resumed_alone < MAX_UNATTENDED_RESUMES
            && stopped_by_watchers(&end.run_dir)
        {
            resumed_alone += 1;
            c.say(format!(
                "the scan {} stopped ({}); unattended: resuming it ({resumed_alone} of at most {MAX_UNATTENDED_RESUMES})",
                entry.run_id, end.reason
            ));
            target = RunTarget::resume(&end.run_dir)?;
            continue;
        }
        refuse!(
            "the scan {} stopped ({}); resume the commissioning to finish it: fringe commission --resume {}",
            end.run_dir.display(),
            end.reason,
            c.dir.display()
        );
    }
}

/// Times one scan the engine stopped by itself is resumed by an unattended commissioning
/// before it stops for a person.
const MAX_UNATTENDED_RESUMES: usize = 2;

/// Whether the run in `run_dir` was closed, resumable, by the engine itself because the
/// watchers kept interrupting one point (its last session ended with that event).
fn stopped_by_watchers(run_dir: &Path) -> bool {
    if !matches!(run_state(run_dir), Ok(RunState::Ended(s)) if s.exit_status == ExitStatus::Failed)
    {
        return false;
    }
    let Ok(events) = RunReader::at(run_dir).events() else {
        return false;
    };
    let last_session = events
        .iter()
        .rposition(|e| e.kind == "resume-run")
        .unwrap_or(0);
    events[last_session..]
        .iter()
        .any(|e| e.kind == STOPPED_BY_WATCHERS_EVENT)
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

#[cfg(all(test, feature = "sim"))]
mod tests {
    use super::*;
    use crate::commission::host::ScanEnded;
    use crate::commission::journal::Options;
    use crate::workflow_error::BoxError;
    use fringe_rig::store::{now_utc, Event, RunFile, StopDocument};
    use fringe_rig::ScanProgram;

    /// A bench whose scans the engine stops `stops` times (a point the watchers kept
    /// interrupting: the run closed failed with a `stopped-by-watchers` event), then completes.
    struct Stops {
        stops: usize,
        unattended: bool,
        asked: Vec<&'static str>,
    }

    impl Host for Stops {
        fn scan(
            &mut self,
            _config: &RigConfig,
            _program: ScanProgram,
            _plan_text: String,
            target: RunTarget,
            _profile_use: ProfileUse,
        ) -> std::result::Result<ScanEnded, BoxError> {
            let resumed = matches!(target, RunTarget::Resume { .. });
            self.asked.push(if resumed { "resume" } else { "new" });
            let run_dir = target.dir();
            drop(target);
            std::fs::create_dir_all(&run_dir)?;
            let run = RunReader::at(&run_dir);
            std::fs::write(run.path(RunFile::Start), "{}")?;
            std::fs::write(run.path(RunFile::Manifest), "")?;
            let mut events = std::fs::read_to_string(run.path(RunFile::Events)).unwrap_or_default();
            let mut event = |kind: &str, message: &str| -> std::result::Result<(), BoxError> {
                let e = Event {
                    host_ns: 0,
                    utc: now_utc(),
                    kind: kind.into(),
                    point: Some(0),
                    message: message.into(),
                };
                events.push_str(&(serde_json::to_string(&e)? + "\n"));
                Ok(())
            };
            if resumed {
                event("resume-run", "")?;
            }
            let (status, reason) = if self.stops > 0 {
                self.stops -= 1;
                let why = "point 1 was interrupted 3 times in a row by the watchers";
                event(STOPPED_BY_WATCHERS_EVENT, why)?;
                (ExitStatus::Failed, why.to_string())
            } else {
                (ExitStatus::Completed, "all points done".to_string())
            };
            std::fs::write(run.path(RunFile::Events), events)?;
            let stop = StopDocument {
                exit_status: status,
                reason: reason.clone(),
                stopped_utc: now_utc(),
                frames: 0,
                dropped_frames: 0,
                force_samples: 0,
                lost_force_samples: 0,
                points_done: 0,
                sync_method: None,
                sync_error_ns: None,
            };
            std::fs::write(run.path(RunFile::Stop), serde_json::to_string(&stop)?)?;
            Ok(ScanEnded {
                completed: status == ExitStatus::Completed,
                reason,
                run_dir,
            })
        }

        fn say(&mut self, _line: String) {}

        fn notice(&mut self, _line: String) {}

        fn frames(&mut self, _what: &'static str, _done: usize, _total: usize) {}

        fn stop_requested(&mut self) -> bool {
            false
        }

        fn unattended(&self) -> bool {
            self.unattended
        }
    }

    /// Issue 62: unattended, a scan the engine stopped by itself is resumed by the job, at most
    /// twice; attended, or a third time, the job stops with the resume advice.
    #[test]
    fn an_unattended_commissioning_resumes_a_scan_the_watchers_stopped_at_most_twice() {
        let config = RigConfig::parse("[sim]\nimage_scale = 0.25\n", "rig.toml").expect("rig");
        let entry = ScanEntry {
            run_id: "round-1".into(),
            plan: crate::session::plans::COMMISSION.text.to_string(),
            estimate_s: 10.0,
            took_s: None,
            completed: false,
        };
        let attempt = |stops: usize, unattended: bool| {
            let dir = std::env::temp_dir().join(format!(
                "fringe-scan-stops-{}-{stops}-{unattended}",
                std::process::id()
            ));
            let _ = std::fs::remove_dir_all(&dir);
            std::fs::create_dir_all(dir.join("runs")).expect("dir");
            let mut host = Stops {
                stops,
                unattended,
                asked: Vec::new(),
            };
            let result = {
                let mut c = Commissioning {
                    dir: dir.clone(),
                    journal: Journal::new(Options {
                        sensor: "unit-1".into(),
                        base: "builtin:layered-keypoint".into(),
                        budget_min: 10.0,
                        spec: None,
                        spec_origin: "paper".into(),
                        seed: 42,
                        round_presses: 1,
                        acceptance_presses: 1,
                        last_block: false,
                        fine_tune: false,
                        camera: None,
                    }),
                    config: config.clone(),
                    spec: Spec::paper(),
                    host: &mut host,
                    threads: 1,
                    compute_s: 0.0,
                    keep_runs: false,
                };
                scan(&mut c, &entry, ProfileUse::Ignore).map_err(|e| e.to_string())
            };
            let _ = std::fs::remove_dir_all(&dir);
            (result, host.asked)
        };
        let (done, asked) = attempt(2, true);
        assert!(done.is_ok(), "{done:?}");
        assert_eq!(asked, ["new", "resume", "resume"]);
        let (stopped, asked) = attempt(3, true);
        assert_eq!(asked, ["new", "resume", "resume"]);
        let e = stopped.expect_err("a third stop");
        assert!(
            e.contains("interrupted 3 times") && e.contains("fringe commission --resume"),
            "{e}"
        );
        let (stopped, asked) = attempt(1, false);
        assert_eq!(asked, ["new"], "attended: a person resumes it");
        assert!(stopped.is_err());
    }
}
