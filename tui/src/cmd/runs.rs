//! `fringe runs` and `fringe verify`: what runs exist and whether one is intact.

use crate::clock_text::clock;
use crate::global::Global;
use crate::signals::{Again, Signal};
use anyhow::Context;
use fringe_app::runs::{estimate_mcap_export, export_mcap, ClockSource, McapExportOptions};
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
    /// One run as an MCAP file as ROS 2 records it (ros2msg schemas, CDR, zstd), for Foxglove,
    /// `ros2 bag`, rosbags: NS/image (sensor_msgs/Image, the frames as stored: mono8, rgb8 or
    /// bayer_rggb8), NS/ft (geometry_msgs/WrenchStamped, every F/T sample, raw), NS/wrench,
    /// NS/contact (geometry_msgs/PointStamped, metres, only in contact) and NS/shape
    /// (vision_msgs/Classification): the labels; NS/events (rcl_interfaces/Log). Stamps are
    /// the recording host's Unix time.
    Mcap,
    /// WebDataset shards for training at scale: tar files of --shard-size samples, each a frame
    /// as stored in PNG (KEY.png; the raw Bayer mosaic in grey) and its labels in JSON
    /// (KEY.json: forces as recorded, contact, shape, press, the calibration geometry), with
    /// shards.json listing them; WebDataset readers stream them from object storage.
    Webdataset,
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
#[command(after_help = MCAP_TOPICS)]
pub struct ExportArgs {
    /// Run directories, exported in the order given (one run for --format mcap).
    #[arg(required = true)]
    runs: Vec<PathBuf>,
    #[arg(long, value_enum, default_value = "reference")]
    format: ExportFormat,
    /// Output directory (created); for --format mcap, the .mcap file (created, never replaced).
    #[arg(long, value_name = "DIR|FILE")]
    out: PathBuf,
    /// --format mcap: the topics' namespace.
    #[arg(long, value_name = "NS", default_value = "/fringe")]
    namespace: String,
    /// --format mcap: the sensor's frame id (the labels'); the images are in ID_camera, the F/T
    /// samples in ID_ft.
    #[arg(long, value_name = "ID", default_value = "fringe_sensor")]
    frame_id: String,
    /// Round forces, torques and positions to this step (the reference trained on 0.1); without
    /// it they are written at the measurement's precision (forces to 1 mN, torques to 10 uN m,
    /// positions to 1 um).
    #[arg(long, value_name = "STEP", value_parser = crate::cmd::arg_values::round_step)]
    round: Option<f64>,
    /// How the TIFF images are compressed (all read by PIL and OpenCV).
    #[arg(long, value_enum, default_value = "lzw")]
    compression: Compression,
    /// --format webdataset: samples in each shard.
    #[arg(long, value_name = "N", default_value_t = 1000)]
    shard_size: usize,
    /// Export runs that fail `fringe verify` too (their problems go into 0.export.json).
    #[arg(long)]
    allow_unverified: bool,
}

/// The topics of `--format mcap`, after `fringe export --help`.
const MCAP_TOPICS: &str = "\
--format mcap writes these topics (NS is --namespace, /fringe by default):
  NS/image    sensor_msgs/msg/Image            every frame, its pixels as stored (mono8, rgb8,
                                               bayer_rggb8: lossless; Foxglove demosaics)
  NS/ft       geometry_msgs/msg/WrenchStamped  every F/T sample at its full rate, raw (N, N m)
  NS/wrench   geometry_msgs/msg/WrenchStamped  each frame's label: the force over its exposure
  NS/contact  geometry_msgs/msg/PointStamped   the label's contact point, metres, in contact only
  NS/shape    vision_msgs/msg/Classification   the label's indenter (None off contact)
  NS/events   rcl_interfaces/msg/Log           the run's events (pauses, warnings, points done)
Frames and labels are stamped at the middle of the frame's exposure; every stamp is the Unix
time of the host that recorded the run (its monotonic clock placed by the events' wall-clock
times), so the file lines up with a robot's logs from the same clock.";

pub fn run_export(args: ExportArgs, global: &Global) -> anyhow::Result<()> {
    if let ExportFormat::Mcap = args.format {
        return run_export_mcap(args, global);
    }
    if let ExportFormat::Webdataset = args.format {
        return run_export_webdataset(args);
    }
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

/// `fringe export RUN... --format webdataset --shard-size N --out DIR`.
fn run_export_webdataset(args: ExportArgs) -> anyhow::Result<()> {
    if args.round.is_some() {
        anyhow::bail!(
            "--round is for --format reference; WebDataset shards keep every value as measured"
        );
    }
    let options = fringe_app::runs::ShardOptions {
        shard_size: args.shard_size,
        cancel: Some(crate::signals::catch(
            &[Signal::Interrupt, Signal::Terminate, Signal::HangUp],
            Again::Counts,
        )),
    };
    let terminal = std::io::stderr().is_terminal();
    let mut in_place = false;
    let summary = fringe_app::runs::export_shards(&args.runs, &args.out, &options, |k| {
        if k % 250 == 0 {
            if terminal {
                eprint!("\r{k} samples");
                in_place = true;
            } else {
                eprintln!("{k} samples");
            }
        }
    });
    if in_place {
        eprintln!();
    }
    let summary = summary?;
    if summary.skipped_damaged > 0 {
        eprintln!(
            "warning: {} records left out, their frames missing or damaged (see `fringe verify RUN`)",
            summary.skipped_damaged
        );
    }
    println!(
        "exported {} samples in {} shards of up to {} to {}",
        summary.samples,
        summary.shards.len(),
        args.shard_size,
        args.out.display()
    );
    println!("index: {}", summary.index.display());
    Ok(())
}

/// `fringe export RUN --format mcap --out FILE`.
fn run_export_mcap(args: ExportArgs, _global: &Global) -> anyhow::Result<()> {
    let [run] = args.runs.as_slice() else {
        anyhow::bail!(
            "--format mcap exports one run into one file, {} were given (export each to its own file)",
            args.runs.len()
        );
    };
    if args.round.is_some() {
        anyhow::bail!(
            "--round is for --format reference; an MCAP export keeps every value as measured"
        );
    }
    let options = McapExportOptions {
        namespace: args.namespace.clone(),
        frame_id: args.frame_id.clone(),
        allow_unverified: args.allow_unverified,
        // Ctrl-C, SIGTERM or a hang-up stop the export and remove what it wrote.
        cancel: Some(crate::signals::catch(
            &[Signal::Interrupt, Signal::Terminate, Signal::HangUp],
            Again::Counts,
        )),
    };
    // What it will write, before it starts (a run that cannot be read is the export's to report).
    if let Ok(e) = estimate_mcap_export(run, &args.out, &options) {
        println!(
            "export: {} frames, {} F/T samples, {} labels ({} in contact), {} events; expected {} (MCAP, zstd; measured on {} of the frames) in about {}",
            e.counts.frames,
            e.counts.force_samples,
            e.counts.labels,
            e.counts.contacts,
            e.counts.events,
            human(e.bytes),
            e.sampled_frames,
            clock(e.time)
        );
    }
    let terminal = std::io::stderr().is_terminal();
    let mut in_place = false;
    let summary = export_mcap(run, &args.out, &options, |p| {
        if p.frames % 250 == 0 || p.frames == p.of {
            if terminal {
                eprint!("\r{} of {} frames", p.frames, p.of);
                in_place = true;
            } else {
                eprintln!("{} of {} frames", p.frames, p.of);
            }
        }
    });
    if in_place {
        eprintln!();
    }
    let s = summary.with_context(|| format!("cannot export {} to MCAP", run.display()))?;
    if !s.problems.is_empty() {
        eprintln!(
            "warning: {} fails verify ({} problem(s), exported as --allow-unverified asked; see `fringe verify {}`)",
            run.display(),
            s.problems.len(),
            run.display()
        );
        for p in &s.problems {
            eprintln!("  {p}");
        }
    }
    let c = s.counts;
    println!(
        "exported {} to {} ({}): {} frames, {} F/T samples, {} labels ({} in contact), {} events",
        run.display(),
        s.path.display(),
        human(s.bytes),
        c.frames,
        c.force_samples,
        c.labels,
        c.contacts,
        c.events
    );
    if s.without_label > 0 {
        println!(
            "{} frames have no label (not valid, or no force over their exposure): their image only",
            s.without_label
        );
    }
    println!(
        "topics: {} {} {} {} {} {}",
        s.topics.image,
        s.topics.ft,
        s.topics.wrench,
        s.topics.contact,
        s.topics.shape,
        s.topics.events
    );
    match s.clock.source {
        ClockSource::Events => println!(
            "stamps: Unix time of the recording host, within {} us (the run's events){}",
            s.clock.uncertainty.as_micros(),
            if s.clock.processes > 1 {
                format!(", {} processes (resumed)", s.clock.processes)
            } else {
                String::new()
            }
        ),
        ClockSource::StartDocument => println!(
            "stamps: Unix time of the recording host from the run's start time (the run has no events: to a fraction of a second)"
        ),
    }
    Ok(())
}
