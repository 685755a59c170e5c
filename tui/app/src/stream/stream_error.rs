//! How a stream fails to start or stops.

use crate::rig::error::RigError;
use fringe_ros2::{NodeError, RecordError};
use fringe_sensor_models::ModelError;
use std::path::PathBuf;

/// Why a stream could not start or stopped.
#[derive(Debug, thiserror::Error)]
pub enum StreamError {
    #[error(transparent)]
    Rig(#[from] RigError),
    #[error("no calibration profile for sensor {sensor} in {}: calibrate or commission the unit first (`fringe calibrate`, `fringe commission`), or give --rig with its `profiles`", .dir.display())]
    NoProfile { sensor: String, dir: PathBuf },
    #[error(transparent)]
    Model(#[from] ModelError),
    #[error("camera: {0}")]
    Camera(#[from] fringe_rig::CameraError),
    #[error("ROS 2 over Zenoh: {0} (give --no-ros2 to stream without it)")]
    Node(#[from] NodeError),
    #[error("recording: {0}")]
    Record(#[from] RecordError),
    #[cfg(feature = "sim")]
    #[error("the simulated robot: {0}")]
    Robot(#[from] fringe_sim::RobotError),
    #[error("cannot start the {what} thread: {source}")]
    Thread {
        what: &'static str,
        #[source]
        source: std::io::Error,
    },
    #[error("{0}")]
    Settings(String),
}
