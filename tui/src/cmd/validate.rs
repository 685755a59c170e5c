//! `fringe validate --no-tui [--model M] [--plan P] [--rig R] [--unit FILE|ID] [--report DIR]`: live validation
//! without the terminal UI. A scan plan drives the rig (the built-in short grid by default);
//! every labelled frame it records is offered to the model, and each prediction is set against
//! that frame's synchronised F/T label. At the end: the paper's metrics, the loop rate and the
//! frames skipped; with `--report DIR` the evaluation report (report.md, plots) and every frame
//! validated (validation.jsonl).

use crate::cmd::model::choose_model;
use crate::cmd::scan::execute;
use crate::cmd::unit_arg::UnitArg;
use crate::global::Global;
use anyhow::{bail, Context, Result};
use fringe_app::models::ForSensor;
use fringe_app::session;
use fringe_app::session::scan_plan;
use fringe_app::session::{LiveValidation, Validation};
use fringe_app::{Note, ProfileUse, RigConfig, RigSource};
use fringe_rig::Plan;
use fringe_rig::{scan::new_run_id, RunTarget};
use fringe_sensor_models::BackendKind;
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::time::Duration;

#[derive(clap::Args)]
pub struct ValidateArgs {
    /// The model: a .pth / .pt, .safetensors or .onnx file that `fringe model info` reads, or
    /// `builtin:NAME` (the models that ship with fringe, README.md "The default models"; `default` is
    /// `builtin:layered`). Default: the rig's sensor's commissioned model (`fringe commission`),
    /// else its design's two-stage model (`builtin:layered-two-stage`,
    /// `builtin:integrated-two-stage`). A model of another design is refused.
    #[arg(long, value_name = "FILE")]
    model: Option<PathBuf>,
    /// The scan plan that presses the sensor (default: the built-in short grid).
    #[arg(long, value_name = "FILE")]
    plan: Option<PathBuf>,
    /// The rig file (default: ./rig.toml if present, else the simulated bench).
    #[arg(long, value_name = "FILE")]
    rig: Option<PathBuf>,
    #[command(flatten)]
    unit: UnitArg,
    /// Directory that receives the run the plan records.
    #[arg(long, value_name = "DIR", default_value = "runs")]
    out: PathBuf,
    /// Write the evaluation report (report.md, plots) and validation.jsonl into DIR.
    #[arg(long, value_name = "DIR")]
    report: Option<PathBuf>,
    /// Inference backend: tract (built in), onnxruntime (cargo feature `onnxruntime`) or torch
    /// (cargo feature `torch`; also runs TorchScript modules).
    #[arg(long, default_value = "tract")]
    backend: BackendKind,
    /// Inference threads of each network (at most the machine's cores are used).
    #[arg(
        long,
        default_value_t = fringe_app::session::THREADS_PER_NETWORK,
        value_parser = crate::cmd::arg_values::threads
    )]
    threads: usize,
    /// Answer every operator prompt with "continue".
    #[arg(long)]
    yes: bool,
}

pub fn run(a: ValidateArgs, global: &Global) -> Result<()> {
    if let Some(report) = &a.report {
        fringe_rig::store::outside_runs(report).context("--report")?;
    }
    // The plan file given, else the built-in short grid.
    let (text, origin) = scan_plan(a.plan.as_deref(), None)?;
    let plan = Plan::parse(&text, &origin)?;
    let (config, source) = RigConfig::resolve(a.rig.as_deref())?;
    let config = a.unit.on(config)?;
    let unit = config.sensor_id().ok();
    let model = choose_model(
        a.model.as_deref(),
        &ForSensor {
            profiles: &config.profile_dir(),
            unit: unit.as_deref(),
            variant: config.sensor_variant()?,
            whose: "this sensor",
        },
    )?;
    // `--no-tui` (the command line's global flag): headless, as when stdout is no terminal.
    if !global.no_tui && std::io::stdout().is_terminal() {
        return run_ui(&a, &model.path, config, &source, text, origin);
    }
    let backend = fringe_sensor_models::Predictor::new(
        &model,
        a.backend,
        crate::cmd::arg_values::cap_threads(a.threads),
    )?;
    println!(
        "fringe {}: rig: {}",
        env!("CARGO_PKG_VERSION"),
        source.describe()
    );
    println!("plan: {origin}");
    println!("model: {} ({})", model.path.display(), model.describe());
    let program = plan.program(&config.limits()?, &origin)?;
    let run_id = new_run_id(&plan.name);
    let target = RunTarget::New {
        root: a.out.clone(),
        run_id: run_id.clone(),
    };
    let mut backend = Some(backend);
    let mut model = Some(model);
    let mut live: Option<LiveValidation> = None;
    let end = execute(
        &config,
        program,
        text,
        target,
        a.yes,
        ProfileUse::Consume,
        global,
        &mut |session| {
            let (Some(m), Some(b)) = (model.take(), backend.take()) else {
                bail!("the session was opened twice");
            };
            let (v, notes) = session.attach_validation(m, b, &run_id)?;
            for note in notes {
                match note {
                    Note::Info(line) => println!("{line}"),
                    Note::Warning(line) => eprintln!("warning: {line}"),
                }
            }
            live = Some(v);
            Ok(())
        },
    )?;
    let Some(live) = live else {
        bail!("the scan ended before live validation started");
    };
    let v = live.finish(Duration::from_secs(10));
    print_summary(&v);
    if let Some(dir) = &a.report {
        let written = session::write_validation_report(dir, &v, &end.outcome.run_dir)?;
        println!(
            "report written to {} ({} frames in {})",
            written.report.display(),
            v.frames.len(),
            written.frames.display()
        );
    }
    if let Some(why) = &v.state.failure {
        bail!("live validation stopped: {why}");
    }
    Ok(())
}

/// Live validation in the terminal UI, on its Validate screen (`--report` is refused: the
/// report is the headless run's).
fn run_ui(
    a: &ValidateArgs,
    model: &Path,
    config: RigConfig,
    source: &RigSource,
    text: String,
    origin: String,
) -> Result<()> {
    if a.report.is_some() {
        bail!("--report DIR writes the headless run's report: add --no-tui");
    }
    crate::ui::run(crate::ui::UiOptions {
        config,
        rig: source.short(),
        rig_note: source.describe(),
        plan_text: text,
        plan_origin: origin,
        runs: a.out.clone(),
        model: Some(crate::ui::ModelChoice {
            path: model.to_path_buf(),
            backend: a.backend,
            threads: crate::cmd::arg_values::cap_threads(a.threads),
        }),
        model_from_rig: a.model.is_none(),
        tab: crate::ui::screens::validate::TAB,
        start: false,
    })
}

fn print_summary(v: &Validation) {
    let s = &v.state;
    let e = &s.errors;
    println!(
        "live validation ({} backend): {} labelled frames offered, {} run, {} skipped; {:.1} predictions/s, {:.1} ms per frame",
        s.backend, s.offered, s.ran, s.skipped, s.loop_hz, s.latency_ms
    );
    if let Some(longest) = v.frames.iter().map(|f| f.waited_ms).max_by(f64::total_cmp) {
        println!(
            "frames waited for the network up to {longest:.0} ms (at most {} wait; then the oldest is skipped)",
            s.backlog
        );
    }
    if s.cut > 0 {
        println!(
            "{} frames validated during interrupted points were cut from the run with those points' records: they are not in these figures",
            s.cut
        );
    }
    if e.n > 0 {
        println!(
            "Fz RMSE {:.3} N over {} frames; contact RMSE {:.3} mm over {} frames in contact; shape accuracy {:.1} %",
            e.fz_rmse(),
            e.n,
            e.contact_rmse(),
            e.n_contact,
            100.0 * e.accuracy()
        );
    }
}
