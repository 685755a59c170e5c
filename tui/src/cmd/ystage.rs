//! `fringe ystage`: home, query or move the y stage (Modbus TCP, Modbus RTU, manual or a Thorlabs axis).

use super::arg_values;
use super::limits::SoftLimitArgs;
use super::terminal_prompt::TerminalPrompt;
use crate::Global;
use anyhow::{bail, Context};
use fringe_app::device_open::{open_axis, TraceTo};
use fringe_app::device_spec::{AxisSpec, ModbusLink, ModbusSpec};
use fringe_app::host_port::HostPort;
use fringe_rig::apt::driver::{AptConfig, Controller};
use fringe_rig::apt::Actuator;
use fringe_rig::units::Millimetres;
use std::time::Duration;

const DEFAULT_MAP: &str = "oriental-az";

#[derive(clap::Args)]
#[command(group(clap::ArgGroup::new("stage").required(true).args(["modbus_tcp", "modbus_rtu", "manual", "apt"])))]
pub struct YstageArgs {
    /// Modbus TCP stage at HOST:PORT.
    #[arg(long, value_name = "HOST:PORT")]
    modbus_tcp: Option<String>,

    /// Modbus RTU stage on the serial port PATH.
    #[arg(long, value_name = "PATH")]
    modbus_rtu: Option<String>,

    /// A stage moved by hand: fringe asks the operator on the terminal.
    #[arg(long)]
    manual: bool,

    /// A Thorlabs APT stepper as the y stage: serial port of its controller.
    #[arg(long, value_name = "PATH", requires = "actuator")]
    apt: Option<String>,

    /// Actuator of the Thorlabs y stage (ZFS25, ZST225, DRV250, ...); with --apt.
    #[arg(long, value_name = "NAME", requires = "apt")]
    actuator: Option<String>,

    /// Controller of the Thorlabs y stage: kst101, kst201, bsc201, bsc202, bsc203; with --apt.
    #[arg(long, value_name = "NAME", requires = "apt")]
    controller: Option<Controller>,

    /// Register map: a built-in name (oriental-az, leadshine-pr) or a TOML file.
    #[arg(long, default_value = DEFAULT_MAP, value_name = "NAME|FILE")]
    map: String,

    /// Slave (unit) id, overriding the map's.
    #[arg(long, value_name = "N")]
    slave: Option<u8>,

    /// Baud rate for --modbus-rtu, overriding the map's.
    #[arg(long, value_name = "N")]
    baud: Option<u32>,

    #[command(flatten)]
    limits: SoftLimitArgs,

    /// Seconds to wait for homing or a move to finish.
    #[arg(long, default_value = "60", value_name = "S", value_parser = arg_values::seconds)]
    timeout: Duration,

    #[command(subcommand)]
    action: Action,
}

#[derive(clap::Subcommand)]
enum Action {
    /// Home the stage (needs a [homing] section in the map).
    Home,
    /// Print the position and status flags.
    Status,
    /// Move to MM (absolute) and wait.
    Move {
        #[arg(allow_negative_numbers = true, value_name = "MM", value_parser = arg_values::millimetres)]
        mm: f64,
    },
}

/// What the y stage is; add a variant and an arm in [`YstageArgs::spec`] for another kind of
/// stage (and one in `fringe_app::device_spec::AxisSpec` for another driver).
enum StageKind {
    ModbusTcp(String),
    ModbusRtu(String),
    Manual,
    Thorlabs(String),
}

impl YstageArgs {
    fn kind(&self) -> anyhow::Result<StageKind> {
        Ok(
            match (&self.modbus_tcp, &self.modbus_rtu, self.manual, &self.apt) {
                (Some(addr), None, false, None) => StageKind::ModbusTcp(addr.clone()),
                (None, Some(path), false, None) => StageKind::ModbusRtu(path.clone()),
                (None, None, true, None) => StageKind::Manual,
                (None, None, false, Some(path)) => StageKind::Thorlabs(path.clone()),
                _ => bail!("give exactly one of --modbus-tcp, --modbus-rtu, --manual, --apt"),
            },
        )
    }

    /// Rejects options that the chosen kind of stage would ignore.
    fn check_options(&self, kind: &StageKind) -> anyhow::Result<()> {
        if self.baud.is_some() && !matches!(kind, StageKind::ModbusRtu(_)) {
            bail!("--baud applies to --modbus-rtu only");
        }
        if matches!(kind, StageKind::Manual | StageKind::Thorlabs(_))
            && (self.slave.is_some() || self.map != DEFAULT_MAP)
        {
            bail!("--map and --slave apply to Modbus stages, not to --manual or --apt");
        }
        Ok(())
    }
}

impl YstageArgs {
    /// The y stage the flags describe, as a rig file's `[y]` section would describe it.
    fn spec(&self) -> anyhow::Result<AxisSpec> {
        let limits = self.limits.limits()?;
        let kind = self.kind()?;
        self.check_options(&kind)?;
        let modbus = |link| {
            AxisSpec::Modbus(ModbusSpec {
                name: "y".into(),
                link,
                map: self.map.clone(),
                slave: self.slave,
                baud: self.baud,
                limits,
            })
        };
        Ok(match kind {
            StageKind::ModbusTcp(addr) => modbus(ModbusLink::Tcp(
                HostPort::parse(&addr, None).context("--modbus-tcp")?,
            )),
            StageKind::ModbusRtu(port) => modbus(ModbusLink::Rtu { port }),
            StageKind::Manual => AxisSpec::Manual {
                name: "y".into(),
                limits,
            },
            StageKind::Thorlabs(port) => {
                let name = self.actuator.as_deref().unwrap_or_default();
                let actuator = Actuator::by_name(name).with_context(|| {
                    format!(
                        "unknown actuator `{name}` (known: {})",
                        Actuator::known_names()
                    )
                })?;
                let controller = self.controller.unwrap_or(Controller::Kst101);
                let mut config = AptConfig::new("y", controller, actuator);
                config.soft_limits = limits;
                AxisSpec::Thorlabs { port, config }
            }
        })
    }
}

pub fn run(args: YstageArgs, global: &Global) -> anyhow::Result<()> {
    let timeout = args.timeout;
    let spec = args.spec()?;
    let mut y = open_axis(
        &spec,
        TraceTo::new(global.record_trace.as_deref(), "ystage"),
        Some(Box::new(TerminalPrompt::stdio())),
    )?;
    let status = match args.action {
        Action::Home => y.home(timeout)?,
        Action::Status => y.status()?,
        Action::Move { mm } => y.move_to(Millimetres(mm), timeout)?,
    };
    println!("y: {status}{}", if status.homed { ", homed" } else { "" });
    Ok(())
}
