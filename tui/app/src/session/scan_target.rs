//! Where a scan's run goes (`fringe scan`, `--resume RUN`): a new run under the runs directory,
//! or an unfinished run continued; a run whose close was cut before its manifest is not run
//! again, its manifest is written instead.

use fringe_rig::store::StopDocument;
use fringe_rig::store::{RunWriter, StoreError};
use fringe_rig::{scan::new_run_id, RunTarget};
use std::path::{Path, PathBuf};

/// What a scan does with its run.
pub enum ScanTarget {
    /// Run the plan into this run.
    Run(RunTarget),
    /// The resumed run had ended but was stopped while writing its manifest: the manifest is
    /// now written and the run is whole.
    Closed {
        /// The run.
        run: PathBuf,
        /// How it ended.
        stop: StopDocument,
    },
}

/// The run a scan of the plan named `plan_name` goes to: the run `resume` continues, else a new
/// run under `out`. A resumed run is taken before the rig is opened: while another process
/// writes it, no device opens (a second connection sequence to controllers in the middle of its
/// scan).
pub fn scan_target(
    resume: Option<&Path>,
    out: &Path,
    plan_name: &str,
) -> Result<ScanTarget, StoreError> {
    let Some(dir) = resume else {
        return Ok(ScanTarget::Run(RunTarget::New {
            root: out.to_path_buf(),
            run_id: new_run_id(plan_name),
        }));
    };
    if let Some(stop) = RunWriter::finish_cut_close(dir)? {
        return Ok(ScanTarget::Closed {
            run: dir.to_path_buf(),
            stop,
        });
    }
    Ok(ScanTarget::Run(RunTarget::resume(dir)?))
}
