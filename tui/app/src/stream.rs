//! The stream: a unit off the bench, on a robot. Only the camera and the unit's model run; each
//! frame becomes the model's prediction (every force it predicts, the contact point in the
//! sensor's frame, the shape with its probabilities, a contact flag), stamped with the frame's
//! exposure on the host clock and with how long it took, and goes out as ROS 2 messages over
//! Zenoh (as `rmw_zenoh` speaks, so a ROS 2 system sees the topics), into an MCAP recording, or
//! both.
//!
//! - `request`: what a stream is asked for (the rig and unit, the model, the node's name, domain
//!   and endpoints, the recording).
//! - `job`: the running stream: the camera read on its own thread, the frames' exposures placed
//!   by the one camera clock (`fringe_rig::CameraClock`), one worker running the model on the
//!   oldest waiting frame (the oldest skipped when more than [`BACKLOG_FRAMES`] wait), its state
//!   for a front end and its summary at the end.
//! - `outlets`: the ROS 2 messages a prediction makes and where they go (the Zenoh node's
//!   publishers, the MCAP recorder's channels).
//! - `stream_error`: how a stream fails.
//! - `health_watch`: the unit's optics, light and no-contact baseline, watched on frames the
//!   model calls free, a drift said.
//! - `latency`: where each frame's time went, and the percentiles.
//! - `robot_truth`: on the simulated bench, the simulator's robot pressing the sensor and the
//!   ground truth each frame is scored against, as `fringe eval` scores a run.

mod health_watch;
mod job;
mod latency;
mod outlets;
mod request;
#[cfg(feature = "sim")]
mod robot_truth;
mod stream_error;

pub use health_watch::StreamHealth;
pub use job::{
    Stream, StreamState, StreamSummary, BACKLOG_FRAMES, HISTORY_SECONDS, RECENT_FRAMES,
    RECORDING_RESERVE_BYTES,
};
pub use latency::{LatencyFigures, Stage};
pub use outlets::{Published, TOPICS};
pub use request::{Ros2Settings, StreamRequest};
pub use stream_error::StreamError;
