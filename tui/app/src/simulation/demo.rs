//! The demonstration on the simulated bench (`fringe demo`): the built-in plan `demo` (three
//! presses to 1, 4 and 9 N; quick: one press to 1 and 4 N) on a simulated rig with the sensor
//! and seed given, run on the one scan engine like any scan.

use crate::rig::file::RigConfig;
use crate::session::plans::DEMO;
use fringe_rig::store::ExitStatus;
use fringe_rig::ConfigError;
use fringe_rig::ScanOutcome;
use fringe_rig::{scan::Axis1d, Plan, ScanProgram};

/// The demonstration's rig and plan.
pub struct Demo {
    /// The simulated rig.
    pub config: RigConfig,
    pub plan: Plan,
    /// The plan as the run stores it.
    pub plan_text: String,
}

/// A demonstration that could not run or stopped.
#[derive(Debug, thiserror::Error)]
pub enum DemoError {
    #[error(transparent)]
    Config(#[from] ConfigError),
    #[error("the demo plan")]
    Plan(#[source] toml::ser::Error),
    #[error("the demonstration stopped: {0}")]
    Stopped(String),
}

impl Demo {
    /// The simulated rig with `sensor` (`layered`, `integrated` or a sensor file) and `seed`,
    /// and the demo plan (`quick`: one press to 1 and 4 N, a shorter dwell).
    pub fn new(sensor: &str, seed: u64, quick: bool) -> Result<Demo, DemoError> {
        let rig_text = format!(
            "# fringe demo: the simulated bench\n[sim]\nseed = {}\nsensor = {}\n",
            seed,
            toml::Value::String(sensor.to_string())
        );
        let config = RigConfig::parse(&rig_text, "fringe demo --sensor/--seed")?;
        let mut plan = Plan::parse(DEMO.text, &DEMO.origin())?;
        if quick {
            plan.grid.x = Some(Axis1d::Points(vec![12.5]));
            plan.indentation.force_targets.truncate(2);
            plan.indentation.dwell = 0.3;
        }
        let plan_text = toml::to_string(&plan).map_err(DemoError::Plan)?;
        Ok(Demo {
            config,
            plan,
            plan_text,
        })
    }

    /// The plan's presses on the simulated rig.
    pub fn program(&self) -> Result<ScanProgram, DemoError> {
        Ok(self.plan.program(&self.config.limits()?, &DEMO.origin())?)
    }
}

/// The end of the demonstration's scan, refused unless it completed.
pub fn completed(outcome: &ScanOutcome) -> Result<(), DemoError> {
    if outcome.status != ExitStatus::Completed {
        return Err(DemoError::Stopped(outcome.reason.clone()));
    }
    Ok(())
}
