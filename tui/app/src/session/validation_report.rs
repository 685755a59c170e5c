//! A live validation's report (`fringe validate --report DIR`): the evaluation report
//! (report.md, plots) and every frame validated, one JSON line each (validation.jsonl).

use crate::session::live_validation::Validation;
use fringe_sensor_models::report::ReportError;
use std::io::Write;
use std::path::{Path, PathBuf};

/// The file of every frame validated, in the report's directory.
const FRAMES_FILE: &str = "validation.jsonl";

/// Where a report went.
#[derive(Debug)]
pub struct Written {
    /// The evaluation report (report.md).
    pub report: PathBuf,
    /// Every frame validated (validation.jsonl).
    pub frames: PathBuf,
}

/// A report that could not be written.
#[derive(Debug, thiserror::Error)]
pub enum ValidationReportError {
    #[error(transparent)]
    Report(#[from] ReportError),
    #[error("{}: cannot create", .path.display())]
    Create {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{}: cannot write", .path.display())]
    Write {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
}

/// Writes the evaluation report of validation `v` (of the run in `run_dir`) and every frame
/// validated into `dir`.
pub fn write(dir: &Path, v: &Validation, run_dir: &Path) -> Result<Written, ValidationReportError> {
    let title = format!(
        "Live validation of {} on run {}",
        v.state.model,
        run_dir.display()
    );
    let report = fringe_sensor_models::report::write(dir, &title, &v.evaluation)?;
    let frames = write_frames(dir, v)?;
    Ok(Written { report, frames })
}

/// Every validated frame as one JSON line: ids, label, prediction, latency.
fn write_frames(dir: &Path, v: &Validation) -> Result<PathBuf, ValidationReportError> {
    let path = dir.join(FRAMES_FILE);
    let file = std::fs::File::create(&path).map_err(|source| ValidationReportError::Create {
        path: path.clone(),
        source,
    })?;
    let mut out = std::io::BufWriter::new(file);
    let failed = |source| ValidationReportError::Write {
        path: path.clone(),
        source,
    };
    for f in &v.frames {
        let p = &f.prediction;
        let line = serde_json::json!({
            "frame_id": f.frame_id,
            "record_index": f.record_index,
            "t_s": f.t_s,
            "measured": {
                "fz_n": f.label.fz(),
                "shape": f.label.shape,
                "contact_mm": f.label.contact,
                "stage_mm": f.label.stage_mm,
            },
            "predicted": {
                "fz_n": p.force.fz.value(),
                "shape": p.shape,
                "probability": p.confidence(),
                "contact_mm": p.contact_raw.map(|v| v.value()),
            },
            "latency_ms": f.latency_ms,
            "waited_ms": f.waited_ms,
        });
        writeln!(out, "{line}").map_err(failed)?;
    }
    out.flush().map_err(failed)?;
    Ok(path)
}
