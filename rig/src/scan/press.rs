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

use super::silence::{await_fresh_sample, Silent, FORCE_SILENCE};
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

    /// The pressing force averaged over the configured number of samples. Called with z at
    /// rest: a stream whose newest sample is older than the silence limit gets that long of this
    /// thread's own running time to deliver (a host that held the F/T reader is not a stalled
    /// sensor); one that stays quiet is an error.
    pub fn pressing_force(&self) -> Result<Newtons, PressError> {
        await_fresh_sample(self.monitor, FORCE_SILENCE, || {
            self.cancel.load(Ordering::SeqCst)
        })
        .map_err(|silent| match silent {
            Silent::Stopped => PressError::Cancelled,
            Silent::Failed(e) => self.force_error(e),
            Silent::NoSamples => self.force_error("no samples yet".into()),
            Silent::For(s) => self.force_error(format!(
                "no data for {} ms (check the cable and the stream)",
                s.as_millis()
            )),
        })?;
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
