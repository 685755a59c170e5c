//! Charts side by side in one picture.

use crate::canvas::render;
use crate::error::PlotError;
use crate::xy::Chart;
use image::RgbImage;
use plotters::style::WHITE;

/// `charts` as panels of `panel` px (width, height), `columns` a row, in reading order.
pub fn panels(charts: &[Chart], columns: usize, panel: (u32, u32)) -> Result<RgbImage, PlotError> {
    let columns = columns.max(1).min(charts.len().max(1));
    let rows = charts.len().div_ceil(columns).max(1);
    render(panel.0 * columns as u32, panel.1 * rows as u32, |root| {
        root.fill(&WHITE)?;
        for (chart, area) in charts.iter().zip(root.split_evenly((rows, columns))) {
            chart.draw_on(&area)?;
        }
        Ok(())
    })
}
