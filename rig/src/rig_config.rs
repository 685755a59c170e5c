//! The rig file (`rig.toml`): which device is which, how each is reached and set up, the soft
//! limits, the sync method and the bench geometry; and opening the rig it describes.
//!
//! A missing file means the simulated bench ([`RigConfig::resolve`]): every device `driver =
//! "sim"`. A rig is either wholly simulated (one shared virtual bench) or wholly real; mixing the
//! two is refused, because a simulated camera cannot see a real indenter.
//!
//! Errors name the file, the key and what is allowed, e.g.
//! ``rig.toml: key `x.velocity` = -1: must be a number > 0 (mm/s)``. Commented examples:
//! `rig/rigs/simulated.toml` and `rig/rigs/reference-bench.toml`.

use crate::apt::driver::{
    open_serial, AptConfig, Controller, HomeConfig, HomeDirection, HomeLimitSwitch,
};
use crate::apt::status::LimitPolarity;
use crate::apt::{Actuator, ThorlabsAxis};
use crate::axis::{Axis, SoftLimits};
use crate::camera::{Camera, CameraSettings, PixelFormat, TriggerMode};
use crate::config_file::{parse_toml, ConfigError};
use crate::devices::Devices;
use crate::force::ForceSensor;
use crate::manual::{ManualStage, TerminalPrompt};
use crate::modbus::{Framing, ModbusStage, RegisterMap, StageOptions};
use crate::netft::{self, NetFt, NetFtConfig, NetFtOptions};
use crate::scan::origin::ContactOrigin;
use crate::scan::plan::BenchLimits;
use crate::sim::bench::AxisConfig;
use crate::sim::ground_truth::TruthSink;
use crate::sim::motion::Kinematics;
use crate::sim::rig::{ForcePath, SimRig, SimRigConfig};
use crate::sim::sensor::SensorConfig;
use crate::sync::method::SyncMethod;
use crate::trace::record::{record_datagrams, record_stream};
use crate::transport::serial::SerialLink;
use crate::transport::tcp::TcpLink;
use crate::transport::udp::UdpLink;
use crate::transport::{ByteLink, DatagramLink};
use crate::units::{
    Decibels, Hertz, Microseconds, Millimetres, MillimetresPerSecond, MillimetresPerSecondSquared,
    Newtons,
};
use serde::Deserialize;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Duration;

/// The file looked for in the working directory when no rig file is named.
pub const DEFAULT_RIG_FILE: &str = "rig.toml";

/// What drives an axis.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Default)]
#[serde(rename_all = "kebab-case")]
pub enum AxisDriver {
    /// The simulated bench's axis.
    #[default]
    Sim,
    /// A Thorlabs stepper controller (KST101/KST201/BSC20x) over its USB serial port.
    Thorlabs,
    /// A Modbus RTU drive on a serial port (RS-485).
    ModbusRtu,
    /// A Modbus TCP drive.
    ModbusTcp,
    /// A stage moved by hand: the operator is asked to set it and confirm.
    Manual,
}

/// Home parameters of a Thorlabs axis.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HomeSection {
    /// "reverse" (default) or "forward".
    #[serde(default = "reverse")]
    pub direction: String,
    /// The limit switch homing runs onto: "reverse" (default) or "forward".
    #[serde(default = "reverse")]
    pub limit_switch: String,
    /// mm/s.
    pub velocity: Option<f64>,
    /// mm away from the switch after homing.
    #[serde(default)]
    pub offset: f64,
}

fn reverse() -> String {
    "reverse".into()
}

/// One axis of the rig file.
#[derive(Debug, Clone, PartialEq, Deserialize, Default)]
#[serde(deny_unknown_fields, default)]
pub struct AxisSection {
    pub driver: AxisDriver,
    /// Serial port (Thorlabs, Modbus RTU), e.g. /dev/ttyUSB0 or /dev/serial/by-id/...
    pub port: Option<String>,
    /// host:port (Modbus TCP).
    pub address: Option<String>,
    /// Thorlabs controller: kst101 (default), kst201, bsc201, bsc202, bsc203.
    pub controller: Option<String>,
    /// Thorlabs actuator (ZFS25, ZST225, DRV250, ...).
    pub actuator: Option<String>,
    /// BSC202/203 bay (0-9).
    pub bay: Option<u8>,
    pub channel: Option<u8>,
    /// Soft limits, mm.
    pub min: Option<f64>,
    pub max: Option<f64>,
    /// mm/s and mm/s^2.
    pub velocity: Option<f64>,
    pub acceleration: Option<f64>,
    pub home: Option<HomeSection>,
    /// Which status bit is the forward limit: "bit0-forward" (default) or "bit0-reverse".
    pub limit_polarity: Option<String>,
    /// Modbus register map: a built-in name (oriental-az, leadshine-pr) or a TOML file.
    pub map: Option<String>,
    pub slave: Option<u8>,
    pub baud: Option<u32>,
}

/// What reads force and torque.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Default)]
#[serde(rename_all = "kebab-case")]
pub enum ForceDriver {
    #[default]
    Sim,
    /// ATI Net F/T or Ethernet Axia over RDT/UDP.
    Netft,
}

#[derive(Debug, Clone, PartialEq, Deserialize, Default)]
#[serde(deny_unknown_fields, default)]
pub struct ForceSection {
    pub driver: ForceDriver,
    /// Net F/T host or host:port (port 49152 by default).
    pub address: Option<String>,
    /// Counts per force / torque unit; read from http://HOST/netftapi2.xml when not given.
    pub cpf: Option<f64>,
    pub cpt: Option<f64>,
    pub force_unit: Option<String>,
    pub torque_unit: Option<String>,
    /// Largest force the F/T sensor and the sensor under test may see, N (default 20).
    pub max_force: Option<f64>,
}

/// What films the sensor.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Default)]
#[serde(rename_all = "kebab-case")]
pub enum CameraDriver {
    #[default]
    Sim,
    /// A GenICam camera through Aravis (cargo feature `aravis`).
    Aravis,
}

#[derive(Debug, Clone, PartialEq, Deserialize, Default)]
#[serde(deny_unknown_fields, default)]
pub struct CameraSection {
    pub driver: CameraDriver,
    /// Aravis camera id or GigE address (`fringe devices` lists them); the first camera if absent.
    pub id: Option<String>,
    pub exposure_us: Option<f64>,
    pub frame_rate: Option<f64>,
    pub gain_db: Option<f64>,
    /// mono8, rgb8 or bayerrg8.
    pub pixel_format: Option<String>,
    /// free-run (default), software, or a hardware line name such as Line1.
    pub trigger: Option<String>,
    /// Output line carrying ExposureActive to the DAQ (strobe sync), e.g. Line2.
    pub exposure_active_line: Option<String>,
}

/// Frame rate of the simulated camera unless the rig file sets one, Hz. The simulated camera
/// renders and a run records every frame at the real camera's 50 fps on 2 cores when nothing else
/// runs (BENCHMARKS.md, "Recording": 0 of 30 008 exposures dropped in 10 minutes), but a whole
/// scan adds the motion emulators and the control loops, and at 50 fps the renderer then falls
/// behind for moments (a full-grid main job dropped 4-7 of about 2150 exposures); at 25 fps it
/// drops none. Real cameras default to 50 fps.
pub const SIM_FRAME_RATE_HZ: f64 = 25.0;

/// Where the sensor sits on the stage (used until a calibration profile gives the origin).
#[derive(Debug, Clone, PartialEq, Deserialize, Default)]
#[serde(deny_unknown_fields, default)]
pub struct GeometrySection {
    /// Stage x and y (mm) that put the indenter over the sensor centre.
    pub x_centre: Option<f64>,
    pub y_centre: Option<f64>,
    /// z (mm) at which the indenter roughly touches the sensor (approach limit and estimates).
    pub z_contact: Option<f64>,
}

/// The simulated bench's own settings.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SimSection {
    pub seed: u64,
    /// layered, integrated or a sensor .toml file.
    pub sensor: String,
    /// daq (DAQ + .cal with the exposure strobe) or netft (no strobe: use clock-fit).
    pub force_path: ForcePath,
    /// Scale of the simulated camera image (1 = 1920x1200; 0.25 = 480x300 for quick tests).
    pub image_scale: f64,
}

impl Default for SimSection {
    fn default() -> Self {
        SimSection {
            seed: 1,
            sensor: "layered".into(),
            force_path: ForcePath::Daq,
            image_scale: 1.0,
        }
    }
}

/// The rig file as written.
#[derive(Debug, Clone, PartialEq, Deserialize, Default)]
#[serde(deny_unknown_fields, default)]
pub struct RigFile {
    pub name: Option<String>,
    /// Sensor build id (profiles/<sensor>.toml); the simulated sensor's id when simulated.
    pub sensor: Option<String>,
    /// strobe, clock-fit or host (default: strobe where the force path records the strobe,
    /// clock-fit otherwise).
    pub sync: Option<String>,
    /// Directory of calibration profiles (default profiles/).
    pub profiles: Option<PathBuf>,
    pub x: AxisSection,
    pub y: AxisSection,
    pub z: AxisSection,
    pub force: ForceSection,
    pub camera: CameraSection,
    pub geometry: GeometrySection,
    pub sim: SimSection,
}

/// Where the rig configuration came from.
#[derive(Debug, Clone, PartialEq)]
pub enum RigSource {
    /// Named on the command line.
    File(PathBuf),
    /// ./rig.toml, found in the working directory.
    Default(PathBuf),
    /// No rig file: the simulated bench.
    Simulated,
}

impl RigSource {
    pub fn describe(&self) -> String {
        match self {
            RigSource::File(p) => p.display().to_string(),
            RigSource::Default(p) => format!("{} (found in the working directory)", p.display()),
            RigSource::Simulated => {
                "no rig.toml: using the simulated bench (for real hardware give --rig FILE or put a rig.toml here; examples in rig/rigs/)"
                    .into()
            }
        }
    }
}

/// A checked rig configuration.
#[derive(Debug, Clone)]
pub struct RigConfig {
    pub file: RigFile,
    /// The file's text (stored in each run's start document).
    pub text: String,
    /// Name of the file in messages.
    pub origin: String,
    simulated: bool,
}

/// A rig that could not be opened.
#[derive(Debug, thiserror::Error)]
pub enum RigError {
    #[error(transparent)]
    Config(#[from] ConfigError),
    #[error("{device}: {message}")]
    Device { device: String, message: String },
}

fn device(device: &str, e: impl std::fmt::Display) -> RigError {
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
    /// The simulated bench, when simulated (kept alive for the devices).
    pub sim: Option<SimRig>,
}

/// A sensor build of the simulator by name (layered, integrated) or file.
pub fn sim_sensor(name: &str, origin: &str) -> Result<SensorConfig, ConfigError> {
    match name {
        "layered" => Ok(SensorConfig::layered()),
        "integrated" => Ok(SensorConfig::integrated()),
        path if path.ends_with(".toml") || Path::new(path).is_file() => {
            SensorConfig::load(Path::new(path)).map_err(|e| ConfigError {
                origin: origin.into(),
                message: format!("key `sim.sensor`: {e}"),
            })
        }
        other => Err(ConfigError {
            origin: origin.into(),
            message: format!(
                "key `sim.sensor` = {other:?}: use layered, integrated or the path of a sensor .toml file"
            ),
        }),
    }
}

impl RigConfig {
    /// The rig a command runs on: `path` if given (it must exist), else ./rig.toml if present,
    /// else the simulated bench.
    pub fn resolve(path: Option<&Path>) -> Result<(RigConfig, RigSource), ConfigError> {
        if let Some(p) = path {
            return Ok((RigConfig::load(p)?, RigSource::File(p.to_path_buf())));
        }
        let default = Path::new(DEFAULT_RIG_FILE);
        if default.is_file() {
            return Ok((
                RigConfig::load(default)?,
                RigSource::Default(default.to_path_buf()),
            ));
        }
        Ok((RigConfig::simulated(), RigSource::Simulated))
    }

    /// The default simulated bench.
    pub fn simulated() -> RigConfig {
        RigConfig {
            file: RigFile::default(),
            text: "# no rig file: the default simulated bench\n".into(),
            origin: "built-in simulated bench".into(),
            simulated: true,
        }
    }

    /// Reads and checks a rig file.
    pub fn load(path: &Path) -> Result<RigConfig, ConfigError> {
        let origin = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|e| ConfigError {
            origin: origin.clone(),
            message: format!(
                "cannot read the rig file: {e} (see rig/rigs/ for commented examples; without a rig file fringe uses the simulated bench)"
            ),
        })?;
        RigConfig::parse(&text, &origin)
    }

    /// Parses and checks rig file text; `origin` names it in errors.
    pub fn parse(text: &str, origin: &str) -> Result<RigConfig, ConfigError> {
        let file: RigFile = parse_toml(text).map_err(|message| ConfigError {
            origin: origin.into(),
            message,
        })?;
        let simulated = check(&file, origin)?;
        let config = RigConfig {
            file,
            text: text.to_string(),
            origin: origin.to_string(),
            simulated,
        };
        // Camera keys are checked here, before a dry run or any homing, not when the camera opens.
        config.camera_settings()?;
        Ok(config)
    }

    pub fn is_simulated(&self) -> bool {
        self.simulated
    }

    fn err(&self, message: String) -> ConfigError {
        ConfigError {
            origin: self.origin.clone(),
            message,
        }
    }

    /// The sync method: as written, or strobe where the force path records the strobe and
    /// clock-fit otherwise.
    pub fn sync(&self) -> Result<SyncMethod, ConfigError> {
        let strobe_wired = if self.simulated {
            self.file.sim.force_path == ForcePath::Daq
        } else {
            false
        };
        let method = match &self.file.sync {
            Some(s) => s
                .parse::<SyncMethod>()
                .map_err(|e| self.err(format!("key `sync`: {e}")))?,
            None if strobe_wired => SyncMethod::Strobe,
            None => SyncMethod::ClockFit,
        };
        if method == SyncMethod::Strobe && !strobe_wired {
            return Err(self.err(
                "key `sync` = \"strobe\": this force path records no exposure strobe (a Net F/T has no spare channel); use sync = \"clock-fit\""
                    .into(),
            ));
        }
        Ok(method)
    }

    /// The simulated rig's configuration (meaningful when simulated).
    pub fn sim_config(&self) -> Result<SimRigConfig, ConfigError> {
        let s = &self.file.sim;
        let mut sensor = sim_sensor(&s.sensor, &self.origin)?;
        if let Some(id) = &self.file.sensor {
            sensor.id = id.clone();
        }
        if s.image_scale != 1.0 {
            let g = &mut sensor.geometry;
            let k = s.image_scale;
            g.width = (f64::from(g.width) * k).round() as u32;
            g.height = (f64::from(g.height) * k).round() as u32;
            g.disc_radius_px *= k;
            g.px_per_mm *= k;
            g.centre_offset_px = [g.centre_offset_px[0] * k, g.centre_offset_px[1] * k];
            sensor.optics.blur_px *= k;
        }
        let mut c = SimRigConfig {
            seed: s.seed,
            sensor,
            force_path: s.force_path,
            ..SimRigConfig::default()
        };
        for (section, axis) in [
            (&self.file.x, &mut c.bench.x),
            (&self.file.y, &mut c.bench.y),
            (&self.file.z, &mut c.bench.z),
        ] {
            apply_sim_axis(section, axis);
        }
        Ok(c)
    }

    /// Soft limits, kinematics, force ceiling and contact height of the bench.
    pub fn limits(&self) -> Result<BenchLimits, ConfigError> {
        let max_force = Newtons(self.file.force.max_force.unwrap_or(20.0));
        if self.simulated {
            let c = self.sim_config()?;
            let b = &c.bench;
            let limits = |name: &str, a: &AxisConfig| {
                SoftLimits::new(Millimetres(0.0), Millimetres(a.travel_mm))
                    .map_err(|e| self.err(format!("[{name}]: {e}")))
            };
            let k = |a: &AxisConfig| Kinematics {
                velocity: MillimetresPerSecond(a.velocity_mm_s),
                acceleration: MillimetresPerSecondSquared(a.acceleration_mm_s2),
            };
            return Ok(BenchLimits {
                x: limits("x", &b.x)?,
                y: limits("y", &b.y)?,
                z: limits("z", &b.z)?,
                x_motion: k(&b.x),
                y_motion: k(&b.y),
                z_motion: k(&b.z),
                manual_y: false,
                max_force,
                contact_z: Millimetres(b.geometry.z_touch_mm),
            });
        }
        let f = &self.file;
        let axis = |name: &str, a: &AxisSection| -> Result<(SoftLimits, Kinematics), ConfigError> {
            let (Some(min), Some(max)) = (a.min, a.max) else {
                return Err(self.err(format!(
                    "[{name}]: keys `{name}.min` and `{name}.max` (soft limits, mm) are required on real hardware"
                )));
            };
            let limits = SoftLimits::new(Millimetres(min), Millimetres(max))
                .map_err(|e| self.err(format!("[{name}] min/max: {e}")))?;
            Ok((
                limits,
                Kinematics {
                    velocity: MillimetresPerSecond(a.velocity.unwrap_or(1.0)),
                    acceleration: MillimetresPerSecondSquared(a.acceleration.unwrap_or(1.0)),
                },
            ))
        };
        let (x, x_motion) = axis("x", &f.x)?;
        let (y, y_motion) = axis("y", &f.y)?;
        let (z, z_motion) = axis("z", &f.z)?;
        let contact_z = f.geometry.z_contact.ok_or_else(|| {
            self.err(
                "key `geometry.z_contact` is required on real hardware: the z (mm) at which the indenter roughly touches the sensor (the approach stops 3 mm past it)"
                    .into(),
            )
        })?;
        Ok(BenchLimits {
            x,
            y,
            z,
            x_motion,
            y_motion,
            z_motion,
            manual_y: f.y.driver == AxisDriver::Manual,
            max_force,
            contact_z: Millimetres(contact_z),
        })
    }

    /// The contact origin given by the rig file (or the simulated bench's geometry).
    pub fn origin(&self) -> Result<ContactOrigin, ConfigError> {
        let g = &self.file.geometry;
        if self.simulated {
            let c = self.sim_config()?;
            return Ok(ContactOrigin {
                x: Millimetres(g.x_centre.unwrap_or(c.bench.geometry.x_centre_mm)),
                y: Millimetres(g.y_centre.unwrap_or(c.bench.geometry.y_centre_mm)),
                source: "simulated bench geometry".into(),
            });
        }
        match (g.x_centre, g.y_centre) {
            (Some(x), Some(y)) => Ok(ContactOrigin {
                x: Millimetres(x),
                y: Millimetres(y),
                source: format!("{} [geometry]", self.origin),
            }),
            _ => Err(self.err(
                "keys `geometry.x_centre` and `geometry.y_centre` (stage mm over the sensor centre) are required on real hardware until `fringe calibrate` has written a profile for this sensor"
                    .into(),
            )),
        }
    }

    /// The sensor id: the rig file's, or the simulated sensor's.
    pub fn sensor_id(&self) -> Result<String, ConfigError> {
        if let Some(id) = &self.file.sensor {
            return Ok(id.clone());
        }
        if self.simulated {
            return Ok(self.sim_config()?.sensor.id);
        }
        Err(self.err(
            "key `sensor` (the sensor build id, e.g. \"layered-01\") is required on real hardware"
                .into(),
        ))
    }

    /// Directory of calibration profiles.
    pub fn profile_dir(&self) -> PathBuf {
        self.file
            .profiles
            .clone()
            .unwrap_or_else(|| PathBuf::from("profiles"))
    }

    /// Camera settings from [camera].
    pub fn camera_settings(&self) -> Result<CameraSettings, ConfigError> {
        let c = &self.file.camera;
        let d = CameraSettings::default();
        let pixel_format = match c.pixel_format.as_deref() {
            None => d.pixel_format,
            Some("mono8") => PixelFormat::Mono8,
            Some("rgb8") => PixelFormat::Rgb8,
            Some("bayerrg8") => PixelFormat::BayerRg8,
            Some(other) => {
                return Err(self.err(format!(
                    "key `camera.pixel_format` = {other:?}: use mono8, rgb8 or bayerrg8"
                )))
            }
        };
        let trigger = match c.trigger.as_deref() {
            None | Some("free-run") => TriggerMode::FreeRun,
            Some("software") => TriggerMode::Software,
            Some(line) if line.starts_with("Line") => TriggerMode::Hardware(line.to_string()),
            Some(other) => {
                return Err(self.err(format!(
                    "key `camera.trigger` = {other:?}: use free-run, software or a line name such as Line1"
                )))
            }
        };
        let settings = CameraSettings {
            exposure: c.exposure_us.map_or(d.exposure, Microseconds),
            gain: c.gain_db.map_or(d.gain, Decibels),
            frame_rate: c.frame_rate.map_or(
                if self.simulated {
                    Hertz(SIM_FRAME_RATE_HZ)
                } else {
                    d.frame_rate
                },
                Hertz,
            ),
            roi: None,
            pixel_format,
            trigger,
            exposure_active_line: c.exposure_active_line.clone(),
        };
        settings.check().map_err(|e| self.err(e.to_string()))?;
        Ok(settings)
    }

    /// Opens every device. `truth` receives the simulator's ground truth (simulated rigs);
    /// `record_trace` records every device link to DIR/<device>.trace (real rigs).
    pub fn open(
        &self,
        truth: Option<Arc<dyn TruthSink>>,
        record_trace: Option<&Path>,
    ) -> Result<OpenRig, RigError> {
        let limits = self.limits()?;
        let origin = self.origin()?;
        let sync = self.sync()?;
        let sensor_id = self.sensor_id()?;
        let camera_settings = self.camera_settings()?;
        if self.simulated {
            let config = self.sim_config()?;
            let (sim, devices) = SimRig::start(&config, truth).map_err(|e| device("rig", e))?;
            return Ok(OpenRig {
                devices,
                limits,
                origin,
                sync,
                sensor_id,
                camera_settings,
                text: self.text.clone(),
                sim: Some(sim),
            });
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

    fn apt_config(
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
            crate::camera::aravis::AravisCamera::open(id).map_err(|e| device("camera", e))?;
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

/// Copies the axis settings a simulated axis understands.
fn apply_sim_axis(s: &AxisSection, a: &mut AxisConfig) {
    if let Some(v) = s.velocity {
        a.velocity_mm_s = v;
    }
    if let Some(v) = s.acceleration {
        a.acceleration_mm_s2 = v;
    }
}

/// Checks what the types cannot; returns whether the rig is simulated.
fn check(f: &RigFile, origin: &str) -> Result<bool, ConfigError> {
    let err = |message: String| ConfigError {
        origin: origin.into(),
        message,
    };
    for (name, a) in [("x", &f.x), ("y", &f.y), ("z", &f.z)] {
        for (key, v, unit) in [
            ("velocity", a.velocity, "mm/s"),
            ("acceleration", a.acceleration, "mm/s^2"),
        ] {
            if let Some(v) = v {
                if !(v.is_finite() && v > 0.0) {
                    return Err(err(format!(
                        "key `{name}.{key}` = {v}: must be a number > 0 ({unit})"
                    )));
                }
            }
        }
        if let (Some(lo), Some(hi)) = (a.min, a.max) {
            if !(lo.is_finite() && hi.is_finite() && lo < hi) {
                return Err(err(format!(
                    "keys `{name}.min` = {lo} and `{name}.max` = {hi}: need min < max (mm)"
                )));
            }
        }
        if (name == "x" || name == "z") && a.driver == AxisDriver::Manual {
            return Err(err(format!(
                "key `{name}.driver` = \"manual\": only y may be moved by hand (x and z need sim or thorlabs)"
            )));
        }
    }
    let finite = |key: &str, v: Option<f64>, unit: &str| match v {
        Some(v) if !v.is_finite() => {
            Err(err(format!("key `{key}` = {v}: must be a number ({unit})")))
        }
        _ => Ok(()),
    };
    finite("geometry.x_centre", f.geometry.x_centre, "mm")?;
    finite("geometry.y_centre", f.geometry.y_centre, "mm")?;
    finite("geometry.z_contact", f.geometry.z_contact, "mm")?;
    for (name, a) in [("x", &f.x), ("y", &f.y), ("z", &f.z)] {
        finite(&format!("{name}.min"), a.min, "mm")?;
        finite(&format!("{name}.max"), a.max, "mm")?;
        if let Some(h) = &a.home {
            finite(&format!("{name}.home.offset"), Some(h.offset), "mm")?;
            if let Some(v) = h.velocity {
                if !(v.is_finite() && v > 0.0) {
                    return Err(err(format!(
                        "key `{name}.home.velocity` = {v}: must be a number > 0 (mm/s)"
                    )));
                }
            }
        }
    }
    for (key, v) in [("force.cpf", f.force.cpf), ("force.cpt", f.force.cpt)] {
        if let Some(v) = v {
            if !(v.is_finite() && v > 0.0) {
                return Err(err(format!(
                    "key `{key}` = {v}: must be a number > 0 (counts per unit, from the sensor's calibration sheet)"
                )));
            }
        }
    }
    let k = f.sim.image_scale;
    if !(k.is_finite() && (0.05..=1.0).contains(&k)) {
        return Err(err(format!(
            "key `sim.image_scale` = {k}: must be between 0.05 and 1 (1 = the full 1920x1200 image)"
        )));
    }
    if let Some(m) = f.force.max_force {
        if !(m.is_finite() && m > 0.0) {
            return Err(err(format!(
                "key `force.max_force` = {m}: must be a number > 0 (N)"
            )));
        }
    }
    let sims = [
        f.x.driver == AxisDriver::Sim,
        f.y.driver == AxisDriver::Sim,
        f.z.driver == AxisDriver::Sim,
        f.force.driver == ForceDriver::Sim,
        f.camera.driver == CameraDriver::Sim,
    ];
    let simulated = sims.iter().all(|s| *s);
    if !simulated && sims.iter().any(|s| *s) {
        let names = ["x", "y", "z", "force", "camera"];
        let sim: Vec<&str> = names
            .iter()
            .zip(sims)
            .filter(|(_, s)| *s)
            .map(|(n, _)| *n)
            .collect();
        return Err(err(format!(
            "devices {} are simulated (driver \"sim\", the default) but others are real: a rig is wholly simulated or wholly real; set a real driver for {}",
            sim.join(", "),
            sim.join(", ")
        )));
    }
    if let Some(s) = &f.sync {
        s.parse::<SyncMethod>()
            .map_err(|e| err(format!("key `sync`: {e}")))?;
    }
    Ok(simulated)
}

#[cfg(test)]
mod tests {
    use super::*;

    const REFERENCE: &str = include_str!("../rigs/reference-bench.toml");
    const SIMULATED: &str = include_str!("../rigs/simulated.toml");

    #[test]
    fn the_shipped_examples_parse_and_give_the_expected_bench() {
        let sim = RigConfig::parse(SIMULATED, "simulated.toml").expect("simulated example");
        assert!(sim.is_simulated());
        assert_eq!(sim.sync().expect("sync"), SyncMethod::Strobe);
        let l = sim.limits().expect("limits");
        assert_eq!(l.x.max, Millimetres(25.0));
        assert!(!l.manual_y);

        let real = RigConfig::parse(REFERENCE, "reference-bench.toml").expect("reference example");
        assert!(!real.is_simulated());
        assert_eq!(real.sync().expect("sync"), SyncMethod::ClockFit);
        let l = real.limits().expect("limits");
        assert!(l.manual_y, "the reference bench's y is moved by hand");
        assert_eq!(l.z.max, Millimetres(25.0));
        let apt = real
            .apt_config("z", &real.file.z, &l.z)
            .expect("z thorlabs config");
        assert_eq!(apt.actuator.name, "ZFS25");
        assert_eq!(apt.controller, Controller::Kst101);
        assert_eq!(
            real.camera_settings().expect("camera").exposure,
            Microseconds(2000.0)
        );
        assert_eq!(real.origin().expect("origin").x, Millimetres(12.5));
    }

    #[test]
    fn errors_name_the_file_the_key_and_what_is_allowed() {
        let e = RigConfig::parse("[x]\nvelocity = -1\n", "rig.toml").expect_err("negative");
        assert_eq!(
            e.to_string(),
            "rig.toml: key `x.velocity` = -1: must be a number > 0 (mm/s)"
        );
        let e = RigConfig::parse("[x]\ndriver = \"stepper\"\n", "rig.toml").expect_err("driver");
        let m = e.to_string();
        assert!(m.starts_with("rig.toml: line 2, key x.driver:"), "{m}");
        assert!(m.contains("thorlabs") && m.contains("manual"), "{m}");
        let e = RigConfig::parse("[x]\nspeed = 3\n", "rig.toml").expect_err("unknown key");
        assert!(e.to_string().contains("speed"), "{e}");
        let e = RigConfig::parse("sync = \"nearest\"\n", "rig.toml").expect_err("sync");
        assert!(e.to_string().contains("strobe, clock-fit or host"), "{e}");
        let e = RigConfig::parse("[camera]\ndriver = \"aravis\"\n", "rig.toml").expect_err("mixed");
        assert!(
            e.to_string().contains("x, y, z, force are simulated"),
            "{e}"
        );
        let e = RigConfig::parse("[sim]\nforce_path = \"netft\"\n", "rig.toml")
            .expect("netft sim")
            .sim_config();
        assert!(e.is_ok());
        let strobe = RigConfig::parse(
            "sync = \"strobe\"\n[sim]\nforce_path = \"netft\"\n",
            "rig.toml",
        )
        .expect("parses")
        .sync()
        .expect_err("no strobe channel");
        assert!(strobe.to_string().contains("clock-fit"), "{strobe}");
        let e = RigConfig::load(Path::new("/nonexistent/rig.toml")).expect_err("missing");
        assert!(
            e.to_string()
                .starts_with("/nonexistent/rig.toml: cannot read"),
            "{e}"
        );
    }

    #[test]
    fn real_rigs_must_give_limits_geometry_and_ports() {
        let text = REFERENCE.replacen("min = 0.0", "# min = 0.0", 1);
        let c = RigConfig::parse(&text, "r.toml").expect("parses");
        let e = c.limits().expect_err("no limits");
        assert!(e.to_string().contains("`x.min` and `x.max`"), "{e}");
        let c = RigConfig::parse(&REFERENCE.replace("z_contact", "# z_contact"), "r.toml")
            .expect("parses");
        assert!(c
            .limits()
            .expect_err("no z_contact")
            .to_string()
            .contains("geometry.z_contact"));
    }

    #[test]
    fn bad_numbers_are_refused_when_the_file_is_read() {
        for (from, to, key) in [
            ("z_contact = 15.0", "z_contact = nan", "geometry.z_contact"),
            ("x_centre = 12.5", "x_centre = inf", "geometry.x_centre"),
            (
                "exposure_us = 2000.0",
                "exposure_us = -5.0",
                "camera.exposure_us",
            ),
            (
                "exposure_us = 2000.0",
                "exposure_us = nan",
                "camera.exposure_us",
            ),
            (
                "exposure_us = 2000.0",
                "exposure_us = 30000.0",
                "camera.exposure_us",
            ),
            ("frame_rate = 50.0", "frame_rate = 0.0", "camera.frame_rate"),
            ("gain_db = 0.0", "gain_db = -3.0", "camera.gain_db"),
        ] {
            assert!(REFERENCE.contains(from), "{from}");
            let e = RigConfig::parse(&REFERENCE.replace(from, to), "r.toml")
                .expect_err(to)
                .to_string();
            assert!(
                e.starts_with("r.toml: key `") && e.contains(key),
                "{to}: {e}"
            );
        }
        let e = RigConfig::parse("[camera]\nframe_rate = 0.0\n", "sim.toml").expect_err("sim 0 Hz");
        assert!(e.to_string().contains("camera.frame_rate"), "{e}");
    }

    #[test]
    fn no_rig_file_means_the_simulated_bench() {
        let c = RigConfig::simulated();
        assert!(c.is_simulated());
        assert_eq!(c.sync().expect("sync"), SyncMethod::Strobe);
        assert_eq!(c.sensor_id().expect("id"), SensorConfig::layered().id);
    }
}
