//! An evaluation's report: `report.md` (Table-2 figures beside the paper's, breakdowns by grid
//! position and force level, the confusion matrix) and its plots, `fz.png` (predicted against
//! measured Fz), `contact.png` (each labelled contact joined to its prediction, over the disc)
//! and `confusion.png`, drawn by `fringe-plot`; and the same as one self-contained page,
//! `report.html` (the plots embedded, a verdict against a spec when one was judged), which opens
//! in any browser with nothing else installed.

use crate::acceptance::Verdict;
use crate::eval::Evaluation;
use crate::metrics::{Errors, Metrics};
use fringe_plot::html::Page;
use fringe_plot::palette::{BLACK, BLUE, GREY, RED};
use fringe_plot::{Axis, Chart, Corner, Matrix, PlotError, Series};
use image::RgbImage;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// The plots' size, px.
const PX: u32 = 720;

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
    // Live validation offers only labelled frames: what it left out, it skipped while busy.
    let left_out = match (eval.skipped, eval.skipped_busy) {
        (n, 0) => format!("{n} left out: no trustworthy label"),
        (0, busy) => format!("{busy} skipped: the model was still busy with an earlier frame"),
        (n, busy) => format!(
            "{n} left out: no trustworthy label; {busy} skipped: the model was still busy with an earlier frame"
        ),
    };
    let _ = writeln!(
        out,
        "{} frames evaluated ({left_out}), {} in contact.\n",
        m.all.n, m.all.n_contact
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

/// Predicted against measured Fz with the diagonal.
pub fn fz_plot(eval: &Evaluation) -> Result<RgbImage, PlotError> {
    let top = eval
        .rows
        .iter()
        .flat_map(|r| [r.scored.fz_true, r.scored.fz_pred])
        .filter(|v| v.is_finite())
        .fold(1.0f64, f64::max)
        * 1.05;
    let frames: Vec<[f64; 2]> = eval
        .rows
        .iter()
        .map(|r| [r.scored.fz_true, r.scored.fz_pred.clamp(0.0, top)])
        .collect();
    Chart::new(
        "Predicted against measured Fz",
        Axis::new("measured Fz (N)").range(0.0, top),
        Axis::new("predicted Fz (N)").range(0.0, top),
    )
    .equal_aspect()
    .series(Series::line("predicted = measured", &[[0.0, 0.0], [top, top]], GREY).dashed())
    .series(Series::points("frame", &frames, 3, BLUE))
    .note(format!("RMSE {} N", fmt(eval.metrics.all.fz_rmse(), 3)))
    .note(format!("{} frames", eval.rows.len()))
    .legend_at(Corner::LowerRight)
    .render(PX, PX)
}

/// Each labelled contact (dot) joined to its prediction (line), errors over 2 mm in red.
pub fn contact_plot(eval: &Evaluation) -> Result<RgbImage, PlotError> {
    let farthest = eval
        .rows
        .iter()
        .filter_map(|r| r.scored.contact_true)
        .map(|[x, y]| x.hypot(y))
        .fold(5.0f64, f64::max);
    let reach = farthest * 1.2;
    let (mut near, mut far, mut labelled) = (Vec::new(), Vec::new(), Vec::new());
    for r in &eval.rows {
        if let Some(t) = r.scored.contact_true {
            let p = r.scored.contact_pred;
            let err = (p[0] - t[0]).hypot(p[1] - t[1]);
            if err > 2.0 { &mut far } else { &mut near }.push([t, p]);
            labelled.push(t);
        }
    }
    Chart::new(
        format!(
            "Contact: labelled to predicted (RMSE {} mm)",
            fmt(eval.metrics.all.contact_rmse(), 3)
        ),
        Axis::new("contact x (mm)").range(-reach, reach),
        Axis::new("contact y (mm)").range(-reach, reach),
    )
    .equal_aspect()
    .series(Series::circle(
        "farthest labelled contact",
        [0.0, 0.0],
        farthest,
        GREY,
    ))
    .series(Series::segments("error up to 2 mm", &near, BLUE))
    .series(Series::segments("error over 2 mm", &far, RED))
    .series(Series::points("labelled contact", &labelled, 2, BLACK))
    .render(PX, PX)
}

/// The confusion matrix, cells shaded by the share of their row.
pub fn confusion_plot(m: &Metrics) -> Result<RgbImage, PlotError> {
    Matrix {
        title: "Shape confusion matrix (shade: share of the row)",
        rows_label: "labelled shape",
        columns_label: "predicted shape",
        names: &m.classes,
        counts: &m.confusion,
    }
    .render(PX)
}

/// Which coordinates are which, said in every report that shows positions.
pub const COORDINATES: &str = "Coordinates: contact positions (contact x and y, the contact error) are sensor millimetres, on the sensor's surface from its centre, as the unit's calibration profile maps the image to it; grid positions and press positions are stage millimetres, where the stage put the indenter.";

/// Writes `report.md`, `report.html` and the plots into `dir` (created); returns the Markdown
/// report's path.
pub fn write(dir: &Path, title: &str, eval: &Evaluation) -> Result<PathBuf, ReportError> {
    write_judged(dir, title, eval, None)
}

/// [`write`], with the verdict against a spec (and where the spec came from) at the head of
/// `report.html`.
pub fn write_judged(
    dir: &Path,
    title: &str,
    eval: &Evaluation,
    verdict: Option<(&Verdict, &str)>,
) -> Result<PathBuf, ReportError> {
    let err = |p: &Path, e: &dyn std::fmt::Display| ReportError {
        path: p.display().to_string(),
        message: e.to_string(),
    };
    std::fs::create_dir_all(dir).map_err(|e| err(dir, &e))?;
    let mut page = Page::new(title);
    if let Some((v, origin)) = verdict {
        verdict_html(&mut page, v, origin);
    }
    let html = dir.join("report.html");
    for (name, img) in [
        ("fz.png", fz_plot(eval)),
        ("contact.png", contact_plot(eval)),
        ("confusion.png", confusion_plot(&eval.metrics)),
    ] {
        let p = dir.join(name);
        let img = img.map_err(|e| err(&p, &e))?;
        img.save(&p).map_err(|e| err(&p, &e))?;
        if name == "fz.png" {
            evaluation_html(&mut page, eval);
        }
        page.image(caption(name), &img)
            .map_err(|e| err(&html, &e))?;
    }
    std::fs::write(&html, page.finish()).map_err(|e| err(&html, &e))?;
    let p = dir.join("report.md");
    std::fs::write(&p, markdown(title, eval)).map_err(|e| err(&p, &e))?;
    Ok(p)
}

/// Writes `eval`'s rows to the CSV file `path`, one per frame in the order evaluated (a run's
/// labelled frames in record order): the press, the stage position, and each label beside its
/// prediction (Fz in N; shapes by name from `classes`; the contact in mm, the label's empty
/// without contact, the contact head's output whatever the shape). Figures are written in full
/// (the shortest text that reads back as the same number).
pub fn write_predictions(
    path: &Path,
    eval: &Evaluation,
    classes: &[String],
) -> Result<(), ReportError> {
    let err = |e: &dyn std::fmt::Display| ReportError {
        path: path.display().to_string(),
        message: e.to_string(),
    };
    let mut w = csv::Writer::from_path(path).map_err(|e| err(&e))?;
    w.write_record([
        "press",
        "stage_x_mm",
        "stage_y_mm",
        "fz_true",
        "fz_pred",
        "shape_true",
        "shape_pred",
        "contact_true_x_mm",
        "contact_true_y_mm",
        "contact_pred_x_mm",
        "contact_pred_y_mm",
    ])
    .map_err(|e| err(&e))?;
    let name = |i: usize| classes.get(i).cloned().unwrap_or_else(|| i.to_string());
    let figure = |v: Option<f64>| v.map_or(String::new(), |v| v.to_string());
    for r in &eval.rows {
        let s = &r.scored;
        w.write_record([
            r.press.clone(),
            figure(r.stage_mm.map(|p| p[0])),
            figure(r.stage_mm.map(|p| p[1])),
            s.fz_true.to_string(),
            s.fz_pred.to_string(),
            name(s.shape_true),
            name(s.shape_pred),
            figure(s.contact_true.map(|c| c[0])),
            figure(s.contact_true.map(|c| c[1])),
            s.contact_pred[0].to_string(),
            s.contact_pred[1].to_string(),
        ])
        .map_err(|e| err(&e))?;
    }
    w.flush().map_err(|e| err(&e))
}

fn caption(png: &str) -> &'static str {
    match png {
        "fz.png" => "Predicted against measured Fz (N)",
        "contact.png" => "Contact: each labelled contact joined to its prediction (sensor mm)",
        _ => "Shape confusion matrix",
    }
}

/// A verdict against a spec on a page: PASS or FAIL in its box, every check, and the groups
/// (grid cells, force levels, shapes) that miss a whole-set threshold, worst first.
pub fn verdict_html(page: &mut Page, v: &Verdict, spec_origin: &str) {
    page.verdict(
        v.pass,
        &format!(
            "Verdict: {} against {spec_origin}",
            if v.pass { "PASS" } else { "FAIL" }
        ),
    );
    page.heading("The spec's checks");
    let rows: Vec<Vec<String>> = v
        .checks
        .iter()
        .map(|c| {
            vec![
                c.figure.to_string(),
                c.over.clone(),
                fmt(c.value, 4),
                format!(
                    "{} {}",
                    if c.at_most { "at most" } else { "at least" },
                    fmt(c.limit, 4)
                ),
                c.frames.to_string(),
                if c.pass { "ok" } else { "FAIL" }.to_string(),
            ]
        })
        .collect();
    page.table(
        &["figure", "over", "value", "threshold", "frames", ""],
        &rows,
    );
    weak_html(page, v);
}

/// The weak cells: groups that miss a threshold the whole set is held to.
fn weak_html(page: &mut Page, v: &Verdict) {
    page.heading("Weak cells");
    if v.weak.is_empty() {
        page.paragraph(
            "None: every grid cell, force level and shape meets the whole set's thresholds.",
        );
        return;
    }
    page.paragraph("Groups of frames (grid cells in stage mm, force levels, shapes) that miss a threshold the whole set is held to, worst first: where to look.");
    let rows: Vec<Vec<String>> = v
        .weak
        .iter()
        .map(|w| {
            vec![
                w.group.clone(),
                w.figure.to_string(),
                fmt(w.value, 4),
                fmt(w.limit, 4),
                w.frames.to_string(),
            ]
        })
        .collect();
    page.table(&["group", "figure", "value", "limit", "frames"], &rows);
}

/// An evaluation's figures on a page (its plots follow): Table 2 beside the paper's rows, the
/// macro scores, the confusion matrix and the breakdowns, and which coordinates are which.
pub fn evaluation_html(page: &mut Page, eval: &Evaluation) {
    let m = &eval.metrics;
    let s = m.macro_scores();
    page.heading("Figures");
    page.paragraph(&format!(
        "{} frames evaluated ({} left out: no trustworthy label), {} in contact. Macro precision {}, recall {}, F1 {}.",
        m.all.n,
        eval.skipped,
        m.all.n_contact,
        fmt(s.precision, 4),
        fmt(s.recall, 4),
        fmt(s.f1, 4)
    ));
    let header = [
        "",
        "frames",
        "Fz MSE (N^2)",
        "Fz RMSE (N)",
        "contact RMSE (mm)",
        "shape accuracy",
    ];
    let mut rows = vec![errors_cells("this model", &m.all)];
    for (name, mse, rmse, c, a) in PAPER {
        rows.push(vec![
            name.to_string(),
            String::new(),
            mse.to_string(),
            rmse.to_string(),
            c.to_string(),
            a.to_string(),
        ]);
    }
    page.table(&header, &rows);
    page.note(COORDINATES);
    page.heading("Confusion matrix (rows: labelled, columns: predicted)");
    let mut head: Vec<&str> = vec![""];
    head.extend(m.classes.iter().map(String::as_str));
    let rows: Vec<Vec<String>> = m
        .classes
        .iter()
        .zip(&m.confusion)
        .map(|(name, row)| {
            let mut r = vec![name.clone()];
            r.extend(row.iter().map(u64::to_string));
            r
        })
        .collect();
    page.table(&head, &rows);
    for (heading, prefix) in [
        ("By force level", "force "),
        ("By grid position (stage mm)", "grid "),
    ] {
        let rows: Vec<Vec<String>> = m
            .by_key
            .iter()
            .filter(|(k, _)| k.starts_with(prefix))
            .map(|(k, e)| errors_cells(k.trim_start_matches(prefix), e))
            .collect();
        if !rows.is_empty() {
            page.heading(heading);
            page.table(&header, &rows);
        }
    }
    page.heading("Plots");
}

/// An errors row's cells: name, frames, Fz MSE, Fz RMSE, contact RMSE, accuracy.
fn errors_cells(name: &str, e: &Errors) -> Vec<String> {
    vec![
        name.to_string(),
        e.n.to_string(),
        fmt(e.fz_mse(), 4),
        fmt(e.fz_rmse(), 4),
        fmt(e.contact_rmse(), 4),
        fmt(e.accuracy(), 4),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::eval::Row;
    use crate::metrics::Scored;

    /// Forty frames: contacts on a ring, predictions 0.5 mm off (one 3 mm off), Fz 1 to 5 N.
    fn evaluation() -> Evaluation {
        let classes = vec!["None".to_string(), "Sphere".to_string()];
        let mut metrics = Metrics::new(classes);
        let mut rows = Vec::new();
        for k in 0..40 {
            let a = k as f64 * 0.4;
            let t = [5.0 * a.cos(), 5.0 * a.sin()];
            let off = if k == 7 { 3.0 } else { 0.5 };
            let scored = Scored {
                fz_true: 1.0 + 0.1 * k as f64,
                fz_pred: 1.05 + 0.1 * k as f64,
                shape_true: 1,
                shape_pred: usize::from(k != 3),
                contact_true: Some(t),
                contact_pred: [t[0] + off, t[1]],
                shear_true: None,
                shear_pred: None,
                slip_true: None,
                slip_pred: None,
            };
            metrics.add(&scored, &[]);
            rows.push(Row {
                scored,
                stage_mm: None,
                press: format!("p{k}"),
            });
        }
        Evaluation {
            metrics,
            rows,
            skipped: 0,
            skipped_busy: 0,
            labels_know_shear: false,
        }
    }

    fn count(img: &RgbImage, c: [u8; 3]) -> usize {
        img.pixels().filter(|p| p.0 == c).count()
    }

    #[test]
    fn the_report_plots_draw_their_data() {
        let eval = evaluation();
        let fz = fz_plot(&eval).expect("fz");
        assert_eq!(fz.dimensions(), (PX, PX));
        assert!(count(&fz, BLUE) > 40 * 20, "a dot per frame");
        assert!(count(&fz, GREY) > 100, "the diagonal");
        let contact = contact_plot(&eval).expect("contact");
        assert!(count(&contact, RED) > 30, "the one error over 2 mm");
        assert!(count(&contact, BLUE) > 39 * 10, "the errors under 2 mm");
        let confusion = confusion_plot(&eval.metrics).expect("confusion");
        // Sphere row: 39 of 40 predicted Sphere (deep blue), 1 None (pale red).
        let shade = (255.0 - 200.0 * 39.0 / 40.0_f64).round() as u8;
        assert!(count(&confusion, [shade, shade, 255]) > 1000);
        let dir = tempfile::tempdir().expect("dir");
        let md = write(dir.path(), "t", &eval).expect("write");
        for png in ["fz.png", "contact.png", "confusion.png"] {
            let img = image::open(dir.path().join(png)).expect(png).to_rgb8();
            assert_eq!(img.dimensions(), (PX, PX), "{png}");
        }
        assert!(md.ends_with("report.md"));
        let html = std::fs::read_to_string(dir.path().join("report.html")).expect("html");
        assert_eq!(
            html.matches("data:image/png;base64,").count(),
            3,
            "three plots embedded"
        );
        assert!(html.contains("sensor millimetres") && html.contains("stage millimetres"));
    }

    /// A live validation's frames skipped while the model was busy are said as such, never as
    /// frames without a trustworthy label (which a stored run's report keeps saying).
    #[test]
    fn the_report_gives_the_reason_frames_were_left_out() {
        let mut eval = evaluation();
        let stored = markdown("t", &eval);
        assert!(
            stored
                .contains("40 frames evaluated (0 left out: no trustworthy label), 40 in contact."),
            "{stored}"
        );
        eval.skipped_busy = 131;
        let live = markdown("t", &eval);
        assert!(
            live.contains("(131 skipped: the model was still busy with an earlier frame)"),
            "{live}"
        );
        assert!(!live.contains("trustworthy"), "{live}");
        eval.skipped = 4;
        let both = markdown("t", &eval);
        assert!(
            both.contains(
                "(4 left out: no trustworthy label; 131 skipped: the model was still busy"
            ),
            "{both}"
        );
    }
}
