//! A unit's history of checks as one picture (`fringe check --history`): each figure over the
//! checks with its threshold (`<profiles>/<sensor>.health.png`).

use crate::health::figures::Rule;
use crate::health::history::Entry;
use fringe_sensor_models::report::line_plot;
use image::RgbImage;
use std::path::{Path, PathBuf};

/// The figures plotted, in the order of the picture's panels.
const PLOTTED: [&str; 9] = [
    "centre_shift_px",
    "turn_deg",
    "force_zero_n",
    "darkest_rim",
    "darkest_side",
    "surface_cells",
    "dimming",
    "force_gain_change",
    "fz_rmse_growth",
];

/// Each figure of `entries` over the checks with its threshold as one picture, written to
/// `<profiles>/<sensor>.health.png`; its path.
pub fn write(
    profiles: &Path,
    sensor: &str,
    entries: &[Entry],
) -> Result<PathBuf, HistoryPlotError> {
    let out = profiles.join(format!("{sensor}.health.png"));
    plot(entries)
        .save(&out)
        .map_err(|source| HistoryPlotError {
            path: out.clone(),
            source,
        })?;
    Ok(out)
}

/// The picture could not be written.
#[derive(Debug, thiserror::Error)]
#[error("cannot write {}", path.display())]
pub struct HistoryPlotError {
    path: PathBuf,
    #[source]
    source: image::ImageError,
}

/// One panel per figure: its value at each check (blue) and its threshold (red), three panels
/// a row.
fn plot(entries: &[Entry]) -> RgbImage {
    let panels: Vec<RgbImage> = PLOTTED
        .iter()
        .map(|key| {
            let mut values = Vec::new();
            let mut thresholds = Vec::new();
            let mut label = (*key).to_string();
            for (k, e) in entries.iter().enumerate() {
                if let Some(f) = e.assessment.figures.iter().find(|f| f.key == *key) {
                    let x = (k + 1) as f64;
                    values.push([x, f.value]);
                    thresholds.push([x, f.threshold]);
                    let side = match f.rule {
                        Rule::AtMost => "at most",
                        Rule::AtLeast => "at least",
                    };
                    label = format!("{key} {}, {side} red", f.unit);
                }
            }
            line_plot(
                &label,
                "check",
                &[("value", &values), ("threshold", &thresholds)],
            )
        })
        .collect();
    let (w, h) = panels.first().map_or((1, 1), |p| (p.width(), p.height()));
    let columns = 3u32;
    let rows = (panels.len() as u32).div_ceil(columns);
    let mut out = RgbImage::from_pixel(w * columns, h * rows, image::Rgb([255, 255, 255]));
    for (k, p) in panels.iter().enumerate() {
        let (c, r) = (k as u32 % columns, k as u32 / columns);
        image::imageops::overlay(&mut out, p, i64::from(c * w), i64::from(r * h));
    }
    out
}
