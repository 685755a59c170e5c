//! A white bitmap to draw on, handed back as an [`RgbImage`].

use crate::error::PlotError;
use image::RgbImage;
use plotters::backend::BitMapBackend;
use plotters::coord::Shift;
use plotters::drawing::{DrawingArea, IntoDrawingArea};

/// A drawing area over a bitmap.
pub(crate) type Area<'a> = DrawingArea<BitMapBackend<'a>, Shift>;

/// A `width` x `height` white picture with `draw` drawn on it.
pub(crate) fn render(
    width: u32,
    height: u32,
    draw: impl FnOnce(&Area<'_>) -> Result<(), PlotError>,
) -> Result<RgbImage, PlotError> {
    render_over(
        RgbImage::from_pixel(width.max(1), height.max(1), image::Rgb([255; 3])),
        draw,
    )
}

/// `picture` with `draw` drawn over it.
pub(crate) fn render_over(
    picture: RgbImage,
    draw: impl FnOnce(&Area<'_>) -> Result<(), PlotError>,
) -> Result<RgbImage, PlotError> {
    crate::font::ensure()?;
    let (width, height) = picture.dimensions();
    let mut buffer = picture.into_raw();
    {
        let root = BitMapBackend::with_buffer(&mut buffer, (width, height)).into_drawing_area();
        draw(&root)?;
        root.present()?;
    }
    RgbImage::from_raw(width, height, buffer)
        .ok_or_else(|| PlotError::Draw("the picture's buffer changed size".to_string()))
}
