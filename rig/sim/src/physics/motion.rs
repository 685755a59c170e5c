//! A simulated stepper/servo axis: trapezoidal motion profiles evaluated in host time.
//!
//! Every emulated controller (APT x and z, Modbus y) owns one [`SimMotor`] and the bench reads the
//! same motor to know where the indenter is. A command starts a new [`Segment`] at the host time it
//! arrives, from the position and velocity the previous one had reached then; the position at any
//! later instant is evaluated in closed form, so motion is real time without a ticking thread.
//!
//! Positions are in the controller's counter frame (zero at power-up, then at the home switch after
//! homing); [`SimMotor::true_position_at`] adds the mechanical offset, which only the bench's ground
//! truth sees. Hard limit switches sit at fixed mechanical positions: a move that would pass one
//! stops there with the limit flag set, as a real limit switch does.

use fringe_rig::HostTime;
use fringe_rig::{Millimetres, MillimetresPerSecond};
use std::sync::Mutex;

pub(crate) use fringe_rig::Kinematics;

/// Mechanical construction of a simulated axis.
#[derive(Debug, Clone, PartialEq)]
pub struct MotorSpec {
    /// Axis name for messages ("x", "z", "y").
    pub name: String,
    /// Mechanical travel between the reverse and forward limit switches.
    pub travel: Millimetres,
    /// Mechanical position (from the reverse limit switch) the carriage has at power-up.
    pub power_up_position: Millimetres,
    /// Default move kinematics.
    pub kinematics: Kinematics,
}

/// One phase of constant acceleration.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Phase {
    duration_s: f64,
    acceleration: f64,
}

/// A planned motion from a start state through constant-acceleration phases, then at rest.
#[derive(Debug, Clone, PartialEq)]
struct Segment {
    start: HostTime,
    /// Mechanical position, mm.
    p0: f64,
    /// Velocity, mm/s.
    v0: f64,
    phases: Vec<Phase>,
    /// When the segment ends, the carriage hits this limit switch (true = forward).
    ends_on_limit: Option<bool>,
    /// The segment is a homing move: arriving zeroes the counter.
    homing: bool,
}

impl Segment {
    fn at_rest(start: HostTime, p0: f64) -> Segment {
        Segment {
            start,
            p0,
            v0: 0.0,
            phases: Vec::new(),
            ends_on_limit: None,
            homing: false,
        }
    }

    fn duration_s(&self) -> f64 {
        self.phases.iter().map(|p| p.duration_s).sum()
    }

    /// Position (mm) and velocity (mm/s) at `t`.
    fn state_at(&self, t: HostTime) -> (f64, f64) {
        let mut left = if t <= self.start {
            0.0
        } else {
            t.since(self.start).as_secs_f64()
        };
        let (mut p, mut v) = (self.p0, self.v0);
        for phase in &self.phases {
            let dt = left.min(phase.duration_s);
            p += v * dt + 0.5 * phase.acceleration * dt * dt;
            v += phase.acceleration * dt;
            left -= dt;
            if left <= 0.0 {
                return (p, v);
            }
        }
        (p, if self.phases.is_empty() { self.v0 } else { 0.0 })
    }

    fn finished(&self, t: HostTime) -> bool {
        t >= self.start && t.since(self.start).as_secs_f64() >= self.duration_s()
    }
}

/// Plans phases that take (p, v) to rest at `target` with |v| <= vmax and |a| = acc.
fn plan(p: f64, v: f64, target: f64, vmax: f64, acc: f64) -> Vec<Phase> {
    let mut phases = Vec::new();
    let (mut p, mut v) = (p, v);
    let acc = acc.max(1e-9);
    let vmax = vmax.max(1e-9);
    let dir = if target >= p { 1.0 } else { -1.0 };
    let stopping = v * v / (2.0 * acc);
    // Moving away from the target, overshooting it, or above the speed limit: brake to rest first.
    if v * dir < 0.0 || stopping > (target - p).abs() + 1e-12 || v.abs() > vmax + 1e-12 {
        let brake = Phase {
            duration_s: v.abs() / acc,
            acceleration: -v.signum() * acc,
        };
        p += v * brake.duration_s + 0.5 * brake.acceleration * brake.duration_s.powi(2);
        v = 0.0;
        phases.push(brake);
    }
    let dir = if target >= p { 1.0 } else { -1.0 };
    let distance = (target - p).abs();
    let u = v.abs();
    if distance < 1e-12 && u < 1e-12 {
        return phases;
    }
    let peak_sq = acc * distance + 0.5 * u * u;
    let peak = peak_sq.sqrt();
    if peak <= vmax {
        phases.push(Phase {
            duration_s: (peak - u) / acc,
            acceleration: dir * acc,
        });
        phases.push(Phase {
            duration_s: peak / acc,
            acceleration: -dir * acc,
        });
    } else {
        let ramp_up = (vmax * vmax - u * u) / (2.0 * acc);
        let ramp_down = vmax * vmax / (2.0 * acc);
        phases.push(Phase {
            duration_s: (vmax - u) / acc,
            acceleration: dir * acc,
        });
        phases.push(Phase {
            duration_s: (distance - ramp_up - ramp_down).max(0.0) / vmax,
            acceleration: 0.0,
        });
        phases.push(Phase {
            duration_s: vmax / acc,
            acceleration: -dir * acc,
        });
    }
    phases
}

/// What a controller reads back from its motor at an instant.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MotorStatus {
    /// Position in the controller's counter frame.
    pub position: Millimetres,
    pub velocity: MillimetresPerSecond,
    pub moving: bool,
    /// A homing move is under way.
    pub homing: bool,
    /// The counter has been zeroed at the home switch since power-up.
    pub homed: bool,
    pub forward_limit: bool,
    pub reverse_limit: bool,
    /// Incremented by every command; lets a controller tell which move just completed.
    pub command_count: u64,
}

#[derive(Debug)]
struct MotorState {
    segment: Segment,
    kinematics: Kinematics,
    /// Mechanical position of counter zero.
    zero_offset: f64,
    homed: bool,
    command_count: u64,
}

/// A simulated axis shared between its controller emulator and the bench.
#[derive(Debug)]
pub struct SimMotor {
    spec: MotorSpec,
    state: Mutex<MotorState>,
}

impl SimMotor {
    /// A motor at rest at its power-up position, counter zero there, not homed.
    pub fn new(spec: MotorSpec) -> SimMotor {
        let p0 = spec.power_up_position.0.clamp(0.0, spec.travel.0);
        SimMotor {
            state: Mutex::new(MotorState {
                segment: Segment::at_rest(HostTime::now(), p0),
                kinematics: spec.kinematics,
                zero_offset: p0,
                homed: false,
                command_count: 0,
            }),
            spec,
        }
    }

    /// The construction this motor was built with.
    pub fn spec(&self) -> &MotorSpec {
        &self.spec
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, MotorState> {
        // A panic while holding the lock leaves a consistent state (segments are replaced whole).
        self.state.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Sets the kinematics used by later moves.
    pub fn set_kinematics(&self, kinematics: Kinematics) {
        self.lock().kinematics = kinematics;
    }

    /// The kinematics used by later moves.
    pub fn kinematics(&self) -> Kinematics {
        self.lock().kinematics
    }

    /// Starts a move at `t` to `target` (counter frame). Targets past a limit switch end on it.
    pub fn move_to(&self, t: HostTime, target: Millimetres) {
        let mut s = self.lock();
        let target_mech = target.0 + s.zero_offset;
        let k = s.kinematics;
        self.start_segment(&mut s, t, target_mech, k, false);
    }

    /// Starts a relative move at `t` by `distance` from where the carriage is then.
    pub fn move_by(&self, t: HostTime, distance: Millimetres) {
        let mut s = self.lock();
        let (p, _) = s.segment.state_at(t);
        let k = s.kinematics;
        self.start_segment(&mut s, t, p + distance.0, k, false);
    }

    /// Starts homing at `t`: travel to the reverse limit switch at `velocity`; arriving there zeroes
    /// the counter and marks the motor homed.
    pub fn home(&self, t: HostTime, velocity: MillimetresPerSecond) {
        let mut s = self.lock();
        let k = Kinematics {
            velocity,
            acceleration: s.kinematics.acceleration,
        };
        self.start_segment(&mut s, t, 0.0, k, true);
    }

    /// Stops at `t`: decelerating at the move acceleration, or at once when `immediate`.
    pub fn stop(&self, t: HostTime, immediate: bool) {
        let mut s = self.lock();
        let (p, v) = s.segment.state_at(t);
        s.command_count += 1;
        if immediate || v.abs() < 1e-12 {
            s.segment = Segment::at_rest(t, p);
            return;
        }
        let acc = s.kinematics.acceleration.0.max(1e-9);
        let brake = Phase {
            duration_s: v.abs() / acc,
            acceleration: -v.signum() * acc,
        };
        let end = p + v * brake.duration_s + 0.5 * brake.acceleration * brake.duration_s.powi(2);
        let ends_on_limit = self.limit_hit(end);
        s.segment = Segment {
            start: t,
            p0: p,
            v0: v,
            phases: vec![brake],
            ends_on_limit,
            homing: false,
        };
    }

    fn limit_hit(&self, mech: f64) -> Option<bool> {
        if mech >= self.spec.travel.0 - 1e-9 {
            Some(true)
        } else if mech <= 1e-9 {
            Some(false)
        } else {
            None
        }
    }

    fn start_segment(
        &self,
        s: &mut MotorState,
        t: HostTime,
        target: f64,
        k: Kinematics,
        homing: bool,
    ) {
        self.settle(s, t);
        let (p, v) = s.segment.state_at(t);
        let clamped = target.clamp(0.0, self.spec.travel.0);
        let phases = plan(p, v, clamped, k.velocity.0.abs(), k.acceleration.0.abs());
        s.command_count += 1;
        s.segment = Segment {
            start: t,
            p0: p,
            v0: v,
            phases,
            ends_on_limit: if homing {
                Some(false)
            } else if (clamped - target).abs() > 1e-12 {
                self.limit_hit(clamped)
            } else {
                None
            },
            homing,
        };
    }

    /// Applies the end of a finished homing segment (zeroes the counter).
    fn settle(&self, s: &mut MotorState, t: HostTime) {
        if s.segment.homing && s.segment.finished(t) {
            s.zero_offset = 0.0;
            s.homed = true;
            s.segment.homing = false;
        }
    }

    /// Redefines the counter at `t` so that the carriage's position then reads `position`
    /// (what MOT_SET_POSCOUNTER does); the carriage does not move and a move under way keeps its
    /// mechanical target.
    pub fn set_position_counter(&self, t: HostTime, position: Millimetres) {
        let mut s = self.lock();
        self.settle(&mut s, t);
        let (p, _) = s.segment.state_at(t);
        s.zero_offset = p - position.0;
    }

    /// The controller's view at `t`.
    pub fn status_at(&self, t: HostTime) -> MotorStatus {
        let mut s = self.lock();
        self.settle(&mut s, t);
        let (p, v) = s.segment.state_at(t);
        let finished = s.segment.finished(t);
        let on_limit = if finished {
            s.segment.ends_on_limit.or_else(|| self.limit_hit(p))
        } else {
            self.limit_hit(p)
        };
        MotorStatus {
            position: Millimetres(p - s.zero_offset),
            velocity: MillimetresPerSecond(v),
            moving: !finished,
            homing: s.segment.homing && !finished,
            homed: s.homed,
            forward_limit: on_limit == Some(true),
            reverse_limit: on_limit == Some(false),
            command_count: s.command_count,
        }
    }

    /// Mechanical position at `t`, from the reverse limit switch (ground truth, not visible to a
    /// controller).
    pub fn true_position_at(&self, t: HostTime) -> Millimetres {
        Millimetres(self.lock().segment.state_at(t).0)
    }

    /// Mechanical position of the counter's zero (ground truth).
    pub fn zero_offset(&self) -> Millimetres {
        Millimetres(self.lock().zero_offset)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use fringe_rig::MillimetresPerSecondSquared;
    use std::time::Duration;

    fn motor() -> SimMotor {
        SimMotor::new(MotorSpec {
            name: "x".into(),
            travel: Millimetres(25.0),
            power_up_position: Millimetres(10.0),
            kinematics: Kinematics {
                velocity: MillimetresPerSecond(2.0),
                acceleration: MillimetresPerSecondSquared(4.0),
            },
        })
    }

    fn after(t: HostTime, s: f64) -> HostTime {
        HostTime(t.0 + Duration::from_secs_f64(s).as_nanos() as u64)
    }

    #[test]
    fn trapezoid_reaches_the_target_in_the_closed_form_time() {
        let m = motor();
        let t0 = HostTime::now();
        m.move_to(t0, Millimetres(5.0));
        // 5 mm at 2 mm/s with 4 mm/s^2: ramps 0.5 s each covering 0.5 mm, cruise 4 mm in 2 s.
        let mid = m.status_at(after(t0, 1.5));
        assert!(mid.moving);
        assert!((mid.velocity.0 - 2.0).abs() < 1e-9, "{mid:?}");
        assert!((mid.position.0 - 2.5).abs() < 1e-9, "{mid:?}");
        let nearly = m.status_at(after(t0, 2.999));
        assert!(nearly.moving);
        let end = m.status_at(after(t0, 3.0001));
        assert!(!end.moving);
        assert!((end.position.0 - 5.0).abs() < 1e-9);
    }

    #[test]
    fn short_move_is_triangular_and_never_exceeds_speed() {
        let m = motor();
        let t0 = HostTime::now();
        m.move_by(t0, Millimetres(-0.25));
        let peak = m.status_at(after(t0, 0.25));
        assert!((peak.velocity.0 + 1.0).abs() < 1e-9, "{peak:?}");
        let end = m.status_at(after(t0, 0.51));
        assert!(!end.moving && (end.position.0 + 0.25).abs() < 1e-9);
    }

    #[test]
    fn reversing_mid_move_brakes_first_and_never_jumps() {
        let m = motor();
        let t0 = HostTime::now();
        m.move_to(t0, Millimetres(5.0));
        let t1 = after(t0, 1.0);
        let before = m.status_at(t1);
        m.move_to(t1, Millimetres(0.0));
        let just_after = m.status_at(after(t1, 1e-6));
        assert!((just_after.position.0 - before.position.0).abs() < 1e-4);
        let end = m.status_at(after(t1, 10.0));
        assert!(!end.moving && end.position.0.abs() < 1e-9);
    }

    #[test]
    fn profiled_stop_decelerates_and_immediate_stop_holds() {
        let m = motor();
        let t0 = HostTime::now();
        m.move_to(t0, Millimetres(10.0));
        let t1 = after(t0, 1.0);
        m.stop(t1, false);
        let end = m.status_at(after(t1, 1.0));
        // at 2 mm/s, braking at 4 mm/s^2 covers 0.5 mm
        let p1 = 0.5 + 2.0 * 0.5;
        assert!((end.position.0 - (p1 + 0.5)).abs() < 1e-9, "{end:?}");
        m.move_to(end_time(t1), Millimetres(10.0));
        let t2 = after(t1, 2.0);
        let here = m.status_at(t2).position;
        m.stop(t2, true);
        assert_eq!(m.status_at(after(t2, 1.0)).position, here);
    }

    fn end_time(t: HostTime) -> HostTime {
        after(t, 1.0)
    }

    #[test]
    fn moves_past_travel_end_on_the_limit_switch() {
        let m = motor();
        let t0 = HostTime::now();
        m.move_to(t0, Millimetres(100.0));
        let end = m.status_at(after(t0, 60.0));
        assert!(!end.moving && end.forward_limit && !end.reverse_limit);
        assert!((m.true_position_at(after(t0, 60.0)).0 - 25.0).abs() < 1e-9);
        assert!((end.position.0 - 15.0).abs() < 1e-9);
    }

    #[test]
    fn setting_the_counter_shifts_readings_but_not_the_carriage() {
        let m = motor();
        let t0 = HostTime::now();
        m.set_position_counter(t0, Millimetres(2.0));
        assert!((m.status_at(t0).position.0 - 2.0).abs() < 1e-12);
        assert!((m.true_position_at(t0).0 - 10.0).abs() < 1e-12);
        m.move_to(t0, Millimetres(3.0));
        assert!((m.true_position_at(after(t0, 10.0)).0 - 11.0).abs() < 1e-9);
    }

    #[test]
    fn homing_zeroes_the_counter_at_the_reverse_switch() {
        let m = motor();
        let t0 = HostTime::now();
        assert!(!m.status_at(t0).homed);
        m.home(t0, MillimetresPerSecond(2.0));
        assert!(m.status_at(after(t0, 1.0)).homing);
        let end = m.status_at(after(t0, 30.0));
        assert!(end.homed && !end.moving && end.reverse_limit);
        assert!(end.position.0.abs() < 1e-9);
        m.move_to(after(t0, 30.0), Millimetres(3.0));
        assert!((m.true_position_at(after(t0, 60.0)).0 - 3.0).abs() < 1e-9);
    }
}
