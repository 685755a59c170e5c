//! The calibration profile a unit will be used with, known from the rig file alone before any
//! device opens: the unit's profile on file, else on the simulated bench its design's geometry;
//! none on a real rig before the unit's first calibration. Forecasts (a commissioning's) and the
//! terminal UI's plan on the disc read it; a scan reads the profile its session opened with.

use super::file::RigConfig;
use fringe_calibration::Profile;
use fringe_rig::ConfigError;

/// The profile the unit `sensor` will be used with on the rig `config` (see the module).
pub fn unit_profile(config: &RigConfig, sensor: &str) -> Result<Option<Profile>, ConfigError> {
    let on_file = fringe_calibration::profile_path(&config.profile_dir(), sensor)
        .ok()
        .filter(|p| p.is_file())
        .and_then(|p| Profile::load(&p).ok());
    let profile = match on_file {
        Some(p) => Some(p),
        #[cfg(feature = "sim")]
        None if config.is_simulated() => Some(super::simulated::design_profile(
            &super::simulated::config(config)?,
            sensor,
        )),
        None => None,
    };
    Ok(profile)
}
