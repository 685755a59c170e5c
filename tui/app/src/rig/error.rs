//! Why a rig could not be opened: its file says something that cannot work, a device did not
//! open, or the simulated bench did not start.

use crate::rig::device_open::DeviceError;
use fringe_rig::ConfigError;

/// A rig that could not be opened.
#[derive(Debug, thiserror::Error)]
pub enum RigError {
    #[error(transparent)]
    Config(#[from] ConfigError),
    #[error(transparent)]
    Device(#[from] DeviceError),
    #[cfg(feature = "sim")]
    #[error("the simulated bench did not start: {0}")]
    Sim(#[source] fringe_sim::SimRigError),
}
