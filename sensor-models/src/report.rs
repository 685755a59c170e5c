//! An evaluation's report: `report.md` (Table-2 figures beside the paper's, breakdowns by grid
//! position and force level, the confusion matrix) and its plots, `fz.png` (predicted against
//! measured Fz), `contact.png` (each labelled contact joined to its prediction, over the disc)
//! and `confusion.png`. Drawn with the calibration report's primitives (lines, discs, a pixel
//! font): no font files or plotting stack needed.

use crate::eval::Evaluation;
use crate::metrics::{Errors, Metrics};
use fringe_calibration::registration::plot::{circle, dot, line, text, text_width};
use image::{Rgb, RgbImage};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

const PX: u32 = 720;
const MARGIN: f64 = 80.0;
const BLACK: [u8; 3] = [0, 0, 0];
const GREY: [u8; 3] = [200, 200, 200];
const BLUE: [u8; 3] = [31, 90, 200];
const RED: [u8; 3] = [210, 40, 30];
const GREEN: [u8; 3] = [30, 140, 60];

/// Why a report could not be written.
#[derive(Debug, thiserror::Error)]
#[error("{path}: {message}")]
pub struct ReportError {
    pub path: String,
    pub message: String,
}

/// The paper's Table 2 rows for comparison: (row, Fz MSE, Fz RMSE, contact RMSE, accuracy).
pub const PAPER: [(&str, f64, f64, f64, f64); 2] = [
    ("paper: Sensor 1, ResNet-18", 0.0213, 0.1459, 0.4462, 0.9624),
    (
        "paper: Sensor 1, custom CNN",
        0.2428,
        0.4927,
        1.4683,
        0.9532,
    ),
];

fn fmt(v: f64, d: usize) -> String {
    if v.is_finite() {
        format!("{v:.d$}")
    } else {
        "-".to_string()
    }
}

/// The figures as a markdown table row: Fz MSE, Fz RMSE, contact RMSE, accuracy.
fn errors_row(name: &str, e: &Errors) -> String {
    format!(
        "| {name} | {} | {} | {} | {} | {} |",
        e.n,
        fmt(e.fz_mse(), 4),
        fmt(e.fz_rmse(), 4),
        fmt(e.contact_rmse(), 4),
        fmt(e.accuracy(), 4)
    )
}

/// The markdown report.
pub fn markdown(title: &str, eval: &Evaluation) -> String {
    let m = &eval.metrics;
    let s = m.macro_scores();
    let mut out = String::new();
    let _ = writeln!(out, "# {title}\n");
    let _ = writeln!(
        out,
        "{} frames evaluated ({} left out: no trustworthy label), {} in contact.\n",
        m.all.n, eval.skipped, m.all.n_contact
    );
    let _ = writeln!(
        out,
        "| | frames | Fz MSE (N^2) | Fz RMSE (N) | contact RMSE (mm) | shape accuracy |"
    );
    let _ = writeln!(out, "|---|---|---|---|---|---|");
    let _ = writeln!(out, "{}", errors_row("this model", &m.all));
    for (name, mse, rmse, c, a) in PAPER {
        let _ = writeln!(out, "| {name} | | {mse} | {rmse} | {c} | {a} |");
    }
    let _ = writeln!(
        out,
        "\nMacro precision {}, recall {}, F1 {}.\n",
        fmt(s.precision, 4),
        fmt(s.recall, 4),
        fmt(s.f1, 4)
    );
    let _ = writeln!(
        out,
        "## Confusion matrix (rows: labelled, columns: predicted)\n"
    );
    let _ = writeln!(out, "| | {} |", m.classes.join(" | "));
    let _ = writeln!(out, "|---|{}", "---|".repeat(m.classes.len()));
    for (name, row) in m.classes.iter().zip(&m.confusion) {
        let cells: Vec<String> = row.iter().map(u64::to_string).collect();
        let _ = writeln!(out, "| {name} | {} |", cells.join(" | "));
    }
    for (heading, prefix) in [("By force level", "force "), ("By grid position", "grid ")] {
        let rows: Vec<(&String, &Errors)> = m
            .by_key
            .iter()
            .filter(|(k, _)| k.starts_with(prefix))
            .collect();
        if rows.is_empty() {
            continue;
        }
        let _ = writeln!(out, "\n## {heading}\n");
        let _ = writeln!(
            out,
            "| | frames | Fz MSE (N^2) | Fz RMSE (N) | contact RMSE (mm) | shape accuracy |"
        );
        let _ = writeln!(out, "|---|---|---|---|---|---|");
        for (k, e) in rows {
            let _ = writeln!(out, "{}", errors_row(k.trim_start_matches(prefix), e));
        }
    }
    let _ = writeln!(
        out,
        "\n![predicted against measured Fz](fz.png)\n![contact errors](contact.png)\n![confusion matrix](confusion.png)"
    );
    out
}

/// Maps data coordinates into a square plot area.
struct Axes {
    lo: [f64; 2],
    hi: [f64; 2],
}

impl Axes {
    fn px(&self, p: [f64; 2]) -> [f64; 2] {
        let span = PX as f64 - 2.0 * MARGIN;
        [
            MARGIN + (p[0] - self.lo[0]) / (self.hi[0] - self.lo[0]) * span,
            PX as f64 - MARGIN - (p[1] - self.lo[1]) / (self.hi[1] - self.lo[1]) * span,
        ]
    }

    /// The box, ticks every `ticks[0]` along x and `ticks[1]` along y, and the axis labels.
    fn frame(&self, img: &mut RgbImage, ticks: [f64; 2], xlabel: &str, ylabel: &str) {
        let (a, b) = (MARGIN, PX as f64 - MARGIN);
        for (p, q) in [
            ([a, a], [b, a]),
            ([b, a], [b, b]),
            ([b, b], [a, b]),
            ([a, b], [a, a]),
        ] {
            line(img, p, q, BLACK);
        }
        // As many decimals as the tick step needs (0.02 -> 2).
        let decimals = |t: f64| (-t.log10()).ceil().max(0.0) as usize;
        let mut t = (self.lo[0] / ticks[0]).ceil() * ticks[0];
        while t <= self.hi[0] + 1e-9 {
            let label = fmt(t, decimals(ticks[0]));
            let x = self.px([t, self.lo[1]])[0];
            line(img, [x, b], [x, b + 6.0], BLACK);
            text(
                img,
                x as i64 - text_width(&label, 2) / 2,
                b as i64 + 12,
                2,
                &label,
                BLACK,
            );
            t += ticks[0];
        }
        let mut t = (self.lo[1] / ticks[1]).ceil() * ticks[1];
        while t <= self.hi[1] + 1e-9 {
            let label = fmt(t, decimals(ticks[1]));
            let y = self.px([self.lo[0], t])[1];
            line(img, [a - 6.0, y], [a, y], BLACK);
            text(
                img,
                a as i64 - 10 - text_width(&label, 2),
                y as i64 - 5,
                2,
                &label,
                BLACK,
            );
            t += ticks[1];
        }
        text(
            img,
            PX as i64 / 2 - text_width(xlabel, 2) / 2,
            PX as i64 - 30,
            2,
            xlabel,
            BLACK,
        );
        text(img, 8, 20, 2, ylabel, BLACK);
    }
}

/// A round tick spacing giving about 5 ticks over `span`.
fn tick(span: f64) -> f64 {
    let raw = span / 5.0;
    let e = 10f64.powf(raw.log10().floor());
    [1.0, 2.0, 5.0, 10.0]
        .into_iter()
        .map(|m| m * e)
        .find(|v| *v >= raw)
        .unwrap_or(10.0 * e)
}

/// Predicted against measured Fz with the diagonal.
pub fn fz_plot(eval: &Evaluation) -> RgbImage {
    let mut img = RgbImage::from_pixel(PX, PX, Rgb([255, 255, 255]));
    let top = eval
        .rows
        .iter()
        .flat_map(|r| [r.scored.fz_true, r.scored.fz_pred])
        .filter(|v| v.is_finite())
        .fold(1.0f64, f64::max)
        * 1.05;
    let ax = Axes {
        lo: [0.0, 0.0],
        hi: [top, top],
    };
    line(&mut img, ax.px([0.0, 0.0]), ax.px([top, top]), GREY);
    for r in &eval.rows {
        let p = [r.scored.fz_true, r.scored.fz_pred.clamp(0.0, top)];
        dot(&mut img, ax.px(p), 2.0, BLUE);
    }
    ax.frame(
        &mut img,
        [tick(top), tick(top)],
        "measured fz (n)",
        "predicted fz (n)",
    );
    let rmse = format!("rmse {} n", fmt(eval.metrics.all.fz_rmse(), 3));
    text(
        &mut img,
        MARGIN as i64 + 12,
        MARGIN as i64 + 12,
        2,
        &rmse,
        BLACK,
    );
    img
}

/// Each labelled contact (dot) joined to its prediction (line), errors over 2 mm in red.
pub fn contact_plot(eval: &Evaluation) -> RgbImage {
    let mut img = RgbImage::from_pixel(PX, PX, Rgb([255, 255, 255]));
    let reach = eval
        .rows
        .iter()
        .filter_map(|r| r.scored.contact_true)
        .map(|[x, y]| x.hypot(y))
        .fold(5.0f64, f64::max)
        * 1.2;
    let ax = Axes {
        lo: [-reach, -reach],
        hi: [reach, reach],
    };
    let centre = ax.px([0.0, 0.0]);
    let scale = ax.px([reach, 0.0])[0] - centre[0];
    circle(&mut img, centre, scale / 1.2, GREY);
    for r in &eval.rows {
        if let Some(t) = r.scored.contact_true {
            let p = r.scored.contact_pred;
            let err = (p[0] - t[0]).hypot(p[1] - t[1]);
            let colour = if err > 2.0 { RED } else { BLUE };
            line(&mut img, ax.px(t), ax.px(p), colour);
            dot(&mut img, ax.px(t), 2.0, BLACK);
        }
    }
    ax.frame(
        &mut img,
        [tick(2.0 * reach), tick(2.0 * reach)],
        "x (mm)",
        "y (mm)",
    );
    let rmse = format!(
        "contact rmse {} mm",
        fmt(eval.metrics.all.contact_rmse(), 3)
    );
    text(
        &mut img,
        MARGIN as i64 + 12,
        MARGIN as i64 + 12,
        2,
        &rmse,
        BLACK,
    );
    img
}

/// The confusion matrix, cells shaded by the share of their row.
pub fn confusion_plot(m: &Metrics) -> RgbImage {
    let mut img = RgbImage::from_pixel(PX, PX, Rgb([255, 255, 255]));
    let n = m.classes.len().max(1);
    let cell = (PX as f64 - 2.0 * MARGIN - 40.0) / n as f64;
    let x0 = MARGIN + 40.0;
    for (i, row) in m.confusion.iter().enumerate() {
        let total = row.iter().sum::<u64>().max(1) as f64;
        for (j, &v) in row.iter().enumerate() {
            let share = v as f64 / total;
            let shade = (255.0 - 200.0 * share) as u8;
            let colour = if i == j {
                [shade, shade, 255]
            } else {
                [255, shade, shade]
            };
            let (cx, cy) = (x0 + j as f64 * cell, MARGIN + i as f64 * cell);
            for y in cy as u32..(cy + cell) as u32 {
                for x in cx as u32..(cx + cell) as u32 {
                    if x < PX && y < PX {
                        img.put_pixel(x, y, Rgb(colour));
                    }
                }
            }
            let label = v.to_string();
            text(
                &mut img,
                (cx + cell / 2.0) as i64 - text_width(&label, 3) / 2,
                (cy + cell / 2.0) as i64 - 7,
                3,
                &label,
                BLACK,
            );
        }
        let name: String = m.classes[i].chars().take(9).collect();
        text(
            &mut img,
            4,
            (MARGIN + (i as f64 + 0.5) * cell) as i64 - 5,
            2,
            &name,
            BLACK,
        );
        text(
            &mut img,
            (x0 + (i as f64 + 0.5) * cell) as i64 - text_width(&name, 2) / 2,
            (MARGIN + n as f64 * cell) as i64 + 12,
            2,
            &name,
            BLACK,
        );
    }
    text(
        &mut img,
        x0 as i64,
        30,
        2,
        "rows: labelled, columns: predicted",
        BLACK,
    );
    img
}

/// Writes `report.md` and the plots into `dir` (created); returns the report's path.
pub fn write(dir: &Path, title: &str, eval: &Evaluation) -> Result<PathBuf, ReportError> {
    let err = |p: &Path, e: &dyn std::fmt::Display| ReportError {
        path: p.display().to_string(),
        message: e.to_string(),
    };
    std::fs::create_dir_all(dir).map_err(|e| err(dir, &e))?;
    for (name, img) in [
        ("fz.png", fz_plot(eval)),
        ("contact.png", contact_plot(eval)),
        ("confusion.png", confusion_plot(&eval.metrics)),
    ] {
        let p = dir.join(name);
        img.save(&p).map_err(|e| err(&p, &e))?;
    }
    let p = dir.join("report.md");
    std::fs::write(&p, markdown(title, eval)).map_err(|e| err(&p, &e))?;
    Ok(p)
}

/// Series of (x, y) points as lines with a legend (training curves), y from 0.
pub fn line_plot(ylabel: &str, xlabel: &str, series: &[(&str, &[[f64; 2]])]) -> RgbImage {
    let mut img = RgbImage::from_pixel(PX, PX, Rgb([255, 255, 255]));
    let finite = || {
        series
            .iter()
            .flat_map(|(_, pts)| pts.iter())
            .filter(|p| p[0].is_finite() && p[1].is_finite())
    };
    let x_hi = finite().map(|p| p[0]).fold(1.0f64, f64::max);
    let x_lo = finite().map(|p| p[0]).fold(x_hi, f64::min).min(x_hi - 1.0);
    let y_hi = finite().map(|p| p[1]).fold(0.0f64, f64::max).max(1e-3) * 1.05;
    let ax = Axes {
        lo: [x_lo, 0.0],
        hi: [x_hi, y_hi],
    };
    let colours = [BLUE, RED, BLACK, GREEN];
    for (k, (name, pts)) in series.iter().enumerate() {
        let colour = colours[k % colours.len()];
        let pts: Vec<[f64; 2]> = pts
            .iter()
            .filter(|p| p[0].is_finite() && p[1].is_finite())
            .map(|p| ax.px(*p))
            .collect();
        for w in pts.windows(2) {
            line(&mut img, w[0], w[1], colour);
        }
        for p in &pts {
            dot(&mut img, *p, 3.0, colour);
        }
        let y = MARGIN as i64 + 12 + 22 * k as i64;
        line(
            &mut img,
            [PX as f64 - MARGIN - 150.0, y as f64 + 5.0],
            [PX as f64 - MARGIN - 120.0, y as f64 + 5.0],
            colour,
        );
        text(&mut img, PX as i64 - MARGIN as i64 - 112, y, 2, name, BLACK);
    }
    ax.frame(&mut img, [tick(x_hi - x_lo), tick(y_hi)], xlabel, ylabel);
    img
}
