//! A unit's history of checks as one picture (`fringe check --history`): each figure over the
//! checks with its threshold (`<profiles>/<sensor>.health.png`).

use crate::health::figures::Rule;
use crate::health::history::Entry;
use fringe_plot::palette::{BLUE, RED};
use fringe_plot::{Axis, Chart, PlotError, Series};
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
    let picture = plot(entries).map_err(|source| HistoryPlotError::Draw {
        path: out.clone(),
        source,
    })?;
    picture
        .save(&out)
        .map_err(|source| HistoryPlotError::Write {
            path: out.clone(),
            source,
        })?;
    Ok(out)
}

/// The picture could not be drawn or written.
#[derive(Debug, thiserror::Error)]
pub enum HistoryPlotError {
    #[error("cannot draw {}", path.display())]
    Draw {
        path: PathBuf,
        #[source]
        source: PlotError,
    },
    #[error("cannot write {}", path.display())]
    Write {
        path: PathBuf,
        #[source]
        source: image::ImageError,
    },
}

/// One panel per figure: its value at each check (blue) and its threshold (red, dashed), three
/// panels a row; x is the check's number, y the figure in its unit.
fn plot(entries: &[Entry]) -> Result<RgbImage, PlotError> {
    let checks = entries.len().max(1) as f64;
    let charts: Vec<Chart> = PLOTTED
        .iter()
        .map(|key| {
            let mut values = Vec::new();
            let mut thresholds = Vec::new();
            let mut unit = String::new();
            let mut side = "";
            for (k, e) in entries.iter().enumerate() {
                if let Some(f) = e.assessment.figures.iter().find(|f| f.key == *key) {
                    let x = (k + 1) as f64;
                    values.push([x, f.value]);
                    thresholds.push([x, f.threshold]);
                    side = match f.rule {
                        Rule::AtMost => "at most",
                        Rule::AtLeast => "at least",
                    };
                    unit = f.unit.clone();
                }
            }
            // The threshold reaches across the panel: from the left border to the right one.
            if let (Some(first), Some(last)) =
                (thresholds.first().copied(), thresholds.last().copied())
            {
                thresholds.insert(0, [0.5, first[1]]);
                thresholds.push([checks + 0.5, last[1]]);
            }
            // The key without its unit ("centre_shift_px" -> "centre shift"), the unit spelled
            // for a reader ("deg" -> "°", a ratio's "x" -> "ratio", a count's "" -> "count").
            let name = key
                .trim_end_matches("_px")
                .trim_end_matches("_deg")
                .trim_end_matches("_n")
                .replace('_', " ")
                .replace("fz rmse", "Fz RMSE");
            let unit = match unit.as_str() {
                "deg" => "°",
                "x" => "ratio",
                "" => "count",
                u => u,
            };
            let mut title = name.clone();
            if let Some(c) = title.get(..1) {
                title = c.to_uppercase() + &title[1..];
            }
            Chart::new(
                title,
                Axis::new("check number")
                    .integers()
                    .range(0.5, checks + 0.5),
                Axis::new(format!("{name} ({unit})")).from_zero(),
            )
            .series(Series::line("value", &values, BLUE).with_markers())
            .series(Series::line(format!("threshold ({side})"), &thresholds, RED).dashed())
        })
        .collect();
    fringe_plot::panels(&charts, 3, (640, 480))
}
