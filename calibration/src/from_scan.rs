//! The whole calibration of a sensor build from its calibration scan's run: the optical fit from
//! the no-contact frames, the force offsets (bias before every press, drift through the run) and
//! the image-to-stage registration from the presses.

use crate::frames::{self, FrameError};
use crate::offsets::{self, Bias, Drift, ForceOffsets};
use crate::optical::{self, grey::GreyImage, DiscFit, OpticalError};
use crate::registration::contact_spot::{
    ContactBackground, ContactError, ContactSpot, SpotSettings,
};
use crate::registration::similarity_fit::{FitError, FitSettings, Press};
use crate::registration::{register, RegistrationFit};
use crate::scan_run::ScanRun;
use image::RgbImage;

/// No-contact frames averaged for the registration's background.
const REGISTRATION_BACKGROUND_FRAMES: usize = 8;

/// One press of the scan as located in its frames.
#[derive(Debug, Clone)]
pub struct LocatedPress {
    pub point: u64,
    pub stage_mm: [f64; 2],
    pub force_n: f64,
    pub frames: usize,
    /// The contact in the image, or why it could not be located.
    pub spot: Result<ContactSpot, ContactError>,
}

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
    /// Every press, located or not.
    pub presses: Vec<LocatedPress>,
    /// The stage-to-image fit of the located presses, or why there is none.
    pub registration: Result<RegistrationFit, FitError>,
    /// The frame of the press nearest the optical centre (for the report).
    pub example_press: Option<(RgbImage, ContactSpot)>,
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
    #[error("{run}: registration background: {source}")]
    Background { run: String, source: ContactError },
}

/// Calibrates from `run`, averaging at most `max_frames` no-contact frames for the optical fit;
/// `spot` tunes contact finding to the sensor's construction.
pub fn calibrate(
    run: &ScanRun,
    max_frames: usize,
    spot: SpotSettings,
) -> Result<ScanCalibration, FromScanError> {
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
    let frames_err = |source| FromScanError::Frames {
        run: name.clone(),
        source,
    };
    let rgb = |paths: &[std::path::PathBuf]| -> Result<Vec<RgbImage>, FrameError> {
        paths
            .iter()
            .map(|p| frames::read(p).map(|i| i.to_rgb8()))
            .collect()
    };
    let bg_frames = rgb(&frames::spread(
        &run.background,
        REGISTRATION_BACKGROUND_FRAMES,
    ))
    .map_err(frames_err)?;
    let centre = [fit.centre_x, fit.centre_y];
    let contact_bg = ContactBackground::new(&bg_frames, centre, fit.crop_radius, fit.outside_dn)
        .map_err(|source| FromScanError::Background {
            run: name.clone(),
            source,
        })?
        .with_settings(spot);
    let mut presses = Vec::with_capacity(run.presses.len());
    let mut example: Option<(f64, RgbImage, ContactSpot)> = None;
    for p in &run.presses {
        let pressed = rgb(&p.files).map_err(frames_err)?;
        let spot = contact_bg.locate(&pressed);
        if let (Ok(s), Some(first)) = (&spot, pressed.first()) {
            let d = (s.u_px - centre[0]).hypot(s.v_px - centre[1]);
            if example.as_ref().is_none_or(|(best, _, _)| d < *best) {
                example = Some((d, first.clone(), *s));
            }
        }
        presses.push(LocatedPress {
            point: p.point,
            stage_mm: p.stage_mm,
            force_n: p.force_n,
            frames: pressed.len(),
            spot,
        });
    }
    let located: Vec<Press> = presses
        .iter()
        .filter_map(|p| {
            p.spot.as_ref().ok().map(|s| Press {
                stage_mm: p.stage_mm,
                pixel: [s.u_px, s.v_px],
                sigma_px: s.sigma_px(),
            })
        })
        .collect();
    let registration = register(
        &located,
        centre,
        [fit.sigma_x, fit.sigma_y],
        &FitSettings::default(),
    );
    Ok(ScanCalibration {
        background,
        fit,
        biases: run.offsets.clone(),
        drift,
        offsets,
        presses,
        registration,
        example_press: example.map(|(_, img, s)| (img, s)),
    })
}
