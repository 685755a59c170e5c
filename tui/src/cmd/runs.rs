//! `fringe runs` and `fringe verify`: what runs exist and whether one is intact.

use crate::clock_text::clock;
use crate::global::Global;
use crate::signals::{Again, Signal};
use anyhow::Context;
use fringe_app::runs::{list_runs, ListedRun};
use fringe_rig::store::human_bytes as human;
use fringe_rig::store::verify_run as verify;
use fringe_rig::store::ExitStatus;
use fringe_rig::store::ImageCompression;
use std::io::IsTerminal;
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
    if !args.root.is_dir() {
        anyhow::bail!(
            "{}: no such directory (give the directory that holds the runs with --root DIR; scans write to ./runs unless told otherwise)",
            args.root.display()
        );
    }
    let (runs, unreadable) = list_runs(&args.root)
        .with_context(|| format!("cannot list runs in {}", args.root.display()))?;
    if runs.is_empty() && unreadable.is_empty() {
        println!("no runs in {}", args.root.display());
        return Ok(());
    }
    println!(
        "{:<32} {:<24} {:<16} {:>7} {:>8}  status",
        "run (directory)", "started (UTC)", "sensor", "frames", "size"
    );
    for ListedRun {
        run: r,
        name,
        bytes,
    } in &runs
    {
        let mut status = match &r.stop {
            None => "unfinished (resumable)".to_string(),
            Some(s) => match s.exit_status {
                ExitStatus::Completed => "completed".to_string(),
                ExitStatus::Aborted => format!("aborted: {}", s.reason),
                ExitStatus::Failed => format!("failed: {}", s.reason),
            },
        };
        // The directory is what the other commands take; a copied run keeps its run id.
        if *name != r.start.run_id {
            status.push_str(&format!(" (run id {})", r.start.run_id));
        }
        // "?" when the directory cannot be read to the end.
        let size = bytes.map_or_else(|| "?".to_string(), human);
        println!(
            "{:<32} {:<24} {:<16} {:>7} {:>8}  {status}",
            name, r.start.started_utc, r.start.sensor_id, r.frames, size
        );
    }
    for u in &unreadable {
        println!("unreadable: {u}");
    }
    Ok(())
}

pub fn run_verify(args: VerifyArgs, _global: &Global) -> anyhow::Result<()> {
    let report = verify(&args.run)?;
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
    let run = args.run.display();
    if let Some(holder) = &report.writer {
        println!("  it is being written ({holder}): let it end, then: fringe verify {run}");
    } else if !report.ended {
        println!("  resume it: fringe scan PLAN --resume {run}");
    } else if report.manifest_missing && report.problems.len() == 1 {
        println!("  resume it to write the manifest: fringe scan --resume {run}");
    } else if report.manifest_missing {
        // A manifest written now would vouch for what is wrong above.
        println!(
            "  mend the problems above first (restore damaged files from a backup); then `fringe scan --resume {run}` writes the manifest"
        );
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

/// `--compression` of `fringe export`.
#[derive(Clone, Copy, clap::ValueEnum)]
pub enum Compression {
    /// LZW with the horizontal predictor (the smallest at the export's pace).
    Lzw,
    /// Deflate (its fastest level) with the horizontal predictor.
    Deflate,
    /// Uncompressed (as exports were written before).
    None,
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
    /// Round forces, torques and positions to this step (the reference trained on 0.1); without
    /// it they are written at the measurement's precision (forces to 1 mN, torques to 10 uN m,
    /// positions to 1 um).
    #[arg(long, value_name = "STEP", value_parser = crate::cmd::arg_values::round_step)]
    round: Option<f64>,
    /// How the TIFF images are compressed (all read by PIL and OpenCV).
    #[arg(long, value_enum, default_value = "lzw")]
    compression: Compression,
    /// Export runs that fail `fringe verify` too (their problems go into 0.export.json).
    #[arg(long)]
    allow_unverified: bool,
}

pub fn run_export(args: ExportArgs, _global: &Global) -> anyhow::Result<()> {
    let ExportFormat::Reference = args.format;
    let options = fringe_rig::store::ExportOptions {
        round: args.round,
        compression: match args.compression {
            Compression::Deflate => ImageCompression::Deflate,
            Compression::Lzw => ImageCompression::Lzw,
            Compression::None => ImageCompression::None,
        },
        allow_unverified: args.allow_unverified,
        // Ctrl-C, SIGTERM or a hang-up stop the export and remove what it wrote.
        cancel: Some(crate::signals::catch(
            &[Signal::Interrupt, Signal::Terminate, Signal::HangUp],
            Again::Counts,
        )),
    };
    // What it will write, before it starts (a run that cannot be read is the export's to report).
    if let Ok(e) = fringe_rig::store::estimate_export(&args.runs, &options) {
        println!(
            "export: {} images, expected {} ({} TIFF, measured on {} of the frames) in about {}",
            e.images,
            human(e.bytes),
            options.compression.name(),
            e.sampled,
            clock(e.time)
        );
    }
    // On a terminal the count is rewritten in place; otherwise one line per report.
    let terminal = std::io::stderr().is_terminal();
    let mut in_place = false;
    let summary = fringe_rig::store::export_reference(&args.runs, &args.out, &options, |k| {
        if k % 250 == 0 {
            if terminal {
                eprint!("\r{k} images");
                in_place = true;
            } else {
                eprintln!("{k} images");
            }
        }
    });
    if in_place {
        eprintln!();
    }
    let summary = summary?;
    for r in summary.runs.iter().filter(|r| !r.problems.is_empty()) {
        eprintln!(
            "warning: {} fails verify ({} problem(s), exported as --allow-unverified asked; see `fringe verify {}`)",
            r.dir,
            r.problems.len(),
            r.dir
        );
    }
    if summary.skipped_damaged > 0 {
        eprintln!(
            "warning: {} records left out, their frames missing or damaged (each listed in {})",
            summary.skipped_damaged,
            summary.provenance.display()
        );
    }
    if summary.skipped_duplicates > 0 {
        eprintln!(
            "warning: {} duplicated records left out (each record is exported once)",
            summary.skipped_duplicates
        );
    }
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
