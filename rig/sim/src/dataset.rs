//! Synthetic training frames straight from the renderer (`fringe sim dataset`): no motion, no
//! devices, only a scene and its label per frame.
//!
//! Each frame is drawn from its own generator, seeded from the dataset's seed and the frame's
//! index ([`frame`]), so frames can be made in any order, on any number of threads, and an
//! interrupted run continues with exactly the frames it would have made.
//!
//! **Draws.** With probability [`DatasetSpec::no_contact_fraction`] nothing touches the sensor.
//! Otherwise: a shape uniformly among [`DatasetSpec::shapes`]; a normal force uniform in
//! ([`FORCE_MIN`], `force_max`]; a contact point uniform over the disc area within (disc radius −
//! the indenter's half-size − [`EDGE_MARGIN_MM`]) of the centre, in the sensor frame of
//! [`Contact`] (mm from the disc centre along the stage axes, the frame scans label contacts in);
//! an indenter angle uniform in [0, 360) degrees. The renderer gets a frame number drawn from the
//! same generator, so noise, drift and flicker differ from frame to frame as in a long recording.
//!
//! **Labels.** The wrench the simulated F/T sensor would read: the true wrench of the normal force
//! on the default mount ([`FtMount::wrench_from_normal_force`]: Fz = −force, pressing, with the
//! moments of the tool's offset) plus the simulated sensor's white noise on all six channels
//! ([`FtNoiseConfig`] defaults: 0.05 N per force axis, 1.5 mN m per torque axis; a tared sensor:
//! no power-up bias or drift). No-contact frames carry that noise alone.

use crate::optics::sensor::SensorConfig;
use crate::physics::ft_config::{FtMount, FtNoiseConfig};
use crate::physics::indenter::Shape;
use crate::scene::{Contact, Scene};
use fringe_rig::seeded::{mix, SplitMix64};
use fringe_rig::{Millimetres, Newtons, Wrench};

/// The shapes a dataset can draw (sizes from the sensor file's `[indenters]`).
pub const SHAPES: [&str; 2] = ["pentagon", "rectangle"];

/// The lightest press, N (forces are drawn above it).
pub const FORCE_MIN: Newtons = Newtons(0.25);

/// `force_max` must exceed this, N (a range of forces, not one value).
pub const FORCE_MAX_LOWEST: Newtons = Newtons(0.3);

/// The sensor's safe maximum, N: the force ceiling of the built-in scan plans
/// (`safety.force_ceiling` in `tui/app/plans/short-grid.toml` and `demo.toml`, and the scan
/// engine's default ceiling); the bench never presses harder.
pub const FORCE_MAX_SAFE: Newtons = Newtons(12.0);

/// The most frames one dataset may hold.
pub const MAX_COUNT: u64 = 1_000_000;

/// The default share of frames without contact.
pub const NO_CONTACT_FRACTION: f64 = 0.1;

/// Contact points keep the indenter this far inside the disc edge, mm.
pub const EDGE_MARGIN_MM: f64 = 1.0;

/// What a dataset holds.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct DatasetSpec {
    /// Frames, numbered 0..count.
    pub count: u64,
    /// Shape names among [`SHAPES`].
    pub shapes: Vec<String>,
    /// The strongest press, N.
    pub force_max: Newtons,
    pub seed: u64,
    /// Share of frames without contact, 0..1.
    pub no_contact_fraction: f64,
}

/// A spec that cannot make a dataset: which setting, its value, and what is allowed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("dataset {key} = {value}: {allowed}")]
pub struct SpecError {
    /// The setting, named as the command-line flag without dashes (`count`, `shapes`,
    /// `force-max`, `no-contact-fraction`, `sensor`).
    pub key: &'static str,
    pub value: String,
    pub allowed: String,
}

impl DatasetSpec {
    /// A spec with the default share of no-contact frames.
    pub fn new(count: u64, shapes: Vec<String>, force_max: Newtons, seed: u64) -> DatasetSpec {
        DatasetSpec {
            count,
            shapes,
            force_max,
            seed,
            no_contact_fraction: NO_CONTACT_FRACTION,
        }
    }

    /// Checks every setting against the limits above and `sensor`'s disc (each shape must fit
    /// inside it with the margin).
    pub fn check(&self, sensor: &SensorConfig) -> Result<(), SpecError> {
        let err = |key, value: String, allowed: String| {
            Err(SpecError {
                key,
                value,
                allowed,
            })
        };
        if !(1..=MAX_COUNT).contains(&self.count) {
            return err(
                "count",
                self.count.to_string(),
                format!("use 1 to {MAX_COUNT} frames"),
            );
        }
        let f = self.force_max.0;
        if !(f.is_finite() && f > FORCE_MAX_LOWEST.0 && f <= FORCE_MAX_SAFE.0) {
            return err(
                "force-max",
                f.to_string(),
                format!(
                    "use a force above {} N and at most {} N (the sensor's safe maximum, the scan plans' force ceiling)",
                    FORCE_MAX_LOWEST.0, FORCE_MAX_SAFE.0
                ),
            );
        }
        let fraction = self.no_contact_fraction;
        if !(fraction.is_finite() && (0.0..=1.0).contains(&fraction)) {
            return err(
                "no-contact-fraction",
                fraction.to_string(),
                "use a share from 0 to 1".into(),
            );
        }
        if self.shapes.is_empty() {
            return err(
                "shapes",
                "(none)".into(),
                format!("name one or more of {}", SHAPES.join(", ")),
            );
        }
        for name in &self.shapes {
            let Some(shape) = shape_named(sensor, name) else {
                return err(
                    "shapes",
                    format!("{name:?}"),
                    format!("unknown shape: use {}", SHAPES.join(", ")),
                );
            };
            if reach_mm(sensor, &shape) <= 0.0 {
                return err(
                    "sensor",
                    format!("{:?}", sensor.id),
                    format!(
                        "its disc (radius {:.1} mm) is too small for the {name} (half-size {:.1} mm) with a {EDGE_MARGIN_MM} mm margin",
                        disc_radius_mm(sensor),
                        half_size_mm(&shape)
                    ),
                );
            }
        }
        Ok(())
    }
}

/// One frame of a dataset: what to render and its label.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SyntheticFrame {
    /// Position in the dataset (`image_<index>.png`).
    pub index: u64,
    /// The frame number to render the scene as (drives noise, drift and flicker).
    pub render_index: u64,
    pub scene: Scene,
    /// The shape's name, `None` without contact.
    pub shape: Option<&'static str>,
    /// The label: the F/T reading, N and N m, ATI tool frame (Fz negative while pressing).
    pub wrench: Wrench,
}

impl SyntheticFrame {
    /// The contact point, sensor frame, mm.
    pub fn contact_mm(&self) -> Option<[f64; 2]> {
        self.scene.contact.map(|c| [c.x.0, c.y.0])
    }
}

/// Frame `index` of the dataset `spec` on `sensor`: a pure function of (seed, index) for a given
/// spec and sensor. `spec` should have passed [`DatasetSpec::check`] (a frame whose shape name is
/// unknown has no contact).
pub fn frame(spec: &DatasetSpec, sensor: &SensorConfig, index: u64) -> SyntheticFrame {
    let mut rng = SplitMix64::new(mix(spec.seed, index));
    // Every draw is made for every frame, in one order, so the stream never shifts.
    let render_index = rng.next_u64() >> 32;
    let pressed = rng.uniform() >= spec.no_contact_fraction;
    let pick = rng.below(spec.shapes.len());
    let force_u = 1.0 - rng.uniform(); // (0, 1]
    let radius_u = rng.uniform();
    let bearing = rng.range(0.0..std::f64::consts::TAU);
    let angle_deg = rng.range(0.0..360.0);
    let noise: [f64; 6] = std::array::from_fn(|_| rng.normal());

    let named = spec
        .shapes
        .get(pick)
        .and_then(|n| SHAPES.iter().find(|s| **s == n.as_str()))
        .and_then(|n| shape_named(sensor, n).map(|s| (*n, s)));
    let contact = named.filter(|_| pressed).map(|(name, shape)| {
        let force = FORCE_MIN.0 + (spec.force_max.0 - FORCE_MIN.0) * force_u;
        let r = reach_mm(sensor, &shape).max(0.0) * radius_u.sqrt();
        (
            name,
            Contact {
                shape,
                force: Newtons(force),
                x: Millimetres(r * bearing.cos()),
                y: Millimetres(r * bearing.sin()),
                angle_deg,
                shear: None,
            },
        )
    });
    labelled(index, render_index, contact, &noise)
}

/// A frame of one press made off the bench clock (no motion): `contact`, the indenter named
/// `shape` (one of [`SHAPES`]) at a place and force the caller chose, or nothing, labelled as
/// [`frame`] labels its frames, the noise and the frame number to render drawn from `seed` and
/// `index` alone.
pub fn pressed_frame(
    seed: u64,
    index: u64,
    contact: Option<(&'static str, Contact)>,
) -> SyntheticFrame {
    let mut rng = SplitMix64::new(mix(seed, index));
    let render_index = rng.next_u64() >> 32;
    let noise: [f64; 6] = std::array::from_fn(|_| rng.normal());
    labelled(index, render_index, contact, &noise)
}

/// Frame `index`, rendered as frame number `render_index`, of `contact`, with the F/T reading
/// of it under `noise`.
fn labelled(
    index: u64,
    render_index: u64,
    contact: Option<(&'static str, Contact)>,
    noise: &[f64; 6],
) -> SyntheticFrame {
    SyntheticFrame {
        index,
        render_index,
        scene: Scene {
            contact: contact.map(|(_, c)| c),
        },
        shape: contact.map(|(name, _)| name),
        wrench: reading(contact.as_ref().map(|(_, c)| c), noise),
    }
}

/// What the simulated, tared F/T sensor reads under `contact`: its true wrench on the default
/// mount plus white noise (`noise`: one standard normal draw per axis).
fn reading(contact: Option<&Contact>, noise: &[f64; 6]) -> Wrench {
    let truth = match contact {
        Some(c) => FtMount::default().wrench_from_normal_force(c.force.0),
        None => Wrench::default(),
    };
    let n = FtNoiseConfig::default();
    let sigma = [
        n.force_noise_n,
        n.force_noise_n,
        n.force_noise_n,
        n.torque_noise_nm,
        n.torque_noise_nm,
        n.torque_noise_nm,
    ];
    let t = truth.to_array();
    Wrench::from_array(std::array::from_fn(|i| t[i] + sigma[i] * noise[i]))
}

/// The indenter called `name` (one of [`SHAPES`]) in `sensor`'s sizes.
pub fn shape_named(sensor: &SensorConfig, name: &str) -> Option<Shape> {
    match name {
        "pentagon" => Some(sensor.pentagon()),
        "rectangle" => Some(sensor.rectangle()),
        _ => None,
    }
}

/// The sensor disc's radius as imaged, mm.
pub fn disc_radius_mm(sensor: &SensorConfig) -> f64 {
    sensor.geometry.disc_radius_px / sensor.geometry.px_per_mm
}

/// The farthest point of the outline from the indenter's centre, mm (any angle fits in a circle
/// of this radius).
pub fn half_size_mm(shape: &Shape) -> f64 {
    match *shape {
        Shape::Pentagon { circumradius_mm } => circumradius_mm,
        Shape::Rectangle {
            width_mm,
            height_mm,
        } => 0.5 * width_mm.hypot(height_mm),
        Shape::Circle { radius_mm } => radius_mm,
        Shape::Sphere {
            contact_radius_mm, ..
        } => contact_radius_mm,
    }
}

/// How far from the centre the contact point of `shape` may lie, mm.
pub fn reach_mm(sensor: &SensorConfig, shape: &Shape) -> f64 {
    disc_radius_mm(sensor) - half_size_mm(shape) - EDGE_MARGIN_MM
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spec(seed: u64) -> DatasetSpec {
        DatasetSpec::new(
            2000,
            vec!["pentagon".into(), "rectangle".into()],
            Newtons(9.0),
            seed,
        )
    }

    #[test]
    fn a_press_frame_is_labelled_with_its_force_and_place() {
        let sensor = SensorConfig::layered();
        let contact = |force: f64| {
            let shape = shape_named(&sensor, "rectangle").expect("shape");
            Contact {
                shape,
                force: Newtons(force),
                x: Millimetres(3.0),
                y: Millimetres(-2.0),
                angle_deg: 0.0,
                shear: None,
            }
        };
        let a = pressed_frame(5, 17, Some(("rectangle", contact(6.0))));
        assert_eq!(a, pressed_frame(5, 17, Some(("rectangle", contact(6.0)))));
        assert_eq!(a.shape, Some("rectangle"));
        assert_eq!(a.contact_mm(), Some([3.0, -2.0]));
        // Fz reads the press (negative, pressing) within the F/T noise (0.05 N).
        assert!((a.wrench.fz.0 + 6.0).abs() < 0.3, "{:?}", a.wrench);
        let other = pressed_frame(5, 18, Some(("rectangle", contact(6.0))));
        assert_ne!(
            a.render_index, other.render_index,
            "each frame its own noise"
        );
        let free = pressed_frame(5, 19, None);
        assert_eq!(free.shape, None);
        assert!(free.wrench.fz.0.abs() < 0.3);
    }

    #[test]
    fn frames_depend_on_seed_and_index_only() {
        let sensor = SensorConfig::layered();
        let s = spec(7);
        let forward: Vec<_> = (0..50).map(|k| frame(&s, &sensor, k)).collect();
        let backward: Vec<_> = (0..50).rev().map(|k| frame(&s, &sensor, k)).collect();
        for (a, b) in forward.iter().zip(backward.iter().rev()) {
            assert_eq!(a, b);
        }
        // A longer dataset with the same seed starts with the same frames.
        let longer = DatasetSpec {
            count: 9000,
            ..s.clone()
        };
        assert_eq!(frame(&longer, &sensor, 13), forward[13]);
        let other = frame(&spec(8), &sensor, 13);
        assert_ne!(other, forward[13]);
        assert_ne!(forward[3].render_index, forward[4].render_index);
    }

    #[test]
    fn draws_stay_within_their_ranges() {
        for sensor in [SensorConfig::layered(), SensorConfig::integrated()] {
            let s = spec(11);
            s.check(&sensor).expect("valid spec");
            let n = FtNoiseConfig::default();
            let mut none = 0;
            let mut shapes = std::collections::BTreeMap::new();
            let (mut noise_sum, mut noise_sq, mut forces) = (0.0, 0.0, Vec::new());
            let mut far = 0.0f64;
            for k in 0..s.count {
                let f = frame(&s, &sensor, k);
                let fz = f.wrench.fz.0;
                match f.scene.contact {
                    None => {
                        none += 1;
                        assert!(f.shape.is_none());
                        assert!(fz.abs() < 5.0 * n.force_noise_n, "{fz}");
                    }
                    Some(c) => {
                        let name = f.shape.expect("named");
                        *shapes.entry(name).or_insert(0) += 1;
                        assert_eq!(shape_named(&sensor, name), Some(c.shape));
                        let force = c.force.0;
                        assert!(force > FORCE_MIN.0 && force <= 9.0, "{force}");
                        forces.push(force);
                        let r = c.x.0.hypot(c.y.0);
                        let reach = reach_mm(&sensor, &c.shape);
                        assert!(r <= reach, "{r} > {reach}");
                        far = far.max(r / reach);
                        assert!((0.0..360.0).contains(&c.angle_deg));
                        // Fz = -force plus the F/T noise.
                        let e = fz + force;
                        noise_sum += e;
                        noise_sq += e * e;
                        assert!(e.abs() < 5.0 * n.force_noise_n, "{e}");
                        // Moments from the tool's offset: |M| = force * 0.47 mm plus noise.
                        let m = f.wrench.tx.0.hypot(f.wrench.ty.0);
                        assert!(
                            (m - force * 0.4717e-3).abs() < 6.0 * n.torque_noise_nm,
                            "{m}"
                        );
                    }
                }
            }
            let share = none as f64 / s.count as f64;
            assert!((share - NO_CONTACT_FRACTION).abs() < 0.025, "{share}");
            assert_eq!(shapes.len(), 2, "{shapes:?}");
            assert!(shapes.values().all(|&v| v > 800), "{shapes:?}");
            let m = forces.len() as f64;
            let mean = forces.iter().sum::<f64>() / m;
            assert!((mean - 0.5 * (0.25 + 9.0)).abs() < 0.25, "{mean}");
            // Uniform over the area: points reach the edge, and half lie beyond 1/sqrt(2).
            assert!(far > 0.99, "{far}");
            let sd = (noise_sq / m - (noise_sum / m).powi(2)).sqrt();
            assert!((sd / n.force_noise_n - 1.0).abs() < 0.1, "{sd}");
        }
    }

    #[test]
    fn check_names_the_setting() {
        let sensor = SensorConfig::layered();
        let good = spec(1);
        assert!(good.check(&sensor).is_ok());
        let key = |s: DatasetSpec| s.check(&sensor).expect_err("refused").key;
        assert_eq!(
            key(DatasetSpec {
                count: 0,
                ..good.clone()
            }),
            "count"
        );
        assert_eq!(
            key(DatasetSpec {
                count: MAX_COUNT + 1,
                ..good.clone()
            }),
            "count"
        );
        for f in [f64::NAN, 0.3, -1.0, 12.5, f64::INFINITY] {
            assert_eq!(
                key(DatasetSpec {
                    force_max: Newtons(f),
                    ..good.clone()
                }),
                "force-max"
            );
        }
        assert!(DatasetSpec {
            force_max: FORCE_MAX_SAFE,
            ..good.clone()
        }
        .check(&sensor)
        .is_ok());
        let e = DatasetSpec {
            shapes: vec!["pentagon".into(), "hexagon".into()],
            ..good.clone()
        }
        .check(&sensor)
        .expect_err("unknown shape");
        assert!(
            e.key == "shapes" && e.allowed.contains("pentagon, rectangle"),
            "{e}"
        );
        let mut tiny = sensor.clone();
        tiny.geometry.disc_radius_px = 100.0;
        assert_eq!(good.check(&tiny).expect_err("too small").key, "sensor");
    }
}
