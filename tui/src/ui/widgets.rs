//! What the screens draw with: the accent colours, titled panels, a box in the middle of the
//! terminal, the disc canvas ([`disc`]) and the time chart ([`time_chart`]).

pub mod disc;
pub mod time_chart;

use ratatui::layout::Rect;
use ratatui::style::{Color, Style};
use ratatui::text::{Line, Span};
use ratatui::widgets::{Block, Borders};

/// Accent colours: ANSI names, which every terminal theme maps to colours that read on its own
/// background (no fixed black or white).
pub const ACCENT: Color = Color::Cyan;
pub const GOOD: Color = Color::Green;
pub const WARN: Color = Color::Yellow;
pub const BAD: Color = Color::Red;
pub const MEASURED: Color = Color::Cyan;
pub const PREDICTED: Color = Color::Magenta;
/// Not yet done: the terminal's own text colour.
pub const PENDING: Color = Color::Reset;

/// A box of `w` x `h` cells in the middle of `area` (smaller when the area is).
pub fn centred(area: Rect, w: u16, h: u16) -> Rect {
    let w = w.min(area.width);
    let h = h.min(area.height);
    Rect::new(
        area.x + (area.width - w) / 2,
        area.y + (area.height - h) / 2,
        w,
        h,
    )
}

/// A titled block.
pub fn panel(title: &str) -> Block<'_> {
    Block::default()
        .borders(Borders::ALL)
        .title(Span::styled(format!(" {title} "), Style::new().fg(ACCENT)))
}

/// A titled block whose title names the series drawn in it, each in its colour (instead of a
/// legend box over the data).
pub fn legend_panel<'a>(title: &'a str, series: &[(&'a str, Color)]) -> Block<'a> {
    let mut spans = vec![Span::styled(format!(" {title}: "), Style::new().fg(ACCENT))];
    for (i, (name, colour)) in series.iter().enumerate() {
        if i > 0 {
            spans.push(Span::raw(", "));
        }
        spans.push(Span::styled(*name, Style::new().fg(*colour)));
    }
    spans.push(Span::raw(" "));
    Block::default()
        .borders(Borders::ALL)
        .title(Line::from(spans))
}
