//! Per-sensor calibration: optical centre and crop radius from no-contact frames, image-to-stage
//! registration from a calibration scan, force offsets, and the per-sensor profile on disk.
//!
//! Built on the device layer (`fringe-rig`); knows nothing of the UI. The algorithms arrive with
//! the calibration issue; the crate exists now so the workspace layout is fixed.
