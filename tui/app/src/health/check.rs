//! A health check (`fringe check`): a unit checked against what it was accepted with (its
//! newest passing commissioning certificate) in at most two minutes of bench time: a few of its
//! acceptance positions pressed again with every indenter; the optics, light and surface of its
//! no-contact frames, its F/T zero and its model's errors compared; a verdict with the evidence,
//! appended to the unit's history.

use crate::commission::certificate::{commissioned_model, Commissioned, PROFILE};
use crate::commission::host::Host;
use crate::commission::journal::Journal;
use crate::commission::scans::estimate_s;
use crate::health::check_plan::{acceptance_positions, check_plan, MAX_BENCH_S};
use crate::health::check_report;
use crate::health::figures::{assess, Assessment, Measured, Thresholds, Verdict};
use crate::health::history::{self, history_path, Entry, HISTORY_FORMAT};
use crate::health::model_errors::{at_any, at_positions, thinned, ModelErrors, EVAL_FRAMES};
use crate::health::reference::compared;
use crate::models::choice::open_model;
use crate::rig::file::RigConfig;
use crate::session::scan::ProfileUse;
use crate::workflow_error::{refuse, Context, WorkflowError};
use fringe_calibration::health::Signature;
use fringe_calibration::Profile;
use fringe_calibration::ScanRun;
use fringe_rig::Plan;
use fringe_rig::RunTarget;
use fringe_sensor_models::dataset;
use fringe_sensor_models::eval::{evaluate, Row};
use fringe_sensor_models::BackendKind;
use fringe_sensor_models::Model;
use fringe_sensor_models::Predictor;
use std::path::{Path, PathBuf};
use std::time::Instant;

type Result<T> = std::result::Result<T, WorkflowError>;

/// A check done: its verdict with the evidence, and where it was appended.
pub struct Checked {
    pub assessment: Assessment,
    /// The unit's history file.
    pub history: PathBuf,
    /// The check's report (HTML, one file).
    pub report: PathBuf,
}

/// Checks `sensor` on the rig of `config` (its run into `out`), telling `host` what it does, and
/// appends the check to the unit's history. A unit that is not ok is an `Ok` whose assessment
/// says what to do.
pub fn run(
    config: &RigConfig,
    sensor: &str,
    out: &Path,
    threads: usize,
    host: &mut dyn Host,
) -> Result<Checked> {
    let sensor = sensor.to_string();
    let profiles = config.profile_dir();
    let accepted = certificate(&profiles, &sensor, config, host)?;
    let dir = accepted.dir.clone();
    commissioning_runs_present(&accepted)?;
    let journal = Journal::read(&dir)?;
    let Some(acceptance) = &journal.acceptance else {
        refuse!(
            "{}: the commissioning's journal has no acceptance scan to check against",
            dir.display()
        );
    };
    let model = open_model(&accepted.model)?;
    if let Some(w) = model.missing_card_warning() {
        host.notice(format!("warning: {w}"));
    }
    model.check_design(config.sensor_variant()?, "this unit")?;
    let shapes: Vec<String> = model.classes.iter().skip(1).cloned().collect();
    let positions =
        acceptance_positions(&acceptance.plan, &format!("{} (acceptance)", dir.display()))?;
    let plan = check_plan(&sensor, &positions, &shapes, |p| {
        estimate_s(p, config).map_err(|e| e.to_string())
    })?;
    host.say(format!(
        "against the commissioning {} (issued {}, fringe {})",
        dir.display(),
        accepted.certificate.issued_utc,
        accepted.certificate.fringe_version
    ));
    host.say(format!(
        "the check presses {} of the {} acceptance positions with {}: about {:.0} s of bench time (a check takes at most {MAX_BENCH_S:.0} s)",
        plan.positions.len(),
        positions.len(),
        shapes.join(", "),
        plan.estimate_s
    ));
    let limits = config.limits()?;
    let program = Plan::parse(&plan.plan, "check plan")?.program(&limits, "check plan")?;
    let started = Instant::now();
    let run_id = free_run_id(
        out,
        &format!(
            "check-{sensor}-{}",
            fringe_rig::store::now_utc().replace([':', '.'], "-")
        ),
    );
    let end = host.scan(
        config,
        program,
        plan.plan.clone(),
        RunTarget::New {
            root: out.to_path_buf(),
            run_id,
        },
        ProfileUse::Consume,
    )?;
    let bench_s = started.elapsed().as_secs_f64();
    let run_dir = end.run_dir.clone();
    if !end.completed {
        refuse!(
            "the check's scan stopped ({}): no verdict; its run is kept in {}. Check again when the bench is ready",
            end.reason,
            run_dir.display()
        );
    }
    let reference = reference_calibration(&accepted, &profiles, &sensor);
    host.say(format!(
        "camera geometry and F/T zero compared with {}; light and surface with the commissioning's calibration scan",
        reference.about
    ));
    let (assessment, model_now, model_then) = compare(
        &accepted,
        &reference,
        &run_dir,
        &model,
        &plan.positions,
        threads,
        host,
    )?;
    for line in report(&assessment) {
        host.say(line);
    }
    let entry = Entry {
        format: HISTORY_FORMAT,
        fringe_version: env!("CARGO_PKG_VERSION").to_string(),
        checked_utc: fringe_rig::store::now_utc(),
        sensor_id: sensor.clone(),
        certificate: dir.display().to_string(),
        run: run_dir.display().to_string(),
        bench_s,
        assessment: assessment.clone(),
        model_now,
        model_then,
    };
    let path = history_path(&profiles, &sensor);
    history::append(&path, &entry)?;
    let mut entries = history::read(&path)?.entries;
    if entries.last() != Some(&entry) {
        entries.push(entry.clone());
    }
    let report = check_report::write(&profiles, &entry, &entries)?;
    Ok(Checked {
        assessment,
        history: path,
        report,
    })
}

/// `id`, or `id-2`, `id-3`, ... when a run of that id is in `root` (two checks started in the
/// same millisecond; the scan engine still refuses a run that exists when it starts).
fn free_run_id(root: &Path, id: &str) -> String {
    (1..)
        .map(|n| {
            if n == 1 {
                id.to_string()
            } else {
                format!("{id}-{n}")
            }
        })
        .find(|c| !root.join(c).exists())
        .unwrap_or_else(|| id.to_string())
}

/// The unit: `--sensor`, else the rig's sensor; both given must agree.
pub fn unit(config: &RigConfig, given: Option<&str>) -> Result<String> {
    let rig = config.sensor_id();
    match (given, rig) {
        (Some(g), Ok(r)) if g != r => refuse!(
            "--sensor {g}: the rig's sensor is {r} (its `sensor` key, or the simulated sensor): check the unit that is under the camera, on the rig file that names it"
        ),
        (Some(g), _) => Ok(g.to_string()),
        (None, Ok(r)) => Ok(r),
        (None, Err(e)) => refuse!("{e}; or give the unit with --sensor ID"),
    }
}

/// The unit's newest passing commissioning, or what to do.
fn certificate(
    profiles: &Path,
    sensor: &str,
    config: &RigConfig,
    host: &mut dyn Host,
) -> Result<Commissioned> {
    let (found, notes) = commissioned_model(profiles, sensor);
    for n in &notes {
        host.notice(format!("warning: {n}"));
    }
    let Some(c) = found else {
        refuse!(
            "no certificate of sensor {sensor} under {} (looked for {}/{sensor}.commission-*/certificate.json that passed): commission it first: fringe commission{}",
            profiles.display(),
            profiles.display(),
            match &config.origin {
                o if o.ends_with(".toml") => format!(" --rig {o}"),
                _ => String::new(),
            }
        );
    };
    if c.certificate.fringe_version != env!("CARGO_PKG_VERSION") {
        host.notice(format!(
            "note: {} was written by fringe {}, this is fringe {}: its runs and figures are compared as they are",
            c.dir.join("certificate.json").display(),
            c.certificate.fringe_version,
            env!("CARGO_PKG_VERSION")
        ));
    }
    Ok(c)
}

/// The commissioning's runs a check compares with (its calibration scan: light, surface; its
/// acceptance scan: the model's errors), found before anything moves.
fn commissioning_runs_present(accepted: &Commissioned) -> Result<()> {
    let runs = &accepted.certificate.runs;
    for (what, run) in [
        ("calibration scan", &runs.calibration),
        ("acceptance scan", &runs.acceptance),
    ] {
        let path = accepted.dir.join(run);
        if !fringe_rig::store::RunReader::at(&path).is_run() {
            refuse!(
                "{}: the commissioning's {what} {} is missing (not a run): a check compares the unit with it, so nothing is pressed. Put the run back from a backup, or commission the unit again (fringe commission)",
                accepted.dir.display(),
                path.display()
            );
        }
    }
    Ok(())
}

/// The calibration the camera geometry and the F/T zero are compared with (the light and the
/// surface are compared with the commissioning's: `fringe_app::health::reference`).
struct Reference {
    /// Its calibration scan.
    run: PathBuf,
    /// The profile made from it.
    profile: PathBuf,
    about: String,
}

/// The unit's profile when it was made from a calibration scan after the commissioning (the unit
/// was calibrated again, as a check may advise: the next check compares with that calibration,
/// or it would tell the user to calibrate again for ever); else the commissioning's calibration
/// scan and profile.
fn reference_calibration(accepted: &Commissioned, profiles: &Path, sensor: &str) -> Reference {
    let cert = &accepted.certificate;
    let commissioned = Reference {
        run: accepted.dir.join(&cert.runs.calibration),
        profile: accepted.dir.join(PROFILE),
        about: "the commissioning's calibration scan".into(),
    };
    let Ok(path) = fringe_calibration::profile_path(profiles, sensor) else {
        return commissioned;
    };
    let Ok(p) = Profile::load(&path) else {
        return commissioned;
    };
    let run = PathBuf::from(&p.source);
    let later = p.created_utc.as_str() > cert.issued_utc.as_str();
    if later && fringe_rig::store::RunReader::at(&run).is_run() && run != commissioned.run {
        Reference {
            about: format!(
                "the unit's calibration of {} ({}, made after its commissioning)",
                p.created_utc,
                path.display()
            ),
            run,
            profile: path,
        }
    } else {
        commissioned
    }
}

/// Everything compared: the no-contact signatures of the check against the commissioning's
/// calibration scan (light, surface) and the reference calibration scan (geometry), the F/T zero
/// against the reference calibration's, the model's errors at the check's positions now and in
/// the acceptance scan.
fn compare(
    accepted: &Commissioned,
    reference: &Reference,
    run_dir: &Path,
    model: &Model,
    positions: &[[f64; 2]],
    threads: usize,
    host: &mut dyn Host,
) -> Result<(Assessment, Option<ModelErrors>, Option<ModelErrors>)> {
    let dir = &accepted.dir;
    let cert = &accepted.certificate;
    let reference_run = ScanRun::read(&reference.run)?;
    let check_run = ScanRun::read(run_dir)?;
    host.say("measuring the no-contact frames (the calibrations' and the check's)".into());
    let commissioned_run = dir.join(&cert.runs.calibration);
    let commissioned = if reference.run == commissioned_run {
        None
    } else {
        Some(Signature::measure(&ScanRun::read(&commissioned_run)?)?)
    };
    let then = Signature::measure(&reference_run)?;
    let now = Signature::measure(&check_run)?;
    let change = match &commissioned {
        Some(c) => compared(c, Some(&then), &now)?,
        None => compared(&then, None, &now)?,
    };
    let force_offset_n = force_zero_moved(&reference_run, &check_run, &reference.profile)?;
    let rows_now = evaluated(model, run_dir, None, threads, "evaluating the check", host)?;
    let acceptance = dir.join(&cert.runs.acceptance);
    let rows_then = evaluated(
        model,
        &acceptance,
        Some(positions),
        threads,
        "evaluating the acceptance at the same positions",
        host,
    )?;
    let model_now = ModelErrors::of(&rows_now.iter().collect::<Vec<_>>());
    let model_then = ModelErrors::of(&at_positions(&rows_then, positions));
    let measured = Measured {
        change: &change,
        radius_px: then.fit.radius,
        radius_sigma_px: then.fit.sigma_radius.hypot(now.fit.sigma_radius),
        force_offset_n,
        model_now: model_now.as_ref(),
        model_then: model_then.as_ref(),
    };
    Ok((
        assess(&measured, &Thresholds::default()),
        model_now,
        model_then,
    ))
}

/// The F/T zero (Fx, Fy, Fz, N) at the check's first no-contact window minus the one at the
/// commissioning's calibration scan's first window: both a few seconds after the bench opened,
/// so the zero's slow wander within a session is alike in both. Without windows in the
/// calibration run, the profile's offsets (its last window) are the reference.
fn force_zero_moved(
    reference: &ScanRun,
    check: &ScanRun,
    profile: &Path,
) -> Result<Option<[f64; 3]>> {
    let Some(now) = check.offsets.first() else {
        return Ok(None);
    };
    let then = match reference.offsets.first() {
        Some(b) => [b.mean[0], b.mean[1], b.mean[2]],
        None => match Profile::load(profile)?.force_offsets {
            Some(o) => o.force_n,
            None => return Ok(None),
        },
    };
    Ok(Some([
        now.mean[0] - then[0],
        now.mean[1] - then[1],
        now.mean[2] - then[2],
    ]))
}

/// The model run on at most [`EVAL_FRAMES`] of the labelled frames of `run` (only of those
/// pressed at `positions`, when given).
fn evaluated(
    model: &Model,
    run: &Path,
    positions: Option<&[[f64; 2]]>,
    threads: usize,
    what: &'static str,
    host: &mut dyn Host,
) -> Result<Vec<Row>> {
    let mut source = dataset::read(run)?;
    if let Some(positions) = positions {
        source.samples.retain(|s| at_any(s.stage_mm, positions));
        if source.samples.is_empty() {
            refuse!(
                "{}: no frames at the check's positions: the acceptance scan does not hold them",
                run.display()
            );
        }
    }
    source.samples = thinned(std::mem::take(&mut source.samples), EVAL_FRAMES);
    let mut predictor = Predictor::new(model, BackendKind::Tract, threads)?;
    let eval = evaluate(model, &mut predictor, &[source], None, None, |d, t| {
        host.frames(what, d, t)
    })
    .with_context(|| format!("evaluating the model on {}", run.display()))?;
    host.frames_end();
    Ok(eval.rows)
}

/// The figures, the verdict and its evidence, in lines.
fn report(a: &Assessment) -> Vec<String> {
    let mut lines = vec!["figures against their thresholds:".to_string()];
    for f in &a.figures {
        lines.push(format!("  {}", f.describe()));
    }
    lines.push(format!("verdict: {}", a.verdict.advice()));
    if a.verdict != Verdict::Ok {
        lines.push(format!("because: {}", a.diagnosis));
        for f in a.moved().filter(|f| f.finding != a.diagnosis) {
            lines.push(format!("  also: {} ({})", f.finding, f.action.name()));
        }
    }
    lines
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::commission::certificate::Certificate;

    /// A profile of `layered-3` made at `utc` from the run `source`.
    fn profile(utc: &str, source: &Path) -> String {
        format!(
            "sensor_id = \"layered-3\"\ncreated_utc = \"{utc}\"\nsource = \"{}\"\n\n[image]\nwidth = 960\nheight = 600\n\n[optical]\ncentre_x_px = 502.0\ncentre_y_px = 289.5\nshift_x_px = 22.0\nshift_y_px = -10.5\nradius_px = 252.5\ncrop_radius_px = 227.0\nsigma_x_px = 0.01\nsigma_y_px = 0.01\nsigma_radius_px = 0.013\nresidual_rms_px = 0.12\nframes = 46\n",
            source.display()
        )
    }

    #[test]
    fn a_unit_calibrated_again_after_its_commissioning_is_compared_with_that_calibration() {
        let root =
            std::env::temp_dir().join(format!("fringe-check-reference-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&root);
        let profiles = root.join("profiles");
        let dir = profiles.join("layered-3.commission-2026-11-20T09-00-00Z");
        let commissioned_run = dir.join("runs/calibration-layered-3");
        std::fs::create_dir_all(&commissioned_run).expect("dirs");
        let text = serde_json::json!({
            "format": 1, "fringe_version": "0.1.0", "issued_utc": "2026-11-20T09:30:00.000Z",
            "sensor_id": "layered-3", "pass": true, "failures": [],
            "figures": {"fz_rmse_n": 0.3, "contact_rmse_mm": 1.0, "shape_accuracy": 0.99,
                        "macro_f1": 0.99, "frames": 100, "presses": 6},
            "verdict": {}, "spec": {}, "spec_origin": "test",
            "base_model": {"path": "default", "sha256": "0", "describe": "test"},
            "model": "model.safetensors", "adaptation": "heads", "profile": "profile.toml",
            "runs": {"calibration": "runs/calibration-layered-3", "rounds": [], "acceptance": "runs/acceptance"},
            "learning_curve": [], "bench_s": 1.0, "compute_s": 1.0
        });
        std::fs::write(dir.join("certificate.json"), text.to_string()).expect("cert");
        let accepted = Commissioned {
            model: dir.join("model.safetensors"),
            certificate: Certificate::read(&dir).expect("certificate"),
            dir: dir.clone(),
        };
        let unit_profile = profiles.join("layered-3.toml");
        // The profile the commissioning wrote: the commissioning's scan.
        std::fs::write(
            &unit_profile,
            profile("2026-11-20T09:05:00.000Z", &commissioned_run),
        )
        .expect("profile");
        let r = reference_calibration(&accepted, &profiles, "layered-3");
        assert_eq!(
            (r.run, r.profile),
            (commissioned_run.clone(), dir.join(PROFILE))
        );
        // Calibrated again later, from a scan of its own: that scan is the reference.
        let later_run = root.join("runs/calibration-layered-3-later");
        std::fs::create_dir_all(&later_run).expect("run");
        let start =
            fringe_rig::store::RunReader::at(&later_run).path(fringe_rig::store::RunFile::Start);
        std::fs::write(start, "{}").expect("start");
        std::fs::write(
            &unit_profile,
            profile("2026-11-27T08:00:00.000Z", &later_run),
        )
        .expect("profile");
        let r = reference_calibration(&accepted, &profiles, "layered-3");
        assert_eq!((r.run, r.profile.clone()), (later_run, unit_profile));
        assert!(
            r.about.contains("made after its commissioning"),
            "{}",
            r.about
        );
        // A profile from an image folder (no run to measure) leaves the commissioning's.
        std::fs::write(
            profiles.join("layered-3.toml"),
            profile("2026-11-28T08:00:00.000Z", &root),
        )
        .expect("profile");
        assert_eq!(
            reference_calibration(&accepted, &profiles, "layered-3").run,
            commissioned_run
        );
        let _ = std::fs::remove_dir_all(&root);
    }
}
