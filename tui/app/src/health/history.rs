//! A unit's health history: one JSON line per check in `<profiles>/<sensor>.health.jsonl`,
//! beside its profile. Entries are only ever appended (a line written whole with one write and
//! synced); a damaged line (a torn write, an edit) is reported with its line number and passed
//! over when reading, and new entries are still appended after it: nothing is lost.

use crate::health::figures::{Assessment, Verdict};
use crate::health::model_errors::ModelErrors;
use std::io::Write as _;
use std::path::{Path, PathBuf};

/// Format of the entries this version writes; older ones are read, newer ones passed over with a
/// note.
pub(crate) const HISTORY_FORMAT: u32 = 1;

/// The history file of `sensor` in the profile directory `profiles`.
pub fn history_path(profiles: &Path, sensor: &str) -> PathBuf {
    profiles.join(format!("{sensor}.health.jsonl"))
}

/// One check.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Entry {
    pub format: u32,
    pub fringe_version: String,
    pub checked_utc: String,
    pub sensor_id: String,
    /// The commissioning the unit was compared with (its directory).
    pub certificate: String,
    /// The check's run.
    pub run: String,
    /// Bench time the check took, s.
    pub bench_s: f64,
    pub assessment: Assessment,
    #[serde(default)]
    pub model_now: Option<ModelErrors>,
    #[serde(default)]
    pub model_then: Option<ModelErrors>,
}

impl Entry {
    pub fn verdict(&self) -> Verdict {
        self.assessment.verdict
    }

    /// The value of figure `key`, if this check measured it.
    pub fn figure(&self, key: &str) -> Option<f64> {
        self.assessment
            .figures
            .iter()
            .find(|f| f.key == key)
            .map(|f| f.value)
    }
}

/// A history that cannot be appended to.
#[derive(Debug, thiserror::Error)]
#[error("{path}: {message}")]
pub struct HistoryError {
    pub path: PathBuf,
    pub message: String,
}

/// Appends `entry` to the history at `path` (made when missing), whole or not at all: one write
/// of the line, then a sync. A file whose last line was torn gets a line break first, so the new
/// entry stays readable.
pub(crate) fn append(path: &Path, entry: &Entry) -> Result<(), HistoryError> {
    let err = |message: String| HistoryError {
        path: path.to_path_buf(),
        message,
    };
    let mut line = serde_json::to_string(entry).map_err(|e| err(e.to_string()))?;
    line.push('\n');
    let torn = std::fs::read(path)
        .ok()
        .is_some_and(|b| b.last().is_some_and(|&c| c != b'\n'));
    if torn {
        line.insert(0, '\n');
    }
    let mut file = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(path)
        .map_err(|e| err(format!("cannot open the health history for appending: {e}")))?;
    file.write_all(line.as_bytes())
        .and_then(|()| file.sync_all())
        .map_err(|e| err(format!("cannot append to the health history: {e}")))
}

/// A history as read: its entries in file order and a note for every line passed over.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct History {
    pub entries: Vec<Entry>,
    pub notes: Vec<String>,
}

/// Reads the history at `path` (empty when there is none yet).
pub fn read(path: &Path) -> Result<History, HistoryError> {
    let text = match std::fs::read(path) {
        Ok(b) => String::from_utf8_lossy(&b).into_owned(),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(History::default()),
        Err(e) => {
            return Err(HistoryError {
                path: path.to_path_buf(),
                message: format!("cannot read the health history: {e}"),
            })
        }
    };
    let mut h = History::default();
    for (n, line) in text.lines().enumerate() {
        if line.trim().is_empty() {
            continue;
        }
        #[derive(serde::Deserialize)]
        struct Format {
            format: u32,
        }
        match serde_json::from_str::<Format>(line) {
            Ok(f) if f.format > HISTORY_FORMAT => h.notes.push(format!(
                "{}:{}: a check of format {} (newer than this fringe reads, {HISTORY_FORMAT}): passed over",
                path.display(),
                n + 1,
                f.format
            )),
            Ok(_) => match serde_json::from_str::<Entry>(line) {
                Ok(e) => h.entries.push(e),
                Err(e) => h.notes.push(format!(
                    "{}:{}: damaged entry passed over ({e})",
                    path.display(),
                    n + 1
                )),
            },
            Err(e) => h.notes.push(format!(
                "{}:{}: damaged entry passed over ({e})",
                path.display(),
                n + 1
            )),
        }
    }
    Ok(h)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::health::figures::{assess, Measured, Thresholds};
    use crate::health::test_change::unchanged;

    fn entry(utc: &str) -> Entry {
        let change = unchanged();
        let m = Measured {
            change: &change,
            radius_px: 245.0,
            radius_sigma_px: 0.05,
            force_offset_n: Some([0.0, 0.01, -0.02]),
            model_now: None,
            model_then: None,
        };
        Entry {
            format: HISTORY_FORMAT,
            fringe_version: "test".into(),
            checked_utc: utc.into(),
            sensor_id: "unit".into(),
            certificate: "c".into(),
            run: "r".into(),
            bench_s: 60.0,
            assessment: assess(&m, &Thresholds::default()),
            model_now: None,
            model_then: None,
        }
    }

    fn scratch(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("fringe-history-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).expect("scratch dir");
        d.join("unit.health.jsonl")
    }

    #[test]
    fn a_damaged_line_is_reported_and_passed_over_and_new_checks_are_still_kept() {
        let path = scratch("damaged");
        append(&path, &entry("2026-01-01T00:00:00Z")).expect("first");
        // A torn write: half a line, no line break.
        let mut f = std::fs::OpenOptions::new()
            .append(true)
            .open(&path)
            .expect("open");
        f.write_all(b"{\"format\":1,\"fringe_ver").expect("tear");
        drop(f);
        append(&path, &entry("2026-02-01T00:00:00Z")).expect("after the tear");
        let h = read(&path).expect("read");
        let times: Vec<&str> = h.entries.iter().map(|e| e.checked_utc.as_str()).collect();
        assert_eq!(times, ["2026-01-01T00:00:00Z", "2026-02-01T00:00:00Z"]);
        assert_eq!(h.notes.len(), 1, "{:?}", h.notes);
        assert!(h.notes[0].contains(":2: damaged entry"), "{:?}", h.notes);
        assert_eq!(h.entries[0].verdict(), Verdict::Ok);
        assert_eq!(
            h.entries[0].figure("force_zero_n").map(|v| v > 0.0),
            Some(true)
        );
    }

    #[test]
    fn a_newer_entry_is_passed_over_with_a_note_and_no_history_is_empty() {
        let path = scratch("newer");
        assert_eq!(read(&path).expect("none"), History::default());
        std::fs::write(&path, "{\"format\":99,\"what\":\"future\"}\n").expect("newer");
        append(&path, &entry("2026-03-01T00:00:00Z")).expect("append");
        let h = read(&path).expect("read");
        assert_eq!(h.entries.len(), 1);
        assert!(h.notes[0].contains("format 99"), "{:?}", h.notes);
    }
}
