//! A commissioning asked, prepared and run: a sensor unit taken from first light to a verdict in one job, whoever runs it (`fringe
//! commission` in a terminal, the Commission screen): the calibration scan and the unit's
//! profile; rounds of presses chosen where the model errs most or has not pressed, each round
//! predicted by the model as adapted so far before it is adapted on (the learning curve); the
//! model's heads adapted to the unit in pure Rust (and, asked in a `torch` build, every layer
//! fine-tuned, kept when it beats the heads on held-out presses); an acceptance scan at held-out
//! positions judged against the spec; everything kept in one directory beside the unit's profile with
//! `certificate.json` and `report.md`. A commissioning goes on after Ctrl-C, a crash or an
//! aborted scan from the runs already recorded.

use super::acceptance::{accept, Accepted};
use super::certificate::{directory_name, PROFILE};
use super::cost::{forecast, Cost};
use super::fine_tune;
use super::host::Host;
use super::journal::{FrameSettings, Journal, Options, ScanEntry};
use super::rounds::{self, DEFAULT_BUDGET_MIN};
use super::scans::{estimate_s, scan, set_aside, Commissioning};
use crate::models::verdict::PAPER;
use crate::rig::file::RigConfig;
use crate::session::calibration_scan::{
    calibrate_run, spot_settings, CalibrationGrid, DEFAULT_MAX_FRAMES,
};
use crate::session::scan::ProfileUse;
use crate::workflow_error::{refuse, Context, WorkflowError};
use fringe_calibration::Profile;
use fringe_sensor_models::Architecture;
use fringe_sensor_models::Model;
use fringe_sensor_models::Spec;
use std::path::{Path, PathBuf};

/// Positions pressed per adaptive round when not given.
pub const DEFAULT_ROUND_PRESSES: usize = 6;
/// Held-out positions of the acceptance scan when not given.
pub const DEFAULT_ACCEPTANCE_PRESSES: usize = 10;
/// Seed of the adaptation's folds when not given.
pub const DEFAULT_SEED: u64 = 42;

type Result<T> = std::result::Result<T, WorkflowError>;

/// What a new commissioning is asked.
pub struct NewCommissioning {
    /// The model to adapt; the one that ships for the sensor's design when `None`.
    pub base: Option<PathBuf>,
    pub budget_min: Option<f64>,
    /// A spec file, or [`PAPER`] (the paper's custom-CNN row).
    pub spec: String,
    pub round_presses: usize,
    pub acceptance_presses: usize,
    pub last_block: bool,
    /// Also fine-tune every layer with libtorch (`torch` builds).
    pub fine_tune: bool,
    pub seed: u64,
}

impl Default for NewCommissioning {
    fn default() -> NewCommissioning {
        NewCommissioning {
            base: None,
            budget_min: None,
            spec: PAPER.into(),
            round_presses: DEFAULT_ROUND_PRESSES,
            acceptance_presses: DEFAULT_ACCEPTANCE_PRESSES,
            last_block: false,
            fine_tune: false,
            seed: DEFAULT_SEED,
        }
    }
}

/// A commissioning to start or to go on with.
pub enum Request {
    New(NewCommissioning),
    /// The commissioning in this directory, with a new budget when given, and full
    /// fine-tuning turned on when asked.
    Resume {
        dir: PathBuf,
        budget_min: Option<f64>,
        fine_tune: bool,
    },
}

/// Where a commissioning lives, once it has a directory (before anything moves).
pub struct Prepared {
    dir: PathBuf,
    journal: Journal,
    spec: Spec,
    /// The base model, opened and checked.
    base: Model,
    resumed: bool,
    keep_runs: bool,
}

impl Prepared {
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// What the unit must meet.
    pub fn spec(&self) -> &Spec {
        &self.spec
    }

    /// Keeps every round's frames after a pass (`--keep-runs`); by default they are pruned,
    /// their features kept.
    pub fn keep_runs(mut self, keep: bool) -> Prepared {
        self.keep_runs = keep;
        self
    }

    /// What a resumed commissioning started as, in a line (`None` for a new one).
    pub fn resumed(&self) -> Option<String> {
        self.resumed.then(|| {
            format!(
                "resuming the commissioning started {} (budget {} min, base {})",
                self.journal.started_utc,
                self.journal.options.budget_min,
                self.journal.options.base
            )
        })
    }
}

/// Checks `request` on the rig and makes (or reads) the commissioning's directory and journal;
/// nothing moves yet. A resumed commissioning's base is checked again, as a new one's is.
/// `warn` hears a warning about the base model (one without its card), as it comes.
pub fn prepare(
    request: &Request,
    config: &RigConfig,
    warn: &mut dyn FnMut(String),
) -> Result<Prepared> {
    let sensor = config.sensor_id()?;
    let (dir, journal, base) = match request {
        Request::Resume {
            dir,
            budget_min,
            fine_tune,
        } => {
            let (dir, journal) = resumed(dir, config, &sensor, *budget_min, *fine_tune)?;
            let (base, warning) =
                rounds::open_base(&journal.options.base, config.sensor_variant()?)
                    .with_context(|| format!("cannot resume {}", dir.display()))?;
            warning.into_iter().for_each(&mut *warn);
            (dir, journal, base)
        }
        Request::New(n) => started(n, config, &sensor, warn)?,
    };
    let spec = match &journal.options.spec {
        Some(text) => Spec::parse(text, &journal.options.spec_origin)?,
        None => Spec::paper(),
    };
    Ok(Prepared {
        dir,
        journal,
        spec,
        base,
        resumed: matches!(request, Request::Resume { .. }),
        keep_runs: false,
    })
}

/// What the commissioning `request` would take on the rig (presses, bench time, computation,
/// disk), checked as [`prepare`] checks it, with nothing made and nothing moved: `fringe
/// commission --dry-run`. `keep_runs`: every round's frames kept after a pass.
pub fn dry_run(
    request: &Request,
    config: &RigConfig,
    keep_runs: bool,
    warn: &mut dyn FnMut(String),
) -> Result<Cost> {
    let sensor = config.sensor_id()?;
    let (options, journal, base) = match request {
        Request::Resume {
            dir,
            budget_min,
            fine_tune,
        } => {
            let mut journal = Journal::read(dir)?;
            if let Some(b) = budget_min {
                journal.options.budget_min = checked_budget(*b)?;
            }
            journal.options.fine_tune |= *fine_tune;
            let (base, warning) =
                rounds::open_base(&journal.options.base, config.sensor_variant()?)?;
            warning.into_iter().for_each(&mut *warn);
            (journal.options.clone(), Some(journal), base)
        }
        Request::New(n) => {
            let (options, base) = checked(n, config, &sensor, warn)?;
            (options, None, base)
        }
    };
    forecast(
        &options,
        journal.as_ref(),
        &rounds::shapes(&base),
        config,
        keep_runs,
    )
}

/// Runs the commissioning `prepared` on the rig to its verdict (a failing unit is an `Ok` whose
/// certificate says fail).
pub fn run(
    prepared: Prepared,
    config: RigConfig,
    threads: usize,
    host: &mut dyn Host,
) -> Result<Accepted> {
    let Prepared {
        dir,
        journal,
        spec,
        base,
        keep_runs,
        ..
    } = prepared;
    let mut c = Commissioning {
        dir,
        journal,
        config,
        spec,
        host,
        threads,
        compute_s: 0.0,
        keep_runs,
    };
    // What it takes, said before anything moves (a rig that cannot say yet, a real one before
    // its first calibration without a sensor centre, is told so and goes on).
    match forecast(
        &c.journal.options,
        Some(&c.journal),
        &rounds::shapes(&base),
        &c.config,
        keep_runs,
    ) {
        Ok(cost) => cost.lines().into_iter().for_each(|l| c.say(l)),
        Err(e) => c.host.notice(format!(
            "note: what the commissioning takes cannot be said yet: {e}"
        )),
    }
    let profile = calibrate(&mut c)?;
    let adapted = rounds::adapt(&mut c, &base, &profile)?;
    accept(&mut c, &base, &profile, adapted)
}

/// A new commissioning: its options checked (spec, budget, base) before anything moves, its
/// directory and journal made; the base model opened.
fn started(
    n: &NewCommissioning,
    config: &RigConfig,
    sensor: &str,
    warn: &mut dyn FnMut(String),
) -> Result<(PathBuf, Journal, Model)> {
    let (options, opened) = checked(n, config, sensor, warn)?;
    let journal = Journal::new(options);
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
    Ok((dir, journal, opened))
}

/// A new commissioning's options, checked (spec, budget, base) before anything moves; the base
/// model opened.
fn checked(
    n: &NewCommissioning,
    config: &RigConfig,
    sensor: &str,
    warn: &mut dyn FnMut(String),
) -> Result<(Options, Model)> {
    let budget = checked_budget(n.budget_min.unwrap_or(DEFAULT_BUDGET_MIN))?;
    let (spec_text, spec_origin) = if n.spec == PAPER {
        (None, "the paper's custom-CNN row (Table 2)".to_string())
    } else {
        let path = Path::new(&n.spec);
        Spec::load(path)?;
        let text = std::fs::read_to_string(path)
            .with_context(|| format!("cannot read the spec {}", path.display()))?;
        (Some(text), path.display().to_string())
    };
    let variant = config.sensor_variant()?;
    let given = match &n.base {
        Some(b) => b.clone(),
        None => fringe_sensor_models::builtin::commissioning_base(variant)?,
    };
    let (opened, warning) = rounds::open_base(&given.display().to_string(), variant)?;
    warning.into_iter().for_each(warn);
    rounds::check_budget(config, &opened, budget)?;
    if n.fine_tune {
        fine_tune::available()?;
        if n.last_block {
            refuse!("--last-block and --fine-tune: choose one (full fine-tuning trains every layer, the last block included)");
        }
    }
    if n.last_block && !opened.arch.is_some_and(Architecture::trains_last_block) {
        refuse!(
            "--last-block trains the custom CNN's last convolution block, and the base {} is {}: give a custom CNN as --base (builtin:layered) or leave --last-block out",
            given.display(),
            opened.describe()
        );
    }
    // A base file is kept by its absolute path: a resume from another directory finds it.
    let base = match fringe_sensor_models::builtin::named(&given) {
        Some(_) => given,
        None => std::fs::canonicalize(&given).unwrap_or(given),
    };
    let options = Options {
        sensor: sensor.to_string(),
        base: base.display().to_string(),
        budget_min: budget,
        spec: spec_text,
        spec_origin,
        seed: n.seed,
        round_presses: n.round_presses,
        acceptance_presses: n.acceptance_presses,
        last_block: n.last_block,
        fine_tune: n.fine_tune,
        camera: Some(FrameSettings::of(config)?),
    };
    Ok((options, opened))
}

fn checked_budget(minutes: f64) -> Result<f64> {
    if !(minutes.is_finite() && minutes > 0.0) {
        refuse!("--budget {minutes}: give the bench time for the presses in minutes, above 0");
    }
    Ok(minutes)
}

/// A commissioning to go on with: its journal, for the same unit and the same camera settings;
/// `budget` replaces its budget, `fine_tune` turns full fine-tuning on.
fn resumed(
    dir: &Path,
    config: &RigConfig,
    sensor: &str,
    budget: Option<f64>,
    fine_tune: bool,
) -> Result<(PathBuf, Journal)> {
    let mut journal = Journal::read(dir)?;
    if journal.options.sensor != sensor {
        refuse!(
            "{}: this commissioning is of sensor {}, and the rig's sensor is {sensor}: resume it on the rig it started on (--rig)",
            dir.display(),
            journal.options.sensor
        );
    }
    // A journal of an older fringe does not say; its rounds are read as they are.
    if let Some(then) = &journal.options.camera {
        let changed = then.differences(&FrameSettings::of(config)?);
        if !changed.is_empty() {
            refuse!(
                "{}: the rig's camera gives other frames than this commissioning was started with ({}): its profile and rounds fit those frames only; resume it with the camera settings it started with (the rig file it started on, --rig)",
                dir.display(),
                changed.join("; ")
            );
        }
    }
    if let Some(b) = budget {
        journal.options.budget_min = checked_budget(b)?;
    }
    if fine_tune {
        fine_tune::available()?;
        if journal.options.last_block {
            refuse!("{}: this commissioning trains the last block (--last-block); full fine-tuning trains every layer, the last block included: start a new commissioning with --fine-tune alone", dir.display());
        }
        journal.options.fine_tune = true;
    }
    if budget.is_some() || fine_tune {
        journal.write(dir)?;
    }
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
    c.say(format!(
        "step 1: calibration ({})",
        CalibrationGrid::defaults(&sensor).describe()
    ));
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
        refuse!(
            "the calibration of {sensor} failed: {why}. Check that the unit sits under the indenter, lit and in focus, then resume (the calibration is pressed again; this scan is kept as {}): fringe commission --resume {}",
            kept.display(),
            c.dir.display()
        );
    }
    let result = fitted?;
    let written = result.write(&c.config.profile_dir())?;
    std::fs::copy(&written.profile, &kept)
        .with_context(|| format!("cannot copy the profile into {}", kept.display()))?;
    c.say(format!(
        "wrote {} (the unit's profile; a copy in the commissioning directory)",
        written.profile.display()
    ));
    if let Some(e) = c.journal.calibration.as_mut() {
        e.completed = true;
        e.took_s = Some(took);
    }
    c.journal.write(&c.dir)?;
    Ok(result.profile)
}
