//! The Health screen: the unit's checks against its commissioning certificate (`fringe check`
//! makes them, a two-minute scan), oldest first with their verdicts, and the chosen check's
//! figures against their thresholds, the moved ones marked. It reads the history again whenever
//! the file changes (a check run from another terminal shows up).

use crate::ui::app::App;
use crate::ui::binding::{self, code, Binding, HelpRow, Scope};
use crate::ui::health;
use crate::ui::screen::{Screen, ScreenDef};
use crate::ui::state::{HealthView, Tab};
use crate::ui::widgets::{panel, BAD, GOOD, WARN};
use fringe_app::health::{Rule, Verdict};
use ratatui::crossterm::event::{KeyCode, KeyModifiers};
use ratatui::layout::{Constraint, Layout, Rect};
use ratatui::style::{Modifier, Style};
use ratatui::text::{Line, Span};
use ratatui::widgets::{Cell, Paragraph, Row, Table, TableState, Wrap};
use ratatui::Frame;
use std::time::SystemTime;

/// This screen, by name: `UiState::tab` when it is shown; the command line and other code
/// choose it by this.
pub const TAB: Tab = Tab::named("health");

pub const SCREEN: ScreenDef = ScreenDef {
    tab: TAB,
    title: "Health",
    help,
    draw: |f, area, s| draw(f, area, &s.health),
    hint: |_| "Up/Down choose a check · fringe check makes one",
    open: |app| {
        Box::new(Health {
            seen: health::history_file(&app.opts.config).and_then(|p| health::changed(&p)),
        })
    },
};

#[derive(Debug, Clone, Copy)]
enum Action {
    Up,
    Down,
}

const KEYS: &[Binding<Action>] = &[
    Binding {
        keys: &[code(KeyCode::Up)],
        scope: Scope::Shown,
        action: Action::Up,
        label: "Up / Down",
        help: "choose a check: its figures against their thresholds",
    },
    Binding {
        keys: &[code(KeyCode::Down)],
        scope: Scope::Shown,
        action: Action::Down,
        label: "",
        help: "",
    },
];

fn help() -> Vec<HelpRow> {
    binding::help_rows(KEYS, Some(SCREEN.title))
}

/// When the history file had last changed when it was read.
struct Health {
    seen: Option<SystemTime>,
}

impl Screen for Health {
    fn key(&mut self, app: &mut App, code: KeyCode, mods: KeyModifiers, shown: bool) -> bool {
        let Some(action) = binding::find(KEYS, code, mods, shown) else {
            return false;
        };
        let v = &mut app.state.health;
        let n = v.checks.len();
        match action {
            Action::Up => v.selected = v.selected.saturating_sub(1),
            Action::Down => v.selected = (v.selected + 1).min(n.saturating_sub(1)),
        }
        true
    }

    fn tick(&mut self, app: &mut App, shown: bool) -> bool {
        if !shown {
            return false;
        }
        let now = health::history_file(&app.opts.config).and_then(|p| health::changed(&p));
        if now == self.seen {
            return false;
        }
        self.seen = now;
        app.state.health = health::view(&app.opts.config);
        true
    }
}

fn verdict_style(v: Verdict) -> Style {
    match v {
        Verdict::Ok => Style::new().fg(GOOD),
        Verdict::Recommission | Verdict::Recalibrate => Style::new().fg(WARN),
        Verdict::Replace => Style::new().fg(BAD),
    }
}

fn draw(f: &mut Frame, area: Rect, v: &HealthView) {
    let notes = v.notes.len().min(3) as u16;
    let [head, body, foot] = Layout::vertical([
        Constraint::Length(4),
        Constraint::Min(6),
        Constraint::Length(notes),
    ])
    .areas(area);
    let head_text = vec![
        Line::from(format!(
            "sensor {} · certificate {}",
            v.sensor, v.certificate
        )),
        Line::from(format!(
            "history {} · fringe check --rig <rig> checks the unit in two minutes of bench time",
            v.history
        )),
    ];
    f.render_widget(
        Paragraph::new(head_text)
            .wrap(Wrap { trim: true })
            .block(panel("unit health")),
        head,
    );
    let notes: Vec<Line> = v
        .notes
        .iter()
        .take(3)
        .map(|n| Line::from(Span::styled(n.clone(), Style::new().fg(WARN))))
        .collect();
    f.render_widget(Paragraph::new(notes), foot);
    if v.checks.is_empty() {
        f.render_widget(
            Paragraph::new("no checks yet: run fringe check on the rig (a commissioned unit)")
                .block(panel("checks")),
            body,
        );
        return;
    }
    let [left, right] =
        Layout::horizontal([Constraint::Percentage(45), Constraint::Percentage(55)]).areas(body);
    let rows = v.checks.iter().map(|e| {
        Row::new(vec![
            Cell::from(
                e.checked_utc
                    .chars()
                    .take(16)
                    .collect::<String>()
                    .replace('T', " "),
            ),
            Cell::from(e.verdict().name()).style(verdict_style(e.verdict())),
            Cell::from(e.assessment.cause.clone()),
        ])
    });
    let table = Table::new(
        rows,
        [
            Constraint::Length(16),
            Constraint::Length(12),
            Constraint::Min(10),
        ],
    )
    .header(
        Row::new(["checked (UTC)", "verdict", "because"])
            .style(Style::new().add_modifier(Modifier::BOLD)),
    )
    .row_highlight_style(Style::new().add_modifier(Modifier::REVERSED))
    .block(panel("checks, oldest first"));
    let mut state = TableState::default().with_selected(Some(v.selected));
    f.render_stateful_widget(table, left, &mut state);
    let Some(chosen) = v.checks.get(v.selected) else {
        return;
    };
    let figures = chosen.assessment.figures.iter().map(|fig| {
        let limit = match fig.rule {
            Rule::AtMost => format!("<= {:.3}", fig.threshold),
            Rule::AtLeast => format!(">= {:.3}", fig.threshold),
        };
        let limit = match fig.name_and_unit().1 {
            "" => limit,
            unit => format!("{limit} {unit}"),
        };
        let (mark, style) = if fig.moved {
            ("MOVED", Style::new().fg(BAD))
        } else {
            ("ok", Style::new().fg(GOOD))
        };
        let (name, unit) = fig.name_and_unit();
        Row::new(vec![
            Cell::from(name),
            Cell::from(format!("{:.3} {unit}", fig.value)),
            Cell::from(limit),
            Cell::from(mark).style(style),
        ])
    });
    let [said, figures_area] =
        Layout::vertical([Constraint::Length(3), Constraint::Min(3)]).areas(right);
    let mut lines = vec![Line::from(Span::styled(
        chosen.verdict().advice(),
        verdict_style(chosen.verdict()),
    ))];
    if !chosen.assessment.diagnosis.is_empty() {
        lines.push(Line::from(format!(
            "because {}",
            chosen.assessment.diagnosis
        )));
    }
    f.render_widget(Paragraph::new(lines).wrap(Wrap { trim: true }), said);
    let title = format!(
        "figures of the check of {}",
        chosen
            .checked_utc
            .chars()
            .take(16)
            .collect::<String>()
            .replace('T', " ")
    );
    let table = Table::new(
        figures,
        [
            Constraint::Length(20),
            Constraint::Length(12),
            Constraint::Length(13),
            Constraint::Min(5),
        ],
    )
    .header(
        Row::new(["figure", "value", "threshold", ""])
            .style(Style::new().add_modifier(Modifier::BOLD)),
    )
    .block(panel(&title));
    f.render_widget(table, figures_area);
}
