//! What the simulated camera sees: the sensor build and its image geometry, the fringe field an
//! indenter makes, the colours of fringe orders, the unloaded background with its scratches, and
//! the renderer that draws a frame from all of them in the camera's pixel format.

pub mod background;
mod blurred_colour;
pub mod colour;
pub mod fringe_field;
pub(crate) mod pixel_format;
pub mod render;
pub(crate) mod scratch;
mod scratch_canvas;
pub mod sensor;
