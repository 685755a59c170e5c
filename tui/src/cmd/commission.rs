//! `fringe commission [--rig R] [--unit FILE|ID] [--base MODEL] [--budget MINUTES] [--spec FILE|paper]`: a sensor
//! unit taken from first light to a verdict in one job. The calibration scan and the unit's
//! profile; rounds of presses chosen where the model errs most or has not pressed, each round
//! predicted by the model as adapted so far before it is adapted on (the learning curve);
//! the model's heads adapted to the unit in pure Rust; an acceptance scan at held-out positions
//! judged against the spec; everything kept in one directory beside the unit's profile with
//! `certificate.json` and `report.md`. `--resume DIR` goes on after Ctrl-C or a crash from the
//! runs already recorded.

use crate::cmd::terminal_host::Terminal;
use crate::cmd::unit_arg::UnitArg;
use crate::global::Global;
use anyhow::{bail, Result};
use fringe_app::commission;
use fringe_app::commission::{
    NewCommissioning, Request, DEFAULT_ACCEPTANCE_PRESSES, DEFAULT_ROUND_PRESSES, DEFAULT_SEED,
};
use fringe_app::models::PAPER;
use fringe_app::RigConfig;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct CommissionArgs {
    /// The rig file (default: ./rig.toml if present, else the simulated bench). The unit is the
    /// rig's sensor (its `sensor` key, or the simulated sensor's id).
    #[arg(long, value_name = "FILE")]
    rig: Option<PathBuf>,
    #[command(flatten)]
    unit: UnitArg,
    /// The model to adapt: a weights file of the paper's networks, or `builtin:NAME`. Default:
    /// the keypoint CNN that ships for the sensor's design (builtin:layered-keypoint,
    /// builtin:integrated).
    #[arg(long, conflicts_with = "resume", value_name = "MODEL")]
    base: Option<PathBuf>,
    /// Bench time for the adaptive presses, minutes (the calibration and acceptance scans come
    /// on top); default 10. With --resume: the new budget of the commissioning resumed.
    #[arg(long, value_name = "MINUTES")]
    budget: Option<f64>,
    /// What the unit must meet: a spec file (TOML; see `fringe eval --spec`) or `paper` (the
    /// paper's custom-CNN row: Fz < 0.49 N, contact < 1.47 mm, shape > 95.3 %).
    #[arg(
        long,
        conflicts_with = "resume",
        value_name = "FILE",
        default_value = PAPER
    )]
    spec: String,
    /// Positions pressed per adaptive round (each with every indenter of the model).
    #[arg(long, conflicts_with = "resume", value_name = "N", default_value_t = DEFAULT_ROUND_PRESSES as u64, value_parser = clap::value_parser!(u64).range(1..=100))]
    round_presses: u64,
    /// Held-out positions of the acceptance scan (each with every indenter).
    #[arg(long, conflicts_with = "resume", value_name = "N", default_value_t = DEFAULT_ACCEPTANCE_PRESSES as u64, value_parser = clap::value_parser!(u64).range(2..=200))]
    acceptance_presses: u64,
    /// Also train the custom CNN's last convolution block with the heads (pure Rust, a minute or
    /// two more), kept only when it beats the heads alone on held-out presses; for a custom CNN
    /// base only (--base builtin:layered).
    #[arg(long, conflicts_with = "resume")]
    last_block: bool,
    /// Also fine-tune every layer of the adapted model with libtorch (builds with the torch
    /// feature; several minutes on 2 cores), one fold of presses held out; kept only when it
    /// beats the heads alone on them. With --resume: turns it on for that commissioning, nothing
    /// is pressed again.
    #[arg(long)]
    fine_tune: bool,
    /// Seed of the adaptation's cross-validation folds.
    #[arg(long, conflicts_with = "resume", default_value_t = DEFAULT_SEED)]
    seed: u64,
    /// Go on with the commissioning in DIR (after Ctrl-C, a crash or power loss) from the runs it
    /// recorded; its options are the ones it started with.
    #[arg(long, value_name = "DIR")]
    resume: Option<PathBuf>,
    /// Inference threads (at most the machine's cores are used).
    #[arg(long, default_value_t = 2, value_parser = crate::cmd::arg_values::threads)]
    threads: usize,
    /// Answer every operator prompt with "continue": unattended (a scan the engine stops by
    /// itself, a point camera drops kept spoiling, is resumed by the job, at most twice).
    #[arg(long)]
    yes: bool,
    /// Say what the commissioning would take (presses, bench time, computation, disk) and stop:
    /// nothing is made, nothing moves.
    #[arg(long)]
    dry_run: bool,
    /// Keep every round's frames after a pass (by default they are pruned, their features and
    /// records kept; the calibration and acceptance scans are always kept whole).
    #[arg(long)]
    keep_runs: bool,
}

pub fn run(a: CommissionArgs, global: &Global) -> Result<()> {
    let (config, source) = RigConfig::resolve(a.rig.as_deref())?;
    let config = a.unit.on(config)?;
    let sensor = config.sensor_id()?;
    println!(
        "fringe {}: commissioning of sensor {sensor} on rig: {}",
        env!("CARGO_PKG_VERSION"),
        source.describe()
    );
    let request = match a.resume {
        Some(dir) => Request::Resume {
            dir,
            budget_min: a.budget,
            fine_tune: a.fine_tune,
        },
        None => Request::New(NewCommissioning {
            base: a.base,
            budget_min: a.budget,
            spec: a.spec,
            round_presses: a.round_presses as usize,
            acceptance_presses: a.acceptance_presses as usize,
            last_block: a.last_block,
            fine_tune: a.fine_tune,
            seed: a.seed,
        }),
    };
    if a.dry_run {
        let cost = commission::dry_run(&request, &config, a.keep_runs, &mut |w| {
            eprintln!("warning: {w}")
        })?;
        for line in cost.lines() {
            println!("{line}");
        }
        println!("dry run: nothing was made and nothing moved");
        return Ok(());
    }
    let prepared = commission::prepare(&request, &config, &mut |w| eprintln!("warning: {w}"))?
        .keep_runs(a.keep_runs);
    if let Some(line) = prepared.resumed() {
        println!("{line}");
    }
    println!("commissioning directory: {}", prepared.dir().display());
    // The same rig and unit again: a resume on another is refused.
    let again: String = [
        ("--rig", a.rig.as_ref().map(|r| r.display().to_string())),
        ("--unit", a.unit.unit.clone()),
    ]
    .into_iter()
    .filter_map(|(flag, v)| v.map(|v| format!(" {flag} {v}")))
    .collect();
    println!(
        "  (after Ctrl-C or a crash: fringe commission{again} --resume {})",
        prepared.dir().display()
    );
    let mut host = Terminal::new(global, a.yes);
    let threads = crate::cmd::arg_values::cap_threads(a.threads);
    let accepted = commission::run(prepared, config, threads, &mut host)?;
    if !accepted.pass {
        bail!(
            "sensor {} fails the spec ({}): {}; the certificate says where ({})",
            accepted.sensor,
            accepted.spec_origin,
            accepted.failures.join("; "),
            accepted.certificate.display()
        );
    }
    println!(
        "sensor {} is commissioned: fringe validate and fringe eval use {} for it by default",
        accepted.sensor,
        accepted.model.display()
    );
    Ok(())
}
