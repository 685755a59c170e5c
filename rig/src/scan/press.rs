//! Pressing under force control with the z axis and the F/T stream.
//!
//! Conventions: z moves towards the sensor with increasing position; the F/T reads Fz negative when
//! the indenter presses (ATI compression), so the pressing force is -Fz of the tared reading.
//!
//! - [`approach`] drives z towards the sensor until the pressing force exceeds a threshold, stops at
//!   once and reports where contact was found.
//! - [`press_to`] reaches a force target by Newton steps on the measured stiffness: each step moves
//!   by (target - F) / k, waits for the move and a settling time, and re-reads the force, until the
//!   force is within tolerance (the soft layer relaxes, so a few steps are normal).
//! - Every wait checks the force ceiling (stop at once, retract) and the cancel flag.

use crate::acquire::force_stream::ForceMonitor;
use crate::axis::{Axis, AxisError, StopMode};
use crate::units::{Millimetres, Newtons};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// How presses are made.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PressSettings {
    /// Pressing force that means contact (above the F/T noise floor).
    pub contact_threshold: Newtons,
    /// Deepest z position the approach may reach before giving up.
    pub approach_limit: Millimetres,
    /// Force never to exceed: z stops at once and retracts.
    pub ceiling: Newtons,
    /// A force within this of the target ends a press.
    pub tolerance: Newtons,
    /// Stiffness assumed for the first step after contact, N/mm.
    pub initial_stiffness_n_per_mm: f64,
    /// Largest single z step while pressing.
    pub max_step: Millimetres,
    /// Pause after each step before the force is read (lets the F/T average and the layer settle).
    pub settle: Duration,
    /// Samples averaged for one force reading (5 kHz: 50 = 10 ms).
    pub average_samples: usize,
    /// Steps before a press gives up.
    pub max_steps: usize,
    /// Timeout for one z move.
    pub move_timeout: Duration,
}

impl Default for PressSettings {
    fn default() -> Self {
        PressSettings {
            contact_threshold: Newtons(0.3),
            approach_limit: Millimetres(25.0),
            ceiling: Newtons(12.0),
            tolerance: Newtons(0.1),
            initial_stiffness_n_per_mm: 10.0,
            max_step: Millimetres(0.3),
            settle: Duration::from_millis(60),
            average_samples: 50,
            max_steps: 25,
            move_timeout: Duration::from_secs(60),
        }
    }
}

/// Why a press did not finish.
#[derive(Debug, thiserror::Error)]
pub enum PressError {
    #[error(transparent)]
    Axis(#[from] AxisError),
    #[error("force sensor {device}: {message}")]
    Force { device: String, message: String },
    #[error("force {force:.2} exceeded the ceiling {ceiling:.2}: z stopped and retracted to {retracted_to:.3}")]
    Ceiling {
        force: Newtons,
        ceiling: Newtons,
        retracted_to: Millimetres,
    },
    #[error("no contact before z reached {limit:.3} (pressing force stayed under {threshold:.2}); check the sensor height or the approach limit")]
    NoContact {
        limit: Millimetres,
        threshold: Newtons,
    },
    #[error("press to {target:.2} did not settle within {steps} steps (last force {force:.2})")]
    NotSettled {
        target: Newtons,
        force: Newtons,
        steps: usize,
    },
    #[error("cancelled by the operator")]
    Cancelled,
}

/// The end of an approach or press.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PressPoint {
    /// z position reported by the axis.
    pub z: Millimetres,
    /// Pressing force (-Fz, tared) averaged over the reading.
    pub force: Newtons,
    /// Steps taken (0 for an approach).
    pub steps: usize,
}

/// Force readings and the safety checks around them.
pub struct ForceGuard<'a> {
    monitor: &'a ForceMonitor,
    settings: &'a PressSettings,
    cancel: Arc<AtomicBool>,
    /// Fz offset (N) subtracted from every reading: the no-contact reading (tare).
    tare_fz: f64,
}

impl<'a> ForceGuard<'a> {
    pub fn new(
        monitor: &'a ForceMonitor,
        settings: &'a PressSettings,
        cancel: Arc<AtomicBool>,
    ) -> Self {
        ForceGuard {
            monitor,
            settings,
            cancel,
            tare_fz: 0.0,
        }
    }

    /// Subtracts `fz` (the no-contact Fz reading, N) from every reading.
    pub fn with_tare(mut self, fz: Newtons) -> Self {
        self.tare_fz = fz.0;
        self
    }

    fn force_error(&self, message: String) -> PressError {
        PressError::Force {
            device: self.monitor.device().to_string(),
            message,
        }
    }

    /// The pressing force averaged over the configured number of samples.
    pub fn pressing_force(&self) -> Result<Newtons, PressError> {
        if let Some(e) = self.monitor.error() {
            return Err(self.force_error(e));
        }
        match self.monitor.silence() {
            None => return Err(self.force_error("no samples yet".into())),
            Some(s) if s > Duration::from_millis(50) => {
                return Err(self.force_error(format!(
                    "no data for {} ms (check the cable and the stream)",
                    s.as_millis()
                )))
            }
            _ => {}
        }
        let (_, mean) = self
            .monitor
            .mean_of_last(self.settings.average_samples)
            .ok_or_else(|| self.force_error("no samples yet".into()))?;
        Ok(Newtons(self.tare_fz - mean[2]))
    }

    /// The newest single sample's pressing force (for the fast ceiling check).
    fn instant_force(&self) -> Result<Newtons, PressError> {
        self.monitor
            .mean_of_last(5)
            .map(|(_, m)| Newtons(self.tare_fz - m[2]))
            .ok_or_else(|| self.force_error("no samples yet".into()))
    }

    fn check_cancel(&self) -> Result<(), PressError> {
        if self.cancel.load(Ordering::SeqCst) {
            Err(PressError::Cancelled)
        } else {
            Ok(())
        }
    }
}

/// Stops z at once, backs off by `back_off` and reports a ceiling error.
fn ceiling_stop(
    z: &mut dyn Axis,
    guard: &ForceGuard<'_>,
    force: Newtons,
    back_off: Millimetres,
) -> PressError {
    let _ = z.stop(StopMode::Immediate);
    let retracted_to = z
        .move_by(-back_off, guard.settings.move_timeout)
        .map(|s| s.position)
        .unwrap_or(Millimetres(f64::NAN));
    PressError::Ceiling {
        force,
        ceiling: guard.settings.ceiling,
        retracted_to,
    }
}

/// Watches a running z move until it ends; stops on the ceiling, on `stop_above` (returns true
/// then) and on cancel.
fn watch_move(
    z: &mut dyn Axis,
    guard: &ForceGuard<'_>,
    stop_above: Option<Newtons>,
) -> Result<bool, PressError> {
    let poll = Duration::from_millis(2);
    let started = Instant::now();
    loop {
        if guard.check_cancel().is_err() {
            let _ = z.stop(StopMode::Immediate);
            return Err(PressError::Cancelled);
        }
        let f = guard.instant_force()?;
        if f > guard.settings.ceiling {
            return Err(ceiling_stop(z, guard, f, Millimetres(1.0)));
        }
        if let Some(threshold) = stop_above {
            if f > threshold {
                z.stop(StopMode::Immediate)?;
                z.wait_idle(guard.settings.move_timeout)?;
                return Ok(true);
            }
        }
        match z.wait_idle(poll) {
            Ok(_) => return Ok(false),
            Err(AxisError::Timeout { .. }) if started.elapsed() < guard.settings.move_timeout => {}
            Err(e) => return Err(e.into()),
        }
    }
}

/// Drives z towards the sensor until contact.
pub fn approach(z: &mut dyn Axis, guard: &ForceGuard<'_>) -> Result<PressPoint, PressError> {
    guard.check_cancel()?;
    let threshold = guard.settings.contact_threshold;
    if guard.pressing_force()? > threshold {
        let status = z.status()?;
        return Ok(PressPoint {
            z: status.position,
            force: guard.pressing_force()?,
            steps: 0,
        });
    }
    z.begin_move_to(guard.settings.approach_limit)?;
    if !watch_move(z, guard, Some(threshold))? {
        return Err(PressError::NoContact {
            limit: guard.settings.approach_limit,
            threshold,
        });
    }
    std::thread::sleep(guard.settings.settle);
    Ok(PressPoint {
        z: z.status()?.position,
        force: guard.pressing_force()?,
        steps: 0,
    })
}

/// Presses to `target` (after contact) by stiffness-estimated steps.
pub fn press_to(
    z: &mut dyn Axis,
    guard: &ForceGuard<'_>,
    target: Newtons,
) -> Result<PressPoint, PressError> {
    let s = guard.settings;
    if target > s.ceiling {
        return Err(PressError::Ceiling {
            force: target,
            ceiling: s.ceiling,
            retracted_to: z.status()?.position,
        });
    }
    let mut stiffness = s.initial_stiffness_n_per_mm;
    let mut position = z.status()?.position;
    let mut force = guard.pressing_force()?;
    for step in 0..s.max_steps {
        guard.check_cancel()?;
        let error = target - force;
        if error.abs() <= s.tolerance {
            return Ok(PressPoint {
                z: position,
                force,
                steps: step,
            });
        }
        // Out of contact (force under threshold while pressing less): move by the max step.
        let mut dz = error.0 / stiffness.max(0.1);
        dz = dz.clamp(-s.max_step.0, s.max_step.0);
        z.begin_move_by(Millimetres(dz))?;
        watch_move(z, guard, None)?;
        std::thread::sleep(s.settle);
        let new_position = z.status()?.position;
        let new_force = guard.pressing_force()?;
        let moved = new_position.0 - position.0;
        let gained = new_force.0 - force.0;
        // Keep a measured stiffness when the step was in contact and large enough to trust.
        if moved.abs() > 1e-3 && force > s.contact_threshold && gained / moved > 0.5 {
            stiffness = gained / moved;
        }
        position = new_position;
        force = new_force;
    }
    if (target - force).abs() <= s.tolerance {
        return Ok(PressPoint {
            z: position,
            force,
            steps: s.max_steps,
        });
    }
    Err(PressError::NotSettled {
        target,
        force,
        steps: s.max_steps,
    })
}

/// Moves z back to `safe` (away from the sensor) and waits.
pub fn retract(
    z: &mut dyn Axis,
    safe: Millimetres,
    timeout: Duration,
) -> Result<Millimetres, PressError> {
    Ok(z.move_to(safe, timeout)?.position)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::acquire::force_stream::ForceStream;
    use crate::axis::AxisStatus;
    use crate::clock::HostTime;
    use crate::force::{ForceError, ForceSample, ForceSensor, StreamStats};
    use crate::sim::motion::{Kinematics, MotorSpec, SimMotor};
    use crate::units::{MillimetresPerSecond, MillimetresPerSecondSquared, Wrench};

    const SURFACE: f64 = 5.0;
    const STIFFNESS: f64 = 13.0;
    /// The F/T reads this Fz with nothing touching (tared away by the guard).
    const BIAS: f64 = 1.5;

    /// An axis straight on a simulated motor.
    struct MotorAxis(Arc<SimMotor>);

    impl Axis for MotorAxis {
        fn name(&self) -> &str {
            "z"
        }
        fn endpoint(&self) -> String {
            "test motor".into()
        }
        fn begin_home(&mut self) -> Result<(), AxisError> {
            self.0.home(HostTime::now(), MillimetresPerSecond(5.0));
            Ok(())
        }
        fn begin_move_to(&mut self, target: Millimetres) -> Result<(), AxisError> {
            self.0.move_to(HostTime::now(), target);
            Ok(())
        }
        fn begin_move_by(&mut self, delta: Millimetres) -> Result<(), AxisError> {
            self.0.move_by(HostTime::now(), delta);
            Ok(())
        }
        fn wait_idle(&mut self, timeout: Duration) -> Result<AxisStatus, AxisError> {
            let until = Instant::now() + timeout;
            loop {
                let s = self.status()?;
                if !s.moving {
                    return Ok(s);
                }
                if Instant::now() >= until {
                    return Err(AxisError::Timeout {
                        axis: "z".into(),
                        endpoint: "test".into(),
                        what: "move".into(),
                        timeout,
                        flags: vec![],
                    });
                }
                std::thread::sleep(Duration::from_micros(500));
            }
        }
        fn stop(&mut self, mode: StopMode) -> Result<(), AxisError> {
            self.0.stop(HostTime::now(), mode == StopMode::Immediate);
            Ok(())
        }
        fn status(&mut self) -> Result<AxisStatus, AxisError> {
            let s = self.0.status_at(HostTime::now());
            Ok(AxisStatus {
                position: s.position,
                moving: s.moving,
                homed: s.homed,
                flags: vec![],
                faults: vec![],
            })
        }
    }

    /// A linear spring under the indenter: Fz = bias - k (z - surface) in contact, at 5 kHz.
    struct Spring {
        motor: Arc<SimMotor>,
        n: u64,
        next: Instant,
    }

    impl ForceSensor for Spring {
        fn describe(&self) -> String {
            "spring".into()
        }
        fn start(&mut self) -> Result<(), ForceError> {
            Ok(())
        }
        fn next_sample(&mut self, _t: Duration) -> Result<Option<ForceSample>, ForceError> {
            let now = Instant::now();
            if self.next > now {
                std::thread::sleep(self.next - now);
            }
            self.next += Duration::from_micros(200);
            self.n += 1;
            let t = HostTime::now();
            let depth = (self.motor.true_position_at(t).0 - SURFACE).max(0.0);
            Ok(Some(ForceSample {
                device_tick: self.n,
                transport_seq: None,
                host_time: t,
                wrench: Wrench {
                    fz: Newtons(BIAS - STIFFNESS * depth),
                    ..Wrench::default()
                },
                status: 0,
                strobe: None,
            }))
        }
        fn stop(&mut self) -> Result<(), ForceError> {
            Ok(())
        }
        fn bias(&mut self) -> Result<(), ForceError> {
            Ok(())
        }
        fn stats(&self) -> StreamStats {
            StreamStats::default()
        }
    }

    fn rig() -> (MotorAxis, ForceStream) {
        let motor = Arc::new(SimMotor::new(MotorSpec {
            name: "z".into(),
            travel: Millimetres(25.0),
            power_up_position: Millimetres(0.0),
            kinematics: Kinematics {
                velocity: MillimetresPerSecond(2.0),
                acceleration: MillimetresPerSecondSquared(20.0),
            },
        }));
        let stream = ForceStream::spawn(Box::new(Spring {
            motor: motor.clone(),
            n: 0,
            next: Instant::now(),
        }))
        .expect("stream");
        std::thread::sleep(Duration::from_millis(30));
        (MotorAxis(motor), stream)
    }

    #[test]
    fn approach_stops_at_first_contact_and_press_reaches_each_target() {
        let (mut z, stream) = rig();
        let monitor = stream.monitor();
        let settings = PressSettings {
            settle: Duration::from_millis(15),
            average_samples: 10,
            ..PressSettings::default()
        };
        let guard = ForceGuard::new(&monitor, &settings, Arc::new(AtomicBool::new(false)))
            .with_tare(Newtons(BIAS));
        let contact = approach(&mut z, &guard).expect("contact");
        // 0.3 N at 13 N/mm is 23 um past the surface; stopping at 2 mm/s adds a few um.
        assert!(
            contact.z.0 > SURFACE + 0.02 && contact.z.0 < SURFACE + 0.08,
            "{contact:?}"
        );
        for target in [1.0, 4.0, 9.0, 2.0] {
            let p = press_to(&mut z, &guard, Newtons(target)).expect("press");
            assert!((p.force.0 - target).abs() <= 0.1, "{p:?} for {target}");
            assert!(
                (p.z.0 - (SURFACE + target / STIFFNESS)).abs() < 0.01,
                "{p:?}"
            );
            assert!(p.steps <= 6, "{p:?}");
        }
        let back = retract(&mut z, Millimetres(0.0), Duration::from_secs(10)).expect("retract");
        assert!(back.0.abs() < 1e-9);
    }

    #[test]
    fn the_ceiling_stops_z_at_once_and_backs_off() {
        let (mut z, stream) = rig();
        let monitor = stream.monitor();
        let settings = PressSettings {
            ceiling: Newtons(1.0),
            initial_stiffness_n_per_mm: 1.0,
            settle: Duration::from_millis(15),
            average_samples: 10,
            ..PressSettings::default()
        };
        let guard = ForceGuard::new(&monitor, &settings, Arc::new(AtomicBool::new(false)))
            .with_tare(Newtons(BIAS));
        approach(&mut z, &guard).expect("contact");
        let err = press_to(&mut z, &guard, Newtons(0.9)).expect_err("ceiling");
        match err {
            PressError::Ceiling {
                force,
                retracted_to,
                ..
            } => {
                assert!(force.0 > 1.0 && force.0 < 1.5, "stopped late: {force}");
                assert!(retracted_to.0 < SURFACE, "{retracted_to}");
            }
            other => panic!("expected a ceiling stop, got {other}"),
        }
        assert!(guard.pressing_force().expect("force").0 < 0.05);
    }

    #[test]
    fn cancel_stops_the_approach_and_a_missing_surface_is_reported() {
        let (mut z, stream) = rig();
        let monitor = stream.monitor();
        let cancel = Arc::new(AtomicBool::new(false));
        let settings = PressSettings {
            approach_limit: Millimetres(3.0),
            ..PressSettings::default()
        };
        let guard = ForceGuard::new(&monitor, &settings, cancel.clone()).with_tare(Newtons(BIAS));
        let err = approach(&mut z, &guard).expect_err("no contact above 3 mm");
        assert!(matches!(err, PressError::NoContact { .. }), "{err}");
        assert!(err.to_string().contains("approach limit"));
        let settings = PressSettings::default();
        let guard = ForceGuard::new(&monitor, &settings, cancel.clone()).with_tare(Newtons(BIAS));
        let flag = cancel.clone();
        let t = std::thread::spawn(move || {
            std::thread::sleep(Duration::from_millis(100));
            flag.store(true, Ordering::SeqCst);
        });
        let err = approach(&mut z, &guard).expect_err("cancelled");
        t.join().expect("thread");
        assert!(matches!(err, PressError::Cancelled));
        assert!(!z.status().expect("status").moving);
    }
}
