//! `fringe plans`: the built-in scan plans by name, each with its points, presses and estimated
//! time on the rig (`fringe scan NAME` runs one).

use crate::clock_text::clock;
use crate::global::Global;
use fringe_app::session::plan_summaries;
use fringe_app::RigConfig;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct PlansArgs {
    /// The rig file the times are estimated for (default: ./rig.toml if present, else the
    /// simulated bench).
    #[arg(long, value_name = "FILE")]
    rig: Option<PathBuf>,
}

pub fn run(args: PlansArgs, _global: &Global) -> anyhow::Result<()> {
    let (config, source) = RigConfig::resolve(args.rig.as_deref())?;
    let limits = config.limits()?;
    println!(
        "built-in plans (run one with `fringe scan NAME`, see it with `fringe scan NAME --dry-run`; commented copies in tui/app/plans/)"
    );
    println!("times estimated for the rig: {}", source.describe());
    let summaries = plan_summaries(&limits);
    let width = summaries
        .iter()
        .map(|s| s.plan.name.len())
        .max()
        .unwrap_or(0);
    for s in summaries {
        let what = match &s.fit {
            Ok(f) => format!(
                "{} point{}, {} press{} to {}, about {}",
                f.points,
                if f.points == 1 { "" } else { "s" },
                f.presses,
                if f.presses == 1 { "" } else { "es" },
                f.targets,
                clock(f.estimate.total)
            ),
            Err(e) => format!("does not fit this rig: {e}"),
        };
        println!("  {:<width$}  {what}: {}", s.plan.name, s.plan.about);
    }
    Ok(())
}
