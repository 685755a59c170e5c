//! The keys, over everything (`?`): the lines [`keys::help_rows`] makes from the binding tables.

use crate::ui::keys;
use crate::ui::widgets::{centred, panel};
use ratatui::text::Line;
use ratatui::widgets::{Clear, Paragraph};
use ratatui::Frame;

/// The keys' column is at least this wide.
const KEYS_WIDTH: usize = 14;

pub(crate) fn draw(f: &mut Frame) {
    let rows = keys::help_rows();
    let width = rows
        .iter()
        .map(|r| r.keys.chars().count())
        .fold(KEYS_WIDTH, usize::max);
    let area = centred(f.area(), 96, rows.len() as u16 + 2);
    let lines: Vec<Line> = rows
        .iter()
        .map(|r| Line::from(format!(" {:<width$} {}", r.keys, r.what)))
        .collect();
    f.render_widget(Clear, area);
    f.render_widget(Paragraph::new(lines).block(panel("keys")), area);
}
