//! A build without the simulated bench (cargo feature `sim` off): rig files whose devices are all
//! simulated are refused when they are read, so these answer only if that check is bypassed.

use crate::rig::file::{RigConfig, NO_SIM};
use fringe_rig::BenchLimits;
use fringe_rig::ConfigError;
use fringe_rig::ContactOrigin;
use fringe_rig::Newtons;
use std::path::Path;

pub(crate) fn refused(rig: &RigConfig) -> ConfigError {
    rig.err(NO_SIM.into())
}

pub(crate) fn limits(rig: &RigConfig, _max_force: Newtons) -> Result<BenchLimits, ConfigError> {
    Err(refused(rig))
}

pub(crate) fn origin(rig: &RigConfig) -> Result<ContactOrigin, ConfigError> {
    Err(refused(rig))
}

pub(crate) fn sensor_id(rig: &RigConfig) -> Result<String, ConfigError> {
    Err(refused(rig))
}

pub(crate) fn sensor_variant(rig: &RigConfig) -> Result<&'static str, ConfigError> {
    Err(refused(rig))
}

/// No simulated units in this build.
pub(crate) fn units() -> Vec<(String, &'static str)> {
    Vec::new()
}

/// No simulator's sensor files in this build.
pub(crate) fn sensor_file(_path: &Path) -> Option<(String, &'static str)> {
    None
}
