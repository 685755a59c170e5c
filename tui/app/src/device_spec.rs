//! What a real device is and how it is reached, whoever described it: a rig file section
//! (`RigConfig::axis_spec`, `force_spec`, `camera_spec`) or a bring-up command's flags (`fringe
//! ystage`, `axis`, `ft`, `camera`). Checked when described; opened by `device_open`, the one
//! opener, so that the same description opens the same driver with the same settings.

use crate::host_port::HostPort;
use fringe_rig::apt::config::AptConfig;
use fringe_rig::atical::ToolTransform;
use fringe_rig::axis::SoftLimits;
use fringe_rig::netft::{Command, NetFtConfig, NetFtOptions};
use fringe_rig::nidaqmx::{CameraTrigger, DaqSettings, Setting};
use std::path::PathBuf;

/// A motion axis.
#[derive(Debug, Clone, PartialEq)]
pub enum AxisSpec {
    /// A Thorlabs stepper controller on its USB serial port; the axis is named by `config.axis`.
    Thorlabs { port: String, config: AptConfig },
    /// A Modbus drive.
    Modbus(ModbusSpec),
    /// A stage moved by hand: the operator is asked to set it and to type its reading.
    Manual {
        name: String,
        limits: Option<SoftLimits>,
    },
}

impl AxisSpec {
    /// The axis's name in messages.
    pub fn name(&self) -> &str {
        match self {
            AxisSpec::Thorlabs { config, .. } => &config.axis,
            AxisSpec::Modbus(m) => &m.name,
            AxisSpec::Manual { name, .. } => name,
        }
    }
}

impl AxisSpec {
    /// One line for the rig's device list ("y: Modbus stage, map oriental-az, on 10.0.0.5:502").
    pub fn describe(&self) -> String {
        match self {
            AxisSpec::Thorlabs { port, config } => format!(
                "{}: Thorlabs {} on {port}",
                config.axis, config.actuator.name
            ),
            AxisSpec::Modbus(m) => format!(
                "{}: Modbus stage, map {}, on {}",
                m.name,
                m.map,
                match &m.link {
                    ModbusLink::Tcp(a) => a.to_string(),
                    ModbusLink::Rtu { port } => port.clone(),
                }
            ),
            AxisSpec::Manual { name, .. } => {
                format!("{name}: moved by hand (the operator is asked)")
            }
        }
    }
}

/// A Modbus drive: its link, register map and overrides.
#[derive(Debug, Clone, PartialEq)]
pub struct ModbusSpec {
    pub name: String,
    pub link: ModbusLink,
    /// A built-in register map (oriental-az, leadshine-pr) or a map file.
    pub map: String,
    /// Slave (unit) id, when not the map's.
    pub slave: Option<u8>,
    /// RTU baud rate, when not the map's.
    pub baud: Option<u32>,
    pub limits: Option<SoftLimits>,
}

/// How a Modbus drive is reached.
#[derive(Debug, Clone, PartialEq)]
pub enum ModbusLink {
    Tcp(HostPort),
    /// RTU on a serial port (RS-485).
    Rtu {
        port: String,
    },
}

/// A force/torque sensor: one variant per interface, all opened by
/// [`open_force`](crate::device_open::open_force).
#[derive(Debug, Clone, PartialEq)]
pub enum ForceSpec {
    /// An ATI Net F/T or Ethernet Axia over RDT/UDP.
    NetFt(NetFtSpec),
    /// An ATI transducer's gauges read by an NI-DAQmx device, converted by its `.cal` file.
    NiDaqmx(DaqSpec),
}

impl ForceSpec {
    /// One line for the rig's device list.
    pub fn describe(&self) -> String {
        match self {
            ForceSpec::NetFt(n) => n.describe(),
            ForceSpec::NiDaqmx(d) => d.describe(),
        }
    }

    /// Whether the force stream carries the camera's exposure strobe (strobe sync possible).
    pub fn records_strobe(&self) -> bool {
        match self {
            ForceSpec::NetFt(_) => false,
            ForceSpec::NiDaqmx(d) => d.settings.strobe.is_some(),
        }
    }

    /// The name of its trace under `--record-trace DIR` (`DIR/<name>.trace`).
    pub fn trace_name(&self) -> &'static str {
        match self {
            ForceSpec::NetFt(_) => "netft",
            ForceSpec::NiDaqmx(_) => "force",
        }
    }
}

/// An NI-DAQmx device reading an ATI transducer's gauges (and the camera strobe), with the
/// transducer's `.cal` file.
#[derive(Debug, Clone, PartialEq)]
pub struct DaqSpec {
    pub settings: DaqSettings,
    /// The transducer's ATI calibration file.
    pub cal_file: PathBuf,
    /// NI-DAQmx's library, when not on the system's search path.
    pub library: Option<PathBuf>,
    /// Wrenches expressed in this tool frame, when given.
    pub tool: Option<ToolTransform>,
    /// The camera trigger the DAQ's counter generates, when it triggers the camera.
    pub camera_trigger: Option<CameraTrigger>,
    /// Who described it: errors name the rig file's key or the command's flag.
    pub named_by: DaqNames,
}

impl DaqSpec {
    /// One line for the rig's device list.
    pub fn describe(&self) -> String {
        format!(
            "force: {}, calibration {}",
            self.settings.describe(),
            self.cal_file.display()
        )
    }
}

/// Where a DAQ's settings were given, so that an error names what the user wrote.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DaqNames {
    /// A rig file's `[force]` keys.
    RigFile,
    /// `fringe daq`'s flags.
    Flags,
}

impl DaqNames {
    /// The key or flag of `setting`, as a user would write it in a message ("key
    /// `force.device`", "--device").
    pub fn of(self, setting: Setting) -> String {
        let (key, flag) = match setting {
            Setting::Library => ("library", "--library"),
            Setting::Device => ("device", "--device"),
            Setting::Gauges => ("gauges", "--channels"),
            Setting::Strobe => ("strobe", "--strobe"),
            Setting::Terminal => ("terminal", "--terminal"),
            Setting::Range => ("range_v", "--range"),
            Setting::Rate => ("rate_hz", "--rate"),
            Setting::Buffer => ("buffer_scans", "--buffer-scans"),
            Setting::CalFile => ("cal_file", "--cal"),
            Setting::Counter => {
                return match self {
                    DaqNames::RigFile => "keys `force.trigger_counter` and `camera.trigger`".into(),
                    DaqNames::Flags => "the camera trigger's counter".into(),
                }
            }
        };
        match self {
            DaqNames::RigFile => format!("key `force.{key}`"),
            DaqNames::Flags => flag.into(),
        }
    }
}

/// An ATI Net F/T or Ethernet Axia over RDT/UDP.
#[derive(Debug, Clone, PartialEq)]
pub struct NetFtSpec {
    pub address: HostPort,
    pub scaling: NetFtScaling,
    pub options: NetFtOptions,
}

impl NetFtSpec {
    /// A Net F/T at `address` streaming in `mode`, the other driver settings the defaults.
    pub fn new(address: HostPort, scaling: NetFtScaling, mode: Command) -> NetFtSpec {
        NetFtSpec {
            address,
            scaling,
            options: NetFtOptions {
                mode,
                ..NetFtOptions::default()
            },
        }
    }
}

impl NetFtSpec {
    /// One line for the rig's device list.
    pub fn describe(&self) -> String {
        format!("force: ATI Net F/T at {}", self.address)
    }
}

/// Where a Net F/T's counts per unit come from.
#[derive(Debug, Clone, PartialEq)]
pub enum NetFtScaling {
    /// Given (rig file `cpf`/`cpt`, `--cpf`/`--cpt`), checked when described.
    Given(NetFtConfig),
    /// Read from the box: `url`, or http://HOST/netftapi2.xml when `None`.
    FromBox { url: Option<String> },
}

/// A camera.
#[derive(Debug, Clone, PartialEq)]
pub enum CameraSpec {
    /// A GenICam camera through Aravis (cargo feature `aravis`): an id or GigE address, or the
    /// first camera found.
    Aravis { id: Option<String> },
}

impl CameraSpec {
    /// One line for the rig's device list.
    pub fn describe(&self) -> String {
        match self {
            CameraSpec::Aravis { id } => format!(
                "camera: Aravis {}",
                id.as_deref().unwrap_or("(first camera)")
            ),
        }
    }
}
