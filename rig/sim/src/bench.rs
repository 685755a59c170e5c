//! The physical bench: three stage motors, the mounted indenter, the sensor surface and the
//! contact between them.
//!
//! **Geometry.** Motor positions are mechanical (millimetres from each axis's reverse limit
//! switch, [`SimMotor::true_position_at`]). The indenter centre is over the sensor centre when x
//! and y stand at [`BenchGeometry::x_centre_mm`], [`BenchGeometry::y_centre_mm`]; the sensor frame
//! (scene.rs) has +x along the stage x, +y along the stage y, origin at the disc centre, so the
//! contact point is (x - x_centre, y - y_centre). The tip touches the nominal surface at
//! z = [`BenchGeometry::z_touch_mm`]; with [`BenchGeometry::z_down_positive`] (default) a larger z
//! lowers the indenter. Depth = (z - z_touch) + surface height under the indenter centre
//! (the signs flip with `z_down_positive = false`); off the disc there is no contact.
//!
//! **State.** One [`ContactModel`] is advanced under a mutex from the motors' true positions, in
//! sub-steps of at most [`BenchConfig::max_step_ms`], whenever a query asks for a later instant
//! than the last one; every sub-step is kept for [`BenchConfig::history_ms`] so that a query
//! slightly in the past (the camera asks for the middle of an exposure that has ended) is
//! interpolated. Queries before the history return its oldest state.

use crate::physics::contact::{
    contact_radius, ContactGeometry, ContactMaterial, ContactModel, SurfaceConfig, SurfaceHeight,
};
use crate::physics::ft_config::{FtMount, FtNoiseConfig};
use crate::physics::indenter::Shape;
use crate::physics::motion::{Kinematics, MotorSpec, SimMotor};
use crate::physics::sliding::Tangential;
use crate::scene::{Contact, LoadSource, Scene, SceneSource, Shear};
use fringe_rig::HostTime;
use fringe_rig::Slip;
use fringe_rig::{Millimetres, MillimetresPerSecond, MillimetresPerSecondSquared, Newtons, Wrench};
use std::collections::VecDeque;
use std::sync::{Arc, Mutex, MutexGuard};

/// Mechanical construction of one stage axis.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default)]
pub struct AxisConfig {
    /// Travel between the limit switches, mm.
    pub travel_mm: f64,
    /// Mechanical position at power-up, mm from the reverse limit.
    pub power_up_mm: f64,
    /// Default move speed, mm/s.
    pub velocity_mm_s: f64,
    /// Default move acceleration, mm/s^2.
    pub acceleration_mm_s2: f64,
}

impl Default for AxisConfig {
    /// A 50 mm stage at its middle, 2 mm/s, 4 mm/s^2.
    fn default() -> Self {
        AxisConfig {
            travel_mm: 50.0,
            power_up_mm: 25.0,
            velocity_mm_s: 2.0,
            acceleration_mm_s2: 4.0,
        }
    }
}

impl AxisConfig {
    /// The motor specification for an axis called `name`.
    pub fn spec(&self, name: &str) -> MotorSpec {
        MotorSpec {
            name: name.to_string(),
            travel: Millimetres(self.travel_mm),
            power_up_position: Millimetres(self.power_up_mm),
            kinematics: Kinematics {
                velocity: MillimetresPerSecond(self.velocity_mm_s),
                acceleration: MillimetresPerSecondSquared(self.acceleration_mm_s2),
            },
        }
    }
}

/// Where the sensor sits relative to the stages.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default)]
pub struct BenchGeometry {
    /// Mechanical x that puts the indenter centre over the sensor centre, mm.
    pub x_centre_mm: f64,
    /// Mechanical y that puts the indenter centre over the sensor centre, mm.
    pub y_centre_mm: f64,
    /// Mechanical z at which the tip touches the nominal sensor surface, mm.
    pub z_touch_mm: f64,
    /// A larger z position lowers the indenter towards the sensor.
    pub z_down_positive: bool,
    /// Radius of the soft disc, mm (no contact beyond it).
    pub disc_radius_mm: f64,
}

impl Default for BenchGeometry {
    fn default() -> Self {
        BenchGeometry {
            x_centre_mm: 25.0,
            y_centre_mm: 25.0,
            z_touch_mm: 15.0,
            z_down_positive: true,
            disc_radius_mm: 30.0,
        }
    }
}

/// An indenter tip as configured.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(tag = "shape", rename_all = "lowercase")]
pub enum IndenterTip {
    /// Regular pentagon flat punch (vertex on +y at angle 0).
    Pentagon { circumradius_mm: f64 },
    /// Rectangular flat punch, `width_mm` along x at angle 0.
    Rectangle { width_mm: f64, height_mm: f64 },
    /// Circular flat punch.
    Circle { radius_mm: f64 },
    /// Sphere.
    Sphere { radius_mm: f64 },
}

impl IndenterTip {
    /// Class name ("pentagon", "rectangle", "circle", "sphere").
    pub fn name(&self) -> &'static str {
        match self {
            IndenterTip::Pentagon { .. } => "pentagon",
            IndenterTip::Rectangle { .. } => "rectangle",
            IndenterTip::Circle { .. } => "circle",
            IndenterTip::Sphere { .. } => "sphere",
        }
    }

    /// Punch face area, mm^2 (sphere: 0, its contact grows with depth).
    pub fn area_mm2(&self) -> f64 {
        match *self {
            IndenterTip::Pentagon { circumradius_mm } => {
                2.5 * circumradius_mm * circumradius_mm * (2.0 * std::f64::consts::PI / 5.0).sin()
            }
            IndenterTip::Rectangle {
                width_mm,
                height_mm,
            } => width_mm * height_mm,
            IndenterTip::Circle { radius_mm } => std::f64::consts::PI * radius_mm * radius_mm,
            IndenterTip::Sphere { .. } => 0.0,
        }
    }

    /// The contact law's view: flat punches by the radius of the circle of equal area.
    pub fn geometry(&self) -> ContactGeometry {
        match *self {
            IndenterTip::Sphere { radius_mm } => ContactGeometry::Sphere { radius_mm },
            IndenterTip::Circle { radius_mm } => ContactGeometry::FlatPunch { radius_mm },
            _ => ContactGeometry::FlatPunch {
                radius_mm: (self.area_mm2() / std::f64::consts::PI).sqrt(),
            },
        }
    }

    /// The outline pressed into the sensor at `depth`.
    pub fn shape_at(&self, depth: Millimetres) -> Shape {
        match *self {
            IndenterTip::Pentagon { circumradius_mm } => Shape::Pentagon { circumradius_mm },
            IndenterTip::Rectangle {
                width_mm,
                height_mm,
            } => Shape::Rectangle {
                width_mm,
                height_mm,
            },
            IndenterTip::Circle { radius_mm } => Shape::Circle { radius_mm },
            IndenterTip::Sphere { radius_mm } => Shape::Sphere {
                radius_mm,
                contact_radius_mm: contact_radius(self.geometry(), depth).0,
            },
        }
    }
}

/// The indenter on the tool and how it is turned.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default)]
pub struct MountedIndenter {
    pub tip: IndenterTip,
    /// Rotation about the load axis, counter-clockwise seen from the indenter side, degrees.
    pub angle_deg: f64,
}

impl Default for MountedIndenter {
    /// The 5 mm pentagon, unturned.
    fn default() -> Self {
        MountedIndenter {
            tip: IndenterTip::Pentagon {
                circumradius_mm: 5.0,
            },
            angle_deg: 0.0,
        }
    }
}

/// Everything that makes a simulated bench.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default)]
pub struct BenchConfig {
    /// Seed of the surface height variation (the F/T noise has its own seed in `ft_noise`).
    pub seed: u64,
    pub x: AxisConfig,
    pub y: AxisConfig,
    pub z: AxisConfig,
    pub geometry: BenchGeometry,
    pub indenter: MountedIndenter,
    pub material: ContactMaterial,
    pub surface: SurfaceConfig,
    /// Where the indenter tip sits relative to the F/T origin.
    pub mount: FtMount,
    /// Noise, drift and bias of the F/T sensor built on this bench
    /// ([`crate::physics::ft_sensor::SimFtSensor`]).
    pub ft_noise: FtNoiseConfig,
    /// Longest contact-model step while advancing, ms.
    pub max_step_ms: f64,
    /// How far back queries are interpolated, ms.
    pub history_ms: f64,
}

impl Default for BenchConfig {
    fn default() -> Self {
        let stage = AxisConfig::default();
        BenchConfig {
            seed: 1,
            x: stage,
            y: stage,
            z: AxisConfig {
                travel_mm: 25.0,
                power_up_mm: 5.0,
                velocity_mm_s: 1.0,
                acceleration_mm_s2: 4.0,
            },
            geometry: BenchGeometry::default(),
            indenter: MountedIndenter::default(),
            material: ContactMaterial::default(),
            surface: SurfaceConfig::default(),
            mount: FtMount::default(),
            ft_noise: FtNoiseConfig::default(),
            max_step_ms: 1.0,
            history_ms: 500.0,
        }
    }
}

/// The true state of the bench at an instant (ground truth).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BenchTruth {
    pub t: HostTime,
    /// Mechanical x, y, z motor positions, mm from the reverse limits.
    pub motors: [Millimetres; 3],
    /// Indenter centre in the sensor frame.
    pub x: Millimetres,
    pub y: Millimetres,
    /// Indentation depth (negative = above the surface).
    pub depth: Millimetres,
    /// Normal force (positive = pressing).
    pub normal_force: Newtons,
    /// Tangential force the indenter applies to the surface, sensor frame [x, y], N.
    pub shear_n: [f64; 2],
    /// Share of the friction limit the tangential force uses: |Q| / (mu_s P) while the contact
    /// sticks, 1 while it slides.
    pub friction_used: f64,
    /// The indenter slides over the surface (gross slip).
    pub sliding: bool,
    pub indenter: MountedIndenter,
}

impl BenchTruth {
    fn lerp(a: &BenchTruth, b: &BenchTruth, t: HostTime) -> BenchTruth {
        let span = b.t.0.saturating_sub(a.t.0);
        if span == 0 {
            return BenchTruth { t, ..*b };
        }
        let w = (t.0.saturating_sub(a.t.0)) as f64 / span as f64;
        let mix = |p: f64, q: f64| p + (q - p) * w;
        BenchTruth {
            t,
            motors: std::array::from_fn(|i| Millimetres(mix(a.motors[i].0, b.motors[i].0))),
            x: Millimetres(mix(a.x.0, b.x.0)),
            y: Millimetres(mix(a.y.0, b.y.0)),
            depth: Millimetres(mix(a.depth.0, b.depth.0)),
            normal_force: Newtons(mix(a.normal_force.0, b.normal_force.0)),
            shear_n: [0, 1].map(|k| mix(a.shear_n[k], b.shear_n[k])),
            friction_used: mix(a.friction_used, b.friction_used),
            sliding: b.sliding,
            indenter: b.indenter,
        }
    }

    /// Whether the indenter presses on the sensor.
    pub fn in_contact(&self) -> bool {
        self.normal_force.0 > 0.0
    }

    /// How the contact holds (`None` without contact; see [`Contact::slip_state`]).
    pub fn slip_state(&self) -> Option<Slip> {
        Bench::contact_of(self).map(|c| c.slip_state())
    }

    /// The push along the surface the camera sees (`None` without one).
    pub fn shear(&self) -> Option<Shear> {
        let [qx, qy] = self.shear_n;
        let q = qx.hypot(qy);
        (q > 0.0 && self.in_contact()).then(|| Shear {
            force: Newtons(q),
            direction_deg: qy.atan2(qx).to_degrees(),
            friction_used: self.friction_used,
            sliding: self.sliding,
        })
    }
}

struct State {
    model: ContactModel,
    tangential: Tangential,
    indenter: MountedIndenter,
    history: VecDeque<BenchTruth>,
}

/// The simulated bench, shared (`Arc`) by the controller emulators, the F/T and the camera.
pub struct Bench {
    config: BenchConfig,
    motors: [Arc<SimMotor>; 3],
    surface: SurfaceHeight,
    /// The F/T wrench per newton of normal force (mount geometry, precomputed).
    unit_wrench: [f64; 6],
    state: Mutex<State>,
}

/// Most sub-steps a single advance takes (longer idle spans use longer, still exact, steps).
const MAX_STEPS: u64 = 20_000;

impl Bench {
    /// A bench with its own three motors, at rest at their power-up positions.
    pub fn new(config: BenchConfig) -> Arc<Bench> {
        let motors = [
            Arc::new(SimMotor::new(config.x.spec("x"))),
            Arc::new(SimMotor::new(config.y.spec("y"))),
            Arc::new(SimMotor::new(config.z.spec("z"))),
        ];
        Bench::with_motors(config, motors)
    }

    /// A bench on motors built elsewhere (x, y, z).
    pub fn with_motors(config: BenchConfig, motors: [Arc<SimMotor>; 3]) -> Arc<Bench> {
        let surface = SurfaceHeight::new(&config.surface, config.seed);
        let model = ContactModel::new(config.material.clone(), config.indenter.tip.geometry());
        let bench = Bench {
            state: Mutex::new(State {
                model,
                tangential: Tangential::new(&config.material),
                indenter: config.indenter,
                history: VecDeque::new(),
            }),
            unit_wrench: config.mount.wrench_from_normal_force(1.0).to_array(),
            config,
            motors,
            surface,
        };
        {
            let mut s = bench.lock();
            let t = HostTime::now();
            let first = bench.kinematic_truth(t, s.indenter);
            let force = s.model.advance(t, first.depth);
            s.history.push_back(BenchTruth {
                normal_force: force,
                ..first
            });
        }
        Arc::new(bench)
    }

    fn lock(&self) -> MutexGuard<'_, State> {
        // The state is replaced step by step; a panic mid-step leaves a usable state.
        self.state.lock().unwrap_or_else(|e| e.into_inner())
    }

    pub fn config(&self) -> &BenchConfig {
        &self.config
    }

    /// The x stage motor (shared with its controller emulator).
    pub fn motor_x(&self) -> Arc<SimMotor> {
        self.motors[0].clone()
    }

    /// The y stage motor.
    pub fn motor_y(&self) -> Arc<SimMotor> {
        self.motors[1].clone()
    }

    /// The z (indentation) motor.
    pub fn motor_z(&self) -> Arc<SimMotor> {
        self.motors[2].clone()
    }

    /// The indenter on the tool now.
    pub fn indenter(&self) -> MountedIndenter {
        self.lock().indenter
    }

    /// Mounts another indenter (the indenter-change prompt). The layer forgets its load history:
    /// change indenters with the tool lifted.
    pub fn set_indenter(&self, indenter: MountedIndenter) {
        let mut s = self.lock();
        s.indenter = indenter;
        s.model.set_geometry(indenter.tip.geometry());
    }

    /// The sensor surface height above nominal at sensor-frame (x, y).
    pub fn surface_height(&self, x: Millimetres, y: Millimetres) -> Millimetres {
        self.surface.height(x, y)
    }

    /// Mechanical x, y that put the indenter centre over sensor-frame (x, y).
    pub fn stage_xy_for(&self, x: Millimetres, y: Millimetres) -> (Millimetres, Millimetres) {
        (
            Millimetres(self.config.geometry.x_centre_mm + x.0),
            Millimetres(self.config.geometry.y_centre_mm + y.0),
        )
    }

    /// Mechanical z at which the tip first touches the surface over sensor-frame (x, y).
    pub fn z_first_contact(&self, x: Millimetres, y: Millimetres) -> Millimetres {
        let g = &self.config.geometry;
        let h = self.surface.height(x, y).0;
        Millimetres(if g.z_down_positive {
            g.z_touch_mm - h
        } else {
            g.z_touch_mm + h
        })
    }

    /// Mechanical z that presses `depth` into the surface over sensor-frame (x, y).
    pub fn z_for_depth(&self, x: Millimetres, y: Millimetres, depth: Millimetres) -> Millimetres {
        let first = self.z_first_contact(x, y).0;
        Millimetres(if self.config.geometry.z_down_positive {
            first + depth.0
        } else {
            first - depth.0
        })
    }

    /// Positions and depth at `t` (no force).
    fn kinematic_truth(&self, t: HostTime, indenter: MountedIndenter) -> BenchTruth {
        let motors: [Millimetres; 3] = std::array::from_fn(|i| self.motors[i].true_position_at(t));
        let g = &self.config.geometry;
        let x = Millimetres(motors[0].0 - g.x_centre_mm);
        let y = Millimetres(motors[1].0 - g.y_centre_mm);
        let on_disc = x.0.hypot(y.0) <= g.disc_radius_mm;
        let depth = if on_disc {
            let below = if g.z_down_positive {
                motors[2].0 - g.z_touch_mm
            } else {
                g.z_touch_mm - motors[2].0
            };
            Millimetres(below + self.surface.height(x, y).0)
        } else {
            Millimetres(f64::NEG_INFINITY)
        };
        BenchTruth {
            t,
            motors,
            x,
            y,
            depth,
            normal_force: Newtons(0.0),
            shear_n: [0.0; 2],
            friction_used: 0.0,
            sliding: false,
            indenter,
        }
    }

    fn advance(&self, s: &mut State, t: HostTime) {
        let Some(last) = s.history.back().map(|b| b.t) else {
            return;
        };
        if t <= last {
            return;
        }
        let span = t.0 - last.0;
        let step_ns = (self.config.max_step_ms.max(1e-3) * 1e6) as u64;
        let n = span.div_ceil(step_ns.max(1)).clamp(1, MAX_STEPS);
        let mut previous = last;
        for k in 1..=n {
            let tk = HostTime(last.0 + span * k / n);
            let mut truth = self.kinematic_truth(tk, s.indenter);
            // A depth of -inf (off the disc) is no contact.
            let depth = if truth.depth.0.is_finite() {
                truth.depth
            } else {
                Millimetres(-1.0)
            };
            truth.normal_force = s.model.advance(tk, depth);
            let radius = contact_radius(s.indenter.tip.geometry(), depth).0;
            let tangential = s.tangential.advance(
                &self.config.material,
                tk.since(previous).as_secs_f64(),
                [truth.x.0, truth.y.0],
                truth.normal_force.0,
                radius,
            );
            truth.shear_n = tangential.force;
            truth.friction_used = tangential.friction_used;
            truth.sliding = tangential.sliding;
            previous = tk;
            s.history.push_back(truth);
        }
        let keep_ns = (self.config.history_ms.max(1.0) * 1e6) as u64;
        while s.history.len() > 2 && s.history[1].t.0 + keep_ns < t.0 {
            s.history.pop_front();
        }
    }

    /// The true state at `t`: advances the contact when `t` is later than any earlier query,
    /// interpolates the history otherwise.
    pub fn truth_at(&self, t: HostTime) -> BenchTruth {
        let mut s = self.lock();
        self.advance(&mut s, t);
        let h = &s.history;
        let Some(last) = h.back() else {
            return self.kinematic_truth(t, s.indenter);
        };
        if t >= last.t {
            return BenchTruth { t, ..*last };
        }
        let i = h.partition_point(|b| b.t <= t);
        if i == 0 {
            return BenchTruth { t, ..h[0] };
        }
        BenchTruth::lerp(&h[i - 1], &h[i], t)
    }

    /// The contact a camera would see in a given true state.
    pub fn contact_of(truth: &BenchTruth) -> Option<Contact> {
        if !truth.in_contact() {
            return None;
        }
        Some(Contact {
            shape: truth.indenter.tip.shape_at(truth.depth),
            force: truth.normal_force,
            x: truth.x,
            y: truth.y,
            angle_deg: truth.indenter.angle_deg,
            shear: truth.shear(),
        })
    }
}

impl LoadSource for Bench {
    fn true_wrench_at(&self, t: HostTime) -> Wrench {
        let truth = self.truth_at(t);
        let n = truth.normal_force.0;
        let [qx, qy] = truth.shear_n;
        if qx == 0.0 && qy == 0.0 {
            return Wrench::from_array(self.unit_wrench.map(|u| u * n));
        }
        // The surface pushes the tip back against the push, and up.
        self.config.mount.wrench_from_tip_force([-qx, -qy, n])
    }
}

impl SceneSource for Bench {
    fn scene_at(&self, t: HostTime) -> Scene {
        Scene {
            contact: Bench::contact_of(&self.truth_at(t)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn after(t: HostTime, s: f64) -> HostTime {
        HostTime(t.0 + (s * 1e9) as u64)
    }

    #[test]
    fn equivalent_radius_of_the_pentagon_and_rectangle() {
        let p = IndenterTip::Pentagon {
            circumradius_mm: 5.0,
        };
        let ContactGeometry::FlatPunch { radius_mm } = p.geometry() else {
            panic!("pentagon is a flat punch");
        };
        assert!((radius_mm - 4.3494).abs() < 1e-3, "{radius_mm}");
        let r = IndenterTip::Rectangle {
            width_mm: 10.0,
            height_mm: 6.0,
        };
        assert!((r.area_mm2() - 60.0).abs() < 1e-12);
    }

    #[test]
    fn config_round_trips_through_toml_and_fills_defaults() {
        let config = BenchConfig::default();
        let text = toml::to_string(&config).expect("serialise");
        assert!(text.contains("shape = \"pentagon\""), "{text}");
        let back: BenchConfig = toml::from_str(&text).expect("parse");
        assert_eq!(back, config);
        let partial: BenchConfig = toml::from_str(
            "seed = 9\n[indenter]\nangle_deg = 30.0\n[indenter.tip]\nshape = \"rectangle\"\nwidth_mm = 8.0\nheight_mm = 6.0\n",
        )
        .expect("partial");
        assert_eq!(partial.seed, 9);
        assert_eq!(
            partial.indenter.tip,
            IndenterTip::Rectangle {
                width_mm: 8.0,
                height_mm: 6.0
            }
        );
        assert_eq!(partial.geometry, BenchGeometry::default());
    }

    #[test]
    fn lowering_z_over_an_offset_point_presses_there() {
        let config = BenchConfig {
            surface: SurfaceConfig {
                rms_um: 0.0,
                ..SurfaceConfig::default()
            },
            ..BenchConfig::default()
        };
        let bench = Bench::new(config);
        let t0 = HostTime::now();
        let (x, y) = bench.stage_xy_for(Millimetres(3.0), Millimetres(-4.0));
        bench.motor_x().move_to(t0, Millimetres(x.0 - 25.0));
        bench.motor_y().move_to(t0, Millimetres(y.0 - 25.0));
        // Counter zero is the power-up position (5 mm); z_touch is 15 mm mechanical.
        bench.motor_z().move_to(t0, Millimetres(10.0 + 1.0));
        let mut last = 0.0;
        for k in 1..=60 {
            let t = after(t0, 0.25 * k as f64);
            let truth = bench.truth_at(t);
            if truth.depth.0 < 0.8 {
                assert!(truth.normal_force.0 >= last, "{truth:?}");
                last = truth.normal_force.0;
            }
        }
        let t = after(t0, 15.0);
        let truth = bench.truth_at(t);
        assert!((truth.depth.0 - 1.0).abs() < 1e-9, "{truth:?}");
        assert!(truth.normal_force.0 > 5.0, "{truth:?}");
        let scene = bench.scene_at(t);
        let c = scene.contact.expect("pressing");
        assert!(
            (c.x.0 - 3.0).abs() < 1e-9 && (c.y.0 + 4.0).abs() < 1e-9,
            "{c:?}"
        );
        // Fz negative when pressing (ATI compression), |Fz| = normal force.
        let w = bench.true_wrench_at(t);
        assert!((w.fz.0 + truth.normal_force.0).abs() < 1e-9);
        // A query in the past interpolates the history, it does not rewind the model.
        let earlier = bench.truth_at(after(t0, 14.9));
        assert!(earlier.normal_force.0 >= truth.normal_force.0);
    }

    #[test]
    fn pressing_then_moving_x_shears_the_contact_until_it_slides_and_the_ft_feels_it() {
        let config = BenchConfig {
            surface: SurfaceConfig {
                rms_um: 0.0,
                ..SurfaceConfig::default()
            },
            ..BenchConfig::default()
        };
        let bench = Bench::new(config);
        let t0 = HostTime::now();
        // 2 mm left of the sensor centre, press 1 mm, then after 15 s move +x by 4 mm at the
        // stage's speed.
        let (x, y) = bench.stage_xy_for(Millimetres(-2.0), Millimetres(0.0));
        bench.motor_x().move_to(t0, Millimetres(x.0 - 25.0));
        bench.motor_y().move_to(t0, Millimetres(y.0 - 25.0));
        bench.motor_z().move_to(t0, Millimetres(10.0 + 1.0));
        let pressed = bench.truth_at(after(t0, 15.0));
        assert!(
            pressed.normal_force.0 > 3.0 && pressed.shear_n == [0.0, 0.0],
            "{pressed:?}"
        );
        assert_eq!(pressed.slip_state(), Some(Slip::Stick));
        assert!(Bench::contact_of(&pressed)
            .expect("contact")
            .shear
            .is_none());
        bench
            .motor_x()
            .move_to(after(t0, 15.0), Millimetres(x.0 - 25.0 + 4.0));
        let mut seen = Vec::new();
        for k in 1..=400 {
            let t = after(t0, 15.0 + 0.01 * k as f64);
            seen.push((bench.truth_at(t), bench.true_wrench_at(t)));
        }
        assert!((seen[399].0.x.0 - 2.0).abs() < 1e-6, "{:?}", seen[399].0);
        let (seen, wrenches): (Vec<BenchTruth>, Vec<Wrench>) = seen.into_iter().unzip();
        let states: Vec<Slip> = seen.iter().filter_map(|t| t.slip_state()).collect();
        let first = |s: Slip| states.iter().position(|&x| x == s).expect("state reached");
        assert!(
            first(Slip::PartialSlip) < first(Slip::GrossSlip),
            "partial slip did not come before gross slip"
        );
        let at = seen.iter().position(|t| t.sliding).expect("it slid");
        let sliding = &seen[at];
        let mu = bench.config().material.friction;
        // The push is along +x; the surface pushes the tip back along -x.
        assert!(
            (sliding.shear_n[0] - mu.kinetic_coefficient * sliding.normal_force.0).abs() < 0.05,
            "{sliding:?}"
        );
        let w = wrenches[at];
        let expected = bench.config().mount.wrench_from_tip_force([
            -sliding.shear_n[0],
            -sliding.shear_n[1],
            sliding.normal_force.0,
        ]);
        assert!(
            (w.fx.0 - expected.fx.0).abs() < 1e-9 && w.fx.0.abs() > 1.0,
            "{w:?} vs {expected:?} from {sliding:?}"
        );
        let shear = Bench::contact_of(sliding)
            .and_then(|c| c.shear)
            .expect("shear");
        assert!(
            shear.direction_deg.abs() < 1e-6 && shear.friction_used == 1.0,
            "{shear:?}"
        );
    }
}
