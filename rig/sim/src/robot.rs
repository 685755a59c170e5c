//! The simulated robot: presses on the sensor at random places, forces and indenters, as a
//! gripper would, driving the simulated bench's motors directly (no controller, no F/T driver:
//! `fringe stream` runs only the camera and the unit's model). Each press is kept with its times,
//! so the stream's predictions can be scored against the truth.
//!
//! A [`Robot`] is a state machine advanced by [`Robot::tick`] at any host time (real or, in
//! tests, synthetic): lift clear of the surface, change the indenter while lifted, travel over a
//! random point of the disc, descend until the true normal force reaches the press's target,
//! dwell, lift again.

use crate::bench::{Bench, MountedIndenter};
use crate::optics::sensor::SensorConfig;
use fringe_rig::{
    HostTime, Kinematics, Millimetres, MillimetresPerSecond, MillimetresPerSecondSquared,
};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use std::sync::Arc;
use std::time::Duration;

/// How the robot presses.
#[derive(Debug, Clone, PartialEq)]
pub struct RobotConfig {
    pub seed: u64,
    /// Target normal forces are drawn uniformly from this range, N.
    pub force_n: [f64; 2],
    /// Press centres are drawn uniformly over this share of the disc's radius.
    pub reach: f64,
    /// Time held at the target force.
    pub dwell: Duration,
    /// Height above the surface for lateral moves, mm.
    pub lift_mm: f64,
    /// The indenters pressed, drawn at random for each press (the sensor's shape names).
    pub shapes: Vec<String>,
    /// z speed while descending to the target force, mm/s.
    pub descend_mm_s: f64,
}

impl Default for RobotConfig {
    fn default() -> Self {
        RobotConfig {
            seed: 1,
            force_n: [1.0, 8.0],
            reach: 0.8,
            dwell: Duration::from_millis(800),
            lift_mm: 1.0,
            shapes: vec!["pentagon".into(), "rectangle".into()],
            descend_mm_s: 1.0,
        }
    }
}

/// A press the robot made (or is making).
#[derive(Debug, Clone, PartialEq)]
pub struct RobotPress {
    /// When the descent began.
    pub start: HostTime,
    /// When it began to lift (`None` while pressing).
    pub end: Option<HostTime>,
    /// The indenter's centre in the sensor frame, mm.
    pub x_mm: f64,
    pub y_mm: f64,
    pub shape: String,
    pub target_n: f64,
    /// The largest true normal force of the press, N.
    pub peak_n: f64,
}

/// A robot that cannot press as asked.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum RobotError {
    #[error("the simulated robot cannot mount a {0:?} indenter: the sensor has pentagon, rectangle, circle and sphere")]
    UnknownShape(String),
    #[error("the simulated robot's force range {0:?} N is not a range of positive forces")]
    ForceRange([f64; 2]),
    #[error("the simulated robot presses with no indenter: give at least one shape")]
    NoShapes,
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Phase {
    /// z going up to the lift height; then the next press is chosen.
    Lifting,
    /// x and y going to the press's point.
    Travelling,
    /// z going down until the target force.
    Descending,
    /// Held at the force until the time given.
    Dwelling(HostTime),
}

/// The simulated robot (see the module).
pub struct Robot {
    bench: Arc<Bench>,
    sensor: SensorConfig,
    config: RobotConfig,
    rng: StdRng,
    phase: Phase,
    presses: Vec<RobotPress>,
    started: bool,
}

/// `t` plus `d`.
fn later(t: HostTime, d: Duration) -> HostTime {
    HostTime(t.0.saturating_add(d.as_nanos() as u64))
}

/// Within this distance a motor has arrived, mm.
const ARRIVED_MM: f64 = 1e-3;

impl Robot {
    pub fn new(
        bench: Arc<Bench>,
        sensor: SensorConfig,
        config: RobotConfig,
    ) -> Result<Robot, RobotError> {
        if config.shapes.is_empty() {
            return Err(RobotError::NoShapes);
        }
        if let Some(s) = config
            .shapes
            .iter()
            .find(|s| sensor.indenter_tip(s).is_none())
        {
            return Err(RobotError::UnknownShape(s.clone()));
        }
        let [lo, hi] = config.force_n;
        if !(lo > 0.0 && hi >= lo && hi.is_finite()) {
            return Err(RobotError::ForceRange(config.force_n));
        }
        Ok(Robot {
            bench,
            sensor,
            rng: StdRng::seed_from_u64(config.seed),
            config,
            phase: Phase::Lifting,
            presses: Vec::new(),
            started: false,
        })
    }

    /// The presses made so far, the last one possibly under way.
    pub fn presses(&self) -> &[RobotPress] {
        &self.presses
    }

    /// Advances the robot to host time `t` (call it every few milliseconds).
    pub fn tick(&mut self, t: HostTime) {
        let truth = self.bench.truth_at(t);
        let (mx, my, mz) = (
            self.bench.motor_x(),
            self.bench.motor_y(),
            self.bench.motor_z(),
        );
        if !self.started {
            self.started = true;
            self.lift(t, truth.x.0, truth.y.0);
            return;
        }
        if let Some(p) = self.presses.last_mut() {
            if p.end.is_none() {
                p.peak_n = p.peak_n.max(truth.normal_force.0);
            }
        }
        match self.phase {
            Phase::Lifting => {
                if !mz.status_at(t).moving {
                    self.next_press(t);
                }
            }
            Phase::Travelling => {
                if !mx.status_at(t).moving && !my.status_at(t).moving {
                    let Some(p) = self.presses.last_mut() else {
                        return;
                    };
                    p.start = t;
                    let (x, y) = (Millimetres(p.x_mm), Millimetres(p.y_mm));
                    // Deep enough for any force the range asks; stopped on the force.
                    let bottom = self.bench.z_for_depth(x, y, Millimetres(4.0));
                    mz.set_kinematics(Kinematics {
                        velocity: MillimetresPerSecond(self.config.descend_mm_s),
                        acceleration: MillimetresPerSecondSquared(50.0),
                    });
                    mz.move_to(t, Millimetres(bottom.0 - mz.zero_offset().0));
                    self.phase = Phase::Descending;
                }
            }
            Phase::Descending => {
                let target = self.presses.last().map_or(0.0, |p| p.target_n);
                if truth.normal_force.0 >= target || !mz.status_at(t).moving {
                    mz.stop(t, true);
                    self.phase = Phase::Dwelling(later(t, self.config.dwell));
                }
            }
            Phase::Dwelling(until) => {
                if t >= until {
                    if let Some(p) = self.presses.last_mut() {
                        p.end = Some(t);
                    }
                    self.lift(t, truth.x.0, truth.y.0);
                }
            }
        }
    }

    /// Starts z up to the lift height over sensor-frame (x, y).
    fn lift(&mut self, t: HostTime, x: f64, y: f64) {
        let mz = self.bench.motor_z();
        mz.set_kinematics(Kinematics {
            velocity: MillimetresPerSecond(10.0),
            acceleration: MillimetresPerSecondSquared(100.0),
        });
        let up = self.bench.z_for_depth(
            Millimetres(x),
            Millimetres(y),
            Millimetres(-self.config.lift_mm),
        );
        let target = up.0 - mz.zero_offset().0;
        if (mz.status_at(t).position.0 - target).abs() > ARRIVED_MM {
            mz.move_to(t, Millimetres(target));
        }
        self.phase = Phase::Lifting;
    }

    /// Chooses the next press, mounts its indenter (lifted) and sends x and y over it.
    fn next_press(&mut self, t: HostTime) {
        let g = &self.bench.config().geometry;
        let r = self.config.reach * g.disc_radius_mm * self.rng.gen::<f64>().sqrt();
        let a = self.rng.gen::<f64>() * std::f64::consts::TAU;
        let (x, y) = (r * a.cos(), r * a.sin());
        let shape = self.config.shapes[self.rng.gen_range(0..self.config.shapes.len())].clone();
        let [lo, hi] = self.config.force_n;
        let target_n = lo + (hi - lo) * self.rng.gen::<f64>();
        if let Some(tip) = self.sensor.indenter_tip(&shape) {
            self.bench.set_indenter(MountedIndenter {
                tip,
                angle_deg: 0.0,
            });
        }
        let (sx, sy) = self.bench.stage_xy_for(Millimetres(x), Millimetres(y));
        for (motor, to) in [(self.bench.motor_x(), sx), (self.bench.motor_y(), sy)] {
            motor.set_kinematics(Kinematics {
                velocity: MillimetresPerSecond(20.0),
                acceleration: MillimetresPerSecondSquared(200.0),
            });
            motor.move_to(t, Millimetres(to.0 - motor.zero_offset().0));
        }
        self.presses.push(RobotPress {
            start: t,
            end: None,
            x_mm: x,
            y_mm: y,
            shape,
            target_n,
            peak_n: 0.0,
        });
        self.phase = Phase::Travelling;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bench::BenchConfig;

    /// Ten seconds of robot on synthetic time: presses at different places and forces, each
    /// reaching its target (within what one 5 ms step of a 1 mm/s descent adds), none off the
    /// disc, the force back to zero between presses.
    #[test]
    fn the_robot_presses_at_random_places_to_its_target_forces_and_lifts_between() {
        let bench = Bench::new(BenchConfig::default());
        let sensor = SensorConfig::layered();
        let mut robot = Robot::new(bench.clone(), sensor, RobotConfig::default()).expect("robot");
        let t0 = HostTime::now();
        let step = Duration::from_millis(5);
        let mut t = t0;
        let mut lifted_between = 0;
        let mut was_pressing = false;
        for _ in 0..(20_000 / 5) {
            robot.tick(t);
            let f = bench.truth_at(t).normal_force.0;
            if was_pressing && f <= 0.0 {
                lifted_between += 1;
            }
            was_pressing = f > 0.0;
            t = later(t, step);
        }
        let done: Vec<&RobotPress> = robot.presses().iter().filter(|p| p.end.is_some()).collect();
        assert!(done.len() >= 4, "{:?}", robot.presses());
        assert!(lifted_between >= done.len() - 1, "{lifted_between} lifts");
        let r = bench.config().geometry.disc_radius_mm;
        for p in &done {
            assert!(p.x_mm.hypot(p.y_mm) <= 0.8 * r + 1e-9, "{p:?}");
            assert!(
                p.peak_n >= p.target_n && p.peak_n < p.target_n + 0.5,
                "{p:?}"
            );
        }
        let places: std::collections::BTreeSet<i64> =
            done.iter().map(|p| (p.x_mm * 10.0) as i64).collect();
        assert!(places.len() >= 3, "{done:?}");
    }

    #[test]
    fn a_robot_asked_for_an_unknown_indenter_or_no_force_is_refused() {
        let bench = Bench::new(BenchConfig::default());
        let bad = RobotConfig {
            shapes: vec!["star".into()],
            ..RobotConfig::default()
        };
        assert_eq!(
            Robot::new(bench.clone(), SensorConfig::layered(), bad).err(),
            Some(RobotError::UnknownShape("star".into()))
        );
        let bad = RobotConfig {
            force_n: [0.0, 2.0],
            ..RobotConfig::default()
        };
        assert!(matches!(
            Robot::new(bench, SensorConfig::layered(), bad).err(),
            Some(RobotError::ForceRange(_))
        ));
    }
}
