//! The Runs screen: the runs in the runs directory, newest first, with their status and frames,
//! the verdict of a verification, the model's figures of an evaluation and where an export went,
//! when the user asked for them.

use super::{panel, BAD, GOOD, WARN};
use crate::ui::state::RunsView;
use ratatui::layout::{Constraint, Rect};
use ratatui::style::{Modifier, Style};
use ratatui::widgets::{Cell, Paragraph, Row, Table, TableState};
use ratatui::Frame;

/// `model`: what `e` evaluates with (the model that ships when none was named).
pub(crate) fn draw(f: &mut Frame, area: Rect, v: &RunsView, model: Option<&str>) {
    let title = format!(
        "runs in {} · Enter verify · e evaluate with {} · x export · g refresh",
        v.root,
        model.unwrap_or(fringe_sensor_models::builtin::DEFAULT)
    );
    if v.rows.is_empty() {
        f.render_widget(
            Paragraph::new("no runs yet: run a scan (Scan screen, r)").block(panel(&title)),
            area,
        );
        return;
    }
    let rows = v.rows.iter().map(|r| {
        let status = match r.status.as_str() {
            "completed" => Style::new().fg(GOOD),
            "unfinished" => Style::new().fg(WARN),
            _ => Style::new().fg(BAD),
        };
        let verified = match r.verified.as_deref() {
            Some(v) if v.starts_with("ok") => {
                Cell::from(v.to_string()).style(Style::new().fg(GOOD))
            }
            Some(v) if v.starts_with("verifying") => Cell::from(v.to_string()),
            Some(v) => Cell::from(v.to_string()).style(Style::new().fg(BAD)),
            None => Cell::from("-"),
        };
        let evaluated = match r.evaluated.as_deref() {
            Some(e) if e.starts_with("cannot") => {
                Cell::from(e.to_string()).style(Style::new().fg(BAD))
            }
            Some(e) => Cell::from(e.to_string()),
            None => Cell::from("-"),
        };
        let exported = match r.exported.as_deref() {
            Some(e) if e.starts_with("cannot") => {
                Cell::from(e.to_string()).style(Style::new().fg(BAD))
            }
            Some(e) if e.starts_with("exported") => {
                Cell::from(e.to_string()).style(Style::new().fg(GOOD))
            }
            Some(e) => Cell::from(e.to_string()),
            None => Cell::from("-"),
        };
        Row::new(vec![
            Cell::from(r.name.clone()),
            Cell::from(r.status.clone()).style(status),
            Cell::from(r.frames.to_string()),
            verified,
            evaluated,
            exported,
        ])
    });
    // The whole run id, which the other commands take (up to a width that leaves the rest room).
    let widest = v
        .rows
        .iter()
        .map(|r| r.name.chars().count())
        .max()
        .unwrap_or(0);
    let run_width = widest.clamp(26, 48) as u16;
    let table = Table::new(
        rows,
        [
            Constraint::Length(run_width),
            Constraint::Length(11),
            Constraint::Length(8),
            Constraint::Min(20),
            Constraint::Length(44),
            Constraint::Length(36),
        ],
    )
    .header(
        Row::new([
            "run",
            "status",
            "frames",
            "verified",
            "evaluation",
            "export",
        ])
        .style(Style::new().add_modifier(Modifier::BOLD)),
    )
    .row_highlight_style(Style::new().add_modifier(Modifier::REVERSED))
    .block(panel(&title));
    let mut state = TableState::default().with_selected(Some(v.selected));
    f.render_stateful_widget(table, area, &mut state);
}
