//! The rig's setup a rig file describes: soft limits and kinematics, the force ceiling, the contact
//! height and origin, and the sensor's id; from the file's keys on real hardware, from the
//! simulated rig (`rig::simulated`) when the rig is simulated.

use crate::rig::file::{AxisDriver, AxisSection, RigConfig};
use crate::rig::force::section::ForceDriver;
use crate::rig::simulated;
use fringe_rig::atical::Calibration;
use fringe_rig::ConfigError;
use fringe_rig::ContactOrigin;
use fringe_rig::{scan::FtRating, BenchLimits};
use fringe_rig::{Kinematics, SoftLimits};
use fringe_rig::{Millimetres, MillimetresPerSecond, MillimetresPerSecondSquared, Newtons};

/// The largest force on the bench when the rig file does not say (or the transducer's rated
/// range, when lower).
pub(crate) const DEFAULT_MAX_FORCE: Newtons = Newtons(20.0);

impl RigConfig {
    /// Soft limits, kinematics, force ceiling and contact height of the bench. A `max_force`
    /// above the F/T transducer's rated range (where its calibration is known) is refused.
    pub fn limits(&self) -> Result<BenchLimits, ConfigError> {
        let given = self.file.force.max_force.map(Newtons);
        let mut limits = self.bench_limits(given.unwrap_or(DEFAULT_MAX_FORCE))?;
        if let Some(rating) = &limits.ft_rating {
            match given {
                Some(m) => rating
                    .check("force.max_force", m)
                    .map_err(|e| self.err(e))?,
                None => limits.max_force = Newtons(limits.max_force.0.min(rating.fz.0)),
            }
        }
        Ok(limits)
    }

    /// A warning when the F/T transducer's rated range is unknown before its device is opened
    /// (a real Net F/T): the forces of the rig and of every plan are then not checked against it.
    pub fn ft_rating_warning(&self) -> Option<String> {
        let limits = self.limits().ok()?;
        if limits.ft_rating.is_some() {
            return None;
        }
        Some(format!(
            "{}: the rated range of the F/T transducer is not known before it is opened, so force.max_force ({:.1} N) and the plans' force ceilings are not checked against it: make sure they are within the transducer's rated Fz (its calibration sheet)",
            self.origin, limits.max_force.0
        ))
    }

    /// The bench's limits with `max_force`, from the simulated bench or the rig file's keys.
    fn bench_limits(&self, max_force: Newtons) -> Result<BenchLimits, ConfigError> {
        if self.simulated {
            return simulated::limits(self, max_force);
        }
        let f = &self.file;
        let axis = |name: &str, a: &AxisSection| -> Result<(SoftLimits, Kinematics), ConfigError> {
            let (Some(min), Some(max)) = (a.min, a.max) else {
                return Err(self.err(format!(
                    "[{name}]: keys `{name}.min` and `{name}.max` (soft limits, mm) are required on real hardware"
                )));
            };
            let limits = SoftLimits::new(Millimetres(min), Millimetres(max))
                .map_err(|e| self.err(format!("[{name}] min/max: {e}")))?;
            Ok((
                limits,
                Kinematics {
                    velocity: MillimetresPerSecond(a.velocity.unwrap_or(1.0)),
                    acceleration: MillimetresPerSecondSquared(a.acceleration.unwrap_or(1.0)),
                },
            ))
        };
        let (x, x_motion) = axis("x", &f.x)?;
        let (y, y_motion) = axis("y", &f.y)?;
        let (z, z_motion) = axis("z", &f.z)?;
        let contact_z = f.geometry.z_contact.ok_or_else(|| {
            self.err(
                "key `geometry.z_contact` is required on real hardware: the z (mm) at which the indenter roughly touches the sensor (the approach stops 3 mm past it)"
                    .into(),
            )
        })?;
        if z.check("z", Millimetres(contact_z)).is_err() {
            return Err(self.err(format!(
                "key `geometry.z_contact` = {contact_z} mm is outside the z soft limits {:.3} .. {:.3} mm: give the z (mm) at which the indenter touches the sensor, within z's travel",
                z.min.0, z.max.0
            )));
        }
        Ok(BenchLimits {
            x,
            y,
            z,
            x_motion,
            y_motion,
            z_motion,
            manual_y: f.y.driver == AxisDriver::Manual,
            max_force,
            // A Net F/T's rated range is known to its box only; a DAQ's is in its .cal file.
            ft_rating: self.daq_rating()?,
            contact_z: Millimetres(contact_z),
            // Where a real bench's axes are before they home is unknown.
            start: None,
        })
    }

    /// The rated range of a DAQ rig's transducer, from its `.cal` file (read here, before any
    /// device opens, so that a file that cannot be read is named first).
    fn daq_rating(&self) -> Result<Option<FtRating>, ConfigError> {
        let f = &self.file.force;
        let (ForceDriver::Nidaqmx, Some(path)) = (f.driver, &f.cal_file) else {
            return Ok(None);
        };
        let cal = Calibration::load(path).map_err(|e| {
            self.err(format!(
                "key `force.cal_file`: {e}; give the transducer's ATI calibration file (FT*.cal, from the CD or ATI's site by serial number)"
            ))
        })?;
        Ok(Some(FtRating {
            transducer: format!(
                "{} ({}, serial {}, {})",
                cal.body_style,
                cal.part_number,
                cal.serial,
                path.display()
            ),
            fz: Newtons(cal.max_loads[2]),
        }))
    }

    /// The contact origin given by the rig file (or the simulated bench's geometry).
    pub fn origin(&self) -> Result<ContactOrigin, ConfigError> {
        let g = &self.file.geometry;
        if self.simulated {
            return simulated::origin(self);
        }
        match (g.x_centre, g.y_centre) {
            (Some(x), Some(y)) => Ok(ContactOrigin {
                x: Millimetres(x),
                y: Millimetres(y),
                source: format!("{} [geometry]", self.origin),
            }),
            _ => Err(self.err(
                "keys `geometry.x_centre` and `geometry.y_centre` (stage mm over the sensor centre) are required on real hardware until `fringe calibrate` has written a profile for this sensor"
                    .into(),
            )),
        }
    }

    /// The sensor's design: the rig file's `variant`, or the simulated sensor's; `None` when a
    /// real rig's file does not say.
    pub fn sensor_variant(&self) -> Result<Option<&'static str>, ConfigError> {
        if let Some(v) = self.file.variant {
            return Ok(Some(v.name()));
        }
        if self.simulated {
            return simulated::sensor_variant(self).map(Some);
        }
        Ok(None)
    }

    /// The sensor id: the rig file's, or the simulated sensor's.
    pub fn sensor_id(&self) -> Result<String, ConfigError> {
        if let Some(id) = &self.file.sensor {
            return Ok(id.clone());
        }
        if self.simulated {
            return simulated::sensor_id(self);
        }
        Err(self.err(
            "key `sensor` (the sensor build id, e.g. \"layered-01\") is required on real hardware"
                .into(),
        ))
    }
}
