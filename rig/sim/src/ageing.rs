//! Ageing of a sensor unit: what has changed in a unit since it was accepted, as a rig file's
//! `[sim.ageing]` table. `fringe check` compares a unit with what it was accepted with;
//! this is how the simulated bench shows it a unit that aged (and, with the defaults, one that
//! did not).
//!
//! Every key is optional and its default changes nothing: without `[sim.ageing]` the bench films
//! and measures exactly what it did before. Unknown keys are refused; [`Ageing::check`] refuses
//! values out of range, naming the key and the range.
//!
//! ```toml
//! [sim.ageing]
//! fringe_value_pct = 10.0      # material fringe value f_sigma +10 %: fewer fringes per newton
//! modulus_pct = -15.0          # effective modulus E* -15 % (the gel softened)
//! led_dimming_pct = 20.0       # every LED gives 20 % less light
//! leds_out = [3]               # LED 3 (0-based, ring order from leds.phase_deg) failed
//! camera_shift_px = [5.0, -2.0]  # the camera was knocked: optical centre moves, px of 1920x1200
//! camera_rotation_deg = 0.5    # ... and turned, counter-clockwise on the image
//! ft_offset_n = [0.0, 0.0, 1.5]  # the F/T transducer's zero moved, N, F/T frame
//!
//! [[sim.ageing.scratches]]     # a scratch on the contact surface (sensor frame, mm)
//! from_mm = [-4.0, 2.0]
//! to_mm = [6.0, 5.0]
//! width_mm = 0.3               # FWHM (default 0.3)
//! stress_fringes = 0.4         # residual order along the line (default 0.4)
//! scatter_dn = 30.0            # light scattered by the groove, after the polariser (default 30)
//! ```
//!
//! What each key does where the bench is built ([`Ageing::apply_to_sensor`],
//! [`Ageing::apply_to_bench`], called by [`crate::rig::SimRig::start`]):
//!
//! - `fringe_value_pct` (-50..=100 %, default 0): f_sigma times 1 + pct / 100, both
//!   `layer.f_sigma_n_per_m` and, for a sensor file that derives f_sigma through
//!   `layer.target_fringes`, `layer.target_force_n` (f_sigma is proportional to it), so the
//!   f_sigma the renderer uses changes by that factor either way. Fringe orders fall by
//!   1 / (1 + pct / 100).
//! - `modulus_pct` (-50..=100 %, default 0): E* times 1 + pct / 100: the sensor's
//!   `layer.effective_modulus_mpa` (a sphere's Hertz contact radius in the image) and the bench's
//!   contact Young's modulus (force against depth).
//! - `led_dimming_pct` (0..=100 %, default 0): `optics.illumination_dn` and `leds.strength_dn`
//!   times 1 - pct / 100 (the disc's light comes from the LEDs; the rim ring and the housing's
//!   ambient light stay).
//! - `leds_out` (LED indices below the sensor's `leds.count`, default none): added to the sensor
//!   file's `leds.out`. A dead LED k loses its hot spot and takes
//!   (1 / count) (1 + clamp((x cos a_k + y sin a_k) / R, -1, 1)) of the illumination at
//!   sensor-frame point (x, y), a_k its angle, R the disc radius ([`crate::optics::background::LedLoss`]).
//! - `camera_shift_px` ([dx, dy], each within +-500 px, default [0, 0]): added to
//!   `geometry.centre_offset_px`. Given in px of the full 1920x1200 frame: a rig file's
//!   `image_scale` scales it like the rest of the geometry.
//! - `camera_rotation_deg` (-180..=180, default 0): added to `geometry.rotation_deg` (about the
//!   optical centre).
//! - `ft_offset_n` ([fx, fy, fz], each within +-100 N, default 0): added to the F/T sensor's
//!   power-up bias at every power cycle ([`crate::physics::ft_sensor`]); the ground truth's `ft_bias`
//!   includes it.
//! - `[[sim.ageing.scratches]]` (keys as in [`crate::optics::scratch`]): added to the sensor file's
//!   `[[surface.scratches]]`; rendered into the unloaded background.

use serde::{Deserialize, Serialize};

use crate::bench::BenchConfig;
use crate::optics::scratch::Scratch;
use crate::optics::sensor::SensorConfig;

/// What changed in a unit since it was accepted. See the module documentation.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Ageing {
    /// Material fringe value change, % (10 = 10 % more N/m per fringe).
    pub fringe_value_pct: f64,
    /// Effective modulus change, % (softening is negative).
    pub modulus_pct: f64,
    /// Less light from every LED, %.
    pub led_dimming_pct: f64,
    /// Failed LEDs, 0-based in ring order from `leds.phase_deg`.
    pub leds_out: Vec<u32>,
    /// Optical centre shift, px [right, down] (of the full frame in a rig file).
    pub camera_shift_px: [f64; 2],
    /// Image rotation change, degrees counter-clockwise.
    pub camera_rotation_deg: f64,
    /// Shift of the F/T sensor's zero, N, F/T frame.
    pub ft_offset_n: [f64; 3],
    /// Scratches on the contact surface.
    pub scratches: Vec<Scratch>,
}

/// A value of `[sim.ageing]` that cannot be used.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("key `sim.ageing.{key}` = {value}: {allowed}")]
pub struct AgeingError {
    /// The key under `sim.ageing`.
    pub key: String,
    pub value: String,
    pub allowed: String,
}

/// Refuses `value` of `key`.
fn refuse(key: &str, value: impl std::fmt::Debug, allowed: &str) -> Result<(), AgeingError> {
    Err(AgeingError {
        key: key.into(),
        value: format!("{value:?}"),
        allowed: allowed.into(),
    })
}

/// Whether `v` is a finite number in `lo..=hi`.
fn within(v: f64, lo: f64, hi: f64) -> bool {
    v.is_finite() && (lo..=hi).contains(&v)
}

impl Ageing {
    /// Whether this ages nothing.
    pub fn is_none(&self) -> bool {
        *self == Ageing::default()
    }

    /// Checks every key's range (the LED indices against a sensor: [`Ageing::check_for`]).
    pub fn check(&self) -> Result<(), AgeingError> {
        for (key, v, lo, hi, allowed) in [
            (
                "fringe_value_pct",
                self.fringe_value_pct,
                -50.0,
                100.0,
                "must be in -50..=100 (%)",
            ),
            (
                "modulus_pct",
                self.modulus_pct,
                -50.0,
                100.0,
                "must be in -50..=100 (%)",
            ),
            (
                "led_dimming_pct",
                self.led_dimming_pct,
                0.0,
                100.0,
                "must be in 0..=100 (%)",
            ),
            (
                "camera_rotation_deg",
                self.camera_rotation_deg,
                -180.0,
                180.0,
                "must be in -180..=180 (degrees)",
            ),
        ] {
            if !within(v, lo, hi) {
                return refuse(key, v, allowed);
            }
        }
        if !self
            .camera_shift_px
            .iter()
            .all(|&v| within(v, -500.0, 500.0))
        {
            return refuse(
                "camera_shift_px",
                self.camera_shift_px,
                "each must be in -500..=500 (px of the 1920x1200 frame)",
            );
        }
        if !self.ft_offset_n.iter().all(|&v| within(v, -100.0, 100.0)) {
            return refuse(
                "ft_offset_n",
                self.ft_offset_n,
                "each must be in -100..=100 (N)",
            );
        }
        if let Some(k) = self.leds_out.iter().find(|&&k| k >= 256) {
            return refuse("leds_out", k, "each must be an LED index in 0..=255");
        }
        for (n, scratch) in self.scratches.iter().enumerate() {
            scratch.check().map_err(|b| AgeingError {
                key: format!("scratches[{n}].{}", b.field),
                value: b.value,
                allowed: b.allowed.into(),
            })?;
        }
        Ok(())
    }

    /// [`Ageing::check`], and the failed LEDs against `sensor`'s ring.
    pub fn check_for(&self, sensor: &SensorConfig) -> Result<(), AgeingError> {
        self.check()?;
        let count = sensor.leds.count;
        if let Some(k) = self.leds_out.iter().find(|&&k| k >= count) {
            return Err(AgeingError {
                key: "leds_out".into(),
                value: k.to_string(),
                allowed: format!(
                    "sensor `{}` has {count} LEDs: each must be in 0..{count} (0-based, ring order from leds.phase_deg)",
                    sensor.id
                ),
            });
        }
        Ok(())
    }

    /// The camera shift scaled by `image_scale` (a rig file gives it in px of the full frame).
    pub fn scaled(&self, image_scale: f64) -> Ageing {
        let mut a = self.clone();
        a.camera_shift_px = self.camera_shift_px.map(|v| v * image_scale);
        a
    }

    /// The sensor build as aged: fringe value, modulus, light, LEDs, camera placement, scratches.
    /// The defaults leave `sensor` unchanged.
    pub fn apply_to_sensor(&self, sensor: &mut SensorConfig) {
        if self.is_none() {
            return;
        }
        if self.fringe_value_pct != 0.0 {
            let k = 1.0 + self.fringe_value_pct / 100.0;
            sensor.layer.f_sigma_n_per_m *= k;
            // With target_fringes, f_sigma = (rectangle's peak N_unit) target_force / target.
            sensor.layer.target_force_n *= k;
        }
        if self.modulus_pct != 0.0 {
            sensor.layer.effective_modulus_mpa *= 1.0 + self.modulus_pct / 100.0;
        }
        if self.led_dimming_pct != 0.0 {
            let k = 1.0 - self.led_dimming_pct / 100.0;
            sensor.optics.illumination_dn *= k;
            sensor.leds.strength_dn *= k;
        }
        sensor.leds.out.extend(&self.leds_out);
        let g = &mut sensor.geometry;
        g.centre_offset_px[0] += self.camera_shift_px[0];
        g.centre_offset_px[1] += self.camera_shift_px[1];
        g.rotation_deg += self.camera_rotation_deg;
        sensor
            .surface
            .scratches
            .extend(self.scratches.iter().cloned());
    }

    /// The bench as aged: the contact's modulus and the F/T sensor's zero. The defaults leave
    /// `bench` unchanged.
    pub fn apply_to_bench(&self, bench: &mut BenchConfig) {
        if self.is_none() {
            return;
        }
        if self.modulus_pct != 0.0 {
            bench.material.youngs_modulus_mpa *= 1.0 + self.modulus_pct / 100.0;
        }
        let shift = &mut bench.ft_noise.zero_shift_n;
        for (s, o) in shift.iter_mut().zip(self.ft_offset_n) {
            *s += o;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::optics::render::Renderer;
    use crate::physics::contact::elastic_force;
    use crate::scene::FrameRenderer;
    use crate::test_support::{contact, disc_pixels, grey, quiet, render};
    use fringe_rig::Millimetres;

    /// The quiet small layered sensor with `ageing` applied, rendered without contact.
    fn aged_frame(base: &SensorConfig, ageing: &Ageing) -> (Renderer, Vec<u8>) {
        let mut c = base.clone();
        ageing.check_for(&c).expect("valid ageing");
        ageing.apply_to_sensor(&mut c);
        let mut r = Renderer::new(c).expect("renderer");
        let img = render(&mut r, None, 0);
        (r, img)
    }

    /// A quiet small layered sensor whose unloaded disc is bright (residual order about 0.5).
    fn bright() -> SensorConfig {
        let mut c = quiet(SensorConfig::layered());
        c.optics.residual_birefringence = 0.5;
        c
    }

    /// Centroid of the pixels brighter than `threshold` grey.
    fn bright_centroid(img: &[u8], w: usize, threshold: f64) -> [f64; 2] {
        let (mut su, mut sv, mut n) = (0.0, 0.0, 0.0);
        for k in 0..img.len() / 3 {
            let (i, j) = (k % w, k / w);
            if grey(img, w, i, j) > threshold {
                su += i as f64 + 0.5;
                sv += j as f64 + 0.5;
                n += 1.0;
            }
        }
        [su / n, sv / n]
    }

    /// Mean grey of the pixels within `radius` px of image position `at`.
    fn mean_near(img: &[u8], w: usize, at: [f64; 2], radius: f64) -> f64 {
        let (mut sum, mut n) = (0.0, 0.0);
        for k in 0..img.len() / 3 {
            let (i, j) = (k % w, k / w);
            if (i as f64 + 0.5 - at[0]).hypot(j as f64 + 0.5 - at[1]) < radius {
                sum += grey(img, w, i, j);
                n += 1.0;
            }
        }
        sum / n
    }

    #[test]
    fn no_ageing_changes_nothing() {
        let base = small_with_flaws();
        let mut aged = base.clone();
        Ageing::default().apply_to_sensor(&mut aged);
        assert_eq!(aged, base);
        let mut bench = BenchConfig::default();
        Ageing::default().apply_to_bench(&mut bench);
        assert_eq!(bench, BenchConfig::default());
        assert!(Ageing::default().is_none());
    }

    /// A sensor file's own flaws stay when `[sim.ageing]` adds its own.
    fn small_with_flaws() -> SensorConfig {
        let mut c = bright();
        c.leds.out = vec![5];
        c.surface.scratches.push(Scratch {
            from_mm: [0.0, -10.0],
            to_mm: [0.0, 10.0],
            width_mm: 0.3,
            stress_fringes: 0.4,
            scatter_dn: 30.0,
        });
        c
    }

    #[test]
    fn leds_out_and_scratches_add_to_the_sensor_files_own() {
        let mut c = small_with_flaws();
        let ageing = Ageing {
            leds_out: vec![2, 5],
            scratches: vec![Scratch {
                from_mm: [1.0, 1.0],
                to_mm: [2.0, 2.0],
                width_mm: 0.5,
                stress_fringes: 1.0,
                scatter_dn: 10.0,
            }],
            ..Ageing::default()
        };
        ageing.apply_to_sensor(&mut c);
        assert_eq!(c.dead_leds(), vec![2, 5]);
        assert_eq!(c.surface.scratches.len(), 2);
        c.validate("aged")
            .expect("an aged sensor is a valid sensor");
    }

    #[test]
    fn a_camera_shift_moves_the_disc_by_as_many_pixels() {
        let mut base = bright();
        base.leds.count = 0;
        let (r, before) = aged_frame(&base, &Ageing::default());
        let shift = Ageing {
            camera_shift_px: [5.0, -3.0],
            ..Ageing::default()
        };
        let (_, after) = aged_frame(&base, &shift);
        let w = r.width() as usize;
        let a = bright_centroid(&before, w, 40.0);
        let b = bright_centroid(&after, w, 40.0);
        eprintln!("disc centroid {a:?} -> {b:?}");
        assert!((b[0] - a[0] - 5.0).abs() < 0.1, "{a:?} -> {b:?}");
        assert!((b[1] - a[1] + 3.0).abs() < 0.1, "{a:?} -> {b:?}");
    }

    #[test]
    fn a_camera_rotation_turns_the_led_ring_about_the_optical_centre() {
        let base = bright();
        let (r, before) = aged_frame(&base, &Ageing::default());
        let turn = Ageing {
            camera_rotation_deg: 10.0,
            ..Ageing::default()
        };
        let (turned, after) = aged_frame(&base, &turn);
        let w = r.width() as usize;
        let leds = &base.leds;
        let ring_mm = leds.radius_factor * base.geometry.disc_radius_px / base.geometry.px_per_mm;
        let a = leds.phase_deg.to_radians();
        let (x, y) = (ring_mm * a.cos(), ring_mm * a.sin());
        let old = r.geometry().to_pixel(x, y);
        let new = turned.geometry().to_pixel(x, y);
        assert!((old[0] - new[0]).hypot(old[1] - new[1]) > 10.0);
        let (spot_before, spot_after) = (
            mean_near(&before, w, old, 2.0),
            mean_near(&after, w, new, 2.0),
        );
        let (left_before, left_after) = (
            mean_near(&after, w, old, 2.0),
            mean_near(&before, w, new, 2.0),
        );
        eprintln!("hot spot {spot_before} -> {spot_after}; left behind {left_before}, where it went before {left_after}");
        // Sampled on another pixel grid: equal within a few DN of a 160 DN peak.
        assert!((spot_before - spot_after).abs() < 0.06 * spot_before);
        assert!(spot_after > left_before + 30.0 && spot_after > left_after + 30.0);
    }

    #[test]
    fn a_dead_led_loses_its_hot_spot_and_darkens_its_side_most() {
        let base = bright();
        let (r, before) = aged_frame(&base, &Ageing::default());
        let dead = Ageing {
            leds_out: vec![0],
            ..Ageing::default()
        };
        let (_, after) = aged_frame(&base, &dead);
        let w = r.width() as usize;
        let g = r.geometry();
        let leds = &base.leds;
        let ring_mm = leds.radius_factor * base.geometry.disc_radius_px / base.geometry.px_per_mm;
        let disc_mm = base.geometry.disc_radius_px / base.geometry.px_per_mm;
        let at = |n: u32, radius_mm: f64| {
            let a = (leds.phase_deg + 360.0 * f64::from(n) / f64::from(leds.count)).to_radians();
            g.to_pixel(radius_mm * a.cos(), radius_mm * a.sin())
        };
        // LED 0's hot spot is gone, its neighbour's stays.
        let (spot0, spot1) = (at(0, ring_mm), at(1, ring_mm));
        let lost = mean_near(&before, w, spot0, 2.0) - mean_near(&after, w, spot0, 2.0);
        let kept = mean_near(&before, w, spot1, 2.0) - mean_near(&after, w, spot1, 2.0);
        eprintln!("hot spot 0 lost {lost} DN, hot spot 1 {kept} DN");
        assert!(lost > 60.0, "{lost}");
        assert!(kept.abs() < 8.0, "{kept}");
        // Inside the disc at 0.7 R: on its side the light falls by (1 + 0.7) / 12, opposite by
        // (1 - 0.7) / 12.
        let ratio = |p: [f64; 2]| mean_near(&after, w, p, 5.0) / mean_near(&before, w, p, 5.0);
        let near = ratio(at(0, 0.7 * disc_mm));
        let far = ratio(at(6, 0.7 * disc_mm));
        eprintln!("light left beside the dead LED {near}, opposite {far}");
        assert!((near - (1.0 - 1.7 / 12.0)).abs() < 0.03, "{near}");
        assert!((far - (1.0 - 0.3 / 12.0)).abs() < 0.03, "{far}");
    }

    #[test]
    fn dimming_lowers_the_disc_by_the_percentage() {
        let mut base = bright();
        base.optics.ambient_dn = 0.0;
        let (r, before) = aged_frame(&base, &Ageing::default());
        let dim = Ageing {
            led_dimming_pct: 20.0,
            ..Ageing::default()
        };
        let (_, after) = aged_frame(&base, &dim);
        let w = r.width() as usize;
        let pixels = disc_pixels(&r, 0.8);
        let mean = |img: &[u8]| {
            pixels.iter().map(|&(i, j)| grey(img, w, i, j)).sum::<f64>() / pixels.len() as f64
        };
        let ratio = mean(&after) / mean(&before);
        eprintln!(
            "mean disc brightness {} -> {} ({ratio})",
            mean(&before),
            mean(&after)
        );
        assert!((ratio - 0.8).abs() < 0.01, "{ratio}");
    }

    #[test]
    fn a_scratch_brightens_a_thin_line_and_nothing_far_from_it() {
        let base = quiet(SensorConfig::layered());
        let (r, before) = aged_frame(&base, &Ageing::default());
        let scratch = Scratch {
            from_mm: [-8.0, 3.0],
            to_mm: [8.0, 3.0],
            width_mm: 0.3,
            stress_fringes: 0.4,
            scatter_dn: 30.0,
        };
        let scratched = Ageing {
            scratches: vec![scratch.clone()],
            ..Ageing::default()
        };
        let (_, after) = aged_frame(&base, &scratched);
        let w = r.width() as usize;
        let g = r.geometry();
        let (mut on_line, mut n_on) = (0.0, 0.0);
        let mut changed_far = 0;
        for k in 0..before.len() / 3 {
            let (i, j) = (k % w, k / w);
            let p = g.to_sensor(i as f64 + 0.5, j as f64 + 0.5);
            let d_px = scratch.distance_mm(p) * g.px_per_mm;
            let diff = grey(&after, w, i, j) - grey(&before, w, i, j);
            if d_px < 0.5 && p[0].abs() < 7.0 {
                on_line += diff;
                n_on += 1.0;
            }
            if d_px > 7.0 && before[3 * k..3 * k + 3] != after[3 * k..3 * k + 3] {
                changed_far += 1;
            }
        }
        let on_line = on_line / n_on;
        eprintln!(
            "along the scratch +{on_line} DN over {n_on} px; {changed_far} px changed far off"
        );
        assert!(on_line > 15.0, "{on_line}");
        assert_eq!(changed_far, 0);
    }

    #[test]
    fn a_higher_fringe_value_lowers_the_fringe_order_of_a_press() {
        for target_fringes in [0.0, 3.0] {
            let mut base = quiet(SensorConfig::integrated());
            base.layer.target_fringes = target_fringes;
            let (mut r, _) = aged_frame(&base, &Ageing::default());
            let stiffer = Ageing {
                fringe_value_pct: 10.0,
                ..Ageing::default()
            };
            let (mut aged, _) = aged_frame(&base, &stiffer);
            let f_ratio = aged.f_sigma_n_per_m() / r.f_sigma_n_per_m();
            assert!((f_ratio - 1.1).abs() < 1e-9, "f_sigma ratio {f_ratio}");
            let press = contact(r.config().rectangle(), 6.0, 2.0, -1.0, 10.0);
            let a = r.fringe_order_map(&press);
            let b = aged.fringe_order_map(&press);
            let peak = a.iter().copied().fold(0.0f32, f32::max);
            assert!(peak > 0.5, "{peak}");
            for (x, y) in a.iter().zip(&b) {
                assert!((f64::from(*y) * 1.1 - f64::from(*x)).abs() <= 1e-5 * f64::from(peak));
            }
        }
    }

    #[test]
    fn a_softer_gel_gives_less_force_at_a_depth_and_larger_sphere_contacts() {
        let soft = Ageing {
            modulus_pct: -20.0,
            ..Ageing::default()
        };
        let mut bench = BenchConfig::default();
        soft.apply_to_bench(&mut bench);
        let tip = SensorConfig::layered()
            .indenter_tip("pentagon")
            .expect("pentagon");
        let depth = Millimetres(0.8);
        let before = elastic_force(&BenchConfig::default().material, tip.geometry(), depth).0;
        let after = elastic_force(&bench.material, tip.geometry(), depth).0;
        assert!((after / before - 0.8).abs() < 1e-9, "{before} -> {after}");
        let mut sensor = SensorConfig::layered();
        let radius = |s: &SensorConfig| match s.sphere(9.0) {
            crate::physics::indenter::Shape::Sphere {
                contact_radius_mm, ..
            } => contact_radius_mm,
            other => panic!("not a sphere: {other:?}"),
        };
        let r0 = radius(&sensor);
        soft.apply_to_sensor(&mut sensor);
        assert!(radius(&sensor) > r0 * 1.05, "{r0} -> {}", radius(&sensor));
    }

    #[test]
    fn check_names_the_key_and_the_range() {
        let sensor = SensorConfig::layered();
        for (ageing, key, range) in [
            (
                Ageing {
                    fringe_value_pct: -80.0,
                    ..Ageing::default()
                },
                "sim.ageing.fringe_value_pct",
                "-50..=100",
            ),
            (
                Ageing {
                    led_dimming_pct: f64::NAN,
                    ..Ageing::default()
                },
                "sim.ageing.led_dimming_pct",
                "0..=100",
            ),
            (
                Ageing {
                    camera_shift_px: [0.0, 900.0],
                    ..Ageing::default()
                },
                "sim.ageing.camera_shift_px",
                "-500..=500",
            ),
            (
                Ageing {
                    leds_out: vec![12],
                    ..Ageing::default()
                },
                "sim.ageing.leds_out",
                "0..12",
            ),
            (
                Ageing {
                    scratches: vec![Scratch {
                        from_mm: [0.0, 0.0],
                        to_mm: [1.0, 0.0],
                        width_mm: -1.0,
                        stress_fringes: 0.4,
                        scatter_dn: 30.0,
                    }],
                    ..Ageing::default()
                },
                "sim.ageing.scratches[0].width_mm",
                "(0, 5]",
            ),
        ] {
            let e = ageing.check_for(&sensor).expect_err(key).to_string();
            assert!(e.contains(key) && e.contains(range), "{e}");
        }
        // Unknown keys are refused with the allowed ones.
        let e = toml::from_str::<Ageing>("fringe_pct = 3.0\n")
            .expect_err("unknown key")
            .to_string();
        assert!(
            e.contains("fringe_pct") && e.contains("fringe_value_pct"),
            "{e}"
        );
    }
}
