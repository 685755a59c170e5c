//! The simulated bench: physics, rendering and device emulators.
//!
//! - [`stress`]: Boussinesq point-load stress integrated through the photoelastic layer.
//! - [`indenter`]: indenter outlines and their contact pressure maps.
//! - [`fringe_field`]: fringe order per newton around an indenter (FFT convolution).
//! - [`colour`]: the colour a white LED and an RGB camera give for each fringe order.
//! - [`blurred_colour`]: that colour averaged over a spread of fringe orders (defocus).
//! - [`motion`]: simulated axes with trapezoidal motion profiles in host time.
//! - [`scene`]: the traits that connect the bench, the emulated devices and the renderer.
//! - [`sensor`]: one sensor build (layer, optics, artefacts, image geometry) from a TOML file, and
//!   the exact sensor-frame mm <-> image px map.
//! - [`background`]: the unloaded sensor image (illumination, rim, LED hot spots, residual
//!   birefringence).
//! - [`render`]: the frame renderer (fringes, blur, noise, drift, gamma) behind `FrameRenderer`.
//!
//! Formulas and sources: docs/photoelastic-sim.md (shared project docs).

pub mod background;
pub mod blurred_colour;
pub mod colour;
pub mod fringe_field;
pub mod indenter;
pub mod motion;
pub mod render;
pub mod scene;
pub mod sensor;
pub mod stress;
