//! What `--unit FILE|ID` names. An id (`layered-2`), or a file of the unit that a person would
//! point at: its calibration profile (`<profiles>/<id>.toml`), a commissioning's certificate
//! (`certificate.json`) or its directory (`<id>.commission-*`), its health history
//! (`<id>.health.jsonl`), or, for the simulated bench, a simulator's sensor file
//! (`rig/sim/sensors/<id>.toml`, which the bench then carries).

use crate::commission::certificate::{Certificate, CERTIFICATE};
use crate::health::history;
use crate::rig::simulated;
use crate::units::error::UnitError;
use fringe_calibration::Profile;
use std::path::{Path, PathBuf};

/// A unit as named.
#[derive(Debug, Clone, PartialEq)]
pub struct UnitRef {
    pub id: String,
    /// Its design when the file said it.
    pub design: Option<String>,
    /// A simulator's sensor file that builds it (the simulated bench carries that build).
    pub sim_sensor: Option<PathBuf>,
    /// The file it was named by.
    pub file: Option<PathBuf>,
}

impl UnitRef {
    /// Reads `given`: an existing file or directory is read for its unit, anything else is an id.
    pub fn parse(given: &str) -> Result<UnitRef, UnitError> {
        let path = Path::new(given);
        if path.exists() {
            return from_file(path);
        }
        let looks_like_file = given.contains(std::path::MAIN_SEPARATOR)
            || given.contains('/')
            || [".toml", ".json", ".jsonl"]
                .iter()
                .any(|e| given.ends_with(e));
        if looks_like_file {
            return Err(UnitError::File {
                path: path.to_path_buf(),
                message: "no such file".into(),
            });
        }
        let ok = !given.is_empty()
            && !given.starts_with('.')
            && given
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '.'));
        if !ok {
            return Err(UnitError::BadId(given.into()));
        }
        Ok(UnitRef {
            id: given.into(),
            design: None,
            sim_sensor: None,
            file: None,
        })
    }
}

/// The unit a file or directory belongs to.
fn from_file(path: &Path) -> Result<UnitRef, UnitError> {
    let err = |message: String| UnitError::File {
        path: path.to_path_buf(),
        message,
    };
    let named = |id: String, design: Option<String>| UnitRef {
        id,
        design,
        sim_sensor: None,
        file: Some(path.to_path_buf()),
    };
    let name = path
        .file_name()
        .and_then(|n| n.to_str())
        .unwrap_or_default()
        .to_string();
    if path.is_dir() || name == CERTIFICATE {
        let dir = if path.is_dir() {
            path
        } else {
            path.parent().unwrap_or(Path::new("."))
        };
        if !dir.join(CERTIFICATE).is_file() {
            return Err(err(format!(
                "no {CERTIFICATE} in it: a unit's directory is one of its commissionings (<profiles>/<unit>.commission-*)"
            )));
        }
        let c = Certificate::read(dir).map_err(|e| err(e.to_string()))?;
        return Ok(named(c.sensor_id, c.variant));
    }
    if let Some(stem) = name.strip_suffix(".health.jsonl") {
        let h = history::read(path).map_err(|e| err(e.message))?;
        let id = h
            .entries
            .first()
            .map(|e| e.sensor_id.clone())
            .unwrap_or_else(|| stem.to_string());
        return Ok(named(id, None));
    }
    if name.ends_with(".toml") {
        if let Ok(p) = Profile::load(path) {
            return Ok(named(p.sensor_id, None));
        }
        if let Some((id, design)) = simulated::sensor_file(path) {
            return Ok(UnitRef {
                id,
                design: Some(design.to_string()),
                sim_sensor: Some(path.to_path_buf()),
                file: Some(path.to_path_buf()),
            });
        }
        return Err(err(
            "neither a calibration profile nor a simulator's sensor file".into(),
        ));
    }
    Err(err(
        "not a unit's file: give its calibration profile (<profiles>/<unit>.toml), a certificate.json or its commissioning directory, its health history (<unit>.health.jsonl), or a simulator's sensor file"
            .into(),
    ))
}
