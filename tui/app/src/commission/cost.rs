//! What a commissioning will take, told before anything moves and by `fringe commission
//! --dry-run`: the presses of each scan, the bench time from the plans' motion, the computation
//! (features of the rounds' frames, the acceptance evaluation) and the disk, from the codec's
//! bytes per frame (the run-size estimate every scan's dry run gives).
//!
//! The rounds are forecast as the job chooses them: positions of the 2 mm lattice over the
//! usable disc (of the unit's profile; on the simulated bench before any, of its design),
//! spread by distance from the presses before them, each round as large as the budget left
//! holds. A job may press fewer rounds than forecast (it stops once a round meets the spec with
//! room, after 3); never more.

use super::journal::{Journal, Options};
use super::press_choice::{choose, tour, PressedPoint, UsableDisc, COVERAGE_MM, LATTICE_MM};
use super::press_plan::{disc_margin, press_plan};
use super::pruning::prunes_as_read;
use crate::rig::file::RigConfig;
use crate::session::calibration_scan::CalibrationGrid;
use crate::session::disk_space::Recording;
use crate::workflow_error::WorkflowError;
use fringe_rig::store::human_bytes;
use fringe_rig::store::RunSize;
use fringe_rig::{Plan, ScanProgram};

type Result<T> = std::result::Result<T, WorkflowError>;

/// Computation per frame of a round (the network's body read for the heads' features) or of the
/// acceptance scan (the whole network), s, release build on 2 threads: an allowance, not yet a
/// measurement of a whole commissioning (the keypoint CNN alone takes 1.9 ms a frame on 2
/// threads, BENCHMARKS.md; reading and preprocessing a stored frame come on top).
pub(crate) const COMPUTE_S_PER_FRAME: f64 = 0.012;
/// A debug build's computation per frame, s: the commissionings of BENCHMARKS.md ("Commissioning
/// a unit", debug build, half-size frames), 98 s for 5172 frames.
const DEBUG_COMPUTE_S_PER_FRAME: f64 = 0.019;
/// Full fine-tuning's computation on 2 cores, s (BENCHMARKS.md, "Full fine-tuning").
const FINE_TUNE_S: f64 = 120.0;

/// One scan's share.
#[derive(Debug, Clone, PartialEq)]
pub struct ScanCost {
    /// `calibration`, `round-2`, `acceptance`.
    pub name: String,
    pub positions: usize,
    pub presses: usize,
    pub bench_s: f64,
    pub size: RunSize,
}

/// A commissioning's forecast (of what is left of it, for one resumed).
#[derive(Debug, Clone, PartialEq)]
pub struct Cost {
    pub scans: Vec<ScanCost>,
    /// Rounds already pressed (a resumed commissioning), not in `scans`.
    pub rounds_done: usize,
    pub compute_s: f64,
    /// The round's frames are kept after a pass (`--keep-runs`).
    pub keep_runs: bool,
    /// Each round's frames go as soon as its features are kept (neither `--keep-runs` nor a
    /// candidate that trains on frames, `--last-block`, `--fine-tune`).
    pub prunes_as_read: bool,
    /// Full fine-tuning's share of `compute_s`, s.
    pub fine_tune_s: f64,
}

impl Cost {
    pub fn bench_s(&self) -> f64 {
        self.scans.iter().map(|s| s.bench_s).sum()
    }

    pub fn presses(&self) -> usize {
        self.scans.iter().map(|s| s.presses).sum()
    }

    /// Bytes written while the job runs (every scan whole).
    pub fn written_bytes(&self) -> u64 {
        self.scans.iter().map(|s| s.size.total_bytes()).sum()
    }

    /// The most bytes on disk at once: every scan whole, less each round's frames once read
    /// when [`Cost::prunes_as_read`].
    pub fn peak_bytes(&self) -> u64 {
        let (mut now, mut peak) = (0u64, 0u64);
        for s in &self.scans {
            now += s.size.total_bytes();
            peak = peak.max(now);
            if self.prunes_as_read && s.name.starts_with("round-") {
                now -= s.size.frames_bytes;
            }
        }
        peak
    }

    /// Bytes kept after a pass: the rounds' frames pruned unless `keep_runs`.
    pub fn kept_bytes(&self) -> u64 {
        self.scans
            .iter()
            .map(|s| {
                if !self.keep_runs && s.name.starts_with("round-") {
                    s.size.total_bytes() - s.size.frames_bytes
                } else {
                    s.size.total_bytes()
                }
            })
            .sum()
    }

    /// The forecast for a person, a line each.
    pub fn lines(&self) -> Vec<String> {
        let mut out = Vec::new();
        let frames: u64 = self.scans.iter().map(|s| s.size.frames).sum();
        let rounds: Vec<&ScanCost> = self
            .scans
            .iter()
            .filter(|s| s.name.starts_with("round-"))
            .collect();
        for s in &self.scans {
            if s.name.starts_with("round-") {
                continue;
            }
            out.push(scan_line(&s.name, s));
        }
        if !rounds.is_empty() {
            let presses: usize = rounds.iter().map(|r| r.presses).sum();
            let bench: f64 = rounds.iter().map(|r| r.bench_s).sum();
            let written: u64 = rounds.iter().map(|r| r.size.total_bytes()).sum();
            let r_frames: u64 = rounds.iter().map(|r| r.size.frames).sum();
            let at = usize::from(self.scans.first().is_some_and(|s| s.name == "calibration"));
            out.insert(
                at,
                format!(
                    "  rounds {}-{} (at most; the rounds stop early once one meets the spec with room): {presses} presses, {}, {r_frames} frames, {}",
                    self.rounds_done + 1,
                    self.rounds_done + rounds.len(),
                    minutes(bench),
                    human_bytes(written)
                ),
            );
            for (k, r) in rounds.iter().enumerate() {
                out.insert(at + 1 + k, format!("  {}", scan_line(&r.name, r)));
            }
        }
        out.insert(
            0,
            format!(
                "what it takes (estimated from the plans' motion and the codec's bytes per frame): {} presses, bench time {}, computation about {} ({frames} frames{}), disk at most {} at once ({} written in all), {} kept after a pass{}",
                self.presses(),
                minutes(self.bench_s()),
                minutes(self.compute_s),
                if self.fine_tune_s > 0.0 {
                    format!(", full fine-tuning {}", minutes(self.fine_tune_s))
                } else {
                    String::new()
                },
                human_bytes(self.peak_bytes()),
                human_bytes(self.written_bytes()),
                human_bytes(self.kept_bytes()),
                if self.keep_runs {
                    " (--keep-runs: every round's frames kept)"
                } else if self.prunes_as_read {
                    " (each round's frames pruned once its features are kept; --keep-runs keeps them)"
                } else {
                    " (the rounds' frames pruned after a pass, their features kept; --keep-runs keeps them)"
                }
            ),
        );
        out
    }
}

fn scan_line(name: &str, s: &ScanCost) -> String {
    format!(
        "  {name}: {} positions, {} presses, {}, {} frames, {}",
        s.positions,
        s.presses,
        minutes(s.bench_s),
        s.size.frames,
        human_bytes(s.size.total_bytes())
    )
}

/// "12 min 30 s", "45 s".
fn minutes(s: f64) -> String {
    let s = s.max(0.0).round() as u64;
    if s >= 60 {
        format!("{} min {:02} s", s / 60, s % 60)
    } else {
        format!("{s} s")
    }
}

/// The forecast of the commissioning `options` describe on the rig `config`, with the base's
/// indenters `shapes`; of what is left of it when `journal` says what was done.
pub(crate) fn forecast(
    options: &Options,
    journal: Option<&Journal>,
    shapes: &[String],
    config: &RigConfig,
    keep_runs: bool,
) -> Result<Cost> {
    let limits = config.limits()?;
    let mut scans = Vec::new();
    let calibrated = journal
        .and_then(|j| j.calibration.as_ref())
        .is_some_and(|e| e.completed);
    if !calibrated {
        let grid = CalibrationGrid::defaults(&options.sensor);
        let plan = grid.plan_text(config)?;
        scans.push(scan_cost(
            "calibration",
            grid.points * grid.points,
            1,
            &plan,
            config,
        )?);
    }
    // The profile the rounds will press by.
    let profile = crate::rig::unit_profile(config, &options.sensor)?;
    let margin = profile.as_ref().and_then(disc_margin);
    let disc = match &profile {
        Some(p) => Some(UsableDisc::from_profile(p)?),
        None => None,
    };
    let (centre, candidates) = match &disc {
        Some(d) => (
            d.centre_mm,
            d.lattice(LATTICE_MM, 0.0, &limits, &options.sensor)?,
        ),
        None => {
            let o = config.origin()?;
            let c = [o.x.0, o.y.0];
            (
                c,
                (0..12)
                    .map(|k| [c[0] + LATTICE_MM * k as f64, c[1]])
                    .collect(),
            )
        }
    };
    // The rounds done (a resume) and the budget they spent.
    let done: Vec<&super::journal::ScanEntry> = journal
        .map(|j| j.rounds.iter().filter(|r| r.completed).collect())
        .unwrap_or_default();
    let mut pressed: Vec<PressedPoint> = done
        .iter()
        .flat_map(|r| plan_points(&r.plan))
        .map(|p| PressedPoint {
            stage_mm: p,
            error: 1.0,
        })
        .collect();
    let mut spent: f64 = done.iter().map(|r| r.took_s.unwrap_or(r.estimate_s)).sum();
    let budget = 60.0 * options.budget_min;
    let finished = journal.is_some_and(|j| j.acceptance.as_ref().is_some_and(|a| a.completed));
    let mut round = done.len();
    let accepted = journal.is_some_and(|j| j.acceptance.is_some());
    while !finished && !accepted && round < 100 {
        let name = format!("round-{}", round + 1);
        let mut n = options.round_presses;
        let sized = loop {
            let points = tour(
                &choose(&candidates, &pressed, n, COVERAGE_MM),
                pressed.last().map_or(centre, |p| p.stage_mm),
            );
            if points.is_empty() {
                break None;
            }
            let plan = press_plan(&name, &points, shapes, "forecast", margin)?;
            let (program, est) = program_of(&plan, config, &name)?;
            if est <= budget - spent {
                break Some((points, plan, program, est));
            }
            if n == 1 {
                break None;
            }
            n -= 1;
        };
        let Some((points, _plan, program, est)) = sized else {
            break;
        };
        scans.push(ScanCost {
            name,
            positions: points.len(),
            presses: points.len() * shapes.len(),
            bench_s: est,
            size: size_of(&program, config)?,
        });
        spent += est;
        pressed.extend(points.iter().map(|p| PressedPoint {
            stage_mm: *p,
            error: 1.0,
        }));
        round += 1;
    }
    if !finished {
        let positions = options.acceptance_presses;
        let plan = match journal.and_then(|j| j.acceptance.as_ref()) {
            Some(e) => e.plan.clone(),
            None => {
                let held_out = match &disc {
                    Some(d) => d.lattice(LATTICE_MM, 0.5, &limits, &options.sensor)?,
                    None => candidates.clone(),
                };
                let points = tour(&choose(&held_out, &[], positions, 1e6), centre);
                press_plan("acceptance", &points, shapes, "forecast", margin)?
            }
        };
        let n = plan_points(&plan).len();
        let (program, est) = program_of(&plan, config, "acceptance")?;
        scans.push(ScanCost {
            name: "acceptance".into(),
            positions: n,
            presses: n * shapes.len(),
            bench_s: est,
            size: size_of(&program, config)?,
        });
    }
    let per_frame = if cfg!(debug_assertions) {
        DEBUG_COMPUTE_S_PER_FRAME
    } else {
        COMPUTE_S_PER_FRAME
    };
    let computed: u64 = scans
        .iter()
        .filter(|s| s.name != "calibration")
        .map(|s| s.size.frames)
        .sum();
    let fine_tune_s = if options.fine_tune { FINE_TUNE_S } else { 0.0 };
    Ok(Cost {
        scans,
        rounds_done: done.len(),
        compute_s: per_frame * computed as f64 + fine_tune_s,
        keep_runs,
        prunes_as_read: prunes_as_read(keep_runs, options.last_block, options.fine_tune),
        fine_tune_s,
    })
}

/// The stage positions of a press plan's `[grid] points`.
fn plan_points(plan: &str) -> Vec<[f64; 2]> {
    let Ok(table) = plan.parse::<toml::Table>() else {
        return Vec::new();
    };
    table
        .get("grid")
        .and_then(|g| g.get("points"))
        .and_then(|p| p.as_array())
        .map(|points| {
            points
                .iter()
                .filter_map(|p| {
                    let xy = p.as_array()?;
                    Some([xy.first()?.as_float()?, xy.get(1)?.as_float()?])
                })
                .collect()
        })
        .unwrap_or_default()
}

fn program_of(plan: &str, config: &RigConfig, name: &str) -> Result<(ScanProgram, f64)> {
    let limits = config.limits()?;
    let program = Plan::parse(plan, name)?.program(&limits, name)?;
    let est = program.estimate(&limits).total.as_secs_f64();
    Ok((program, est))
}

fn scan_cost(
    name: &str,
    positions: usize,
    shapes: usize,
    plan: &str,
    config: &RigConfig,
) -> Result<ScanCost> {
    let (program, est) = program_of(plan, config, name)?;
    Ok(ScanCost {
        name: name.into(),
        positions,
        presses: positions * shapes,
        bench_s: est,
        size: size_of(&program, config)?,
    })
}

/// The run `program` will write on the rig, as every scan's dry run estimates it.
fn size_of(program: &ScanProgram, config: &RigConfig) -> Result<RunSize> {
    let limits = config.limits()?;
    let recording = Recording::from_rig_files(config, Some(&program.plan))?;
    Ok(recording.expected(program.estimate(&limits).recording_time()))
}

#[cfg(all(test, feature = "sim"))]
mod tests {
    use super::*;

    fn options(budget_min: f64) -> Options {
        Options {
            sensor: "unit-1".into(),
            base: "builtin:layered-keypoint".into(),
            budget_min,
            spec: None,
            spec_origin: "paper".into(),
            seed: 42,
            round_presses: 6,
            acceptance_presses: 10,
            last_block: false,
            fine_tune: false,
            camera: None,
        }
    }

    /// The forecast of a new commissioning on the simulated bench: the calibration grid, as
    /// many rounds as the budget holds (none over it), the acceptance presses with every
    /// indenter; the rounds' frames counted in what is written and left out of what is kept.
    #[test]
    fn a_forecast_fills_the_budget_with_rounds_and_keeps_less_than_it_writes() {
        let dir = std::env::temp_dir().join(format!("fringe-cost-{}", std::process::id()));
        let config = RigConfig::parse(
            &format!(
                "profiles = \"{}\"\n[sim]\nimage_scale = 0.5\n",
                dir.join("profiles").display()
            ),
            "rig.toml",
        )
        .expect("rig");
        let shapes = ["pentagon".to_string(), "rectangle".to_string()];
        let cost = forecast(&options(10.0), None, &shapes, &config, false).expect("forecast");
        let names: Vec<&str> = cost.scans.iter().map(|s| s.name.as_str()).collect();
        assert_eq!(names.first(), Some(&"calibration"), "{names:?}");
        assert_eq!(names.last(), Some(&"acceptance"), "{names:?}");
        let rounds: Vec<&ScanCost> = cost
            .scans
            .iter()
            .filter(|s| s.name.starts_with("round-"))
            .collect();
        assert!(rounds.len() >= 2, "{names:?}");
        let pressing: f64 = rounds.iter().map(|r| r.bench_s).sum();
        assert!(pressing <= 600.0 && pressing > 400.0, "{pressing} s of 600");
        assert!(rounds.iter().all(|r| r.presses == 2 * r.positions));
        assert_eq!(cost.scans[0].presses, 9);
        let acceptance = cost.scans.last().expect("acceptance");
        assert_eq!((acceptance.positions, acceptance.presses), (10, 20));
        assert!(cost.kept_bytes() < cost.written_bytes());
        // Each round's frames go once read: never two rounds' frames on disk at once.
        let largest_round = rounds
            .iter()
            .map(|r| r.size.frames_bytes)
            .max()
            .unwrap_or(0);
        assert!(cost.prunes_as_read);
        assert!(
            cost.peak_bytes() <= cost.kept_bytes() + largest_round,
            "peak {} kept {} round {largest_round}",
            cost.peak_bytes(),
            cost.kept_bytes()
        );
        let kept = forecast(&options(10.0), None, &shapes, &config, true).expect("forecast");
        assert_eq!(kept.kept_bytes(), kept.written_bytes());
        assert_eq!(kept.peak_bytes(), kept.written_bytes());
        // A candidate that trains on the rounds' frames keeps them until the commissioning ends.
        let mut block = options(10.0);
        block.last_block = true;
        let block = forecast(&block, None, &shapes, &config, false).expect("forecast");
        assert!(!block.prunes_as_read);
        assert_eq!(block.peak_bytes(), block.written_bytes());
        assert_eq!(block.kept_bytes(), cost.kept_bytes());
        assert!(cost.compute_s > 0.0);
        // Twice the budget: more rounds, never over it.
        let more = forecast(&options(20.0), None, &shapes, &config, false).expect("forecast");
        let pressing_more: f64 = more
            .scans
            .iter()
            .filter(|s| s.name.starts_with("round-"))
            .map(|s| s.bench_s)
            .sum();
        assert!(pressing_more > pressing && pressing_more <= 1200.0);
        let lines = cost.lines();
        assert!(lines[0].starts_with("what it takes"), "{lines:?}");
        assert!(
            lines.iter().any(|l| l.starts_with("  rounds 1-")),
            "{lines:?}"
        );
        assert!(!dir.exists(), "a forecast made {}", dir.display());
    }
}
