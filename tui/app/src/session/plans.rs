//! The built-in scan plans, from the files in `tui/app/plans/` (each file is also a commented
//! example to copy): `fringe` runs `short-grid`, `fringe calibrate` runs `calibration`, `fringe
//! demo` runs `demo`, `fringe commission` runs `commission` with its own points.

/// A plan shipped with fringe.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BuiltinPlan {
    pub name: &'static str,
    /// Where the file lives in the source tree, for messages.
    pub path: &'static str,
    pub text: &'static str,
    /// What it is for, in one line (`fringe plans`).
    pub about: &'static str,
}

impl BuiltinPlan {
    /// How messages name the plan.
    pub fn origin(&self) -> String {
        format!("built-in plan {} ({})", self.name, self.path)
    }
}

/// The main job: a short indentation grid.
pub const SHORT_GRID: BuiltinPlan = BuiltinPlan {
    name: "short-grid",
    path: "tui/app/plans/short-grid.toml",
    text: include_str!("../../plans/short-grid.toml"),
    about: "the main job (fringe with no command): a short indentation grid",
};

/// The calibration scan of `fringe calibrate`.
pub(crate) const CALIBRATION: BuiltinPlan = BuiltinPlan {
    name: "calibration",
    path: "tui/app/plans/calibration.toml",
    text: include_str!("../../plans/calibration.toml"),
    about: "the calibration scan of fringe calibrate: light presses around the centre",
};

/// The demonstration of `fringe demo` on the simulated bench.
pub const DEMO: BuiltinPlan = BuiltinPlan {
    name: "demo",
    path: "tui/app/plans/demo.toml",
    text: include_str!("../../plans/demo.toml"),
    about: "the demonstration of fringe demo: three presses to 1, 4 and 9 N",
};

/// Presses that slide: shear and slip data.
pub(crate) const SLIDES: BuiltinPlan = BuiltinPlan {
    name: "slides",
    path: "tui/app/plans/slides.toml",
    text: include_str!("../../plans/slides.toml"),
    about: "presses that slide (x, -y, 135 degrees at 0.5 and 2 mm/s under 1.5 and 2.5 N): shear and slip data",
};

/// The presses of `fringe commission` (its rounds and acceptance scan replace the points and the
/// indenters): a template, not among the plans offered to run ([`ALL`]).
pub(crate) const COMMISSION: BuiltinPlan = BuiltinPlan {
    name: "commission",
    path: "tui/app/plans/commission.toml",
    text: include_str!("../../plans/commission.toml"),
    about: "the presses of fringe commission (a template)",
};

/// Every built-in plan offered to run.
pub const ALL: [BuiltinPlan; 4] = [SHORT_GRID, CALIBRATION, DEMO, SLIDES];

/// A built-in plan by name.
pub fn by_name(name: &str) -> Option<BuiltinPlan> {
    ALL.into_iter().find(|p| p.name == name)
}

/// A built-in plan as `fringe plans` lists it: how many places it presses, how many presses,
/// and how long it takes on the rig (the scan's own estimate, homing included).
#[derive(Debug)]
pub struct PlanSummary {
    pub plan: BuiltinPlan,
    /// The plan on this rig, or why it cannot run there (outside its soft limits...).
    pub fit: Result<PlanFit, fringe_rig::ConfigError>,
}

/// What a built-in plan does on a rig.
#[derive(Debug, Clone)]
pub struct PlanFit {
    /// Distinct stage positions pressed.
    pub points: usize,
    /// Indentations: positions times indenters times repetitions.
    pub presses: usize,
    /// Force (N) or depth (mm past contact) targets of each press.
    pub targets: String,
    pub estimate: fringe_rig::scan::Estimate,
}

/// Every built-in plan offered to run, summarised for the rig within `limits`.
pub fn summaries(limits: &fringe_rig::BenchLimits) -> Vec<PlanSummary> {
    ALL.into_iter()
        .map(|plan| PlanSummary {
            plan,
            fit: fit(&plan, limits),
        })
        .collect()
}

fn fit(
    plan: &BuiltinPlan,
    limits: &fringe_rig::BenchLimits,
) -> Result<PlanFit, fringe_rig::ConfigError> {
    let origin = plan.origin();
    let program = fringe_rig::Plan::parse(plan.text, &origin)?.program(limits, &origin)?;
    let mut places: Vec<(u64, u64)> = program
        .points
        .iter()
        .map(|p| (p.x.0.to_bits(), p.y.0.to_bits()))
        .collect();
    places.sort_unstable();
    places.dedup();
    let list = |v: Vec<f64>| {
        v.iter()
            .map(|x| format!("{x}"))
            .collect::<Vec<_>>()
            .join(", ")
    };
    let targets = match &program.targets {
        fringe_rig::scan::Targets::Force(t) => {
            format!("{} N", list(t.iter().map(|t| t.0).collect()))
        }
        fringe_rig::scan::Targets::Depth(t) => {
            format!("{} mm deep", list(t.iter().map(|t| t.0).collect()))
        }
    };
    Ok(PlanFit {
        points: places.len(),
        presses: program.points.len(),
        targets,
        estimate: program.estimate(limits),
    })
}

/// A plan file that cannot be read, with what to do.
#[derive(Debug, thiserror::Error)]
#[error("{}: cannot read the plan: {source}{}", path.display(), advice(source))]
pub struct PlanFileError {
    pub path: std::path::PathBuf,
    #[source]
    pub source: std::io::Error,
}

fn advice(e: &std::io::Error) -> &'static str {
    match e.kind() {
        std::io::ErrorKind::NotFound => {
            " (check the path; the built-in plans are short-grid, calibration, demo and slides, with commented copies in tui/app/plans/)"
        }
        std::io::ErrorKind::PermissionDenied => " (make the file readable by your user)",
        _ => " (a plan is a TOML text file; see tui/app/plans/ for examples)",
    }
}

/// The text of the plan file at `path`.
pub fn read_file(path: &std::path::Path) -> Result<String, PlanFileError> {
    std::fs::read_to_string(path).map_err(|source| PlanFileError {
        path: path.to_path_buf(),
        source,
    })
}

/// The built-in plan `path` names when no file of that name exists (a file always wins).
fn builtin_named(path: &std::path::Path) -> Option<BuiltinPlan> {
    if path.exists() {
        return None;
    }
    by_name(path.to_str()?)
}

/// Why the plan of a scan could not be had.
#[derive(Debug, thiserror::Error)]
pub enum ScanPlanError {
    #[error("{0}")]
    File(#[source] PlanFileError),
    #[error("{0}")]
    Run(#[source] fringe_rig::store::StoreError),
}

/// The plan a scan runs and a name for messages: the plan file given (or, when no such file
/// exists, the built-in plan of that name: `fringe scan short-grid`), else the plan stored in
/// the run it resumes, else the built-in short grid.
pub fn scan_plan(
    file: Option<&std::path::Path>,
    resume: Option<&std::path::Path>,
) -> Result<(String, String), ScanPlanError> {
    if let Some(path) = file {
        if let Some(plan) = builtin_named(path) {
            return Ok((plan.text.to_string(), plan.origin()));
        }
        let text = read_file(path).map_err(ScanPlanError::File)?;
        return Ok((text, path.display().to_string()));
    }
    if let Some(run) = resume {
        let start = fringe_rig::store::RunReader::at(run)
            .start()
            .map_err(ScanPlanError::Run)?;
        return Ok((start.plan, format!("the plan stored in {}", run.display())));
    }
    Ok((SHORT_GRID.text.to_string(), SHORT_GRID.origin()))
}

#[cfg(all(test, feature = "sim"))]
mod tests {
    use super::*;
    use fringe_rig::Plan;

    #[test]
    fn every_built_in_plan_is_valid_on_the_simulated_bench() {
        let limits = crate::rig::file::RigConfig::simulated()
            .limits()
            .expect("limits");
        for plan in ALL.into_iter().chain([COMMISSION]) {
            let parsed = Plan::parse(plan.text, &plan.origin()).expect("parses");
            assert_eq!(parsed.name, plan.name);
            let program = parsed.program(&limits, &plan.origin()).expect("valid");
            assert!(!program.points.is_empty());
        }
        for plan in ALL {
            assert_eq!(by_name(plan.name), Some(plan));
        }
        assert_eq!(
            by_name(COMMISSION.name),
            None,
            "a template, not offered to run"
        );
    }
}
