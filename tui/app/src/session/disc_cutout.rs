//! The part of each frame a scan stores when only the disc's square is kept (`[recording] store =
//! "disc"`): the square of the sensor's calibration profile, and why it cannot be had.

use crate::rig::file::RigConfig;
use fringe_calibration::Profile;
use fringe_rig::store::FrameStorage;
use fringe_rig::store::ProfileRef;
use fringe_rig::ConfigError;
use fringe_rig::Cutout;

/// Why a scan's recording cannot be set up.
#[derive(Debug, thiserror::Error)]
pub enum RecordingError {
    #[error(transparent)]
    Config(#[from] ConfigError),
    #[error("{0}")]
    Disc(String),
}

/// The square around the disc of the sensor's profile that `[recording] store = "disc"` keeps.
pub(crate) fn disc_cutout(
    profile: Option<&ProfileRef>,
    sensor_id: &str,
    margin_px: f64,
    config: &RigConfig,
) -> Result<Cutout, RecordingError> {
    let Some(p) = profile else {
        return Err(RecordingError::Disc(format!(
            "[recording] store = \"disc\" needs the calibration profile of sensor {sensor_id} \
             in {}: run `fringe calibrate` first, or store whole frames (store = \"frame\")",
            config.profile_dir().display()
        )));
    };
    let profile: Profile = toml::from_str(&p.content).map_err(|e| {
        RecordingError::Disc(format!("{}: the profile cannot be read: {e}", p.path))
    })?;
    let o = &profile.optical;
    FrameStorage::disc_square(
        [o.centre_x_px, o.centre_y_px],
        o.radius_px,
        margin_px,
        profile.image.width,
        profile.image.height,
    )
    .map_err(|e| RecordingError::Disc(format!("[recording] store = \"disc\": {e} ({})", p.path)))
}
