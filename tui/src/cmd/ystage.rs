//! `fringe ystage`: home, query or move the y stage (Modbus TCP, Modbus RTU, manual or a Thorlabs axis).

use super::arg_values;
use super::limits::SoftLimitArgs;
use super::terminal_prompt::TerminalPrompt;
use crate::global::Global;
use anyhow::{bail, Context};
use fringe_app::rig::HostPort;
use fringe_app::rig::{open_axis, TraceTo};
use fringe_app::rig::{AxisSpec, ModbusLink, ModbusSpec};
use fringe_rig::apt::Actuator;
use fringe_rig::Millimetres;
use fringe_rig::{AptConfig, Controller};
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
/// stage (and one in `fringe_app::rig::AxisSpec` for another driver).
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

/// The same y stage described by `fringe ystage` flags and by a rig file's `[y]` section.
#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;
    use fringe_app::rig::open_modbus;
    use fringe_app::RigConfig;
    use fringe_rig::Axis;

    #[derive(Parser)]
    struct Cli {
        #[command(flatten)]
        y: YstageArgs,
    }

    fn flags(args: &[&str]) -> AxisSpec {
        let cli = Cli::try_parse_from(std::iter::once("ystage").chain(args.iter().copied()))
            .unwrap_or_else(|e| panic!("{args:?}: {e}"));
        cli.y.spec().expect("spec from flags")
    }

    /// A real rig whose `[y]` section is `y`.
    fn rig_file(y: &str) -> AxisSpec {
        let text = format!(
            r#"
sensor = "s-01"
[x]
driver = "thorlabs"
port = "/dev/ttyX"
actuator = "ZFS25"
min = 0.0
max = 25.0
[y]
{y}
min = 0.0
max = 20.0
[z]
driver = "thorlabs"
port = "/dev/ttyZ"
actuator = "ZFS25"
min = 0.0
max = 25.0
[force]
driver = "netft"
address = "192.168.1.1"
[camera]
driver = "aravis"
[geometry]
x_centre = 12.5
y_centre = 10.0
z_contact = 15.0
"#
        );
        let rig = RigConfig::parse(&text, "rig.toml").expect("rig file");
        let limits = rig.limits().expect("limits");
        rig.axis_spec("y", &limits.y)
            .expect("spec from the rig file")
    }

    #[test]
    fn flags_and_a_rig_file_describe_the_same_stage() {
        let limits = ["--min", "0", "--max", "20", "status"];
        let with = |head: &[&'static str]| -> Vec<&'static str> {
            head.iter().chain(limits.iter()).copied().collect()
        };
        // Modbus TCP at an IPv6 address, its slave id overridden.
        let tcp = flags(&with(&["--modbus-tcp", "[::1]:1502", "--slave", "3"]));
        assert_eq!(
            tcp,
            rig_file(
                "driver = \"modbus-tcp\"\naddress = \"[::1]:1502\"\nmap = \"oriental-az\"\nslave = 3"
            )
        );
        assert!(
            matches!(&tcp, AxisSpec::Modbus(m) if m.link == ModbusLink::Tcp(HostPort { host: "::1".into(), port: 1502 })),
            "{tcp:?}"
        );
        let rtu = flags(&with(&[
            "--modbus-rtu",
            "/dev/ttyUSB1",
            "--map",
            "leadshine-pr",
            "--baud",
            "38400",
        ]));
        assert_eq!(
            rtu,
            rig_file("driver = \"modbus-rtu\"\nport = \"/dev/ttyUSB1\"\nmap = \"leadshine-pr\"\nbaud = 38400")
        );
        assert_eq!(flags(&with(&["--manual"])), rig_file("driver = \"manual\""));
        assert_eq!(
            flags(&with(&["--apt", "/dev/ttyUSB2", "--actuator", "ZST225", "--controller", "kst201"])),
            rig_file("driver = \"thorlabs\"\nport = \"/dev/ttyUSB2\"\nactuator = \"ZST225\"\ncontroller = \"kst201\"")
        );
    }

    #[test]
    fn both_descriptions_open_the_same_driver_on_the_same_address() {
        // A listener stands in for the drive: opening a Modbus TCP stage only connects.
        let listener = std::net::TcpListener::bind("127.0.0.1:0").expect("listener");
        let addr = listener.local_addr().expect("address").to_string();
        let from_flags = flags(&["--modbus-tcp", &addr, "status"]);
        let from_file = rig_file(&format!(
            "driver = \"modbus-tcp\"\naddress = \"{addr}\"\nmap = \"oriental-az\""
        ));
        let (AxisSpec::Modbus(a), AxisSpec::Modbus(mut b)) = (from_flags, from_file) else {
            panic!("both are Modbus stages");
        };
        // The rig file always has soft limits; these flags gave none.
        assert_eq!(b.limits.take().map(|l| l.max), Some(Millimetres(20.0)));
        assert_eq!(a, b);
        let trace = TraceTo::new(None, "ystage");
        let one = open_modbus(&a, trace).expect("open from flags");
        let two = open_modbus(&b, trace).expect("open from the rig file");
        assert_eq!(one.endpoint(), two.endpoint());
        assert!(one.endpoint().contains(&addr), "{}", one.endpoint());
    }
}
