//! The whole simulated bench, wired to the real drivers: what `fringe` uses when no hardware is
//! configured.
//!
//! One [`Bench`] (stage motors, contact, F/T physics) is shared by the emulated devices; each
//! emulator speaks its real protocol to the real driver over an in-process link (no sockets), so a
//! simulated run exercises the same driver code as the bench:
//!
//! - x and z: emulated KST101 controllers with ZFS25 actuators <-> `ThorlabsAxis`;
//! - y: an emulated Modbus drive (built-in register map) <-> `ModbusStage`;
//! - force: the simulated Mini40 through a simulated DAQ (gauge voltages via the inverse of a
//!   `.cal` matrix, 5 kHz, with the camera's exposure strobe on a spare channel) <->
//!   `CalibratedSensor` (the `.cal` math), or an emulated Net F/T box <-> the `NetFt` driver;
//! - camera: the simulated camera rendering photoelastic frames with the sensor's renderer.
//!
//! [`SimServe`] exposes the same emulators on pseudo-terminals and loopback sockets for
//! third-party software (`fringe sim serve`).

use crate::ageing::Ageing;
use crate::bench::{AxisConfig, Bench, BenchConfig};
use crate::emulators::apt_emulator::{AptEmulator, AptEmulatorConfig, AptEmulatorHandle};
use crate::emulators::camera_emulator::{
    ExposureSchedule, SimCamera, SimCameraConfig, TriggerInput,
};
use crate::emulators::daq_emulator::{SimDaq, SimDaqConfig};
use crate::emulators::modbus_emulator::ModbusEmulator;
use crate::emulators::netft_emulator::{NetFtEmulator, NetFtEmulatorConfig};
use crate::faults::{
    FaultDevice, FaultKind, FaultSpec, FaultTrigger, Faults, FaultyCamera, FaultyDatagrams,
    FaultyForce, FaultyLink,
};
use crate::ground_truth::records::TruthSink;
use crate::optics::render::Renderer;
use crate::optics::sensor::SensorConfig;
use crate::physics::ft_sensor::SimFtSensor;
use crate::physics::motion::SimMotor;
use crate::scene::{LoadSource, SceneSource};
use crate::session::salted;
use fringe_rig::atical::{CalibratedSensor, Calibration};
use fringe_rig::byte_pair;
use fringe_rig::Camera;
use fringe_rig::ConfigError;
use fringe_rig::Devices;
use fringe_rig::ForceSensor;
use fringe_rig::{apt::Actuator, ThorlabsAxis};
use fringe_rig::{AptConfig, Controller};
use fringe_rig::{Framing, ModbusStage, RegisterMap, StageOptions};
use fringe_rig::{Hertz, Millimetres, MillimetresPerSecond, MillimetresPerSecondSquared, Volts};
use fringe_rig::{NetFt, NetFtOptions};
use std::net::SocketAddr;
use std::sync::Arc;

/// The `.cal` file of the simulated Mini40 (a constructed calibration, not a real sensor's).
/// The simulated camera's trigger input wired to the DAQ's counter output.
pub(crate) const CAMERA_TRIGGER_LINE: &str = "Line1";

pub const SIM_CAL: &str = include_str!("../sim-data/sim-mini40.cal");

/// Which path the force takes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize, Default)]
#[serde(rename_all = "kebab-case")]
pub enum ForcePath {
    /// DAQ + `.cal` at 5 kHz with the exposure strobe recorded beside the gauges (the reference
    /// bench's wiring, and the one that allows `strobe` synchronisation).
    #[default]
    Daq,
    /// An ATI Net F/T box over RDT (no strobe channel).
    Netft,
}

/// Everything that makes a simulated rig.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SimRigConfig {
    /// Seeds every random part of the bench (surface, F/T noise and bias, camera drops and
    /// jitter) so a run is reproducible; the sensor build's own seed (its file's `seed`) fixes
    /// its residual birefringence and image noise.
    pub seed: u64,
    /// The sensor build under the camera.
    pub sensor: SensorConfig,
    pub bench: BenchConfig,
    pub camera: SimCameraConfig,
    pub force_path: ForcePath,
    pub daq: SimDaqConfig,
    /// The camera triggered by the DAQ's counter at this frame rate (Hz), its trigger input
    /// ([`CAMERA_TRIGGER_LINE`]) wired to the counter's output; free run when `None`.
    pub camera_trigger: Option<f64>,
    /// Register map of the emulated y drive (built-in name or file).
    pub y_map: String,
    /// Faults to inject (none on a normal bench): see [`crate::faults`].
    pub faults: Vec<FaultSpec>,
    /// Session of this bench (default 0): another session films and measures the same unit with
    /// other noise ([`crate::session`]).
    pub session: u64,
    /// What changed in the unit since it was accepted (default nothing): see [`crate::ageing`].
    /// Applied to `sensor` and `bench` when the bench is built ([`SimRigConfig::as_built`]).
    pub ageing: Ageing,
}

impl Default for SimRigConfig {
    /// The reference bench: ZFS25 axes (25 mm) on x and z, a 50 mm Modbus RTU y stage (Leadshine
    /// PR map), a layered
    /// sensor, DAQ + strobe, camera at 50 Hz.
    fn default() -> Self {
        let mut bench = BenchConfig::default();
        let zfs25 = AxisConfig {
            travel_mm: 25.0,
            power_up_mm: 8.0,
            velocity_mm_s: 2.0,
            acceleration_mm_s2: 4.0,
        };
        bench.x = zfs25;
        bench.z = AxisConfig {
            power_up_mm: 3.0,
            ..zfs25
        };
        bench.geometry.x_centre_mm = 12.5;
        SimRigConfig {
            seed: 1,
            sensor: SensorConfig::layered(),
            bench,
            camera: SimCameraConfig::default(),
            force_path: ForcePath::Daq,
            daq: SimDaqConfig::default(),
            camera_trigger: None,
            y_map: "leadshine-pr".into(),
            faults: Vec::new(),
            session: 0,
            ageing: Ageing::default(),
        }
    }
}

impl SimRigConfig {
    /// The configuration with the master seed spread over every seeded part of the bench. The
    /// sensor keeps its own seed: it is part of the build its file describes (residual
    /// birefringence, noise, drift), so the bench films the same sensor build that
    /// `fringe sim render` and `fringe sim dataset` render, whatever the bench's seed.
    ///
    /// The session salts the seeds of what differs between sessions on a real bench
    /// ([`crate::session`]): camera drops, jitter and latch delays, DAQ jitter and the F/T noise;
    /// the surface and the F/T power-up bias keep the master seed's (the renderer and the stage
    /// controllers get the session where they are built). Session 0 salts nothing.
    pub fn seeded(&self) -> SimRigConfig {
        let mut c = self.clone();
        let s = self.seed;
        c.bench.seed = s;
        c.bench.ft_noise.seed = s.wrapping_add(1);
        c.bench.ft_noise.session = self.session;
        c.camera.seed = salted(s.wrapping_add(2), self.session);
        c.daq.seed = salted(s.wrapping_add(4), self.session);
        c
    }

    /// The bench as it is built: [`SimRigConfig::seeded`], then the unit's ageing applied to the
    /// sensor build and the bench ([`Ageing::apply_to_sensor`], [`Ageing::apply_to_bench`]). The
    /// result keeps `ageing` as a record of what was applied; do not apply it again.
    pub fn as_built(&self) -> Result<SimRigConfig, SimRigError> {
        self.ageing
            .check_for(&self.sensor)
            .map_err(|e| device_error("sensor", e))?;
        let mut c = self.seeded();
        self.ageing.apply_to_sensor(&mut c.sensor);
        self.ageing.apply_to_bench(&mut c.bench);
        // The gel's friction is the sensor unit's.
        c.bench.material.friction = c.sensor.surface.friction();
        Ok(c)
    }

    /// The driver configuration of the x or z axis (the emulated controller matches it).
    pub fn apt_config(&self, axis: &str) -> AptConfig {
        let k = if axis == "z" {
            &self.bench.z
        } else {
            &self.bench.x
        };
        let actuator = Actuator::by_name("ZFS25").unwrap_or(fringe_rig::apt::ACTUATORS[0]);
        let mut c = AptConfig::new(axis, Controller::Kst101, actuator);
        c.velocity = MillimetresPerSecond(k.velocity_mm_s);
        c.acceleration = MillimetresPerSecondSquared(k.acceleration_mm_s2);
        c.home.velocity = MillimetresPerSecond(k.velocity_mm_s);
        c.soft_limits =
            fringe_rig::SoftLimits::new(Millimetres(0.0), Millimetres(k.travel_mm)).ok();
        c
    }
}

/// Errors while building the simulated rig.
#[derive(Debug, thiserror::Error)]
pub enum SimRigError {
    #[error(transparent)]
    Config(#[from] ConfigError),
    #[error("simulated {device}: {message}")]
    Device { device: String, message: String },
}

fn device_error(device: &str, e: impl std::fmt::Display) -> SimRigError {
    SimRigError::Device {
        device: device.to_string(),
        message: e.to_string(),
    }
}

/// A running simulated rig: the bench and its emulators (stopped when dropped).
pub struct SimRig {
    pub config: SimRigConfig,
    pub bench: Arc<Bench>,
    _apt: Vec<AptEmulatorHandle>,
    _modbus: ModbusEmulator,
    _netft: Option<NetFtEmulator>,
}

impl SimRig {
    /// Builds the bench and its emulators and connects the real drivers to them.
    /// `truth` receives the ground truth (exposures, clocks, F/T bias) if given. The running
    /// rig's `config` is the bench as built ([`SimRigConfig::as_built`]: seeds spread, the unit's
    /// ageing applied): what the bench really is.
    pub fn start(
        config: &SimRigConfig,
        truth: Option<Arc<dyn TruthSink>>,
    ) -> Result<(SimRig, Devices), SimRigError> {
        let config = config.as_built()?;
        let bench = Bench::new(config.bench.clone());
        let mut description = Vec::new();
        check_faults(&config)?;
        let wiring = Wiring {
            config: &config,
            bench: &bench,
            truth: truth.as_ref(),
        };
        let (apt_x, x) = wiring.apt_axis("x", bench.motor_x(), FaultDevice::X, &mut description)?;
        let (apt_z, z) = wiring.apt_axis("z", bench.motor_z(), FaultDevice::Z, &mut description)?;
        let (modbus, y) = wiring.y_stage(&mut description)?;
        let schedule = ExposureSchedule::new();
        let (force, netft, trigger) = wiring.force(&schedule, &mut description)?;
        let mut camera = wiring.camera(schedule, &mut description)?;
        if let Some(line) = trigger {
            camera = camera.with_trigger_input(CAMERA_TRIGGER_LINE, line);
        }
        let force = wiring.force_with_faults(force);
        let camera = wiring.camera_with_faults(camera);
        description.extend(config.faults.iter().map(fault_description));
        let devices = Devices {
            x: Box::new(x),
            y: Box::new(y),
            z: Box::new(z),
            force,
            camera,
            description,
        };
        Ok((
            SimRig {
                config,
                bench,
                _apt: vec![apt_x, apt_z],
                _modbus: modbus,
                _netft: netft,
            },
            devices,
        ))
    }
}

/// Refuses faults that are malformed or that need the Net F/T force path on the DAQ's.
fn check_faults(config: &SimRigConfig) -> Result<(), SimRigError> {
    for f in &config.faults {
        f.check().map_err(|e| device_error(f.device.name(), e))?;
        if f.while_streaming && config.force_path == ForcePath::Daq {
            return Err(device_error(
                "force",
                "while_streaming watches the Net F/T's stream: it needs sim.force_path = \"netft\"",
            ));
        }
        let netft_only = matches!(f.fault, FaultKind::Loss | FaultKind::Reboot);
        if netft_only && config.force_path == ForcePath::Daq {
            let name = if f.fault == FaultKind::Loss {
                "loss"
            } else {
                "reboot"
            };
            return Err(device_error(
                "force",
                format!("fault `{name}` needs the Net F/T force path (sim.force_path = \"netft\")"),
            ));
        }
    }
    Ok(())
}

/// The line of the rig's description naming an injected fault.
fn fault_description(f: &FaultSpec) -> String {
    format!(
        "injected fault: {} {:?} after {} s{}{}",
        f.device.name(),
        f.fault,
        f.after,
        if f.while_moving { ", while moving" } else { "" },
        f.duration
            .map(|d| format!(", for {d} s"))
            .unwrap_or_default()
    )
}

/// What the simulated devices are wired from: the configuration, the bench they share and where
/// the ground truth goes.
struct Wiring<'a> {
    config: &'a SimRigConfig,
    bench: &'a Arc<Bench>,
    truth: Option<&'a Arc<dyn TruthSink>>,
}

impl Wiring<'_> {
    /// The faults configured on `device`, their clocks starting now.
    fn faults_on(&self, device: FaultDevice) -> Faults {
        let motor = match device {
            FaultDevice::X => Some(self.bench.motor_x()),
            FaultDevice::Y => Some(self.bench.motor_y()),
            FaultDevice::Z => Some(self.bench.motor_z()),
            FaultDevice::Force | FaultDevice::Camera => None,
        };
        Faults::new(
            self.config
                .faults
                .iter()
                .filter(|f| f.device == device)
                .map(|f| FaultTrigger::new(f.clone(), motor.clone()))
                .collect(),
        )
    }

    /// The x or z axis (`name`): an emulated KST101 driving `motor`, and the real driver
    /// connected to it through the axis's faults.
    fn apt_axis(
        &self,
        name: &str,
        motor: Arc<SimMotor>,
        device: FaultDevice,
        description: &mut Vec<String>,
    ) -> Result<(AptEmulatorHandle, ThorlabsAxis), SimRigError> {
        let driver_config = self.config.apt_config(name);
        let mut emulator_config = AptEmulatorConfig::matching(&driver_config)
            .ok_or_else(|| device_error(name, "no emulated controller for this configuration"))?;
        emulator_config.jitter_seed = salted(emulator_config.jitter_seed, self.config.session);
        let (host, link) = byte_pair(&format!("apt-{name}"), &format!("emulated KST101 {name}"));
        let emulator = AptEmulator::spawn(emulator_config, motor, Box::new(link))
            .map_err(|e| device_error(name, e))?;
        let host = FaultyLink::new(host, self.faults_on(device));
        let axis = ThorlabsAxis::connect(Box::new(host), driver_config)
            .map_err(|e| device_error(name, e))?;
        description.push(format!(
            "{name}: Thorlabs KST101 + ZFS25 (emulated, in process)"
        ));
        Ok((emulator, axis))
    }

    /// The y axis: an emulated Modbus RTU drive with the configured register map, and the real
    /// stage driver connected to it through the axis's faults.
    fn y_stage(
        &self,
        description: &mut Vec<String>,
    ) -> Result<(ModbusEmulator, ModbusStage), SimRigError> {
        let config = self.config;
        let map = RegisterMap::load(&config.y_map).map_err(|e| device_error("y", e))?;
        let (modbus, link) =
            ModbusEmulator::spawn_in_process(map.clone(), self.bench.motor_y(), Framing::Rtu)
                .map_err(|e| device_error("y", e))?;
        let y_limits =
            fringe_rig::SoftLimits::new(Millimetres(0.0), Millimetres(config.bench.y.travel_mm))
                .ok();
        let y = ModbusStage::new(
            "y",
            Box::new(FaultyLink::new(link, self.faults_on(FaultDevice::Y))),
            Framing::Rtu,
            map,
            StageOptions {
                limits: y_limits,
                ..StageOptions::default()
            },
        );
        description.push(format!(
            "y: Modbus RTU drive, map {} (emulated, in process)",
            config.y_map
        ));
        Ok((modbus, y))
    }

    /// The force sensor on the configured path: the simulated Mini40 through the DAQ (strobed
    /// by `schedule`, its counter triggering the camera when asked: its output is returned) and
    /// the `.cal` math, or through an emulated Net F/T box (returned too, to keep it running) and
    /// its driver, with the force faults on its UDP link.
    #[allow(clippy::type_complexity)]
    fn force(
        &self,
        schedule: &Arc<ExposureSchedule>,
        description: &mut Vec<String>,
    ) -> Result<
        (
            Box<dyn ForceSensor>,
            Option<NetFtEmulator>,
            Option<Arc<dyn TriggerInput>>,
        ),
        SimRigError,
    > {
        let load: Arc<dyn LoadSource> = self.bench.clone();
        let mut ft = SimFtSensor::new(load, self.config.bench.ft_noise);
        if let Some(t) = self.truth {
            ft = ft.with_truth(t.clone());
        }
        match self.config.force_path {
            ForcePath::Daq => {
                let cal = Calibration::parse(SIM_CAL, "simulated Mini40 (built-in .cal)")
                    .map_err(|e| device_error("force", e))?;
                let mut daq = SimDaq::new(self.config.daq.clone(), &cal, Box::new(ft))
                    .map_err(|e| device_error("force", e))?
                    .with_strobe(schedule.clone());
                if let Some(t) = self.truth {
                    daq = daq.with_truth(t.clone());
                }
                description.push(
                    "force: Mini40 through a 5 kHz NI-DAQmx DAQ with the exposure strobe (simulated USB-6218, the real driver)".into(),
                );
                let mut trigger = None;
                if let Some(rate) = self.config.camera_trigger {
                    daq = daq.with_camera_trigger(Hertz(rate));
                    trigger = Some(daq.trigger_line());
                    description.push(format!(
                        "camera trigger: the DAQ's ctr0 at {rate} Hz on PFI12, wired to the camera's {CAMERA_TRIGGER_LINE}"
                    ));
                }
                let range = Volts(self.config.daq.range_v);
                let sensor = CalibratedSensor::new(daq, cal).with_saturation(range);
                Ok((Box::new(sensor), None, trigger))
            }
            ForcePath::Netft => {
                let emulator_config = NetFtEmulatorConfig::default();
                let driver_config = emulator_config
                    .driver_config()
                    .map_err(|e| device_error("force", e))?;
                let (emulator, link) =
                    NetFtEmulator::spawn_in_process(emulator_config, Box::new(ft))
                        .map_err(|e| device_error("force", e))?;
                let link = FaultyDatagrams::new(link, self.faults_on(FaultDevice::Force))
                    .with_power_switch(emulator.power_switch());
                description.push("force: Net F/T (emulated, in process)".into());
                let driver = NetFt::new(link, driver_config, NetFtOptions::default());
                if self.config.camera_trigger.is_some() {
                    return Err(device_error(
                        "camera trigger",
                        "a Net F/T has no counter to trigger the camera: use the DAQ force path",
                    ));
                }
                Ok((Box::new(driver), Some(emulator), None))
            }
        }
    }

    /// The simulated camera filming the sensor build on the bench, exposing on `schedule`.
    fn camera(
        &self,
        schedule: Arc<ExposureSchedule>,
        description: &mut Vec<String>,
    ) -> Result<SimCamera, SimRigError> {
        let config = self.config;
        let mut renderer =
            Renderer::new(config.sensor.clone()).map_err(|e| device_error("camera", e))?;
        renderer.set_session(config.session);
        let scene: Arc<dyn SceneSource> = self.bench.clone();
        let mut camera = SimCamera::new(config.camera.clone(), scene, Box::new(renderer))
            .with_schedule(schedule);
        if let Some(t) = self.truth {
            camera = camera.with_truth(t.clone());
        }
        description.push(format!(
            "camera: simulated {}x{} (frame rate as the camera is configured), sensor {} ({})",
            config.sensor.geometry.width,
            config.sensor.geometry.height,
            config.sensor.id,
            config.sensor.variant.name()
        ));
        Ok(camera)
    }

    /// `force` with the force faults, when on the DAQ path (over a Net F/T they act on its UDP
    /// link: [`Wiring::force`]).
    fn force_with_faults(&self, force: Box<dyn ForceSensor>) -> Box<dyn ForceSensor> {
        let force_faults = match self.config.force_path {
            ForcePath::Netft => Faults::default(),
            ForcePath::Daq => self.faults_on(FaultDevice::Force),
        };
        if force_faults.is_empty() {
            force
        } else {
            Box::new(FaultyForce::new(force, force_faults))
        }
    }

    /// `camera` with the camera faults, if any.
    fn camera_with_faults(&self, camera: SimCamera) -> Box<dyn Camera> {
        let camera_faults = self.faults_on(FaultDevice::Camera);
        if camera_faults.is_empty() {
            Box::new(camera)
        } else {
            Box::new(FaultyCamera::new(Box::new(camera), camera_faults))
        }
    }
}

/// Where `fringe sim serve` put each emulated device.
#[derive(Debug, Clone, PartialEq)]
pub struct ServeEndpoints {
    pub apt_x: String,
    pub apt_z: String,
    pub netft: SocketAddr,
    pub netft_http: Option<String>,
    pub modbus_tcp: SocketAddr,
    pub modbus_rtu: Option<String>,
}

/// The simulated bench exposed on pseudo-terminals and loopback sockets.
pub struct SimServe {
    pub bench: Arc<Bench>,
    pub endpoints: ServeEndpoints,
    _apt: Vec<AptEmulatorHandle>,
    _netft: NetFtEmulator,
    _modbus: Vec<ModbusEmulator>,
}

impl SimServe {
    /// Starts the emulators: APT x and z on new pseudo-terminals, the Net F/T on `netft`
    /// (UDP, HTTP on an ephemeral port of the same address), Modbus TCP on `modbus` and Modbus RTU
    /// on a new pseudo-terminal.
    pub fn start(
        config: &SimRigConfig,
        netft: SocketAddr,
        modbus: SocketAddr,
    ) -> Result<SimServe, SimRigError> {
        let config = config.as_built()?;
        let bench = Bench::new(config.bench.clone());
        let mut apt = Vec::new();
        let mut paths = Vec::new();
        for (name, motor) in [("x", bench.motor_x()), ("z", bench.motor_z())] {
            let mut emulator_config = AptEmulatorConfig::matching(&config.apt_config(name))
                .ok_or_else(|| {
                    device_error(name, "no emulated controller for this configuration")
                })?;
            emulator_config.jitter_seed = salted(emulator_config.jitter_seed, config.session);
            let handle = AptEmulator::spawn_pty(emulator_config, motor)
                .map_err(|e| device_error(name, e))?;
            paths.push(handle.slave_path().unwrap_or_default().to_string());
            apt.push(handle);
        }
        let load: Arc<dyn LoadSource> = bench.clone();
        let ft = SimFtSensor::new(load, config.bench.ft_noise);
        let netft =
            NetFtEmulator::spawn_udp(netft, None, NetFtEmulatorConfig::default(), Box::new(ft))
                .map_err(|e| device_error("netft", e))?;
        let map = RegisterMap::load(&config.y_map).map_err(|e| device_error("y", e))?;
        let tcp = ModbusEmulator::spawn_tcp(modbus, map.clone(), bench.motor_y())
            .map_err(|e| device_error("y", e))?;
        let rtu = ModbusEmulator::spawn_rtu_pty(map, bench.motor_y())
            .map_err(|e| device_error("y", e))?;
        let endpoints = ServeEndpoints {
            apt_x: paths[0].clone(),
            apt_z: paths[1].clone(),
            netft: netft
                .addr()
                .ok_or_else(|| device_error("netft", "no UDP address"))?,
            netft_http: netft.http_url(),
            modbus_tcp: tcp
                .addr()
                .ok_or_else(|| device_error("y", "no TCP address"))?,
            modbus_rtu: rtu.pty_path().map(str::to_string),
        };
        Ok(SimServe {
            bench,
            endpoints,
            _apt: apt,
            _netft: netft,
            _modbus: vec![tcp, rtu],
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_bench_films_the_sensor_build_its_file_describes_whatever_its_seed() {
        let mut config = SimRigConfig::default();
        for seed in [1, 2, 977] {
            config.seed = seed;
            let seeded = config.seeded();
            assert_eq!(seeded.sensor, config.sensor, "seed {seed}");
            assert_eq!(seeded.camera.seed, seed.wrapping_add(2));
        }
    }

    #[test]
    fn sessions_salt_only_the_seeds_of_what_differs_between_sessions() {
        let config = SimRigConfig {
            seed: 5,
            ..SimRigConfig::default()
        };
        let zero = config.seeded();
        assert_eq!(
            (zero.camera.seed, zero.daq.seed, zero.bench.ft_noise.seed),
            (7, 9, 6)
        );
        assert_eq!(zero.bench.ft_noise.session, 0);
        let three = SimRigConfig {
            session: 3,
            ..config.clone()
        }
        .seeded();
        assert_eq!(three.bench.seed, zero.bench.seed);
        assert_eq!(three.bench.ft_noise.seed, zero.bench.ft_noise.seed);
        assert_eq!(three.bench.ft_noise.session, 3);
        assert_eq!(three.sensor, zero.sensor);
        assert_ne!(three.camera.seed, zero.camera.seed);
        assert_ne!(three.daq.seed, zero.daq.seed);
    }

    /// The ageing reaches the running bench: its configuration is the aged unit and the F/T
    /// sensor's recorded bias carries the shifted zero.
    #[test]
    fn a_started_rig_films_and_measures_the_aged_unit() {
        let mut config = SimRigConfig::default();
        let s = &mut config.sensor;
        s.geometry.width = 320;
        s.geometry.height = 200;
        s.geometry.disc_radius_px = 90.0;
        s.geometry.px_per_mm = 3.0;
        s.field.cells = 64;
        s.field.cell_mm = 1.2;
        let bias_of = |config: &SimRigConfig| {
            let log = crate::ground_truth::records::TruthLog::new();
            let (rig, _devices) = SimRig::start(config, Some(log.clone())).expect("sim rig");
            let bias = log.records().into_iter().find_map(|r| match r {
                crate::ground_truth::records::TruthRecord::FtBias { bias, .. } => Some(bias),
                _ => None,
            });
            (rig.config.clone(), bias.expect("an ft_bias record"))
        };
        let (plain, plain_bias) = bias_of(&config);
        assert_eq!(plain.sensor, config.sensor);
        config.ageing = Ageing {
            camera_shift_px: [5.0, 0.0],
            led_dimming_pct: 10.0,
            ft_offset_n: [0.0, 0.0, 2.0],
            ..Ageing::default()
        };
        let (aged, aged_bias) = bias_of(&config);
        let shifted =
            aged.sensor.geometry.centre_offset_px[0] - plain.sensor.geometry.centre_offset_px[0];
        assert_eq!(shifted, 5.0);
        assert!(
            (aged.sensor.optics.illumination_dn - 0.9 * plain.sensor.optics.illumination_dn).abs()
                < 1e-9
        );
        assert!((aged_bias.fz.0 - plain_bias.fz.0 - 2.0).abs() < 1e-12);
        config.ageing.leds_out = vec![12];
        let e = SimRig::start(&config, None).err().expect("LED 12 of 12");
        assert!(e.to_string().contains("sim.ageing.leds_out"), "{e}");
    }
}
