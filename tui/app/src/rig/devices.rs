//! The rig file's device sections (`[x]`, `[y]`, `[z]`, `[camera]`) as device descriptions
//! ([`crate::rig::device_spec`]), checked and naming the file and key in errors; the rig opens
//! them with the one opener (`device_open`), as the bring-up commands do theirs. The `[force]`
//! section is the F/T door's (`RigConfig::force_spec` in `rig::force`, each interface's keys in
//! its own module).

use crate::rig::device_spec::{AxisSpec, CameraSpec, ModbusLink, ModbusSpec};
use crate::rig::file::{AxisDriver, AxisSection, CameraDriver, RigConfig};
use crate::rig::host_port::HostPort;
use fringe_rig::apt::Actuator;
use fringe_rig::apt::LimitPolarity;
use fringe_rig::ConfigError;
use fringe_rig::SoftLimits;
use fringe_rig::{
    apt::{HomeConfig, HomeDirection, HomeLimitSwitch},
    AptConfig, Controller,
};
use fringe_rig::{Millimetres, MillimetresPerSecond, MillimetresPerSecondSquared};

impl RigConfig {
    /// The axis `name` (`x`, `y` or `z`) of a real rig as a device description, with its soft
    /// limits.
    pub fn axis_spec(&self, name: &str, limits: &SoftLimits) -> Result<AxisSpec, ConfigError> {
        let a = match name {
            "x" => &self.file.x,
            "y" => &self.file.y,
            "z" => &self.file.z,
            other => {
                return Err(self.err(format!(
                    "no axis [{other}] in a rig file (the axes are x, y and z)"
                )))
            }
        };
        let port = || {
            a.port.clone().ok_or_else(|| {
                self.err(format!(
                    "[{name}]: key `{name}.port` (the serial port, e.g. /dev/ttyUSB0) is required for driver {:?}",
                    a.driver
                ))
            })
        };
        match a.driver {
            AxisDriver::Sim => Err(self.err(format!(
                "key `{name}.driver` = \"sim\" on a real rig: a rig is wholly simulated or wholly real"
            ))),
            AxisDriver::Thorlabs => Ok(AxisSpec::Thorlabs {
                config: self.apt_config(name, a, limits)?,
                port: port()?,
            }),
            AxisDriver::ModbusRtu | AxisDriver::ModbusTcp => {
                let map = a.map.clone().ok_or_else(|| {
                    self.err(format!(
                        "[{name}]: key `{name}.map` (oriental-az, leadshine-pr or a register map file) is required for a Modbus stage"
                    ))
                })?;
                let link = if a.driver == AxisDriver::ModbusRtu {
                    ModbusLink::Rtu { port: port()? }
                } else {
                    let text = a.address.as_deref().ok_or_else(|| {
                        self.err(format!(
                            "[{name}]: key `{name}.address` (host:port) is required for a Modbus TCP stage"
                        ))
                    })?;
                    ModbusLink::Tcp(
                        HostPort::parse(text, None)
                            .map_err(|e| self.err(format!("key `{name}.address`: {e}")))?,
                    )
                };
                Ok(AxisSpec::Modbus(ModbusSpec {
                    name: name.to_string(),
                    link,
                    map,
                    slave: a.slave,
                    baud: a.baud,
                    limits: Some(*limits),
                }))
            }
            AxisDriver::Manual => Ok(AxisSpec::Manual {
                name: name.to_string(),
                limits: Some(*limits),
            }),
        }
    }

    /// The Thorlabs settings of axis `name` from its section.
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

    /// The `[camera]` section of a real rig as a device description.
    pub fn camera_spec(&self) -> Result<CameraSpec, ConfigError> {
        match self.file.camera.driver {
            CameraDriver::Aravis => Ok(CameraSpec::Aravis {
                id: self.file.camera.id.clone(),
            }),
            CameraDriver::Sim => Err(self.err(
                "key `camera.driver` = \"sim\" on a real rig: a rig is wholly simulated or wholly real (use driver = \"aravis\")".into(),
            )),
        }
    }
}
