//! `fringe check [--rig R] [--unit FILE|ID]`: a unit checked against what it was accepted with (its
//! newest passing commissioning certificate) in at most two minutes of bench time: a few of its
//! acceptance positions pressed again with every indenter; the optics, light and surface of its
//! no-contact frames, its F/T zero and its model's errors compared; a verdict with the evidence,
//! appended to the unit's history (the workflow: `fringe_app::health::run`). `--history`
//! shows the history and plots it.

use crate::cmd::terminal_host::Terminal;
use crate::cmd::unit_arg::{self, UnitArg};
use crate::global::Global;
use anyhow::{bail, Result};
use fringe_app::health;
use fringe_app::health::history_path;
use fringe_app::health::Verdict;
use fringe_app::RigConfig;
use std::path::{Path, PathBuf};

#[derive(clap::Args)]
pub struct CheckArgs {
    /// The rig file (default: ./rig.toml if present, else the simulated bench).
    #[arg(long, value_name = "FILE")]
    rig: Option<PathBuf>,
    #[command(flatten)]
    unit: UnitArg,
    /// The unit to check, as --unit (kept from before --unit).
    #[arg(long, value_name = "ID", conflicts_with = "unit")]
    sensor: Option<String>,
    /// Show the unit's history of checks and plot it (<profiles>/<sensor>.health.png); nothing
    /// moves.
    #[arg(long)]
    history: bool,
    /// Directory that receives the check's run.
    #[arg(long, value_name = "DIR", default_value = "runs")]
    out: PathBuf,
    /// Inference threads (at most the machine's cores are used).
    #[arg(long, default_value_t = 2, value_parser = crate::cmd::arg_values::threads)]
    threads: usize,
    /// Answer every operator prompt with "continue".
    #[arg(long)]
    yes: bool,
}

pub fn run(a: CheckArgs, global: &Global) -> Result<()> {
    let (config, source) = RigConfig::resolve(a.rig.as_deref())?;
    let config = match (&a.unit.unit, &a.sensor) {
        (None, Some(s)) => unit_arg::on("--sensor", Some(s), config)?,
        _ => a.unit.on(config)?,
    };
    let sensor = health::unit_to_check(&config, None)?;
    let profiles = config.profile_dir();
    if a.history {
        return show(&profiles, &sensor);
    }
    println!(
        "fringe {}: health check of sensor {sensor} on rig: {}",
        env!("CARGO_PKG_VERSION"),
        source.describe()
    );
    let mut host = Terminal::new(global, a.yes);
    let threads = crate::cmd::arg_values::cap_threads(a.threads);
    let checked = health::run(&config, &sensor, &a.out, threads, &mut host)?;
    println!(
        "appended to {} (fringe check --history shows it)",
        checked.history.display()
    );
    println!(
        "report: {} (one file: opens in any browser)",
        checked.report.display()
    );
    let assessment = checked.assessment;
    if assessment.verdict != Verdict::Ok {
        bail!(
            "sensor {sensor}: {}: {}",
            assessment.verdict.advice(),
            assessment.diagnosis
        );
    }
    Ok(())
}

/// `fringe check --history`: the unit's checks as a table, and the picture of them.
fn show(profiles: &Path, sensor: &str) -> Result<()> {
    let path = history_path(profiles, sensor);
    let h = health::read_history(&path)?;
    for n in &h.notes {
        eprintln!("warning: {n}");
    }
    if h.entries.is_empty() {
        bail!(
            "{}: no checks of sensor {sensor} yet (fringe check --rig R makes one)",
            path.display()
        );
    }
    println!("{}", heading(h.entries.len(), sensor, &path));
    println!(
        "{:>3}  {:<20}  {:<12}  {:>8}  {:>7}  {:>6}  {:>6}  {:>5}  {:>7}  diagnosis",
        "#", "checked (UTC)", "verdict", "centre px", "zero N", "rim", "side", "cells", "gain"
    );
    for (k, e) in h.entries.iter().enumerate() {
        let f = |key: &str| e.figure(key).unwrap_or(f64::NAN);
        println!(
            "{:>3}  {:<20}  {:<12}  {:>8.2}  {:>7.3}  {:>6.2}  {:>6.2}  {:>5.0}  {:>7.3}  {}",
            k + 1,
            e.checked_utc.chars().take(19).collect::<String>(),
            e.verdict().name(),
            f("centre_shift_px"),
            f("force_zero_n"),
            f("darkest_rim"),
            f("darkest_side"),
            f("surface_cells"),
            f("force_gain_change"),
            e.assessment.diagnosis
        );
    }
    let out = health::write_history_plot(profiles, sensor, &h.entries)?;
    println!(
        "wrote {} (each figure over the checks, its threshold in red)",
        out.display()
    );
    Ok(())
}

/// The table's heading: `2 checks of sensor S (PATH)`, `1 check of ...`.
fn heading(checks: usize, sensor: &str, path: &Path) -> String {
    format!(
        "{checks} {} of sensor {sensor} ({})",
        if checks == 1 { "check" } else { "checks" },
        path.display()
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_heading_counts_checks_in_words() {
        let path = Path::new("profiles/layered-3.health.jsonl");
        assert_eq!(
            heading(1, "layered-3", path),
            "1 check of sensor layered-3 (profiles/layered-3.health.jsonl)"
        );
        assert_eq!(
            heading(2, "layered-3", path),
            "2 checks of sensor layered-3 (profiles/layered-3.health.jsonl)"
        );
    }
}
