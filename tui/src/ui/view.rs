//! Drawing the UI from its state: tabs, the screen of the chosen tab, the footer with the keys
//! or the newest error, and the dialog and help overlays. Pure: state in, cells out.

mod help;

use super::screens;
use super::state::{Picker, UiState};
use super::widgets::{centred, panel, ACCENT, BAD, WARN};
use ratatui::layout::{Constraint, Layout};
use ratatui::style::{Modifier, Style};
use ratatui::text::{Line, Span};
use ratatui::widgets::{Block, Borders, Clear, List, ListItem, ListState, Paragraph, Tabs, Wrap};
use ratatui::Frame;

pub fn draw(f: &mut Frame, s: &UiState) {
    let [top, body, foot] = Layout::vertical([
        Constraint::Length(1),
        Constraint::Min(0),
        Constraint::Length(1),
    ])
    .areas(f.area());
    let titles: Vec<Line> = screens::ALL
        .iter()
        .enumerate()
        .map(|(i, screen)| Line::from(format!("{} {}", i + 1, screen.title)))
        .collect();
    let selected = screens::index(s.tab);
    let screen = &screens::ALL[selected];
    // Each title padded by a space either side, one divider between two, then a gap.
    let tabs_width = titles.iter().map(|t| t.width() + 3).sum::<usize>() + 1;
    let [tabs_area, rig_area] = Layout::horizontal([
        Constraint::Length(u16::try_from(tabs_width).unwrap_or(u16::MAX)),
        Constraint::Min(0),
    ])
    .areas(top);
    f.render_widget(
        Tabs::new(titles).select(selected).highlight_style(
            Style::new()
                .fg(ACCENT)
                .add_modifier(Modifier::BOLD | Modifier::REVERSED),
        ),
        tabs_area,
    );
    f.render_widget(
        Paragraph::new(shortened(&format!("fringe · {}", s.rig), rig_area.width))
            .style(Style::new().add_modifier(Modifier::DIM)),
        rig_area,
    );
    (screen.draw)(f, body, s);
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
            Span::raw((screen.hint)(s)),
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

#[cfg(test)]
mod tests;

/// `text` cut to `width` columns, ending in `…` when cut.
pub(crate) fn shortened(text: &str, width: u16) -> String {
    let width = usize::from(width);
    if text.chars().count() <= width {
        return text.to_string();
    }
    let mut out: String = text.chars().take(width.saturating_sub(1)).collect();
    out.push('…');
    out
}
