//! What every synchronisation method gives the recorder: a frame's exposure window located in the
//! force stream and the six-axis force averaged over it.
//!
//! One implementation per method: [`super::strobe_labeler::StrobeLabeler`] (`strobe`),
//! [`super::clock_fit_labeler::ClockFitLabeler`] (`clock-fit`) and
//! [`super::host_labeler::HostLabeler`] (`host`). The recorder feeds every force sample in stream
//! order, shows it every frame, and asks for each filmed frame's label until it is ready.

use crate::camera::Frame;
use crate::force::ForceSample;
use crate::sync::method::SyncMethod;
use crate::sync::window::WindowMean;

/// A frame's exposure in the force stream and the force over it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ExposureLabel {
    /// Exposure window in the force stream's sample index (its device ticks), fractional.
    pub window_ticks: [f64; 2],
    /// The same window on the host time base (ns), when the method maps it there.
    pub window_host_ns: Option<[f64; 2]>,
    /// Estimated error (1 sigma) of the window's placement, ns.
    pub error_ns: f64,
    /// Six-axis force averaged over the window (raw: not tared).
    pub mean: WindowMean,
}

/// What a labeler found for a frame.
#[derive(Debug, Clone, PartialEq)]
pub enum LabelOutcome {
    Ready(ExposureLabel),
    /// The frame's window, or the samples after it, have not arrived yet: ask again later.
    NotYet,
    /// No window can be given to this frame; the reason goes into the frame record.
    Unmatched(String),
}

/// A synchronisation method at work.
pub trait FrameLabeler: Send {
    fn method(&self) -> SyncMethod;
    /// Feeds one force sample, in stream order.
    fn push_sample(&mut self, sample: &ForceSample);
    /// Shows the labeler every frame the camera delivers, labelled or not, in arrival order
    /// (clock fits learn from all of them).
    fn observe_frame(&mut self, _frame: &Frame) {}
    /// The label of `frame` (the frame's pixels are not needed; ids, timestamps and arrival are).
    fn label(&mut self, frame: &Frame) -> LabelOutcome;
    /// The method's current estimate of its label-time error (1 sigma, ns), for run documents.
    fn estimated_error_ns(&self) -> Option<f64>;
}
