//! The plans the Scan screen can run: the one fringe was started with, the built-in ones and the
//! `*.toml` files in `./plans`; a chosen plan parsed and checked against the rig's limits, and
//! what the Scan screen shows of it before it runs.

use super::state::{Phase, PlanPoint, ScanView};
use fringe_app::session::Recording;
use fringe_rig::{scan::Targets, BenchLimits, Plan, ScanProgram};
use std::collections::VecDeque;
use std::path::Path;

/// A plan's text and how messages name it.
#[derive(Debug, Clone, PartialEq)]
pub struct PlanSource {
    /// What the chooser lists.
    pub label: String,
    pub text: String,
    /// How errors name it (a path, or the built-in plan's name and source file).
    pub origin: String,
    /// Why the file could not be read (shown when it is chosen).
    pub unreadable: Option<String>,
}

/// The plans to choose from: `first` (the one the UI starts with), then the built-in plans, then
/// `dir/*.toml` sorted by name (unreadable files are listed; choosing one says why it fails).
pub fn available(first: PlanSource, dir: &Path) -> Vec<PlanSource> {
    let mut out = vec![first];
    for p in fringe_app::session::BUILTIN_PLANS {
        if out.iter().all(|s| s.text != p.text) {
            out.push(PlanSource {
                label: format!("{} (built in)", p.name),
                text: p.text.to_string(),
                origin: p.origin(),
                unreadable: None,
            });
        }
    }
    let mut files: Vec<_> = std::fs::read_dir(dir)
        .map(|entries| {
            entries
                .filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|p| p.extension().is_some_and(|e| e == "toml"))
                .collect()
        })
        .unwrap_or_default();
    files.sort();
    for path in files {
        let origin = path.display().to_string();
        if out.iter().any(|s| s.origin == origin) {
            continue;
        }
        let (text, unreadable) = match fringe_app::session::read_plan_file(&path) {
            Ok(text) => (text, None),
            Err(e) => (String::new(), Some(e.to_string())),
        };
        out.push(PlanSource {
            label: origin.clone(),
            text,
            origin,
            unreadable,
        });
    }
    out
}

/// The plan parsed and laid out on this rig (errors name the file and key).
pub fn load(src: &PlanSource, limits: &BenchLimits) -> anyhow::Result<ScanProgram> {
    if let Some(why) = &src.unreadable {
        anyhow::bail!("{why}");
    }
    let plan = Plan::parse(&src.text, &src.origin)?;
    Ok(plan.program(limits, &src.origin)?)
}

/// The Scan screen of a plan that has not run: its points, targets, estimated duration and, when
/// the rig's recording is known, expected size on disk.
pub fn scan_view(
    program: &ScanProgram,
    limits: &BenchLimits,
    origin_mm: (f64, f64),
    recording: Option<&Recording>,
) -> ScanView {
    let list = |v: Vec<f64>| {
        v.iter()
            .map(|x| x.to_string())
            .collect::<Vec<_>>()
            .join(", ")
    };
    let targets = match &program.targets {
        Targets::Force(t) => format!("{} N", list(t.iter().map(|v| v.0).collect())),
        Targets::Depth(t) => format!("{} mm deep", list(t.iter().map(|v| v.0).collect())),
    };
    let estimated = program.estimate(limits);
    let estimate = estimated.total;
    ScanView {
        plan: program.plan.name.clone(),
        points: program
            .points
            .iter()
            .map(|p| PlanPoint {
                x_mm: p.x.0,
                y_mm: p.y.0,
            })
            .collect(),
        origin_mm,
        disc_radius_mm: None,
        targets,
        estimate,
        expected_bytes: recording.map(|r| r.expected(estimated.recording_time()).total_bytes()),
        phase: Phase::Ready,
        done: 0,
        total: program.points.len() as u64,
        eta: estimate,
        force_n: 0.0,
        frame_rate_hz: 0.0,
        frames: 0,
        dropped: 0,
        current: None,
        log: VecDeque::new(),
        live: Default::default(),
        run_dir: None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn limits() -> BenchLimits {
        fringe_app::RigConfig::simulated()
            .limits()
            .expect("simulated limits")
    }

    fn given() -> PlanSource {
        let p = fringe_app::session::SHORT_GRID;
        PlanSource {
            label: "short-grid".into(),
            text: p.text.into(),
            origin: p.origin(),
            unreadable: None,
        }
    }

    #[test]
    fn an_unreadable_plan_file_is_listed_and_choosing_it_says_why() {
        let dir =
            std::env::temp_dir().join(format!("fringe-plan-unreadable-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        // A directory named like a plan: unreadable as a file even for root.
        std::fs::create_dir_all(dir.join("odd.toml")).expect("dir");
        let plans = available(given(), &dir);
        let odd = plans
            .iter()
            .find(|p| p.origin.ends_with("odd.toml"))
            .expect("listed");
        let e = load(odd, &limits()).expect_err("unreadable").to_string();
        assert!(e.contains("odd.toml: cannot read the plan"), "{e}");
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn the_plans_dir_adds_its_files_after_the_built_in_plans() {
        let dir = std::env::temp_dir().join(format!("fringe-plan-choice-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).expect("dir");
        let wide = fringe_app::session::SHORT_GRID
            .text
            .replace("name = \"short-grid\"", "name = \"wide\"");
        std::fs::write(dir.join("b-wide.toml"), &wide).expect("write");
        std::fs::write(dir.join("a-broken.toml"), "[grid]\nx = nan").expect("write");
        std::fs::write(dir.join("notes.txt"), "not a plan").expect("write");
        let plans = available(given(), &dir);
        let labels: Vec<&str> = plans.iter().map(|p| p.label.as_str()).collect();
        // The given plan first, short-grid not repeated, then the other built-in plans, then
        // the files by name.
        assert_eq!(labels[0], "short-grid");
        assert_eq!(labels.len(), 6, "{labels:?}");
        assert_eq!(labels[1], "calibration (built in)");
        assert_eq!(labels[2], "demo (built in)");
        assert_eq!(labels[3], "slides (built in)");
        assert!(labels[4].ends_with("a-broken.toml"), "{labels:?}");
        assert!(labels[5].ends_with("b-wide.toml"), "{labels:?}");

        let limits = limits();
        let program = load(&plans[5], &limits).expect("the wide plan loads");
        let recording = Recording::from_rig_files(&fringe_app::RigConfig::simulated(), None)
            .expect("the simulated bench's recording");
        let view = scan_view(&program, &limits, (12.5, 25.0), Some(&recording));
        assert_eq!(view.plan, "wide");
        let time = program.estimate(&limits).recording_time();
        assert_eq!(
            view.expected_bytes,
            Some(recording.expected(time).total_bytes())
        );
        assert!(view.expected_bytes > Some(100_000_000), "{view:?}");
        assert_eq!(view.points.len(), 6);
        assert_eq!(view.targets, "1, 4 N");
        assert!(view.estimate.as_secs() > 10);
        let err = load(&plans[4], &limits).expect_err("a broken plan is refused");
        assert!(err.to_string().contains("a-broken.toml"), "{err}");
        let _ = std::fs::remove_dir_all(&dir);
    }
}
