//! The one font of every plot: DejaVu Sans, embedded, registered with plotters once.

use crate::error::PlotError;
use plotters::style::{register_font, FontStyle, IntoFont, TextStyle};
use std::sync::OnceLock;

/// The family name every text style asks for.
const FAMILY: &str = "sans-serif";

static DEJAVU_SANS: &[u8] = include_bytes!("../fonts/DejaVuSans.ttf");

/// Registers the embedded font (once per process).
pub(crate) fn ensure() -> Result<(), PlotError> {
    static REGISTERED: OnceLock<bool> = OnceLock::new();
    let ok =
        *REGISTERED.get_or_init(|| register_font(FAMILY, FontStyle::Normal, DEJAVU_SANS).is_ok());
    if ok {
        Ok(())
    } else {
        Err(PlotError::Font)
    }
}

/// Text of `size` px in `colour`.
pub(crate) fn text(size: f64, colour: crate::palette::Colour) -> TextStyle<'static> {
    let [r, g, b] = colour;
    (FAMILY, size)
        .into_font()
        .color(&plotters::style::RGBColor(r, g, b))
}
