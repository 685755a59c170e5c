//! `fringe-sim`: the simulated bench over `fringe-rig`: physics, rendering, device emulators that
//! speak the real protocols, ground truth and its scores. It depends on the rig crate, never the
//! reverse: the rig's drivers talk to these emulators exactly as to the real devices.
//!
//! The simulated bench as a whole, at the top:
//! - `rig`: the whole simulated bench wired to the real drivers (what `fringe` uses when no
//!   hardware is configured).
//! - `bench`: the physical bench (motors, indenter, contact) behind the scene traits.
//! - `scene`: the traits that connect the bench, the emulated devices and the renderer.
//! - `session`: repeated sessions of the same bench (a rig file's `[sim] session`): other noise,
//!   the same unit.
//! - `ageing`: what changed in a unit since it was accepted (a rig file's `[sim.ageing]`).
//! - `faults`: faults injected on purpose into the simulated devices (a rig file's
//!   `[[sim.faults]]`).
//! - [`dataset`]: synthetic training frames (scene and F/T-style label) drawn per frame from a
//!   seed, rendered without motion by `fringe sim dataset`.
//!
//! `physics`: what moves and what presses.
//! - `physics::stress`: Boussinesq point-load stress integrated through the photoelastic layer.
//! - `physics::indenter`: indenter outlines and their contact pressure maps.
//! - `physics::contact`: force against indentation depth in the soft layer, relaxation, surface
//!   height.
//! - `physics::motion`: simulated axes with trapezoidal motion profiles in host time.
//! - `physics::ft_config`: the F/T sensor's mount and imperfections (configuration).
//! - `physics::ft_sensor`: the F/T sensor's moments, noise, drift and power-up bias.
//!
//! `optics`: what the camera sees.
//! - `optics::sensor`: one sensor build (layer, optics, artefacts, image geometry) from a TOML
//!   file, and the exact sensor-frame mm <-> image px map.
//! - `optics::fringe_field`: fringe order per newton around an indenter (FFT convolution).
//! - `optics::colour`: the colour a white LED and an RGB camera give for each fringe order.
//! - `optics::blurred_colour`: that colour averaged over a spread of fringe orders (defocus).
//! - `optics::background`: the unloaded sensor image (illumination, rim, LED hot spots, residual
//!   birefringence).
//! - `optics::scratch`: a scratch on the contact surface (sensor file `[[surface.scratches]]`);
//!   `optics::scratch_canvas` draws it into the unloaded background.
//! - `optics::render`: the frame renderer (fringes, blur, noise, drift, gamma) behind
//!   `FrameRenderer`.
//! - `optics::pixel_format`: the camera's pixel formats (RGB8, BayerRG8, Mono8) as samples of the
//!   rendered RGB image.
//!
//! `emulators`: the devices, speaking their real protocols.
//! - `emulators::apt_emulator`: an emulated Thorlabs APT stepper controller (KST101 / BSC20x
//!   channel) on a byte link, driving a [`SimMotor`].
//! - `emulators::modbus_emulator`: an emulated Modbus y stage (TCP, RTU on a pty, in process)
//!   from a register map.
//! - `emulators::netft_emulator`: an emulated ATI Net F/T box (RDT over UDP or in process,
//!   netftapi2.xml).
//! - `emulators::netft_box`: that box on loopback UDP with its HTTP configuration page, for tests
//!   and benchmarks.
//! - `emulators::camera_emulator`: the simulated camera (device clock, exposures, drops, latch).
//! - `emulators::daq_emulator`: a simulated DAQ: gauge voltages through a `.cal` matrix plus the
//!   strobe.
//! - `emulators::daqmx_library`: a simulated NI-DAQmx library (NI's C functions over simulated
//!   devices).
//!
//! [`ground_truth`]: what really happened, and the scores against it.
//! - `ground_truth::records`: the true state of a simulated run, in memory or as JSON lines.
//! - `ground_truth::truth_spool`: ground truth held until the run filming it takes it (after
//!   every point).
//! - `ground_truth::label_score`: a simulated run's labels scored against the ground truth.
//! - `ground_truth::sync_score`: the three synchronisation methods run side by side on one
//!   simulated bench and scored against the ground truth.
//!
//! Formulas, parameters and what is not simulated: docs/photoelastic-sim.md.
//!
//! The surface is curated: every module is private except two namespaces, and what other
//! crates use is re-exported here at the root: the simulated rig ([`SimRig`], [`SimRigConfig`])
//! and bench ([`Bench`], [`BenchConfig`]), the emulators and their configurations, the renderer
//! and the scene traits, the sensor file ([`SensorConfig`]), faults, ageing. The two public
//! modules are namespaces whose names only read well with theirs: [`dataset`] (the synthetic
//! frames of `fringe sim dataset`: `dataset::frame`, `dataset::SHAPES`) and [`ground_truth`]
//! (the truth file and the scores against it: `ground_truth::read_frames`,
//! `ground_truth::score_labels`, `ground_truth::run_sync_bench`; its records and spool are at the
//! root). Every type the public API hands out is re-exported too, so all of it can be named
//! (`unnameable_types` is warned). Inside this crate, files import from the defining module, never through these
//! re-exports.
#![warn(unreachable_pub)]
#![warn(unnameable_types)]

mod ageing;
mod bench;
pub mod dataset;
mod emulators;
mod faults;
pub mod ground_truth;
mod optics;
mod physics;
mod rig;
mod robot;
mod scene;
mod session;
#[cfg(test)]
mod test_support;

pub use ageing::{Ageing, AgeingError};
pub use bench::{
    AxisConfig, Bench, BenchConfig, BenchGeometry, BenchTruth, IndenterTip, MountedIndenter,
};
pub use emulators::apt_emulator::core::{EmulatorCounters, UpdateMessage};
pub use emulators::apt_emulator::server::EmulatorError;
pub use emulators::apt_emulator::{AptEmulator, AptEmulatorConfig, AptEmulatorHandle, KeepAlive};
pub use emulators::camera_emulator::camera::SimCameraStats;
pub use emulators::camera_emulator::timing::{DeviceClock, ExposureWindow, TriggerInput};
pub use emulators::camera_emulator::{ExposureSchedule, SimCamera, SimCameraConfig, FRAME_MEMORY};
pub use emulators::daq_emulator::{DaqClock, DaqClockHandle, SimDaq, SimDaqConfig};
pub use emulators::daqmx_library::c_api::{
    device as daqmx_device, install as install_daqmx_device, lookup as lookup_daqmx_symbol,
};
pub use emulators::daqmx_library::device::PulseTrain;
pub use emulators::daqmx_library::{DaqSignals, DeviceModel, DeviceTiming, SimDevice};
pub use emulators::modbus_emulator::core::{decode_request_pdu, ModbusCore, ServerRequest};
pub use emulators::modbus_emulator::line_timing::RtuTiming;
pub use emulators::modbus_emulator::ModbusEmulator;
pub use emulators::netft_box::{SimHttp, SimNetFt, SimOptions, SimReport};
pub use emulators::netft_emulator::core::NetFtReport;
pub use emulators::netft_emulator::server::PowerSwitch;
pub use emulators::netft_emulator::{NetFtEmulator, NetFtEmulatorConfig};
pub use faults::{FaultDevice, FaultKind, FaultSpec, FaultTrigger, Faults, FaultyDatagrams};
pub use ground_truth::records::{TruthLog, TruthSink};
pub use ground_truth::truth_spool::TruthSpool;
pub use optics::render::Renderer;
pub use optics::scratch::{BadScratch, Scratch};
pub use optics::sensor::{
    FieldConfig, GeometryConfig, IndenterConfig, LayerConfig, LedConfig, NoiseConfig, OpticsConfig,
    SensorConfig, SensorConfigError, SensorGeometry, SurfaceFinish, Variant,
};
pub use physics::contact::{ContactGeometry, ContactMaterial, PronyTerm, SurfaceConfig};
pub use physics::friction::Friction;
pub use physics::ft_config::FtMount;
pub use physics::ft_sensor::{FtNoiseConfig, SimFtSensor};
pub use physics::indenter::Shape;
pub use physics::motion::{MotorSpec, MotorStatus, SimMotor};
pub use physics::stress::Layer;
pub use rig::{ForcePath, ServeEndpoints, SimRig, SimRigConfig, SimRigError, SimServe, SIM_CAL};
pub use robot::{Robot, RobotConfig, RobotError, RobotPress};
pub use scene::{Contact, ForceReading, FrameRenderer, LoadSource, Scene, SceneSource, Shear};
