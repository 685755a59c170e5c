//! The whole calibration of a sensor build from its calibration scan's run: the optical fit from
//! the no-contact frames, the force offsets (bias before every press, drift through the run) and
//! the image-to-stage registration from the presses.

use crate::frames::{self, FrameError};
use crate::offsets::{self, Bias, Drift, ForceOffsets};
use crate::optical::{self, grey::GreyImage, DiscFit, OpticalError};
use crate::registration::contact_spot::spot::{ContactError, ContactSpot};
use crate::registration::contact_spot::{ContactBackground, SpotSettings};
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
    let (background, fit) = optical_fit(run, max_frames, &name)?;
    let drift = offsets::drift(&run.offsets);
    let offsets = run
        .offsets
        .last()
        .map(|b| ForceOffsets::from_bias(b, drift.as_ref()));
    let contact_bg = registration_background(run, &fit, spot, &name)?;
    let centre = [fit.centre_x, fit.centre_y];
    let (presses, example_press) = locate_presses(run, &contact_bg, centre, &name)?;
    let registration = register_presses(&presses, &fit);
    Ok(ScanCalibration {
        background,
        fit,
        biases: run.offsets.clone(),
        drift,
        offsets,
        presses,
        registration,
        example_press,
    })
}

/// The mean of at most `max_frames` of the run's no-contact frames (spread through the run) and
/// the optical fit of that mean; `name` names the run in errors.
fn optical_fit(
    run: &ScanRun,
    max_frames: usize,
    name: &str,
) -> Result<(GreyImage, DiscFit), FromScanError> {
    if run.background.is_empty() {
        return Err(FromScanError::NoBackground {
            run: name.to_string(),
        });
    }
    let used = frames::spread(&run.background, max_frames);
    let storage = run.start.frame_storage();
    let background =
        frames::grey_average(&used, Some(&storage)).map_err(|source| FromScanError::Frames {
            run: name.to_string(),
            source,
        })?;
    let fit = optical::find_disc_in(&background).map_err(|source| FromScanError::Optical {
        run: name.to_string(),
        source,
    })?;
    Ok((background, fit))
}

/// Reads the frames at `paths` as RGB images.
fn read_rgb(run: &ScanRun, paths: &[std::path::PathBuf]) -> Result<Vec<RgbImage>, FrameError> {
    let storage = run.start.frame_storage();
    paths
        .iter()
        .map(|p| frames::read(p, Some(&storage)).map(|i| i.to_rgb8()))
        .collect()
}

/// The background for locating presses: [`REGISTRATION_BACKGROUND_FRAMES`] no-contact frames of
/// the run within the optical fit's crop circle, with the `spot` settings.
fn registration_background(
    run: &ScanRun,
    fit: &DiscFit,
    spot: SpotSettings,
    name: &str,
) -> Result<ContactBackground, FromScanError> {
    let bg_frames = read_rgb(
        run,
        &frames::spread(&run.background, REGISTRATION_BACKGROUND_FRAMES),
    )
    .map_err(|source| FromScanError::Frames {
        run: name.to_string(),
        source,
    })?;
    let centre = [fit.centre_x, fit.centre_y];
    Ok(
        ContactBackground::new(&bg_frames, centre, fit.crop_radius, fit.outside_dn)
            .map_err(|source| FromScanError::Background {
                run: name.to_string(),
                source,
            })?
            .with_settings(spot),
    )
}

/// A pressed frame and the contact spot found in it.
type PressedFrame = (RgbImage, ContactSpot);

/// Every press of the run located in its frames, and the first frame of the located press
/// nearest `centre` (px) with its spot.
fn locate_presses(
    run: &ScanRun,
    contact_bg: &ContactBackground,
    centre: [f64; 2],
    name: &str,
) -> Result<(Vec<LocatedPress>, Option<PressedFrame>), FromScanError> {
    let mut presses = Vec::with_capacity(run.presses.len());
    let mut example: Option<(f64, RgbImage, ContactSpot)> = None;
    for p in &run.presses {
        let pressed = read_rgb(run, &p.files).map_err(|source| FromScanError::Frames {
            run: name.to_string(),
            source,
        })?;
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
    Ok((presses, example.map(|(_, img, s)| (img, s))))
}

/// The stage-to-image registration of the located presses about the optical fit's centre.
fn register_presses(presses: &[LocatedPress], fit: &DiscFit) -> Result<RegistrationFit, FitError> {
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
    register(
        &located,
        [fit.centre_x, fit.centre_y],
        [fit.sigma_x, fit.sigma_y],
        &FitSettings::default(),
    )
}
