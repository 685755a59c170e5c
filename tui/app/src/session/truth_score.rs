//! How well a simulated run's labels match the bench's ground truth.

/// The labels of a simulated run against the bench's ground truth.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TruthScore {
    pub frames: usize,
    pub force_rms_n: f64,
    pub force_max_n: f64,
    pub contact_frames: usize,
    pub contact_rms_mm: f64,
}
