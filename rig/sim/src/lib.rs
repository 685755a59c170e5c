//! `fringe-sim`: the simulated bench over `fringe-rig`: physics, rendering, device emulators that
//! speak the real protocols, ground truth and its scores. It depends on the rig crate, never the
//! reverse: the rig's drivers talk to these emulators exactly as to the real devices.
//!
//! - `stress`: Boussinesq point-load stress integrated through the photoelastic layer.
//! - [`indenter`]: indenter outlines and their contact pressure maps.
//! - [`fringe_field`]: fringe order per newton around an indenter (FFT convolution).
//! - [`colour`]: the colour a white LED and an RGB camera give for each fringe order.
//! - `blurred_colour`: that colour averaged over a spread of fringe orders (defocus).
//! - [`motion`]: simulated axes with trapezoidal motion profiles in host time.
//! - [`modbus_emulator`]: an emulated Modbus y stage (TCP, RTU on a pty, in process) from a register map.
//! - [`netft_emulator`]: an emulated ATI Net F/T box (RDT over UDP or in process, netftapi2.xml).
//! - [`netft_box`]: that box on loopback UDP with its HTTP configuration page, for tests and
//!   benchmarks.
//! - [`apt_emulator`]: an emulated Thorlabs APT stepper controller (KST101 / BSC20x channel) on a
//!   byte link, driving a [`motion::SimMotor`].
//! - [`contact`]: force against indentation depth in the soft layer, relaxation, surface height.
//! - `ft_config`: the F/T sensor's mount and imperfections (configuration).
//! - [`ft_sensor`]: the F/T sensor's moments, noise, drift and power-up bias.
//! - [`bench`]: the physical bench (motors, indenter, contact) behind the scene traits.
//! - [`camera_emulator`]: the simulated camera (device clock, exposures, drops, latch).
//! - [`daq_emulator`]: a simulated DAQ: gauge voltages through a `.cal` matrix plus the strobe.
//! - [`dataset`]: synthetic training frames (scene and F/T-style label) drawn per frame from a
//!   seed, rendered without motion by `fringe sim dataset`.
//! - [`ground_truth`]: the true state of a simulated run, in memory or as JSON lines.
//! - [`truth_spool`]: ground truth held until the run filming it takes it (after every point).
//! - [`label_score`]: a simulated run's labels scored against the ground truth.
//! - [`sync_score`]: the three synchronisation methods run side by side on one simulated bench
//!   and scored against the ground truth.
//! - [`scene`]: the traits that connect the bench, the emulated devices and the renderer.
//! - [`scratch`]: a scratch on the contact surface (sensor file `[[surface.scratches]]`);
//!   `scratch_canvas` draws it into the unloaded background.
//! - [`ageing`]: what changed in a unit since it was accepted (a rig file's `[sim.ageing]`).
//! - [`session`]: repeated sessions of the same bench (a rig file's `[sim] session`): other noise,
//!   the same unit.
//! - [`sensor`]: one sensor build (layer, optics, artefacts, image geometry) from a TOML file, and
//!   the exact sensor-frame mm <-> image px map.
//! - [`background`]: the unloaded sensor image (illumination, rim, LED hot spots, residual
//!   birefringence).
//! - [`render`]: the frame renderer (fringes, blur, noise, drift, gamma) behind `FrameRenderer`.
//! - `pixel_format`: the camera's pixel formats (RGB8, BayerRG8, Mono8) as samples of the
//!   rendered RGB image.
//!
//! Formulas, parameters and what is not simulated: docs/photoelastic-sim.md.
//!
//! The modules no other crate uses (`stress`, `blurred_colour`, `ft_config`, `pixel_format`) are
//! private: callers reach them through the bench, the renderer and the sensor file. `colour`,
//! `contact` and `fringe_field` stay public although no other crate names them today: part of
//! their API (the colour table, contact model accessors, field sampling) has no caller inside
//! this crate and would be dead code if private. What callers across the workspace use is
//! re-exported here: the simulated rig and bench, the emulators and their configurations, the
//! renderer and the scene traits, ground truth. Inside this crate, files import from the
//! defining module, never through these re-exports.
#![warn(unreachable_pub)]

pub mod ageing;
pub mod apt_emulator;
pub mod background;
pub mod bench;
mod blurred_colour;
pub mod camera_emulator;
pub mod colour;
pub mod contact;
pub mod daq_emulator;
pub mod daqmx_library;
pub mod dataset;
pub mod faults;
pub mod fringe_field;
mod ft_config;
pub mod ft_sensor;
pub mod ground_truth;
pub mod indenter;
pub mod label_score;
pub mod modbus_emulator;
pub mod motion;
pub mod netft_box;
pub mod netft_emulator;
mod pixel_format;
pub mod render;
pub mod rig;
pub mod scene;
pub mod scratch;
mod scratch_canvas;
pub mod sensor;
pub mod session;
mod stress;
pub mod sync_score;
#[cfg(test)]
mod test_support;
pub mod truth_spool;

pub use apt_emulator::{AptEmulator, AptEmulatorConfig, AptEmulatorHandle};
pub use bench::{Bench, BenchConfig};
pub use camera_emulator::{ExposureSchedule, SimCamera, SimCameraConfig};
pub use daq_emulator::{SimDaq, SimDaqConfig};
pub use ft_sensor::SimFtSensor;
pub use ground_truth::{TruthLog, TruthSink};
pub use modbus_emulator::ModbusEmulator;
pub use motion::{MotorSpec, SimMotor};
pub use netft_box::{SimNetFt, SimOptions};
pub use netft_emulator::{NetFtEmulator, NetFtEmulatorConfig};
pub use render::Renderer;
pub use rig::{SimRig, SimRigConfig};
pub use scene::{Contact, FrameRenderer, Scene, SceneSource};
pub use sensor::SensorConfig;
pub use truth_spool::TruthSpool;
