//! What the simulated camera sees: the sensor build and its image geometry, the fringe field an
//! indenter makes, the colours of fringe orders, the unloaded background with its scratches, and
//! the renderer that draws a frame from all of them in the camera's pixel format.

pub(crate) mod background;
mod blurred_colour;
pub(crate) mod colour;
pub(crate) mod fringe_field;
pub(crate) mod pixel_format;
pub(crate) mod push_stress;
pub(crate) mod render;
pub(crate) mod scratch;
mod scratch_canvas;
pub(crate) mod sensor;
