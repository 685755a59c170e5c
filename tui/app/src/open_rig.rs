//! Opening the rig a rig file describes: the real drivers (Thorlabs APT, Modbus, manual, Net F/T,
//! Aravis) on their links, or the simulated bench ([`crate::sim_bench`]) when the rig is simulated.

use crate::rig_file::{AxisDriver, AxisSection, RigConfig};
use fringe_rig::apt::driver::{
    open_serial, AptConfig, Controller, HomeConfig, HomeDirection, HomeLimitSwitch,
};
use fringe_rig::apt::status::LimitPolarity;
use fringe_rig::apt::{Actuator, ThorlabsAxis};
use fringe_rig::axis::{Axis, SoftLimits};
use fringe_rig::camera::{Camera, CameraSettings};
use fringe_rig::config_file::ConfigError;
use fringe_rig::devices::Devices;
use fringe_rig::force::ForceSensor;
use fringe_rig::manual::{ManualStage, TerminalPrompt};
use fringe_rig::modbus::{Framing, ModbusStage, RegisterMap, StageOptions};
use fringe_rig::netft::{self, NetFt, NetFtConfig, NetFtOptions};
use fringe_rig::scan::origin::ContactOrigin;
use fringe_rig::scan::plan::BenchLimits;
use fringe_rig::sync::method::SyncMethod;
use fringe_rig::trace::record::{record_datagrams, record_stream};
use fringe_rig::transport::serial::SerialLink;
use fringe_rig::transport::tcp::TcpLink;
use fringe_rig::transport::udp::UdpLink;
use fringe_rig::transport::{ByteLink, DatagramLink};
use fringe_rig::units::{Millimetres, MillimetresPerSecond, MillimetresPerSecondSquared};
use std::path::Path;
use std::time::Duration;

/// A rig that could not be opened.
#[derive(Debug, thiserror::Error)]
pub enum RigError {
    #[error(transparent)]
    Config(#[from] ConfigError),
    #[error("{device}: {message}")]
    Device { device: String, message: String },
}

pub(crate) fn device(device: &str, e: impl std::fmt::Display) -> RigError {
    RigError::Device {
        device: device.into(),
        message: e.to_string(),
    }
}

/// The rig, opened.
pub struct OpenRig {
    pub devices: Devices,
    pub limits: BenchLimits,
    /// Contact origin from the rig file or the simulated bench (a profile may replace it).
    pub origin: ContactOrigin,
    pub sync: SyncMethod,
    pub sensor_id: String,
    pub camera_settings: CameraSettings,
    /// The rig file's text (or a description of the default simulated bench).
    pub text: String,
    /// The simulated bench, when simulated (kept alive for the devices), and its ground truth.
    #[cfg(feature = "sim")]
    pub sim: Option<crate::sim_bench::SimBench>,
}

impl RigConfig {
    /// Opens every device: the simulated bench's when the rig is simulated (its ground truth
    /// recorded), else the real drivers; `record_trace` records every real device link to
    /// DIR/<device>.trace.
    pub fn open(&self, record_trace: Option<&Path>) -> Result<OpenRig, RigError> {
        let limits = self.limits()?;
        let origin = self.origin()?;
        let sync = self.sync()?;
        let sensor_id = self.sensor_id()?;
        let camera_settings = self.camera_settings()?;
        if self.simulated {
            return crate::sim_bench::open(self, limits, origin, sync, sensor_id, camera_settings);
        }
        let mut description = Vec::new();
        let x = self.open_axis("x", &self.file.x, &limits.x, record_trace, &mut description)?;
        let y = self.open_axis("y", &self.file.y, &limits.y, record_trace, &mut description)?;
        let z = self.open_axis("z", &self.file.z, &limits.z, record_trace, &mut description)?;
        let force = self.open_force(record_trace, &mut description)?;
        let camera = self.open_camera(&mut description)?;
        Ok(OpenRig {
            devices: Devices {
                x,
                y,
                z,
                force,
                camera,
                description,
            },
            limits,
            origin,
            sync,
            sensor_id,
            camera_settings,
            text: self.text.clone(),
            #[cfg(feature = "sim")]
            sim: None,
        })
    }

    fn open_axis(
        &self,
        name: &str,
        a: &AxisSection,
        limits: &SoftLimits,
        record_trace: Option<&Path>,
        description: &mut Vec<String>,
    ) -> Result<Box<dyn Axis>, RigError> {
        let trace = |link: Box<dyn ByteLink>| {
            record_stream(link, record_trace, &format!("axis-{name}"))
                .map_err(|e| device(name, format!("cannot record the trace: {e}")))
        };
        let port = || {
            a.port.clone().ok_or_else(|| {
                RigError::Config(self.err(format!(
                    "[{name}]: key `{name}.port` (the serial port, e.g. /dev/ttyUSB0) is required for driver {:?}",
                    a.driver
                )))
            })
        };
        match a.driver {
            AxisDriver::Sim => Err(device(name, "driver \"sim\" on a real rig")),
            AxisDriver::Thorlabs => {
                let config = self.apt_config(name, a, limits)?;
                let port = port()?;
                let serial = open_serial(&port).map_err(|e| {
                    device(
                        name,
                        format!("cannot open {port}: {e} (run `fringe devices` to list ports)"),
                    )
                })?;
                let link = trace(Box::new(serial))?;
                let axis = ThorlabsAxis::connect(link, config).map_err(|e| device(name, e))?;
                description.push(format!(
                    "{name}: Thorlabs {} on {port}",
                    a.actuator.as_deref().unwrap_or("")
                ));
                Ok(Box::new(axis))
            }
            AxisDriver::ModbusRtu | AxisDriver::ModbusTcp => {
                let map_name = a.map.clone().ok_or_else(|| {
                    RigError::Config(self.err(format!(
                        "[{name}]: key `{name}.map` (oriental-az, leadshine-pr or a register map file) is required for a Modbus stage"
                    )))
                })?;
                let map = RegisterMap::load(&map_name).map_err(|e| device(name, e))?;
                let (link, framing, at): (Box<dyn ByteLink>, Framing, String) = if a.driver
                    == AxisDriver::ModbusRtu
                {
                    let port = port()?;
                    let link = SerialLink::open(&port, &map.serial_settings(a.baud))
                        .map_err(|e| device(name, format!("cannot open {port}: {e}")))?;
                    (Box::new(link), Framing::Rtu, port)
                } else {
                    let addr = a.address.clone().ok_or_else(|| {
                            RigError::Config(self.err(format!(
                                "[{name}]: key `{name}.address` (host:port) is required for a Modbus TCP stage"
                            )))
                        })?;
                    let link = TcpLink::connect(&addr, Duration::from_secs(3))
                        .map_err(|e| device(name, format!("cannot connect to {addr}: {e}")))?;
                    (Box::new(link), Framing::Tcp, addr)
                };
                let link = trace(link)?;
                description.push(format!("{name}: Modbus stage, map {map_name}, on {at}"));
                Ok(Box::new(ModbusStage::new(
                    name,
                    link,
                    framing,
                    map,
                    StageOptions {
                        slave: a.slave,
                        limits: Some(*limits),
                        baud: a.baud,
                        ..StageOptions::default()
                    },
                )))
            }
            AxisDriver::Manual => {
                description.push(format!("{name}: moved by hand (the operator is asked)"));
                Ok(Box::new(ManualStage::new(
                    name,
                    Box::new(TerminalPrompt::stdio()),
                    Some(*limits),
                )))
            }
        }
    }

    pub(crate) fn apt_config(
        &self,
        name: &str,
        a: &AxisSection,
        limits: &SoftLimits,
    ) -> Result<AptConfig, ConfigError> {
        let actuator_name = a.actuator.as_deref().ok_or_else(|| {
            self.err(format!(
                "[{name}]: key `{name}.actuator` is required for a Thorlabs axis (known: {})",
                Actuator::known_names()
            ))
        })?;
        let actuator = Actuator::by_name(actuator_name).ok_or_else(|| {
            self.err(format!(
                "key `{name}.actuator` = {actuator_name:?}: unknown (known: {})",
                Actuator::known_names()
            ))
        })?;
        let controller = match a.controller.as_deref() {
            None => Controller::Kst101,
            Some(c) => c
                .parse::<Controller>()
                .map_err(|e| self.err(format!("key `{name}.controller`: {e}")))?,
        };
        let mut c = AptConfig::new(name, controller, actuator);
        c.bay = a.bay;
        if let Some(ch) = a.channel {
            c.channel = ch;
        }
        c.velocity = MillimetresPerSecond(a.velocity.unwrap_or(1.0));
        c.acceleration = MillimetresPerSecondSquared(a.acceleration.unwrap_or(1.0));
        c.soft_limits = Some(*limits);
        if let Some(h) = &a.home {
            let side = |key: &str, v: &str| match v {
                "reverse" => Ok(false),
                "forward" => Ok(true),
                other => Err(self.err(format!(
                    "key `{name}.home.{key}` = {other:?}: use reverse or forward"
                ))),
            };
            c.home = HomeConfig {
                direction: if side("direction", &h.direction)? {
                    HomeDirection::Forward
                } else {
                    HomeDirection::Reverse
                },
                limit_switch: if side("limit_switch", &h.limit_switch)? {
                    HomeLimitSwitch::Forward
                } else {
                    HomeLimitSwitch::Reverse
                },
                velocity: MillimetresPerSecond(h.velocity.unwrap_or(c.velocity.0.min(1.0))),
                offset: Millimetres(h.offset),
            };
        } else {
            c.home.velocity = MillimetresPerSecond(c.velocity.0.min(1.0));
        }
        c.limit_polarity = match a.limit_polarity.as_deref() {
            None | Some("bit0-forward") => LimitPolarity::Bit0Forward,
            Some("bit0-reverse") => LimitPolarity::Bit0Reverse,
            Some(other) => {
                return Err(self.err(format!(
                    "key `{name}.limit_polarity` = {other:?}: use bit0-forward or bit0-reverse"
                )))
            }
        };
        Ok(c)
    }

    fn open_force(
        &self,
        record_trace: Option<&Path>,
        description: &mut Vec<String>,
    ) -> Result<Box<dyn ForceSensor>, RigError> {
        let f = &self.file.force;
        let address =
            f.address.clone().ok_or_else(|| {
                RigError::Config(self.err(
                    "key `force.address` (the Net F/T's host or host:port) is required".into(),
                ))
            })?;
        let (host, port) = match address.rsplit_once(':') {
            Some((h, p)) if !h.contains(':') => (
                h.to_string(),
                p.parse::<u16>().map_err(|_| {
                    RigError::Config(self.err(format!(
                        "key `force.address` = {address:?}: the port must be a number"
                    )))
                })?,
            ),
            _ => (address.clone(), netft::DEFAULT_PORT),
        };
        let config = match (f.cpf, f.cpt) {
            (Some(cpf), Some(cpt)) => NetFtConfig::new(
                cpf,
                cpt,
                f.force_unit.as_deref().unwrap_or("N"),
                f.torque_unit.as_deref().unwrap_or("Nm"),
                "rig file [force] cpf/cpt",
            )
            .map_err(|e| device("force", e))?,
            (None, None) => {
                netft::fetch_config(&netft::netftapi2_url(&host), Duration::from_secs(3))
                    .map_err(|e| device("force", e))?
            }
            _ => {
                return Err(RigError::Config(self.err(
                    "[force]: give both `cpf` and `cpt`, or neither (then they are read from the box)"
                        .into(),
                )))
            }
        };
        let addr = format!("{host}:{port}");
        let link: Box<dyn DatagramLink> =
            Box::new(UdpLink::connect(&addr).map_err(|e| {
                device("force", format!("cannot open a UDP socket to {addr}: {e}"))
            })?);
        let link = record_datagrams(link, record_trace, "netft")
            .map_err(|e| device("force", format!("cannot record the trace: {e}")))?;
        description.push(format!("force: ATI Net F/T at {addr}"));
        Ok(Box::new(NetFt::new(link, config, NetFtOptions::default())))
    }

    #[cfg(feature = "aravis")]
    fn open_camera(&self, description: &mut Vec<String>) -> Result<Box<dyn Camera>, RigError> {
        let id = self.file.camera.id.as_deref();
        let camera =
            fringe_rig::camera::aravis::AravisCamera::open(id).map_err(|e| device("camera", e))?;
        description.push(format!("camera: Aravis {}", id.unwrap_or("(first camera)")));
        Ok(Box::new(camera))
    }

    #[cfg(not(feature = "aravis"))]
    fn open_camera(&self, _description: &mut Vec<String>) -> Result<Box<dyn Camera>, RigError> {
        Err(device(
            "camera",
            "driver \"aravis\" needs a build with the aravis feature: sudo apt install libaravis-dev libusb-1.0-0-dev; cargo run --release --features aravis -- ...",
        ))
    }
}
