//! One simulated sensor frame written as a PNG (`fringe sim render`).

use fringe_sim::Renderer;
use fringe_sim::{Contact, FrameRenderer, Scene};
use fringe_sim::{SensorConfig, SensorConfigError};
use std::path::{Path, PathBuf};

/// A frame written.
pub struct Rendered {
    pub width: u32,
    pub height: u32,
    /// Where the contact point lies in the image, px.
    pub pixel: [f64; 2],
}

/// A frame that could not be rendered or written.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    #[error(transparent)]
    Sensor(#[from] SensorConfigError),
    #[error("cannot write {}", .path.display())]
    Write {
        path: PathBuf,
        #[source]
        source: image::ImageError,
    },
}

/// Renders frame number `frame` of `sensor` pressed by `contact` (none: untouched) into the PNG
/// `out`; `at_mm` is the contact point in the sensor frame, mm.
pub fn render_png(
    sensor: SensorConfig,
    contact: Option<Contact>,
    at_mm: [f64; 2],
    frame: u64,
    out: &Path,
) -> Result<Rendered, RenderError> {
    let mut renderer = Renderer::new(sensor)?;
    let mut rgb = Vec::new();
    renderer.render(&Scene { contact }, frame, &mut rgb);
    let (width, height) = (renderer.width(), renderer.height());
    image::save_buffer(out, &rgb, width, height, image::ColorType::Rgb8).map_err(|source| {
        RenderError::Write {
            path: out.to_path_buf(),
            source,
        }
    })?;
    Ok(Rendered {
        width,
        height,
        pixel: renderer.geometry().to_pixel(at_mm[0], at_mm[1]),
    })
}
