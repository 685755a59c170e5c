//! The rig file (`rig.toml`): which device is which, how each is reached and set up, the soft
//! limits, the sync method and the bench geometry, read and checked. The bench it describes
//! (limits, origin, sensor) is module `rig::setup`; its devices as descriptions `rig::devices`;
//! opening them `rig::open`; the simulated rig's part `rig::simulated`.
//!
//! A missing file means the simulated bench ([`RigConfig::resolve`]): every device `driver =
//! "sim"`. A rig is either wholly simulated (one shared virtual bench) or wholly real; mixing the
//! two is refused, because a simulated camera cannot see a real indenter.
//!
//! Errors name the file, the key and what is allowed, e.g.
//! ``rig.toml: key `x.velocity` = -1: must be a number > 0 (mm/s)``. Commented examples:
//! `tui/app/rigs/simulated.toml` and `tui/app/rigs/reference-bench.toml`.

use crate::rig::force::section::check_force_section;
use crate::rig::force::section::{ForceDriver, ForceSection};
use fringe_rig::apt::Actuator;
use fringe_rig::nidaqmx::DaqSettings;
use fringe_rig::store::FrameCodec;
use fringe_rig::store::{RecordingSection, StoredPart};
use fringe_rig::Plan;
use fringe_rig::SyncMethod;
use fringe_rig::TriggerTiming;
use fringe_rig::{parse_toml, ConfigError};
use fringe_rig::{CameraSettings, PixelFormat, TriggerMode};
use fringe_rig::{
    Decibels, Hertz, Microseconds, MillimetresPerSecond, MillimetresPerSecondSquared,
};
use serde::Deserialize;
use std::path::{Path, PathBuf};

/// Why a build without the `sim` feature refuses a simulated rig.
pub(crate) const NO_SIM: &str = "every device is simulated (driver \"sim\", the default), but this fringe was built without the simulated bench: give each device a real driver, or build with the default features (cargo feature `sim`)";

/// The file looked for in the working directory when no rig file is named.
pub(crate) const DEFAULT_RIG_FILE: &str = "rig.toml";

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
    /// free-run (default), software, a hardware line name such as Line1, or daq (the DAQ's
    /// counter on `trigger_line`, on the gauges' sample clock: sync `trigger`).
    pub trigger: Option<String>,
    /// With trigger = "daq": the camera's input line the counter is wired to (default Line1).
    pub trigger_line: Option<String>,
    /// With trigger = "daq": rising edge to exposure start, us (the camera's exposure start
    /// delay plus its line's response time; default Basler's example, 17.62 + 1.5 us).
    pub trigger_delay_us: Option<f64>,
    /// Output line carrying ExposureActive to the DAQ (strobe sync), e.g. Line2.
    pub exposure_active_line: Option<String>,
}

/// Frame rate of the simulated camera unless the rig file sets one, Hz: the real camera's 50 fps.
/// The simulated camera renders every frame in the same process; a whole scan at 50 fps on an
/// idle 2-core machine drops none (BENCHMARKS.md, "Recording").
pub(crate) const SIM_FRAME_RATE_HZ: f64 = 50.0;

/// The camera's input line the DAQ's counter is wired to, unless the rig file says.
pub(crate) const DAQ_TRIGGER_LINE: &str = "Line1";

/// Rising edge to exposure start when the rig file does not say, us: Basler's documented example
/// (an exposure start delay of 17.62 us plus the input line's response time, 1.5 us).
pub(crate) const BASLER_EXAMPLE_TRIGGER_DELAY_US: f64 = 19.12;

/// The simulated DAQ's scan rate, Hz (`SimDaqConfig`'s, which a rig file does not change).
const SIM_DAQ_RATE_HZ: f64 = 5000.0;

/// The simulated camera's delay from a trigger line's edge to the exposure, us.
fn sim_trigger_delay_us() -> f64 {
    #[cfg(feature = "sim")]
    {
        let c = fringe_sim::SimCameraConfig::default();
        c.trigger_latency_us + c.line_response_us
    }
    #[cfg(not(feature = "sim"))]
    BASLER_EXAMPLE_TRIGGER_DELAY_US
}

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

/// Which path the simulated force takes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Default)]
#[serde(rename_all = "kebab-case")]
pub enum SimForcePath {
    /// DAQ + `.cal` at 5 kHz with the exposure strobe recorded beside the gauges.
    #[default]
    Daq,
    /// An ATI Net F/T box over RDT (no strobe channel).
    Netft,
}

/// The simulated bench's own settings.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SimSection {
    pub seed: u64,
    /// layered, integrated or a sensor .toml file.
    pub sensor: String,
    /// daq (DAQ + .cal with the exposure strobe) or netft (no strobe: use clock-fit).
    pub force_path: SimForcePath,
    /// Scale of the simulated camera image (1 = 1920x1200; 0.25 = 480x300 for quick tests).
    pub image_scale: f64,
    /// Faults injected on purpose (`[[sim.faults]]`, see fringe_sim::FaultSpec): what a user sees
    /// and what a run keeps when a device fails.
    #[cfg(feature = "sim")]
    pub faults: Vec<fringe_sim::FaultSpec>,
    /// Session of the bench (default 0): repeated checks of the same unchanged bench differ only
    /// by their noise (see rig/sim/src/session.rs).
    pub session: u64,
    /// What changed in the unit since it was accepted (`[sim.ageing]`, see fringe_sim::Ageing;
    /// default nothing).
    #[cfg(feature = "sim")]
    pub ageing: fringe_sim::Ageing,
}

impl Default for SimSection {
    fn default() -> Self {
        SimSection {
            seed: 1,
            sensor: "layered".into(),
            force_path: SimForcePath::Daq,
            image_scale: 1.0,
            #[cfg(feature = "sim")]
            faults: Vec::new(),
            session: 0,
            #[cfg(feature = "sim")]
            ageing: fringe_sim::Ageing::default(),
        }
    }
}

/// A sensor design: the two builds of the reference paper.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum SensorVariant {
    Layered,
    Integrated,
}

impl SensorVariant {
    pub fn name(self) -> &'static str {
        match self {
            SensorVariant::Layered => "layered",
            SensorVariant::Integrated => "integrated",
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
    /// The sensor's design, `layered` or `integrated` (a model of the other design is refused);
    /// the simulated sensor's when simulated.
    pub variant: Option<SensorVariant>,
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
    pub recording: RecordingSection,
    pub sim: SimSection,
    pub stream: StreamSection,
}

/// `fringe stream`'s ROS 2 node and recording (`[stream]`; its flags override each key).
#[derive(Debug, Clone, PartialEq, Deserialize, Default)]
#[serde(deny_unknown_fields, default)]
pub struct StreamSection {
    /// The node's namespace, `/fringe` by default: topics `<namespace>/wrench`, ...
    pub namespace: Option<String>,
    /// ROS domain id (0 by default).
    pub domain: Option<u32>,
    /// The frame id in every message's header (`fringe_sensor` by default).
    pub frame_id: Option<String>,
    /// Zenoh endpoints to connect to (`tcp/localhost:7447`, rmw_zenoh's router, by default).
    pub connect: Vec<String>,
    /// Zenoh endpoints to listen on (`tcp/localhost:0` by default).
    pub listen: Vec<String>,
    /// Frames a second published as `<namespace>/image/compressed` (0, none, by default).
    pub image_hz: Option<f64>,
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
    /// The rig in a few words, for a header line: the file, or the simulated bench (the advice
    /// [`RigSource::describe`] gives left out).
    pub fn short(&self) -> String {
        match self {
            RigSource::File(p) => p.display().to_string(),
            RigSource::Default(p) => format!("{} (working directory)", p.display()),
            RigSource::Simulated => "simulated bench (no rig.toml)".into(),
        }
    }

    pub fn describe(&self) -> String {
        match self {
            RigSource::File(p) => p.display().to_string(),
            RigSource::Default(p) => format!("{} (found in the working directory)", p.display()),
            RigSource::Simulated => {
                "no rig.toml: using the simulated bench (for real hardware give --rig FILE or put a rig.toml here; examples in tui/app/rigs/)"
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
    pub(crate) simulated: bool,
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
        if !cfg!(feature = "sim") {
            return Err(ConfigError {
                origin: DEFAULT_RIG_FILE.into(),
                message: format!("not found in the working directory and {NO_SIM}"),
            });
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
                "cannot read the rig file: {e} (see tui/app/rigs/ for commented examples; without a rig file fringe uses the simulated bench)"
            ),
        })?;
        RigConfig::parse(&text, &origin)
    }

    /// Parses and checks rig file text; `origin` names it in errors.
    pub fn parse(text: &str, origin: &str) -> Result<RigConfig, ConfigError> {
        let file: RigFile = parse_toml(text, origin)?;
        let simulated = check(&file, origin)?;
        if simulated && !cfg!(feature = "sim") {
            return Err(ConfigError {
                origin: origin.into(),
                message: NO_SIM.into(),
            });
        }
        let config = RigConfig {
            file,
            text: text.to_string(),
            origin: origin.to_string(),
            simulated,
        };
        // Camera and recording keys are checked here, before a dry run or any homing, not when
        // the camera opens.
        config.camera_settings()?;
        config.stored_part(None)?;
        config.frame_codec(None)?;
        Ok(config)
    }

    pub fn is_simulated(&self) -> bool {
        self.simulated
    }

    pub(crate) fn err(&self, message: String) -> ConfigError {
        ConfigError {
            origin: self.origin.clone(),
            message,
        }
    }

    /// Whether the DAQ triggers the camera (`[camera] trigger = "daq"`); refused where the force
    /// path has no DAQ counter.
    pub fn daq_triggers_camera(&self) -> Result<bool, ConfigError> {
        if self.file.camera.trigger.as_deref() != Some("daq") {
            for (key, given) in [
                (
                    "camera.trigger_line",
                    self.file.camera.trigger_line.is_some(),
                ),
                (
                    "camera.trigger_delay_us",
                    self.file.camera.trigger_delay_us.is_some(),
                ),
                (
                    "force.trigger_counter",
                    self.file.force.trigger_counter.is_some(),
                ),
                (
                    "force.trigger_terminal",
                    self.file.force.trigger_terminal.is_some(),
                ),
            ] {
                if given {
                    return Err(self.err(format!(
                        "key `{key}` is for a camera triggered by the DAQ: set `camera.trigger` = \"daq\" or remove it"
                    )));
                }
            }
            return Ok(false);
        }
        let daq = if self.simulated {
            self.file.sim.force_path == SimForcePath::Daq
        } else {
            self.file.force.driver == ForceDriver::Nidaqmx
        };
        if !daq {
            return Err(self.err(
                "key `camera.trigger` = \"daq\": the camera is triggered by a counter of the DAQ that reads the gauges; it needs [force] driver = \"nidaqmx\" (or, simulated, [sim] force_path = \"daq\")"
                    .into(),
            ));
        }
        if let Some(d) = self.file.camera.trigger_delay_us {
            if !(d.is_finite() && (0.0..1e6).contains(&d)) {
                return Err(self.err(format!(
                    "key `camera.trigger_delay_us` = {d}: must be the camera's delay from the trigger's edge to the exposure, in us (0 or more; Basler's example is 19.12)"
                )));
            }
        }
        Ok(true)
    }

    /// The DAQ-triggered camera's timing for sync `trigger`, when the DAQ triggers the camera.
    pub fn trigger_timing(&self) -> Result<Option<TriggerTiming>, ConfigError> {
        if !self.daq_triggers_camera()? {
            return Ok(None);
        }
        let camera = self.camera_settings()?;
        let scan_rate = if self.simulated {
            SIM_DAQ_RATE_HZ
        } else {
            self.file
                .force
                .rate_hz
                .unwrap_or(DaqSettings::default().rate.0)
        };
        let delay = self
            .file
            .camera
            .trigger_delay_us
            .unwrap_or(if self.simulated {
                sim_trigger_delay_us()
            } else {
                BASLER_EXAMPLE_TRIGGER_DELAY_US
            });
        Ok(Some(TriggerTiming {
            scan_rate: Hertz(scan_rate),
            frame_rate: camera.frame_rate,
            delay: Microseconds(delay),
            exposure: camera.exposure,
        }))
    }

    /// The sync method: as written, or `trigger` where the DAQ triggers the camera, `strobe`
    /// where the force path records the strobe, and clock-fit otherwise.
    pub fn sync(&self) -> Result<SyncMethod, ConfigError> {
        let triggered = self.daq_triggers_camera()?;
        let daq = !self.simulated && self.file.force.driver == ForceDriver::Nidaqmx;
        let strobe_wired = if self.simulated {
            self.file.sim.force_path == SimForcePath::Daq
        } else {
            daq && self.file.force.strobe.is_some()
        };
        let method = match &self.file.sync {
            Some(s) => s
                .parse::<SyncMethod>()
                .map_err(|e| self.err(format!("key `sync`: {e}")))?,
            None if triggered => SyncMethod::Trigger,
            None if strobe_wired => SyncMethod::Strobe,
            None => SyncMethod::ClockFit,
        };
        if method == SyncMethod::Trigger && !triggered {
            return Err(self.err(
                "key `sync` = \"trigger\": the camera is not triggered by the DAQ; set `camera.trigger` = \"daq\" (and wire the DAQ's counter to the camera's trigger line), or use another sync"
                    .into(),
            ));
        }
        if method == SyncMethod::Strobe && !strobe_wired && daq {
            return Err(self.err(
                "key `sync` = \"strobe\": the DAQ records no exposure strobe without key `force.strobe` (the analogue input wired to the camera's exposure-active output, e.g. \"ai7\"); give it, or use sync = \"clock-fit\""
                    .into(),
            ));
        }
        if method == SyncMethod::Strobe && !strobe_wired {
            return Err(self.err(
                "key `sync` = \"strobe\": this force path records no exposure strobe (a Net F/T has no spare channel); use sync = \"clock-fit\""
                    .into(),
            ));
        }
        Ok(method)
    }

    /// Directory of calibration profiles.
    pub fn profile_dir(&self) -> PathBuf {
        self.file
            .profiles
            .clone()
            .unwrap_or_else(|| PathBuf::from("profiles"))
    }

    /// `[recording]` for a scan of `plan`: the plan's keys over the rig file's (`None`: the
    /// rig file's alone).
    fn recording(&self, plan: Option<&Plan>) -> RecordingSection {
        let rig = &self.file.recording;
        plan.and_then(|p| p.recording.as_ref())
            .map_or_else(|| rig.clone(), |over| over.over(rig))
    }

    /// The part of each frame a scan of `plan` stores. A plan's keys were checked when it was
    /// expanded; an error names the rig file's key.
    pub fn stored_part(&self, plan: Option<&Plan>) -> Result<StoredPart, ConfigError> {
        self.recording(plan).stored_part().map_err(|m| self.err(m))
    }

    /// The codec a scan of `plan` stores frames in (`None`: the default for the camera's pixel
    /// format).
    pub fn frame_codec(&self, plan: Option<&Plan>) -> Result<Option<FrameCodec>, ConfigError> {
        self.recording(plan).codec().map_err(|m| self.err(m))
    }

    /// `[stream]`: the stream's node and recording settings.
    pub fn stream_section(&self) -> &StreamSection {
        &self.file.stream
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
            Some("daq") => {
                let line = c.trigger_line.as_deref().unwrap_or(DAQ_TRIGGER_LINE);
                if !line.starts_with("Line") {
                    return Err(self.err(format!(
                        "key `camera.trigger_line` = {line:?}: give the camera's input line the DAQ's counter is wired to, such as Line1"
                    )));
                }
                TriggerMode::Hardware(line.to_string())
            }
            Some(line) if line.starts_with("Line") => TriggerMode::Hardware(line.to_string()),
            Some(other) => {
                return Err(self.err(format!(
                    "key `camera.trigger` = {other:?}: use free-run, software, daq or a line name such as Line1"
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
}

/// Checks what the types cannot; returns whether the rig is simulated.
fn check(f: &RigFile, origin: &str) -> Result<bool, ConfigError> {
    for (name, a) in [("x", &f.x), ("y", &f.y), ("z", &f.z)] {
        check_axis(name, a, origin)?;
    }
    check_positions(f, origin)?;
    check_force_section(&f.force).map_err(|message| bad(origin, message))?;
    check_sim(&f.sim, origin)?;
    if let Some(m) = f.force.max_force {
        if !(m.is_finite() && m > 0.0) {
            return Err(bad(
                origin,
                format!("key `force.max_force` = {m}: must be a number > 0 (N)"),
            ));
        }
    }
    let simulated = wholly_simulated(f, origin)?;
    if let Some(s) = &f.sync {
        s.parse::<SyncMethod>()
            .map_err(|e| bad(origin, format!("key `sync`: {e}")))?;
    }
    Ok(simulated)
}

/// An error in the rig file `origin`.
fn bad(origin: &str, message: String) -> ConfigError {
    ConfigError {
        origin: origin.into(),
        message,
    }
}

/// Checks axis `name`'s motion settings, soft limits and driver.
fn check_axis(name: &str, a: &AxisSection, origin: &str) -> Result<(), ConfigError> {
    for (key, v, unit) in [
        ("velocity", a.velocity, "mm/s"),
        ("acceleration", a.acceleration, "mm/s^2"),
    ] {
        if let Some(v) = v {
            if !(v.is_finite() && v > 0.0) {
                return Err(bad(
                    origin,
                    format!("key `{name}.{key}` = {v}: must be a number > 0 ({unit})"),
                ));
            }
        }
    }
    if let (Some(lo), Some(hi)) = (a.min, a.max) {
        if !(lo.is_finite() && hi.is_finite() && lo < hi) {
            return Err(bad(
                origin,
                format!("keys `{name}.min` = {lo} and `{name}.max` = {hi}: need min < max (mm)"),
            ));
        }
    }
    check_stepper_units(name, a, origin)?;
    if (name == "x" || name == "z") && a.driver == AxisDriver::Manual {
        return Err(bad(origin, format!(
            "key `{name}.driver` = \"manual\": only y may be moved by hand (x and z need sim or thorlabs)"
        )));
    }
    Ok(())
}

/// A stepper axis (Thorlabs, and the simulated bench's emulated KST101 + ZFS25) takes its
/// velocity and acceleration in 32-bit device units: checked here, not at the first move.
fn check_stepper_units(name: &str, a: &AxisSection, origin: &str) -> Result<(), ConfigError> {
    let stepper = match a.driver {
        AxisDriver::Sim => Actuator::by_name("ZFS25"),
        AxisDriver::Thorlabs => a.actuator.as_deref().and_then(Actuator::by_name),
        _ => None,
    };
    let Some(act) = stepper else {
        return Ok(());
    };
    let v = a
        .velocity
        .map(|v| act.velocity_to_device(MillimetresPerSecond(v)).err());
    let acc = a.acceleration.map(|v| {
        act.acceleration_to_device(MillimetresPerSecondSquared(v))
            .err()
    });
    for (key, value, too_big) in [
        ("velocity", a.velocity, v.flatten().is_some()),
        ("acceleration", a.acceleration, acc.flatten().is_some()),
    ] {
        if too_big {
            return Err(bad(origin, format!(
                "key `{name}.{key}` = {}: more than a {} controller can be given for the {} (its {key} is a 32-bit number of device units); use a value the stage's datasheet allows",
                value.unwrap_or_default(),
                if a.driver == AxisDriver::Sim { "simulated KST101" } else { "Thorlabs" },
                act.name
            )));
        }
    }
    Ok(())
}

/// Checks the bench geometry, the soft limits and the homing settings are numbers.
fn check_positions(f: &RigFile, origin: &str) -> Result<(), ConfigError> {
    let finite = |key: &str, v: Option<f64>, unit: &str| match v {
        Some(v) if !v.is_finite() => Err(bad(
            origin,
            format!("key `{key}` = {v}: must be a number ({unit})"),
        )),
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
                    return Err(bad(
                        origin,
                        format!("key `{name}.home.velocity` = {v}: must be a number > 0 (mm/s)"),
                    ));
                }
            }
        }
    }
    Ok(())
}

/// Checks the simulated bench's faults and image scale.
fn check_sim(sim: &SimSection, origin: &str) -> Result<(), ConfigError> {
    #[cfg(feature = "sim")]
    for fault in &sim.faults {
        fault
            .check()
            .map_err(|e| bad(origin, format!("[[sim.faults]]: {e}")))?;
    }
    #[cfg(feature = "sim")]
    sim.ageing.check().map_err(|e| bad(origin, e.to_string()))?;
    let k = sim.image_scale;
    if !(k.is_finite() && (0.05..=1.0).contains(&k)) {
        return Err(bad(
            origin,
            format!(
            "key `sim.image_scale` = {k}: must be between 0.05 and 1 (1 = the full 1920x1200 image)"
        ),
        ));
    }
    Ok(())
}

/// Whether every device is simulated; a rig mixing simulated and real devices is refused.
fn wholly_simulated(f: &RigFile, origin: &str) -> Result<bool, ConfigError> {
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
        return Err(bad(origin, format!(
            "devices {} are simulated (driver \"sim\", the default) but others are real: a rig is wholly simulated or wholly real; set a real driver for {}",
            sim.join(", "),
            sim.join(", ")
        )));
    }
    Ok(simulated)
}

// The examples include a simulated bench: these tests need the `sim` feature (a default).
#[cfg(all(test, feature = "sim"))]
mod tests {
    use super::*;
    use fringe_rig::Controller;
    use fringe_rig::Millimetres;

    const REFERENCE: &str = include_str!("../../rigs/reference-bench.toml");
    const SIMULATED: &str = include_str!("../../rigs/simulated.toml");
    const PAPER: &str = include_str!("../../rigs/paper-bench.toml");

    #[test]
    fn recording_keys_are_checked_when_the_file_is_read() {
        let disc = RigConfig::parse("[recording]\nstore = \"disc\"\n", "rig.toml").expect("disc");
        assert_eq!(
            disc.stored_part(None).expect("stored part"),
            StoredPart::Disc {
                margin_px: fringe_rig::store::DISC_MARGIN_PX
            }
        );
        for (text, key) in [
            ("[recording]\nstore = \"crop\"\n", "recording.store"),
            ("[recording]\ncodec = \"jpeg\"\n", "recording.codec"),
            (
                "[recording]\ndisc_margin_px = -3.0\n",
                "recording.disc_margin_px",
            ),
        ] {
            let e = RigConfig::parse(text, "rig.toml")
                .expect_err(text)
                .to_string();
            assert!(e.contains("rig.toml") && e.contains(key), "{e}");
        }
    }

    #[test]
    fn the_shipped_examples_parse_and_give_the_expected_bench() {
        let sim = RigConfig::parse(SIMULATED, "simulated.toml").expect("simulated example");
        assert!(sim.is_simulated());
        assert_eq!(
            sim.camera_settings().expect("camera").pixel_format,
            PixelFormat::BayerRg8
        );
        assert_eq!(sim.stored_part(None).expect("recording"), StoredPart::Frame);
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

    /// The paper's bench: the DAQ reads the gauges and the strobe and triggers the camera, so
    /// frames are labelled by the trigger with the camera's delay.
    #[test]
    fn the_paper_bench_example_triggers_the_camera_from_the_daq() {
        let cal = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../tests/data/mini40-v1.0.cal"
        );
        let paper = RigConfig::parse(&PAPER.replace("FT12345.cal", cal), "paper-bench.toml")
            .expect("paper example");
        assert!(!paper.is_simulated());
        assert_eq!(paper.sync().expect("sync"), SyncMethod::Trigger);
        let camera = paper.camera_settings().expect("camera");
        assert_eq!(camera.trigger, TriggerMode::Hardware("Line1".into()));
        let timing = paper.trigger_timing().expect("timing").expect("triggered");
        assert_eq!(timing.scan_rate, Hertz(5000.0));
        assert_eq!(timing.frame_rate, Hertz(50.0));
        assert_eq!(timing.delay, Microseconds(19.12));
        assert!(
            !paper.limits().expect("limits").manual_y,
            "a Modbus y stage"
        );
        // The camera trigger's keys without the trigger, and the trigger without a DAQ: refused,
        // naming the key.
        let e = RigConfig::parse(
            &PAPER.replace("trigger = \"daq\"", "trigger = \"free-run\""),
            "r.toml",
        )
        .expect("parses")
        .sync()
        .expect_err("trigger keys without the trigger");
        assert!(e.to_string().contains("camera.trigger_line"), "{e}");
        let sim = RigConfig::parse("sync = \"trigger\"\n", "r.toml")
            .expect("parses")
            .sync()
            .expect_err("a free-running camera");
        assert!(
            sim.to_string().contains("`camera.trigger` = \"daq\""),
            "{sim}"
        );
        let netft = RigConfig::parse(
            "[sim]\nforce_path = \"netft\"\n[camera]\ntrigger = \"daq\"\n",
            "r.toml",
        )
        .expect("parses")
        .sync()
        .expect_err("no DAQ to trigger from");
        assert!(
            netft.to_string().contains("force_path = \"daq\""),
            "{netft}"
        );
        let sim = RigConfig::parse("[camera]\ntrigger = \"daq\"\n", "r.toml").expect("sim");
        assert_eq!(sim.sync().expect("sync"), SyncMethod::Trigger);
        assert_eq!(
            sim.trigger_timing()
                .expect("timing")
                .expect("triggered")
                .delay,
            Microseconds(sim_trigger_delay_us())
        );
    }

    #[test]
    fn errors_name_the_file_the_key_and_what_is_allowed() {
        let e = RigConfig::parse("[z]\nvelocity = 2000\n", "rig.toml").expect_err("too fast");
        assert!(
            e.to_string()
                .contains("key `z.velocity` = 2000: more than a simulated KST101"),
            "{e}"
        );
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
        assert!(
            e.to_string().contains("strobe, trigger, clock-fit or host"),
            "{e}"
        );
        let e = RigConfig::parse("[camera]\ndriver = \"aravis\"\n", "rig.toml").expect_err("mixed");
        assert!(
            e.to_string().contains("x, y, z, force are simulated"),
            "{e}"
        );
        RigConfig::parse("[sim]\nforce_path = \"netft\"\n", "rig.toml").expect("netft sim");
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
    fn ageing_keys_are_checked_when_the_file_is_read() {
        let good = "[sim]\nsession = 3\n[sim.ageing]\nfringe_value_pct = 10.0\nleds_out = [2]\n\
                    camera_shift_px = [5.0, -2.0]\nft_offset_n = [0.0, 0.0, 1.5]\n\
                    [[sim.ageing.scratches]]\nfrom_mm = [-4.0, 2.0]\nto_mm = [6.0, 5.0]\n";
        let c = RigConfig::parse(good, "rig.toml").expect("valid ageing");
        assert_eq!(c.file.sim.session, 3);
        let a = &c.file.sim.ageing;
        assert_eq!(a.fringe_value_pct, 10.0);
        assert_eq!(a.leds_out, vec![2]);
        assert_eq!(a.scratches.len(), 1);
        assert_eq!(a.scratches[0].width_mm, 0.3, "default width");
        assert_eq!(a.modulus_pct, 0.0, "default: no change");
        for (text, expected) in [
            (
                "[sim.ageing]\nfringe_pct = 10.0\n",
                vec!["rig.toml", "fringe_pct", "fringe_value_pct"],
            ),
            (
                "[sim.ageing]\nled_dimming_pct = 120.0\n",
                vec!["rig.toml: key `sim.ageing.led_dimming_pct` = 120.0", "0..=100"],
            ),
            (
                "[sim.ageing]\ncamera_rotation_deg = inf\n",
                vec!["sim.ageing.camera_rotation_deg", "-180..=180"],
            ),
            (
                "[sim.ageing]\nft_offset_n = [0.0, 0.0]\n",
                vec!["rig.toml", "ft_offset_n"],
            ),
            (
                "[[sim.ageing.scratches]]\nfrom_mm = [0.0, 0.0]\nto_mm = [1.0, 0.0]\nwidth_mm = 0.0\n",
                vec!["sim.ageing.scratches[0].width_mm", "(0, 5]"],
            ),
            (
                "[[sim.ageing.scratches]]\nfrom_mm = [0.0, 0.0]\n",
                vec!["rig.toml", "to_mm"],
            ),
        ] {
            let e = RigConfig::parse(text, "rig.toml")
                .expect_err(text)
                .to_string();
            for part in expected {
                assert!(e.contains(part), "{text}: {e} lacks {part}");
            }
        }
    }

    #[test]
    fn no_rig_file_means_the_simulated_bench() {
        let c = RigConfig::simulated();
        assert!(c.is_simulated());
        assert_eq!(c.sync().expect("sync"), SyncMethod::Strobe);
        assert_eq!(
            c.sensor_id().expect("id"),
            fringe_sim::SensorConfig::layered().id
        );
    }
}
