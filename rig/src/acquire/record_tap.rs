//! A caller's view of the recording as it happens: every frame the recorder sees, and every
//! frame record it writes with the frame it labels. Live displays and live validation are built
//! on it; the engine knows only this trait.

use crate::camera::Frame;
use crate::store::documents::FrameRecord;

/// Called on the recorder thread: implementations return at once (copy what they need into a
/// bounded channel or a slot another thread reads, and drop what they cannot take), so that a
/// slow consumer never slows the recording.
pub trait RecordTap: Send + Sync + std::fmt::Debug {
    /// A frame arrived (filmed or not), before it is labelled.
    fn seen(&self, _frame: &Frame) {}
    /// `record` was appended to the run for `frame` (its label, or why it has none).
    fn recorded(&self, frame: &Frame, record: &FrameRecord);
    /// The records from index `first` on were cut from the run (an interrupted point that is
    /// done again): whatever was taken from them is no longer part of the run, and the indices
    /// are used again by the records that follow.
    fn cut(&self, _first: u64) {}
}
