//! The set of devices a scan runs on, whatever they are: real, simulated or replayed.

use crate::axis::Axis;
use crate::camera::Camera;
use crate::force::ForceSensor;

/// The bench as the acquisition and scan code see it.
pub struct Devices {
    pub x: Box<dyn Axis>,
    pub y: Box<dyn Axis>,
    pub z: Box<dyn Axis>,
    pub force: Box<dyn ForceSensor>,
    pub camera: Box<dyn Camera>,
    /// One line per device saying what it is and how it is reached, for logs and run documents.
    pub description: Vec<String>,
}
