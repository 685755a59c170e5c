//! The simulated bench: physics, rendering and device emulators.
//!
//! - [`stress`]: Boussinesq point-load stress integrated through the photoelastic layer.
//! - [`indenter`]: indenter outlines and their contact pressure maps.
//! - [`fringe_field`]: fringe order per newton around an indenter (FFT convolution).
//! - [`colour`]: the colour a white LED and an RGB camera give for each fringe order.
//! - [`blurred_colour`]: that colour averaged over a spread of fringe orders (defocus).
//! - [`motion`]: simulated axes with trapezoidal motion profiles in host time.
//! - [`modbus_emulator`]: an emulated Modbus y stage (TCP, RTU on a pty, in process) from a register map.
//! - [`netft_emulator`]: an emulated ATI Net F/T box (RDT over UDP or in process, netftapi2.xml).
//! - [`apt_emulator`]: an emulated Thorlabs APT stepper controller (KST101 / BSC20x channel) on a
//!   byte link, driving a [`motion::SimMotor`].
//! - [`scene`]: the traits that connect the bench, the emulated devices and the renderer.
//!
//! Formulas and sources: docs/photoelastic-sim.md (shared project docs).

pub mod apt_emulator;
pub mod blurred_colour;
pub mod colour;
pub mod fringe_field;
pub mod indenter;
pub mod modbus_emulator;
pub mod motion;
pub mod netft_emulator;
pub mod scene;
pub mod stress;
