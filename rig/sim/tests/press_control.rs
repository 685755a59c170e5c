//! The press controller of the scan engine (approach, closed-loop force targets, the ceiling,
//! cancel) against a simulated z motor pressing a linear spring.

use fringe_rig::scan::{approach, press_to, retract, ForceGuard, PressError, PressSettings};
use fringe_rig::AxisStatus;
use fringe_rig::ForceStream;
use fringe_rig::HostTime;
use fringe_rig::{Axis, AxisError, Kinematics, StopMode};
use fringe_rig::{ForceError, ForceSample, ForceSensor, StreamStats};
use fringe_rig::{Millimetres, Newtons};
use fringe_rig::{MillimetresPerSecond, MillimetresPerSecondSquared, Wrench};
use fringe_sim::{MotorSpec, SimMotor};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

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
    fn begin_move_to_at(
        &mut self,
        target: Millimetres,
        motion: Kinematics,
    ) -> Result<(), AxisError> {
        self.0.set_kinematics(motion);
        self.0.move_to(HostTime::now(), target);
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
    /// Set by a test: the reader is held this long (ms) once, as a busy host holds a thread,
    /// and then delivers what came in meanwhile.
    hold_ms: Arc<AtomicU64>,
    /// Set by a test: the sensor delivers nothing from then on.
    dead: Arc<AtomicBool>,
}

impl ForceSensor for Spring {
    fn describe(&self) -> String {
        "spring".into()
    }
    fn start(&mut self) -> Result<(), ForceError> {
        Ok(())
    }
    fn next_sample(&mut self, timeout: Duration) -> Result<Option<ForceSample>, ForceError> {
        if self.dead.load(Ordering::SeqCst) {
            std::thread::sleep(timeout);
            return Ok(None);
        }
        let hold = self.hold_ms.swap(0, Ordering::SeqCst);
        if hold > 0 {
            std::thread::sleep(Duration::from_millis(hold));
        }
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
    let (z, stream, _) = rig_with_faults();
    (z, stream)
}

/// The held and dead switches of the spring's stream.
struct Faults {
    hold_ms: Arc<AtomicU64>,
    dead: Arc<AtomicBool>,
}

fn rig_with_faults() -> (MotorAxis, ForceStream, Faults) {
    let motor = Arc::new(SimMotor::new(MotorSpec {
        name: "z".into(),
        travel: Millimetres(25.0),
        power_up_position: Millimetres(0.0),
        kinematics: Kinematics {
            velocity: MillimetresPerSecond(2.0),
            acceleration: MillimetresPerSecondSquared(20.0),
        },
    }));
    let faults = Faults {
        hold_ms: Arc::new(AtomicU64::new(0)),
        dead: Arc::new(AtomicBool::new(false)),
    };
    let stream = ForceStream::spawn(Box::new(Spring {
        motor: motor.clone(),
        n: 0,
        next: Instant::now(),
        hold_ms: faults.hold_ms.clone(),
        dead: faults.dead.clone(),
    }))
    .expect("stream");
    std::thread::sleep(Duration::from_millis(30));
    (MotorAxis(motor), stream, faults)
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

#[test]
fn a_reading_waits_out_a_held_reader_and_a_dead_stream_is_said_after_the_silence_limit() {
    let (_z, stream, faults) = rig_with_faults();
    let monitor = stream.monitor();
    let settings = PressSettings::default();
    let guard = ForceGuard::new(&monitor, &settings, Arc::new(AtomicBool::new(false)))
        .with_tare(Newtons(BIAS));
    // The host holds the F/T reader 90 ms; the reading is asked for 75 ms into it, when the
    // newest sample is already older than the 50 ms limit. The reader runs again 15 ms later
    // with what the sensor sent meanwhile: the reading waits for it instead of stopping a scan.
    faults.hold_ms.store(90, Ordering::SeqCst);
    std::thread::sleep(Duration::from_millis(75));
    let stale = monitor.silence().expect("samples arrived");
    assert!(stale > Duration::from_millis(50), "not held yet: {stale:?}");
    let force = guard.pressing_force().expect("the held reader's samples");
    assert!(force.0.abs() < 0.05, "{force}");
    assert!(monitor.silence().expect("samples") < Duration::from_millis(50));

    // A sensor that stops: a reading asked for once its newest sample is past the limit says
    // so when it has watched the stream for the limit itself, not later.
    faults.dead.store(true, Ordering::SeqCst);
    std::thread::sleep(Duration::from_millis(60));
    let asked = Instant::now();
    let err = guard.pressing_force().expect_err("a dead stream");
    let waited = asked.elapsed();
    assert!(
        err.to_string().contains("no data for") && err.to_string().contains("check the cable"),
        "{err}"
    );
    assert!(waited >= Duration::from_millis(40), "said after {waited:?}");
    assert!(waited < Duration::from_secs(2), "said after {waited:?}");
}
