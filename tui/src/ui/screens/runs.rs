//! The Runs screen: the runs in the runs directory, newest first, with their status and frames,
//! the verdict of a verification, the model's figures of an evaluation and where an export went,
//! when the user asked for them.

use crate::ui::app::App;
use crate::ui::binding::{self, char, code, Binding, HelpRow, Scope};
use crate::ui::screen::{Screen, ScreenDef};
use crate::ui::session::ModelChoice;
use crate::ui::state::{RunRow, RunsView, Tab};
use crate::ui::widgets::{panel, BAD, GOOD, WARN};
use crate::ui::workers::{self, Verdict};
use crossbeam_channel::{unbounded, Receiver, Sender};
use fringe_rig::store::human_bytes as human;
use ratatui::crossterm::event::{KeyCode, KeyModifiers};
use ratatui::layout::{Constraint, Rect};
use ratatui::style::{Modifier, Style};
use ratatui::widgets::{Cell, Paragraph, Row, Table, TableState};
use ratatui::Frame;

/// This screen, by name: `UiState::tab` when it is shown; the command line and other code
/// choose it by this.
pub const TAB: Tab = Tab::named("runs");

pub const SCREEN: ScreenDef = ScreenDef {
    tab: TAB,
    title: "Runs",
    help,
    draw: |f, area, s| draw(f, area, &s.runs),
    hint: |s| s.scan.phase.key_hint(),
    open: |_| Box::<Runs>::default(),
};

#[derive(Debug, Clone, Copy)]
enum Action {
    Up,
    Down,
    Verify,
    Evaluate,
    Export,
    Refresh,
}

const KEYS: &[Binding<Action>] = &[
    Binding {
        keys: &[code(KeyCode::Up)],
        scope: Scope::Shown,
        action: Action::Up,
        label: "Up / Down",
        help: "choose a run",
    },
    Binding {
        keys: &[code(KeyCode::Down)],
        scope: Scope::Shown,
        action: Action::Down,
        label: "",
        help: "",
    },
    Binding {
        keys: &[code(KeyCode::Enter)],
        scope: Scope::Shown,
        action: Action::Verify,
        label: "Enter",
        help: "verify the chosen run",
    },
    Binding {
        keys: &[char('e')],
        scope: Scope::Shown,
        action: Action::Evaluate,
        label: "e",
        help: "evaluate the chosen run with the model",
    },
    Binding {
        keys: &[char('x')],
        scope: Scope::Shown,
        action: Action::Export,
        label: "x",
        help: "export the chosen run to exports/ (reference layout)",
    },
    Binding {
        keys: &[char('g')],
        scope: Scope::Everywhere,
        action: Action::Refresh,
        label: "g",
        help: "refresh the runs",
    },
];

fn help() -> Vec<HelpRow> {
    binding::help_rows(KEYS, Some(SCREEN.title))
}

/// Where a thread's lines go in a run's row.
type Column = fn(&mut RunRow) -> &mut Option<String>;

/// The verifications, evaluations and exports under way: progress and outcomes, by run.
struct Runs {
    verify: (Sender<Verdict>, Receiver<Verdict>),
    /// Evaluations of a run with the session's model: progress, then the figures.
    evaluate: (Sender<Verdict>, Receiver<Verdict>),
    /// Exports of a run in the reference layout: progress, then where it went.
    export: (Sender<Verdict>, Receiver<Verdict>),
}

impl Default for Runs {
    fn default() -> Runs {
        Runs {
            verify: unbounded(),
            evaluate: unbounded(),
            export: unbounded(),
        }
    }
}

impl Runs {
    /// Verifies, evaluates or exports the chosen run on a thread.
    fn start(&self, app: &mut App, action: Action) {
        let Some(row) = app.state.runs.rows.get_mut(app.state.runs.selected) else {
            return;
        };
        let name = row.name.clone();
        let dir = app.opts.runs.join(&name);
        match action {
            Action::Verify => {
                row.verified = Some("verifying...".into());
                workers::verify(name, dir, self.verify.0.clone());
            }
            Action::Evaluate => {
                // The session's model (the unit's commissioned one, else the one that ships,
                // when none was named).
                row.evaluated = Some("evaluating...".into());
                let choice = app
                    .opts
                    .model
                    .clone()
                    .unwrap_or_else(|| ModelChoice::for_rig(&app.opts.config));
                workers::evaluate(name, dir, choice, self.evaluate.0.clone());
            }
            Action::Export => {
                let out = workers::export_dir(&app.opts.runs, &name);
                row.exported = Some(format!("exporting to {}...", out.display()));
                workers::export(name, dir, out, self.export.0.clone());
            }
            Action::Up | Action::Down | Action::Refresh => {}
        }
    }
}

impl Screen for Runs {
    fn key(&mut self, app: &mut App, code: KeyCode, mods: KeyModifiers, shown: bool) -> bool {
        let Some(action) = binding::find(KEYS, code, mods, shown) else {
            return false;
        };
        let runs = &mut app.state.runs;
        let n = runs.rows.len();
        match action {
            Action::Up => runs.selected = runs.selected.saturating_sub(1),
            Action::Down => runs.selected = (runs.selected + 1).min(n.saturating_sub(1)),
            Action::Refresh => app.refresh_runs(),
            Action::Verify | Action::Evaluate | Action::Export => self.start(app, action),
        }
        true
    }

    fn tick(&mut self, app: &mut App, _shown: bool) -> bool {
        let rows = &mut app.state.runs.rows;
        let mut changed = false;
        let columns: [(&Receiver<Verdict>, Column); 3] = [
            (&self.verify.1, |r| &mut r.verified),
            (&self.evaluate.1, |r| &mut r.evaluated),
            (&self.export.1, |r| &mut r.exported),
        ];
        for (rx, column) in columns {
            while let Ok((name, text)) = rx.try_recv() {
                if let Some(r) = rows.iter_mut().find(|r| r.name == name) {
                    *column(r) = Some(text);
                }
                changed = true;
            }
        }
        changed
    }
}

fn draw(f: &mut Frame, area: Rect, v: &RunsView) {
    let title = format!(
        "runs in {} · Enter verify · e evaluate with {} · x export · g refresh",
        v.root, v.model
    );
    if v.rows.is_empty() {
        f.render_widget(
            Paragraph::new("no runs yet: run a scan (Scan screen, r)").block(panel(&title)),
            area,
        );
        return;
    }
    let rows = v.rows.iter().map(run_row);
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
            Constraint::Length(8),
            // Verification and export give way first: the run id stays whole.
            Constraint::Fill(1),
            Constraint::Length(44),
            Constraint::Fill(1),
        ],
    )
    .header(
        Row::new([
            "run",
            "status",
            "frames",
            "size",
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

/// One run: its id, status, frames, size on disk, and what verification, evaluation and export said.
fn run_row(r: &RunRow) -> Row<'static> {
    let status = match r.status.as_str() {
        "completed" => Style::new().fg(GOOD),
        "unfinished" => Style::new().fg(WARN),
        _ => Style::new().fg(BAD),
    };
    let verified = match r.verified.as_deref() {
        Some(v) if v.starts_with("ok") => Cell::from(v.to_string()).style(Style::new().fg(GOOD)),
        Some(v) if v.starts_with("verifying") => Cell::from(v.to_string()),
        Some(v) => Cell::from(v.to_string()).style(Style::new().fg(BAD)),
        None => Cell::from("-"),
    };
    let evaluated = match r.evaluated.as_deref() {
        Some(e) if e.starts_with("cannot") => Cell::from(e.to_string()).style(Style::new().fg(BAD)),
        Some(e) => Cell::from(e.to_string()),
        None => Cell::from("-"),
    };
    let exported = match r.exported.as_deref() {
        Some(e) if e.starts_with("cannot") => Cell::from(e.to_string()).style(Style::new().fg(BAD)),
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
        Cell::from(r.bytes.map_or_else(|| "?".to_string(), human)),
        verified,
        evaluated,
        exported,
    ])
}
