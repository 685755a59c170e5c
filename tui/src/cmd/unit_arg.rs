//! `--unit FILE|ID`, shared by every command that works on one sensor unit (`commission`,
//! `check`, `validate`, `eval`, and `stream` when it comes): the unit by its id or one of its
//! files, put on the rig (`fringe_app::units`).

use anyhow::{Context, Result};
use fringe_app::units;
use fringe_app::units::UnitRef;
use fringe_app::RigConfig;

/// The unit a command works on.
#[derive(clap::Args, Debug, Clone, Default)]
pub struct UnitArg {
    /// The unit: its id (`layered-2`; `fringe units` lists the units known) or one of its files
    /// (its calibration profile <profiles>/<id>.toml, a commissioning's certificate.json or
    /// directory, its <id>.health.jsonl, or a simulator's sensor file). The simulated bench
    /// carries that unit; a real rig must hold it (its rig file's `sensor`). Default: the rig's
    /// sensor.
    #[arg(long, value_name = "FILE|ID")]
    pub unit: Option<String>,
}

impl UnitArg {
    /// The unit named, read (`None`: none given).
    pub fn named(&self) -> Result<Option<UnitRef>> {
        named(self.unit.as_deref())
    }

    /// `config` with the unit on it (unchanged when none is given).
    pub fn on(&self, config: RigConfig) -> Result<RigConfig> {
        on("--unit", self.unit.as_deref(), config)
    }
}

/// `given` read as a unit.
pub fn named(given: Option<&str>) -> Result<Option<UnitRef>> {
    given
        .map(|u| UnitRef::parse(u).with_context(|| format!("--unit {u}")))
        .transpose()
}

/// `config` with the unit `given` by `flag` on it (unchanged when `None`).
pub fn on(flag: &str, given: Option<&str>, config: RigConfig) -> Result<RigConfig> {
    let Some(given) = given else {
        return Ok(config);
    };
    let u = UnitRef::parse(given).with_context(|| format!("{flag} {given}"))?;
    units::carrying(config, &u).with_context(|| format!("{flag} {given}"))
}
