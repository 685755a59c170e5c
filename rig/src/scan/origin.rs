//! The contact origin: the stage position that presses the sensor's optical centre.
//!
//! Contact labels are in mm relative to the sensor centre along the stage axes:
//! contact = stage - origin. The origin comes from the sensor's calibration profile when there is
//! one, otherwise from the rig file (or the simulated bench's geometry).

use crate::units::Millimetres;

#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ContactOrigin {
    /// Stage x that puts the indenter over the optical centre.
    pub x: Millimetres,
    /// Stage y that puts the indenter over the optical centre.
    pub y: Millimetres,
    /// Where the values come from ("profile profiles/s1.toml", "rig.toml [geometry]", ...).
    pub source: String,
}

impl ContactOrigin {
    /// The contact point (mm from the sensor centre) of an indenter at stage (x, y).
    pub fn contact_mm(&self, x: Millimetres, y: Millimetres) -> [f64; 2] {
        [x.0 - self.x.0, y.0 - self.y.0]
    }

    /// The stage position that presses `contact` (mm from the sensor centre).
    pub fn stage_for(&self, contact: [f64; 2]) -> (Millimetres, Millimetres) {
        (
            Millimetres(self.x.0 + contact[0]),
            Millimetres(self.y.0 + contact[1]),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn contact_and_stage_positions_are_inverse() {
        let o = ContactOrigin {
            x: Millimetres(12.5),
            y: Millimetres(25.0),
            source: "test".into(),
        };
        assert_eq!(
            o.contact_mm(Millimetres(10.0), Millimetres(27.0)),
            [-2.5, 2.0]
        );
        assert_eq!(
            o.stage_for([-2.5, 2.0]),
            (Millimetres(10.0), Millimetres(27.0))
        );
    }
}
