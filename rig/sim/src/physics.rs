//! What moves and what presses on the simulated bench: the stage motors' motion, the indenter and
//! its contact with the soft layer, the stress it causes through the layer, and the six-axis
//! force/torque sensor that measures it.

pub(crate) mod contact;
pub(crate) mod friction;
pub(crate) mod ft_config;
pub(crate) mod ft_sensor;
pub(crate) mod indenter;
pub(crate) mod motion;
pub(crate) mod sliding;
pub(crate) mod stress;
pub(crate) mod traction;
