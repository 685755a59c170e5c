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
use crate::ui::widgets::disc::{aspect, canvas_about, Disc, Glyph, Layer};
use crate::ui::widgets::time_chart::{self, Series};
use crate::ui::widgets::{panel, ACCENT, BAD, GOOD, MEASURED, PENDING, WARN};
use fringe_rig::store::human_bytes as human;
use ratatui::crossterm::event::{KeyCode, KeyModifiers};
use ratatui::layout::{Constraint, Layout, Rect};
use ratatui::style::{Color, Style};
use ratatui::text::{Line, Span};
use ratatui::widgets::{Gauge, Paragraph, Wrap};
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
    WholeDisc,
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
    Binding {
        keys: &[char('d')],
        scope: Scope::Shown,
        action: Action::WholeDisc,
        // Said where it applies: the plan panel's title, when the plan is small on its disc.
        label: "",
        help: "",
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
            Action::WholeDisc => app.state.scan_whole_disc = !app.state.scan_whole_disc,
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
    draw_plan(f, disc_area, v, s.scan_whole_disc);
    draw_log(f, log_area, v);
    // The phase line (a scan's end with its summary) wraps: the panel grows to hold it.
    let (phase, _) = phase_text(&v.phase);
    let inner = usize::from(right.width.saturating_sub(2)).max(1);
    let phase_rows = phase.chars().count().div_ceil(inner).max(1) as u16;
    let [status_area, gauge_area, bottom] = Layout::vertical([
        Constraint::Length(6 + phase_rows),
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
fn draw_plan(f: &mut Frame, area: Rect, v: &ScanView, whole_disc: bool) {
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
    let (centre, radius, disc, zoom) = plan_view(v, &all, whole_disc);
    let title = match (v.disc_radius_mm, zoom) {
        (Some(_), Some(z)) => format!(
            "{}: {} points · ×{z:.0} · d: whole disc",
            v.plan,
            v.points.len()
        ),
        (Some(_), None) if close_up_helps(v, &all) => {
            format!("{}: {} points · d: close up", v.plan, v.points.len())
        }
        _ => format!("{}: {} points", v.plan, v.points.len()),
    };
    f.render_widget(
        canvas_about(
            panel(&title),
            centre,
            radius,
            disc,
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

/// A plan this much smaller than the disc (its reach from its own centre over the disc's
/// radius) is drawn close up, its points apart; the whole disc is a key away.
const CLOSE_UP_BELOW: f64 = 0.4;

/// Whether the plan `all` is small enough on `v`'s disc to be drawn close up.
fn close_up_helps(v: &ScanView, all: &[(f64, f64)]) -> bool {
    let (_, reach) = plan_reach(all);
    v.disc_radius_mm
        .is_some_and(|d| !all.is_empty() && reach < CLOSE_UP_BELOW * d)
}

/// The plan's centre (of its bounding box) and its reach from there, mm (at least 1 mm).
fn plan_reach(all: &[(f64, f64)]) -> ((f64, f64), f64) {
    let (mut lo, mut hi) = ((f64::MAX, f64::MAX), (f64::MIN, f64::MIN));
    for (x, y) in all {
        lo = (lo.0.min(*x), lo.1.min(*y));
        hi = (hi.0.max(*x), hi.1.max(*y));
    }
    if all.is_empty() {
        return ((0.0, 0.0), 1.0);
    }
    let c = ((lo.0 + hi.0) / 2.0, (lo.1 + hi.1) / 2.0);
    let reach = all
        .iter()
        .map(|(x, y)| ((x - c.0).powi(2) + (y - c.1).powi(2)).sqrt())
        .fold(1.0f64, f64::max);
    (c, reach)
}

/// What the plan panel shows: its centre and radius, mm, the disc's outline, and the zoom when
/// the plan is drawn close up (a plan small on its disc, unless the whole disc was asked for).
fn plan_view(
    v: &ScanView,
    all: &[(f64, f64)],
    whole_disc: bool,
) -> ((f64, f64), f64, Option<Disc>, Option<f64>) {
    let disc = v.disc_radius_mm.map(|radius| Disc {
        centre: v.origin_mm,
        radius,
    });
    match disc {
        Some(d) if !whole_disc && close_up_helps(v, all) => {
            let (c, reach) = plan_reach(all);
            let radius = reach * 1.6;
            (c, radius, disc, Some(d.radius / radius))
        }
        Some(d) => {
            let extent = all
                .iter()
                .map(|(x, y)| ((x - d.centre.0).powi(2) + (y - d.centre.1).powi(2)).sqrt())
                .fold(1.0f64, f64::max);
            (d.centre, d.radius.max(extent), disc, None)
        }
        None => {
            let extent = all
                .iter()
                .map(|(x, y)| ((x - v.origin_mm.0).powi(2) + (y - v.origin_mm.1).powi(2)).sqrt())
                .fold(1.0f64, f64::max);
            (v.origin_mm, extent * 1.2, None, None)
        }
    }
}

/// The scan's messages, newest first, each wrapped to the panel's width; warnings in yellow.
fn draw_log(f: &mut Frame, area: Rect, v: &ScanView) {
    let lines: Vec<Line> = v
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
            Line::styled(l.clone(), style)
        })
        .collect();
    f.render_widget(
        Paragraph::new(lines)
            .wrap(Wrap { trim: false })
            .block(panel("messages (newest first)")),
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
        Paragraph::new(status)
            .wrap(Wrap { trim: false })
            .block(panel(v.run_dir.as_deref().unwrap_or("scan"))),
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
