//! Image-to-stage geometry (registration) from a calibration scan: light presses at known stage
//! positions, each located in its frames against the unloaded background, and the stage-mm to
//! image-px similarity fitted to them.
//!
//! - [`contact_spot`]: the contact's pixel position (and sigma) in the frames of one press.
//! - [`similarity_fit`]: px/mm, rotation, mirror and offset from the presses, with sigmas,
//!   residuals, outliers and the mirror decision's margin.
//! - [`plot`]: the residual plot and the contact overlay.
//!
//! [`register`] ties the fit to the optical centre: the stage position that presses it is the
//! contact origin; [`RegistrationFit::to_profile`] gives the profile's `[registration]` section.

pub(crate) mod contact_spot;
pub(crate) mod plot;
pub(crate) mod similarity_fit;

use crate::profile::Registration;
use similarity_fit::{fit_similarity, FitError, FitSettings, Press, SimilarityFit};

/// The registration of one sensor build.
#[derive(Debug, Clone, PartialEq)]
pub struct RegistrationFit {
    pub fit: SimilarityFit,
    /// Stage position (x, y) that presses the optical centre, mm.
    pub contact_origin_stage_mm: [f64; 2],
    /// Its 1-sigma per axis (fit covariance and the optical centre's sigma), mm.
    pub sigma_contact_origin_stage_mm: [f64; 2],
}

/// Fits the presses and finds the contact origin from the optical centre (px) and its sigma.
pub fn register(
    presses: &[Press],
    optical_centre_px: [f64; 2],
    sigma_centre_px: [f64; 2],
    settings: &FitSettings,
) -> Result<RegistrationFit, FitError> {
    let fit = fit_similarity(presses, settings)?;
    let (origin, sigma) = fit.contact_origin(optical_centre_px, sigma_centre_px);
    Ok(RegistrationFit {
        fit,
        contact_origin_stage_mm: origin,
        sigma_contact_origin_stage_mm: sigma,
    })
}

impl RegistrationFit {
    /// The profile's `[registration]` section, rounded for reading (well below the sigmas).
    pub fn to_profile(&self) -> Registration {
        let f = &self.fit;
        let r = |v: f64, digits: i32| {
            let s = 10f64.powi(digits);
            (v * s).round() / s
        };
        Registration {
            px_per_mm: r(f.px_per_mm, 5),
            sigma_px_per_mm: r(f.sigma_px_per_mm, 5),
            rotation_deg: r(f.rotation_deg, 4),
            sigma_rotation_deg: r(f.sigma_rotation_deg, 4),
            mirror: f.mirror,
            offset_px: f.offset_px.map(|v| r(v, 3)),
            contact_origin_stage_mm: self.contact_origin_stage_mm.map(|v| r(v, 4)),
            sigma_contact_origin_stage_mm: self.sigma_contact_origin_stage_mm.map(|v| r(v, 4)),
            residual_rms_px: r(f.residual_rms_px, 4),
            presses: f.inliers,
            outliers: f.residuals.len() - f.inliers,
        }
    }
}
