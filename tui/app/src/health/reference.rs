//! Which calibration each no-contact figure of a check is compared with.
//!
//! A unit calibrated again after its commissioning (as a check may advise: the camera moved, the
//! F/T zero moved) has its camera geometry (optical centre, disc radius, turn) and its F/T zero
//! compared with that calibration: they are what a calibration sets right, and a check that
//! kept comparing them with the commissioning would advise calibrating again for ever. Its light
//! (rim, sides, brightness) and its surface are always compared with the commissioning's
//! calibration scan: a calibration does not mend them, and a fault already there when the unit
//! was calibrated again (an LED out, dimming, a scratch) would otherwise be taken as the unit's
//! normal and hidden.

use fringe_calibration::health::Signature;
use fringe_calibration::health::{Change, ChangeError};

/// The changes of a check `now` against the commissioning's calibration `commissioned` and,
/// when the unit was calibrated again after it, that calibration `recalibrated`: the geometry's
/// against the newest calibration, the light's and the surface's against the commissioning.
pub(crate) fn compared(
    commissioned: &Signature,
    recalibrated: Option<&Signature>,
    now: &Signature,
) -> Result<Change, ChangeError> {
    let light = Change::between(commissioned, now)?;
    let Some(recalibrated) = recalibrated else {
        return Ok(light);
    };
    let geometry = Change::between(recalibrated, now)?;
    Ok(Change {
        centre_shift_px: geometry.centre_shift_px,
        centre_sigma_px: geometry.centre_sigma_px,
        radius_change_px: geometry.radius_change_px,
        turn_deg: geometry.turn_deg,
        ..light
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::health::figures::{assess, Measured, Thresholds, Verdict};
    use crate::health::model_errors::ModelErrors;
    use fringe_calibration::health::{CELLS, INNER, RIM_BINS, SIDES};
    use fringe_calibration::DiscFit;

    /// The signature of a unit with twelve LEDs (`lit`), its light scaled by `gain`, its disc
    /// centred at `centre` (px) in a 960x600 image: the rim's hot spots where the LEDs are, each
    /// side lit most by its own LEDs, a smooth pattern over the cells.
    fn signature(lit: [bool; 12], gain: f64, centre: [f64; 2]) -> Signature {
        let radius = 250.0;
        let led_deg = |k: usize| 7.5 + 30.0 * k as f64;
        let angular = |a: f64, b: f64| {
            let d = (a - b).rem_euclid(360.0);
            d.min(360.0 - d)
        };
        let share = lit.iter().filter(|l| **l).count() as f64 / 12.0;
        let rim_dn = (0..RIM_BINS)
            .map(|d| {
                let spots: f64 = (0..12)
                    .filter(|k| lit[*k])
                    .map(|k| {
                        100.0 * (-0.5 * (angular(d as f64 + 0.5, led_deg(k)) / 3.0).powi(2)).exp()
                    })
                    .sum();
                gain * (20.0 + spots)
            })
            .collect();
        let sides_dn = (0..SIDES)
            .map(|s| {
                let at = (s as f64 + 0.5) * 360.0 / SIDES as f64;
                let light: f64 = (0..12)
                    .filter(|k| lit[*k])
                    .map(|k| (1.0 + 0.6 * angular(at, led_deg(k)).to_radians().cos()) / 12.0)
                    .sum();
                gain * 150.0 * light
            })
            .collect();
        let cells = (0..CELLS * CELLS)
            .map(|k| {
                let (x, y) = (
                    (k % CELLS) as f64 + 0.5 - 0.5 * CELLS as f64,
                    (k / CELLS) as f64 + 0.5 - 0.5 * CELLS as f64,
                );
                let inside = x.hypot(y) < 0.5 * CELLS as f64;
                let pattern = 150.0 + 8.0 * (0.3 * x).sin() + 6.0 * (0.2 * y + 0.1 * x).cos();
                inside.then_some((gain * share * pattern) as f32)
            })
            .collect();
        Signature {
            run: "synthetic".into(),
            width: 960,
            height: 600,
            fit: DiscFit {
                width: 960,
                height: 600,
                frames: 24,
                centre_x: centre[0],
                centre_y: centre[1],
                radius,
                sigma_x: 0.01,
                sigma_y: 0.01,
                sigma_radius: 0.013,
                edge_radius: radius,
                residual_rms_px: 0.1,
                inliers: 360,
                rays: 360,
                crop_radius: 0.9 * radius,
                edge_blur_px: Some(1.0),
                inside_dn: 150.0 * gain,
                outside_dn: 5.0,
                noise_dn: 1.0,
            },
            brightness_dn: gain * share * 150.0,
            rim_dn,
            sides_dn,
            cells,
            cell_px: 2.0 * INNER * radius / CELLS as f64,
        }
    }

    /// The model's errors at the check's positions: worse than at acceptance, as a unit with an
    /// LED out and dimmed light reads.
    fn errors(gain: f64, fz: f64) -> ModelErrors {
        ModelErrors {
            frames: 400,
            fz_rmse_n: fz,
            contact_rmse_mm: 1.0,
            shape_accuracy: 0.97,
            force_gain: gain,
        }
    }

    fn verdict(change: &Change, radius: f64) -> (Verdict, String) {
        let (now, then) = (errors(0.9, 0.6), errors(1.0, 0.3));
        let a = assess(
            &Measured {
                change,
                radius_px: radius,
                radius_sigma_px: 0.02,
                force_offset_n: Some([0.0; 3]),
                model_now: Some(&now),
                model_then: Some(&then),
            },
            &Thresholds::default(),
        );
        (a.verdict, a.diagnosis)
    }

    #[test]
    fn an_led_out_and_dimmed_light_say_replace_before_and_after_the_unit_is_calibrated_again() {
        let centre = [482.0, 301.0];
        let commissioned = signature([true; 12], 1.0, centre);
        let mut one_out = [true; 12];
        one_out[3] = false;
        // An LED out and the light 30 % dimmer; the check's frames.
        let now = signature(one_out, 0.7, centre);
        let change = compared(&commissioned, None, &now).expect("change");
        let (v, why) = verdict(&change, commissioned.fit.radius);
        assert_eq!(v, Verdict::Replace, "{why}");
        assert!(why.contains("an LED is out"), "{why}");
        // `fringe calibrate` now: its scan shows the fault already. The next check still says
        // replace or repair, not "commission again: the material changed".
        let recalibrated = signature(one_out, 0.7, centre);
        let change = compared(&commissioned, Some(&recalibrated), &now).expect("change");
        let (v, why) = verdict(&change, recalibrated.fit.radius);
        assert_eq!(v, Verdict::Replace, "{why}");
        assert!(why.contains("an LED is out"), "{why}");
        assert!(change.brightness_ratio < 0.85, "{change:?}");
        // Compared with the new calibration alone, the fault would have been hidden.
        let hidden = Change::between(&recalibrated, &now).expect("change");
        assert_eq!(
            verdict(&hidden, recalibrated.fit.radius).0,
            Verdict::Recommission
        );
    }

    #[test]
    fn only_the_geometry_is_compared_with_a_later_calibration() {
        let commissioned = signature([true; 12], 1.0, [482.0, 301.0]);
        // The camera was knocked 3 px; a check advised calibrating again, and it was done.
        let knocked = signature([true; 12], 1.0, [485.0, 301.0]);
        let now = signature([true; 12], 1.0, [485.0, 301.0]);
        let before = compared(&commissioned, None, &now).expect("change");
        assert!((before.centre_shift_px[0] - 3.0).abs() < 1e-9, "{before:?}");
        let after = compared(&commissioned, Some(&knocked), &now).expect("change");
        assert_eq!(after.centre_shift(), 0.0, "{after:?}");
        let (now_errors, then) = (errors(1.0, 0.3), errors(1.0, 0.3));
        let a = assess(
            &Measured {
                change: &after,
                radius_px: knocked.fit.radius,
                radius_sigma_px: 0.02,
                force_offset_n: Some([0.0; 3]),
                model_now: Some(&now_errors),
                model_then: Some(&then),
            },
            &Thresholds::default(),
        );
        assert_eq!(a.verdict, Verdict::Ok, "{a:?}");
    }
}
