//! Acquisition: devices read on their own threads, samples and frames handed on through channels.
//!
//! - [`force_stream`]: a force/torque sensor read continuously; every sample goes to the recorder
//!   channel and the latest ones to a monitor that control loops and safety watchers read.
//! - [`camera_stream`]: a camera read continuously, frames to a channel.
//! - [`labeler`]: the interface every synchronisation method offers the recorder.
//! - [`recorder`]: the thread that labels frames and writes the run store.
//! - [`record_tap`]: what a caller sees of the recording as it happens (live displays).
//! - [`clock_fit_labeler`]: both device clocks mapped onto host time (one-way fits, latches),
//!   windows placed in the force stream through them.
//! - [`host_labeler`]: host arrival times only, the reference pipeline's baseline.
//! - [`strobe_labeler`]: frames matched with their exposure windows found in the strobe channel,
//!   labelled with the force averaged over the window.

pub(crate) mod camera_stream;
pub(crate) mod clock_fit_labeler;
pub(crate) mod force_stream;
pub(crate) mod frame_gaps;
pub(crate) mod host_labeler;
pub(crate) mod labeler;
pub(crate) mod record_tap;
pub(crate) mod recorder;
pub(crate) mod strobe_labeler;
#[cfg(test)]
pub(crate) mod synthetic;
