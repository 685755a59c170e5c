//! A unit's history of checks as one picture (`fringe check --history`, a check's HTML report):
//! every figure over the checks' dates with its threshold (`<profiles>/<sensor>.health.png`).

use crate::health::figures::{spelled as named, Rule};
use crate::health::history::Entry;
use fringe_plot::palette::{BLUE, RED};
use fringe_plot::{Axis, Chart, PlotError, Series};
use fringe_rig::store::utc_days;
use image::RgbImage;
use std::path::{Path, PathBuf};

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

/// One panel per figure the checks measured (in the order of the checks' figures): its value at
/// each check (blue) and its threshold (red, dashed) across the panel, four panels a row; x is
/// the check's date (a single check in the middle), y the figure in its unit.
pub(crate) fn plot(entries: &[Entry]) -> Result<RgbImage, PlotError> {
    let mut keys: Vec<&str> = Vec::new();
    for e in entries {
        for f in &e.assessment.figures {
            if !keys.contains(&f.key.as_str()) {
                keys.push(&f.key);
            }
        }
    }
    let at: Vec<Option<f64>> = entries.iter().map(|e| day_of(&e.checked_utc)).collect();
    let (lo, hi) = at
        .iter()
        .flatten()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), d| {
            (lo.min(*d), hi.max(*d))
        });
    let (lo, hi) = if !(lo.is_finite() && hi.is_finite()) {
        (0.0, 1.0)
    } else if hi - lo < 1.0 {
        (0.5 * (lo + hi) - 1.0, 0.5 * (lo + hi) + 1.0)
    } else {
        let pad = (0.08 * (hi - lo)).max(0.5);
        (lo - pad, hi + pad)
    };
    let charts: Vec<Chart> = keys
        .iter()
        .map(|key| {
            let mut values = Vec::new();
            let mut thresholds = Vec::new();
            let mut unit = String::new();
            let mut side = "";
            for (e, day) in entries.iter().zip(&at) {
                let Some(x) = day else { continue };
                if let Some(f) = e.assessment.figures.iter().find(|f| f.key == *key) {
                    values.push([*x, f.value]);
                    thresholds.push([*x, f.threshold]);
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
                thresholds.insert(0, [lo, first[1]]);
                thresholds.push([hi, last[1]]);
            }
            let (name, unit) = named(key, &unit);
            let mut title = name.clone();
            if let Some(c) = title.get(..1) {
                title = c.to_uppercase() + &title[1..];
            }
            Chart::new(
                title,
                Axis::new("check date (UTC)").dates().range(lo, hi),
                Axis::new(format!("{name} ({unit})")).from_zero(),
            )
            .series(Series::line("value", &values, BLUE).with_markers())
            .series(Series::line(format!("threshold ({side})"), &thresholds, RED).dashed())
        })
        .collect();
    fringe_plot::panels(&charts, 4, (560, 420))
}

/// A check's time as days since 1970-01-01 (fractions for the time of day).
fn day_of(utc: &str) -> Option<f64> {
    let day = utc_days(utc)?;
    let hours: f64 = utc.get(11..13).and_then(|h| h.parse().ok()).unwrap_or(0.0);
    let minutes: f64 = utc.get(14..16).and_then(|m| m.parse().ok()).unwrap_or(0.0);
    Some(day as f64 + (hours + minutes / 60.0) / 24.0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::health::figures::{assess, Measured, Thresholds};
    use crate::health::history::HISTORY_FORMAT;
    use crate::health::model_errors::ModelErrors;
    use crate::health::test_change::unchanged;

    /// A check at `utc` of the unchanged unit, its F/T zero moved by `zero` N.
    fn entry(utc: &str, zero: f64) -> Entry {
        let change = unchanged();
        let errors = ModelErrors {
            frames: 40,
            fz_rmse_n: 0.3,
            contact_rmse_mm: 1.0,
            shape_accuracy: 0.98,
            force_gain: 1.0,
        };
        let m = Measured {
            change: &change,
            radius_px: 245.0,
            radius_sigma_px: 0.05,
            force_offset_n: Some([0.0, 0.0, zero]),
            model_now: Some(&errors),
            model_then: Some(&errors),
        };
        Entry {
            format: HISTORY_FORMAT,
            fringe_version: "test".into(),
            checked_utc: utc.into(),
            sensor_id: "unit".into(),
            certificate: "c".into(),
            run: "r".into(),
            bench_s: 60.0,
            assessment: assess(&m, &Thresholds::default()),
            model_now: Some(errors.clone()),
            model_then: Some(errors),
        }
    }

    /// Where a test's picture is kept for a look (`FRINGE_KEEP_PLOTS=DIR`), else a scratch file.
    fn kept(name: &str) -> PathBuf {
        let dir = std::env::var_os("FRINGE_KEEP_PLOTS")
            .map(PathBuf::from)
            .unwrap_or_else(std::env::temp_dir);
        dir.join(format!("{name}-{}.png", std::process::id()))
    }

    #[test]
    fn the_history_is_drawn_over_dates_with_every_figure_and_its_threshold() {
        let one = [entry("2026-12-01T09:00:00.000Z", 0.01)];
        let many = [
            entry("2026-11-20T09:00:00.000Z", 0.01),
            entry("2026-11-27T10:30:00.000Z", 0.02),
            entry("2026-12-04T08:15:00.000Z", 0.1),
        ];
        for (name, entries) in [("history-one", &one[..]), ("history-three", &many[..])] {
            let img = plot(entries).expect("plot");
            img.save(kept(name)).expect("save");
            // Thirteen figures, four panels a row: four rows.
            assert_eq!(img.dimensions(), (4 * 560, 4 * 420), "{name}");
        }
    }
}
