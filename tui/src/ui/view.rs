//! Drawing the UI from its state: tabs, the screen of the chosen tab, the footer with the keys
//! or the newest error, and the dialog and help overlays. Pure: state in, cells out.

mod bench;
mod calibrate;
mod disc;
mod help;
mod runs;
mod scan;
mod time_chart;
mod validate;

use super::state::{Picker, Tab, UiState};
use ratatui::layout::{Constraint, Layout, Rect};
use ratatui::style::{Color, Modifier, Style};
use ratatui::text::{Line, Span};
use ratatui::widgets::{Block, Borders, Clear, List, ListItem, ListState, Paragraph, Tabs, Wrap};
use ratatui::Frame;

/// Accent colours: ANSI names, which every terminal theme maps to colours that read on its own
/// background (no fixed black or white).
pub(crate) const ACCENT: Color = Color::Cyan;
pub(crate) const GOOD: Color = Color::Green;
pub(crate) const WARN: Color = Color::Yellow;
pub(crate) const BAD: Color = Color::Red;
pub(crate) const MEASURED: Color = Color::Cyan;
pub(crate) const PREDICTED: Color = Color::Magenta;
/// Not yet done: the terminal's own text colour.
pub(crate) const PENDING: Color = Color::Reset;

pub fn draw(f: &mut Frame, s: &UiState) {
    let [top, body, foot] = Layout::vertical([
        Constraint::Length(1),
        Constraint::Min(0),
        Constraint::Length(1),
    ])
    .areas(f.area());
    let titles: Vec<Line> = Tab::ALL
        .iter()
        .enumerate()
        .map(|(i, t)| Line::from(format!("{} {}", i + 1, t.title())))
        .collect();
    let selected = Tab::ALL.iter().position(|t| *t == s.tab).unwrap_or(0);
    let [tabs_area, rig_area] =
        Layout::horizontal([Constraint::Length(56), Constraint::Min(0)]).areas(top);
    f.render_widget(
        Tabs::new(titles).select(selected).highlight_style(
            Style::new()
                .fg(ACCENT)
                .add_modifier(Modifier::BOLD | Modifier::REVERSED),
        ),
        tabs_area,
    );
    f.render_widget(
        Paragraph::new(format!("fringe · {}", s.rig))
            .style(Style::new().add_modifier(Modifier::DIM)),
        rig_area,
    );
    match s.tab {
        Tab::Scan => scan::draw(f, body, s),
        Tab::Validate => validate::draw(f, body, s),
        Tab::Runs => runs::draw(f, body, &s.runs, s.model.as_deref()),
        Tab::Bench => bench::draw(f, body, &s.bench),
        Tab::Calibrate => calibrate::draw(f, body, &s.calibrate, &s.scan),
    }
    let footer = match &s.error {
        Some(e) => Line::from(Span::styled(
            format!(" {e}"),
            Style::new().fg(BAD).add_modifier(Modifier::BOLD),
        )),
        None => Line::from(vec![
            Span::styled(" ? ", Style::new().add_modifier(Modifier::REVERSED)),
            Span::raw(" keys  "),
            Span::styled(" q ", Style::new().add_modifier(Modifier::REVERSED)),
            Span::raw(" quit  "),
            Span::styled(" Tab ", Style::new().add_modifier(Modifier::REVERSED)),
            Span::raw(" next screen  "),
            Span::raw(match s.tab {
                Tab::Bench => bench::KEY_HINT,
                Tab::Calibrate => calibrate::key_hint(&s.calibrate),
                _ => scan::key_hint(s),
            }),
        ]),
    };
    f.render_widget(Paragraph::new(footer), foot);
    if let Some(d) = &s.dialog {
        let area = centred(f.area(), 60, 7);
        f.render_widget(Clear, area);
        f.render_widget(
            Paragraph::new(vec![
                Line::from(d.message.clone()),
                Line::from(""),
                Line::from(vec![
                    Span::styled(" Enter ", Style::new().add_modifier(Modifier::REVERSED)),
                    Span::raw(" continue   "),
                    Span::styled(" a ", Style::new().add_modifier(Modifier::REVERSED)),
                    Span::raw(" abort the scan"),
                ]),
            ])
            .wrap(Wrap { trim: true })
            .block(
                Block::default()
                    .borders(Borders::ALL)
                    .border_style(Style::new().fg(WARN))
                    .title(format!(" {} ", d.title)),
            ),
            area,
        );
    }
    if let Some(p) = &s.picker {
        draw_picker(f, p);
    }
    if s.help {
        help::draw(f);
    }
}

/// The plan chooser over the screen.
fn draw_picker(f: &mut Frame, p: &Picker) {
    let area = centred(f.area(), 76, p.items.len() as u16 + 2);
    let items: Vec<ListItem> = p.items.iter().map(|i| ListItem::new(i.as_str())).collect();
    let list = List::new(items)
        .highlight_style(Style::new().add_modifier(Modifier::REVERSED))
        .block(panel("scan plans · Enter choose · Esc close"));
    f.render_widget(Clear, area);
    f.render_stateful_widget(
        list,
        area,
        &mut ListState::default().with_selected(Some(p.selected)),
    );
}

/// A box of `w` x `h` cells in the middle of `area` (smaller when the area is).
pub(crate) fn centred(area: Rect, w: u16, h: u16) -> Rect {
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
pub(crate) fn panel(title: &str) -> Block<'_> {
    Block::default()
        .borders(Borders::ALL)
        .title(Span::styled(format!(" {title} "), Style::new().fg(ACCENT)))
}

/// A titled block whose title names the series drawn in it, each in its colour (instead of a
/// legend box over the data).
pub(crate) fn legend_panel<'a>(title: &'a str, series: &[(&'a str, Color)]) -> Block<'a> {
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

#[cfg(test)]
mod tests;
