//! The Scan screen: the plan's points on the disc with the path, progress, force, the newest
//! frame, the force chart and the scan's messages. Its keys choose, run, pause, continue and
//! abort the scan on every screen (the scan goes on whichever screen is shown).

use super::{bench, validate};
use crate::clock_text::clock;
use crate::ui::app::App;
use crate::ui::binding::{self, char, Binding, HelpRow, Scope};
use crate::ui::picture::Picture;
use crate::ui::screen::{Screen, ScreenDef};
use crate::ui::state::{Phase, ScanView, Tab, UiState};
use crate::ui::widgets::disc::{aspect, canvas, Glyph, Layer};
use crate::ui::widgets::time_chart::{self, Series};
use crate::ui::widgets::{panel, ACCENT, BAD, GOOD, MEASURED, PENDING, WARN};
use fringe_rig::store::human_bytes as human;
use ratatui::crossterm::event::{KeyCode, KeyModifiers};
use ratatui::layout::{Constraint, Layout, Rect};
use ratatui::style::{Color, Style};
use ratatui::text::{Line, Span};
use ratatui::widgets::{Gauge, List, ListItem, Paragraph};
use ratatui::Frame;

/// This screen, by name: `UiState::tab` when it is shown; the command line and other code
/// choose it by this.
pub const TAB: Tab = Tab::named("scan");

pub const SCREEN: ScreenDef = ScreenDef {
    tab: TAB,
    title: "Scan",
    help,
    draw,
    hint: |s| s.scan.phase.key_hint(),
    open: |_| Box::new(ScanKeys),
};

#[derive(Debug, Clone, Copy)]
enum Action {
    ChoosePlan,
    Run,
    Pause,
    PauseNow,
    Continue,
    Abort,
}

const KEYS: &[Binding<Action>] = &[
    Binding {
        keys: &[char('l')],
        scope: Scope::Everywhere,
        action: Action::ChoosePlan,
        label: "l",
        help: "choose the scan plan (built in, ./plans/*.toml)",
    },
    Binding {
        keys: &[char('r')],
        scope: Scope::Everywhere,
        action: Action::Run,
        label: "r",
        help: "run the scan plan (with live validation on Validate)",
    },
    Binding {
        keys: &[char('p')],
        scope: Scope::Everywhere,
        action: Action::Pause,
        label: "p",
        help: "pause after the current press",
    },
    Binding {
        keys: &[char('P')],
        scope: Scope::Everywhere,
        action: Action::PauseNow,
        label: "P",
        help: "pause now (z retracts)",
    },
    Binding {
        keys: &[char('c')],
        scope: Scope::Everywhere,
        action: Action::Continue,
        label: "c",
        help: "continue a paused scan",
    },
    Binding {
        keys: &[char('a')],
        scope: Scope::Everywhere,
        action: Action::Abort,
        label: "a",
        help: "abort the scan (z retracts, the run is closed)",
    },
];

fn help() -> Vec<HelpRow> {
    binding::help_rows(KEYS, Some(SCREEN.title))
}

/// Runs the chosen plan (`r` on any screen, or at once when the UI starts): the Bench screen
/// gives way to this one, and on the Validate screen (or when the UI was opened on it) the plan
/// runs with live validation.
pub fn run(app: &mut App) {
    if !app.scan_active() && app.state.tab == bench::TAB {
        app.state.tab = TAB;
    }
    let validate = app.state.tab == validate::TAB || app.opts.tab == validate::TAB;
    app.run_scan(validate);
}

/// The scan's keys (the scan itself is the [`App`]'s: every screen shows it).
struct ScanKeys;

impl Screen for ScanKeys {
    fn key(&mut self, app: &mut App, code: KeyCode, mods: KeyModifiers, shown: bool) -> bool {
        let Some(action) = binding::find(KEYS, code, mods, shown) else {
            return false;
        };
        match action {
            Action::ChoosePlan => {
                if app.open_picker() {
                    app.state.tab = TAB;
                }
            }
            Action::Run => run(app),
            Action::Pause => app.pause(false),
            Action::PauseNow => app.pause(true),
            Action::Continue => app.resume(),
            Action::Abort => app.abort(),
        }
        true
    }
}

fn draw(f: &mut Frame, area: Rect, s: &UiState) {
    let v = &s.scan;
    let [left, right] =
        Layout::horizontal([Constraint::Percentage(40), Constraint::Percentage(60)]).areas(area);
    let [disc_area, log_area] =
        Layout::vertical([Constraint::Percentage(60), Constraint::Percentage(40)]).areas(left);
    draw_plan(f, disc_area, v);
    draw_log(f, log_area, v);
    let [status_area, gauge_area, bottom] = Layout::vertical([
        Constraint::Length(7),
        Constraint::Length(1),
        Constraint::Min(0),
    ])
    .areas(right);
    draw_status(f, status_area, v);
    draw_progress(f, gauge_area, v);
    let [chart_area, picture_area] =
        Layout::horizontal([Constraint::Percentage(60), Constraint::Percentage(40)]).areas(bottom);
    draw_force_chart(f, chart_area, s);
    draw_frame(f, picture_area, v);
}

/// The plan on the disc: all points and the path; done points green; the current one yellow.
fn draw_plan(f: &mut Frame, area: Rect, v: &ScanView) {
    let all: Vec<(f64, f64)> = v.points.iter().map(|p| (p.x_mm, p.y_mm)).collect();
    let done: Vec<(f64, f64)> = all.iter().copied().take(v.done as usize).collect();
    let current: Vec<(f64, f64)> = v
        .current
        .as_ref()
        .and_then(|(i, _)| all.get(*i as usize).copied())
        .into_iter()
        .collect();
    let current_index = v.current.as_ref().map_or(0, |(i, _)| *i as usize);
    // Up to this many points are numbered in scan order; more are dots.
    let glyph = |first: usize| {
        if all.len() <= 60 {
            Glyph::Numbers(first)
        } else {
            Glyph::Dots
        }
    };
    let extent = all
        .iter()
        .map(|(x, y)| ((x - v.origin_mm.0).powi(2) + (y - v.origin_mm.1).powi(2)).sqrt())
        .fold(1.0f64, f64::max);
    let radius = v.disc_radius_mm.unwrap_or(extent * 1.2).max(extent);
    let title = format!("{}: {} points", v.plan, v.points.len());
    f.render_widget(
        canvas(
            panel(&title),
            v.origin_mm,
            radius,
            v.disc_radius_mm.is_some(),
            vec![
                Layer {
                    coords: &all,
                    color: PENDING,
                    path: true,
                    glyph: glyph(0),
                },
                Layer {
                    coords: &done,
                    color: GOOD,
                    path: false,
                    glyph: glyph(0),
                },
                Layer {
                    coords: &current,
                    color: WARN,
                    path: false,
                    glyph: glyph(current_index),
                },
            ],
            aspect(area),
        ),
        area,
    );
}

/// The scan's messages, newest first; warnings in yellow.
fn draw_log(f: &mut Frame, area: Rect, v: &ScanView) {
    let lines: Vec<ListItem> = v
        .log
        .iter()
        .rev()
        .take(area.height.saturating_sub(2) as usize)
        .map(|l| {
            let style = if l.starts_with("warning") {
                Style::new().fg(WARN)
            } else {
                Style::new()
            };
            ListItem::new(Line::styled(l.clone(), style))
        })
        .collect();
    f.render_widget(
        List::new(lines).block(panel("messages (newest first)")),
        area,
    );
}

/// The status panel: the phase, the plan's size and estimate, the point, force and camera.
fn draw_status(f: &mut Frame, area: Rect, v: &ScanView) {
    let (phase, colour) = phase_text(&v.phase);
    let point = match &v.current {
        Some((i, what)) => format!("point {} of {}: {what}", i + 1, v.total),
        None => format!("{} of {} points", v.done, v.total),
    };
    let status = vec![
        Line::from(Span::styled(phase, Style::new().fg(colour))),
        Line::from(format!(
            "{} points to {}, about {}{}",
            v.points.len(),
            v.targets,
            clock(v.estimate),
            v.expected_bytes
                .map(|b| format!(", {} on disk", human(b)))
                .unwrap_or_default()
        )),
        Line::from(point),
        Line::from(format!("force {:>6.2} N   ETA {}", v.force_n, clock(v.eta))),
        Line::from(format!(
            "camera {:>4.1} fps   {} frames   {} dropped",
            v.frame_rate_hz, v.frames, v.dropped
        )),
    ];
    f.render_widget(
        Paragraph::new(status).block(panel(v.run_dir.as_deref().unwrap_or("scan"))),
        area,
    );
}

/// What the scan is doing, and its colour.
fn phase_text(phase: &Phase) -> (String, Color) {
    match phase {
        Phase::Ready => ("ready: press r to run".to_string(), ACCENT),
        Phase::Running => ("running".to_string(), GOOD),
        Phase::Paused(why) => (format!("paused: {why}"), WARN),
        Phase::Stopping(what) => (what.clone(), WARN),
        Phase::Finished {
            completed: true,
            summary,
        } => (format!("completed: {summary}"), GOOD),
        Phase::Finished { summary, .. } => (format!("stopped: {summary}"), WARN),
        Phase::Failed(why) => (format!("failed: {why}"), BAD),
    }
}

/// The share of the points done, as a gauge.
fn draw_progress(f: &mut Frame, area: Rect, v: &ScanView) {
    let ratio = if v.total == 0 {
        0.0
    } else {
        (v.done as f64 / v.total as f64).clamp(0.0, 1.0)
    };
    f.render_widget(
        Gauge::default()
            .gauge_style(Style::new().fg(GOOD))
            .ratio(ratio)
            .label(format!("{:.0} %", 100.0 * ratio)),
        area,
    );
}

/// The newest frame, or a line saying there is none yet.
fn draw_frame(f: &mut Frame, area: Rect, v: &ScanView) {
    let block = panel("frame");
    let inner = block.inner(area);
    f.render_widget(block, area);
    match &v.live.picture {
        Some(p) => f.render_widget(Picture(p), inner),
        None => f.render_widget(Paragraph::new("no frame yet"), inner),
    }
}

fn draw_force_chart(f: &mut Frame, area: Rect, s: &UiState) {
    let labels = &s.scan.live.labels;
    let fz: Vec<(f64, f64)> = labels.iter().map(|p| (p.t_s, p.fz_n.abs())).collect();
    let ft: Vec<(f64, f64)> = labels.iter().map(|p| (p.t_s, p.f_n)).collect();
    time_chart::draw(
        f,
        area,
        "force labels, N",
        &[
            Series {
                name: "|Fz|",
                color: MEASURED,
                points: &fz,
            },
            Series {
                name: "|F|",
                color: WARN,
                points: &ft,
            },
        ],
    );
}
