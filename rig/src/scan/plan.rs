//! Scan plans (`plan.toml`): the stage positions (a grid or a list of points), indenters, and how
//! each point is pressed.
//!
//! ```toml
//! name = "pentagon-grid"
//! [grid]
//! x = { start = -10.0, stop = 10.0, step = 5.0 }   # or explicit: x = [-10.0, 0.0, 10.0]
//! y = [0.0]
//! order = "snake"                                   # or "raster"
//! # instead of x, y and order, a list of stage positions (x, y in mm), pressed as written:
//! # points = [[12.5, 24.0], [11.0, 26.5]]
//! [indenters]
//! shapes = ["pentagon", "rectangle"]                # the operator is asked to change between
//! [approach]
//! safe_z = 0.0              # z (mm) for lateral moves
//! contact_threshold = 0.3   # N: first contact
//! [indentation]
//! force_targets = [1.0, 4.0, 9.0]                   # N, closed loop on the F/T; or depth_targets (mm past contact)
//! ramp_rate = 2.0           # N/s (or mm/s for depth)
//! dwell = 1.0               # s at each target
//! repetitions = 1
//! [safety]
//! force_ceiling = 12.0      # N
//! # tangential_ceiling = 8.0  # N of |Fx, Fy| (default: force_ceiling)
//! # [slide]                 # optional: slide at each force target (see `scan::slide`)
//! [recording]               # optional; overrides the rig file's [recording] key by key
//! store = "disc"            # "frame" (whole frames) or "disc" (the square around the disc)
//! disc_margin_px = 40.0
//! ```
//!
//! `[grid]` holds either `x` and `y` or `points`, never both. With `x` and `y` the order is:
//! indenter (outermost: a prompt to change it), then y rows (a manual y stage is asked once per
//! row), then x along the row (snake reverses every other row), then repetitions. With `points`
//! it is: indenter, then the points in the order written (a manual y stage is asked whenever a
//! point's y differs from the previous point's), then repetitions; `order` is refused with
//! `points`.

use super::slide::{Slide, SlideSection, MAX_SLIDE, MAX_SLIDES, MIN_SLIDE_SPEED};
use crate::axis::{Kinematics, SoftLimits};
use crate::config_file::{load_toml, parse_toml, ConfigError};
use crate::store::run_size::RecordingTime;
use crate::store::stored_part::RecordingSection;
use crate::units::{Millimetres, MillimetresPerSecond, Newtons};
use std::path::Path;
use std::time::Duration;

/// The most indentations one plan may hold (about 5 s each: roughly a week of bench time).
pub(crate) const MAX_POINTS: usize = 100_000;
/// The longest dwell at one target.
pub(crate) const MAX_DWELL: Duration = Duration::from_secs(600);
/// The most targets pressed at one point.
pub(crate) const MAX_TARGETS: usize = 100;
/// The most repetitions of each point.
pub(crate) const MAX_REPETITIONS: u32 = 1000;
/// The smallest first-contact force: below it the F/T noise alone reads as contact.
pub(crate) const MIN_CONTACT_THRESHOLD: Newtons = Newtons(0.02);
/// Ramp rates allowed for force targets (N/s) and depth targets (mm/s).
pub(crate) const FORCE_RAMP_RATE: std::ops::RangeInclusive<f64> = 0.01..=50.0;
pub(crate) const DEPTH_RAMP_RATE: std::ops::RangeInclusive<f64> = 0.001..=5.0;
/// The deepest depth target, mm past first contact.
pub(crate) const MAX_DEPTH: Millimetres = Millimetres(5.0);

/// A list of coordinates, as a range or explicitly.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(untagged)]
pub enum Axis1d {
    Range { start: f64, stop: f64, step: f64 },
    Points(Vec<f64>),
}

impl Axis1d {
    /// The coordinates; a range includes `stop` when it falls on the step (within 1e-9 mm).
    pub fn values(&self, key: &str) -> Result<Vec<f64>, String> {
        match self {
            Axis1d::Points(p) if p.is_empty() => Err(format!("key {key}: give at least one point")),
            Axis1d::Points(p) if p.len() > MAX_POINTS => Err(format!(
                "key {key}: {} points is too many (at most {MAX_POINTS})",
                p.len()
            )),
            Axis1d::Points(p) => match p.iter().find(|v| !v.is_finite()) {
                Some(v) => Err(format!("key {key}: {v} is not a number")),
                None => Ok(p.clone()),
            },
            Axis1d::Range { start, stop, step } => {
                if !(start.is_finite() && stop.is_finite() && step.is_finite() && *step > 0.0) {
                    return Err(format!(
                        "key {key}: start, stop must be numbers and step a positive number"
                    ));
                }
                let span = stop - start;
                let n = (span.abs() / step + 1e-9).floor();
                if n >= MAX_POINTS as f64 {
                    return Err(format!(
                        "key {key}: {n:.0} points is too many (at most {MAX_POINTS}): make the step larger"
                    ));
                }
                let n = n as usize;
                let dir = if span < 0.0 { -1.0 } else { 1.0 };
                Ok((0..=n).map(|k| start + dir * step * k as f64).collect())
            }
        }
    }
}

/// Grid ordering.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum Order {
    /// Every row in the same x direction.
    Raster,
    /// Every other row reversed (shortest path).
    #[default]
    Snake,
}

/// `[grid]`: either `x` and `y` (a grid, ordered by `order`) or `points` (stage positions in the
/// order written). [`Plan::program`] refuses any other combination.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GridSection {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub x: Option<Axis1d>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub y: Option<Axis1d>,
    /// Stage positions `[x, y]`, mm, pressed in the order written.
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "xy_pairs"
    )]
    pub points: Option<Vec<[f64; 2]>>,
    /// Row order of an x/y grid; not given means snake. Refused with `points`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub order: Option<Order>,
}

/// `grid.points` as read: a list of lists, each exactly `[x, y]` (a fixed-size array would take
/// the first two numbers of `[x, y, z]` and drop the rest without a word).
fn xy_pairs<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Option<Vec<[f64; 2]>>, D::Error> {
    use serde::de::Error;
    let lists: Vec<Vec<f64>> = serde::Deserialize::deserialize(d)?;
    let n = lists.len();
    lists
        .into_iter()
        .enumerate()
        .map(|(i, p)| match p.as_slice() {
            [x, y] => Ok([*x, *y]),
            _ => Err(D::Error::custom(format!(
                "point {} of {n} has {} numbers; write each point as [x, y] (mm)",
                i + 1,
                p.len()
            ))),
        })
        .collect::<Result<Vec<_>, _>>()
        .map(Some)
}

/// The checked stage positions of a plan.
enum Lateral<'a> {
    /// The x values of every row and the y of each row.
    Grid { xs: Vec<f64>, ys: Vec<f64> },
    /// `grid.points`, in the order written.
    Points(&'a [[f64; 2]]),
}

#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct IndenterSection {
    pub shapes: Vec<String>,
}

fn default_threshold() -> f64 {
    0.3
}

#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ApproachSection {
    /// z for lateral moves, away from the sensor.
    pub safe_z: f64,
    /// Pressing force that means first contact, N.
    #[serde(default = "default_threshold")]
    pub contact_threshold: f64,
}

fn default_one() -> u32 {
    1
}

#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct IndentationSection {
    /// Force targets, N, reached under closed-loop control on the F/T reading.
    #[serde(default)]
    pub force_targets: Vec<f64>,
    /// Depth targets, mm past first contact.
    #[serde(default)]
    pub depth_targets: Vec<f64>,
    /// N/s for force targets, mm/s for depth targets.
    pub ramp_rate: f64,
    /// Seconds held at each target.
    pub dwell: f64,
    #[serde(default = "default_one")]
    pub repetitions: u32,
}

#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SafetySection {
    pub force_ceiling: f64,
    /// The largest tangential force |Fx, Fy|, N; not given: the force ceiling.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tangential_ceiling: Option<f64>,
}

impl SafetySection {
    /// The tangential ceiling: as given, else the force ceiling.
    pub fn tangential(&self) -> Newtons {
        Newtons(self.tangential_ceiling.unwrap_or(self.force_ceiling))
    }
}

/// A scan plan as written.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Plan {
    pub name: String,
    pub grid: GridSection,
    pub indenters: IndenterSection,
    pub approach: ApproachSection,
    pub indentation: IndentationSection,
    pub safety: SafetySection,
    /// Slides at each force target ([`crate::scan::slide`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub slide: Option<SlideSection>,
    /// What the scan stores of each frame, over the rig file's `[recording]`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub recording: Option<RecordingSection>,
}

/// What is pressed at a point.
#[derive(Debug, Clone, PartialEq)]
pub enum Targets {
    Force(Vec<Newtons>),
    Depth(Vec<Millimetres>),
}

/// One indentation of the scan, in execution order.
#[derive(Debug, Clone, PartialEq)]
pub struct ScanPoint {
    /// Position in the execution order (0, 1, ...): the checkpoint number.
    pub index: u64,
    pub shape: String,
    pub x: Millimetres,
    pub y: Millimetres,
    pub repetition: u32,
    /// The operator must change the indenter to `shape` before this point.
    pub change_indenter: bool,
    /// y differs from the previous point's (a manual y stage asks the operator).
    pub new_row: bool,
    /// The press slides after its target (a plan with `[slide]`): it presses to the slide's
    /// force only.
    pub slide: Option<Slide>,
}

/// What the bench can do, for validation and duration estimates.
#[derive(Debug, Clone, PartialEq)]
pub struct BenchLimits {
    pub x: SoftLimits,
    pub y: SoftLimits,
    pub z: SoftLimits,
    pub x_motion: Kinematics,
    pub y_motion: Kinematics,
    pub z_motion: Kinematics,
    /// The y stage is moved by hand (rows are grouped and the operator asked once per row).
    pub manual_y: bool,
    /// The largest force the F/T sensor and the sensor under test may see.
    pub max_force: Newtons,
    /// The F/T transducer's rated range in Fz, from its calibration; `None` when unknown.
    pub ft_rating: Option<FtRating>,
    /// z of first contact, roughly: the known height of the sensor surface. z grows towards the
    /// sensor, so every safe height lies below it and the approach goes up from there.
    pub contact_z: Millimetres,
    /// How far each axis is from its home switch when a scan starts (x, y, z), when that is known
    /// before it opens (the simulated bench's power-up positions); `None`: unknown, and an
    /// estimate takes the middle of each travel.
    pub start: Option<[Millimetres; 3]>,
}

/// The rated range of an F/T transducer in Fz, from its calibration.
#[derive(Debug, Clone, PartialEq)]
pub struct FtRating {
    /// The transducer as messages name it ("the simulated Mini40 (SI-40-2, serial FT90001)").
    pub transducer: String,
    /// The largest |Fz| it is rated for.
    pub fz: Newtons,
}

impl FtRating {
    /// Refuses `force` (the value of `key`) above the rated range.
    pub fn check(&self, key: &str, force: Newtons) -> Result<(), String> {
        if force.0 > self.fz.0 {
            return Err(format!(
                "key {key}: {} N is above the rated range of the F/T transducer, {}: {} N in Fz; give at most {} N",
                shown(force.0),
                self.transducer,
                shown(self.fz.0),
                shown(self.fz.0)
            ));
        }
        Ok(())
    }
}

impl BenchLimits {
    /// Checks a safe height (`key` names where it came from): inside the z soft limits and clear
    /// of the sensor, short of the known contact height (z grows towards the sensor). A safe
    /// height at or past the surface would drag the indenter through the sensor on every lateral
    /// move and take the no-contact offset under load.
    pub fn check_safe_z(&self, key: &str, safe_z: Millimetres) -> Result<(), String> {
        if self.z.check("z", safe_z).is_err() {
            return Err(format!(
                "key {key}: {} mm is outside the z soft limits {:.3} .. {:.3} mm",
                shown(safe_z.0),
                self.z.min.0,
                self.z.max.0
            ));
        }
        if safe_z.0 >= self.contact_z.0 {
            let clear = (self.contact_z.0 - 1.0).max(self.z.min.0);
            return Err(format!(
                "key {key}: {} mm is at or past the sensor surface (first contact at z = {} mm; z grows towards the sensor): lateral moves there would drag the indenter through the sensor; give a safe height above the surface, such as {key} = {clear:.1}",
                shown(safe_z.0),
                shown(self.contact_z.0)
            ));
        }
        Ok(())
    }

    /// The z the approach may reach: 3 mm past the known contact height (towards the sensor),
    /// inside the soft limits; refused for a safe height at or past the contact height (an
    /// approach from there would have no way down to search).
    pub fn approach_limit(&self, safe_z: Millimetres) -> Result<Millimetres, String> {
        self.check_safe_z("approach.safe_z", safe_z)?;
        Ok(Millimetres(
            (self.contact_z.0 + 3.0).clamp(self.z.min.0, self.z.max.0),
        ))
    }
}

/// A plan checked against the bench, expanded into points.
#[derive(Debug, Clone, PartialEq)]
pub struct ScanProgram {
    pub plan: Plan,
    pub targets: Targets,
    /// The dwell at each target (checked: 0 ..= [`MAX_DWELL`]).
    pub dwell: Duration,
    /// The dwell at the end of each slide (zero without slides).
    pub slide_dwell: Duration,
    pub points: Vec<ScanPoint>,
}

impl Plan {
    /// Parses plan text; `origin` names it in errors.
    pub fn parse(text: &str, origin: &str) -> Result<Plan, ConfigError> {
        parse_toml(text, origin)
    }

    /// Loads a plan file.
    pub fn load(path: &Path) -> Result<(Plan, String), ConfigError> {
        load_toml(path)
    }

    /// Checks the plan against `bench` before any motion and expands it; errors name the key.
    pub fn program(&self, bench: &BenchLimits, origin: &str) -> Result<ScanProgram, ConfigError> {
        let err = |message: String| ConfigError {
            origin: origin.to_string(),
            message,
        };
        if self.name.contains('\0') {
            return Err(err("key name: contains a NUL byte".into()));
        }
        let lateral = self.lateral(bench).map_err(err)?;
        self.check_safe_z(bench).map_err(err)?;
        self.check_shapes().map_err(err)?;
        self.check_forces(bench).map_err(err)?;
        let targets = self.targets().map_err(err)?;
        self.check_pressing(&targets).map_err(err)?;
        self.check_tangential_ceiling(bench).map_err(err)?;
        let presses = self.presses(&targets, bench).map_err(err)?;
        if let Some(r) = &self.recording {
            r.stored_part().map_err(err)?;
            r.codec().map_err(err)?;
        }
        // The size check comes before anything is allocated for the points.
        self.check_count(&lateral, presses.len()).map_err(err)?;
        self.check_slide_ends(&lateral, &presses, bench)
            .map_err(err)?;
        let points = match &lateral {
            Lateral::Grid { xs, ys } => self.expand(xs, ys, &presses),
            Lateral::Points(points) => self.expand_points(points, &presses),
        };
        Ok(ScanProgram {
            plan: self.clone(),
            targets,
            dwell: Duration::from_secs_f64(self.indentation.dwell),
            slide_dwell: Duration::from_secs_f64(self.slide.as_ref().map_or(0.0, |s| s.dwell)),
            points,
        })
    }

    /// The stage positions: `grid.x` and `grid.y`, or `grid.points` (exactly one of the two
    /// forms), each checked against the bench's soft limits.
    fn lateral(&self, bench: &BenchLimits) -> Result<Lateral<'_>, String> {
        let grid = &self.grid;
        match (&grid.x, &grid.y, &grid.points) {
            (Some(x), Some(y), None) => {
                let (xs, ys) = grid_values(x, y, bench)?;
                Ok(Lateral::Grid { xs, ys })
            }
            (None, None, Some(points)) => {
                if let Some(order) = grid.order {
                    let order = match order {
                        Order::Snake => "snake",
                        Order::Raster => "raster",
                    };
                    return Err(format!(
                        "keys grid.order and grid.points: order = \"{order}\" applies to an x/y grid only; points are pressed in the order written: remove order"
                    ));
                }
                check_points(points, bench)?;
                Ok(Lateral::Points(points))
            }
            (x, y, Some(_)) => {
                let (given, grid_keys) = match (x.is_some(), y.is_some()) {
                    (true, true) => ("grid.x, grid.y and grid.points", "x and y"),
                    (true, false) => ("grid.x and grid.points", "x"),
                    _ => ("grid.y and grid.points", "y"),
                };
                Err(format!(
                    "keys {given}: give either x and y (a grid) or points (a list of [x, y] stage positions), not both: remove points, or remove {grid_keys}"
                ))
            }
            (None, None, None) => Err(
                "section [grid]: give the stage positions, either x and y (a grid, e.g. x = [10.5, 12.5] and y = [25.0]) or points (a list of [x, y] in mm, e.g. points = [[12.5, 24.0], [11.0, 26.5]])".into(),
            ),
            (Some(_), None, None) => Err(
                "key grid.x: given without grid.y: add y (the rows, e.g. y = [25.0]), or replace x with points = [[x, y], ...]".into(),
            ),
            (None, Some(_), None) => Err(
                "key grid.y: given without grid.x: add x (the positions along each row, e.g. x = [10.5, 12.5]), or replace y with points = [[x, y], ...]".into(),
            ),
        }
    }

    /// Checks `approach.safe_z` against the bench ([`BenchLimits::check_safe_z`]).
    fn check_safe_z(&self, bench: &BenchLimits) -> Result<(), String> {
        bench.check_safe_z("approach.safe_z", Millimetres(self.approach.safe_z))
    }

    /// Checks that there is at least one indenter and that each has a name.
    fn check_shapes(&self) -> Result<(), String> {
        if self.indenters.shapes.is_empty() {
            return Err("key indenters.shapes: name at least one indenter".into());
        }
        if let Some(s) = self.indenters.shapes.iter().find(|s| s.trim().is_empty()) {
            return Err(format!(
                "key indenters.shapes: {s:?} is not a name (give each indenter a name, e.g. \"pentagon\")"
            ));
        }
        Ok(())
    }

    /// Checks the force ceiling against the rig and the F/T transducer's rated range, and the
    /// contact threshold against the ceiling.
    fn check_forces(&self, bench: &BenchLimits) -> Result<(), String> {
        let ceiling = self.safety.force_ceiling;
        if let Some(rating) = &bench.ft_rating {
            rating.check("safety.force_ceiling", Newtons(ceiling))?;
        }
        if !(ceiling.is_finite() && ceiling > 0.0) || ceiling > bench.max_force.0 {
            return Err(format!(
                "key safety.force_ceiling: {} N must be positive and at most the rig's {:.1} N",
                shown(ceiling),
                bench.max_force.0
            ));
        }
        let threshold = self.approach.contact_threshold;
        if !(threshold.is_finite() && threshold >= MIN_CONTACT_THRESHOLD.0 && threshold < ceiling) {
            return Err(format!(
                "key approach.contact_threshold: {} N must be a number from {} N (above the F/T noise) and below the force ceiling {ceiling} N",
                shown(threshold),
                MIN_CONTACT_THRESHOLD.0
            ));
        }
        Ok(())
    }

    /// The checked force or depth targets (exactly one of the two lists is given).
    fn targets(&self) -> Result<Targets, String> {
        let ind = &self.indentation;
        let count_targets = ind.force_targets.len() + ind.depth_targets.len();
        if count_targets > MAX_TARGETS {
            return Err(format!(
                "section [indentation]: {count_targets} targets per point; at most {MAX_TARGETS}"
            ));
        }
        match (ind.force_targets.is_empty(), ind.depth_targets.is_empty()) {
            (false, true) => self.force_targets().map(Targets::Force),
            (true, false) => self.depth_targets().map(Targets::Depth),
            _ => Err("section [indentation]: give either force_targets or depth_targets".into()),
        }
    }

    /// The force targets, each between the contact threshold and the force ceiling.
    fn force_targets(&self) -> Result<Vec<Newtons>, String> {
        let ind = &self.indentation;
        let ceiling = self.safety.force_ceiling;
        let threshold = self.approach.contact_threshold;
        if let Some(t) = ind
            .force_targets
            .iter()
            .find(|t| !(t.is_finite() && **t > 0.0 && **t < ceiling))
        {
            return Err(format!(
                "key indentation.force_targets: {} N must be above 0 and below the force ceiling {ceiling} N",
                shown(*t)
            ));
        }
        if let Some(t) = ind.force_targets.iter().find(|t| **t <= threshold) {
            return Err(format!(
                "key indentation.force_targets: {t} N is not above approach.contact_threshold = {threshold} N (first contact must come before every target)"
            ));
        }
        Ok(ind.force_targets.iter().map(|t| Newtons(*t)).collect())
    }

    /// The depth targets, each above 0 and below [`MAX_DEPTH`].
    fn depth_targets(&self) -> Result<Vec<Millimetres>, String> {
        let ind = &self.indentation;
        if let Some(t) = ind
            .depth_targets
            .iter()
            .find(|t| !(t.is_finite() && **t > 0.0 && **t < MAX_DEPTH.0))
        {
            return Err(format!(
                "key indentation.depth_targets: {} mm must be above 0 and below {} mm",
                shown(*t),
                MAX_DEPTH.0
            ));
        }
        Ok(ind.depth_targets.iter().map(|t| Millimetres(*t)).collect())
    }

    /// Checks the ramp rate (in the targets' unit), the dwell and the repetitions.
    fn check_pressing(&self, targets: &Targets) -> Result<(), String> {
        let ind = &self.indentation;
        let (rate_range, rate_unit) = match targets {
            Targets::Force(_) => (FORCE_RAMP_RATE, "N/s"),
            Targets::Depth(_) => (DEPTH_RAMP_RATE, "mm/s"),
        };
        if !(ind.ramp_rate.is_finite() && rate_range.contains(&ind.ramp_rate)) {
            return Err(format!(
                "key indentation.ramp_rate: {} must be a number from {} to {} {rate_unit}",
                shown(ind.ramp_rate),
                rate_range.start(),
                rate_range.end()
            ));
        }
        if !(ind.dwell.is_finite() && ind.dwell >= 0.0 && ind.dwell <= MAX_DWELL.as_secs_f64()) {
            return Err(format!(
                "key indentation.dwell: {} s must be a number from 0 to {} s",
                shown(ind.dwell),
                MAX_DWELL.as_secs()
            ));
        }
        if ind.repetitions == 0 || ind.repetitions > MAX_REPETITIONS {
            return Err(format!(
                "key indentation.repetitions: {} must be from 1 to {MAX_REPETITIONS}",
                ind.repetitions
            ));
        }
        Ok(())
    }

    /// Checks that the plan holds at most [`MAX_POINTS`] indentations, without allocating them.
    fn check_count(&self, lateral: &Lateral, presses: usize) -> Result<(), String> {
        let shapes = self.indenters.shapes.len();
        let repetitions = self.indentation.repetitions;
        let (positions, described) = match lateral {
            Lateral::Grid { xs, ys } => (
                xs.len() as u128 * ys.len() as u128,
                format!("{} x x {} y", xs.len(), ys.len()),
            ),
            Lateral::Points(points) => (points.len() as u128, format!("{} points", points.len())),
        };
        let count = shapes as u128 * positions * presses as u128 * u128::from(repetitions);
        if count > MAX_POINTS as u128 {
            let slides = if self.slide.is_some() {
                format!(" x {presses} slides")
            } else {
                String::new()
            };
            return Err(format!(
                "the plan has {count} indentations ({shapes} shapes x {described}{slides} x {repetitions} repetitions); at most {MAX_POINTS} (weeks of bench time) in one plan: split it into several plans or a coarser grid"
            ));
        }
        Ok(())
    }

    /// Checks `safety.tangential_ceiling` when given: positive and at most the rig's force.
    fn check_tangential_ceiling(&self, bench: &BenchLimits) -> Result<(), String> {
        let Some(t) = self.safety.tangential_ceiling else {
            return Ok(());
        };
        if !(t.is_finite() && t > 0.0) || t > bench.max_force.0 {
            return Err(format!(
                "key safety.tangential_ceiling: {} N must be positive and at most the rig's {:.1} N",
                shown(t),
                bench.max_force.0
            ));
        }
        Ok(())
    }

    /// The presses made at each position: one per force target and slide (direction x speed)
    /// with `[slide]`, else one press through all the targets (`None`).
    fn presses(
        &self,
        targets: &Targets,
        bench: &BenchLimits,
    ) -> Result<Vec<Option<Slide>>, String> {
        let Some(slide) = &self.slide else {
            return Ok(vec![None]);
        };
        let Targets::Force(forces) = targets else {
            return Err(
                "section [slide]: a slide holds the normal force in closed loop: give indentation.force_targets, not depth_targets".into(),
            );
        };
        if slide.directions.is_empty() || slide.speeds.is_empty() {
            return Err(
                "section [slide]: give at least one direction (e.g. directions = [\"x\"]) and one speed (e.g. speeds = [1.0], mm/s)".into(),
            );
        }
        let per_target = slide.directions.len().saturating_mul(slide.speeds.len());
        if per_target > MAX_SLIDES {
            return Err(format!(
                "section [slide]: {} directions x {} speeds is {per_target} slides per target; at most {MAX_SLIDES}",
                slide.directions.len(),
                slide.speeds.len()
            ));
        }
        let d = slide.distance;
        if !(d.is_finite() && d > 0.0 && d <= MAX_SLIDE.0) {
            return Err(format!(
                "key slide.distance: {} mm must be above 0 and at most {} mm",
                shown(d),
                MAX_SLIDE.0
            ));
        }
        if !(slide.dwell.is_finite()
            && slide.dwell >= 0.0
            && slide.dwell <= MAX_DWELL.as_secs_f64())
        {
            return Err(format!(
                "key slide.dwell: {} s must be a number from 0 to {} s",
                shown(slide.dwell),
                MAX_DWELL.as_secs()
            ));
        }
        let mut degrees = Vec::new();
        for direction in &slide.directions {
            degrees.push(direction.degrees("slide.directions")?);
        }
        let mut presses = Vec::new();
        for force in forces {
            for &direction_deg in &degrees {
                for &speed in &slide.speeds {
                    let s = Slide {
                        force: *force,
                        direction_deg,
                        distance: Millimetres(d),
                        speed: MillimetresPerSecond(speed),
                    };
                    check_slide_motion(&s, bench)?;
                    presses.push(Some(s));
                }
            }
        }
        Ok(presses)
    }

    /// Checks that every slide ends inside the x and y soft limits from every position.
    fn check_slide_ends(
        &self,
        lateral: &Lateral,
        presses: &[Option<Slide>],
        bench: &BenchLimits,
    ) -> Result<(), String> {
        if self.slide.is_none() {
            return Ok(());
        }
        let check = |x: f64, y: f64| -> Result<(), String> {
            for s in presses.iter().flatten() {
                let (ex, ey) = s.end_from(Millimetres(x), Millimetres(y));
                for (axis, v, limits) in [("x", ex, &bench.x), ("y", ey, &bench.y)] {
                    if limits.check(axis, v).is_err() {
                        return Err(format!(
                            "section [slide]: the slide of {} mm at {} degrees from [{}, {}] ends at {axis} = {:.3} mm, outside the {axis} soft limits {:.3} .. {:.3} mm of the rig: shorten slide.distance or move the point",
                            shown(s.distance.0),
                            shown(s.direction_deg),
                            shown(x),
                            shown(y),
                            v.0,
                            limits.min.0,
                            limits.max.0
                        ));
                    }
                }
            }
            Ok(())
        };
        match lateral {
            Lateral::Grid { xs, ys } => {
                // The corners of the grid bound every point's slide.
                let (x0, x1) = min_max(xs);
                let (y0, y1) = min_max(ys);
                for (x, y) in [(x0, y0), (x0, y1), (x1, y0), (x1, y1)] {
                    check(x, y)?;
                }
                Ok(())
            }
            Lateral::Points(points) => points.iter().try_for_each(|&[x, y]| check(x, y)),
        }
    }

    /// The points in execution order: indenter, then y row, then x (snake or raster), then
    /// repetition.
    fn expand(&self, xs: &[f64], ys: &[f64], presses: &[Option<Slide>]) -> Vec<ScanPoint> {
        let mut points = Vec::new();
        let mut last: Option<(String, f64)> = None;
        for shape in &self.indenters.shapes {
            for (row, y) in ys.iter().enumerate() {
                let reverse = self.grid.order.unwrap_or_default() == Order::Snake && row % 2 == 1;
                let row_xs: Vec<f64> = if reverse {
                    xs.iter().rev().copied().collect()
                } else {
                    xs.to_vec()
                };
                for x in row_xs {
                    for slide in presses {
                        for repetition in 0..self.indentation.repetitions {
                            let change_indenter = last.as_ref().is_none_or(|(s, _)| s != shape);
                            let new_row = last.as_ref().is_none_or(|(_, ly)| ly != y);
                            points.push(ScanPoint {
                                index: points.len() as u64,
                                shape: shape.clone(),
                                x: Millimetres(x),
                                y: Millimetres(*y),
                                repetition,
                                change_indenter,
                                new_row,
                                slide: *slide,
                            });
                            last = Some((shape.clone(), *y));
                        }
                    }
                }
            }
        }
        points
    }

    /// The points of `grid.points` in execution order: indenter, then the points as written,
    /// then repetition.
    fn expand_points(&self, positions: &[[f64; 2]], presses: &[Option<Slide>]) -> Vec<ScanPoint> {
        let mut points = Vec::new();
        let mut last: Option<(&str, f64)> = None;
        for shape in &self.indenters.shapes {
            for &[x, y] in positions {
                for slide in presses {
                    for repetition in 0..self.indentation.repetitions {
                        let change_indenter = last.is_none_or(|(s, _)| s != shape);
                        let new_row = last.is_none_or(|(_, ly)| ly != y);
                        points.push(ScanPoint {
                            index: points.len() as u64,
                            shape: shape.clone(),
                            x: Millimetres(x),
                            y: Millimetres(y),
                            repetition,
                            change_indenter,
                            new_row,
                            slide: *slide,
                        });
                        last = Some((shape, y));
                    }
                }
            }
        }
        points
    }
}

/// A grid's x and y coordinates, each checked against the bench's soft limits.
fn grid_values(
    x: &Axis1d,
    y: &Axis1d,
    bench: &BenchLimits,
) -> Result<(Vec<f64>, Vec<f64>), String> {
    let xs = x.values("grid.x")?;
    let ys = y.values("grid.y")?;
    for (key, values, limits) in [("grid.x", &xs, &bench.x), ("grid.y", &ys, &bench.y)] {
        if let Some(v) = values
            .iter()
            .find(|v| limits.check(key, Millimetres(**v)).is_err())
        {
            return Err(format!(
                "key {key}: {v} mm is outside the soft limits {:.3} .. {:.3} mm of the rig",
                limits.min.0, limits.max.0
            ));
        }
    }
    Ok((xs, ys))
}

/// Checks `grid.points`: at least one and at most [`MAX_POINTS`] positions, each a pair of
/// numbers within the bench's x and y soft limits. Errors give the point's number, counted from
/// 1 as the operator reads the file.
fn check_points(points: &[[f64; 2]], bench: &BenchLimits) -> Result<(), String> {
    if points.is_empty() {
        return Err(
            "key grid.points: give at least one [x, y] position, e.g. points = [[12.5, 24.0]]"
                .into(),
        );
    }
    let n = points.len();
    if n > MAX_POINTS {
        return Err(format!(
            "key grid.points: {n} points is too many (at most {MAX_POINTS}): split the plan into several plans"
        ));
    }
    for (i, &[x, y]) in points.iter().enumerate() {
        let at = format!("point {} of {n}, [{}, {}]", i + 1, shown(x), shown(y));
        if !(x.is_finite() && y.is_finite()) {
            return Err(format!(
                "key grid.points: {at}: x and y must be numbers (mm)"
            ));
        }
        for (axis, v, limits) in [("x", x, &bench.x), ("y", y, &bench.y)] {
            if limits.check(axis, Millimetres(v)).is_err() {
                return Err(format!(
                    "key grid.points: {at}: {axis} = {} mm is outside the {axis} soft limits {:.3} .. {:.3} mm of the rig",
                    shown(v),
                    limits.min.0,
                    limits.max.0
                ));
            }
        }
    }
    Ok(())
}

/// The smallest and largest of `values` (not empty).
fn min_max(values: &[f64]) -> (f64, f64) {
    values
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(*v), hi.max(*v))
        })
}

/// Checks a slide's speed against the bench: at least [`MIN_SLIDE_SPEED`], each axis's share
/// within its speed, and no y share on a y stage moved by hand.
fn check_slide_motion(s: &Slide, bench: &BenchLimits) -> Result<(), String> {
    let v = s.speed.0;
    if !(v.is_finite() && v >= MIN_SLIDE_SPEED) {
        return Err(format!(
            "key slide.speeds: {} mm/s must be a number of at least {MIN_SLIDE_SPEED} mm/s",
            shown(v)
        ));
    }
    let m = s.motion(&bench.x_motion, &bench.y_motion);
    if bench.manual_y && m.y.is_some() {
        return Err(format!(
            "key slide.directions: {} degrees moves y, which is moved by hand on this rig: slide along x only (\"x\" or \"-x\")",
            shown(s.direction_deg)
        ));
    }
    for (axis, share, limit) in [("x", m.x, &bench.x_motion), ("y", m.y, &bench.y_motion)] {
        if let Some(k) = share {
            if k.velocity.0 > limit.velocity.0 * (1.0 + 1e-9) {
                return Err(format!(
                    "key slide.speeds: {} mm/s at {} degrees asks {axis} for {:.3} mm/s, above its {:.3} mm/s in the rig file",
                    shown(v),
                    shown(s.direction_deg),
                    k.velocity.0,
                    limit.velocity.0
                ));
            }
        }
    }
    Ok(())
}

/// Time of a trapezoidal move of `distance` with `k` (rest to rest).
pub(crate) fn move_time(distance: f64, k: &Kinematics) -> Duration {
    seconds(k.move_seconds(distance))
}

/// Time of a move of `distance` from rest that is stopped at once where it ends (the approach
/// stops on first contact, without decelerating).
fn time_to_stop_at(distance: f64, k: &Kinematics) -> f64 {
    let d = distance.abs();
    let (v, a) = (
        k.velocity.0.abs().max(1e-9),
        k.acceleration.0.abs().max(1e-9),
    );
    if d <= v * v / (2.0 * a) {
        (2.0 * d / a).sqrt()
    } else {
        d / v + v / (2.0 * a)
    }
}

/// Seconds as a duration, saturating (an estimate never panics on a huge or odd number).
fn seconds(secs: f64) -> Duration {
    Duration::try_from_secs_f64(secs.max(0.0)).unwrap_or(Duration::MAX)
}

/// How a press goes, as the engine makes it (`scan::press`, `engine::indentation`) with the
/// default [`PressSettings`](crate::scan::press::PressSettings): what the estimate of a press
/// counts beyond the plan's moves and dwells.
mod pressing {
    /// Newton steps of one force target (measured on the simulated layered sensor: two, the
    /// first from the assumed stiffness, the second from the measured one).
    pub(super) const NEWTON_STEPS: f64 = 2.0;
    /// z travel of one Newton step, mm (about half the force step over the sensor's 10 N/mm).
    pub(super) const STEP_MM: f64 = 0.075;
    /// The pause after each step and after first contact, and one force reading (50 samples at
    /// 5 kHz), s.
    pub(super) const SETTLE_S: f64 = 0.060 + 0.010;
    /// The stiffness a press assumes until it has measured one, N/mm: how deep the largest target
    /// goes past contact, for the retract.
    pub(super) const STIFFNESS_N_PER_MM: f64 = 10.0;
    /// First contact lies this far past the sensor's nominal surface, mm (0.3 N on the layered
    /// sensor: 0.04 to 0.10 mm measured).
    pub(super) const CONTACT_PAST_MM: f64 = 0.05;
}

/// The force (or depth) targets one press goes through, as the engine ramps force targets:
/// steps of at most half a second of the ramp rate (at least 0.2 N) from the contact threshold.
fn press_steps(targets: &Targets, ramp_rate: f64, contact_threshold: f64) -> usize {
    match targets {
        Targets::Depth(t) => t.len(),
        Targets::Force(t) => {
            let step = (ramp_rate * 0.5).max(0.2);
            let mut f = contact_threshold;
            let mut n = 0usize;
            for target in t {
                let gap = (target.0 - f).abs();
                // Saturating: an absurd plan is a huge estimate, never a loop without end.
                n = n.saturating_add(((gap / step).ceil() as usize).max(1));
                f = target.0;
            }
            n
        }
    }
}

/// The estimate of a dry run.
#[derive(Debug, Clone, PartialEq)]
pub struct Estimate {
    /// Everything: homing, moves, presses.
    pub total: Duration,
    /// Of which homing z, then x and y (unless moved by hand) at once, z down to the safe height
    /// and the move to the first point: each axis from where it starts when that is known
    /// ([`BenchLimits::start`]), else from the middle of its travel.
    pub homing: Duration,
    /// Of which the indentations (approach, ramps, dwells, retract): the time the scan films,
    /// since frames are stored only while the indenter presses.
    pub filming: Duration,
    pub lateral_path_mm: f64,
    pub indenter_changes: usize,
    pub manual_rows: usize,
}

impl ScanProgram {
    /// Estimated duration from the bench kinematics, homing included (operator prompts not
    /// counted).
    pub fn estimate(&self, bench: &BenchLimits) -> Estimate {
        self.estimate_from(bench, 0)
    }

    /// [`ScanProgram::estimate`] of the points from index `first` on (what a resumed run has
    /// left): homing, the move to point `first`, and the points after it.
    ///
    /// The time follows the moves the engine makes with the bench's kinematics (trapezoidal
    /// profiles, as the axes and the simulator move): homing z, then x and y together, z down to
    /// the safe height; per point the lateral move (x and y together), the approach to first
    /// contact (stopped there), the force targets in the engine's ramp steps (each a few Newton
    /// steps with their settling, [`pressing`]), the dwells and the retract to the safe height.
    pub fn estimate_from(&self, bench: &BenchLimits, first: usize) -> Estimate {
        let plan = &self.plan;
        let points = self.points.get(first..).unwrap_or_default();
        let start = bench.start.map(|s| s.map(|m| m.0.abs()));
        let middle = |l: &SoftLimits| (l.max.0 - l.min.0).abs() / 2.0;
        let [from_x, from_y, from_z] =
            start.unwrap_or([middle(&bench.x), middle(&bench.y), middle(&bench.z)]);
        let home_x = move_time(from_x, &bench.x_motion);
        let home_y = if bench.manual_y {
            Duration::ZERO
        } else {
            move_time(from_y, &bench.y_motion)
        };
        let mut homing =
            move_time(from_z, &bench.z_motion).as_secs_f64() + home_x.max(home_y).as_secs_f64();
        if let Some(first) = points.first() {
            let to_x = move_time(first.x.0, &bench.x_motion);
            let to_y = if bench.manual_y {
                Duration::ZERO
            } else {
                move_time(first.y.0, &bench.y_motion)
            };
            homing += to_x.max(to_y).as_secs_f64()
                + move_time(plan.approach.safe_z, &bench.z_motion).as_secs_f64();
        }
        let ind = &plan.indentation;
        let (mut secs, mut path) = (0.0f64, 0.0f64);
        let (mut changes, mut rows) = (0, 0);
        let contact_past = pressing::CONTACT_PAST_MM;
        let approach = (bench.contact_z.0 - plan.approach.safe_z).abs() + contact_past;
        let (n_targets, deepest) = match &self.targets {
            Targets::Force(t) => (
                t.len(),
                t.iter().map(|f| f.0).fold(0.0, f64::max) / pressing::STIFFNESS_N_PER_MM,
            ),
            Targets::Depth(t) => (t.len(), t.iter().map(|d| d.0).fold(0.0, f64::max)),
        };
        let steps = press_steps(
            &self.targets,
            ind.ramp_rate,
            plan.approach.contact_threshold,
        ) as f64;
        let z = &bench.z_motion;
        let newton_step = move_time(pressing::STEP_MM, z).as_secs_f64() + pressing::SETTLE_S;
        let pressing_s = match &self.targets {
            Targets::Force(_) => steps * pressing::NEWTON_STEPS * newton_step,
            // Depth targets are driven at the ramp rate (mm/s), then settled.
            Targets::Depth(_) => deepest / ind.ramp_rate.max(1e-9) + steps * pressing::SETTLE_S,
        };
        let per_press = time_to_stop_at(approach, z)
            + pressing::SETTLE_S
            + pressing_s
            + n_targets as f64 * ind.dwell
            + move_time(approach + deepest, z).as_secs_f64();
        // A press that slides goes to its one force, dwells, slides, dwells again and lifts.
        let slide_dwell = self.slide_dwell.as_secs_f64();
        let per_slide = |s: &Slide| {
            let one = Targets::Force(vec![s.force]);
            let steps = press_steps(&one, ind.ramp_rate, plan.approach.contact_threshold) as f64;
            let motion = s.motion(&bench.x_motion, &bench.y_motion);
            time_to_stop_at(approach, z)
                + pressing::SETTLE_S
                + steps * pressing::NEWTON_STEPS * newton_step
                + ind.dwell
                + motion.seconds(s.distance.0)
                + slide_dwell
                + move_time(approach + s.force.0 / pressing::STIFFNESS_N_PER_MM, z).as_secs_f64()
        };
        let mut at: Option<(f64, f64)> = None;
        let mut filming = 0.0f64;
        for p in points {
            if p.change_indenter {
                changes += 1;
            }
            if p.new_row && bench.manual_y {
                rows += 1;
            }
            if let Some((x0, y0)) = at {
                let (dx, dy) = (p.x.0 - x0, p.y.0 - y0);
                path += dx.abs() + dy.abs();
                secs += move_time(dx, &bench.x_motion)
                    .max(if bench.manual_y {
                        Duration::ZERO
                    } else {
                        move_time(dy, &bench.y_motion)
                    })
                    .as_secs_f64();
            }
            let press = p.slide.as_ref().map_or(per_press, per_slide);
            // A slide ends away from the point: the next lateral move starts there.
            at = Some(match &p.slide {
                Some(s) => {
                    let (x, y) = s.end_from(p.x, p.y);
                    (x.0, y.0)
                }
                None => (p.x.0, p.y.0),
            });
            secs += press;
            filming += press;
        }
        Estimate {
            total: seconds(secs + homing),
            homing: seconds(homing),
            filming: seconds(filming),
            lateral_path_mm: path,
            indenter_changes: changes,
            manual_rows: rows,
        }
    }
}

impl Estimate {
    /// How long the scan records: the force stream all along, frames while it films.
    pub fn recording_time(&self) -> RecordingTime {
        RecordingTime {
            total: self.total,
            filming: self.filming,
        }
    }
}

/// A value from the user's file as messages show it: very large or very small magnitudes in
/// exponent form (`1e300`, not 301 digits).
fn shown(v: f64) -> String {
    if v != 0.0 && v.is_finite() && !(1e-6..1e9).contains(&v.abs()) {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::units::{MillimetresPerSecond, MillimetresPerSecondSquared};

    const PLAN: &str = r#"
name = "test"
[grid]
x = { start = -5.0, stop = 5.0, step = 5.0 }
y = [0.0, 2.0]
[indenters]
shapes = ["pentagon", "rectangle"]
[approach]
safe_z = 1.0
[indentation]
force_targets = [1.0, 4.0]
ramp_rate = 2.0
dwell = 0.5
[safety]
force_ceiling = 10.0
"#;

    fn bench() -> BenchLimits {
        let k = Kinematics {
            velocity: MillimetresPerSecond(2.0),
            acceleration: MillimetresPerSecondSquared(4.0),
        };
        let lim = |a, b| SoftLimits::new(Millimetres(a), Millimetres(b)).expect("limits");
        BenchLimits {
            x: lim(-12.0, 12.0),
            y: lim(-12.0, 12.0),
            z: lim(0.0, 25.0),
            x_motion: k,
            y_motion: k,
            z_motion: k,
            manual_y: true,
            max_force: Newtons(20.0),
            ft_rating: None,
            contact_z: Millimetres(5.0),
            start: None,
        }
    }

    #[test]
    fn snake_order_groups_shapes_and_rows() {
        let plan = Plan::parse(PLAN, "plan.toml").expect("parse");
        let program = plan.program(&bench(), "plan.toml").expect("valid");
        let xy: Vec<(String, f64, f64)> = program
            .points
            .iter()
            .map(|p| (p.shape.clone(), p.x.0, p.y.0))
            .collect();
        assert_eq!(xy.len(), 12);
        assert_eq!(
            &xy[..6],
            &[
                ("pentagon".into(), -5.0, 0.0),
                ("pentagon".into(), 0.0, 0.0),
                ("pentagon".into(), 5.0, 0.0),
                ("pentagon".into(), 5.0, 2.0),
                ("pentagon".into(), 0.0, 2.0),
                ("pentagon".into(), -5.0, 2.0),
            ]
        );
        assert!(program.points[6].change_indenter && program.points[6].new_row);
        assert_eq!(
            program.points.iter().filter(|p| p.change_indenter).count(),
            2
        );
        let est = program.estimate(&bench());
        assert_eq!(est.indenter_changes, 2);
        assert_eq!(est.manual_rows, 4);
        // lateral: 5+5 per row, plus row changes of 2 mm (3 of them, one with the shape change
        // going back from (-5, 2) to (-5, 0)).
        assert!(
            (est.lateral_path_mm - (4.0 * 10.0 + 3.0 * 2.0)).abs() < 1e-9,
            "{est:?}"
        );
        assert!(est.total > Duration::from_secs(12 * 5), "{est:?}");
        // Where the axes start is unknown: homing z from the middle of its travel (12.5 mm at
        // 2 mm/s, 4 mm/s^2: 6.75 s), then x from the middle of its (12 mm: 6.5 s; y is moved by
        // hand), then to the first point (-5 mm: 3 s) and up to safe z.
        let safe_z = program.plan.approach.safe_z;
        let want = 6.75 + 6.5 + 3.0 + move_time(safe_z, &bench().z_motion).as_secs_f64();
        assert!(
            (est.homing.as_secs_f64() - want).abs() < 1e-6,
            "{est:?} (want {want} s)"
        );
        // Where they start known (the simulated bench's power-up positions): from there, x and
        // y at once after z.
        let known = BenchLimits {
            start: Some([Millimetres(8.0), Millimetres(25.0), Millimetres(3.0)]),
            manual_y: false,
            ..bench()
        };
        let est_known = program.estimate(&known);
        // z 3 mm: 2 s; x 8 mm: 4.5 s, y 25 mm: 13 s together; to the first point (-5, 0): 3 s.
        let want = 2.0 + 13.0 + 3.0 + move_time(safe_z, &bench().z_motion).as_secs_f64();
        assert!(
            (est_known.homing.as_secs_f64() - want).abs() < 1e-6,
            "{est_known:?} (want {want} s)"
        );
        assert!(est.total > est.homing);
        assert!(
            est.filming > Duration::ZERO && est.filming + est.homing < est.total,
            "{est:?}"
        );

        // A resume from point 6 (the second shape): only the last six points, and the homing
        // ends at point 6 (-5, 0) as the whole plan's ends at point 0.
        let rest = program.estimate_from(&bench(), 6);
        assert_eq!(program.estimate_from(&bench(), 0), est);
        assert_eq!((rest.indenter_changes, rest.manual_rows), (1, 2));
        assert!(
            (rest.lateral_path_mm - (2.0 * 10.0 + 2.0)).abs() < 1e-9,
            "{rest:?}"
        );
        assert_eq!(rest.homing, est.homing);
        assert!(
            rest.total < est.total && rest.total > rest.homing,
            "{rest:?}"
        );
        let none_left = program.estimate_from(&bench(), program.points.len() + 3);
        assert_eq!(none_left.lateral_path_mm, 0.0);
        assert!(none_left.total < rest.total, "{none_left:?}");
    }

    #[test]
    fn plans_outside_the_rig_are_refused_naming_the_key() {
        let too_far = PLAN.replace("stop = 5.0", "stop = 15.0");
        let err = Plan::parse(&too_far, "plan.toml")
            .expect("parse")
            .program(&bench(), "plan.toml")
            .expect_err("outside limits");
        assert!(
            err.to_string().starts_with("plan.toml: key grid.x: 15 mm"),
            "{err}"
        );
        let too_hard = PLAN.replace("[1.0, 4.0]", "[1.0, 11.0]");
        let err = Plan::parse(&too_hard, "p")
            .expect("parse")
            .program(&bench(), "p")
            .expect_err("above ceiling");
        assert!(
            err.to_string().contains("indentation.force_targets: 11 N"),
            "{err}"
        );
        let both = PLAN.replace("ramp_rate", "depth_targets = [0.5]\nramp_rate");
        let err = Plan::parse(&both, "p")
            .expect("parse")
            .program(&bench(), "p")
            .expect_err("both kinds");
        assert!(
            err.to_string()
                .contains("either force_targets or depth_targets"),
            "{err}"
        );
        let typo = PLAN.replace("dwell", "dwel");
        let err = Plan::parse(&typo, "plan.toml").expect_err("unknown key");
        assert!(err.to_string().contains("dwel"), "{err}");
    }

    fn refusal(plan_text: &str) -> String {
        match Plan::parse(plan_text, "plan.toml") {
            Err(e) => e.to_string(),
            Ok(plan) => plan
                .program(&bench(), "plan.toml")
                .map(|p| format!("accepted with {} points", p.points.len()))
                .unwrap_or_else(|e| e.to_string()),
        }
    }

    #[test]
    fn contact_threshold_must_lie_below_every_target_and_the_ceiling() {
        // A nan threshold once pressed the sensor to the force ceiling three times.
        for bad in ["nan", "-1.0", "0.0", "1.0", "2.5", "10.0", "11.0", "inf"] {
            let text = PLAN.replace(
                "safe_z = 1.0",
                &format!("safe_z = 1.0\ncontact_threshold = {bad}"),
            );
            let msg = refusal(&text);
            assert!(
                msg.starts_with("plan.toml: key approach.contact_threshold")
                    || msg.contains("is not above approach.contact_threshold"),
                "threshold {bad}: {msg}"
            );
        }
        let ok = PLAN.replace("safe_z = 1.0", "safe_z = 1.0\ncontact_threshold = 0.5");
        assert!(refusal(&ok).starts_with("accepted"), "{}", refusal(&ok));
        // With depth targets the threshold is still bounded by the ceiling.
        let depth = PLAN
            .replace("force_targets = [1.0, 4.0]", "depth_targets = [0.3]")
            .replace("safe_z = 1.0", "safe_z = 1.0\ncontact_threshold = 12.0");
        assert!(
            refusal(&depth).contains("approach.contact_threshold"),
            "{}",
            refusal(&depth)
        );
    }

    #[test]
    fn a_safe_height_at_or_past_the_sensor_surface_is_refused_naming_the_key() {
        // The bench's surface is at z 5 mm and z grows towards the sensor.
        for inside in ["5.0", "5.5", "16.0"] {
            let msg = refusal(&PLAN.replace("safe_z = 1.0", &format!("safe_z = {inside}")));
            assert!(
                msg.starts_with("plan.toml: key approach.safe_z:")
                    && msg.contains("at or past the sensor surface (first contact at z = 5 mm")
                    && msg.contains("approach.safe_z = 4.0"),
                "{inside}: {msg}"
            );
        }
        assert!(refusal(&PLAN.replace("safe_z = 1.0", "safe_z = 4.9")).starts_with("accepted"));
        // The approach goes towards the sensor, 3 mm past the surface; from a safe height past
        // the surface it has no way down and is refused rather than turned round.
        let b = bench();
        assert_eq!(b.approach_limit(Millimetres(1.0)), Ok(Millimetres(8.0)));
        let refused = b.approach_limit(Millimetres(6.0)).expect_err("past");
        assert!(refused.contains("approach.safe_z"), "{refused}");
        let deep = BenchLimits {
            contact_z: Millimetres(24.0),
            ..bench()
        };
        assert_eq!(deep.approach_limit(Millimetres(1.0)), Ok(Millimetres(25.0)));
    }

    #[test]
    fn a_ceiling_above_the_transducers_rated_range_is_refused_naming_it() {
        let rated = BenchLimits {
            max_force: Newtons(1e9),
            ft_rating: Some(FtRating {
                transducer: "the simulated Mini40 (SI-40-2, serial FT90001)".into(),
                fz: Newtons(120.0),
            }),
            ..bench()
        };
        let text = PLAN
            .replace("[1.0, 4.0]", "[150.0]")
            .replace("force_ceiling = 10.0", "force_ceiling = 200.0");
        let plan = Plan::parse(&text, "plan.toml").expect("parse");
        let msg = plan
            .program(&rated, "plan.toml")
            .expect_err("above the rated range")
            .to_string();
        assert_eq!(
            msg,
            "plan.toml: key safety.force_ceiling: 200 N is above the rated range of the F/T transducer, the simulated Mini40 (SI-40-2, serial FT90001): 120 N in Fz; give at most 120 N"
        );
        let within = PLAN.replace("force_ceiling = 10.0", "force_ceiling = 120.0");
        let plan = Plan::parse(&within, "plan.toml").expect("parse");
        assert!(plan.program(&rated, "plan.toml").is_ok());
    }

    #[test]
    fn every_plan_number_is_checked_before_anything_runs() {
        for (from, to, key) in [
            ("dwell = 0.5", "dwell = 1e20", "indentation.dwell"),
            ("dwell = 0.5", "dwell = 1e300", "indentation.dwell"),
            ("dwell = 0.5", "dwell = nan", "indentation.dwell"),
            (
                "ramp_rate = 2.0",
                "ramp_rate = 1e-300",
                "indentation.ramp_rate",
            ),
            (
                "ramp_rate = 2.0",
                "ramp_rate = 1e300",
                "indentation.ramp_rate",
            ),
            ("safe_z = 1.0", "safe_z = nan", "approach.safe_z"),
            (
                "force_ceiling = 10.0",
                "force_ceiling = nan",
                "safety.force_ceiling",
            ),
            ("[1.0, 4.0]", "[1.0, nan]", "indentation.force_targets"),
            ("y = [0.0, 2.0]", "y = [0.0, inf]", "grid.y"),
        ] {
            let msg = refusal(&PLAN.replace(from, to));
            assert!(msg.contains(key), "{to}: {msg}");
        }
        // A huge or tiny value is quoted as the user wrote it, not as hundreds of digits.
        let msg = refusal(&PLAN.replace("dwell = 0.5", "dwell = 1e300"));
        assert!(msg.contains("1e300 s must be"), "{msg}");
        let msg = refusal(&PLAN.replace("ramp_rate = 2.0", "ramp_rate = 1e-300"));
        assert!(msg.contains("1e-300 must be"), "{msg}");
        assert!(msg.len() < 200, "{msg}");
    }

    #[test]
    fn oversized_plans_are_refused_before_allocation() {
        let huge_reps = PLAN.replace("dwell = 0.5", "dwell = 0.5\nrepetitions = 4294967295");
        assert!(refusal(&huge_reps).contains("indentation.repetitions"));
        // 10^4 x 10^3 = 10^7 points: each axis alone is allowed, the product is not.
        let wide = PLAN
            .replace(
                "x = { start = -5.0, stop = 5.0, step = 5.0 }",
                "x = { start = -5.0, stop = 5.0, step = 0.001 }",
            )
            .replace(
                "y = [0.0, 2.0]",
                "y = { start = 0.0, stop = 10.0, step = 0.01 }",
            );
        let msg = refusal(&wide);
        assert!(
            msg.contains("indentations") && msg.contains("at most 100000"),
            "{msg}"
        );
        let tiny_step = PLAN.replace("step = 5.0", "step = 1e-9");
        assert!(
            refusal(&tiny_step).contains("too many"),
            "{}",
            refusal(&tiny_step)
        );
    }

    #[test]
    fn estimates_of_the_largest_plans_do_not_panic() {
        let slow = PLAN
            .replace("dwell = 0.5", "dwell = 600.0\nrepetitions = 1000")
            .replace("ramp_rate = 2.0", "ramp_rate = 0.01");
        let plan = Plan::parse(&slow, "p").expect("parse");
        let program = plan.program(&bench(), "p").expect("valid");
        assert_eq!(program.dwell, MAX_DWELL);
        let est = program.estimate(&bench());
        assert!(est.total > Duration::from_secs(12_000 * 600), "{est:?}");
        let k = Kinematics {
            velocity: MillimetresPerSecond(f64::MIN_POSITIVE),
            acceleration: MillimetresPerSecondSquared(f64::MIN_POSITIVE),
        };
        assert_eq!(move_time(1e300, &k), Duration::MAX);
    }

    /// `PLAN` with its x/y grid replaced by `points = {points}`.
    fn with_points(points: &str) -> String {
        let grid = "x = { start = -5.0, stop = 5.0, step = 5.0 }\ny = [0.0, 2.0]\n";
        assert!(PLAN.contains(grid));
        PLAN.replace(grid, &format!("points = {points}\n"))
    }

    #[test]
    fn points_are_pressed_as_written_for_each_shape_then_repeated() {
        let text = with_points("[[5.0, 2.0], [-5.0, 0.0], [0.0, 0.0], [1, 2]]")
            .replace("dwell = 0.5", "dwell = 0.5\nrepetitions = 2");
        let plan = Plan::parse(&text, "plan.toml").expect("parse");
        let program = plan.program(&bench(), "plan.toml").expect("valid");
        let got: Vec<(&str, f64, f64, u32, bool, bool)> = program
            .points
            .iter()
            .map(|p| {
                (
                    p.shape.as_str(),
                    p.x.0,
                    p.y.0,
                    p.repetition,
                    p.change_indenter,
                    p.new_row,
                )
            })
            .collect();
        let per_shape = |shape, first_new_row| {
            vec![
                (shape, 5.0, 2.0, 0, true, first_new_row),
                (shape, 5.0, 2.0, 1, false, false),
                (shape, -5.0, 0.0, 0, false, true),
                (shape, -5.0, 0.0, 1, false, false),
                (shape, 0.0, 0.0, 0, false, false),
                (shape, 0.0, 0.0, 1, false, false),
                (shape, 1.0, 2.0, 0, false, true),
                (shape, 1.0, 2.0, 1, false, false),
            ]
        };
        // The rectangle starts at y = 2 where the pentagon ended: a new indenter, the same row.
        let want = [per_shape("pentagon", true), per_shape("rectangle", false)].concat();
        assert_eq!(got, want);
        assert!(program
            .points
            .iter()
            .enumerate()
            .all(|(i, p)| p.index == i as u64));
        let est = program.estimate(&bench());
        assert_eq!(est.indenter_changes, 2);
        assert_eq!(est.manual_rows, 5);
        // 12 + 5 + 3 mm per shape (|dx| + |dy|), and 4 mm from (1, 2) back to (5, 2).
        assert!(
            (est.lateral_path_mm - (2.0 * 20.0 + 4.0)).abs() < 1e-9,
            "{est:?}"
        );
        // Homing ends at the first point as written (5 mm: 3 s), not at a grid corner.
        let safe_z = program.plan.approach.safe_z;
        let want = 6.75 + 6.5 + 3.0 + move_time(safe_z, &bench().z_motion).as_secs_f64();
        assert!((est.homing.as_secs_f64() - want).abs() < 1e-6, "{est:?}");
    }

    #[test]
    fn a_grid_is_given_by_x_and_y_or_by_points_never_both() {
        let both = PLAN.replace("y = [0.0, 2.0]", "y = [0.0, 2.0]\npoints = [[0.0, 0.0]]");
        let msg = refusal(&both);
        assert!(
            msg.starts_with("plan.toml: keys grid.x, grid.y and grid.points:")
                && msg.contains("not both"),
            "{msg}"
        );
        let x_and_points = with_points("[[0.0, 0.0]]").replace("[grid]", "[grid]\nx = [1.0]");
        let msg = refusal(&x_and_points);
        assert!(
            msg.starts_with("plan.toml: keys grid.x and grid.points:")
                && msg.ends_with("remove points, or remove x"),
            "{msg}"
        );
        let neither = with_points("[[0.0, 0.0]]").replace("points = [[0.0, 0.0]]\n", "");
        let msg = refusal(&neither);
        assert!(
            msg.starts_with("plan.toml: section [grid]:")
                && msg.contains("x and y")
                && msg.contains("points = [["),
            "{msg}"
        );
        let x_only = PLAN.replace("y = [0.0, 2.0]\n", "");
        let msg = refusal(&x_only);
        assert!(
            msg.starts_with("plan.toml: key grid.x: given without grid.y")
                && msg.contains("points = [[x, y], ...]"),
            "{msg}"
        );
        let y_only = PLAN.replace("x = { start = -5.0, stop = 5.0, step = 5.0 }\n", "");
        let msg = refusal(&y_only);
        assert!(
            msg.starts_with("plan.toml: key grid.y: given without grid.x"),
            "{msg}"
        );
        for order in ["snake", "raster"] {
            let ordered = with_points("[[0.0, 0.0]]")
                .replace("[indenters]", &format!("order = \"{order}\"\n[indenters]"));
            let msg = refusal(&ordered);
            assert!(
                msg.starts_with("plan.toml: keys grid.order and grid.points:")
                    && msg.contains("remove order"),
                "{msg}"
            );
        }
        assert!(refusal(&with_points("[[0.0, 0.0]]")).starts_with("accepted with 2 points"));
    }

    #[test]
    fn every_point_is_checked_against_the_rig() {
        let msg = refusal(&with_points("[[0.0, 0.0], [5.0, 2.0], [15.0, 2.0]]"));
        assert!(
            msg.starts_with("plan.toml: key grid.points: point 3 of 3, [15, 2]: x = 15 mm")
                && msg.contains("-12.000 .. 12.000 mm"),
            "{msg}"
        );
        let msg = refusal(&with_points("[[0.0, -12.5]]"));
        assert!(
            msg.starts_with("plan.toml: key grid.points: point 1 of 1, [0, -12.5]: y = -12.5 mm"),
            "{msg}"
        );
        for bad in ["[[nan, 0.0]]", "[[0.0, inf]]", "[[0.0, 0.0], [-inf, 1.0]]"] {
            let msg = refusal(&with_points(bad));
            assert!(
                msg.starts_with("plan.toml: key grid.points: point")
                    && msg.contains("must be numbers"),
                "{bad}: {msg}"
            );
        }
        let msg = refusal(&with_points("[]"));
        assert!(
            msg.starts_with("plan.toml: key grid.points: give at least one"),
            "{msg}"
        );
        // A point is a pair: a single number or a triple is refused when the file is read.
        for bad in ["[[1.0]]", "[[1.0, 2.0, 3.0]]", "[1.0, 2.0]"] {
            let msg = refusal(&with_points(bad));
            assert!(msg.contains("points"), "{bad}: {msg}");
            assert!(!msg.starts_with("accepted"), "{bad}: {msg}");
        }
    }

    #[test]
    fn oversized_point_lists_are_refused_before_expansion() {
        let plan = Plan::parse(&with_points("[[0.0, 0.0]]"), "p").expect("parse");
        let program = |points: Vec<[f64; 2]>, repetitions| {
            let mut plan = plan.clone();
            plan.grid.points = Some(points);
            plan.indentation.repetitions = repetitions;
            plan.program(&bench(), "p")
        };
        let msg = program(vec![[0.0, 0.0]; MAX_POINTS + 1], 1)
            .expect_err("too many")
            .to_string();
        assert!(
            msg.contains("grid.points") && msg.contains("at most 100000"),
            "{msg}"
        );
        // 2 shapes x 30000 points x 2 repetitions: the list alone is allowed, the product not.
        let msg = program(vec![[0.0, 0.0]; 30_000], 2)
            .expect_err("too many indentations")
            .to_string();
        assert!(
            msg.contains("120000 indentations (2 shapes x 30000 points x 2 repetitions)"),
            "{msg}"
        );
        let ok = program(vec![[0.0, 0.0]; 25_000], 2).expect("100000 indentations");
        assert_eq!(ok.points.len(), MAX_POINTS);
    }

    #[test]
    fn plans_serialize_back_to_the_form_they_were_written_in() {
        // A grid plan as before: no points key; a points plan: no x, y or order.
        let grid = Plan::parse(PLAN, "p").expect("parse");
        let written = toml::to_string(&grid).expect("serialize");
        assert!(!written.contains("points"), "{written}");
        assert_eq!(Plan::parse(&written, "p").expect("reparse"), grid);
        let points = Plan::parse(&with_points("[[1.5, -2.0], [0.0, 3.0]]"), "p").expect("parse");
        let written = toml::to_string(&points).expect("serialize");
        assert!(written.contains("points = "), "{written}");
        assert!(
            !written.lines().any(|l| ["x", "y", "order", "[grid."]
                .iter()
                .any(|k| l.starts_with(k))),
            "{written}"
        );
        assert_eq!(Plan::parse(&written, "p").expect("reparse"), points);
    }

    /// [`PLAN`] with a `[slide]` section (and the tangential ceiling) on a bench with a
    /// motorised y stage.
    fn sliding(slide: &str) -> String {
        format!("{PLAN}tangential_ceiling = 6.0\n[slide]\n{slide}\n")
    }

    fn motorised() -> BenchLimits {
        BenchLimits {
            manual_y: false,
            ..bench()
        }
    }

    #[test]
    fn a_plan_that_slides_presses_once_per_target_direction_and_speed() {
        let text =
            sliding("directions = [\"x\", 90.0]\ndistance = 2.0\nspeeds = [0.5, 1.0]\ndwell = 0.5");
        let plan = Plan::parse(&text, "plan.toml").expect("parse");
        assert_eq!(plan.safety.tangential(), Newtons(6.0));
        let program = plan.program(&motorised(), "plan.toml").expect("valid");
        // 2 shapes x 6 positions x (2 targets x 2 directions x 2 speeds).
        assert_eq!(program.points.len(), 2 * 6 * 8);
        assert_eq!(program.slide_dwell, Duration::from_millis(500));
        let first: Vec<(f64, f64, f64, f64)> = program.points[..8]
            .iter()
            .map(|p| {
                let s = p.slide.expect("every press slides");
                (p.x.0, s.force.0, s.direction_deg, s.speed.0)
            })
            .collect();
        assert_eq!(
            first,
            vec![
                (-5.0, 1.0, 0.0, 0.5),
                (-5.0, 1.0, 0.0, 1.0),
                (-5.0, 1.0, 90.0, 0.5),
                (-5.0, 1.0, 90.0, 1.0),
                (-5.0, 4.0, 0.0, 0.5),
                (-5.0, 4.0, 0.0, 1.0),
                (-5.0, 4.0, 90.0, 0.5),
                (-5.0, 4.0, 90.0, 1.0),
            ]
        );
        assert!(program.points[8].slide.is_some() && program.points[8].x.0 == 0.0);
        assert_eq!(program.points.iter().map(|p| p.index).max(), Some(95));
        // Each press's estimate holds its slide: 2 mm at the speed (with the 4 mm/s^2 ramps)
        // and the dwell after it, beyond the press to one target.
        let plain = Plan::parse(
            &format!("{PLAN}[slide]\ndirections = [\"x\"]\ndistance = 0.001\nspeeds = [2.0]\n"),
            "p",
        )
        .expect("parse")
        .program(&motorised(), "p")
        .expect("valid");
        let est = program.estimate(&motorised());
        let one_slide_each = plain.estimate(&motorised());
        let slides: f64 = [0.5, 1.0]
            .iter()
            .map(|v| 2.0 * (2.0 / v + v / 4.0 + 0.5))
            .sum::<f64>()
            * 2.0
            * 12.0;
        // The plain plan presses each target once per position, the sliding one four times.
        assert!(
            est.filming.as_secs_f64() > slides + one_slide_each.filming.as_secs_f64(),
            "{est:?} vs {one_slide_each:?} + {slides} s of slides"
        );
        // Slides end away from their points: the path between presses counts the way back.
        assert!(est.lateral_path_mm > one_slide_each.lateral_path_mm + 2.0 * 6.0 * 12.0);
        let written = toml::to_string(&plan).expect("serialize");
        assert_eq!(Plan::parse(&written, "p").expect("reparse"), plan);
    }

    #[test]
    fn slides_are_checked_against_the_rig_before_anything_runs() {
        let refused = |slide: &str, bench: &BenchLimits| {
            Plan::parse(&sliding(slide), "plan.toml")
                .expect("parse")
                .program(bench, "plan.toml")
                .expect_err("refused")
                .to_string()
        };
        let ok = "directions = [\"x\"]\ndistance = 2.0\nspeeds = [1.0]";
        assert!(Plan::parse(&sliding(ok), "p")
            .expect("parse")
            .program(&motorised(), "p")
            .is_ok());
        // y is moved by hand on bench(): only x slides.
        let e = refused(
            "directions = [\"-y\"]\ndistance = 2.0\nspeeds = [1.0]",
            &bench(),
        );
        assert!(
            e.contains("key slide.directions: 270 degrees moves y, which is moved by hand"),
            "{e}"
        );
        assert!(Plan::parse(
            &sliding("directions = [\"-x\"]\ndistance = 2.0\nspeeds = [1.0]"),
            "p"
        )
        .expect("parse")
        .program(&bench(), "p")
        .is_ok());
        // The x stage runs at 2 mm/s: 3 mm/s along x, or 2.5 mm/s at 30 degrees (2.17 on x).
        let e = refused(
            "directions = [\"x\"]\ndistance = 2.0\nspeeds = [3.0]",
            &motorised(),
        );
        assert!(
            e.contains(
                "key slide.speeds: 3 mm/s at 0 degrees asks x for 3.000 mm/s, above its 2.000 mm/s"
            ),
            "{e}"
        );
        assert!(refused(
            "directions = [30.0]\ndistance = 2.0\nspeeds = [2.5]",
            &motorised()
        )
        .contains("asks x for 2.165"));
        // From x = 5 mm, 8 mm along +x ends at 13 mm, past the 12 mm soft limit.
        let e = refused(
            "directions = [\"x\"]\ndistance = 8.0\nspeeds = [1.0]",
            &motorised(),
        );
        assert!(e.contains("the slide of 8 mm at 0 degrees from [5, 0] ends at x = 13.000 mm, outside the x soft limits"), "{e}");
        for (slide, key) in [
            (
                "directions = [\"z\"]\ndistance = 2.0\nspeeds = [1.0]",
                "key slide.directions: \"z\" is not a direction",
            ),
            (
                "directions = [\"x\"]\ndistance = 0.0\nspeeds = [1.0]",
                "key slide.distance: 0 mm",
            ),
            (
                "directions = [\"x\"]\ndistance = 25.0\nspeeds = [1.0]",
                "key slide.distance: 25 mm",
            ),
            (
                "directions = [\"x\"]\ndistance = 2.0\nspeeds = []",
                "section [slide]: give at least one direction",
            ),
            (
                "directions = [\"x\"]\ndistance = 2.0\nspeeds = [0.0]",
                "key slide.speeds: 0 mm/s",
            ),
            (
                "directions = [\"x\"]\ndistance = 2.0\nspeeds = [1.0]\ndwell = -1.0",
                "key slide.dwell: -1 s",
            ),
        ] {
            let e = refused(slide, &motorised());
            assert!(e.contains(key), "{slide}: {e}");
        }
        // A slide holds a force: depth targets cannot slide.
        let depth = sliding(ok).replace("force_targets = [1.0, 4.0]", "depth_targets = [0.5]");
        let e = Plan::parse(&depth, "p")
            .expect("parse")
            .program(&motorised(), "p")
            .expect_err("depth");
        assert!(
            e.to_string()
                .contains("give indentation.force_targets, not depth_targets"),
            "{e}"
        );
        let ceiling = sliding(ok).replace("tangential_ceiling = 6.0", "tangential_ceiling = -1.0");
        let e = Plan::parse(&ceiling, "p")
            .expect("parse")
            .program(&motorised(), "p")
            .expect_err("ceiling");
        assert!(
            e.to_string()
                .contains("key safety.tangential_ceiling: -1 N must be positive"),
            "{e}"
        );
        // Without the key, the tangential ceiling is the force ceiling.
        let plan = Plan::parse(PLAN, "p").expect("parse");
        assert_eq!(plan.safety.tangential(), Newtons(10.0));
        assert!(!toml::to_string(&plan)
            .expect("serialize")
            .contains("tangential"));
    }

    #[test]
    fn a_plan_may_say_what_is_stored_of_each_frame() {
        let disc = format!("{PLAN}[recording]\nstore = \"disc\"\ndisc_margin_px = 20.0\n");
        let plan = Plan::parse(&disc, "p").expect("parse");
        let written = toml::to_string(&plan).expect("serialize");
        assert_eq!(Plan::parse(&written, "p").expect("reparse"), plan);
        assert!(refusal(&disc).starts_with("accepted"), "{}", refusal(&disc));
        let t = refusal(&format!("{PLAN}[recording]\nstore = \"crop\"\n"));
        assert!(
            t.contains("plan.toml") && t.contains("recording.store"),
            "{t}"
        );
        let t = refusal(&format!("{PLAN}[recording]\ndisc_margin_px = -2.0\n"));
        assert!(t.contains("recording.disc_margin_px"), "{t}");
        let t = refusal(&format!("{PLAN}[recording]\nstor = \"disc\"\n"));
        assert!(t.contains("stor"), "{t}");
        // A plan without the section writes none.
        let plain = toml::to_string(&Plan::parse(PLAN, "p").expect("parse")).expect("serialize");
        assert!(!plain.contains("recording"), "{plain}");
    }

    #[test]
    fn ranges_include_the_stop_and_count_down() {
        let r = Axis1d::Range {
            start: 1.0,
            stop: -1.0,
            step: 0.5,
        };
        assert_eq!(
            r.values("x").expect("values"),
            vec![1.0, 0.5, 0.0, -0.5, -1.0]
        );
        let bad = Axis1d::Range {
            start: 0.0,
            stop: 1.0,
            step: 0.0,
        };
        assert!(bad
            .values("grid.x")
            .expect_err("zero step")
            .contains("grid.x"));
    }

    #[test]
    fn move_time_is_the_trapezoid() {
        let k = Kinematics {
            velocity: MillimetresPerSecond(2.0),
            acceleration: MillimetresPerSecondSquared(4.0),
        };
        assert!((move_time(5.0, &k).as_secs_f64() - 3.0).abs() < 1e-9);
        assert!((move_time(0.25, &k).as_secs_f64() - 0.5).abs() < 1e-9);
    }
}
