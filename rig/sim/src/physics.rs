//! What moves and what presses on the simulated bench: the stage motors' motion, the indenter and
//! its contact with the soft layer, the stress it causes through the layer, and the six-axis
//! force/torque sensor that measures it.

pub mod contact;
pub(crate) mod ft_config;
pub mod ft_sensor;
pub mod indenter;
pub mod motion;
pub(crate) mod stress;
