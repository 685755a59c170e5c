//! No load where there must be none: at the safe height, before and during a lateral move, and
//! when the no-contact offset (tare) is taken.
//!
//! The F/T's no-contact reading is first taken with z homed (away from the sensor, where nothing
//! can touch the indenter), then followed from tare to tare, so that the slow drift of the
//! transducer is tracked and a load is told from a zero: a reading more than the load threshold
//! off the last no-contact reading is a load. A device restart moves its zero: the next tare then
//! starts the reading again (the scan is at the safe height, which the plan's check put clear of
//! the sensor).

use crate::units::{Millimetres, Newtons};

/// The smallest load threshold: the F/T's noise over a short mean stays well under it.
pub(crate) const MIN_LOAD: Newtons = Newtons(0.1);

/// Force samples averaged to tell a load (10 ms at 5 kHz): before and during a lateral move, and
/// before a tare.
pub const LOAD_SAMPLES: usize = 50;

/// What was about to happen, or happening, under load.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Motion {
    /// z going down from its home to the safe height.
    ToSafeHeight,
    /// The no-contact offset (tare) at the safe height.
    Tare,
    /// A lateral (x, y) move about to start.
    LateralStart,
    /// A lateral move under way (stopped at once).
    LateralMoving,
}

impl Motion {
    fn describe(self) -> &'static str {
        match self {
            Motion::ToSafeHeight => "the move down to the safe height was stopped",
            Motion::Tare => "the no-contact offset (tare) was not taken",
            Motion::LateralStart => "the lateral move was not started",
            Motion::LateralMoving => "the lateral move was stopped at once",
        }
    }
}

/// A load read where there must be none.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error(
    "force sensor {device}: {load:.2} N of load at z {z:.3} (more than {threshold:.2} off its no-contact reading, taken {reference_from}): {}; the indenter touches the sensor or something else at the safe height {safe_z:.3} (z grows towards the sensor), and z was lifted to {lifted_to:.3}",
    motion.describe()
)]
pub struct UnderLoad {
    pub device: String,
    pub motion: Motion,
    /// The pressing force against the no-contact reading.
    pub load: Newtons,
    pub threshold: Newtons,
    pub z: Millimetres,
    pub safe_z: Millimetres,
    /// Where z was taken (away from the sensor) after the refusal.
    pub lifted_to: Millimetres,
    pub reference_from: String,
}

/// The F/T's no-contact reading in Fz and the threshold a load is told by.
#[derive(Debug, Clone, PartialEq)]
pub struct Clearance {
    /// Fz of no contact, N.
    reference_fz: f64,
    /// The device's restarts when the reference was taken.
    restarts: u64,
    /// Where the reference was taken, for messages.
    from: String,
    threshold: Newtons,
}

impl Clearance {
    /// The reference `fz` (N, a mean of no-contact samples) taken `from` (for messages) after
    /// `restarts` restarts of the device; a load is more than `contact_threshold` (at least
    /// [`MIN_LOAD`]) off it.
    pub fn new(fz: f64, restarts: u64, from: String, contact_threshold: Newtons) -> Clearance {
        Clearance {
            reference_fz: fz,
            restarts,
            from,
            threshold: Newtons(contact_threshold.0.max(MIN_LOAD.0)),
        }
    }

    pub fn threshold(&self) -> Newtons {
        self.threshold
    }

    /// Where the reference was taken.
    pub fn from(&self) -> &str {
        &self.from
    }

    /// The load `fz` reads against the reference (its size, pressing or pulling).
    pub fn load(&self, fz: f64) -> Newtons {
        Newtons((self.reference_fz - fz).abs())
    }

    /// Whether `fz` reads a load (NaN counts as one: nothing moves on a reading it cannot trust).
    pub fn loaded(&self, fz: f64) -> bool {
        let load = self.load(fz).0;
        load.is_nan() || load > self.threshold.0
    }

    /// Whether the device restarted since the reference was taken (its zero moved).
    pub fn outdated(&self, restarts: u64) -> bool {
        restarts > self.restarts
    }

    /// Follows the reference to a no-contact reading `fz` (a tare found clear, or the first after
    /// a restart) taken `from`.
    pub fn follow(&mut self, fz: f64, restarts: u64, from: String) {
        self.reference_fz = fz;
        self.restarts = restarts;
        self.from = from;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_load_is_told_from_the_no_contact_reading_either_way_and_follows_drift() {
        let mut c = Clearance::new(-1.0, 0, "with z homed".into(), Newtons(0.3));
        assert!(!c.loaded(-1.2));
        assert!(c.loaded(-6.07), "5 N pressing");
        assert!(c.loaded(-0.5), "0.5 N pulling");
        assert!(c.loaded(f64::NAN));
        assert!((c.load(-6.07).0 - 5.07).abs() < 1e-9);
        c.follow(-1.25, 0, "at point 1".into());
        assert!(!c.loaded(-1.5), "drift followed");
        assert!(!c.outdated(0) && c.outdated(1));
        // A threshold under the F/T noise is raised to the floor.
        let tiny = Clearance::new(0.0, 0, String::new(), Newtons(0.02));
        assert_eq!(tiny.threshold(), MIN_LOAD);
        assert!(!tiny.loaded(0.05));
    }
}
