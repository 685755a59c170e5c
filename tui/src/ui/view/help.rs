//! The keys, over everything (`?`).

use super::{centred, panel};
use ratatui::text::Line;
use ratatui::widgets::{Clear, Paragraph};
use ratatui::Frame;

pub(crate) const KEYS: [(&str, &str); 24] = [
    (
        "1-5 / Tab",
        "Scan, Validate, Runs, Bench, Calibrate screens",
    ),
    ("l", "choose the scan plan (built in, ./plans/*.toml)"),
    ("r", "run the scan plan (with live validation on Validate)"),
    ("p", "pause after the current press"),
    ("P", "pause now (z retracts)"),
    ("c", "continue a paused scan"),
    ("a", "abort the scan (z retracts, the run is closed)"),
    ("Enter", "answer a dialog: continue"),
    ("Up / Down", "choose a run"),
    ("Enter (Runs)", "verify the chosen run"),
    ("e (Runs)", "evaluate the chosen run with the model"),
    (
        "x (Runs)",
        "export the chosen run to exports/ (reference layout)",
    ),
    ("g", "refresh the runs"),
    ("x y z (Bench)", "choose the axis to jog"),
    (
        "← → (Bench)",
        "jog the axis by the step (within its soft limits)",
    ),
    ("s (Bench)", "next jog step: 0.01, 0.1, 1, 5 mm"),
    ("h (Bench)", "home the chosen axis"),
    ("Space (Bench)", "stop every axis at once"),
    ("t (Bench)", "tare the F/T sensor (nothing touching)"),
    (
        "r (Calibrate)",
        "run the calibration scan, then fit the profile",
    ),
    (
        "w (Calibrate)",
        "write the fitted profile (profiles/<sensor>.toml)",
    ),
    ("?", "show or hide these keys"),
    ("q / Esc", "quit (asks to abort a running scan first)"),
    ("Ctrl-C", "abort a running scan and quit"),
];

pub(crate) fn draw(f: &mut Frame) {
    let area = centred(f.area(), 72, KEYS.len() as u16 + 2);
    let lines: Vec<Line> = KEYS
        .iter()
        .map(|(k, what)| Line::from(format!(" {k:<14} {what}")))
        .collect();
    f.render_widget(Clear, area);
    f.render_widget(Paragraph::new(lines).block(panel("keys")), area);
}
