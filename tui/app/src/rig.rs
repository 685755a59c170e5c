//! The device door: the rig file read and checked, the rig it describes opened, and the one
//! opener of real devices, which the rig and the bring-up commands share.
//!
//! - `file`: the rig file (`rig.toml`), read and checked; re-exported as `RigConfig`.
//! - `setup`: the rig it describes: soft limits and kinematics, the force ceiling, the contact
//!   height and origin, the sensor's id.
//! - `devices`: its device sections as device descriptions.
//! - `open` and `error`: opening every device of the rig, real or simulated, and why it failed.
//! - `device_spec`: what a device is and how it is reached, from a rig file section or a
//!   command's flags; `device_open`: opening it; `host_port`: `HOST[:PORT]`, IPv6 included.
//! - `force`: the F/T door, one module per interface (`force::netft`, `force::nidaqmx`) and
//!   the rig file's `[force]` section (`force::section`).
//! - `simulated`: the simulated rig behind a rig file (public with the cargo feature `sim`, a
//!   default).

pub(crate) mod device_open;
pub(crate) mod device_spec;
pub(crate) mod devices;
pub(crate) mod error;
pub(crate) mod file;
pub(crate) mod force;
pub(crate) mod host_port;
pub(crate) mod open;
pub(crate) mod setup;
#[cfg(feature = "sim")]
pub(crate) mod simulated;
#[cfg(not(feature = "sim"))]
#[path = "rig/no_simulated.rs"]
pub(crate) mod simulated;
pub(crate) mod unit_profile;

pub use device_open::{open_axis, open_modbus, open_thorlabs, DeviceError, TraceTo};
pub use device_spec::{AxisSpec, CameraSpec, ModbusLink, ModbusSpec};
pub use file::{
    AxisDriver, AxisSection, CameraDriver, CameraSection, GeometrySection, HomeSection, RigFile,
    SimForcePath, SimSection, StreamSection,
};
pub use force::netft::{open_netft, NetFtScaling, NetFtSpec};
pub use force::nidaqmx::names::DaqNames;
pub use force::nidaqmx::{daq_error, open_daq, DaqForce, DaqGauges, DaqSpec};
pub use force::section::{ForceDriver, ForceSection};
pub use force::ForceSpec;
pub use host_port::{HostPort, HostPortError};
pub use open::OpenCamera;
#[cfg(feature = "sim")]
pub use simulated::{
    config as sim_config, sensor_by_name, sensor_profile, CalibrationTruth, RegistrationTruth,
    SensorNameError, SimBench,
};
pub use unit_profile::unit_profile;
