//! A slide: with the indenter pressed to its force, the stage axes move it sideways along a
//! straight line at the plan's speed while z holds the normal force in closed loop; filmed all
//! along, each frame placed where the slide had taken the indenter mid-exposure.
//!
//! The normal-force loop runs every [`SERVO_PERIOD`]: it reads the pressing force (averaged as a
//! press reads it) and, while z is at rest, moves z by the force error over the stiffness the
//! press measured, at most [`MAX_SERVO_STEP`] at a time. The tangential force is watched by the
//! watcher thread (its ceiling, [`crate::scan::WatchSettings`]); an alarm stops x, y and z at
//! once.

use super::motions::settled;
use super::runner::{Runner, MOVE_TIMEOUT, POLL};
use crate::acquire::recorder::{Filming, SlidePath};
use crate::axis::{Axis, StopMode};
use crate::clock::HostTime;
use crate::scan::control::Phase;
use crate::scan::failure::ScanError;
use crate::scan::press::{ForceGuard, PressError, PressPoint};
use crate::scan::slide::Slide;
use crate::scan::watchers::{tangential_of, Alarm};
use crate::units::Millimetres;
use std::time::{Duration, Instant};

/// How often the normal force is corrected during a slide.
const SERVO_PERIOD: Duration = Duration::from_millis(20);
/// The largest z correction at once, mm (0.5 N on a 10 N/mm layer).
const MAX_SERVO_STEP: Millimetres = Millimetres(0.05);
/// The share of the force error one correction takes out (less than all of it: the layer
/// relaxes and the force reading lags the move).
const SERVO_GAIN: f64 = 0.6;
/// The stiffness range a press's measurement is trusted in, N/mm.
const STIFFNESS: std::ops::RangeInclusive<f64> = 1.0..=500.0;

/// How a slide ended.
pub(super) enum SlideEnd {
    /// At the end of the line, where the slide reached.
    Done,
    Interrupted(Alarm),
}

/// What the normal force did during a slide, for the run's event.
#[derive(Default)]
struct Holding {
    /// Largest |pressing force - target| read, N.
    worst: f64,
    /// Sum and count of the squared errors, for their RMS.
    sum_sq: f64,
    reads: u32,
    /// Largest tangential force read, N.
    tangential: f64,
    corrections: u32,
}

impl Runner<'_> {
    /// Slides the indenter of point `i` by `s`, z holding `s.force`; `contact` is where the
    /// press first touched and `reached` where it reached the force (their ratio is the
    /// stiffness the loop steers by).
    pub(super) fn slide(
        &mut self,
        i: u64,
        s: &Slide,
        guard: &ForceGuard<'_>,
        contact: PressPoint,
        reached: PressPoint,
        filming: &mut Filming,
    ) -> Result<SlideEnd, ScanError> {
        let motion = s.motion(&self.setup.limits.x_motion, &self.setup.limits.y_motion);
        let from = [filming.measured.x.0, filming.measured.y.0];
        let (end_x, end_y) = s.end_from(filming.measured.x, filming.measured.y);
        let stiffness = {
            let (dz, df) = (reached.z.0 - contact.z.0, reached.force.0 - contact.force.0);
            let k = if dz.abs() > 1e-4 { df / dz } else { f64::NAN };
            if STIFFNESS.contains(&k) {
                k
            } else {
                self.press.initial_stiffness_n_per_mm
            }
        };
        self.phase(i, Phase::Sliding);
        let sliding = Instant::now();
        let sent = HostTime::now();
        let started = self.start_slide(&motion, end_x, end_y);
        filming.slide = Some(SlidePath {
            sent,
            from,
            contact_from: filming.contact,
            unit: motion.unit,
            distance: s.distance.0,
            along: motion.along,
        });
        self.context.set(Some(filming.clone()));
        if let Err(e) = started {
            self.stop_all();
            return Err(e.into());
        }
        let held = self.hold_force_while_sliding(s, guard, stiffness, &motion);
        self.excluded += sliding.elapsed();
        let (holding, rest) = match held {
            Ok(HeldTo::Interrupted(alarm)) => {
                self.stop_all();
                filming.slide = None;
                return Ok(SlideEnd::Interrupted(alarm));
            }
            Ok(HeldTo::End { holding, rest }) => (holding, rest),
            Err(e) => {
                self.stop_all();
                return Err(e);
            }
        };
        // At rest at the end of the line: frames from here on are labelled where it stopped.
        let moved = [rest[0] - from[0], rest[1] - from[1]];
        filming.slide = None;
        filming.commanded.x = end_x;
        filming.commanded.y = end_y;
        filming.measured.x = Millimetres(rest[0]);
        filming.measured.y = Millimetres(rest[1]);
        filming.measured.z = self.axes.z.status()?.position;
        filming.contact = [filming.contact[0] + moved[0], filming.contact[1] + moved[1]];
        self.context.set(Some(filming.clone()));
        let rms = (holding.sum_sq / f64::from(holding.reads.max(1))).sqrt();
        self.recorder.event(
            "slide",
            Some(i),
            &format!(
                "slid {:.3} mm at {} degrees at {:.3} mm/s holding {:.2} N: normal force within {:.3} N (RMS {:.3} N, {} z corrections), tangential force up to {:.2} N",
                s.distance.0,
                s.direction_deg,
                s.speed.0,
                s.force.0,
                holding.worst,
                rms,
                holding.corrections,
                holding.tangential
            ),
        );
        Ok(SlideEnd::Done)
    }

    /// Sends the stage axes their shares of the slide (x first, then y).
    fn start_slide(
        &mut self,
        motion: &crate::scan::slide::SlideMotion,
        end_x: Millimetres,
        end_y: Millimetres,
    ) -> Result<(), crate::axis::AxisError> {
        if let Some(k) = motion.x {
            self.axes.x.begin_move_to_at(end_x, k)?;
        }
        if let Some(k) = motion.y {
            self.axes.y.begin_move_to_at(end_y, k)?;
        }
        Ok(())
    }

    /// Holds the normal force until x and y have come to rest at the end of the slide.
    fn hold_force_while_sliding(
        &mut self,
        s: &Slide,
        guard: &ForceGuard<'_>,
        stiffness: f64,
        motion: &crate::scan::slide::SlideMotion,
    ) -> Result<HeldTo, ScanError> {
        let deadline = Instant::now()
            + Duration::from_secs_f64(motion.seconds(s.distance.0))
            + Duration::from_secs(10);
        let mut holding = Holding::default();
        // Axes that do not move are at rest where they are.
        let mut x_rest = match motion.x {
            None => Some(self.axes.x.status()?.position),
            Some(_) => None,
        };
        let mut y_rest = match motion.y {
            None => Some(self.axes.y.status()?.position),
            Some(_) => None,
        };
        let mut z_moving = false;
        let mut next_servo = Instant::now() + SERVO_PERIOD;
        loop {
            if let Some(alarm) = self.interrupted() {
                return Ok(HeldTo::Interrupted(alarm));
            }
            if z_moving && settled(self.axes.z.as_mut())?.is_some() {
                z_moving = false;
            }
            if Instant::now() >= next_servo {
                next_servo += SERVO_PERIOD;
                if !z_moving {
                    let force = match guard.pressing_force() {
                        Ok(f) => f,
                        Err(PressError::Cancelled) => continue,
                        Err(e) => return Err(e.into()),
                    };
                    let error = s.force.0 - force.0;
                    holding.worst = holding.worst.max(error.abs());
                    holding.sum_sq += error * error;
                    holding.reads += 1;
                    if let Some((_, mean)) = self.monitor.mean_of_last(self.press.average_samples) {
                        let t = tangential_of(&mean, self.tare.forces());
                        holding.tangential = holding.tangential.max(t.0);
                    }
                    if error.abs() > self.press.tolerance.0 / 2.0 {
                        let dz = (SERVO_GAIN * error / stiffness)
                            .clamp(-MAX_SERVO_STEP.0, MAX_SERVO_STEP.0);
                        self.axes.z.begin_move_by(Millimetres(dz))?;
                        z_moving = true;
                        holding.corrections += 1;
                    }
                }
            }
            if x_rest.is_none() {
                x_rest = settled(self.axes.x.as_mut())?.map(|st| st.position);
            }
            if y_rest.is_none() {
                y_rest = settled(self.axes.y.as_mut())?.map(|st| st.position);
            }
            if let (Some(x), Some(y)) = (x_rest, y_rest) {
                if z_moving {
                    self.axes.z.wait_idle(MOVE_TIMEOUT)?;
                }
                return Ok(HeldTo::End {
                    holding,
                    rest: [x.0, y.0],
                });
            }
            if Instant::now() > deadline {
                return Err(ScanError::Setup(format!(
                    "the slide did not finish within {:.1} s ({}, {})",
                    motion.seconds(s.distance.0) + 10.0,
                    self.axes.x.endpoint(),
                    self.axes.y.endpoint()
                )));
            }
            self.status(false);
            std::thread::sleep(POLL.min(Duration::from_millis(2)));
        }
    }

    /// Stops x, y and z at once (a y stage moved by hand has nothing to stop).
    pub(super) fn stop_all(&mut self) {
        let manual_y = self.setup.limits.manual_y;
        let mut axes: Vec<&mut Box<dyn Axis>> = vec![&mut self.axes.x, &mut self.axes.z];
        if !manual_y {
            axes.push(&mut self.axes.y);
        }
        for axis in &mut axes {
            let _ = axis.stop(StopMode::Immediate);
        }
        for axis in axes {
            let _ = axis.wait_idle(MOVE_TIMEOUT);
        }
    }
}

/// How the normal-force loop of a slide ended.
enum HeldTo {
    End { holding: Holding, rest: [f64; 2] },
    Interrupted(Alarm),
}
