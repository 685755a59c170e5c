//! Thorlabs actuators: microsteps per millimetre, actuator type codes for
//! MOT_SET_TSTACTUATORTYPE, and conversion of positions, velocities and accelerations to the
//! device units of the stepper controllers (KST101, KST201, BSC20x).

use crate::units::{Millimetres, MillimetresPerSecond, MillimetresPerSecondSquared};

/// Velocity scale of the stepper controllers: device units per microstep/s.
pub const VELOCITY_SCALE: f64 = 53.68;
/// Acceleration scale: device units per microstep/s^2.
pub const ACCELERATION_SCALE: f64 = 53.68 * 204.94e-6;

/// One actuator model.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Actuator {
    /// Canonical name ("ZFS25").
    pub name: &'static str,
    /// Microsteps per millimetre of travel (2048 microsteps per full step).
    pub microsteps_per_mm: f64,
    /// Code for MOT_SET_TSTACTUATORTYPE, where the controller has one for this actuator.
    pub type_code: Option<u8>,
    /// Travel between its limit switches, where its name says it (ZFS25: 25 mm); `None` for
    /// the DRV013, DRV014 and DRV001, whose travel fringe does not know.
    pub travel: Option<Millimetres>,
}

const ZFS: f64 = 24.0 * 2048.0 * 400.0 / 9.0;
const ZST: f64 = 24.0 * 2048.0 * 40.866;
const DRV: f64 = 409_600.0;
const DRV_FINE: f64 = 819_200.0;

/// Every actuator known by name.
pub const ACTUATORS: &[Actuator] = &[
    Actuator {
        name: "ZFS06",
        microsteps_per_mm: ZFS,
        type_code: Some(0x40),
        travel: Some(Millimetres(6.0)),
    },
    Actuator {
        name: "ZFS13",
        microsteps_per_mm: ZFS,
        type_code: Some(0x41),
        travel: Some(Millimetres(13.0)),
    },
    Actuator {
        name: "ZFS25",
        microsteps_per_mm: ZFS,
        type_code: Some(0x42),
        travel: Some(Millimetres(25.0)),
    },
    Actuator {
        name: "ZST206",
        microsteps_per_mm: ZST,
        type_code: Some(0x30),
        travel: Some(Millimetres(6.0)),
    },
    Actuator {
        name: "ZST213",
        microsteps_per_mm: ZST,
        type_code: Some(0x31),
        travel: Some(Millimetres(13.0)),
    },
    Actuator {
        name: "ZST225",
        microsteps_per_mm: ZST,
        type_code: Some(0x32),
        travel: Some(Millimetres(25.0)),
    },
    Actuator {
        name: "DRV013",
        microsteps_per_mm: DRV,
        type_code: Some(0x50),
        travel: None,
    },
    Actuator {
        name: "DRV014",
        microsteps_per_mm: DRV,
        type_code: Some(0x51),
        travel: None,
    },
    Actuator {
        name: "DRV225",
        microsteps_per_mm: DRV,
        type_code: Some(0xB0),
        travel: Some(Millimetres(25.0)),
    },
    Actuator {
        name: "DRV250",
        microsteps_per_mm: DRV,
        type_code: Some(0xB1),
        travel: Some(Millimetres(50.0)),
    },
    Actuator {
        name: "DRV208",
        microsteps_per_mm: DRV_FINE,
        type_code: Some(0xB2),
        travel: Some(Millimetres(8.0)),
    },
    Actuator {
        name: "DRV001",
        microsteps_per_mm: DRV_FINE,
        type_code: None,
        travel: None,
    },
    Actuator {
        name: "NRT100",
        microsteps_per_mm: DRV,
        type_code: Some(0xB3),
        travel: Some(Millimetres(100.0)),
    },
    Actuator {
        name: "NRT150",
        microsteps_per_mm: DRV,
        type_code: Some(0xB4),
        travel: Some(Millimetres(150.0)),
    },
    Actuator {
        name: "LTS150",
        microsteps_per_mm: DRV,
        type_code: None,
        travel: Some(Millimetres(150.0)),
    },
    Actuator {
        name: "LTS300",
        microsteps_per_mm: DRV,
        type_code: None,
        travel: Some(Millimetres(300.0)),
    },
];

/// Conversion out of range for the 32-bit device field.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{what} {value} is out of range for the controller ({device_units} device units)")]
pub struct OutOfRange {
    pub what: &'static str,
    pub value: String,
    pub device_units: f64,
}

fn to_i32(what: &'static str, value: String, x: f64) -> Result<i32, OutOfRange> {
    let r = x.round();
    if r.is_finite() && r >= i32::MIN as f64 && r <= i32::MAX as f64 {
        Ok(r as i32)
    } else {
        Err(OutOfRange {
            what,
            value,
            device_units: x,
        })
    }
}

impl Actuator {
    /// Looks an actuator up by name, case-insensitively; a trailing "B"/"-B" suffix
    /// (ZFS25B) and the ZST short names (ZST25 for ZST225) are accepted.
    pub fn by_name(name: &str) -> Option<Actuator> {
        let mut n = name.trim().to_ascii_uppercase().replace('-', "");
        if n.ends_with('B') && n.len() > 3 {
            n.pop();
        }
        let n = match n.as_str() {
            "ZFS6" => "ZFS06".to_string(),
            "ZST6" | "ZST206" => "ZST206".to_string(),
            "ZST13" => "ZST213".to_string(),
            "ZST25" => "ZST225".to_string(),
            _ => n,
        };
        ACTUATORS.iter().find(|a| a.name == n).copied()
    }

    /// The names accepted by [`Actuator::by_name`], for error messages.
    pub fn known_names() -> String {
        ACTUATORS
            .iter()
            .map(|a| a.name)
            .collect::<Vec<_>>()
            .join(", ")
    }

    /// Millimetres to microsteps.
    pub fn to_steps(&self, mm: Millimetres) -> Result<i32, OutOfRange> {
        to_i32("position", format!("{mm}"), mm.0 * self.microsteps_per_mm)
    }

    /// Microsteps to millimetres.
    pub fn to_mm(&self, steps: i32) -> Millimetres {
        Millimetres(steps as f64 / self.microsteps_per_mm)
    }

    /// Velocity to controller units (KST101/KST201/BSC20x).
    pub fn velocity_to_device(&self, v: MillimetresPerSecond) -> Result<i32, OutOfRange> {
        to_i32(
            "velocity",
            format!("{v}"),
            v.0 * self.microsteps_per_mm * VELOCITY_SCALE,
        )
    }

    /// Controller velocity units to mm/s.
    pub fn velocity_from_device(&self, v: i32) -> MillimetresPerSecond {
        MillimetresPerSecond(v as f64 / (self.microsteps_per_mm * VELOCITY_SCALE))
    }

    /// Acceleration to controller units.
    pub fn acceleration_to_device(
        &self,
        a: MillimetresPerSecondSquared,
    ) -> Result<i32, OutOfRange> {
        to_i32(
            "acceleration",
            format!("{a}"),
            a.0 * self.microsteps_per_mm * ACCELERATION_SCALE,
        )
    }

    /// Controller acceleration units to mm/s^2.
    pub fn acceleration_from_device(&self, a: i32) -> MillimetresPerSecondSquared {
        MillimetresPerSecondSquared(a as f64 / (self.microsteps_per_mm * ACCELERATION_SCALE))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn drv250_conversions_match_the_published_figures() {
        let a = Actuator::by_name("DRV250").expect("known");
        assert_eq!(
            a.velocity_to_device(MillimetresPerSecond(1.0)),
            Ok(21_987_328)
        );
        assert_eq!(
            a.acceleration_to_device(MillimetresPerSecondSquared(1.0)),
            Ok(4_506)
        );
        assert_eq!(a.to_steps(Millimetres(1.0)), Ok(409_600));
        assert_eq!(a.type_code, Some(0xB1));
    }

    #[test]
    fn scales_per_family() {
        let zfs = Actuator::by_name("zfs25b").expect("ZFS25B");
        assert!((zfs.microsteps_per_mm - 2_184_533.33).abs() < 0.01);
        assert_eq!(zfs.type_code, Some(0x42));
        let zst = Actuator::by_name("ZST213B").expect("ZST213B");
        assert!((zst.microsteps_per_mm - 2_008_645.6).abs() < 0.1);
        assert_eq!(zst.type_code, Some(0x31));
        assert_eq!(Actuator::by_name("ZST25").map(|a| a.name), Some("ZST225"));
        assert_eq!(
            Actuator::by_name("DRV208").map(|a| a.microsteps_per_mm),
            Some(819_200.0)
        );
        assert_eq!(
            Actuator::by_name("NRT150").and_then(|a| a.type_code),
            Some(0xB4)
        );
        assert_eq!(
            Actuator::by_name("LTS300").map(|a| a.microsteps_per_mm),
            Some(409_600.0)
        );
        assert!(Actuator::by_name("Z825").is_none());
    }

    #[test]
    fn round_trip_and_range() {
        let a = Actuator::by_name("ZFS13").expect("known");
        let steps = a.to_steps(Millimetres(5.0)).expect("in range");
        assert_eq!(steps, 10_922_667);
        assert!((a.to_mm(steps).0 - 5.0).abs() < 1e-6);
        assert!(a.to_steps(Millimetres(5000.0)).is_err());
        assert!(a.to_steps(Millimetres(f64::NAN)).is_err());
        let v = a
            .velocity_to_device(MillimetresPerSecond(2.0))
            .expect("in range");
        assert!((a.velocity_from_device(v).0 - 2.0).abs() < 1e-6);
        let acc = a
            .acceleration_to_device(MillimetresPerSecondSquared(3.0))
            .expect("in range");
        assert!((a.acceleration_from_device(acc).0 - 3.0).abs() < 1e-3);
    }
}
