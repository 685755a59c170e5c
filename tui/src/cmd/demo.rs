//! `fringe demo` (and `fringe` with no command): the main job on the simulated bench.
//!
//! Builds the simulated rig (real drivers over in-process links to the emulated controllers,
//! simulated DAQ with the exposure strobe, camera rendering photoelastic frames), presses the
//! indenter at a few points to 1, 4 and 9 N, records every frame of each dwell with its force
//! label into a run directory and scores the labels against the simulator's ground truth.

use super::sim_render::load_sensor;
use crate::Global;
use anyhow::Context;
use fringe_rig::scan::demo::{run_demo, DemoPlan};
use fringe_rig::sim::ground_truth::{TruthLog, TruthSink};
use fringe_rig::sim::rig::{SimRig, SimRigConfig};
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Instant;

#[derive(clap::Args)]
pub struct DemoArgs {
    /// Directory that receives the run.
    #[arg(long, value_name = "DIR", default_value = "runs")]
    out: PathBuf,
    /// Sensor build under the simulated camera: layered, integrated or a sensor TOML file.
    #[arg(
        long,
        value_name = "layered|integrated|PATH.toml",
        default_value = "layered"
    )]
    sensor: String,
    /// Seed of the simulated bench (same seed, same run).
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// One point and two force levels (a few seconds; for a quick look and for tests).
    #[arg(long)]
    quick: bool,
}

impl Default for DemoArgs {
    /// The same as the command-line defaults (what `fringe` with no command runs).
    fn default() -> Self {
        DemoArgs {
            out: PathBuf::from("runs"),
            sensor: "layered".into(),
            seed: 1,
            quick: false,
        }
    }
}

pub fn run(args: DemoArgs, _global: &Global) -> anyhow::Result<()> {
    let started = Instant::now();
    let sensor = load_sensor(&args.sensor)?;
    let config = SimRigConfig {
        seed: args.seed,
        sensor,
        ..SimRigConfig::default()
    };
    println!(
        "fringe {}: simulated bench (no rig file given; see README for real hardware)",
        env!("CARGO_PKG_VERSION")
    );
    let truth = TruthLog::new();
    let sink: Arc<dyn TruthSink> = truth.clone();
    let (rig, devices) =
        SimRig::start(&config, Some(sink)).context("cannot start the simulated bench")?;
    for line in &devices.description {
        println!("  {line}");
    }
    let mut plan = DemoPlan::default();
    if args.quick {
        plan.points.truncate(1);
        plan.targets.truncate(2);
        plan.dwell = std::time::Duration::from_millis(300);
    }
    let summary = run_demo(&rig, devices, truth, &args.out, &plan, &mut |line| {
        println!("{line}")
    })
    .context("the demonstration stopped")?;
    println!(
        "recorded {} labelled frames ({} presses, {} frames seen, {} dropped, {} without a label), {} force samples",
        summary.frames_recorded,
        summary.presses,
        summary.frames_seen,
        summary.dropped_frames,
        summary.frames_unlabelled,
        summary.force_samples
    );
    if let Some(rms) = summary.label_rms_error {
        println!(
            "force labels (mean over each exposure, from the strobe) against the simulator's truth: RMS error {:.3} N over {} frames",
            rms, summary.label_frames_scored
        );
    }
    println!(
        "run written to {} in {:.1} s; check it with `fringe verify {}`, list runs with `fringe runs`",
        summary.run_dir.display(),
        started.elapsed().as_secs_f64(),
        summary.run_dir.display()
    );
    Ok(())
}
