//! A spec given on the command line (`--spec FILE`, or `paper` for the paper's custom-CNN row)
//! and the verdict of an evaluation against it, as printed.

use fringe_sensor_models::{Spec, SpecError, Verdict};
use std::path::Path;

/// The name that stands for the paper's row instead of a file.
pub const PAPER: &str = "paper";

/// `paper` or a spec file.
pub fn load(spec: &Path) -> Result<Spec, SpecError> {
    if spec == Path::new(PAPER) {
        return Ok(Spec::paper());
    }
    Spec::load(spec)
}

/// Groups that miss a threshold shown under a failing verdict.
const WEAK_SHOWN: usize = 8;

/// The verdict's lines: every check, then where a failing model is weakest.
pub fn lines(v: &Verdict) -> Vec<String> {
    let mut out = vec![format!(
        "verdict:        {}",
        if v.pass { "PASS" } else { "FAIL" }
    )];
    for c in &v.checks {
        out.push(format!(
            "  {} {}",
            if c.pass { "ok  " } else { "FAIL" },
            c.describe()
        ));
    }
    if !v.pass && !v.weak.is_empty() {
        out.push("  weakest:".to_string());
        for w in v.weak.iter().take(WEAK_SHOWN) {
            out.push(format!(
                "    {}: {} {:.4} (limit {:.4}, {} frames)",
                w.group, w.figure, w.value, w.limit, w.frames
            ));
        }
        if v.weak.len() > WEAK_SHOWN {
            out.push(format!("    ... and {} more", v.weak.len() - WEAK_SHOWN));
        }
    }
    out
}
