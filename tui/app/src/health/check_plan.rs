//! The check's presses: a fixed subset of the unit's acceptance positions (the same ones at every
//! check, spread over the disc), each pressed with every indenter of the unit's model through the
//! commissioning's force range, in at most [`MAX_BENCH_S`] of bench time.

use crate::commission::press_choice::{choose, tour};
use crate::commission::press_plan::{press_plan, PressPlanError};
use fringe_rig::Plan;

/// Positions a check presses at most.
pub(crate) const CHECK_POSITIONS: usize = 3;
/// Bench time a check may take, s.
pub(crate) const MAX_BENCH_S: f64 = 120.0;

/// A check's plan.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct CheckPlan {
    /// Stage positions, mm, in the order pressed.
    pub positions: Vec<[f64; 2]>,
    pub plan: String,
    /// Bench time it is estimated to take, s.
    pub estimate_s: f64,
}

/// Why there is no check plan.
#[derive(Debug, thiserror::Error)]
pub enum CheckPlanError {
    #[error("{origin}: {message}")]
    Acceptance { origin: String, message: String },
    #[error(transparent)]
    Plan(#[from] PressPlanError),
    #[error(
        "one press of each indenter ({shapes}) takes about {estimate_s:.0} s of bench time, more \
         than a check's {MAX_BENCH_S:.0} s: check with quicker axes (their velocity in the rig \
         file) or fewer indenters"
    )]
    TooLong { shapes: String, estimate_s: f64 },
    #[error("estimating the check's bench time: {0}")]
    Estimate(String),
}

/// The acceptance scan's positions, from its plan text (`origin` names it in errors).
pub(crate) fn acceptance_positions(
    plan: &str,
    origin: &str,
) -> Result<Vec<[f64; 2]>, CheckPlanError> {
    let err = |message: String| CheckPlanError::Acceptance {
        origin: origin.to_string(),
        message,
    };
    let plan = Plan::parse(plan, origin).map_err(|e| err(e.to_string()))?;
    match plan.grid.points {
        Some(points) if !points.is_empty() => Ok(points),
        _ => Err(err("the acceptance plan lists no positions".into())),
    }
}

/// The check of `sensor` at up to [`CHECK_POSITIONS`] of `acceptance` (the ones farthest
/// apart, always the same), with each of `shapes`; fewer positions when the bench time
/// `estimate` gives a plan is over [`MAX_BENCH_S`].
pub(crate) fn check_plan(
    sensor: &str,
    acceptance: &[[f64; 2]],
    shapes: &[String],
    mut estimate: impl FnMut(&str) -> Result<f64, String>,
) -> Result<CheckPlan, CheckPlanError> {
    let spread = choose(acceptance, &[], CHECK_POSITIONS, 1e6);
    let centre = centroid(acceptance);
    let mut n = spread.len();
    loop {
        let positions = tour(&spread[..n], centre);
        let plan = press_plan(
            "check",
            &positions,
            shapes,
            &format!(
                "fringe check, sensor {sensor}: {} of its acceptance positions, every indenter, \
                 compared with what it was accepted with",
                positions.len()
            ),
            None,
        )?;
        let estimate_s = estimate(&plan).map_err(CheckPlanError::Estimate)?;
        if estimate_s <= MAX_BENCH_S {
            return Ok(CheckPlan {
                positions,
                plan,
                estimate_s,
            });
        }
        if n <= 1 {
            return Err(CheckPlanError::TooLong {
                shapes: shapes.join(", "),
                estimate_s,
            });
        }
        n -= 1;
    }
}

fn centroid(points: &[[f64; 2]]) -> [f64; 2] {
    let n = points.len().max(1) as f64;
    let s = points
        .iter()
        .fold([0.0, 0.0], |s, p| [s[0] + p[0], s[1] + p[1]]);
    [s[0] / n, s[1] / n]
}
