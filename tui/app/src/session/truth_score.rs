//! How well a simulated run's labels match the bench's ground truth.

/// The labels of a simulated run against the bench's ground truth.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TruthScore {
    pub frames: usize,
    pub force_rms_n: f64,
    pub force_max_n: f64,
    pub contact_frames: usize,
    pub contact_rms_mm: f64,
    /// Frames with a shear label, and its RMS off the true push per axis (x, y), N.
    pub shear_frames: usize,
    pub shear_rms_n: [f64; 2],
    /// Frames with a slip label, and how many say what the truth says.
    pub slip_frames: usize,
    pub slip_agree: usize,
    /// Presses whose gross slip starts in both, the largest distance between the starts
    /// (frames), and the presses that slide in the truth only or in the labels only.
    pub onsets: usize,
    pub onset_max_frames: usize,
    pub onsets_missed: usize,
    pub onsets_false: usize,
}
