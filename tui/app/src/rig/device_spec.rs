//! What a real device is and how it is reached, whoever described it: a rig file section
//! (`RigConfig::axis_spec`, `force_spec`, `camera_spec`) or a bring-up command's flags (`fringe
//! ystage`, `axis`, `ft`, `camera`). Checked when described; opened by `device_open`, the one
//! opener, so that the same description opens the same driver with the same settings.

use crate::rig::host_port::HostPort;
use fringe_rig::AptConfig;
use fringe_rig::SoftLimits;

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
