//! ATI DAQ force/torque sensors: `.cal` calibration files and gauge voltages -> wrench.
//!
//! - [`calfile`]: parsing `.cal` XML (version 1.0 `Axis` rows + `BasicTransform`, version 1.1
//!   `UserAxis` rows that already include it), units normalised to N and N m.
//! - [`transform`]: tool transforms (translation and rotation) on wrenches.
//! - [`sensor`]: the [`GaugeSource`] trait a DAQ implements and [`CalibratedSensor`], a
//!   [`crate::force::ForceSensor`] over any gauge source.

pub(crate) mod calfile;
pub(crate) mod sensor;
pub(crate) mod transform;

pub use calfile::{CalError, Calibration};
pub use sensor::{CalibratedSensor, GaugeReading, GaugeSource, SATURATION_SHARE};
pub use transform::ToolTransform;
