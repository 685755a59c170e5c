//! `fringe check --history`: the unit's checks as a table, and each figure over the checks with
//! its threshold as one picture (`<profiles>/<sensor>.health.png`).

use anyhow::{bail, Context, Result};
use fringe_app::health::figures::Rule;
use fringe_app::health::history::{self, history_path, Entry};
use fringe_plot::palette::{BLUE, RED};
use fringe_plot::{Axis, Chart, Series};
use image::RgbImage;
use std::path::Path;

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

pub(super) fn show(profiles: &Path, sensor: &str) -> Result<()> {
    let path = history_path(profiles, sensor);
    let h = history::read(&path)?;
    for n in &h.notes {
        eprintln!("warning: {n}");
    }
    if h.entries.is_empty() {
        bail!(
            "{}: no checks of sensor {sensor} yet (fringe check --rig R makes one)",
            path.display()
        );
    }
    println!("{}", heading(h.entries.len(), sensor, &path));
    println!(
        "{:>3}  {:<20}  {:<12}  {:>8}  {:>7}  {:>6}  {:>6}  {:>5}  {:>7}  diagnosis",
        "#", "checked (UTC)", "verdict", "centre px", "zero N", "rim", "side", "cells", "gain"
    );
    for (k, e) in h.entries.iter().enumerate() {
        let f = |key: &str| e.figure(key).unwrap_or(f64::NAN);
        println!(
            "{:>3}  {:<20}  {:<12}  {:>8.2}  {:>7.3}  {:>6.2}  {:>6.2}  {:>5.0}  {:>7.3}  {}",
            k + 1,
            e.checked_utc.chars().take(19).collect::<String>(),
            e.verdict().name(),
            f("centre_shift_px"),
            f("force_zero_n"),
            f("darkest_rim"),
            f("darkest_side"),
            f("surface_cells"),
            f("force_gain_change"),
            e.assessment.diagnosis
        );
    }
    let picture = plot(&h.entries)?;
    let out = profiles.join(format!("{sensor}.health.png"));
    picture
        .save(&out)
        .with_context(|| format!("cannot write {}", out.display()))?;
    println!(
        "wrote {} (each figure over the checks, its threshold in red)",
        out.display()
    );
    Ok(())
}

/// The table's heading: `2 checks of sensor S (PATH)`, `1 check of ...`.
fn heading(checks: usize, sensor: &str, path: &Path) -> String {
    format!(
        "{checks} {} of sensor {sensor} ({})",
        if checks == 1 { "check" } else { "checks" },
        path.display()
    )
}

/// One panel per figure: its value at each check (blue) and its threshold (red, dashed), three
/// panels a row; x is the check's number, y the figure in its unit.
fn plot(entries: &[Entry]) -> Result<RgbImage> {
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
    Ok(fringe_plot::panels(&charts, 3, (640, 480))?)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_heading_counts_checks_in_words() {
        let path = Path::new("profiles/layered-3.health.jsonl");
        assert_eq!(
            heading(1, "layered-3", path),
            "1 check of sensor layered-3 (profiles/layered-3.health.jsonl)"
        );
        assert_eq!(
            heading(2, "layered-3", path),
            "2 checks of sensor layered-3 (profiles/layered-3.health.jsonl)"
        );
    }
}
