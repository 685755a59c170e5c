//! The Units screen: every unit known (as `fringe units` lists them), each with its design, its
//! certificate, its last check, when the next check is due and the model `validate` runs for it;
//! the chosen unit's details below. It reads the profiles again whenever they change (a unit
//! commissioned or checked from another terminal shows up).

use crate::ui::app::App;
use crate::ui::binding::{self, code, Binding, HelpRow, Scope};
use crate::ui::screen::{Screen, ScreenDef};
use crate::ui::state::{Tab, UnitsView};
use crate::ui::units;
use crate::ui::widgets::{panel, BAD, GOOD, WARN};
use fringe_app::health::Verdict;
use fringe_app::units::{when, NextCheck, UnitView, CHECK_EVERY_DAYS};
use ratatui::crossterm::event::{KeyCode, KeyModifiers};
use ratatui::layout::{Constraint, Layout, Rect};
use ratatui::style::{Modifier, Style};
use ratatui::text::{Line, Span};
use ratatui::widgets::{Cell, Paragraph, Row, Table, TableState, Wrap};
use ratatui::Frame;
use std::time::SystemTime;

/// This screen, by name: `UiState::tab` when it is shown; the command line and other code
/// choose it by this.
pub const TAB: Tab = Tab::named("units");

pub const SCREEN: ScreenDef = ScreenDef {
    tab: TAB,
    title: "Units",
    help,
    draw: |f, area, s| draw(f, area, &s.units),
    hint: |_| "Up/Down choose a unit · --unit ID on a command works on it",
    open: |app| {
        Box::new(Units {
            seen: units::changed(&app.opts.config),
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
        help: "choose a unit: its certificate, checks and model",
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

/// When the profiles had last changed when they were read.
struct Units {
    seen: Option<SystemTime>,
}

impl Screen for Units {
    fn key(&mut self, app: &mut App, code: KeyCode, mods: KeyModifiers, shown: bool) -> bool {
        let Some(action) = binding::find(KEYS, code, mods, shown) else {
            return false;
        };
        let v = &mut app.state.units;
        let n = v.units.len();
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
        let now = units::changed(&app.opts.config);
        if now == self.seen {
            return false;
        }
        self.seen = now;
        let selected = app.state.units.selected;
        app.state.units = units::view(&app.opts.config);
        app.state.units.selected = selected.min(app.state.units.units.len().saturating_sub(1));
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

/// `2026-12-06 14:50 UTC` as `2026-12-06`.
fn day(utc: &str) -> String {
    utc.chars().take(10).collect()
}

fn next_style(n: &NextCheck) -> Style {
    match n {
        NextCheck::On { overdue: false, .. } => Style::new(),
        NextCheck::NotCommissioned => Style::new().add_modifier(Modifier::DIM),
        _ => Style::new().fg(WARN),
    }
}

fn draw(f: &mut Frame, area: Rect, v: &UnitsView) {
    let notes = v.notes.len().min(2) as u16;
    let [table_area, detail, foot] = Layout::vertical([
        Constraint::Min(5),
        Constraint::Length(8),
        Constraint::Length(notes),
    ])
    .areas(area);
    let rows = v.units.iter().map(|u| {
        let mut name = u.id.clone();
        if v.on_rig.as_deref() == Some(u.id.as_str()) {
            name.push_str(" *");
        }
        let (cert, cert_style) = match &u.certificate {
            Some(c) => (
                format!(
                    "{} {}",
                    if c.pass { "PASS" } else { "FAIL" },
                    day(&c.issued_utc)
                ),
                Style::new().fg(if c.pass { GOOD } else { BAD }),
            ),
            None => ("none".to_string(), Style::new().add_modifier(Modifier::DIM)),
        };
        let (check, check_style) = match &u.last_check {
            Some(c) => (
                format!("{} {}", c.verdict.name(), day(&c.checked_utc)),
                verdict_style(c.verdict),
            ),
            None => ("none".to_string(), Style::new().add_modifier(Modifier::DIM)),
        };
        let next = match &u.next_check {
            NextCheck::NotCommissioned => "-".to_string(),
            NextCheck::Now(_) => "now".to_string(),
            NextCheck::On { date, overdue } => {
                if *overdue {
                    format!("{date} overdue")
                } else {
                    date.clone()
                }
            }
        };
        let model = match &u.validate {
            fringe_app::units::ValidateModel::Commissioned(_) => "commissioned".to_string(),
            fringe_app::units::ValidateModel::Shipped { .. } => "shipped".to_string(),
            fringe_app::units::ValidateModel::None(_) => "none".to_string(),
        };
        Row::new(vec![
            Cell::from(name),
            Cell::from(u.design.clone().unwrap_or_else(|| "?".into())),
            Cell::from(cert).style(cert_style),
            Cell::from(check).style(check_style),
            Cell::from(next).style(next_style(&u.next_check)),
            Cell::from(model),
        ])
    });
    let title = format!(
        "units under {} (* on the rig; a check is due {CHECK_EVERY_DAYS} days after the last ok one)",
        v.profiles
    );
    let table = Table::new(
        rows,
        [
            Constraint::Length(13),
            Constraint::Length(10),
            Constraint::Length(15),
            Constraint::Length(22),
            Constraint::Length(18),
            Constraint::Min(12),
        ],
    )
    .header(
        Row::new([
            "unit",
            "design",
            "certificate",
            "last check",
            "next check",
            "validate uses",
        ])
        .style(Style::new().add_modifier(Modifier::BOLD)),
    )
    .row_highlight_style(Style::new().add_modifier(Modifier::REVERSED))
    .block(panel(&title));
    let mut state = TableState::default().with_selected(Some(v.selected));
    f.render_stateful_widget(table, table_area, &mut state);
    let foot_lines: Vec<Line> = v
        .notes
        .iter()
        .take(2)
        .map(|n| Line::from(Span::styled(n.clone(), Style::new().fg(WARN))))
        .collect();
    f.render_widget(Paragraph::new(foot_lines), foot);
    let Some(u) = v.units.get(v.selected) else {
        f.render_widget(
            Paragraph::new("no units known: fringe calibrate or fringe commission makes one")
                .block(panel("unit")),
            detail,
        );
        return;
    };
    let title = format!("unit {}", u.id);
    f.render_widget(
        Paragraph::new(detail_lines(u))
            .wrap(Wrap { trim: true })
            .block(panel(&title)),
        detail,
    );
}

/// The chosen unit in full.
fn detail_lines(u: &UnitView) -> Vec<Line<'static>> {
    let mut lines = Vec::new();
    lines.push(Line::from(match &u.certificate {
        Some(c) => format!(
            "certificate: {} against {}: Fz {:.2} N, contact {:.2} mm, shape {:.1} % · {}",
            c.describe(),
            c.spec_origin,
            c.fz_rmse_n,
            c.contact_rmse_mm,
            100.0 * c.shape_accuracy,
            c.dir.display()
        ),
        None => "certificate: none (fringe commission --unit ID commissions it)".to_string(),
    }));
    if let Some(p) = &u.passing {
        lines.push(Line::from(format!("last passing: {}", p.describe())));
    }
    lines.push(Line::from(match &u.last_check {
        Some(c) => {
            let mut s = format!(
                "last check: {} on {} ({} in all)",
                c.verdict.name(),
                when(&c.checked_utc),
                u.checks
            );
            if !c.diagnosis.is_empty() {
                s.push_str(&format!(": {}", c.diagnosis));
            }
            s
        }
        None => "last check: none".to_string(),
    }));
    lines.push(Line::from(format!(
        "next check: {}",
        u.next_check.describe()
    )));
    lines.push(Line::from(format!("validate uses: {}", u.validate.describe())));
    lines
}
