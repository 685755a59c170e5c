//! The Calibrate screen: the calibration plan and where the profile goes, the scan's progress,
//! then the fit: the averaged no-contact frame with the fitted disc (green), crop circle (yellow)
//! and centre (red), the optical figures, the registration and its residual per press, the force
//! offsets; `w` writes the profile.

use super::{panel, ACCENT, BAD, GOOD, WARN};
use crate::ui::picture::Picture;
use crate::ui::state::{CalibrateView, CalibrationPhase, Phase, ScanView};
use ratatui::layout::{Constraint, Layout, Rect};
use ratatui::style::Style;
use ratatui::text::{Line, Span};
use ratatui::widgets::{Paragraph, Wrap};
use ratatui::Frame;

/// A residual over this many px is shown as a warning.
const RESIDUAL_WARN_PX: f64 = 3.0;

/// The keys that act on the calibration now.
pub(crate) fn key_hint(v: &CalibrateView) -> &'static str {
    match v.phase {
        CalibrationPhase::Fitted => "w write the profile · r run the calibration scan again",
        CalibrationPhase::Scanning => "a abort the scan",
        CalibrationPhase::Fitting | CalibrationPhase::Writing => "",
        _ => "r run the calibration scan",
    }
}

pub(crate) fn draw(f: &mut Frame, area: Rect, v: &CalibrateView, scan: &ScanView) {
    let [left, right] =
        Layout::horizontal([Constraint::Percentage(55), Constraint::Percentage(45)]).areas(area);
    let (phase, colour) = match &v.phase {
        CalibrationPhase::Ready => (
            "ready: press r to run the calibration scan".to_string(),
            ACCENT,
        ),
        CalibrationPhase::Scanning => {
            let state = match &scan.phase {
                Phase::Paused(why) => format!("paused: {why}"),
                _ => format!("press {} of {}", scan.done.min(scan.total) + 1, scan.total),
            };
            (format!("calibration scan: {state}"), GOOD)
        }
        CalibrationPhase::Fitting => ("fitting the profile from the run...".to_string(), ACCENT),
        CalibrationPhase::Fitted => (
            "fitted: press w to write the profile (r runs the scan again)".to_string(),
            WARN,
        ),
        CalibrationPhase::Writing => ("writing the profile...".to_string(), ACCENT),
        CalibrationPhase::Written(files) => (format!("written: {files}"), GOOD),
        CalibrationPhase::Failed(why) => (format!("failed: {why}"), BAD),
    };
    let mut lines = vec![
        Line::from(Span::styled(phase, Style::new().fg(colour))),
        Line::from(format!("sensor {} · profile {}", v.sensor, v.profile)),
        Line::from(v.plan.clone()),
        Line::from(""),
    ];
    let heading = |t: &str| Line::from(Span::styled(t.to_string(), Style::new().fg(ACCENT)));
    if !v.fit.is_empty() {
        lines.push(heading("optical fit"));
        lines.extend(v.fit.iter().map(|l| Line::from(format!("  {l}"))));
        lines.push(heading("registration (image <-> stage)"));
        lines.push(Line::from(format!("  {}", v.registration)));
        for (i, p) in v.presses.iter().enumerate() {
            let (text, style) = match &p.outcome {
                Ok((px, true)) => (
                    format!("{px:.2} px, left out as an outlier"),
                    Style::new().fg(WARN),
                ),
                Ok((px, false)) if *px > RESIDUAL_WARN_PX => {
                    (format!("{px:.2} px"), Style::new().fg(WARN))
                }
                Ok((px, false)) => (format!("{px:.2} px"), Style::new().fg(GOOD)),
                Err(e) => (format!("not located: {e}"), Style::new().fg(BAD)),
            };
            lines.push(Line::from(vec![
                Span::raw(format!(
                    "  press {:>2} at ({:>8.3}, {:>8.3}) mm: ",
                    i + 1,
                    p.stage_mm.0,
                    p.stage_mm.1
                )),
                Span::styled(text, style),
            ]));
        }
        lines.push(heading("force offsets"));
        lines.extend(v.offsets.iter().map(|l| Line::from(format!("  {l}"))));
    }
    f.render_widget(
        Paragraph::new(lines)
            .wrap(Wrap { trim: false })
            .block(panel("calibration")),
        left,
    );
    let block = panel("averaged frame: disc green, crop yellow, centre red");
    let inner = block.inner(right);
    f.render_widget(block, right);
    match &v.picture {
        Some(p) => f.render_widget(Picture(p), inner),
        None => f.render_widget(Paragraph::new("no fit yet"), inner),
    }
}
