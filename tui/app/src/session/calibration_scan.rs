//! The calibration scan from the rig: the built-in press grid around the rig's nominal centre,
//! and the contact-finding tuning for the sensor's construction. `fringe calibrate` runs it as a
//! scan session and builds the profile from the run ([`calibrate_run`], over
//! `fringe-calibration`), which the command line and the terminal UI write alike.

use crate::rig::file::RigConfig;
use crate::session::plans::{read_file, PlanFileError, CALIBRATION};
use fringe_calibration::calibrate;
use fringe_calibration::residual_plot;
use fringe_calibration::{draw_spot, SpotSettings};
use fringe_calibration::{overlay, overlay_scaled};
use fringe_calibration::{profile_path, Profile, ProfileError};
use fringe_calibration::{FromScanError, ScanCalibration};
use fringe_calibration::{ScanRun, ScanRunError};
use fringe_rig::store::ExitStatus;
use fringe_rig::ConfigError;
use fringe_rig::ScanOutcome;
use fringe_rig::{Plan, ScanProgram};
use std::path::{Path, PathBuf};

/// The built-in grid: `points` x `points` light presses over +- `span_mm` around the nominal
/// centre, each to `force_n` with `indenter`.
#[derive(Debug, Clone, PartialEq)]
pub struct CalibrationGrid {
    pub sensor: String,
    pub points: usize,
    pub span_mm: f64,
    pub force_n: f64,
    pub indenter: String,
}

impl CalibrationGrid {
    /// Presses per axis of the built-in grid (`fringe calibrate --points`).
    pub const DEFAULT_POINTS: usize = 3;
    /// Half-width of the grid around the nominal centre, mm (`--span`).
    pub const DEFAULT_SPAN_MM: f64 = 5.0;
    /// Force of each light press, N (`--force`).
    pub const DEFAULT_FORCE_N: f64 = 1.5;
    /// Indenter of the presses (`--indenter`).
    pub const DEFAULT_INDENTER: &'static str = "pentagon";

    /// The built-in grid for `sensor` with the defaults above.
    pub fn defaults(sensor: &str) -> CalibrationGrid {
        CalibrationGrid {
            sensor: sensor.to_string(),
            points: Self::DEFAULT_POINTS,
            span_mm: Self::DEFAULT_SPAN_MM,
            force_n: Self::DEFAULT_FORCE_N,
            indenter: Self::DEFAULT_INDENTER.to_string(),
        }
    }

    /// In a few words, for the operator.
    pub fn describe(&self) -> String {
        format!(
            "{} x {} light presses over +-{} mm, {} N, {}",
            self.points, self.points, self.span_mm, self.force_n, self.indenter
        )
    }
}

/// A calibration grid that cannot be pressed.
#[derive(Debug, thiserror::Error)]
pub enum CalibrationPlanError {
    #[error("--points {0}: use at least 2 (the fit needs presses in two directions)")]
    Points(usize),
    #[error("--span {0}: use a positive number of mm")]
    Span(f64),
    #[error("--force {0}: use a positive number of newtons")]
    Force(f64),
    #[error("--variant {0}: use layered or integrated")]
    Variant(String),
    #[error(transparent)]
    Config(#[from] ConfigError),
    #[error("the built-in calibration plan ({path}): {message}")]
    Builtin { path: &'static str, message: String },
    #[error(transparent)]
    File(#[from] PlanFileError),
}

/// The calibration scan's plan: its text, its name in messages and its program.
pub struct CalibrationPlan {
    pub text: String,
    pub name: String,
    pub program: ScanProgram,
}

/// The calibration scan's plan on `config`'s rig: the plan file `file` if one is given, else
/// `grid`.
pub fn calibration_plan(
    file: Option<&Path>,
    grid: &CalibrationGrid,
    config: &RigConfig,
) -> Result<CalibrationPlan, CalibrationPlanError> {
    let limits = config.limits()?;
    let (text, name) = match file {
        Some(path) => (read_file(path)?, path.display().to_string()),
        None => (grid.plan_text(config)?, "built-in calibration grid".into()),
    };
    let program = Plan::parse(&text, &name)?.program(&limits, &name)?;
    Ok(CalibrationPlan {
        text,
        name,
        program,
    })
}

/// A calibration scan that did not complete: no profile is made from it.
#[derive(Debug, thiserror::Error)]
#[error(
    "the calibration scan did not complete ({reason}); no profile written (the run is kept in {})",
    .run_dir.display()
)]
pub struct Incomplete {
    pub reason: String,
    pub run_dir: PathBuf,
}

/// The end of a calibration scan, refused unless it completed.
pub fn completed(outcome: &ScanOutcome) -> Result<(), Incomplete> {
    if outcome.status == ExitStatus::Completed {
        return Ok(());
    }
    Err(Incomplete {
        reason: outcome.reason.clone(),
        run_dir: outcome.run_dir.clone(),
    })
}

/// Contact finding for the sensor's construction: as given, else the simulated sensor's, else a
/// layered sensor's (the second value says which default was taken, for the operator).
pub fn spot_settings(
    variant: Option<&str>,
    config: &RigConfig,
) -> Result<(SpotSettings, Option<&'static str>), CalibrationPlanError> {
    match variant {
        Some("layered") => Ok((SpotSettings::layered(), None)),
        Some("integrated") => Ok((SpotSettings::integrated(), None)),
        Some(other) => Err(CalibrationPlanError::Variant(other.into())),
        None => {
            #[cfg(feature = "sim")]
            if config.is_simulated() {
                return Ok((crate::rig::simulated::spot_settings(config)?, None));
            }
            #[cfg(not(feature = "sim"))]
            let _ = config;
            Ok((
                SpotSettings::layered(),
                Some("contact finding tuned for a layered sensor (thin film); give --variant integrated for a gel"),
            ))
        }
    }
}

impl CalibrationGrid {
    /// The plan text: the built-in calibration plan with its grid, force, ceiling and indenter
    /// replaced, headed by a comment that says how it was made.
    pub fn plan_text(&self, config: &RigConfig) -> Result<String, CalibrationPlanError> {
        if self.points < 2 {
            return Err(CalibrationPlanError::Points(self.points));
        }
        if !(self.span_mm > 0.0 && self.span_mm.is_finite()) {
            return Err(CalibrationPlanError::Span(self.span_mm));
        }
        if !(self.force_n > 0.0 && self.force_n.is_finite()) {
            return Err(CalibrationPlanError::Force(self.force_n));
        }
        let builtin = |message: String| CalibrationPlanError::Builtin {
            path: CALIBRATION.path,
            message,
        };
        let centre = config.origin()?;
        let axis = |c: f64| -> Vec<f64> {
            (0..self.points)
                .map(|k| {
                    let t = k as f64 / (self.points - 1) as f64;
                    ((c - self.span_mm + 2.0 * self.span_mm * t) * 1000.0).round() / 1000.0
                })
                .collect()
        };
        let mut plan: toml::Table = CALIBRATION
            .text
            .parse()
            .map_err(|e: toml::de::Error| builtin(e.to_string()))?;
        let set = |plan: &mut toml::Table, section: &str, key: &str, value: toml::Value| {
            if let Some(toml::Value::Table(t)) = plan.get_mut(section) {
                t.insert(key.into(), value);
            }
        };
        let floats =
            |v: Vec<f64>| toml::Value::Array(v.into_iter().map(toml::Value::Float).collect());
        set(&mut plan, "grid", "x", floats(axis(centre.x.0)));
        set(&mut plan, "grid", "y", floats(axis(centre.y.0)));
        set(
            &mut plan,
            "indentation",
            "force_targets",
            floats(vec![self.force_n]),
        );
        set(
            &mut plan,
            "indenters",
            "shapes",
            toml::Value::Array(vec![toml::Value::String(self.indenter.clone())]),
        );
        set(
            &mut plan,
            "safety",
            "force_ceiling",
            toml::Value::Float((4.0 * self.force_n).max(self.force_n + 2.0)),
        );
        plan.insert(
            "name".into(),
            toml::Value::String(format!("calibration-{}", self.sensor)),
        );
        let body = toml::to_string(&plan).map_err(|e| builtin(e.to_string()))?;
        Ok(format!(
            "# fringe calibrate --sensor {}: {}x{} presses over +-{} mm around the nominal centre ({:.3}, {:.3}) mm from {}\n{body}",
            self.sensor,
            self.points,
            self.points,
            self.span_mm,
            centre.x.0,
            centre.y.0,
            centre.source,
        ))
    }
}

/// A calibration scan's run made into a profile, with what shows how good it is.
pub struct CalibrationResult {
    pub sensor: String,
    pub run_dir: PathBuf,
    /// The fits: optical, presses located, registration, force offsets.
    pub cal: ScanCalibration,
    /// The profile they make (not written until [`CalibrationResult::write`]).
    pub profile: Profile,
}

/// Why a run gave no profile.
#[derive(Debug, thiserror::Error)]
pub enum CalibrationRunError {
    #[error(transparent)]
    Read(#[from] ScanRunError),
    #[error(transparent)]
    Fit(#[from] FromScanError),
    #[error(transparent)]
    Profile(#[from] ProfileError),
    #[error("cannot write {path}: {message}")]
    Write { path: String, message: String },
}

/// The files [`CalibrationResult::write`] wrote.
#[derive(Debug, Clone, PartialEq)]
pub struct WrittenProfile {
    pub profile: PathBuf,
    /// The averaged frame with the fitted disc (green), crop circle (yellow), centre (red).
    pub report: PathBuf,
    /// Registration residuals per press, when there is a registration.
    pub residuals: Option<PathBuf>,
    /// The press nearest the centre with its located contact marked, when one was located.
    pub contact: Option<PathBuf>,
}

/// No-contact frames averaged for the optical fit at most (`fringe calibrate --max-frames`).
pub const DEFAULT_MAX_FRAMES: usize = 50;

/// Calibrates sensor `sensor` from the calibration scan in `run_dir`, averaging at most
/// `max_frames` no-contact frames; `spot` tunes contact finding.
pub fn calibrate_run(
    run_dir: &Path,
    sensor: &str,
    max_frames: usize,
    spot: SpotSettings,
) -> Result<CalibrationResult, CalibrationRunError> {
    let run = ScanRun::read(run_dir)?;
    let cal = calibrate(&run, max_frames, spot)?;
    let mut profile = Profile::from_fit(sensor, &run_dir.display().to_string(), &cal.fit);
    profile.force_offsets = cal.offsets;
    profile.registration = cal.registration.as_ref().ok().map(|r| r.to_profile());
    Ok(CalibrationResult {
        sensor: sensor.to_string(),
        run_dir: run_dir.to_path_buf(),
        cal,
        profile,
    })
}

impl CalibrationResult {
    /// The fit over the averaged frame (see [`overlay`]).
    pub fn report_image(&self) -> Result<image::RgbImage, fringe_plot::PlotError> {
        overlay(&self.cal.background, &self.cal.fit)
    }

    /// The same, at most `side` px on its longer side (for displays).
    pub fn preview(&self, side: u32) -> Result<image::RgbImage, fringe_plot::PlotError> {
        let g = &self.cal.background;
        let longer = g.width.max(g.height).max(1) as f64;
        overlay_scaled(g, &self.cal.fit, f64::from(side) / longer)
    }

    /// Writes the profile into `dir` (`<dir>/<sensor>.toml`, created) with its report images
    /// beside it.
    pub fn write(&self, dir: &Path) -> Result<WrittenProfile, CalibrationRunError> {
        let profile_file = profile_path(dir, &self.sensor)?;
        let failed = |path: &Path, e: &dyn std::fmt::Display| CalibrationRunError::Write {
            path: path.display().to_string(),
            message: e.to_string(),
        };
        std::fs::create_dir_all(dir).map_err(|e| failed(dir, &e))?;
        let report = profile_file.with_extension("png");
        self.report_image()
            .map_err(|e| failed(&report, &e))?
            .save(&report)
            .map_err(|e| failed(&report, &e))?;
        let residuals = match &self.cal.registration {
            Ok(r) => {
                let path = dir.join(format!("{}-registration.png", self.sensor));
                let stage: Vec<[f64; 2]> = self
                    .cal
                    .presses
                    .iter()
                    .filter(|p| p.spot.is_ok())
                    .map(|p| p.stage_mm)
                    .collect();
                residual_plot(&r.fit, &stage)
                    .map_err(|e| failed(&path, &e))?
                    .save(&path)
                    .map_err(|e| failed(&path, &e))?;
                Some(path)
            }
            Err(_) => None,
        };
        let contact = match &self.cal.example_press {
            Some((frame, spot)) => {
                let path = dir.join(format!("{}-contact.png", self.sensor));
                draw_spot(frame, spot, [255, 255, 0])
                    .map_err(|e| failed(&path, &e))?
                    .save(&path)
                    .map_err(|e| failed(&path, &e))?;
                Some(path)
            }
            None => None,
        };
        self.profile.save(&profile_file)?;
        Ok(WrittenProfile {
            profile: profile_file,
            report,
            residuals,
            contact,
        })
    }
}
