//! The commissioning's journal (`journal.json` in its directory): the choices made and the runs
//! recorded so far, written before each scan starts and after it ends, so that a commissioning
//! cut short (Ctrl-C, a crash, power loss) goes on from its runs with `--resume DIR` and
//! presses nothing twice.

use crate::rig::file::RigConfig;
use crate::session::disk_space::camera_frame;
use fringe_rig::format_name;
use fringe_rig::store::write_atomic;
use fringe_rig::store::{ExitStatus, StopDocument};
use fringe_rig::store::{RunFile, RunReader};
use fringe_rig::ConfigError;
use std::path::{Path, PathBuf};

/// The journal's file name in a commissioning directory.
pub(crate) const JOURNAL: &str = "journal.json";
/// Format of the journal this version writes; older ones are read, newer ones refused.
pub(crate) const JOURNAL_FORMAT: u32 = 1;

/// What the commissioning was asked to do (fixed when it starts; `--resume` keeps them).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Options {
    pub sensor: String,
    /// The base model as given (`default` or a path).
    pub base: String,
    /// Simulated or real bench time for the presses, minutes (calibration and acceptance not
    /// counted).
    pub budget_min: f64,
    /// The spec's text (TOML), or `None` for the paper's row.
    pub spec: Option<String>,
    /// Where the spec came from, for the report.
    pub spec_origin: String,
    pub seed: u64,
    /// Presses per adaptive round.
    pub round_presses: usize,
    /// Presses of the acceptance scan.
    pub acceptance_presses: usize,
    /// Also train the custom CNN's last block (kept when it beats the heads alone).
    #[serde(default)]
    pub last_block: bool,
    /// Also fine-tune every layer with libtorch (`torch` builds; kept when it beats the heads
    /// alone).
    #[serde(default)]
    pub fine_tune: bool,
    /// The camera settings that decide its frames, as the rig gave them when it started (a
    /// resume on other settings would press frames the unit's profile and rounds do not fit);
    /// `None` in journals written before they were recorded.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub camera: Option<FrameSettings>,
}

/// What decides a commissioning's frames, known from the rig file before the camera opens.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct FrameSettings {
    /// The camera's pixel format (`camera.pixel_format`: mono8, rgb8, bayerrg8).
    pub pixel_format: String,
    /// The frame's size, px [width, height], when the rig file decides it (the simulated
    /// bench's: its sensor and `sim.image_scale`); a real camera gives its own sensor's.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub size_px: Option<[u32; 2]>,
    /// The simulated camera's `sim.image_scale`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub image_scale: Option<f64>,
}

impl FrameSettings {
    /// The settings `config` gives.
    pub fn of(config: &RigConfig) -> Result<FrameSettings, ConfigError> {
        let pixel_format = format_name(config.camera_settings()?.pixel_format).to_string();
        if !config.is_simulated() {
            return Ok(FrameSettings {
                pixel_format,
                size_px: None,
                image_scale: None,
            });
        }
        let size = camera_frame(None, config);
        Ok(FrameSettings {
            pixel_format,
            size_px: Some([size.width, size.height]),
            image_scale: Some(config.file.sim.image_scale),
        })
    }

    /// How `now` differs from these settings, one phrase each (`frame size 480x300 px, was
    /// 960x600 px`); empty when they agree.
    pub fn differences(&self, now: &FrameSettings) -> Vec<String> {
        let mut out = Vec::new();
        if self.pixel_format != now.pixel_format {
            out.push(format!(
                "camera.pixel_format {}, was {}",
                now.pixel_format, self.pixel_format
            ));
        }
        let size = |s: Option<[u32; 2]>| {
            s.map_or("the camera's own".to_string(), |[w, h]| {
                format!("{w}x{h} px")
            })
        };
        if self.size_px != now.size_px {
            out.push(format!(
                "frame size {}, was {}",
                size(now.size_px),
                size(self.size_px)
            ));
        }
        if self.image_scale != now.image_scale {
            let scale =
                |s: Option<f64>| s.map_or("none (a real camera)".to_string(), |k| k.to_string());
            out.push(format!(
                "sim.image_scale {}, was {}",
                scale(now.image_scale),
                scale(self.image_scale)
            ));
        }
        out
    }
}

/// One scan of the commissioning.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ScanEntry {
    /// The run's directory name under `runs/`.
    pub run_id: String,
    /// The plan it runs (TOML).
    pub plan: String,
    /// Bench time the plan was estimated to take, s.
    pub estimate_s: f64,
    /// Bench time it took, s (when it ended).
    #[serde(default)]
    pub took_s: Option<f64>,
    /// The run completed (its frames may be used).
    #[serde(default)]
    pub completed: bool,
}

/// The journal.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Journal {
    pub format: u32,
    pub fringe_version: String,
    pub started_utc: String,
    pub options: Options,
    #[serde(default)]
    pub calibration: Option<ScanEntry>,
    #[serde(default)]
    pub rounds: Vec<ScanEntry>,
    #[serde(default)]
    pub acceptance: Option<ScanEntry>,
    /// The fine-tuning's checkpoint to go on from (relative to the directory), when it was
    /// stopped.
    #[serde(default)]
    pub fine_tune_checkpoint: Option<String>,
    /// Rounds whose frames were pruned (their features and records kept): once their features
    /// were kept, or after the commissioning passed; empty in journals written before pruning.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub pruned: Vec<String>,
}

/// A journal that cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum JournalError {
    #[error(
        "{0}: no commissioning journal here (give the directory `fringe commission` printed when \
         it started, the one holding journal.json)"
    )]
    Missing(PathBuf),
    #[error("{path}: {message}")]
    Read { path: PathBuf, message: String },
    #[error(
        "{path}: journal format {found} is newer than this fringe reads ({JOURNAL_FORMAT}): \
         resume it with the newer fringe that started it"
    )]
    Newer { path: PathBuf, found: u32 },
}

impl Journal {
    pub fn new(options: Options) -> Journal {
        Journal {
            format: JOURNAL_FORMAT,
            fringe_version: env!("CARGO_PKG_VERSION").to_string(),
            started_utc: fringe_rig::store::now_utc(),
            options,
            calibration: None,
            rounds: Vec::new(),
            acceptance: None,
            fine_tune_checkpoint: None,
            pruned: Vec::new(),
        }
    }

    /// Reads the journal of the commissioning in `dir`.
    pub fn read(dir: &Path) -> Result<Journal, JournalError> {
        let path = dir.join(JOURNAL);
        if !path.is_file() {
            return Err(JournalError::Missing(dir.to_path_buf()));
        }
        let text = std::fs::read_to_string(&path).map_err(|e| JournalError::Read {
            path: path.clone(),
            message: e.to_string(),
        })?;
        #[derive(serde::Deserialize)]
        struct Format {
            format: u32,
        }
        let format: Format = serde_json::from_str(&text).map_err(|e| JournalError::Read {
            path: path.clone(),
            message: format!("not a commissioning journal ({e})"),
        })?;
        if format.format > JOURNAL_FORMAT {
            return Err(JournalError::Newer {
                path,
                found: format.format,
            });
        }
        serde_json::from_str(&text).map_err(|e| JournalError::Read {
            path,
            message: format!("damaged journal ({e}); the runs under runs/ are intact"),
        })
    }

    /// Writes the journal into `dir`, whole or not at all.
    pub fn write(&self, dir: &Path) -> Result<(), JournalError> {
        let path = dir.join(JOURNAL);
        let text = serde_json::to_string_pretty(self).map_err(|e| JournalError::Read {
            path: path.clone(),
            message: e.to_string(),
        })?;
        write_atomic(&path, (text + "\n").as_bytes()).map_err(|e| JournalError::Read {
            path,
            message: e.to_string(),
        })
    }

    /// Bench time the rounds took (or, for one still to finish, were estimated to take), s.
    pub fn round_seconds(&self) -> f64 {
        self.rounds
            .iter()
            .map(|r| r.took_s.unwrap_or(r.estimate_s))
            .fold(0.0, |a, b| a + b)
    }
}

/// Where a journal's scan stands on disk.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum RunState {
    /// Not started: start it as a new run with its id.
    Absent,
    /// Started and cut short: resume it.
    Unfinished,
    /// Ended, with how.
    Ended(StopDocument),
}

/// The state of the run `dir`.
pub(crate) fn run_state(dir: &Path) -> Result<RunState, JournalError> {
    let run = RunReader::at(dir);
    if !run.is_run() {
        return Ok(RunState::Absent);
    }
    if !run.is_closed() {
        return Ok(RunState::Unfinished);
    }
    let document = run.stop().map_err(|e| JournalError::Read {
        path: run.path(RunFile::Stop),
        message: e.to_string(),
    })?;
    Ok(document.map_or(RunState::Unfinished, RunState::Ended))
}

/// A run that ended completed.
pub(crate) fn completed(state: &RunState) -> bool {
    matches!(state, RunState::Ended(s) if s.exit_status == ExitStatus::Completed)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn options() -> Options {
        Options {
            sensor: "unit-7".into(),
            base: "default".into(),
            budget_min: 10.0,
            spec: None,
            spec_origin: "paper".into(),
            seed: 42,
            round_presses: 6,
            acceptance_presses: 8,
            last_block: false,
            fine_tune: false,
            camera: None,
        }
    }

    #[test]
    fn a_journal_reads_back_and_a_newer_one_is_refused() {
        let dir = std::env::temp_dir().join(format!("fringe-journal-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("dir");
        let mut j = Journal::new(options());
        j.rounds.push(ScanEntry {
            run_id: "round-1".into(),
            plan: "name = \"r\"".into(),
            estimate_s: 60.0,
            took_s: Some(55.0),
            completed: true,
        });
        j.rounds.push(ScanEntry {
            run_id: "round-2".into(),
            plan: String::new(),
            estimate_s: 40.0,
            took_s: None,
            completed: false,
        });
        j.write(&dir).expect("write");
        let back = Journal::read(&dir).expect("read");
        assert_eq!(back, j);
        assert_eq!(back.round_seconds(), 95.0);
        let newer = std::fs::read_to_string(dir.join(JOURNAL))
            .expect("text")
            .replace("\"format\": 1", "\"format\": 9");
        std::fs::write(dir.join(JOURNAL), newer).expect("write");
        let e = Journal::read(&dir).expect_err("newer").to_string();
        assert!(e.contains("format 9 is newer"), "{e}");
        let e = Journal::read(&dir.join("nothing"))
            .expect_err("missing")
            .to_string();
        assert!(e.contains("no commissioning journal"), "{e}");
        assert_eq!(
            run_state(&dir.join("no-run")).expect("state"),
            RunState::Absent
        );
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn the_camera_settings_are_kept_and_a_journal_without_them_still_reads() {
        let dir = std::env::temp_dir().join(format!("fringe-journal-cam-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("dir");
        let half = RigConfig::parse("[sim]\nimage_scale = 0.5\n", "half.toml").expect("rig");
        let quarter = RigConfig::parse("[sim]\nimage_scale = 0.25\n", "quarter.toml").expect("rig");
        let then = FrameSettings::of(&half).expect("settings");
        assert_eq!(then.pixel_format, "bayerrg8");
        assert_eq!(then.size_px, Some([960, 600]));
        let mut j = Journal::new(Options {
            camera: Some(then.clone()),
            ..options()
        });
        j.write(&dir).expect("write");
        let back = Journal::read(&dir).expect("read");
        assert_eq!(back.options.camera.as_ref(), Some(&then));
        assert!(then
            .differences(&FrameSettings::of(&half).expect("same"))
            .is_empty());
        assert_eq!(
            then.differences(&FrameSettings::of(&quarter).expect("other")),
            [
                "frame size 480x300 px, was 960x600 px",
                "sim.image_scale 0.25, was 0.5"
            ]
        );
        // A journal of an older fringe, without the settings, reads as it did.
        j.options.camera = None;
        j.write(&dir).expect("write");
        let text = std::fs::read_to_string(dir.join(JOURNAL)).expect("text");
        assert!(!text.contains("camera"), "{text}");
        assert_eq!(Journal::read(&dir).expect("old").options.camera, None);
        let _ = std::fs::remove_dir_all(&dir);
    }
}
