//! The whole calibration of a sensor build from its calibration scan's run: the optical fit from
//! the no-contact frames, the force offsets (bias before every press, drift through the run) and
//! the image-to-stage registration from the presses.

use crate::frames::{self, FrameError};
use crate::offsets::{self, Bias, Drift, ForceOffsets};
use crate::optical::{self, grey::GreyImage, DiscFit, OpticalError};
use crate::scan_run::ScanRun;

/// What a calibration scan gave.
#[derive(Debug, Clone)]
pub struct ScanCalibration {
    /// Mean of the no-contact frames used for the optical fit.
    pub background: GreyImage,
    pub fit: DiscFit,
    /// One bias per no-contact window (before every press).
    pub biases: Vec<Bias>,
    /// Their straight-line drift through the run (two windows or more).
    pub drift: Option<Drift>,
    /// The offsets kept in the profile: the last window's bias (the sensor as the profile is
    /// made) with the run's drift.
    pub offsets: Option<ForceOffsets>,
}

/// Why a calibration scan gave no calibration.
#[derive(Debug, thiserror::Error)]
pub enum FromScanError {
    #[error(
        "{run}: no no-contact frames (every frame shows |Fz| >= 0.2 N or is invalid): check the F/T offset and that the plan's safe z clears the sensor"
    )]
    NoBackground { run: String },
    #[error("{run}: {source}")]
    Frames { run: String, source: FrameError },
    #[error("{run}: optical fit of the no-contact frames: {source}")]
    Optical { run: String, source: OpticalError },
}

/// Calibrates from `run`, averaging at most `max_frames` no-contact frames.
pub fn calibrate(run: &ScanRun, max_frames: usize) -> Result<ScanCalibration, FromScanError> {
    let name = run.dir.display().to_string();
    if run.background.is_empty() {
        return Err(FromScanError::NoBackground { run: name });
    }
    let used = frames::spread(&run.background, max_frames);
    let background = frames::grey_average(&used).map_err(|source| FromScanError::Frames {
        run: name.clone(),
        source,
    })?;
    let fit = optical::find_disc_in(&background).map_err(|source| FromScanError::Optical {
        run: name.clone(),
        source,
    })?;
    let drift = offsets::drift(&run.offsets);
    let offsets = run
        .offsets
        .last()
        .map(|b| ForceOffsets::from_bias(b, drift.as_ref()));
    Ok(ScanCalibration {
        background,
        fit,
        biases: run.offsets.clone(),
        drift,
        offsets,
    })
}
