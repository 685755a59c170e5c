//! The background work the screens start: verifying, evaluating and exporting a run (Runs),
//! fitting and writing a calibration profile (Calibrate). Each runs on its own thread and sends
//! its progress and outcome on a channel the screen drains once a frame; a panic is sent as its
//! failure (never a screen left waiting on a thread that is gone).

use super::calibration;
use super::session::{self, ModelChoice};
use super::state::CalibrateView;
use crossbeam_channel::Sender;
use fringe_app::session::guarded;
use fringe_app::session::{calibrate_run, spot_settings, CalibrationResult, DEFAULT_MAX_FRAMES};
use fringe_app::RigConfig;
use std::path::{Path, PathBuf};

/// A run's name and a line about it (a verdict, progress, figures).
pub type Verdict = (String, String);

/// Verifies the run `dir` (named `name`); the verdict is sent on `tx`.
pub fn verify(name: String, dir: PathBuf, tx: Sender<Verdict>) {
    std::thread::spawn(move || {
        let verdict = guarded("verify", || match fringe_rig::store::verify_run(&dir) {
            Ok(r) if r.ok() => {
                format!("ok: {} frames, {} force samples", r.frames, r.force_samples)
            }
            Ok(r) => format!("{} problem(s): {}", r.problems.len(), r.problems.join("; ")),
            Err(e) => format!("cannot verify: {e}"),
        })
        .unwrap_or_else(|why| format!("cannot verify: {why}"));
        let _ = tx.send((name, verdict));
    });
}

/// Where the Runs screen exports run `name`: `exports/<name>` beside the runs directory.
pub fn export_dir(runs: &Path, name: &str) -> PathBuf {
    let base = match runs.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.join("exports"),
        _ => PathBuf::from("exports"),
    };
    base.join(name)
}

/// Exports the run `dir` in the reference layout (`0.images/`, `0.labels.csv`, as `fringe
/// export` does) to `out`: progress, then where it went, are sent on `tx`.
pub fn export(name: String, dir: PathBuf, out: PathBuf, tx: Sender<Verdict>) {
    std::thread::spawn(move || {
        let options = fringe_rig::store::ExportOptions::default();
        let outcome = guarded("export", || {
            fringe_rig::store::export_reference(&[dir], &out, &options, |k| {
                if k % 250 == 0 {
                    let _ = tx.send((name.clone(), format!("exporting: {k} images")));
                }
            })
            .map_err(|e| e.to_string())
        })
        .and_then(|r| r);
        let text = match outcome {
            Ok(s) => format!("exported {} images to {}", s.images, out.display()),
            Err(e) => format!("cannot export: {e}"),
        };
        let _ = tx.send((name, text));
    });
}

/// Evaluates the run `dir` with `choice`: progress, then the Table-2 figures, are sent on `tx`.
pub fn evaluate(name: String, dir: PathBuf, choice: ModelChoice, tx: Sender<Verdict>) {
    std::thread::spawn(move || {
        let figures = match guarded("evaluate", || {
            session::run_figures(&dir, &choice, &|done, total| {
                if done % 100 == 0 {
                    let _ = tx.send((
                        name.clone(),
                        format!("evaluating: {done} of {total} frames"),
                    ));
                }
            })
        })
        .and_then(|r| r)
        {
            Ok(f) => f,
            Err(e) => format!("cannot evaluate: {e}"),
        };
        let _ = tx.send((name, figures));
    });
}

/// What the calibration threads report.
pub enum Calibrated {
    /// The profile fitted from the calibration scan's run, and the screen that shows it.
    Fitted(Box<CalibrationResult>, Box<CalibrateView>),
    /// The profile written (the files, as text).
    Written(String),
    Failed(String),
}

/// Fits the profile from the calibration scan's run `run_dir`; `view` is the screen to fill.
pub fn fit_calibration(
    config: RigConfig,
    mut view: CalibrateView,
    run_dir: PathBuf,
    tx: Sender<Calibrated>,
) {
    std::thread::spawn(move || {
        let outcome = guarded("calibration fit", || {
            spot_settings(None, &config)
                .map_err(|e| e.to_string())
                .and_then(|(spot, _)| {
                    calibrate_run(&run_dir, &view.sensor, DEFAULT_MAX_FRAMES, spot)
                        .map_err(|e| e.to_string())
                })
        })
        .and_then(|r| r);
        let _ = tx.send(match outcome {
            Ok(result) => {
                calibration::show(&mut view, &result);
                Calibrated::Fitted(Box::new(result), Box::new(view))
            }
            Err(why) => Calibrated::Failed(why),
        });
    });
}

/// Writes the fitted profile (and its report images) into `dir`.
pub fn write_profile(result: Box<CalibrationResult>, dir: PathBuf, tx: Sender<Calibrated>) {
    std::thread::spawn(move || {
        let written = guarded("profile writer", || {
            result.write(&dir).map_err(|e| e.to_string())
        })
        .and_then(|r| r);
        let _ = tx.send(match written {
            Ok(w) => {
                let mut files = vec![
                    w.profile.display().to_string(),
                    w.report.display().to_string(),
                ];
                files.extend(
                    w.residuals
                        .iter()
                        .chain(&w.contact)
                        .map(|p| p.display().to_string()),
                );
                Calibrated::Written(files.join(", "))
            }
            Err(e) => Calibrated::Failed(e),
        });
    });
}
