//! Slides: a press that, once at its normal force, moves the indenter sideways while z holds
//! that force, to record shear and the onset of slip.
//!
//! ```toml
//! [slide]
//! directions = ["x", "-y", 45.0]   # "x", "-x", "y", "-y", or degrees in the sensor frame (0 = +x, 90 = +y)
//! distance = 2.0                   # mm slid
//! speeds = [0.5, 2.0]              # mm/s; every direction at every speed
//! dwell = 0.5                      # s held at the end of the slide before the lift
//! [safety]
//! tangential_ceiling = 8.0         # N of |Fx, Fy| never to exceed (default: force_ceiling)
//! ```
//!
//! Every (force target, direction, speed) is a press of its own: approach, press to the target,
//! the indentation dwell, the slide, the slide's dwell, lift. The stage axes move along a
//! straight line: each axis gets its share of the speed and of the acceleration, so both follow
//! the same trapezoid in time.

use crate::axis::Kinematics;
use crate::units::{Millimetres, MillimetresPerSecond, MillimetresPerSecondSquared, Newtons};

/// The longest slide, mm (the discs are about 25 mm across).
pub(crate) const MAX_SLIDE: Millimetres = Millimetres(20.0);
/// The slowest slide, mm/s.
pub(crate) const MIN_SLIDE_SPEED: f64 = 0.01;
/// The most slides (directions x speeds) per force target.
pub(crate) const MAX_SLIDES: usize = 100;

/// A slide direction as written: an axis name or degrees.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(untagged)]
pub enum Direction {
    /// Degrees in the sensor frame, counter-clockwise from +x.
    Degrees(f64),
    /// "x", "-x", "+x", "y", "-y", "+y".
    Axis(String),
}

impl Direction {
    /// The direction in degrees, or why it is not one (for `key`).
    pub fn degrees(&self, key: &str) -> Result<f64, String> {
        match self {
            Direction::Degrees(d) if d.is_finite() => Ok(*d),
            Direction::Degrees(d) => Err(format!("key {key}: {d} is not a number of degrees")),
            Direction::Axis(a) => match a.trim() {
                "x" | "+x" => Ok(0.0),
                "y" | "+y" => Ok(90.0),
                "-x" => Ok(180.0),
                "-y" => Ok(270.0),
                other => Err(format!(
                    "key {key}: {other:?} is not a direction; give \"x\", \"-x\", \"y\", \"-y\" or degrees in the sensor frame (0 = +x, 90 = +y)"
                )),
            },
        }
    }
}

/// `[slide]` as written.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SlideSection {
    /// Where to slide: each direction is a slide of its own.
    pub directions: Vec<Direction>,
    /// How far, mm.
    pub distance: f64,
    /// How fast, mm/s: every direction at every speed.
    pub speeds: Vec<f64>,
    /// Seconds held at the end of the slide before the lift.
    #[serde(default)]
    pub dwell: f64,
}

/// One slide of the program: after the press to `force`, `distance` along `direction_deg` at
/// `speed`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Slide {
    /// The normal force held during the slide.
    pub force: Newtons,
    /// Degrees in the sensor frame, counter-clockwise from +x.
    pub direction_deg: f64,
    pub distance: Millimetres,
    pub speed: MillimetresPerSecond,
}

/// How the stage axes make a slide: their shares of the speed and acceleration of one trapezoid
/// along the line.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SlideMotion {
    /// The trapezoid along the line.
    pub along: Kinematics,
    /// The unit vector of the slide (x, y).
    pub unit: [f64; 2],
    /// Each axis's share, `None` for an axis that does not move (a slide along the other).
    pub x: Option<Kinematics>,
    pub y: Option<Kinematics>,
}

/// Shares of a line below this fraction are taken as no motion of that axis (a slide along
/// "x" written as 0 degrees has a y share of 1e-17, not a move).
const NO_SHARE: f64 = 1e-9;

impl Slide {
    /// The unit vector of the slide's direction.
    pub fn unit(&self) -> [f64; 2] {
        let r = self.direction_deg.to_radians();
        let (s, c) = r.sin_cos();
        let tidy = |v: f64| if v.abs() < NO_SHARE { 0.0 } else { v };
        [tidy(c), tidy(s)]
    }

    /// Where a slide from stage (`x`, `y`) ends.
    pub fn end_from(&self, x: Millimetres, y: Millimetres) -> (Millimetres, Millimetres) {
        let [ux, uy] = self.unit();
        (
            Millimetres(x.0 + ux * self.distance.0),
            Millimetres(y.0 + uy * self.distance.0),
        )
    }

    /// The motion of the axes: the slide's speed along the line, with the largest acceleration
    /// no axis exceeds its own with.
    pub fn motion(&self, x: &Kinematics, y: &Kinematics) -> SlideMotion {
        let unit = self.unit();
        let limit = |k: &Kinematics, share: f64| {
            if share.abs() < NO_SHARE {
                f64::INFINITY
            } else {
                k.acceleration.0 / share.abs()
            }
        };
        let acceleration = limit(x, unit[0]).min(limit(y, unit[1]));
        let along = Kinematics {
            velocity: self.speed,
            acceleration: MillimetresPerSecondSquared(acceleration),
        };
        let share = |s: f64| {
            (s.abs() >= NO_SHARE).then(|| Kinematics {
                velocity: MillimetresPerSecond(along.velocity.0 * s.abs()),
                acceleration: MillimetresPerSecondSquared(along.acceleration.0 * s.abs()),
            })
        };
        SlideMotion {
            along,
            unit,
            x: share(unit[0]),
            y: share(unit[1]),
        }
    }
}

impl SlideMotion {
    /// How long the slide takes, s.
    pub fn seconds(&self, distance: f64) -> f64 {
        self.along.move_seconds(distance)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn k(v: f64, a: f64) -> Kinematics {
        Kinematics {
            velocity: MillimetresPerSecond(v),
            acceleration: MillimetresPerSecondSquared(a),
        }
    }

    fn slide(direction_deg: f64, speed: f64) -> Slide {
        Slide {
            force: Newtons(3.0),
            direction_deg,
            distance: Millimetres(2.0),
            speed: MillimetresPerSecond(speed),
        }
    }

    #[test]
    fn directions_are_axis_names_or_degrees() {
        let d = |s: &str| Direction::Axis(s.into()).degrees("slide.directions");
        assert_eq!(d("x"), Ok(0.0));
        assert_eq!(d("-y"), Ok(270.0));
        assert_eq!(d("+y"), Ok(90.0));
        let e = d("z").expect_err("z");
        assert!(
            e.starts_with("key slide.directions: \"z\" is not a direction"),
            "{e}"
        );
        assert_eq!(Direction::Degrees(45.0).degrees("k"), Ok(45.0));
        assert!(Direction::Degrees(f64::NAN).degrees("k").is_err());
    }

    #[test]
    fn a_diagonal_slide_shares_speed_and_acceleration_so_both_axes_run_one_trapezoid() {
        let m = slide(45.0, 1.0).motion(&k(8.0, 40.0), &k(8.0, 10.0));
        let h = std::f64::consts::FRAC_1_SQRT_2;
        // y's 10 mm/s² over its share sets the line's acceleration.
        assert!((m.along.acceleration.0 - 10.0 / h).abs() < 1e-9, "{m:?}");
        let (x, y) = (m.x.expect("x moves"), m.y.expect("y moves"));
        assert!((x.velocity.0 - h).abs() < 1e-12 && (y.acceleration.0 - 10.0).abs() < 1e-9);
        // Half way in time, each axis alone, with its share, is half way along the line.
        let t = m.seconds(2.0) / 2.0;
        let (px, py) = (x.travelled(2.0 * h, t), y.travelled(2.0 * h, t));
        assert!((px - h).abs() < 1e-9 && (py - h).abs() < 1e-9, "{px} {py}");
        assert!((m.along.travelled(2.0, t) - 1.0).abs() < 1e-9);
    }

    #[test]
    fn a_slide_along_an_axis_moves_only_that_axis() {
        let m = slide(180.0, 2.0).motion(&k(8.0, 40.0), &k(8.0, 40.0));
        assert!(m.y.is_none() && m.x.is_some(), "{m:?}");
        assert_eq!(
            slide(270.0, 2.0).end_from(Millimetres(10.0), Millimetres(20.0)),
            (Millimetres(10.0), Millimetres(18.0))
        );
    }
}
