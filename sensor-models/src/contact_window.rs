//! A window about the contact point: what the force network of a two-stage model reads. The
//! first network finds the contact (and the shape) on the whole disc; the second reads the
//! force from a square of `window_mm` about that contact, resampled to its input, so the dense
//! fringes of a hard press fill the input instead of a corner of it (BENCHMARKS.md, "A window
//! about the contact").
//!
//! The window is the one preprocessing with its crop centred on the contact's pixel instead of
//! the optical centre and a crop radius of half the window: the contact label (mm from the
//! optical centre, +x right, +y up in the camera view after the registration's mirror and turn)
//! is mapped to pixels by the sensor's registration (px per mm, mirror, rotation).

use crate::preprocess::{Centre, PreprocessError, Preprocessing};
use fringe_calibration::Profile;
use std::ops::RangeInclusive;

/// The sides a force window may have, mm (what `fringe train --force-window` and a model card's
/// `force_window_mm` accept): from a press's few millimetres to a whole disc and more.
pub const FORCE_WINDOW_MM: RangeInclusive<f64> = 2.0..=100.0;

/// Why a contact window cannot be made for a sensor.
#[derive(Debug, thiserror::Error)]
pub enum WindowError {
    #[error(
        "the profile of sensor {sensor} has no registration (image <-> stage geometry): a force \
         window about the contact needs its px per mm; calibrate the registration \
         (`fringe calibrate`) or use a whole-disc model"
    )]
    NoRegistration { sensor: String },
    #[error(
        "a force window of {0} mm: a window is {min} to {max} mm across",
        min = FORCE_WINDOW_MM.start(),
        max = FORCE_WINDOW_MM.end()
    )]
    Size(f64),
    #[error(
        "the preprocessing of {sensor} is the reference pipeline's (image centre, no \
         registration): a force window about the contact needs the sensor's calibration profile \
         (--profile)"
    )]
    Reference { sensor: String },
    #[error(transparent)]
    Preprocess(#[from] PreprocessError),
}

/// The map from a contact label to the window about it, for one sensor.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct ContactWindow {
    /// Side of the window, mm.
    pub window_mm: f64,
    px_per_mm: f64,
    rotation_deg: f64,
    mirror: bool,
}

impl ContactWindow {
    /// The window of `window_mm` for the sensor of `profile` (its registration's scale, turn
    /// and mirror).
    pub(crate) fn from_profile(
        profile: &Profile,
        window_mm: f64,
    ) -> Result<ContactWindow, WindowError> {
        let reg = profile
            .registration
            .as_ref()
            .ok_or_else(|| WindowError::NoRegistration {
                sensor: profile.sensor_id.clone(),
            })?;
        if !FORCE_WINDOW_MM.contains(&window_mm) {
            return Err(WindowError::Size(window_mm));
        }
        Ok(ContactWindow::new(
            window_mm,
            reg.px_per_mm,
            reg.rotation_deg,
            reg.mirror,
        ))
    }

    /// The window of `window_mm` under a registration of `px_per_mm`, turned `rotation_deg`
    /// counter-clockwise and mirror-reversed or not (a profile's registration's fields).
    pub(crate) fn new(
        window_mm: f64,
        px_per_mm: f64,
        rotation_deg: f64,
        mirror: bool,
    ) -> ContactWindow {
        ContactWindow {
            window_mm,
            px_per_mm,
            rotation_deg,
            mirror,
        }
    }

    /// The image offset (px, x right, y down) of a contact `contact_mm` from the optical centre.
    pub(crate) fn offset_px(&self, contact_mm: [f64; 2]) -> [f64; 2] {
        let (s, c) = self.rotation_deg.to_radians().sin_cos();
        let m = if self.mirror { -1.0 } else { 1.0 };
        let [x, y] = contact_mm;
        let k = self.px_per_mm;
        [k * (c * m * x - s * y), -k * (s * m * x + c * y)]
    }

    /// The preprocessing of the window about `contact_mm`: `disc`'s (the sensor's whole-disc
    /// preprocessing, centred on its optical centre) with the crop moved onto the contact and
    /// narrowed to the window, at the force network's `input_size` and `colour`.
    pub(crate) fn preprocessing(
        &self,
        disc: &Preprocessing,
        contact_mm: [f64; 2],
        input_size: u32,
        colour: crate::preprocess::Colour,
    ) -> Result<Preprocessing, WindowError> {
        let Centre::At(centre) = disc.centre else {
            return Err(WindowError::Reference {
                sensor: disc.sensor.clone(),
            });
        };
        if disc.reference {
            return Err(WindowError::Reference {
                sensor: disc.sensor.clone(),
            });
        }
        let [dx, dy] = self.offset_px(contact_mm);
        let p = Preprocessing {
            centre: Centre::At([centre[0] + dx, centre[1] + dy]),
            crop_radius_px: self.window_mm / 2.0 * self.px_per_mm,
            input_size,
            colour,
            ..disc.clone()
        };
        p.check()?;
        Ok(p)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::preprocess::{Colour, FrameRef};
    use fringe_rig::PixelFormat;

    fn window(rotation_deg: f64, mirror: bool) -> ContactWindow {
        ContactWindow {
            window_mm: 4.0,
            px_per_mm: 5.0,
            rotation_deg,
            mirror,
        }
    }

    fn disc() -> Preprocessing {
        Preprocessing {
            centre: Centre::At([100.0, 80.0]),
            crop_radius_px: 70.0,
            frame_size: Some((200, 160)),
            sensor: "test".into(),
            input_size: 32,
            colour: Colour::Grey,
            reference: false,
        }
    }

    /// Under every registration (as the layered design's mirrored view and the integrated
    /// design's mirrored and turned one), a bright spot drawn where the registration puts a
    /// contact sits at the centre of the window about that contact: the force network sees the
    /// press, not the disc beside it.
    #[test]
    fn the_window_about_a_contact_is_centred_on_its_press() {
        let contact = [4.0, 5.0];
        for (rotation, mirror) in [(90.0, true), (0.0, true), (0.0, false), (37.0, false)] {
            let w = window(rotation, mirror);
            let [dx, dy] = w.offset_px(contact);
            let (u, v) = (100.0 + dx, 80.0 + dy);
            let mut data = vec![20u8; 200 * 160];
            for y in (v as usize - 2)..(v as usize + 2) {
                for x in (u as usize - 2)..(u as usize + 2) {
                    data[y * 200 + x] = 250;
                }
            }
            let frame = FrameRef {
                width: 200,
                height: 160,
                format: PixelFormat::Mono8,
                data: &data,
                cutout: None,
            };
            let pre = w
                .preprocessing(&disc(), contact, 16, Colour::Grey)
                .expect("window");
            assert_eq!(pre.crop_radius_px, 10.0, "4 mm at 5 px/mm");
            let input = pre.run(frame).expect("run");
            let plane = &input[..16 * 16];
            // The spot's 4 px fill the middle 6 or so of the 20 px window: the brightest input
            // pixels are about the centre.
            let (mut sx, mut sy, mut n) = (0.0, 0.0, 0.0);
            for (i, &val) in plane.iter().enumerate() {
                if val > 0.5 {
                    sx += (i % 16) as f64 - 7.5;
                    sy += (i / 16) as f64 - 7.5;
                    n += 1.0;
                }
            }
            assert!(
                n > 0.0,
                "turn {rotation}, mirror {mirror}: no spot in the window"
            );
            let miss = ((sx / n).powi(2) + (sy / n).powi(2)).sqrt();
            assert!(
                miss < 1.0,
                "turn {rotation}, mirror {mirror}: the spot sits {miss:.1} px from the window's centre"
            );
        }
    }

    #[test]
    fn a_reference_geometry_has_no_window() {
        let reference = Preprocessing {
            centre: Centre::Image,
            reference: true,
            ..disc()
        };
        let e = window(0.0, false)
            .preprocessing(&reference, [0.0, 0.0], 16, Colour::Grey)
            .expect_err("refused");
        assert!(e.to_string().contains("--profile"), "{e}");
    }

    /// A window of 1e300 mm (a card's `force_window_mm` once let through) is refused with the
    /// crop it would make, where its resampling asked for more memory than there is and the
    /// live validation's thread panicked (capacity overflow); so is any crop wider than
    /// [`crate::preprocess::MAX_CROP_RADIUS_PX`] run on a frame.
    #[test]
    fn a_window_too_wide_for_any_frame_is_refused_not_resampled() {
        for mm in [1e300, 1e6, f64::MAX] {
            let w = ContactWindow::new(mm, 5.0, 0.0, false);
            let e = w
                .preprocessing(&disc(), [0.0, 0.0], 16, Colour::Grey)
                .expect_err("refused");
            assert!(
                matches!(e, WindowError::Preprocess(PreprocessError::Radius(_))),
                "{mm} mm: {e}"
            );
            assert!(e.to_string().contains("from 1 to 10000 px"), "{e}");
        }
        let data = vec![20u8; 200 * 160];
        let frame = FrameRef {
            width: 200,
            height: 160,
            format: PixelFormat::Mono8,
            data: &data,
            cutout: None,
        };
        let mut pre = disc();
        pre.crop_radius_px = 1e300;
        let e = pre.run(frame).expect_err("refused");
        assert!(matches!(e, PreprocessError::Radius(_)), "{e}");
        pre.crop_radius_px = crate::preprocess::MAX_CROP_RADIUS_PX;
        assert!(pre.run(frame).is_ok(), "the widest crop allowed runs");
    }
}
