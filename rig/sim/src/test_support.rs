//! Helpers of this crate's unit tests: small sensor builds that render fast, a contact, a
//! rendered frame and its grey levels.

use crate::optics::render::Renderer;
use crate::optics::sensor::SensorConfig;
use crate::physics::indenter::Shape;
use crate::scene::{Contact, FrameRenderer, Scene};
use fringe_rig::{Millimetres, Newtons};

/// A 320x200 sensor at 3 px/mm (disc radius 90 px = 30 mm), coarse field grid.
pub(crate) fn small(mut c: SensorConfig) -> SensorConfig {
    c.geometry.width = 320;
    c.geometry.height = 200;
    c.geometry.disc_radius_px = 90.0;
    c.geometry.px_per_mm = 3.0;
    c.geometry.centre_offset_px = [6.0, -2.0];
    c.leds.width_px = 8.0;
    c.optics.rim_width_px = 2.0;
    c.field.cells = 128;
    c.field.cell_mm = 0.6;
    c
}

/// [`small`] without noise, drift or flicker.
pub(crate) fn quiet(c: SensorConfig) -> SensorConfig {
    let mut c = small(c);
    c.noise.poisson_a = 0.0;
    c.noise.gaussian_b = 0.0;
    c.noise.gain_drift = 0.0;
    c.noise.offset_drift_dn = 0.0;
    c.noise.flicker = 0.0;
    c
}

/// `shape` pressed with `force` N at (`x`, `y`) mm in the sensor frame, turned `angle_deg`.
pub(crate) fn contact(shape: Shape, force: f64, x: f64, y: f64, angle_deg: f64) -> Contact {
    Contact {
        shape,
        force: Newtons(force),
        x: Millimetres(x),
        y: Millimetres(y),
        angle_deg,
        shear: None,
    }
}

/// Frame `frame` of `contact` (or none), interleaved RGB8.
pub(crate) fn render(r: &mut Renderer, contact: Option<Contact>, frame: u64) -> Vec<u8> {
    let mut out = Vec::new();
    r.render(&Scene { contact }, frame, &mut out);
    assert_eq!(out.len(), (r.width() * r.height() * 3) as usize);
    out
}

/// Pixels (i, j) whose centre lies within `fraction` of the disc radius.
pub(crate) fn disc_pixels(r: &Renderer, fraction: f64) -> Vec<(usize, usize)> {
    let g = r.geometry();
    let radius = fraction * r.config().geometry.disc_radius_px;
    let mut out = Vec::new();
    for j in 0..r.height() as usize {
        for i in 0..r.width() as usize {
            let (du, dv) = (
                i as f64 + 0.5 - g.centre_px[0],
                j as f64 + 0.5 - g.centre_px[1],
            );
            if du.hypot(dv) < radius {
                out.push((i, j));
            }
        }
    }
    out
}

/// Mean of the three channels of pixel (`i`, `j`) of an RGB8 image `w` pixels wide.
pub(crate) fn grey(img: &[u8], w: usize, i: usize, j: usize) -> f64 {
    let k = 3 * (j * w + i);
    (f64::from(img[k]) + f64::from(img[k + 1]) + f64::from(img[k + 2])) / 3.0
}
