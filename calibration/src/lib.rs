//! Per-sensor calibration: optical centre and crop radius from no-contact frames, force offsets,
//! the image-to-stage registration from a scan of light presses, and the per-sensor profile on
//! disk.
//!
//! Built on the device layer (`fringe-rig`); knows nothing of the UI.
//!
//! - `frames`: frame files (PNG, TIFF) read and averaged.
//! - `from_scan`: the whole calibration from a calibration scan's run.
//! - [`health`]: a unit's signature in a run's no-contact frames and what changed since it was
//!   accepted (the health check's optical figures).
//! - `optical`: the sensor disc (centre, radius, crop radius) from no-contact frames.
//! - [`offsets`]: F/T bias, its drift through a run and the zero-load check.
//! - `registration`: contact positions in pressed frames, the stage-to-image similarity
//!   (px/mm, rotation, mirror, contact origin) and its residual plot.
//! - `profile`: `profiles/<sensor-id>.toml`, read, written and checked.
//! - `scan_run`: a calibration scan's run directory read for calibration (background frames,
//!   press frames, no-contact force windows).
//!
//! The surface is curated: what other crates use is re-exported here, at the root: the whole
//! calibration from a scan ([`ScanCalibration`], [`calibrate`]), the profile on disk
//! ([`Profile`], [`profile_path`], [`load_checked`]), the optical fit ([`find_disc`], [`DiscFit`],
//! [`GreyImage`]), the registration and its contact spots ([`register`], [`SpotSettings`]), the
//! offset check the scan engine runs ([`ProfileOffsetCheck`], [`ZeroTolerance`]) and a
//! calibration scan's run ([`ScanRun`]). Two modules stay public as namespaces: [`health`] (a
//! unit's signature and its change: `health::Signature`, `health::Change`, their constants) and
//! [`offsets`] (`offsets::bias`, `offsets::drift`, `offsets::CHANNELS`: names that need their
//! module's). Every type the public API hands out is re-exported too, so all of it can be
//! named (`unnameable_types` is warned). Inside this crate, files import from the defining module, never through these
//! re-exports.
#![warn(unreachable_pub)]
#![warn(unnameable_types)]

mod frames;
mod from_scan;
pub mod health;
pub mod offsets;
mod optical;
mod profile;
mod registration;
mod scan_run;

pub use frames::{grey_average, spread, FrameError};
pub use from_scan::{calibrate, FromScanError, LocatedPress, ScanCalibration};
pub use offsets::{ProfileOffsetCheck, ZeroTolerance};
pub use optical::grey::{GreyImage, SizeMismatch};
pub use optical::overlay::{overlay, overlay_scaled};
pub use optical::{find_disc, find_disc_in, DiscFit, OpticalError};
pub use profile::{
    load_checked, profile_path, Expectation, ImageSize, Optical, Profile, ProfileError,
    ProfileWarning, Registration, MAX_AGE_DAYS,
};
pub use registration::contact_spot::spot::{ContactError, ContactSpot};
pub use registration::contact_spot::{draw_spot, ContactBackground, SpotSettings};
pub use registration::plot::residual_plot;
pub use registration::similarity_fit::{
    FitError, FitSettings, Press, PressResidual, SimilarityFit,
};
pub use registration::{register, RegistrationFit};
pub use scan_run::{Press as PressFrames, ScanRun, ScanRunError};
