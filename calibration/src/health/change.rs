//! What changed between the signature a unit was accepted with and the signature of a check.
//!
//! - **Optics**: the centre's shift and the radius's change, px, with the combined 1-sigma of the
//!   two fits.
//! - **Brightness**: the ratio of the disc's mean grey (the camera's slow gain drift is in it).
//! - **Rotation**: the turn of the rim light's pattern (the LED hot spots) that matches the two
//!   best, degrees, within +-[`MAX_TURN_DEG`].
//! - **Rim light**: after that turn, the darkest of the 10-degree sectors of the rim relative to
//!   the brightness ratio (a failed LED takes its hot spot away: its sector darkens far more than
//!   the disc).
//! - **Sides**: the darkest side sector of the disc relative to the brightness ratio (a failed
//!   LED takes its share of the light from its side).
//! - **Surface**: the check's cells against the reference's, fitted with one gain and offset
//!   (the camera's drift), minus each residual's local median over 5x5 cells: what remains is
//!   sharp, local change (a scratch's scattered light and stress), not the smooth change of
//!   lighting or drift. Cells beyond [`SURFACE_SIGMAS`] times the robust noise of those residuals
//!   (and at least [`SURFACE_MIN_DN`]) are counted.

use super::signature::{Signature, CELLS, RIM_BINS};
use crate::optical::grey::median_f64;

/// Largest turn of the rim pattern searched, degrees.
pub(crate) const MAX_TURN_DEG: usize = 12;
/// Width of the rim sectors compared, degrees.
pub const RIM_SECTOR_DEG: usize = 10;
/// A cell counts as changed beyond this many robust sigmas ...
pub(crate) const SURFACE_SIGMAS: f64 = 6.0;
/// ... and at least this many DN.
pub(crate) const SURFACE_MIN_DN: f64 = 2.0;

/// The changes of a unit between two signatures.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Change {
    /// Centre now minus then, px [x right, y down].
    pub centre_shift_px: [f64; 2],
    /// Combined 1-sigma of the shift per axis, px.
    pub centre_sigma_px: [f64; 2],
    /// Radius now minus then, px.
    pub radius_change_px: f64,
    /// Disc brightness now over then.
    pub brightness_ratio: f64,
    /// Turn of the rim light's pattern, degrees counter-clockwise on the image.
    pub turn_deg: f64,
    /// The darkest rim sector (its first degree) and its light now over then, over the
    /// brightness ratio.
    pub darkest_rim_deg: f64,
    pub darkest_rim_ratio: f64,
    /// The darkest side sector (its first degree) and its light now over then, over the
    /// brightness ratio.
    pub darkest_side_deg: f64,
    pub darkest_side_ratio: f64,
    /// Cells of the disc that changed sharply, of the cells compared (those whose 5x5 window
    /// lies wholly on the disc).
    pub surface_cells: usize,
    pub cells_compared: usize,
    /// The largest sharp change of a cell, DN, and the robust noise of all, DN.
    pub surface_peak_dn: f64,
    pub surface_noise_dn: f64,
}

/// Two signatures that cannot be compared.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ChangeError {
    #[error(
        "the check's frames are {now_w}x{now_h} px and the reference's {then_w}x{then_h} px: \
         check with the camera settings the unit was accepted with"
    )]
    Size {
        now_w: usize,
        now_h: usize,
        then_w: usize,
        then_h: usize,
    },
}

impl Change {
    /// The change from `then` (the reference) to `now` (the check).
    pub fn between(then: &Signature, now: &Signature) -> Result<Change, ChangeError> {
        if (then.width, then.height) != (now.width, now.height) {
            return Err(ChangeError::Size {
                now_w: now.width,
                now_h: now.height,
                then_w: then.width,
                then_h: then.height,
            });
        }
        let brightness_ratio = now.brightness_dn / then.brightness_dn.max(1e-6);
        let turn = best_turn(&then.rim_dn, &now.rim_dn);
        let (darkest_rim_deg, darkest_rim_ratio) =
            darkest_sector(&then.rim_dn, &now.rim_dn, turn, brightness_ratio);
        let per_side = RIM_BINS / then.sides_dn.len().max(1);
        let (darkest_side_deg, darkest_side_ratio) = then
            .sides_dn
            .iter()
            .zip(&now.sides_dn)
            .enumerate()
            .map(|(k, (a, b))| ((k * per_side) as f64, b / a.max(1e-6) / brightness_ratio))
            .fold((0.0, f64::INFINITY), |m, s| if s.1 < m.1 { s } else { m });
        let surface = surface(then, now);
        let f = (&then.fit, &now.fit);
        Ok(Change {
            centre_shift_px: [f.1.centre_x - f.0.centre_x, f.1.centre_y - f.0.centre_y],
            centre_sigma_px: [
                f.0.sigma_x.hypot(f.1.sigma_x),
                f.0.sigma_y.hypot(f.1.sigma_y),
            ],
            radius_change_px: f.1.radius - f.0.radius,
            brightness_ratio,
            turn_deg: turn as f64,
            darkest_rim_deg,
            darkest_rim_ratio,
            darkest_side_deg,
            darkest_side_ratio,
            surface_cells: surface.changed,
            cells_compared: surface.compared,
            surface_peak_dn: surface.peak,
            surface_noise_dn: surface.noise,
        })
    }

    /// The centre's shift, px.
    pub fn centre_shift(&self) -> f64 {
        self.centre_shift_px[0].hypot(self.centre_shift_px[1])
    }
}

/// The turn (whole degrees, +-[`MAX_TURN_DEG`]) that best matches `now` to `then` (least squares
/// on the mean-removed profiles): `now[k + turn] ~ then[k]`.
fn best_turn(then: &[f64], now: &[f64]) -> i64 {
    let n = then.len();
    if n == 0 || now.len() != n {
        return 0;
    }
    let centred = |v: &[f64]| {
        let m = v.iter().sum::<f64>() / n as f64;
        v.iter().map(|x| x - m).collect::<Vec<_>>()
    };
    let (a, b) = (centred(then), centred(now));
    let max = MAX_TURN_DEG as i64;
    (-max..=max)
        .map(|t| {
            let score: f64 = (0..n)
                .map(|k| a[k] * b[(k as i64 + t).rem_euclid(n as i64) as usize])
                .sum();
            (t, score)
        })
        .fold((0, f64::NEG_INFINITY), |m, s| if s.1 > m.1 { s } else { m })
        .0
}

/// The darkest [`RIM_SECTOR_DEG`] sector of `now` (turned back by `turn`) against `then`,
/// relative to `brightness`: (its first degree in `then`'s angles, its ratio).
fn darkest_sector(then: &[f64], now: &[f64], turn: i64, brightness: f64) -> (f64, f64) {
    let n = then.len();
    if n == 0 || now.len() != n {
        return (0.0, 1.0);
    }
    (0..n / RIM_SECTOR_DEG)
        .map(|s| {
            let (mut a, mut b) = (0.0, 0.0);
            for k in s * RIM_SECTOR_DEG..(s + 1) * RIM_SECTOR_DEG {
                a += then[k];
                b += now[(k as i64 + turn).rem_euclid(n as i64) as usize];
            }
            ((s * RIM_SECTOR_DEG) as f64, b / a.max(1e-6) / brightness)
        })
        .fold((0.0, f64::INFINITY), |m, s| if s.1 < m.1 { s } else { m })
}

/// Sharp local change of the disc's cells (see the module documentation).
struct Surface {
    changed: usize,
    compared: usize,
    peak: f64,
    noise: f64,
}

fn surface(then: &Signature, now: &Signature) -> Surface {
    let pairs: Vec<(usize, f64, f64)> = then
        .cells
        .iter()
        .zip(&now.cells)
        .enumerate()
        .filter_map(|(k, (a, b))| Some((k, f64::from((*a)?), f64::from((*b)?))))
        .collect();
    let none = Surface {
        changed: 0,
        compared: pairs.len(),
        peak: 0.0,
        noise: 0.0,
    };
    if pairs.len() < 25 {
        return none;
    }
    // now ~ gain * then + offset, least squares.
    let n = pairs.len() as f64;
    let (sx, sy) = pairs
        .iter()
        .fold((0.0, 0.0), |(sx, sy), (_, a, b)| (sx + a, sy + b));
    let (mx, my) = (sx / n, sy / n);
    let (sxx, sxy) = pairs.iter().fold((0.0, 0.0), |(sxx, sxy), (_, a, b)| {
        (sxx + (a - mx) * (a - mx), sxy + (a - mx) * (b - my))
    });
    let gain = if sxx > 0.0 { sxy / sxx } else { 1.0 };
    let mut residual = vec![f64::NAN; CELLS * CELLS];
    for (k, a, b) in &pairs {
        residual[*k] = b - (my + gain * (a - mx));
    }
    let mut sharp = Vec::with_capacity(pairs.len());
    for (k, _, _) in &pairs {
        let (x, y) = ((k % CELLS) as i64, (k / CELLS) as i64);
        let mut near: Vec<f64> = (-2..=2)
            .flat_map(|dy| (-2..=2).map(move |dx| (x + dx, y + dy)))
            .filter(|&(i, j)| (0..CELLS as i64).contains(&i) && (0..CELLS as i64).contains(&j))
            .map(|(i, j)| residual[j as usize * CELLS + i as usize])
            .filter(|v| v.is_finite())
            .collect();
        // Only cells with their whole window on the disc: at the edge of the compared cells a
        // one-sided median follows a smooth change of light badly.
        if near.len() == 25 {
            sharp.push(residual[*k] - median_f64(&mut near));
        }
    }
    let mut abs: Vec<f64> = sharp.iter().map(|v| v.abs()).collect();
    let noise = 1.4826 * median_f64(&mut abs);
    let limit = (SURFACE_SIGMAS * noise).max(SURFACE_MIN_DN);
    Surface {
        changed: sharp.iter().filter(|v| v.abs() > limit).count(),
        compared: sharp.len(),
        peak: sharp.iter().fold(0.0f64, |m, v| m.max(v.abs())),
        noise,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::optical::grey::GreyImage;
    use fringe_rig::seeded::uniform;
    use std::f64::consts::TAU;

    /// A synthetic unit seen by the camera: a lit disc with vignetting, a smooth residual
    /// pattern and the light of its LEDs (each brighter on its own side, smoothly), a glowing rim with twelve LED hot spots
    /// just outside it, dark housing, sensor noise.
    #[derive(Clone)]
    struct Unit {
        centre: [f64; 2],
        leds: [bool; 12],
        /// A scratch: its two ends, px.
        scratch: Option<([f64; 2], [f64; 2])>,
        /// The camera's gain (slow drift).
        gain: f64,
    }

    const W: usize = 400;
    const H: usize = 300;
    const R: f64 = 120.0;

    impl Unit {
        fn new() -> Unit {
            Unit {
                centre: [203.0, 148.0],
                leds: [true; 12],
                scratch: None,
                gain: 1.0,
            }
        }

        fn led_angle(k: usize) -> f64 {
            (7.5 + 30.0 * k as f64).to_radians()
        }

        fn frame(&self, seed: u64) -> GreyImage {
            let mut state = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
            let mut data = Vec::with_capacity(W * H);
            for j in 0..H {
                for i in 0..W {
                    let (u, v) = (
                        i as f64 + 0.5 - self.centre[0],
                        j as f64 + 0.5 - self.centre[1],
                    );
                    let r = u.hypot(v);
                    let angle = (-v).atan2(u);
                    let mask = 1.0 / (1.0 + (1.7 * (r - R) / 1.0).exp());
                    let q = r / (3.0 * R);
                    let vignetting = 1.0 / ((1.0 + q * q) * (1.0 + q * q));
                    let mut light = 0.0;
                    let mut glow = 4.0 + 20.0 * (-0.5 * ((r - R) / 3.0).powi(2)).exp();
                    for k in 0..12 {
                        if !self.leds[k] {
                            continue;
                        }
                        let a = Unit::led_angle(k);
                        light += (1.0 + (r / R).min(1.0) * (angle - a).cos()) / 12.0;
                        let p = [1.02 * R * a.cos(), -1.02 * R * a.sin()];
                        let d2 = (u - p[0]).powi(2) + (v - p[1]).powi(2);
                        glow += 100.0 * (-0.5 * d2 / 9.0).exp();
                    }
                    let residual =
                        8.0 * ((u * 0.02 + v * 0.013).sin() + (u * 0.011 - v * 0.017).cos());
                    let mut value = mask * vignetting * (150.0 * light + residual) + glow;
                    if let Some((a, b)) = self.scratch {
                        let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
                        let t = (((u + self.centre[0] - a[0]) * dx
                            + (v + self.centre[1] - a[1]) * dy)
                            / (dx * dx + dy * dy))
                            .clamp(0.0, 1.0);
                        let (cx, cy) = (a[0] + t * dx, a[1] + t * dy);
                        let d = (i as f64 + 0.5 - cx).hypot(j as f64 + 0.5 - cy);
                        value += mask * 30.0 * (-0.5 * (d / 1.0).powi(2)).exp();
                    }
                    let noise = (0..4).map(|_| uniform(&mut state)).sum::<f64>() - 2.0;
                    data.push((self.gain * value + 2.0 * noise * 1.7).clamp(0.0, 255.0) as f32);
                }
            }
            GreyImage::from_values(W, H, data).expect("frame")
        }

        fn signature(&self, seed: u64) -> Signature {
            let frames: Vec<GreyImage> = (0..6).map(|k| self.frame(seed * 100 + k)).collect();
            Signature::of_frames("synthetic".into(), &frames).expect("signature")
        }
    }

    #[test]
    fn an_unchanged_unit_changes_nothing_beyond_noise_and_drift() {
        let then = Unit::new().signature(1);
        let now = Unit {
            gain: 1.04,
            ..Unit::new()
        }
        .signature(2);
        let c = Change::between(&then, &now).expect("change");
        assert!(c.centre_shift() < 0.3, "{c:?}");
        assert!((c.brightness_ratio - 1.04).abs() < 0.01, "{c:?}");
        assert_eq!(c.turn_deg, 0.0, "{c:?}");
        assert!(c.darkest_rim_ratio > 0.95, "{c:?}");
        assert!(c.darkest_side_ratio > 0.98, "{c:?}");
        assert_eq!(c.surface_cells, 0, "{c:?}");
    }

    #[test]
    fn a_dead_led_darkens_its_rim_sector_and_its_side_but_marks_no_surface() {
        let then = Unit::new().signature(1);
        let mut aged = Unit::new();
        aged.leds[3] = false;
        let c = Change::between(&then, &aged.signature(2)).expect("change");
        assert!(c.darkest_rim_ratio < 0.6, "{c:?}");
        // LED 3 sits at 97.5 degrees: in the sector from 90.
        assert_eq!(c.darkest_rim_deg, 90.0, "{c:?}");
        assert!(c.darkest_side_ratio < 0.96, "{c:?}");
        let side = c.darkest_side_deg;
        assert!((60.0..=120.0).contains(&side), "{c:?}");
        assert_eq!(c.surface_cells, 0, "{c:?}");
    }

    #[test]
    fn a_scratch_marks_the_cells_along_it_and_nothing_else() {
        let then = Unit::new().signature(1);
        let scratched = Unit {
            scratch: Some(([140.0, 100.0], [270.0, 190.0])),
            ..Unit::new()
        };
        let c = Change::between(&then, &scratched.signature(2)).expect("change");
        assert!(c.surface_cells >= 15, "{c:?}");
        assert!(c.darkest_rim_ratio > 0.95, "{c:?}");
        assert!(c.centre_shift() < 0.3, "{c:?}");
    }

    #[test]
    fn a_camera_shift_moves_the_centre_and_nothing_else() {
        let then = Unit::new().signature(1);
        let moved = Unit {
            centre: [205.5, 146.0],
            ..Unit::new()
        };
        let c = Change::between(&then, &moved.signature(2)).expect("change");
        assert!((c.centre_shift_px[0] - 2.5).abs() < 0.3, "{c:?}");
        assert!((c.centre_shift_px[1] + 2.0).abs() < 0.3, "{c:?}");
        assert!(c.darkest_rim_ratio > 0.9, "{c:?}");
        assert_eq!(c.surface_cells, 0, "{c:?}");
    }

    #[test]
    fn frames_of_another_size_are_refused() {
        let then = Unit::new().signature(1);
        let mut other = then.clone();
        other.width = 800;
        assert!(matches!(
            Change::between(&then, &other),
            Err(ChangeError::Size { now_w: 800, .. })
        ));
        let _ = TAU;
    }
}
