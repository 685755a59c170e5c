//! What the simulated bench tells its simulated devices, and nothing more.
//!
//! The bench (stage motors, contact mechanics) answers two questions about any host instant: what
//! load acts on the force/torque sensor ([`LoadSource`]) and what the camera would see
//! ([`SceneSource`]). The F/T emulators read a [`ForceReading`] (the sensor's own reading of that
//! load: noise, drift, bias), the camera emulator renders a [`Scene`] with a [`FrameRenderer`].
//! These traits keep the emulators, the bench and the renderer independent of each other.

use crate::optics::pixel_format;
use crate::physics::indenter::Shape;
use crate::physics::traction::partial_slip_onset;
use fringe_rig::HostTime;
use fringe_rig::PixelFormat;
use fringe_rig::{Millimetres, Newtons, Slip, Wrench};

/// An indenter pressing on the sensor, in the sensor frame: millimetres from the sensor disc's
/// centre, +x and +y along the stage's x and y axes, angle counter-clockwise about the load axis
/// seen from the indenter side. The renderer maps this frame to image pixels (rotation, mirror,
/// scale and optical centre of the sensor build).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Contact {
    /// The indenter tip.
    pub shape: Shape,
    /// Normal force the indenter presses with (positive = pressing).
    pub force: Newtons,
    pub x: Millimetres,
    pub y: Millimetres,
    /// Indenter rotation about the load axis, degrees.
    pub angle_deg: f64,
    /// The indenter's push along the surface, if any (`None`: a normal press).
    pub shear: Option<Shear>,
}

/// The tangential force an indenter applies to the sensor surface, and how much of the friction
/// it uses (docs/photoelastic-sim.md, "Shear and slip").
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Shear {
    /// Magnitude of the tangential force on the sensor surface, N.
    pub force: Newtons,
    /// Its direction in the sensor frame, degrees counter-clockwise from +x.
    pub direction_deg: f64,
    /// Share of the friction limit the traction uses, 0 to 1: 0 is full stick, the stick zone
    /// shrinks as it grows, 1 is gross slip (the whole contact slides, the traction mu p).
    pub friction_used: f64,
    /// The indenter slides over the surface (gross slip).
    pub sliding: bool,
}

impl Contact {
    /// How the contact holds: gross slip while the indenter slides; partial slip while it
    /// sticks with a tenth or more of its contact slipping (the share of the friction used at
    /// or past the outline's [`partial_slip_onset`]); stick otherwise, a press without a push
    /// included.
    pub fn slip_state(&self) -> Slip {
        match self.shear {
            Some(s) if s.sliding => Slip::GrossSlip,
            Some(s) if s.friction_used >= partial_slip_onset(&self.shape) => Slip::PartialSlip,
            _ => Slip::Stick,
        }
    }
}

/// Everything the camera sees that changes with time.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Scene {
    /// The indenter in contact, or `None` when nothing touches the sensor.
    pub contact: Option<Contact>,
}

/// The true load on the force/torque sensor (no noise, no bias), in the sensor's own frame.
pub trait LoadSource: Send + Sync {
    fn true_wrench_at(&self, t: HostTime) -> Wrench;
}

/// What the camera sees at an instant.
pub trait SceneSource: Send + Sync {
    fn scene_at(&self, t: HostTime) -> Scene;
}

/// The F/T sensor's own reading at `t`: the true load plus the sensor's noise, drift and power-up
/// bias. Calls come in non-decreasing `t` from one acquisition thread.
pub trait ForceReading: Send {
    fn reading_at(&mut self, t: HostTime) -> Wrench;

    /// The transducer lost its power and got it back (the box feeding it rebooted): a sensor
    /// with a power-up bias draws a new one.
    fn power_cycle(&mut self);
}

/// A scripted reading (a function of time) has no power-up state: a power cycle leaves it as it
/// is.
impl<F: FnMut(HostTime) -> Wrench + Send> ForceReading for F {
    fn reading_at(&mut self, t: HostTime) -> Wrench {
        self(t)
    }

    fn power_cycle(&mut self) {}
}

/// Turns a scene into an interleaved 8-bit RGB image.
pub trait FrameRenderer: Send {
    /// Image width in pixels.
    fn width(&self) -> u32;
    /// Image height in pixels.
    fn height(&self) -> u32;
    /// Renders `scene` as frame number `frame_index` (drives noise, flicker and drift) into `out`,
    /// resized to width * height * 3 bytes. The same renderer (for [`crate::optics::render::Renderer`]:
    /// the same sensor seed and session), scene and frame index give the same bytes.
    fn render(&mut self, scene: &Scene, frame_index: u64, out: &mut Vec<u8>);

    /// Renders `scene` in the camera's pixel `format` (see [`pixel_format`]) into `out`, resized to
    /// width * height * bytes per pixel. The default renders RGB and converts it; renderers that
    /// can write a format directly override this (the bytes must be the same).
    fn render_as(
        &mut self,
        scene: &Scene,
        frame_index: u64,
        format: PixelFormat,
        out: &mut Vec<u8>,
    ) {
        if format == PixelFormat::Rgb8 {
            self.render(scene, frame_index, out);
        } else {
            let mut rgb = Vec::new();
            self.render(scene, frame_index, &mut rgb);
            pixel_format::from_rgb(&rgb, self.width() as usize, format, out);
        }
    }
}
