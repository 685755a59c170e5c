//! The Health screen's side of a unit's checks: the certificate the checks compare with and the
//! unit's history, read from the profiles (`fringe check` makes the checks).

use super::state::HealthView;
use fringe_app::commission::commissioned_model;
use fringe_app::health;
use fringe_app::health::history_path;
use fringe_app::RigConfig;
use std::path::PathBuf;
use std::time::SystemTime;

/// The history file of the rig's sensor, when the rig names one.
pub fn history_file(config: &RigConfig) -> Option<PathBuf> {
    let sensor = config.sensor_id().ok()?;
    Some(history_path(&config.profile_dir(), &sensor))
}

/// When the history file last changed (`None` when there is none).
pub fn changed(path: &std::path::Path) -> Option<SystemTime> {
    std::fs::metadata(path).and_then(|m| m.modified()).ok()
}

/// The screen as the profiles are now: the newest check selected.
pub fn view(config: &RigConfig) -> HealthView {
    let sensor = match config.sensor_id() {
        Ok(s) => s,
        Err(e) => {
            return HealthView {
                sensor: "?".into(),
                certificate: format!("no sensor: {e}"),
                ..HealthView::default()
            }
        }
    };
    let profiles = config.profile_dir();
    let (found, mut notes) = commissioned_model(&profiles, &sensor);
    let certificate = match found {
        Some(c) => format!(
            "{} (issued {}, {})",
            c.dir.display(),
            c.certificate.issued_utc,
            if c.certificate.pass {
                "passed"
            } else {
                "failed"
            }
        ),
        None => format!(
            "none under {}: commission the unit first (fringe commission)",
            profiles.display()
        ),
    };
    let path = history_path(&profiles, &sensor);
    let checks = match health::read_history(&path) {
        Ok(h) => {
            notes.extend(h.notes);
            h.entries
        }
        Err(e) => {
            notes.push(e.to_string());
            Vec::new()
        }
    };
    HealthView {
        sensor,
        certificate,
        history: path.display().to_string(),
        selected: checks.len().saturating_sub(1),
        checks,
        notes,
    }
}
