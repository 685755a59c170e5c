//! Steps 2 and 3 of commissioning: rounds of presses where the model is weakest, each predicted
//! by the model as adapted on every press before it (an honest held-out learning curve), then
//! adapted on; until the bench budget is spent or a round's unseen presses meet the spec.

use super::certificate::CurvePoint;
use super::fine_tune::{self, FineTune};
use super::journal::ScanEntry;
use super::last_block;
use super::press_choice::{choose, tour, PressedPoint, UsableDisc, COVERAGE_MM, LATTICE_MM};
use super::press_errors::round_errors;
use super::press_plan::{disc_margin, press_plan};
use super::pruning::{features_path, prune_read_round};
use super::scans::{estimate_s, scan, set_aside, Commissioning};
use crate::models::choice::open_model;
use crate::rig::file::RigConfig;
use crate::session::scan::ProfileUse;
use crate::workflow_error::{refuse, Context, WorkflowError};
use fringe_calibration::Profile;
use fringe_sensor_models::adapt::{fit_heads, head_scores, AdaptConfig, Adapted, Features};
use fringe_sensor_models::dataset;
use fringe_sensor_models::BlockFit;
use fringe_sensor_models::Model;
use fringe_sensor_models::StateDict;
use std::path::{Path, PathBuf};
use std::time::Instant;

type Result<T> = std::result::Result<T, WorkflowError>;

/// Bench time for the presses when no budget is given, minutes.
pub const DEFAULT_BUDGET_MIN: f64 = 10.0;

/// A round stops the presses early when its unseen presses are within this share of every
/// threshold of the spec.
const EARLY_MARGIN: f64 = 0.8;
/// Rounds pressed before an early stop is considered.
const MIN_ROUNDS: usize = 3;

/// The adaptation's outcome: the adapted weights, the runs and the learning curve.
pub(crate) struct Adaptation {
    /// The heads alone, fitted on every press.
    pub adapted: Adapted,
    /// The last block trained with the heads (the custom CNN), when it ran.
    pub block: Option<BlockFit>,
    /// Every layer fine-tuned with libtorch, when it ran.
    pub fine_tune: Option<FineTune>,
    pub runs: Vec<PathBuf>,
    pub curve: Vec<CurvePoint>,
    pub pressed: Vec<PressedPoint>,
    /// Where presses could go.
    pub disc: UsableDisc,
}

/// Which adaptation a commissioned model's weights come from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Method {
    Heads,
    LastBlock,
    FineTuning,
}

impl Method {
    /// Its name, as the model's card records it.
    pub(crate) fn name(self) -> &'static str {
        match self {
            Method::Heads => "heads",
            Method::LastBlock => "last block",
            Method::FineTuning => "full fine-tuning",
        }
    }

    /// What it did, for the certificate.
    pub(crate) fn about(self) -> &'static str {
        match self {
            Method::Heads => "heads: the network's force, shape and contact heads fitted again on the unit's frames in pure Rust, each pulled towards the base model's by cross-validation over presses",
            Method::LastBlock => "last block: the custom CNN's last convolution block and its heads trained again on the unit's frames in pure Rust, kept because it beat the heads alone on held-out presses (model.json has both figures)",
            Method::FineTuning => "full fine-tuning: every layer trained again on the unit's frames with libtorch from the heads fitted on them, one fold of presses held out, kept because it beat the heads alone on that fold (model.json has both figures)",
        }
    }
}

impl Adaptation {
    /// The weights to use: the last block's or the fine-tuned network's when it beat the heads
    /// alone on held-out presses.
    pub(crate) fn weights(&self) -> &StateDict {
        if let Some(w) = self.fine_tune.as_ref().and_then(|f| f.kept.as_ref()) {
            return w;
        }
        match &self.block {
            Some(b) if b.epoch > 0 => &b.weights,
            _ => &self.adapted.weights,
        }
    }

    /// Which adaptation the weights come from.
    pub(crate) fn method(&self) -> Method {
        if self.fine_tune.as_ref().is_some_and(|f| f.kept.is_some()) {
            return Method::FineTuning;
        }
        match &self.block {
            Some(b) if b.epoch > 0 => Method::LastBlock,
            _ => Method::Heads,
        }
    }
}

/// Opens the base model and checks that it can be adapted (the paper's networks, by weights,
/// with a no-contact class and at least one indenter), that it runs on whole frames (not a
/// window network, by the rule evaluation keeps) and that it is of the sensor's design
/// (`variant`, when known).
pub(crate) fn open_base(spec: &str, variant: Option<&str>) -> Result<(Model, Option<String>)> {
    let model = open_model(Path::new(spec))?;
    let warning = model.missing_card_warning();
    model.check_design(variant, "this unit")?;
    model.check_runs_alone().with_context(|| {
        format!("--base {spec}: a commissioning adapts a network that reads the whole disc")
    })?;
    if model.weights().is_none() {
        refuse!(
            "--base {spec}: only the paper's networks can be adapted, from a weights file (.pth, .pt, .safetensors) or an ONNX graph that holds their weights by name; this is {}",
            model.describe()
        );
    }
    if model.classes.first().map(String::as_str) != Some("None") || model.classes.len() < 2 {
        refuse!(
            "--base {spec}: its shape classes ({}) must be \"None\" followed by the indenters it knows; commissioning presses each of them",
            model.classes.join(", ")
        );
    }
    Ok((model, warning))
}

/// Refuses a bench budget that cannot hold the fewest presses an adaptation needs
/// ([`fringe_sensor_models::adapt::MIN_PRESSES`], each position pressed with every indenter of
/// `base`, the positions a lattice spacing apart about the sensor's centre), before anything
/// moves: such a commissioning would calibrate, press what fits and fail at the end. Without a
/// sensor centre known yet (a real rig before its first calibration) the rounds say it.
pub(crate) fn check_budget(config: &RigConfig, base: &Model, budget_min: f64) -> Result<()> {
    let Ok(origin) = config.origin() else {
        return Ok(());
    };
    let shapes = shapes(base);
    let positions = fringe_sensor_models::adapt::MIN_PRESSES.div_ceil(shapes.len().max(1));
    let points: Vec<[f64; 2]> = (0..positions)
        .map(|k| [origin.x.0 + LATTICE_MM * k as f64, origin.y.0])
        .collect();
    let plan = press_plan(
        "budget",
        &points,
        &shapes,
        "the fewest presses an adaptation needs",
        None,
    )?;
    let need_s = estimate_s(&plan, config)?;
    if need_s > 60.0 * budget_min {
        refuse!(
            "--budget {budget_min}: the adaptation needs at least {} presses ({positions} positions x {} indenters: {}), about {need_s:.0} s of bench time on this rig at the least, more than {:.0} s: give a larger --budget (minutes; the default is {})",
            fringe_sensor_models::adapt::MIN_PRESSES,
            shapes.len(),
            shapes.join(", "),
            60.0 * budget_min,
            DEFAULT_BUDGET_MIN
        );
    }
    Ok(())
}

/// The indenters pressed: the model's classes after "None".
pub(crate) fn shapes(model: &Model) -> Vec<String> {
    model.classes.iter().skip(1).cloned().collect()
}

/// Step 2 and 3: the rounds recorded so far replayed (resume), then new rounds while the
/// budget lasts; the heads fitted on every press.
pub(crate) fn adapt(
    c: &mut Commissioning<'_>,
    base: &Model,
    profile: &Profile,
) -> Result<Adaptation> {
    let Some(base_weights) = base.weights() else {
        refuse!("{}: the base model holds no weights", base.path.display());
    };
    let limits = c.config.limits()?;
    let disc = UsableDisc::from_profile(profile)?;
    let sensor = c.journal.options.sensor.clone();
    let candidates = disc.lattice(LATTICE_MM, 0.0, &limits, &sensor)?;
    c.say(format!(
        "step 2: presses over the usable disc ({:.1} mm about stage ({:.2}, {:.2}) mm, {} candidate positions), budget {} min of bench time",
        disc.reach_mm,
        disc.centre_mm[0],
        disc.centre_mm[1],
        candidates.len(),
        c.journal.options.budget_min
    ));
    let mut state = Rounds {
        disc,
        disc_margin: disc_margin(profile),
        features: Features::empty(),
        weights: base_weights.clone(),
        adapted: None,
        runs: Vec::new(),
        curve: Vec::new(),
        pressed: Vec::new(),
    };
    let mut round = 0;
    loop {
        let entry = match c.journal.rounds.get(round).cloned() {
            Some(e) => e,
            None => match next_round(c, &state, &candidates, base, round)? {
                Some(e) => e,
                None => break,
            },
        };
        // A round learnt from before is not read again: its features were kept (a journal of
        // an older fringe kept none, and its round is read once more, then kept).
        if entry.completed {
            if let Some(features) = kept_features(c, &entry.run_id) {
                let run_dir = c.dir.join("runs").join(&entry.run_id);
                state.learn_from(c, base_weights, features, &run_dir, round)?;
                round += 1;
                continue;
            }
        }
        let (run_dir, took) = scan(c, &entry, ProfileUse::Consume)?;
        if let Some(e) = c.journal.rounds.get_mut(round) {
            e.took_s = Some(e.took_s.unwrap_or(0.0) + took);
        }
        // A round is complete when its frames were learnt from: one whose frames cannot be used
        // is kept aside and pressed again on resume, never taken as done.
        if let Err(e) = state.learn(c, base, base_weights, &run_dir, round) {
            c.journal.write(&c.dir)?;
            let kept = set_aside(&run_dir)?;
            return Err(e.context(format!(
                "round {} could not be learnt from (it is kept as {} and pressed again when the commissioning is resumed: fringe commission --resume {})",
                round + 1,
                kept.display(),
                c.dir.display()
            )));
        }
        if let Some(e) = c.journal.rounds.get_mut(round) {
            e.completed = true;
        }
        c.journal.write(&c.dir)?;
        prune_read_round(c, &run_dir)?;
        round += 1;
    }
    let Some(adapted) = state.adapted else {
        refuse!(
            "the budget of {} min allowed too few presses to adapt on (at least {} positions); give a larger --budget",
            c.journal.options.budget_min,
            fringe_sensor_models::adapt::MIN_PRESSES
        );
    };
    let block = if c.journal.options.last_block {
        last_block::train(c, base, &state.runs)?
    } else {
        None
    };
    let fine_tune = if c.journal.options.fine_tune {
        fine_tune::run(c, base, &state.runs)?
    } else {
        None
    };
    Ok(Adaptation {
        adapted,
        block,
        fine_tune,
        runs: state.runs,
        curve: state.curve,
        pressed: state.pressed,
        disc,
    })
}

/// What the rounds have learnt so far.
struct Rounds {
    /// Where presses go (the first round's path starts at its centre).
    disc: UsableDisc,
    /// The margin of the disc's square the rounds store ([`disc_margin`]).
    disc_margin: Option<f64>,
    features: Features,
    /// The heads as adapted so far (the base model's before any fit).
    weights: StateDict,
    adapted: Option<Adapted>,
    runs: Vec<PathBuf>,
    curve: Vec<CurvePoint>,
    pressed: Vec<PressedPoint>,
}

impl Rounds {
    /// A round's run: its features read (and kept in the commissioning directory, so that a
    /// resume does not read them again), then learnt from ([`Rounds::learn_from`]).
    fn learn(
        &mut self,
        c: &mut Commissioning<'_>,
        base: &Model,
        base_weights: &StateDict,
        run_dir: &Path,
        round: usize,
    ) -> Result<()> {
        let started = Instant::now();
        let source = dataset::read(run_dir)?;
        let threads = c.threads;
        let host = &mut *c.host;
        let features = Features::read(base, &[source], None, threads, |d, t| {
            host.frames("reading the round's features", d, t)
        })?;
        // Kept so that a resume does not read them again; a round whose features could not
        // be kept is read again then, and its frames are never pruned.
        if let Some(id) = run_dir.file_name() {
            if let Err(e) = features.save(&features_path(&c.dir, &id.to_string_lossy())) {
                c.host.notice(format!("warning: {e}"));
            }
        }
        c.compute_s += started.elapsed().as_secs_f64();
        self.learn_from(c, base_weights, features, run_dir, round)
    }

    /// A round's features predicted by the current heads (the curve, the errors by position),
    /// then added to the frames adapted on and the heads fitted again.
    fn learn_from(
        &mut self,
        c: &mut Commissioning<'_>,
        base_weights: &StateDict,
        features: Features,
        run_dir: &Path,
        round: usize,
    ) -> Result<()> {
        let started = Instant::now();
        let scores = head_scores(&self.weights, &features)?;
        let errors = round_errors(
            round + 1,
            self.features.presses(),
            features.samples(),
            &scores,
            &c.spec,
        );
        let p = &errors.curve;
        c.say(format!(
            "round {}: {} frames of {} presses, unseen by the model adapted on {} presses: Fz RMSE {:.3} N, contact RMSE {:.2} mm, shape accuracy {:.1} %",
            p.round,
            p.frames,
            features.presses(),
            p.presses_before,
            p.fz_rmse_n,
            p.contact_rmse_mm,
            100.0 * p.shape_accuracy
        ));
        self.curve.push(errors.curve);
        self.pressed.extend(errors.presses);
        c.host.learnt(&self.curve, &self.pressed, &self.disc);
        self.features.append(features)?;
        self.runs.push(run_dir.to_path_buf());
        let config = AdaptConfig {
            folds: 5,
            seed: c.journal.options.seed,
            threads: c.threads,
        };
        if self.features.presses() >= fringe_sensor_models::adapt::MIN_PRESSES {
            let adapted = fit_heads(base_weights, &self.features, &config)?;
            self.weights = adapted.weights.clone();
            self.adapted = Some(adapted);
        }
        c.compute_s += started.elapsed().as_secs_f64();
        Ok(())
    }
}

/// The features kept of the round `run_id`, when there are and they read; a file that does not
/// read is said and passed over (the round is read from its run again).
fn kept_features(c: &mut Commissioning<'_>, run_id: &str) -> Option<Features> {
    let path = features_path(&c.dir, run_id);
    if !path.is_file() {
        return None;
    }
    match Features::load(&path) {
        Ok(f) => Some(f),
        Err(e) => {
            c.host.notice(format!(
                "warning: {e}; the round's features are read from its run again"
            ));
            None
        }
    }
}

/// The next round's presses, recorded in the journal before it runs; `None` when the budget
/// cannot hold another round or the last rounds met the spec.
fn next_round(
    c: &mut Commissioning<'_>,
    state: &Rounds,
    candidates: &[[f64; 2]],
    base: &Model,
    round: usize,
) -> Result<Option<ScanEntry>> {
    if round >= MIN_ROUNDS {
        if let Some(last) = state.curve.last() {
            if meets(&c.spec, last, EARLY_MARGIN) {
                let line = format!(
                    "round {} met the spec with room ({}% of each threshold) on presses it had not seen: no more presses",
                    last.round,
                    EARLY_MARGIN * 100.0
                );
                c.say(line);
                return Ok(None);
            }
        }
    }
    let spent = c.journal.round_seconds();
    let budget = 60.0 * c.journal.options.budget_min;
    let name = format!("round-{}", round + 1);
    let Some((points, plan, estimate)) =
        sized_round(c, state, candidates, base, &name, budget - spent)?
    else {
        return Ok(None);
    };
    let entry = ScanEntry {
        run_id: name,
        plan,
        estimate_s: estimate,
        took_s: None,
        completed: false,
    };
    c.journal.rounds.push(entry.clone());
    c.journal.write(&c.dir)?;
    c.say(format!(
        "round {}: {} positions x {} indenters, about {:.0} s of bench time ({:.0} s of {:.0} s spent)",
        round + 1,
        points.len(),
        shapes(base).len(),
        estimate,
        spent,
        budget
    ));
    Ok(Some(entry))
}

/// A round's positions (stage mm), its plan and its estimated bench time (s).
type SizedRound = (Vec<[f64; 2]>, String, f64);

/// The round's positions, plan and estimated bench time: as many positions as `left` seconds
/// hold (a last round may be smaller); `None` when not one press fits or every position is
/// pressed.
fn sized_round(
    c: &mut Commissioning<'_>,
    state: &Rounds,
    candidates: &[[f64; 2]],
    base: &Model,
    name: &str,
    left: f64,
) -> Result<Option<SizedRound>> {
    let mut n = c.journal.options.round_presses;
    loop {
        let points = tour(
            &choose(candidates, &state.pressed, n, COVERAGE_MM),
            state
                .pressed
                .last()
                .map_or(state.disc.centre_mm, |p| p.stage_mm),
        );
        if points.is_empty() {
            c.say("every candidate position is pressed: no more presses".into());
            return Ok(None);
        }
        let plan = press_plan(
            name,
            &points,
            &shapes(base),
            &format!(
                "fringe commission, sensor {}: adaptive {name} ({} positions chosen where the model erred most or has not pressed)",
                c.journal.options.sensor,
                points.len()
            ),
            state.disc_margin,
        )?;
        let estimate = estimate_s(&plan, &c.config)?;
        if estimate <= left {
            return Ok(Some((points, plan, estimate)));
        }
        if n == 1 {
            c.say(format!(
                "the bench budget is spent ({:.0} s left; one more press would take about {estimate:.0} s): no more presses",
                left.max(0.0)
            ));
            return Ok(None);
        }
        n -= 1;
    }
}

/// The curve point meets every whole-set threshold of `spec` scaled by `margin`.
fn meets(spec: &fringe_sensor_models::Spec, p: &CurvePoint, margin: f64) -> bool {
    let t = &spec.all;
    t.fz_rmse_n.is_none_or(|v| p.fz_rmse_n <= margin * v)
        && t.contact_rmse_mm
            .is_none_or(|v| p.contact_rmse_mm <= margin * v)
        && t.shape_accuracy
            .is_none_or(|v| 1.0 - p.shape_accuracy <= margin * (1.0 - v))
}

#[cfg(all(test, feature = "sim"))]
mod tests {
    use super::*;
    use crate::commission::host::{Host, ScanEnded};
    use crate::commission::journal::{Journal, Options};
    use crate::workflow_error::BoxError;
    use fringe_rig::store::{now_utc, ExitStatus, StopDocument};
    use fringe_rig::store::{RunFile, RunReader};
    use fringe_rig::RunTarget;
    use fringe_rig::ScanProgram;
    use fringe_sensor_models::Spec;

    /// A bench whose every scan completes with frames that cannot be learnt from (as a round
    /// pressed on a camera of another frame size): the run is written ended completed, with
    /// no frame in it. Counts the scans it was asked for, by run id.
    struct UnusableFrames {
        pressed: Vec<String>,
    }

    impl Host for UnusableFrames {
        fn scan(
            &mut self,
            _config: &RigConfig,
            _program: ScanProgram,
            _plan_text: String,
            target: RunTarget,
            _profile_use: ProfileUse,
        ) -> std::result::Result<ScanEnded, BoxError> {
            let RunTarget::New { root, run_id } = target else {
                return Err("a resume was asked for, not a new scan".into());
            };
            self.pressed.push(run_id.clone());
            let run_dir = root.join(&run_id);
            std::fs::create_dir_all(&run_dir)?;
            let run = RunReader::at(&run_dir);
            std::fs::write(run.path(RunFile::Start), "{}")?;
            std::fs::write(run.path(RunFile::Manifest), "")?;
            let stop = StopDocument {
                exit_status: ExitStatus::Completed,
                reason: "all points done".into(),
                stopped_utc: now_utc(),
                frames: 0,
                dropped_frames: 0,
                force_samples: 0,
                lost_force_samples: 0,
                points_done: 1,
                sync_method: None,
                sync_error_ns: None,
            };
            std::fs::write(run.path(RunFile::Stop), serde_json::to_string(&stop)?)?;
            Ok(ScanEnded {
                completed: true,
                reason: stop.reason,
                run_dir,
            })
        }

        fn say(&mut self, _line: String) {}

        fn notice(&mut self, _line: String) {}

        fn frames(&mut self, _what: &'static str, _done: usize, _total: usize) {}

        fn stop_requested(&mut self) -> bool {
            false
        }
    }

    /// Issue 59, item 9: a round pressed on the wrong rig (another camera size) and failed was
    /// recorded complete, its run kept as done, so a resume on the right rig took it as pressed
    /// and failed on it again, for ever. A round whose frames cannot be learnt from is not
    /// complete in the journal, and the resume presses it again.
    #[test]
    fn a_round_that_could_not_be_learnt_from_is_not_complete_and_is_pressed_again() {
        let dir = std::env::temp_dir().join(format!("fringe-round-failed-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).expect("dir");
        let config = RigConfig::parse("[sim]\nimage_scale = 0.25\n", "rig.toml").expect("rig");
        let sim = crate::rig::simulated::config(&config).expect("simulated bench");
        let profile = crate::rig::simulated::design_profile(&sim, "unit-1");
        let variant = config.sensor_variant().expect("variant");
        let base_path =
            fringe_sensor_models::builtin::commissioning_base(variant).expect("builtin base");
        let (base, _) = open_base(&base_path.display().to_string(), variant).expect("base");
        let disc = UsableDisc::from_profile(&profile).expect("disc");
        let plan = press_plan(
            "round-1",
            &[disc.centre_mm],
            &shapes(&base),
            "a test round",
            None,
        )
        .expect("plan");
        let mut journal = Journal::new(Options {
            sensor: "unit-1".into(),
            base: base_path.display().to_string(),
            budget_min: 10.0,
            spec: None,
            spec_origin: "paper".into(),
            seed: 42,
            round_presses: 1,
            acceptance_presses: 1,
            last_block: false,
            fine_tune: false,
            camera: None,
        });
        journal.rounds.push(ScanEntry {
            run_id: "round-1".into(),
            plan,
            estimate_s: 10.0,
            took_s: None,
            completed: false,
        });
        journal.write(&dir).expect("journal");
        let mut host = UnusableFrames {
            pressed: Vec::new(),
        };
        let attempt = |host: &mut UnusableFrames| {
            let mut c = Commissioning {
                dir: dir.clone(),
                journal: Journal::read(&dir).expect("journal"),
                config: config.clone(),
                spec: Spec::paper(),
                host,
                threads: 1,
                compute_s: 0.0,
                keep_runs: false,
            };
            match adapt(&mut c, &base, &profile) {
                Ok(_) => panic!("adapted on a round without frames"),
                Err(e) => format!("{e:#}"),
            }
        };
        let failed = attempt(&mut host);
        assert_eq!(host.pressed, ["round-1"], "{failed}");
        let journal = Journal::read(&dir).expect("journal");
        assert!(
            !journal.rounds[0].completed,
            "the failed round is recorded complete: {:?}\n{failed}",
            journal.rounds[0]
        );
        // Resumed: the round is pressed again, not taken as done.
        let again = attempt(&mut host);
        assert_eq!(host.pressed, ["round-1", "round-1"], "{again}");
        assert!(
            failed.contains("round 1 could not be learnt from")
                && failed.contains("pressed again when the commissioning is resumed"),
            "{failed}"
        );
        assert!(
            dir.join("runs/round-1.stopped-1").is_dir(),
            "the failed round's run is kept aside"
        );
        let _ = std::fs::remove_dir_all(&dir);
    }
}
