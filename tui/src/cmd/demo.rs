//! `fringe demo`: the demonstration on the simulated bench, on the one scan engine: the built-in
//! plan `demo` (three presses to 1, 4 and 9 N; `--quick`: one press to 1 and 4 N) on a simulated
//! rig with the sensor and seed given, every frame labelled from the exposure strobe, stored in a
//! run and scored against the simulator's ground truth.

use crate::cmd::scan::execute;
use crate::global::Global;
use fringe_app::session::DEMO;
use fringe_app::simulation::{demo_completed, Demo};
use fringe_app::ProfileUse;
use fringe_rig::{scan::new_run_id, RunTarget};
use std::path::PathBuf;
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

pub fn run(args: DemoArgs, global: &Global) -> anyhow::Result<()> {
    let started = Instant::now();
    let demo = Demo::new(&args.sensor, args.seed, args.quick)?;
    println!(
        "fringe {}: demonstration on the simulated bench (sensor {}, seed {}); plan {}{}",
        env!("CARGO_PKG_VERSION"),
        args.sensor,
        args.seed,
        DEMO.origin(),
        if args.quick { ", quick" } else { "" }
    );
    let program = demo.program()?;
    let target = RunTarget::New {
        root: args.out.clone(),
        run_id: new_run_id(&demo.plan.name),
    };
    let end = execute(
        &demo.config,
        program,
        demo.plan_text,
        target,
        true,
        ProfileUse::Ignore,
        global,
        &mut |_| Ok(()),
    )?;
    let dir = end.outcome.run_dir.display();
    println!(
        "run written to {dir} in {:.1} s; check it with `fringe verify {dir}`, list runs with `fringe runs`",
        started.elapsed().as_secs_f64()
    );
    demo_completed(&end.outcome)?;
    Ok(())
}
