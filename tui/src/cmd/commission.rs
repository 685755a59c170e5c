//! `fringe commission [--rig R] [--base MODEL] [--budget MINUTES] [--spec FILE|paper]`: a sensor
//! unit taken from first light to a verdict in one job. The calibration scan and the unit's
//! profile; rounds of presses chosen where the model errs most or has not pressed, each round
//! predicted by the model as adapted so far before it is adapted on (the learning curve);
//! the model's heads adapted to the unit in pure Rust; an acceptance scan at held-out positions
//! judged against the spec; everything kept in one directory beside the unit's profile with
//! `certificate.json` and `report.md`. `--resume DIR` goes on after Ctrl-C or a crash from the
//! runs already recorded.

mod certify;
mod last_block;
mod rounds;
pub(crate) mod session;

use crate::global::Global;
use anyhow::{bail, Context, Result};
use fringe_app::calibration_scan::{
    calibrate_run, spot_settings, CalibrationGrid, DEFAULT_MAX_FRAMES,
};
use fringe_app::commission::certificate::{directory_name, PROFILE};
use fringe_app::commission::journal::{Journal, Options, ScanEntry};
use fringe_app::{ProfileUse, RigConfig};
use fringe_calibration::profile::Profile;
use fringe_sensor_models::acceptance::Spec;
use session::{estimate_s, scan, set_aside, Commissioning};
use std::path::{Path, PathBuf};

#[derive(clap::Args)]
pub struct CommissionArgs {
    /// The rig file (default: ./rig.toml if present, else the simulated bench). The unit is the
    /// rig's sensor (its `sensor` key, or the simulated sensor's id).
    #[arg(long, value_name = "FILE")]
    rig: Option<PathBuf>,
    /// The model to adapt: a weights file of the paper's networks, or `builtin:NAME`. Default:
    /// the model that ships for the sensor's design.
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
        default_value = "paper"
    )]
    spec: String,
    /// Positions pressed per adaptive round (each with every indenter of the model).
    #[arg(long, conflicts_with = "resume", value_name = "N", default_value_t = 6, value_parser = clap::value_parser!(u64).range(1..=100))]
    round_presses: u64,
    /// Held-out positions of the acceptance scan (each with every indenter).
    #[arg(long, conflicts_with = "resume", value_name = "N", default_value_t = 10, value_parser = clap::value_parser!(u64).range(2..=200))]
    acceptance_presses: u64,
    /// Also train the custom CNN's last convolution block with the heads (pure Rust, a minute or
    /// two more), kept only when it beats the heads alone on held-out presses.
    #[arg(long, conflicts_with = "resume")]
    last_block: bool,
    /// Seed of the adaptation's cross-validation folds.
    #[arg(long, conflicts_with = "resume", default_value_t = 42)]
    seed: u64,
    /// Go on with the commissioning in DIR (after Ctrl-C, a crash or power loss) from the runs it
    /// recorded; its options are the ones it started with.
    #[arg(long, value_name = "DIR")]
    resume: Option<PathBuf>,
    /// Inference threads (at most the machine's cores are used).
    #[arg(long, default_value_t = 2, value_parser = crate::cmd::arg_values::threads)]
    threads: usize,
    /// Answer every operator prompt with "continue".
    #[arg(long)]
    yes: bool,
}

pub fn run(a: CommissionArgs, global: &Global) -> Result<()> {
    let (config, source) = RigConfig::resolve(a.rig.as_deref())?;
    let sensor = config.sensor_id()?;
    println!(
        "fringe {}: commissioning of sensor {sensor} on rig: {}",
        env!("CARGO_PKG_VERSION"),
        source.describe()
    );
    let (dir, journal) = match &a.resume {
        Some(dir) => resumed(dir, &sensor, a.budget)?,
        None => started(&a, &config, &sensor)?,
    };
    let spec = match &journal.options.spec {
        Some(text) => Spec::parse(text, &journal.options.spec_origin)?,
        None => Spec::paper(),
    };
    let mut c = Commissioning {
        dir,
        journal,
        config,
        spec,
        global,
        yes: a.yes,
        threads: crate::cmd::arg_values::cap_threads(a.threads),
        compute_s: 0.0,
    };
    println!("commissioning directory: {}", c.dir.display());
    println!(
        "  (after Ctrl-C or a crash: fringe commission --resume {})",
        c.dir.display()
    );
    let base = rounds::open_base(&c.journal.options.base, c.config.sensor_variant()?)?;
    let profile = calibrate(&mut c)?;
    let adapted = rounds::adapt(&mut c, &base, &profile)?;
    certify::accept(&mut c, &base, &profile, adapted)
}

/// A new commissioning: its options checked (spec, budget) before anything moves, its directory
/// and journal made.
fn started(a: &CommissionArgs, config: &RigConfig, sensor: &str) -> Result<(PathBuf, Journal)> {
    let budget = checked_budget(a.budget.unwrap_or(DEFAULT_BUDGET_MIN))?;
    let (spec_text, spec_origin) = if a.spec == "paper" {
        (None, "the paper's custom-CNN row (Table 2)".to_string())
    } else {
        let path = Path::new(&a.spec);
        Spec::load(path)?;
        let text = std::fs::read_to_string(path)
            .with_context(|| format!("cannot read the spec {}", path.display()))?;
        (Some(text), path.display().to_string())
    };
    let variant = config.sensor_variant()?;
    let given = match &a.base {
        Some(b) => b.clone(),
        None => fringe_sensor_models::builtin::for_design(variant)?,
    };
    rounds::open_base(&given.display().to_string(), variant)?;
    // A base file is kept by its absolute path: a resume from another directory finds it.
    let base = match fringe_sensor_models::builtin::named(&given) {
        Some(_) => given,
        None => std::fs::canonicalize(&given).unwrap_or(given),
    };
    let journal = Journal::new(Options {
        sensor: sensor.to_string(),
        base: base.display().to_string(),
        budget_min: budget,
        spec: spec_text,
        spec_origin,
        seed: a.seed,
        round_presses: a.round_presses as usize,
        acceptance_presses: a.acceptance_presses as usize,
        last_block: a.last_block,
    });
    let dir = config
        .profile_dir()
        .join(directory_name(sensor, &journal.started_utc));
    std::fs::create_dir_all(dir.join("runs")).with_context(|| {
        format!(
            "cannot create the commissioning directory {}",
            dir.display()
        )
    })?;
    journal.write(&dir)?;
    Ok((dir, journal))
}

/// Bench time for the presses when `--budget` is not given, minutes.
const DEFAULT_BUDGET_MIN: f64 = 10.0;

fn checked_budget(minutes: f64) -> Result<f64> {
    if !(minutes.is_finite() && minutes > 0.0) {
        bail!("--budget {minutes}: give the bench time for the presses in minutes, above 0");
    }
    Ok(minutes)
}

/// A commissioning to go on with: its journal, for the same unit; `budget` replaces its budget.
fn resumed(dir: &Path, sensor: &str, budget: Option<f64>) -> Result<(PathBuf, Journal)> {
    let mut journal = Journal::read(dir)?;
    if journal.options.sensor != sensor {
        bail!(
            "{}: this commissioning is of sensor {}, and the rig's sensor is {sensor}: resume it on the rig it started on (--rig)",
            dir.display(),
            journal.options.sensor
        );
    }
    if let Some(b) = budget {
        journal.options.budget_min = checked_budget(b)?;
        journal.write(dir)?;
    }
    println!(
        "resuming the commissioning started {} (budget {} min, base {})",
        journal.started_utc, journal.options.budget_min, journal.options.base
    );
    Ok((dir.to_path_buf(), journal))
}

/// Step 1: the calibration scan (recorded once) and the unit's profile from it, written where
/// the rig's scans read it and into the commissioning directory.
fn calibrate(c: &mut Commissioning<'_>) -> Result<Profile> {
    let sensor = c.journal.options.sensor.clone();
    let kept = c.dir.join(PROFILE);
    let entry = match c.journal.calibration.clone() {
        Some(e) if e.completed && kept.is_file() => return Ok(Profile::load(&kept)?),
        Some(e) => e,
        None => {
            let plan = CalibrationGrid::defaults(&sensor).plan_text(&c.config)?;
            let e = ScanEntry {
                run_id: format!("calibration-{sensor}"),
                estimate_s: estimate_s(&plan, &c.config)?,
                plan,
                took_s: None,
                completed: false,
            };
            c.journal.calibration = Some(e.clone());
            c.journal.write(&c.dir)?;
            e
        }
    };
    println!(
        "step 1: calibration ({})",
        CalibrationGrid::defaults(&sensor).describe()
    );
    let (run_dir, took) = scan(c, &entry, ProfileUse::Ignore)?;
    let (spot, _) = spot_settings(None, &c.config)?;
    let fitted = calibrate_run(&run_dir, &sensor, DEFAULT_MAX_FRAMES, spot);
    let failure = match &fitted {
        Err(e) => Some(e.to_string()),
        Ok(r) => r.cal.registration.as_ref().err().map(|e| {
            format!("no image-to-stage registration ({e}): commissioning needs it to place presses on the disc")
        }),
    };
    if let Some(why) = failure {
        let kept = set_aside(&run_dir)?;
        bail!(
            "the calibration of {sensor} failed: {why}. Check that the unit sits under the indenter, lit and in focus, then resume (the calibration is pressed again; this scan is kept as {}): fringe commission --resume {}",
            kept.display(),
            c.dir.display()
        );
    }
    let result = fitted?;
    let written = result.write(&c.config.profile_dir())?;
    std::fs::copy(&written.profile, &kept)
        .with_context(|| format!("cannot copy the profile into {}", kept.display()))?;
    println!(
        "wrote {} (the unit's profile; a copy in the commissioning directory)",
        written.profile.display()
    );
    if let Some(e) = c.journal.calibration.as_mut() {
        e.completed = true;
        e.took_s = Some(took);
    }
    c.journal.write(&c.dir)?;
    Ok(result.profile)
}
