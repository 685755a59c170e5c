//! What the F/T reads with nothing touching: the no-contact offset taken at the safe height
//! before every point, and the checks that refuse a motion while something touches.

use super::runner::{Runner, POLL, TARE_SAMPLES};
use crate::clock::HostTime;
use crate::scan::clearance::{Motion, UnderLoad, LOAD_SAMPLES};
use crate::scan::control::ScanProgress;
use crate::scan::failure::ScanError;
use crate::units::Millimetres;
use std::time::{Duration, Instant};

/// Longest wait for fresh samples to tare from after an interruption.
const FRESH_TARE_TIMEOUT: Duration = Duration::from_secs(5);

impl Runner<'_> {
    /// Measures the no-contact offset at the safe height (every point: drift is tracked).
    pub(super) fn tare(&mut self, point: u64) -> Result<[f64; 6], ScanError> {
        if let Some(after) = self.tare_not_before {
            self.wait_for_fresh_samples(after)?;
            self.tare_not_before = None;
        }
        let (_, mean) = self
            .monitor
            .mean_of_last(TARE_SAMPLES)
            .ok_or_else(|| super::runner::no_samples(&self.monitor))?;
        let restarts = self.monitor.stats().restarts;
        // Never a no-contact offset under load: it would hide the load from every label and
        // from the ceiling. After a device restart its zero moved: the reading starts again here.
        let from = if self.clearance.outdated(restarts) {
            format!(
                "at the safe height before point {} (the device had restarted)",
                point + 1
            )
        } else if self.clearance.loaded(mean[2]) {
            return Err(self.under_load(Motion::Tare, mean[2]).into());
        } else {
            format!("at the tare before point {}", point + 1)
        };
        self.clearance.follow(mean[2], restarts, from);
        self.tare.set(&mean);
        if restarts > self.force_restarts_seen {
            self.force_restarts_seen = restarts;
            let warning = format!(
                "force sensor {}: the device restarted (its sample counter began again; {restarts} time(s) this session): a bias set in it is gone and its zero moved, which this point's tare takes out of the labels; if it happens again, check the box's power supply and cable",
                self.monitor.device()
            );
            self.recorder.event("warning", Some(point), &warning);
            (self.progress)(ScanProgress::Message(format!("warning: {warning}")));
        }
        if !self.offset_checked {
            self.offset_checked = true;
            if let Some(check) = &self.setup.offset_check {
                let (n, sd) = self.monitor.spread_of_last(TARE_SAMPLES);
                let se = sd.map(|s| s / (n.max(1) as f64).sqrt());
                for warning in check.check(mean, se) {
                    self.recorder.event("warning", Some(point), &warning);
                    (self.progress)(ScanProgress::Message(format!("warning: {warning}")));
                }
            }
        }
        self.recorder.event(
            "force-offset",
            Some(point),
            &format!(
                "no-contact offset Fx {:.4} Fy {:.4} Fz {:.4} N, Mx {:.5} My {:.5} Mz {:.5} N m",
                mean[0], mean[1], mean[2], mean[3], mean[4], mean[5]
            ),
        );
        Ok(mean)
    }

    /// Paused, with z at the safe height, after the F/T device restarted: the force the
    /// watchers see over the ceiling is the device's new zero, not a load. Their zero is taken
    /// again from samples of no contact; false if there is no restart or not enough samples yet.
    pub(super) fn retare_after_restart(&mut self) -> bool {
        if self.monitor.stats().restarts <= self.force_restarts_seen {
            return false;
        }
        let Some(after) = self.tare_not_before else {
            return false;
        };
        if self.monitor.count_since(after) < TARE_SAMPLES {
            return false;
        }
        let Some((_, mean)) = self.monitor.mean_of_last(TARE_SAMPLES) else {
            return false;
        };
        self.tare.set(&mean);
        true
    }

    /// Waits until [`TARE_SAMPLES`] samples have arrived after `after`.
    fn wait_for_fresh_samples(&mut self, after: HostTime) -> Result<(), ScanError> {
        let waiting = Instant::now();
        loop {
            let fresh = self.monitor.count_since(after);
            if fresh >= TARE_SAMPLES {
                self.excluded += waiting.elapsed();
                return Ok(());
            }
            if waiting.elapsed() > FRESH_TARE_TIMEOUT {
                return Err(ScanError::Setup(format!(
                    "{}: {fresh} force samples in {} s at the safe height after the interruption, {TARE_SAMPLES} needed to take the no-contact offset: check the F/T stream",
                    self.monitor.device(),
                    FRESH_TARE_TIMEOUT.as_secs()
                )));
            }
            std::thread::sleep(POLL);
        }
    }

    /// Fz now (N): the mean of the newest [`LOAD_SAMPLES`]; `None` before any sample (the
    /// watchers stop a silent stream).
    pub(super) fn fz_now(&self) -> Option<f64> {
        self.monitor.mean_of_last(LOAD_SAMPLES).map(|(_, m)| m[2])
    }

    /// Refuses `motion` when the F/T reads a load now.
    pub(super) fn check_clear(&mut self, motion: Motion) -> Result<(), ScanError> {
        match self.fz_now() {
            Some(fz) if self.clearance.loaded(fz) => Err(self.under_load(motion, fz).into()),
            _ => Ok(()),
        }
    }

    /// The refusal of `motion` under the load `fz` reads. The safe height proved not to be
    /// clear: from here on z retracts to the end of its travel away from the sensor, and it is
    /// taken there now (a move away from the sensor is always allowed).
    pub(super) fn under_load(&mut self, motion: Motion, fz: f64) -> UnderLoad {
        let z = self
            .axes
            .z
            .status()
            .map_or(Millimetres(f64::NAN), |s| s.position);
        let safe_z = self.safe_z;
        self.safe_z = self.setup.limits.z.min;
        let lifted_to = match self.retract() {
            Ok(()) => self.safe_z,
            Err(_) => Millimetres(f64::NAN),
        };
        UnderLoad {
            device: self.monitor.device().to_string(),
            motion,
            load: self.clearance.load(fz),
            threshold: self.clearance.threshold(),
            z,
            safe_z,
            lifted_to,
            reference_from: self.clearance.from().to_string(),
        }
    }
}
