//! `fringe runs` and `fringe verify`: what runs exist and whether one is intact.

use crate::Global;
use anyhow::Context;
use fringe_rig::store::documents::ExitStatus;
use fringe_rig::store::run_list::list;
use fringe_rig::store::verify::verify;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct RunsArgs {
    /// Directory holding the runs.
    #[arg(long, value_name = "DIR", default_value = "runs")]
    root: PathBuf,
}

#[derive(clap::Args)]
pub struct VerifyArgs {
    /// The run directory to check.
    run: PathBuf,
}

pub fn run_list(args: RunsArgs, _global: &Global) -> anyhow::Result<()> {
    let (runs, unreadable) =
        list(&args.root).with_context(|| format!("cannot list runs in {}", args.root.display()))?;
    if runs.is_empty() && unreadable.is_empty() {
        println!("no runs in {}", args.root.display());
        return Ok(());
    }
    println!(
        "{:<32} {:<24} {:<16} {:>7}  status",
        "run", "started (UTC)", "sensor", "frames"
    );
    for r in &runs {
        let status = match &r.stop {
            None => "unfinished (resumable)".to_string(),
            Some(s) => match s.exit_status {
                ExitStatus::Completed => "completed".to_string(),
                ExitStatus::Aborted => format!("aborted: {}", s.reason),
                ExitStatus::Failed => format!("failed: {}", s.reason),
            },
        };
        println!(
            "{:<32} {:<24} {:<16} {:>7}  {status}",
            r.start.run_id, r.start.started_utc, r.start.sensor_id, r.frames
        );
    }
    for u in &unreadable {
        println!("unreadable: {u}");
    }
    Ok(())
}

pub fn run_verify(args: VerifyArgs, _global: &Global) -> anyhow::Result<()> {
    let report = verify(&args.run)
        .with_context(|| format!("{} is not a readable run", args.run.display()))?;
    println!(
        "run {}: {} frames, {} force samples, {}",
        report.run_id,
        report.frames,
        report.force_samples,
        if report.ended { "ended" } else { "not ended" }
    );
    if report.ok() {
        println!("ok: every file matches the manifest and the records are complete");
        return Ok(());
    }
    for p in &report.problems {
        println!("  problem: {p}");
    }
    anyhow::bail!(
        "run {} has {} problem(s)",
        args.run.display(),
        report.problems.len()
    )
}

/// Layouts `fringe export` writes.
#[derive(Clone, Copy, clap::ValueEnum)]
pub enum ExportFormat {
    /// `0.images/image_K.tiff` + `0.labels.csv`, as the paper's training code reads.
    Reference,
}

#[derive(clap::Args)]
pub struct ExportArgs {
    /// Run directories, exported in the order given.
    #[arg(required = true)]
    runs: Vec<PathBuf>,
    #[arg(long, value_enum, default_value = "reference")]
    format: ExportFormat,
    /// Output directory (created).
    #[arg(long, value_name = "DIR")]
    out: PathBuf,
    /// Round forces, torques and positions to this step (the reference trained on 0.1).
    #[arg(long, value_name = "STEP")]
    round: Option<f64>,
}

pub fn run_export(args: ExportArgs, _global: &Global) -> anyhow::Result<()> {
    if let Some(step) = args.round {
        if !(step.is_finite() && step > 0.0) {
            anyhow::bail!("--round {step}: give a positive step such as 0.1");
        }
    }
    for run in &args.runs {
        let report =
            verify(run).with_context(|| format!("{} is not a readable run", run.display()))?;
        if !report.ok() {
            eprintln!(
                "warning: {} has {} problem(s) (see `fringe verify {}`); exporting what is there",
                run.display(),
                report.problems.len(),
                run.display()
            );
        }
    }
    let ExportFormat::Reference = args.format;
    let options = fringe_rig::store::export::ExportOptions { round: args.round };
    let summary =
        fringe_rig::store::export::export_reference(&args.runs, &args.out, &options, |k| {
            if k % 250 == 0 {
                eprint!("\r{k} images");
            }
        })?;
    eprintln!();
    println!(
        "exported {} images ({} without contact) to {}; {} invalid frames left out",
        summary.images,
        summary.without_contact,
        summary.labels.display(),
        summary.skipped_invalid
    );
    println!(
        "provenance (runs, sensors, calibration profiles): {}",
        summary.provenance.display()
    );
    let mut profiles: Vec<&Option<String>> = summary
        .runs
        .iter()
        .map(|r| &r.calibration_profile)
        .collect();
    profiles.sort();
    profiles.dedup();
    for r in summary
        .runs
        .iter()
        .filter(|r| r.calibration_profile.is_none())
    {
        eprintln!(
            "warning: run {} used no calibration profile: its contact positions are relative to the rig file's origin (run `fringe calibrate --sensor {}`)",
            r.dir, r.sensor_id
        );
    }
    if profiles.len() > 1 {
        eprintln!(
            "warning: the exported runs used {} different calibration profiles (or none); their contact positions may not share one origin (see {})",
            profiles.len(),
            summary.provenance.display()
        );
    }
    Ok(())
}
