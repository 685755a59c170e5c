//! Soft-limit options shared by every command that moves an axis.

use fringe_rig::Millimetres;
use fringe_rig::SoftLimits;

/// `--min MM --max MM`: soft limits checked before any move is sent.
#[derive(clap::Args)]
pub struct SoftLimitArgs {
    /// Lower soft limit in mm, checked before a move is sent (give --max too).
    #[arg(
        long,
        value_name = "MM",
        requires = "max",
        allow_negative_numbers = true
    )]
    pub min: Option<f64>,
    /// Upper soft limit in mm (give --min too).
    #[arg(
        long,
        value_name = "MM",
        requires = "min",
        allow_negative_numbers = true
    )]
    pub max: Option<f64>,
}

impl SoftLimitArgs {
    /// The limits given, `None` when neither option was.
    pub fn limits(&self) -> anyhow::Result<Option<SoftLimits>> {
        match (self.min, self.max) {
            (Some(min), Some(max)) => Ok(Some(
                SoftLimits::new(Millimetres(min), Millimetres(max))
                    .map_err(|e| anyhow::anyhow!("--min/--max: {e}"))?,
            )),
            (None, None) => Ok(None),
            _ => anyhow::bail!("give both --min and --max, or neither"),
        }
    }
}
